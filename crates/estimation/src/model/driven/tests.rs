//! Tests of the driven model's derivatives and measured quantities.

use super::kinematics::{
    Angles, Motion, NUDGE_LIMIT, PseudoRates, derivative, dual_derivative, flight_path_rates,
    motion_rates, offset_evaluation, offset_response, rotated,
};
use super::linearise::evaluate;
use super::measured::{Ambient, Surroundings};
use super::{AIRSPEED, ALTITUDE, FLIGHT_PATH_SIZE, FlightPathState};
use crate::structure::Observable;
use crate::structure::{ModelStructure, stall_test_structure};
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::dual::{Dual, LANES, Real};
use aeroid_sim::aero::Coefficient;
use aeroid_sim::dynamics::FlightModel;
use aeroid_sim::state::{Control, Controls};

/// The derivative tests' models: a wind-axis stall model with χ a
/// state, τ2 = 0.2 (χ̇ moves with α̇), an Oswald and a CL² drag term; the
/// body-axis CDRW model; the lateral model with measured airspeed and
/// sideslip rates.
fn test_models() -> [(ModelStructure, PseudoRates); 3] {
    [
        (stall_test_structure(0.2), PseudoRates::default()),
        (
            ModelStructure::load("cdrw-longitudinal").unwrap(),
            PseudoRates::default(),
        ),
        (
            ModelStructure::load("attas-lateral").unwrap(),
            PseudoRates {
                airspeed: Some(0.3),
                beta: Some(0.02),
            },
        ),
    ]
}

/// The record's measured quantities replace the model's own
/// ([`Ambient`]): given the ISA's density at the altitude and the
/// propulsion model's thrust as measured, the rates and outputs are the
/// model's own to rounding (1e-12); a measured density 1 % lower makes
/// q̄ 1 % lower (1e-12); a measured thrust 1 kN higher moves nx by
/// exactly the thrust line's x component of 1 kN/(m·g0), and the
/// throttle then moves nothing.
#[test]
fn measured_density_and_thrust_replace_the_models() {
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let model = FlightModel::new(structure.aircraft.clone(), Default::default());
    let (x, controls) = test_point();
    let outputs = ["nx", "dynamic_pressure"].map(|name| Observable::parse(name).unwrap());
    let air = model.environment.atmosphere.at(x[ALTITUDE]);
    let propulsion = &model.aircraft.propulsion;
    let thrust = propulsion.thrust(controls[Control::Throttle.index()], air.log_density_ratio);
    assert!(thrust > 1e3);
    let pseudo = PseudoRates::default();
    let at = |ambient: Ambient, controls: &Controls| {
        evaluate(&model, &x, controls, pseudo, ambient, &outputs)
    };
    let (rates, own) = at(Ambient::default(), &controls);
    let measured = Ambient {
        density: Some(air.density),
        thrust: Some(thrust),
        mach: None,
        alpha_dot: None,
    };
    let (same_rates, same) = at(measured, &controls);
    assert!((same_rates - rates).amax() <= 1e-12 * rates.amax());
    for (a, b) in same.iter().zip(&own) {
        assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
    }
    let thinner = Ambient {
        density: Some(0.99 * air.density),
        ..measured
    };
    let (_, thin) = at(thinner, &controls);
    assert!((thin[1] / own[1] - 0.99).abs() <= 1e-12);
    let stronger = Ambient {
        thrust: Some(thrust + 1e3),
        ..measured
    };
    let (_, strong) = at(stronger, &controls);
    let expected = propulsion.direction.x * 1e3 / (model.aircraft.mass.mass * STANDARD_GRAVITY);
    assert!(
        (strong[0] - own[0] - expected).abs() <= 1e-12,
        "{strong:?} vs {own:?}"
    );
    let mut throttled = controls;
    throttled[Control::Throttle.index()] = 0.9;
    assert_eq!(at(stronger, &throttled), at(stronger, &controls));
}

/// The ATTAS longitudinal model with a term in Mach itself, CL_dMach =
/// 0.5 about `reference_mach` (as the structure file writes it).
fn with_mach_term(reference: &str) -> crate::error::Result<ModelStructure> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../models/attas-longitudinal.toml"
    );
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("[aero.CL]\n0 = 0.2\n", "[aero.CL]\n0 = 0.2\ndMach = 0.5\n")
        .replace(
            "oswald_efficiency = 0.8\n",
            &format!("oswald_efficiency = 0.8\nreference_mach = {reference}\n"),
        );
    assert!(text.contains("dMach") && text.contains("reference_mach"));
    let file = std::env::temp_dir().join(format!(
        "aeroid-mach-{reference}-{}.toml",
        std::process::id()
    ));
    std::fs::write(&file, text).unwrap();
    let structure = ModelStructure::load(file.to_str().unwrap());
    std::fs::remove_file(&file).unwrap();
    structure
}

/// A recorded Mach replaces V/a ([`Ambient`]), and `reference_mach = 0`
/// states a term in Mach itself: with the ISA's V/a given as measured the
/// outputs are the model's own (1e-12); a measured Mach 2 % higher is the
/// model's Mach exactly and moves CL by CL_dMach × the difference
/// (1e-12). A negative reference is refused, naming the field.
#[test]
fn measured_mach_replaces_v_over_a_about_a_zero_reference() {
    let structure = with_mach_term("0").unwrap();
    assert_eq!(structure.aircraft.aero.reference_mach, 0.0);
    let model = FlightModel::new(structure.aircraft.clone(), Default::default());
    let (x, controls) = test_point();
    let outputs = ["mach", "CL"].map(|name| Observable::parse(name).unwrap());
    let at = |ambient: Ambient| {
        evaluate(
            &model,
            &x,
            &controls,
            PseudoRates::default(),
            ambient,
            &outputs,
        )
        .1
    };
    let own = at(Ambient::default());
    let air = model.environment.atmosphere.at(x[ALTITUDE]);
    let v_over_a = own[0];
    assert!((v_over_a - x[AIRSPEED] / air.speed_of_sound).abs() < 1e-12);
    let same = at(Ambient {
        mach: Some(v_over_a),
        ..Ambient::default()
    });
    for (a, b) in same.iter().zip(&own) {
        assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
    }
    let recorded = 1.02 * v_over_a;
    let measured = at(Ambient {
        mach: Some(recorded),
        ..Ambient::default()
    });
    assert_eq!(measured[0], recorded);
    let moved = measured[1] - own[1];
    assert!(
        (moved - 0.5 * (recorded - v_over_a)).abs() <= 1e-12,
        "CL moved by {moved}"
    );
    let error = with_mach_term("-0.1").unwrap_err().to_string();
    assert!(
        error.contains("reference_mach: must be a Mach number, zero or more"),
        "{error}"
    );
}

/// [`rotated`] against the library's sine and cosine, over base angles
/// through all four quadrants and moves up to ±[`NUDGE_LIMIT`]: within
/// 4·10⁻¹⁶ (two ulp of 1; measured 2.2·10⁻¹⁶), so the simulation's
/// angles are the library's to rounding wherever it takes them this way.
#[test]
fn rotated_angles_match_the_library() {
    let mut worst: f64 = 0.0;
    for base in (-40..=40).map(|k| k as f64 * 0.0873) {
        for h in (-64..=64).map(|k| k as f64 * NUDGE_LIMIT / 64.0) {
            let (sin, cos) = rotated(base.sin_cos(), h);
            let (expected_sin, expected_cos) = (base + h).sin_cos();
            worst = worst.max((sin - expected_sin).abs().max((cos - expected_cos).abs()));
        }
    }
    assert!(worst <= 4e-16, "largest difference {worst:e}");
}

/// A state and controls away from trim, every rate and angle non-zero.
fn test_point() -> (FlightPathState, Controls) {
    (
        FlightPathState::from_column_slice(&[
            60.0, 0.21, 0.03, 0.05, -0.04, 0.02, 0.1, 0.15, 0.3, 1000.0, 0.6,
        ]),
        Controls::from_column_slice(&[-0.05, 0.02, -0.01, 0.0, 0.5]),
    )
}

/// ∂f/∂x and ∂g/∂x by dual numbers, along all eleven flight-path
/// states (three passes of four lanes; altitude included: its air is
/// held, as the dual evaluation holds it), against central differences
/// of the f64 evaluation (step 1e-6·max(|x|, 1), error ~1e-9 relative),
/// on the wind-axis stall model with χ a state (Kirchhoff factor, χ̇),
/// the body-axis CDRW model and the lateral model with measured airspeed
/// and sideslip rates; the values are the f64 evaluation's, bit for bit.
#[test]
fn dual_derivatives_match_central_differences() {
    let cases = test_models();
    let outputs = [
        "nx", "ny", "nz", "p_dot", "q_dot", "r_dot", "mach", "CX", "CY", "CZ", "CL", "CD", "Cl",
        "Cm", "Cn",
    ]
    .map(|name| Observable::parse(name).unwrap());
    let (x, controls) = test_point();
    for (structure, pseudo) in cases {
        let model = FlightModel::new(structure.aircraft.clone(), Default::default());
        let air = Surroundings::from(model.environment.atmosphere.at(x[ALTITUDE]));
        let evaluate =
            |x: &FlightPathState| derivative(&model, x, &Angles::of(x), &air, &controls, pseudo);
        let (rates, at) = evaluate(&x);
        for lanes in (0..FLIGHT_PATH_SIZE).collect::<Vec<_>>().chunks(LANES) {
            let (dual_x, dual_rates, dual_at) = dual_derivative(
                &model,
                &x,
                Angles::of(&x),
                lanes.iter().copied(),
                &air,
                &controls,
                pseudo,
            );
            assert_eq!(dual_rates.map(Dual::value), rates);
            assert_eq!(dual_at.values(), at);
            for (lane, &i) in lanes.iter().enumerate() {
                let step = 1e-6 * x[i].abs().max(1.0);
                let moved = |sign: f64| {
                    let mut moved = x;
                    moved[i] += sign * step;
                    evaluate(&moved)
                };
                let ((plus, plus_at), (minus, minus_at)) = (moved(1.0), moved(-1.0));
                let numeric = (plus - minus) / (2.0 * step);
                let dual = dual_rates.map(|r| r.tangent[lane]);
                let scale = numeric.amax().max(1.0);
                assert!(
                    (dual - numeric).amax() <= 1e-7 * scale,
                    "{}: ∂f/∂x{i}: {dual} vs {numeric}",
                    structure.name
                );
                for output in outputs {
                    let dual = output.value(&dual_x, &dual_at).tangent[lane];
                    let numeric =
                        (output.value(&x, &plus_at) - output.value(&x, &minus_at)) / (2.0 * step);
                    assert!(
                        (dual - numeric).abs() <= 1e-7 * numeric.abs().max(1.0),
                        "{}: ∂{output:?}/∂x{i}: {dual} vs {numeric}",
                        structure.name
                    );
                }
            }
        }
    }
}

/// The exact coefficient responses ([`offset_evaluation`]) against
/// central differences of models with the coefficient's offset moved by
/// ±10⁻⁵ (exact for the quadratic CL² drag; rounding ~10⁻¹⁰), for every
/// coefficient, flight-path rate and output: wind axes with an Oswald
/// term, a CL² drag term and a stall model whose χ̇ moves with α̇ (τ2);
/// body axes (CDRW); and the lateral model with measured airspeed and
/// sideslip rates.
#[test]
fn coefficient_responses_match_perturbed_models() {
    let cases = test_models();
    let outputs = [
        "airspeed", "alpha", "beta", "p", "q", "r", "chi", "nx", "ny", "nz", "p_dot", "q_dot",
        "r_dot", "CX", "CY", "CZ", "CL", "CD", "Cl", "Cm", "Cn",
    ]
    .map(|name| Observable::parse(name).unwrap());
    for (structure, pseudo) in cases {
        let model = FlightModel::new(structure.aircraft.clone(), Default::default());
        assert!(!model.aircraft.aero.forces_depend_on_alpha_dot());
        let (x, controls) = test_point();
        let (angles, air) = (
            Angles::of(&x),
            Surroundings::from(model.environment.atmosphere.at(x[ALTITUDE])),
        );
        let (rates, at) = derivative(&model, &x, &angles, &air, &controls, pseudo);
        for coefficient in Coefficient::ALL {
            let offset = offset_response(&model, &at, coefficient);
            let moved = offset_evaluation(&at, &offset);
            let exact = flight_path_rates(&x, &angles, &Motion::of(&moved), pseudo) - rates;
            // The rates' response as the linearisation takes it: the
            // part of the rates linear in the accelerations.
            let direct = motion_rates(
                &x,
                &angles,
                &Motion::of(&at).response(&offset.1, offset.2),
                pseudo.linear(),
            );
            assert!(
                (exact - direct).amax() <= 1e-12 * exact.amax().max(1.0),
                "{}: {coefficient:?}: rates {exact} vs {direct}",
                structure.name
            );
            let step = 1e-5;
            let shifted = |sign: f64| {
                let mut perturbed = model.clone();
                perturbed.aircraft.aero.offsets[coefficient as usize] += sign * step;
                derivative(&perturbed, &x, &angles, &air, &controls, pseudo)
            };
            let ((plus, plus_eval), (minus, minus_eval)) = (shifted(1.0), shifted(-1.0));
            let numeric = (plus - minus) / (2.0 * step);
            let scale = numeric.amax().max(1.0);
            assert!(
                (exact - numeric).amax() <= 1e-6 * scale,
                "{}: {coefficient:?}: rates {exact} vs {numeric}",
                structure.name
            );
            for output in outputs {
                let exact = output.value(&x, &moved) - output.value(&x, &at);
                let numeric =
                    (output.value(&x, &plus_eval) - output.value(&x, &minus_eval)) / (2.0 * step);
                assert!(
                    (exact - numeric).abs() <= 1e-6 * numeric.abs().max(1.0),
                    "{}: {coefficient:?}: {output:?} {exact} vs {numeric}",
                    structure.name
                );
            }
        }
    }
}
