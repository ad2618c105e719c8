//! Tests of the aerodynamic model: terms and products, the moment transfer,
//! the stall variants, and the problems of a file table.

use super::*;
use crate::state::Control;
use aeroid_core::error::FieldErrors;

fn geometry() -> ReferenceGeometry {
    ReferenceGeometry {
        span: 21.5,
        chord: 3.159,
        aspect_ratio: 21.5 * 21.5 / 64.0,
    }
}

fn parse(text: &str) -> (AeroModel, FieldErrors) {
    let spec: AeroSpec = toml::from_str(text).unwrap();
    let mut problems = FieldErrors::default();
    let model = AeroModel::from_spec(&spec, geometry(), "aero", &mut problems);
    (model, problems)
}

#[test]
fn linear_terms_are_named_and_summed() {
    let (model, problems) = parse(
        "[CL]\n0 = 0.2\nalpha = 5.0\nq = 10.0\n[Cm]\nde = -1.0\n[CD]\n0 = 0.03\nCL2 = 0.05\n",
    );
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(model.parameters.get("CL_alpha"), Some(5.0));
    let mut input = AeroInput {
        alpha: 0.1,
        airspeed: 100.0,
        ..Default::default()
    };
    input.rates.y = 0.2;
    input.controls[Control::Elevator.index()] = 0.05;
    let c = model.coefficients(&input);
    let q_hat = 0.2 * 3.159 / 200.0;
    let lift = 0.2 + 0.5 + 10.0 * q_hat;
    assert!((c.lift - lift).abs() < 1e-15);
    assert!((c.drag - (0.03 + 0.05 * lift * lift)).abs() < 1e-15);
    assert!((c.moment.y + 0.05).abs() < 1e-15);
    let cz = -c.drag * 0.1f64.sin() - lift * 0.1f64.cos();
    assert!((c.force.z - cz).abs() < 1e-15);
}

#[test]
fn products_are_canonical_and_multiply_their_factors() {
    let term = Monomial::parse("alpha^2*de").unwrap();
    assert_eq!(term.key(), "alpha^2*de");
    assert_eq!(
        term.factors(),
        [Regressor::Alpha, Regressor::Alpha, Regressor::Elevator]
    );
    let mut regressors = [0.0; REGRESSOR_COUNT];
    regressors[Regressor::Alpha as usize] = 0.1;
    regressors[Regressor::Elevator as usize] = -0.05;
    assert!((term.value(&regressors) - 0.1 * 0.1 * -0.05).abs() < 1e-18);
    assert_eq!(Monomial::parse("alpha").unwrap(), Regressor::Alpha.into());
    for bad in [
        "de*alpha",
        "alpha*alpha",
        "alpha^1",
        "alpha^2.5",
        "alpha^",
        "*alpha",
    ] {
        assert!(Monomial::parse(bad).is_err(), "{bad}");
    }
    let (model, problems) =
        parse("[CL]\nalpha = 5.0\n\"alpha^2\" = -2.0\n[Cm]\n\"alpha*de\" = -1.0\n");
    assert!(problems.is_empty(), "{problems:?}");
    let mut input = AeroInput {
        alpha: 0.1,
        airspeed: 100.0,
        ..Default::default()
    };
    input.controls[Control::Elevator.index()] = 0.05;
    let c = model.coefficients(&input);
    assert!((c.lift - (0.5 - 0.02)).abs() < 1e-15);
    assert!((c.moment.y + 0.005).abs() < 1e-15);
    let regressors = model.term_regressors(&input);
    let (coefficient, term) = model.term_of(1).unwrap();
    let slot = model.term_slot(coefficient, term);
    assert_eq!(regressors.values[slot], 0.1 * 0.1);
}

/// M_cg = M_ref + r × F: a reference point ahead of the CG (x > 0)
/// with lift (CZ < 0) pitches the nose up about the CG.
#[test]
fn moments_are_transferred_to_the_cg() {
    let (model, problems) =
        parse("[moment_reference]\noffset = [0.5, 0.0, 0.2]\n[CL]\n0 = 1.0\n[CD]\n0 = 0.1\n");
    assert!(problems.is_empty(), "{problems:?}");
    let input = AeroInput {
        airspeed: 100.0,
        ..Default::default()
    };
    let c = model.coefficients(&input);
    // α = 0: CX = −CD = −0.1, CZ = −CL = −1: (z·CX − x·CZ)/c̄.
    let (cx, cz) = (-0.1, -1.0);
    let expected = (0.2 * cx - 0.5 * cz) / 3.159;
    assert!((c.moment.y - expected).abs() < 1e-15 && expected > 0.0);
    assert_eq!(c.moment.x, 0.0);
    assert_eq!(c.moment.z, 0.0);
}

fn stall(options: &str) -> AeroModel {
    let (model, problems) = parse(&format!(
        "model = \"stall\"\noswald_efficiency = 0.8\n[stall]\na1 = 20.0\nalpha_star = 0.3\ntau1 = 0.2\ntau2 = 0.5\n{options}\n[CL]\n0 = 0.1\nalpha = 4.0\n"
    ));
    assert!(problems.is_empty(), "{problems:?}");
    model
}

/// τ in units of c̄/V is τ·c̄/V seconds; τ2 acting only while α̇ < 0
/// leaves χ∞ at its α̇ = 0 value while α rises; the attached-flow
/// induced drag squares CL with χ = 1.
#[test]
fn stall_variants_change_what_they_say() {
    let seconds = stall("");
    let chord = stall("time_unit = \"chord/V\"");
    let (alpha, alpha_dot, airspeed) = (0.32, -0.05, 80.0);
    let scale = 3.159 / airspeed;
    let mut equivalent = seconds.clone();
    equivalent.parameters.set("tau1", 0.2 * scale).unwrap();
    equivalent.parameters.set("tau2", 0.5 * scale).unwrap();
    let target = chord.separation_target(alpha, alpha_dot, airspeed);
    assert!((target - equivalent.separation_target(alpha, alpha_dot, 1.0)).abs() < 1e-15);
    let rate = chord.separation_rate(alpha, alpha_dot, 0.5, airspeed);
    assert!((rate - equivalent.separation_rate(alpha, alpha_dot, 0.5, 1.0)).abs() < 1e-12);
    assert_ne!(
        target,
        seconds.separation_target(alpha, alpha_dot, airspeed)
    );
    let one_sided = stall("tau2_only_while_decreasing = true");
    let steady = one_sided.steady_separation(alpha);
    assert_eq!(one_sided.separation_target(alpha, 0.05, 1.0), steady);
    assert_ne!(seconds.separation_target(alpha, 0.05, 1.0), steady);
    assert_eq!(
        one_sided.separation_target(alpha, -0.05, 1.0),
        seconds.separation_target(alpha, -0.05, 1.0)
    );
    assert_eq!(one_sided.separation_rate_slope(alpha, 0.05, 1.0), 0.0);
    let attached = stall("induced_drag_lift = \"attached\"");
    let input = AeroInput {
        alpha,
        airspeed,
        chi: 0.3,
        ..Default::default()
    };
    let induced = |lift: f64| lift * lift / (0.8 * std::f64::consts::PI * geometry().aspect_ratio);
    let lift_attached = 0.1 + 4.0 * alpha;
    let c = attached.coefficients(&input);
    assert!(c.lift < lift_attached - 0.1);
    assert!((c.drag - induced(lift_attached)).abs() < 1e-15);
    let c = seconds.coefficients(&input);
    assert!((c.drag - induced(c.lift)).abs() < 1e-15);
    assert!(!attached.offset_response_is_exact() && seconds.offset_response_is_exact());
}

/// The smooth switch of the one-sided τ2 is α̇ well below −2b and 0
/// well above 2b, and ∂χ̇/∂α̇ is its derivative (to a central
/// difference's error); the measured α̇ replaces the state's in χ only
/// with `alpha_dot = "measured"`, and only where one is given.
#[test]
fn smooth_switch_and_measured_alpha_dot() {
    let (alpha, airspeed) = (0.32, 80.0);
    let smooth = stall("tau2_only_while_decreasing = true\ntau2_switch_band = 0.01");
    let sharp = stall("tau2_only_while_decreasing = true");
    for alpha_dot in [-0.1, 0.1] {
        let (a, b) = (
            smooth.separation_target(alpha, alpha_dot, 1.0),
            sharp.separation_target(alpha, alpha_dot, 1.0),
        );
        assert!((a - b).abs() < 1e-8, "{alpha_dot}: {a} vs {b}");
    }
    for alpha_dot in [-0.02, -0.005, 0.0, 0.004, 0.03] {
        let h = 1e-6;
        let rate = |d: f64| smooth.separation_rate(alpha, d, 0.5, airspeed);
        let difference = (rate(alpha_dot + h) - rate(alpha_dot - h)) / (2.0 * h);
        let slope = smooth.separation_rate_slope(alpha, alpha_dot, airspeed);
        assert!(
            (slope - difference).abs() < 1e-6 * difference.abs().max(1.0),
            "{alpha_dot}: {slope} vs {difference}"
        );
    }
    let (_, problems) = parse(
        "model = \"stall\"\n[stall]\na1 = 20.0\nalpha_star = 0.3\ntau1 = 0.0\ntau2 = 0.5\ntau2_switch_band = 0.01\n[CL]\nalpha = 4.0\n",
    );
    let fields: Vec<&str> = problems.0.iter().map(|p| p.field.as_str()).collect();
    assert_eq!(fields, ["aero.stall.tau2_switch_band"]);
    let measured = stall("alpha_dot = \"measured\"");
    let state = stall("");
    assert!(measured.takes_measured_alpha_dot() && !state.takes_measured_alpha_dot());
    assert_eq!(measured.separation_alpha_dot(-0.05, Some(0.02)), 0.02);
    assert_eq!(measured.separation_alpha_dot(-0.05, None), -0.05);
    assert_eq!(state.separation_alpha_dot(-0.05, Some(0.02)), -0.05);
    let mut algebraic = measured.clone();
    algebraic.parameters.set("tau1", 0.0).unwrap();
    assert!(!algebraic.forces_depend_on_alpha_dot());
    assert!(algebraic.forces_depend_on_state_alpha_dot(false));
    let input = AeroInput {
        alpha,
        airspeed,
        alpha_dot: -0.05,
        measured_alpha_dot: Some(0.02),
        ..Default::default()
    };
    assert_eq!(
        algebraic.effective_chi(&input),
        algebraic.separation_target(alpha, 0.02, airspeed)
    );
}

#[test]
fn every_problem_is_reported() {
    let (_, problems) = parse("[CL]\nalpha = nan\nbogus = 1.0\n[CQ]\n0 = 1.0\n[Cm]\nchi = 0.1\n");
    let fields: Vec<&str> = problems.0.iter().map(|p| p.field.as_str()).collect();
    assert_eq!(
        fields,
        ["aero.CL.alpha", "aero.CL.bogus", "aero.CQ", "aero.Cm.chi"],
        "{problems:?}"
    );
}
