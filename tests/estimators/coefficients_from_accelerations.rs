//! The aerodynamic coefficients computed from the measured accelerations
//! (`aeroid derive --coefficients`): on the ATTAS stall manoeuvre recorded
//! with the accelerometers away from the centre of gravity they are the
//! simulator's own coefficients, and the stall model fitted to them as
//! outputs (CD, CL, Cm, no state integrated but χ) recovers the truth.

use crate::common;
use aeroid::estimation::coefficient_channels::{COEFFICIENT_CHANNELS, coefficient_channels};
use aeroid::estimation::estimate::Status;
use aeroid::estimation::reconstruction::{AngularAccelerations, ReconstructionOptions};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::sim::scenario::Scenario;
use aeroid::sim::trace::TruthTrace;
use nalgebra::Vector3;
use std::sync::OnceLock;

/// The accelerometers' place in the test records: 6 m ahead of, 1.5 m
/// right of and 0.8 m above the CG (a nose-mounted package is 5–10 m from
/// a transport's CG).
const ARM: [f64; 3] = [6.0, 1.5, -0.8];

/// The bundled recorder profile `base` with its load factors measured at
/// [`ARM`], written to a folder named after `test`.
fn with_arm(test: &str, base: &str) -> aeroid::record::recorder::Profile {
    let position = format!(
        "position = [\"{} m\", \"{} m\", \"{} m\"]\n",
        ARM[0], ARM[1], ARM[2]
    );
    common::profile_variant(&common::temp_folder(test), base, "", |name, table| {
        Some(if ["nx", "ny", "nz"].contains(&name) {
            format!("{}\n{position}", table.trim_end_matches('\n'))
        } else {
            table.to_string()
        })
    })
}

/// The ATTAS stall manoeuvre recorded by the ideal recorder (100 Hz, no
/// error) with the load factors measured at [`ARM`], and the truth trace.
fn ideal_stall() -> &'static (FlightRecord, TruthTrace, Scenario) {
    static RECORD: OnceLock<(FlightRecord, TruthTrace, Scenario)> = OnceLock::new();
    RECORD.get_or_init(|| {
        let profile = with_arm("coefficients_ideal", "ideal");
        let scenario = Scenario::load("attas-stall").unwrap();
        let (record, trace) = common::fly_and_record(&scenario, &profile);
        (record, trace, scenario)
    })
}

fn options(angular_accelerations: AngularAccelerations, arm: [f64; 3]) -> ReconstructionOptions {
    ReconstructionOptions {
        angular_accelerations,
        accelerometer_position: Vector3::from(arm),
        ..ReconstructionOptions::default()
    }
}

/// The largest error of each computed coefficient against the simulator's
/// at the channel's instants, over the coefficient's range in the record.
fn errors(
    record: &FlightRecord,
    trace: &TruthTrace,
    options: &ReconstructionOptions,
) -> Vec<(String, f64, f64)> {
    let aircraft = &Scenario::load("attas-stall").unwrap().aircraft;
    let computed = coefficient_channels(record, aircraft, options).unwrap();
    assert!(computed.left_out.is_empty(), "{:?}", computed.left_out);
    let names: Vec<&str> = computed.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, COEFFICIENT_CHANNELS, "every coefficient, in order");
    computed
        .channels
        .iter()
        .map(|channel| {
            let truth = common::truth_at(trace, &channel.name, &channel.times);
            let worst = channel
                .values
                .iter()
                .zip(&truth)
                .map(|(v, t)| (v - t).abs())
                .fold(0.0, f64::max);
            let (low, high) = truth
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), t| {
                    (l.min(*t), h.max(*t))
                });
            assert!(
                channel.values.iter().all(|v| v.is_finite()),
                "{}",
                channel.name
            );
            (channel.name.clone(), worst, high - low)
        })
        .collect()
}

/// With the record's angular accelerations and the accelerometers' place
/// stated, every coefficient is the simulator's to rounding (1e-9: the
/// ideal recorder samples on the simulator's steps and writes each value
/// exactly); read as if at the CG, the forces are wrong by far more than
/// that — the transfer is what makes them right.
#[test]
fn the_coefficients_are_the_simulators_with_the_accelerometers_carried_to_the_cg() {
    let (record, trace, _) = ideal_stall();
    for (name, worst, range) in errors(record, trace, &options(AngularAccelerations::Measured, ARM))
    {
        eprintln!("measured ω̇, transferred: {name} worst {worst:.2e} over a range of {range:.3}");
        assert!(worst < 1e-9, "{name}: {worst:e}");
    }
    let untransferred = errors(
        record,
        trace,
        &options(AngularAccelerations::Measured, [0.0; 3]),
    );
    for (name, worst, range) in &untransferred {
        eprintln!("read as if at the CG: {name} worst {worst:.2e} over a range of {range:.3}");
    }
    let worst_force = untransferred
        .iter()
        .filter(|(name, ..)| ["CX", "CY", "CZ", "CL", "CD"].contains(&name.as_str()))
        .map(|(_, worst, _)| *worst)
        .fold(0.0, f64::max);
    assert!(
        worst_force > 1e-3,
        "the sensor's place moved nothing: {worst_force:e}"
    );
}

/// The bundled example's stall model (`examples/stall-flight/`): the
/// structure of `models/attas-stall.toml` with no state integrated (α, q,
/// V and the controls fed in from the record, χ the one state) and the
/// coefficients as its outputs — the book's way of fitting the
/// quasi-steady stall model to flight data.
fn coefficient_model() -> ModelStructure {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/stall-flight/stall-coefficients.toml");
    ModelStructure::load(path.to_str().unwrap()).unwrap()
}

/// Output error fits the stall model to the noise-free coefficients
/// computed from the ideal record (accelerometers away from the CG): every
/// parameter to the truth (1e-6 relative: the data are exact, so the
/// optimum is the truth and the tolerance is the solver's).
#[test]
fn the_stall_model_fitted_to_the_coefficients_recovers_the_truth() {
    let (record, _, scenario) = ideal_stall();
    let mut record = record.clone();
    coefficient_channels(
        &record,
        &scenario.aircraft,
        &options(AngularAccelerations::Measured, ARM),
    )
    .unwrap()
    .add_to(&mut record, false);
    let structure = coefficient_model();
    let problem = common::registry()
        .problem("oem", vec![record], structure, &[])
        .unwrap();
    let estimate = common::registry().estimate(&problem, None).unwrap();
    let rows = common::against_truth(&estimate, scenario);
    eprintln!("{}\n{}", estimate.status, common::truth_table(&rows));
    assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
    for (name, value, _, truth) in rows.iter().filter(|row| row.3.is_finite()) {
        assert!(
            (value - truth).abs() <= 1e-6 * truth.abs().max(0.01),
            "{name}: {value} against the truth {truth}"
        );
    }
}

/// With the rates differentiated instead (the default), the moments and
/// the transferred forces carry the differentiator's error: its gain is
/// within 1 % of the derivative's over the band it states (the default
/// quartic over ±0.1 s, its band in the notes), which holds the stall
/// manoeuvre's motion, so each coefficient is within 1 % of its range.
#[test]
fn differentiated_rates_give_the_coefficients_within_the_differentiators_gain() {
    let (record, trace, _) = ideal_stall();
    let options = options(AngularAccelerations::Differentiated, ARM);
    for (name, worst, range) in errors(record, trace, &options) {
        eprintln!("differentiated ω̇: {name} worst {worst:.2e} over a range of {range:.3}");
        assert!(
            worst <= 0.01 * range.max(1e-6),
            "{name}: {worst:e} over {range}"
        );
    }
}

/// The flight-test recorder (25 Hz, noise on α, q, V and the load
/// factors, accelerometers at [`ARM`]) over eight recorder seeds: the
/// coefficients computed with differentiated rates, the stall model fitted
/// to them lands every parameter within 3 of its Cramér–Rao σ of the truth
/// (a parameter outside 3σ has 0.3 % probability under the bound).
#[test]
fn the_stall_model_fitted_to_noisy_coefficients_lies_within_its_bounds() {
    let scenario = &ideal_stall().2;
    let profile = with_arm("coefficients_noisy", "flight-test-25hz");
    let (trace, _) = aeroid::sim::fly(scenario).unwrap();
    let structure = coefficient_model();
    let mut worst = (0.0, String::new());
    for seed in 0..8 {
        let mut record = profile.record(&trace, &scenario.aircraft, seed).unwrap();
        let options = options(AngularAccelerations::Differentiated, ARM);
        coefficient_channels(&record, &scenario.aircraft, &options)
            .unwrap()
            .add_to(&mut record, false);
        let problem = common::registry()
            .problem("oem", vec![record], structure.clone(), &[])
            .unwrap();
        let estimate = common::registry().estimate(&problem, None).unwrap();
        assert_eq!(
            estimate.status,
            Status::Converged,
            "seed {seed}: {:?}",
            estimate.notes
        );
        for (name, value, sigma, truth) in common::against_truth(&estimate, scenario) {
            let off = (value - truth).abs() / sigma;
            if off > worst.0 {
                worst = (off, format!("{name} (seed {seed})"));
            }
        }
    }
    eprintln!("worst error: {:.2} σ, {}", worst.0, worst.1);
    assert!(worst.0 <= 3.0, "{:.2} σ: {}", worst.0, worst.1);
}
