//! Flight path reconstruction / data compatibility check (reflex-wing UAV paper, Eqs.
//! 31–32): sensor biases and scale factors planted by the recorder are found
//! again, and the corrected record is consistent.

use aeroid::estimation::compatibility::flight_path_reconstruction;
use aeroid::estimation::estimate::Status;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;

const DEG: f64 = std::f64::consts::PI / 180.0;
const G: f64 = 9.80665;

/// A recorder with the planted errors, at `rate`, with white noise when `noisy`.
fn biased_profile(test: &str, rate: &str, noisy: bool) -> Profile {
    let noise = |sigma: &str| {
        if noisy {
            format!("noise = \"{sigma}\"\n")
        } else {
            String::new()
        }
    };
    let channel = |name: &str, extra: &str, sigma: &str| {
        format!(
            "[[channels]]\nname = \"{name}\"\nrate = \"{rate}\"\n{extra}{}\n",
            noise(sigma)
        )
    };
    let text = [
        "name = \"biased\"\n".to_string(),
        channel("airspeed", "", "0.2 m/s"),
        channel(
            "alpha",
            "scale_factor = 1.05\nbias = \"0.5 deg\"\n",
            "0.1 deg",
        ),
        channel(
            "beta",
            "scale_factor = 0.97\nbias = \"-0.3 deg\"\n",
            "0.1 deg",
        ),
        channel("roll", "", "0.1 deg"),
        channel("pitch", "", "0.1 deg"),
        channel("yaw", "", "0.1 deg"),
        channel("nx", "bias = \"0.01 g\"\n", "0.02 m/s^2"),
        channel("ny", "bias = \"-0.005 g\"\n", "0.02 m/s^2"),
        channel("nz", "bias = \"0.02 g\"\n", "0.02 m/s^2"),
        channel("p", "bias = \"0.003 rad/s\"\n", "0.002 rad/s"),
        channel("q", "bias = \"-0.002 rad/s\"\n", "0.002 rad/s"),
        channel("r", "bias = \"0.0015 rad/s\"\n", "0.002 rad/s"),
    ]
    .concat();
    let path = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-{test}-{}.toml", std::process::id()));
    std::fs::write(&path, text).unwrap();
    Profile::load(path.to_str().unwrap(), None).unwrap()
}

/// The planted errors in the estimator's terms: Δa = g·(load-factor bias),
/// with a_z = −g·nz, so Δa_z = −g·(nz bias).
fn planted() -> [(&'static str, f64); 10] {
    [
        ("delta_ax", 0.01 * G),
        ("delta_ay", -0.005 * G),
        ("delta_az", -0.02 * G),
        ("delta_p", 0.003),
        ("delta_q", -0.002),
        ("delta_r", 0.0015),
        ("K_alpha", 1.05),
        ("delta_alpha", 0.5 * DEG),
        ("K_beta", 0.97),
        ("delta_beta", -0.3 * DEG),
    ]
}

/// Noise-free record at the simulator's 100 Hz, all axes excited (the
/// bundled multisine flight): every planted error is recovered within 1 %
/// of its size (the kinematics are integrated with linearly interpolated
/// inputs, an O(h²) approximation of the truth's), and the corrected
/// record's rates equal the truth's (the ideal profile's) to 1e-4 rad/s.
#[test]
fn recovers_planted_sensor_errors() {
    let scenario = Scenario::load("attas-multisine").unwrap();
    let (record, _) =
        record_scenario(&scenario, &biased_profile("fpr-clean", "100 Hz", false)).unwrap();
    let result = flight_path_reconstruction(&record, 30).unwrap();
    assert_eq!(
        result.estimate.status,
        Status::Converged,
        "{:?}",
        result.estimate.cost_history
    );
    for (name, truth) in planted() {
        let value = result.estimate.parameter(name).unwrap().value;
        assert!(
            (value - truth).abs() < 0.01 * truth.abs(),
            "{name}: {value} vs {truth}"
        );
    }
    let (ideal, _) = record_scenario(&scenario, &Profile::load("ideal", None).unwrap()).unwrap();
    for name in ["p", "q", "r"] {
        let corrected = result.corrected.channel(name).unwrap();
        let truth = ideal
            .channel(name)
            .unwrap()
            .values_at(&corrected.times)
            .unwrap();
        let worst = corrected
            .values
            .iter()
            .zip(&truth)
            .map(|(c, t)| (c - t).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-4,
            "{name} corrected differs from truth by {worst}"
        );
    }
}

/// With the flight-test noise at 25 Hz. Noise-free at 25 Hz every error is
/// recovered within 0.25 % (measured), so what remains here is the noise of
/// the measured accelerations and rates, which are the kinematic model's
/// INPUTS: integrated, it makes the residuals coloured, and the white-residual
/// Cramér–Rao bounds of output-error reconstruction are then optimistic
/// (gyro biases measured 7–44 σ off while within 5 % of their size; a
/// filter-error or smoother formulation is the cure, ROADMAP). So the input
/// biases are gated on an engineering tolerance, 10 % of their size
/// (measured ≤ 4.7 %), while the flow-angle scale factors and offsets, which
/// sit in the output equations, are gated on 4 Cramér–Rao σ (measured ≤ 2.7).
/// That the input biases' bounds are optimistic is asserted too: at least
/// one of the six lies beyond 4 of its σ, which honest bounds would give
/// with a probability of about 4e-4 (6 × 6.3e-5).
#[test]
fn noisy_record_input_biases_and_flow_angle_calibration() {
    let scenario = Scenario::load("attas-multisine").unwrap();
    let (record, _) =
        record_scenario(&scenario, &biased_profile("fpr-noisy", "25 Hz", true)).unwrap();
    let result = flight_path_reconstruction(&record, 30).unwrap();
    assert_eq!(result.estimate.status, Status::Converged);
    let mut input_sigmas: f64 = 0.0;
    for (name, truth) in planted() {
        let p = result.estimate.parameter(name).unwrap();
        let sigmas = (p.value - truth) / p.standard_error;
        let output_side = name.contains("alpha") || name.contains("beta");
        let tolerance = if output_side {
            4.0 * p.standard_error
        } else {
            0.1 * truth.abs()
        };
        assert!(
            (p.value - truth).abs() < tolerance,
            "{name}: {} ± {} vs {truth} ({sigmas:+.2} σ)",
            p.value,
            p.standard_error
        );
        if !output_side {
            input_sigmas = input_sigmas.max(sigmas.abs());
        }
    }
    assert!(
        input_sigmas > 4.0,
        "the input biases' bounds are now honest: worst {input_sigmas:.2} σ"
    );
}

/// One sample per channel is fewer data than the reconstruction's
/// unknowns: refused with both numbers, never "converged" with every value
/// ± inf.
#[test]
fn a_one_sample_record_is_refused() {
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let (mut record, _) =
        record_scenario(&scenario, &biased_profile("fpr-short", "25 Hz", true)).unwrap();
    for channel in &mut record.channels {
        channel.times.truncate(1);
        channel.values.truncate(1);
    }
    match flight_path_reconstruction(&record, 30) {
        Err(aeroid::estimation::Error::Refused(refusal)) => assert_eq!(
            refusal.kind(),
            aeroid::estimation::estimator::RefusalKind::TooFewData,
            "{refusal}"
        ),
        Err(other) => panic!("an error, not a refusal: {other}"),
        Ok(result) => panic!("reconstructed: {}", result.estimate.status),
    }
}

/// Calibrations a manoeuvre does not separate are diagnosed: on the
/// lateral multistep α barely moves, so the α vane's scale factor cannot be
/// told from its offset (their estimates correlate beyond 0.95, each bound
/// then at least 3.2 times what it would be with the other known); on the
/// multisine, which moves α, neither is diagnosed.
#[test]
fn calibrations_the_manoeuvre_does_not_separate_are_diagnosed() {
    use aeroid::estimation::diagnosis::DiagnosisKind;
    let inseparable = |scenario: &str| -> Vec<(String, f64)> {
        let scenario = Scenario::load(scenario).unwrap();
        let profile = biased_profile(&format!("fpr-separate-{}", scenario.name), "25 Hz", true);
        let (record, _) = record_scenario(&scenario, &profile).unwrap();
        let result = flight_path_reconstruction(&record, 30).unwrap();
        let estimate = &result.estimate;
        for (i, p) in estimate.parameters.iter().enumerate() {
            eprintln!(
                "{} {}: {:?}",
                scenario.name,
                p.name,
                estimate.strongest_correlation(i)
            );
        }
        estimate
            .diagnoses
            .iter()
            .filter(|d| d.kind == DiagnosisKind::Inseparable)
            .flat_map(|d| d.about.iter().cloned().zip(d.measures.iter().copied()))
            .collect()
    };
    let lateral = inseparable("attas-lateral-multistep");
    eprintln!("lateral: {lateral:?}");
    assert!(
        lateral
            .iter()
            .any(|(name, r)| name.starts_with("K_alpha") && *r > 0.95),
        "{lateral:?}"
    );
    let multisine = inseparable("attas-multisine");
    eprintln!("multisine: {multisine:?}");
    assert!(
        !multisine
            .iter()
            .any(|(name, _)| name.starts_with("K_alpha")),
        "{multisine:?}"
    );
}
