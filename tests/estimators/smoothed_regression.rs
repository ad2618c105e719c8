//! Estimation before modelling (`ebm`: EKF + modified Bryson–Frazier
//! smoother with the coefficients as Gauss–Markov states, then regression)
//! on simulated records whose truth is known.

use crate::common;
use aeroid::estimation::estimate::Status;
use aeroid::estimation::methods::smoothed_regression::{
    Smoothed, SmoothedRegressionSettings, smooth_and_regress,
};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::Profile;
use aeroid::sim::scenario::Scenario;
use aeroid::sim::trace::TruthTrace;

/// The bundled flight-test profile with the noise lines removed from the
/// channels `strip` selects.
fn flight_test_variant(test: &str, strip: impl Fn(&str) -> bool) -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/recorders/flight-test-25hz.toml"
    ))
    .unwrap();
    let mut channel = String::new();
    let mut out = String::new();
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("name = \"") {
            channel = name.trim_end_matches('"').to_string();
        }
        if !(line.starts_with("noise") && strip(&channel)) {
            out += line;
            out += "\n";
        }
    }
    let path = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-ebm-{test}-{}.toml", std::process::id()));
    std::fs::write(&path, out).unwrap();
    path.to_string_lossy().into_owned()
}

fn fly(scenario: &str, profile: &str, seed: u64) -> (FlightRecord, TruthTrace, Scenario) {
    let scenario = Scenario::load(scenario).unwrap();
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    let profile = Profile::load(profile, None).unwrap();
    let record = profile.record(&trace, &scenario.aircraft, seed).unwrap();
    (record, trace, scenario)
}

/// RMS of smoothed − truth of each body-axis coefficient at the grid
/// points at least `margin` s from a control step, and the truth's own RMS
/// variation about its mean there.
fn coefficient_errors(
    smoothed: &Smoothed,
    trace: &TruthTrace,
    record: &FlightRecord,
    margin: f64,
) -> Vec<(&'static str, f64, f64)> {
    let steps = aeroid::estimation::reconstruction::control_steps(record);
    let kept: Vec<usize> = (0..smoothed.times.len())
        .filter(|&k| steps.iter().all(|s| (s - smoothed.times[k]).abs() > margin))
        .collect();
    ["CX", "CY", "CZ", "Cl", "Cm", "Cn"]
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let truth = trace.values(name).unwrap();
            let estimate = smoothed.coefficient(i);
            let at = |k: usize| truth[(smoothed.times[k] / trace.step).round() as usize];
            let n = kept.len() as f64;
            let rms = (kept
                .iter()
                .map(|&k| (estimate[k] - at(k)).powi(2))
                .sum::<f64>()
                / n)
                .sqrt();
            let mean = kept.iter().map(|&k| at(k)).sum::<f64>() / n;
            let variation = (kept.iter().map(|&k| (at(k) - mean).powi(2)).sum::<f64>() / n).sqrt();
            (*name, rms, variation)
        })
        .collect()
}

/// Noise-free flight-test records (25 Hz, every channel exact) of the
/// lateral multistep and the elevator 3211, with the bundled settings.
///
/// 1. The smoothed coefficient histories match the simulator's (its truth
///    trace) away from the control steps (0.2 s either side: a
///    Gauss–Markov coefficient cannot jump between two samples and ramps
///    over one interval): measured RMS errors — lateral: CX 4.6e-8,
///    CY 9.5e-6, CZ 8.1e-7, Cl 5.4e-6, Cm 1.8e-7, Cn 5.0e-6 (0.03 % of CY's
///    variation, 0.3 % of Cl's); 3211: CX 2.0e-7, CZ 2.6e-6, Cm 3.6e-5
///    (1.0 % of Cm's variation). Asserted: every RMS error below 2 % of the coefficient's
///    own variation (or 1e-5 where the manoeuvre does not move it), i.e.
///    the history is the truth's to plotting accuracy.
/// 2. The derivatives regressed on those histories recover the truth to
///    within 1 % (measured: worst 0.29 %, Cl_0 on the lateral multistep
///    and Cm_q on the 3211; CL_de 0.10 %), also without noise: the residual error
///    is the smoothing across control steps that the 0.2 s margin does not
///    remove entirely. 1 % is the accuracy a flight-test derivative is
///    used to (and ten times finer than the 10 % identifiability bar).
#[test]
fn ideal_records_give_the_truth_coefficients_and_derivatives() {
    let profile = flight_test_variant("noise-free", |_| true);
    for (name, model) in [
        ("attas-lateral-multistep", "attas-lateral"),
        ("attas-elevator-3211", "attas-longitudinal"),
    ] {
        let (record, trace, scenario) = fly(name, &profile, 1);
        let structure = ModelStructure::load(model).unwrap();
        let settings = SmoothedRegressionSettings::default();
        let (smoothed, estimate) = smooth_and_regress(&record, &structure, &settings).unwrap();
        for (coefficient, rms, variation) in
            coefficient_errors(&smoothed, &trace, &record, settings.step_margin)
        {
            eprintln!("{name} {coefficient}: RMS error {rms:.2e}, variation {variation:.2e}");
            assert!(
                rms < (0.02 * variation).max(1e-5),
                "{name} {coefficient}: RMS error {rms:.3e} against variation {variation:.3e}"
            );
        }
        let rows = common::against_truth(&estimate, &scenario);
        let text = common::truth_table(&rows);
        eprintln!("{name}:\n{text}");
        assert_eq!(estimate.status, Status::Converged, "{text}");
        for (parameter, value, _, truth) in &rows {
            assert!(
                (value - truth).abs() < 0.01 * truth.abs(),
                "{name} {parameter} off by more than 1 %:\n{text}"
            );
        }
    }
}

/// The bundled 25 Hz flight-test profile (white noise on every sensor as
/// DATA.md gives it, 0.01° on the controls): every estimate lies within
/// 3σ of the truth (its coloured-residual Cramér–Rao bound). Measured,
/// seed 1: worst 2.7σ (CY_0) on the lateral multistep, 2.4σ (CL_alpha)
/// on the 3211. 3σ: 28 parameters, so a 2.5σ excursion is expected by
/// chance (P(|z| > 3) per parameter 0.3 %); the regressors are the
/// smoothed states, whose small errors are in the variables, so a
/// method-bias would show as a growing σ-excess, which this bound catches.
#[test]
fn noisy_flight_test_records_within_three_sigma() {
    for (name, model) in [
        ("attas-lateral-multistep", "attas-lateral"),
        ("attas-elevator-3211", "attas-longitudinal"),
    ] {
        let (record, _, scenario) = fly(name, "flight-test-25hz", 1);
        let structure = ModelStructure::load(model).unwrap();
        let (_, estimate) =
            smooth_and_regress(&record, &structure, &SmoothedRegressionSettings::default())
                .unwrap();
        let rows = common::against_truth(&estimate, &scenario);
        let text = common::truth_table(&rows);
        eprintln!("{name}:\n{text}");
        for (parameter, value, sigma, truth) in &rows {
            assert!(
                sigma.is_finite() && *sigma > 0.0,
                "{name} {parameter}: σ {sigma}"
            );
            assert!(
                (value - truth).abs() < 3.0 * sigma,
                "{name} {parameter} beyond 3σ:\n{text}"
            );
        }
    }
}

/// The lateral multistep and the elevator 3211 with their models: the
/// slow-record cases.
const SLOW_CASES: [(&str, &str); 2] = [
    ("attas-lateral-multistep", "attas-lateral"),
    ("attas-elevator-3211", "attas-longitudinal"),
];

/// `name` flown and recorded by the flight-test profile at `rate` Hz
/// (recorder seed 1), smoothed and regressed on `model` with the default
/// settings: the scenario, the smoothed histories and the estimate.
fn smoothed_at(
    rate: f64,
    name: &str,
    model: &str,
) -> (
    Scenario,
    aeroid::estimation::methods::smoothed_regression::Smoothed,
    aeroid::estimation::estimate::Estimate,
) {
    let profile = Profile::load("flight-test-25hz", None)
        .unwrap()
        .with_rate(rate);
    let scenario = Scenario::load(name).unwrap();
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    let record = profile.record(&trace, &scenario.aircraft, 1).unwrap();
    let structure = ModelStructure::load(model).unwrap();
    let (smoothed, estimate) =
        smooth_and_regress(&record, &structure, &SmoothedRegressionSettings::default()).unwrap();
    (scenario, smoothed, estimate)
}

/// The same flights with every channel at 10 Hz: the filter's grid
/// divides the 0.1 s sample period into three 0.033 s steps (`max_step`
/// 0.04 s; with the sample period as its step the coefficient-state EKF
/// departs within seconds), and the estimates keep the 25 Hz test's 3σ
/// bound. At 10 Hz the change bounds lower the Cl and Cn chains of the
/// lateral flight (`moment_change_bound`). Measured, seed 1: worst 2.2σ
/// (Cm_q) on the 3211, 2.8σ (Cl_r) on the lateral multistep; 3σ as at
/// 25 Hz (28 parameters, P(|z| > 3) 0.3 % each).
#[test]
fn ten_hertz_records_are_filtered_on_a_divided_grid_within_three_sigma() {
    for (name, model) in SLOW_CASES {
        let (scenario, smoothed, estimate) = smoothed_at(10.0, name, model);
        assert!(
            (smoothed.times[1] - smoothed.times[0] - 0.1).abs() < 1e-9,
            "the histories are at the 10 Hz samples"
        );
        assert!(
            smoothed
                .notes
                .iter()
                .any(|n| n.contains("(3 to the sample period")),
            "{:?}",
            smoothed.notes
        );
        let rows = common::against_truth(&estimate, &scenario);
        let text = common::truth_table(&rows);
        eprintln!("{name} at 10 Hz:\n{text}");
        assert_eq!(estimate.status, Status::Converged, "{text}");
        for (parameter, value, sigma, truth) in &rows {
            assert!(
                (value - truth).abs() < 3.0 * sigma,
                "{name} {parameter} beyond 3σ at 10 Hz:\n{text}"
            );
        }
    }
}

/// A QAR-like record: the flight-test record of the elevator 3211 without
/// its p, q, r channels. The method still runs (the moments are observed
/// through the attitude angles alone, Wang et al. 2012's case) and its
/// estimate says what it could determine: the force derivatives as before
/// (within 3σ; CL_alpha, CD_0, e determined to 10 %), while Cm_q, now seen
/// through the second derivative of the pitch angle only, is left with a
/// standard error larger than 10 % of its value (measured: −6.3 ± 3.7
/// against −12.3); every estimate is still within 3σ, and the notes name
/// the absent channels and the determined parameters.
#[test]
fn record_without_angular_rates_says_what_it_could_estimate() {
    let (mut record, _, scenario) = fly("attas-elevator-3211", "flight-test-25hz", 1);
    record
        .channels
        .retain(|c| !["p", "q", "r"].contains(&c.name.as_str()));
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let problem = crate::common::registry()
        .problem("ebm", vec![record], structure, &[])
        .unwrap();
    let estimate = crate::common::registry().estimate(&problem, None).unwrap();
    let rows = common::against_truth(&estimate, &scenario);
    let text = common::truth_table(&rows);
    eprintln!("{text}{:#?}", estimate.notes);
    let notes = estimate.notes.join("\n");
    assert!(notes.contains("not in the record: p, q, r"), "{notes}");
    let determined = notes
        .lines()
        .find(|l| l.starts_with("determined to 10 %"))
        .unwrap();
    for parameter in ["CL_alpha", "CD_0", "e"] {
        assert!(
            determined.split(';').next().unwrap().contains(parameter),
            "{determined}"
        );
    }
    let cm_q = estimate.parameter("Cm_q").unwrap();
    assert!(cm_q.standard_error > 0.1 * cm_q.value.abs(), "{text}");
    assert!(
        determined.split(';').nth(1).unwrap().contains("Cm_q"),
        "{determined}"
    );
    for (parameter, value, sigma, truth) in &rows {
        assert!(
            (value - truth).abs() < 3.0 * sigma,
            "{parameter} beyond 3σ:\n{text}"
        );
    }
}

/// The smoothed histories as CSV: a header naming each column with its
/// unit like the truth trace's, one row per grid point, and the values
/// the library returned; an unwritable path is an error, not a panic.
#[test]
fn smoothed_histories_are_written_as_csv() {
    let profile = flight_test_variant("noise-free-csv", |_| true);
    let (record, _, _) = fly("attas-elevator-3211", &profile, 1);
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let (smoothed, _) =
        smooth_and_regress(&record, &structure, &SmoothedRegressionSettings::default()).unwrap();
    let folder = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-ebm-csv-{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let path = folder.join("smoothed.csv");
    smoothed.write_csv(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[0], "time [s]");
    let cm = header.iter().position(|h| *h == "Cm [-]").unwrap();
    assert!(header.contains(&"CL [-]") && header.contains(&"sigma_Cm [-]"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), smoothed.times.len());
    let k = rows.len() / 2;
    assert_eq!(rows[k][0], smoothed.times[k]);
    assert_eq!(rows[k][cm], smoothed.coefficient(4)[k]);
    assert!(
        smoothed
            .write_csv(&folder.join("no-such-folder").join("x.csv"))
            .is_err()
    );
    std::fs::remove_dir_all(&folder).ok();
}

/// A misspelt observation or a negative spectral density is refused, the
/// key named.
#[test]
fn bad_settings_are_refused_naming_the_key() {
    let method = crate::common::registry().find("ebm").unwrap();
    for (key, value, expected) in [
        (
            "observations",
            serde_json::json!(["nx", "n_z"]),
            "observations",
        ),
        ("force_noise", serde_json::json!(-1.0), "force_noise"),
        (
            "measurement_noise",
            serde_json::json!({"pitch": -0.1}),
            "measurement_noise",
        ),
        ("step_margin", serde_json::json!(-0.1), "step_margin"),
    ] {
        let mut settings = aeroid::estimation::estimator::Settings::new();
        settings.insert(key.into(), value);
        let error = method.check_settings(&settings).unwrap_err().to_string();
        assert!(error.contains(expected) && error.contains("ebm"), "{error}");
    }
}

/// A record without a needed observation (the load factors) or without a
/// control of the model's terms is refused with every missing channel
/// named and what it is for; a stall model (not linear in its parameters)
/// is refused as equation error refuses it.
#[test]
fn missing_channels_and_nonlinear_models_are_refused() {
    use aeroid::estimation::estimator::RefusalKind;
    let (mut record, _, _) = fly("attas-elevator-3211", "flight-test-25hz", 1);
    record
        .channels
        .retain(|c| !["nz", "elevator"].contains(&c.name.as_str()));
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let problem = crate::common::registry()
        .problem("ebm", vec![record.clone()], structure, &[])
        .unwrap();
    let Err(aeroid::estimation::Error::Refused(refusal)) =
        crate::common::registry().estimate(&problem, None)
    else {
        panic!("not refused");
    };
    assert_eq!(refusal.kind(), RefusalKind::MissingChannels, "{refusal}");
    assert_eq!(refusal.missing_channels(), ["nz", "elevator"], "{refusal}");
    let text = refusal.to_string();
    assert!(
        text.contains("Eq. 8") && text.contains("regressor 'de'"),
        "{text}"
    );
    let stall = ModelStructure::load("attas-stall").unwrap();
    let problem = crate::common::registry()
        .problem("ebm", vec![record], stall, &[])
        .unwrap();
    let Err(aeroid::estimation::Error::Refused(refusal)) =
        crate::common::registry().estimate(&problem, None)
    else {
        panic!("not refused");
    };
    assert_eq!(
        refusal.kind(),
        RefusalKind::NotLinearInParameters,
        "{refusal}"
    );
}

/// The seed paper's own case: `transport-approach` (gusts, moderate
/// turbulence) recorded by `qar-seed000` (1 Hz, every channel at its word
/// slot, no angular rates) and derived as in `the_qar_approach_end_to_end`
/// (geometric α, β, airspeed; kinematic p, q, r; thrust from the fuel
/// flow), the transport-longitudinal model, the default settings.
///
/// 1. The smoother runs to the end of the record (within the last 3 s:
///    the derived rates end 3 s early, their differentiator's half
///    window): at 1 Hz the change
///    bounds lower all six Gauss–Markov chains (the note says so) and the
///    derived channels carry their own noise.
/// 2. The smoothed coefficient histories against the truth trace's, RMS
///    over the 1 Hz samples (measured): CX 2.9e-3 (9 % of its variation
///    3.2e-2), CZ 1.9e-2 (10 % of 0.19), Cm 1.7e-3 (16 % of 1.1e-2);
///    asserted within 15 %, 15 % and 25 %. The lateral ones are near their
///    variation (Cl 9.5e-4 of 1.2e-3, Cn 2.9e-3 of 3.5e-3): the 1 Hz
///    attitude does not carry the turbulent rolling and yawing moments.
/// 3. The regression: CD_0 +2.5 % (0.5σ). The α derivatives are
///    attenuated far beyond their bounds (CL_α −76 %, 13σ; Cm_α −68 %,
///    13σ), and this is the regressor, not the coefficients: the smoothed
///    α errs by 0.020 rad RMS, as much as the geometric α it observes (the
///    unknown vertical gusts) and more than half of α's own variation
///    (0.023 rad RMS about its mean), so least squares on it is biased
///    towards zero (errors in variables), with Cramér–Rao bounds that
///    assume exact regressors. Asserted: CD_0 within 3σ, the smoothed α
///    error above 0.015 rad, and CL_α and Cm_α below half their truth.
/// 4. The paper's observation set alone (Eq. 8: no α, β, p, q, r) departs
///    after 11 s: at 1 Hz nothing but ψ and n_y holds the yaw rate and
///    sideslip between samples.
#[test]
fn the_derived_qar_approach_is_smoothed_to_the_end() {
    let scenario = common::approach(true);
    let (record, trace) = common::derived_qar_approach();
    let structure = ModelStructure::load("transport-longitudinal").unwrap();
    let settings = SmoothedRegressionSettings::default();
    let (smoothed, estimate) = smooth_and_regress(&record, &structure, &settings).unwrap();
    let end = record.channel("nz").unwrap().times.last().copied().unwrap();
    assert!(
        *smoothed.times.last().unwrap() > end - 4.0,
        "ends at {} s of {end}",
        smoothed.times.last().unwrap()
    );
    assert!(
        smoothed
            .notes
            .iter()
            .any(|n| n.contains("CX, CY, CZ, Cl, Cm, Cn lowered to the change bounds")),
        "{:?}",
        smoothed.notes
    );
    for (coefficient, rms, variation) in coefficient_errors(&smoothed, &trace, &record, 0.0) {
        eprintln!("QAR {coefficient}: RMS error {rms:.2e}, variation {variation:.2e}");
        let share = match coefficient {
            "CX" | "CZ" => 0.15,
            "Cm" => 0.25,
            _ => continue,
        };
        assert!(
            rms < share * variation,
            "{coefficient}: RMS error {rms:.3e} against variation {variation:.3e}"
        );
    }
    let alpha = trace.values("alpha").unwrap();
    let at = |k: usize| alpha[(smoothed.times[k] / trace.step).round() as usize];
    let n = smoothed.times.len() as f64;
    let smoothed_alpha = |k: usize| smoothed.states[k][2].atan2(smoothed.states[k][0]);
    let alpha_error = ((0..smoothed.times.len())
        .map(|k| (smoothed_alpha(k) - at(k)).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let mean = (0..smoothed.times.len()).map(at).sum::<f64>() / n;
    let alpha_variation = ((0..smoothed.times.len())
        .map(|k| (at(k) - mean).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let rows = common::against_truth(&estimate, &scenario);
    let text = common::truth_table(&rows);
    eprintln!(
        "QAR: smoothed α RMS error {alpha_error:.4} rad, α variation {alpha_variation:.4} rad\n{text}"
    );
    assert_eq!(estimate.status, Status::Converged, "{text}");
    let row = |name: &str| rows.iter().find(|r| r.0 == name).unwrap().clone();
    let (_, cd0, sigma, truth) = row("CD_0");
    assert!((cd0 - truth).abs() < 3.0 * sigma, "{text}");
    assert!(alpha_error > 0.015, "α error {alpha_error}");
    for name in ["CL_alpha", "Cm_alpha"] {
        let (_, value, _, truth) = row(name);
        assert!(value.abs() < 0.5 * truth.abs(), "{name}: {text}");
    }
    let eq8 = SmoothedRegressionSettings {
        optional_observations: Vec::new(),
        ..SmoothedRegressionSettings::default()
    };
    let error = smooth_and_regress(&record, &structure, &eq8).unwrap_err();
    assert!(error.to_string().contains("departed"), "{error}");
}

/// The same flights recorded at 2 Hz and 5 Hz (the flight-test profile
/// resampled, rate gyros included): the change bounds lower the chains
/// (all six at 2 Hz, Cl, Cm, Cn at 5 Hz) and the smoother runs through.
/// Measured, seed 1: at 2 Hz every estimate within 3σ (worst 2.5σ, Cn_dr
/// and Cl_r on the lateral multistep; 1.9σ, CL_0 and CL_alpha, on the
/// 3211); at 5 Hz the lateral multistep within 3σ (worst 2.5σ, CY_da)
/// while two of the 3211's pitching-moment terms are biased beyond it:
/// Cm_0 +18 % (3.4σ), Cm_q −57 % (4.2σ); Cm_alpha +25 % (2.9σ). The 5 Hz
/// finding is asserted so that a change to it is seen.
#[test]
fn two_and_five_hertz_records_are_smoothed() {
    for rate in [2.0, 5.0] {
        for (name, model) in SLOW_CASES {
            let (scenario, smoothed, estimate) = smoothed_at(rate, name, model);
            assert!(
                smoothed.notes.iter().any(|n| n.contains("lowered")),
                "{:?}",
                smoothed.notes
            );
            let rows = common::against_truth(&estimate, &scenario);
            let text = common::truth_table(&rows);
            eprintln!("{name} at {rate} Hz:\n{text}");
            assert_eq!(estimate.status, Status::Converged, "{text}");
            let biased: &[&str] = if rate == 5.0 && model == "attas-longitudinal" {
                &["Cm_0", "Cm_q"]
            } else {
                &[]
            };
            for (parameter, value, sigma, truth) in &rows {
                let within = (value - truth).abs() < 3.0 * sigma;
                if biased.contains(&parameter.as_str()) {
                    assert!(
                        !within,
                        "{name} {parameter} at {rate} Hz now within 3σ:\n{text}"
                    );
                } else {
                    assert!(within, "{name} {parameter} beyond 3σ at {rate} Hz:\n{text}");
                }
            }
        }
    }
}
