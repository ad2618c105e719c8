//! The augmented-state filters (`ekf`, `ukf`) on simulated records where
//! the answer is known: noise-free and noisy ATTAS lateral multistep, the
//! stall manoeuvre, a parameter that changes in flight, their innovations'
//! whiteness and their settings.

use crate::common;
use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::estimator::Settings;
use aeroid::estimation::methods::augmented_ekf::{self, FilterRun, FilterSettings};
use aeroid::estimation::methods::output_error::Start;
use aeroid::estimation::solver::{extended_kalman, unscented_kalman};
use aeroid::estimation::structure::ModelStructure;
use aeroid::numerics::kalman;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario, record_scenario_seeded};
use aeroid::sim::integrator::Interpolation;
use aeroid::sim::scenario::Scenario;
use aeroid::sim::state::Control;

/// The flight-test profile (25 Hz) with the noise line of every channel
/// `strip` selects removed.
fn flight_test_variant(test: &str, strip: impl Fn(&str) -> bool) -> Profile {
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
        .join(format!("aeroid-{test}-{}.toml", std::process::id()));
    std::fs::write(&path, out).unwrap();
    Profile::load(path.to_str().unwrap(), None).unwrap()
}

/// Sensor noise only: the control channels exact (noise on them is noise
/// in the model's inputs, which a filter, like output error, takes as
/// exact; docs/findings.md).
fn is_control(channel: &str) -> bool {
    Control::ALL.iter().any(|c| c.name() == channel)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Filter {
    Extended,
    Unscented,
}

/// The method's own run (its default sigma points for the UKF), with the
/// histories and innovations the registered method does not return.
fn run(
    filter: Filter,
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &FilterSettings,
) -> FilterRun {
    let name = match filter {
        Filter::Extended => "ekf",
        Filter::Unscented => "ukf",
    };
    let unscented = aeroid::estimation::methods::unscented::read(&Settings::new())
        .unwrap()
        .1;
    augmented_ekf::augmented_estimate(
        name,
        record,
        structure,
        settings,
        None,
        &|model, initial, noise, observations| match filter {
            Filter::Extended => extended_kalman::filter(model, &[], initial, noise, observations),
            Filter::Unscented => {
                unscented_kalman::filter(model, &[], initial, noise, observations, &unscented)
            }
        },
    )
    .unwrap()
}

/// Worst relative error, worst error in σ, and a report.
fn report(estimate: &Estimate, truth: impl Fn(&str) -> f64) -> (f64, f64, String) {
    let mut text = format!("{}: {}\n", estimate.method, estimate.status);
    let (mut worst_relative, mut worst_sigma): (f64, f64) = (0.0, 0.0);
    for p in &estimate.parameters {
        let truth = truth(&p.name);
        let relative = ((p.value - truth) / truth).abs();
        let sigmas = (p.value - truth) / p.standard_error;
        worst_relative = worst_relative.max(relative);
        worst_sigma = worst_sigma.max(sigmas.abs());
        text += &format!(
            "{}: {:.6} ± {:.2e} (truth {truth:.6}, rel {relative:.2e}, {sigmas:+.2} σ)\n",
            p.name, p.value, p.standard_error
        );
    }
    (worst_relative, worst_sigma, text + &estimate.details)
}

fn lateral() -> (Scenario, ModelStructure) {
    (
        Scenario::load("attas-lateral-multistep").unwrap(),
        ModelStructure::load("attas-lateral").unwrap(),
    )
}

/// The lateral multistep recorded at 25 Hz without noise. The EKF,
/// started from the model file's values (equation error is already within
/// 2e-5 of the truth on noise-free data, so starting there would test
/// nothing): every derivative within 1e-3 relative. Its model is not the
/// truth's exactly: the pseudo-controls (V, α, q, θ) are interpolated
/// linearly between the 25 Hz samples inside each 0.04 s step, an O(h²)
/// error (output error on the 100 Hz record is within 2e-4); measured
/// worst 5e-5 (CY_da). It is converged (settled and identified), with
/// its innovations diagnosed inconsistent with their covariance: they are
/// that interpolation error, far below the noise floor R is held at, not
/// white noise of variance R.
///
/// The UKF (square-root form, default α = 0.5) is held to the same: every
/// derivative within 1e-3 relative, converged with the same diagnosis.
/// Measured worst 5.2e-5 (CY_da; the EKF's 5.0e-5): the same
/// interpolation error as the EKF's.
#[test]
fn noise_free_record_gives_the_truth() {
    let (scenario, structure) = lateral();
    let profile = flight_test_variant("filters-noise-free", |_| true);
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let settings = FilterSettings {
        start: Start::Model,
        ..FilterSettings::default()
    };
    let truth = |n: &str| scenario.aircraft.aero.parameters.get(n).unwrap();
    let run_ekf = run(Filter::Extended, &record, &structure, &settings);
    let (relative, _, text) = report(&run_ekf.estimate, truth);
    println!("{text}");
    assert!(relative < 1e-3, "{relative:e}\n{text}");
    let settled = |e: &aeroid::estimation::estimate::Estimate| {
        let inconsistent = aeroid::estimation::estimate::DiagnosisKind::InconsistentInnovations;
        e.status == Status::Converged && e.diagnosis(inconsistent).is_some()
    };
    assert!(settled(&run_ekf.estimate), "{text}");
    let run_ukf = run(Filter::Unscented, &record, &structure, &settings);
    let (relative, _, text) = report(&run_ukf.estimate, truth);
    println!("{text}");
    assert!(relative < 1e-3, "{relative:e}\n{text}");
    assert!(settled(&run_ukf.estimate), "{text}");
}

/// A single pass is judged by the same settling test as several: on the
/// noise-free lateral multistep and on its flight-test record, with
/// `passes = 1` (and the default start from equation error), both
/// filters' parameters settle and are identified, so
/// the estimate is `converged` (with the diagnosis of its innovations
/// where ν²/S is off 1), never `unsettled`, every parameter within 4σ of
/// the truth (this file's bound for one noisy run).
#[test]
fn a_single_pass_that_settles_is_converged() {
    let (scenario, structure) = lateral();
    let settings = FilterSettings {
        passes: 1,
        ..FilterSettings::default()
    };
    let truth = |n: &str| scenario.aircraft.aero.parameters.get(n).unwrap();
    for (name, profile) in [
        (
            "noise-free",
            flight_test_variant("filters-one-pass", |_| true),
        ),
        (
            "flight-test",
            Profile::load("flight-test-25hz", None).unwrap(),
        ),
    ] {
        let (record, _) = record_scenario(&scenario, &profile).unwrap();
        for filter in [Filter::Extended, Filter::Unscented] {
            let estimate = run(filter, &record, &structure, &settings).estimate;
            let (_, sigmas, text) = report(&estimate, truth);
            assert_eq!(estimate.status, Status::Converged, "{name}\n{text}");
            assert!(sigmas < 4.0, "{name}: {sigmas:.2}σ\n{text}");
        }
    }
}

/// Sensor noise (flight-test profile, controls exact), five recorder seeds
/// for the EKF, one for the UKF (1.8 s a run): every parameter within 4σ
/// of the truth, every run converged, and the σ checked against the
/// scatter of the errors: the mean of ((θ̂ − θ)/σ)² over the 90 EKF
/// estimates is 1 when σ is right (its sampling σ ≈ √(2/90) = 0.15); it
/// must lie in [0.5, 2.25], σ within a factor 1.5 of the errors. Measured
/// 1.30 (UKF, one run: 1.58): σ is about 1.15 times optimistic, as the
/// noise on the pseudo-controls (V, α, q, θ fed in from the record) is not
/// in the filter's model. Worst measured 2.9σ.
#[test]
fn noisy_record_within_sigma_checked_by_monte_carlo() {
    let (scenario, structure) = lateral();
    let profile = flight_test_variant("filters-sensor-noise", is_control);
    for (filter, seeds) in [
        (Filter::Extended, &[1u64, 2, 3, 4, 5][..]),
        (Filter::Unscented, &[1u64][..]),
    ] {
        let mut squares = Vec::new();
        for &seed in seeds {
            let (record, _) = record_scenario_seeded(&scenario, &profile, seed).unwrap();
            let run = run(filter, &record, &structure, &FilterSettings::default());
            let truth = |n: &str| scenario.aircraft.aero.parameters.get(n).unwrap();
            let (_, worst, text) = report(&run.estimate, truth);
            println!("{filter:?} seed {seed}: worst {worst:.2} σ\n{text}");
            assert_eq!(run.estimate.status, Status::Converged, "{text}");
            assert!(worst <= 4.0, "{filter:?} seed {seed}: {worst} σ\n{text}");
            squares.extend(
                run.estimate
                    .parameters
                    .iter()
                    .map(|p| ((p.value - truth(&p.name)) / p.standard_error).powi(2)),
            );
        }
        let mean = squares.iter().sum::<f64>() / squares.len() as f64;
        println!(
            "{filter:?}: mean ((θ̂ − θ)/σ)² {mean:.3} over {}",
            squares.len()
        );
        if seeds.len() > 1 {
            assert!((0.5..=2.25).contains(&mean), "{filter:?}: {mean}");
        }
    }
}

/// The lateral multistep in moderate Dryden turbulence
/// (`attas-lateral-turbulence`, its bundled seed, flight-test-25hz), the
/// filters' default settings: the gust is process noise on β, p and r,
/// which Mehra's residual-correlation passes measure from the first
/// pass's innovations. Both filters converged, every parameter within
/// 3.5σ of the truth, σ the estimate's own standard error: 18
/// parameters, two filters, so a bound a correct σ breaks with
/// probability 4.7e-4 per parameter (1.7 % for the 36 together); 3.5σ is
/// also the bar filter error, built for process noise, meets on this
/// flight (worst 2.4σ). Measured: EKF worst 2.2σ (CY_da, CY_beta
/// 2.0σ), UKF worst 1.8σ (Cn_p). With the zero-lag covariance matching
/// (`correlation_lags = 0`) the EKF ends unidentified with Cn_r 183σ off.
#[test]
fn turbulence_flight_within_three_and_a_half_sigma() {
    let scenario = Scenario::load("attas-lateral-turbulence").unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let truth = |n: &str| scenario.aircraft.aero.parameters.get(n).unwrap();
    for filter in [Filter::Extended, Filter::Unscented] {
        let run = run(filter, &record, &structure, &FilterSettings::default());
        let (_, worst, text) = report(&run.estimate, truth);
        println!("{filter:?}: worst {worst:.2} σ\n{text}");
        assert_eq!(run.estimate.status, Status::Converged, "{filter:?}\n{text}");
        assert!(worst <= 3.5, "{filter:?}: {worst} σ\n{text}");
    }
}

/// On data without process noise (calm air, sensor noise only) the EKF's
/// innovations are white: for each output, the normalised autocorrelation
/// at lags 1–50 (2 s, past the Dutch roll's half period) inside
/// ±1.96/√N ([`kalman::whiteness`]). For exactly white innovations the
/// number of lags outside is Binomial(50, 0.05), mean 2.5: "≥ 95 % inside"
/// (at most 2 outside) would fail such innovations 46 % of the time. So
/// each output needs ≥ 86 % (at most 7 outside; false alarm 0.4 %) and the
/// five outputs together ≥ 92 % (250 lags, 2 σ below the white mean of
/// 95 %). Coloured innovations (a wrong model, a mistuned filter) fail by
/// far: their early lags all lie outside. Measured: 0.88–0.98 per output,
/// 0.95 pooled. The same filter with Cn_beta held 20 % off (fixed) is
/// checked to fail, so the test can.
#[test]
fn innovations_are_white_without_process_noise() {
    let (scenario, structure) = lateral();
    let profile = flight_test_variant("filters-white", is_control);
    let (record, _) = record_scenario_seeded(&scenario, &profile, 1).unwrap();
    let mut wrong = structure.clone();
    let i = wrong.aircraft.aero.parameters.index("Cn_beta").unwrap();
    wrong.free[i] = false;
    let truth = scenario.aircraft.aero.parameters.get("Cn_beta").unwrap();
    wrong
        .aircraft
        .aero
        .parameters
        .set("Cn_beta", 0.8 * truth)
        .unwrap();
    for (structure, white) in [(&structure, true), (&wrong, false)] {
        let run = run(
            Filter::Extended,
            &record,
            structure,
            &FilterSettings::default(),
        );
        let fractions: Vec<f64> = run
            .innovations
            .iter()
            .map(|innovations| {
                let series: Vec<f64> = innovations
                    .iter()
                    .map(|i| i.value / i.variance.sqrt())
                    .collect();
                kalman::whiteness(&series, 50)
            })
            .collect();
        let pooled = fractions.iter().sum::<f64>() / fractions.len() as f64;
        println!("white {white}: {fractions:?}, pooled {pooled:.3}");
        let passes = fractions.iter().all(|&f| f >= 0.86) && pooled >= 0.92;
        assert_eq!(passes, white, "{fractions:?}");
    }
}

/// The stall manoeuvre (Verma & Peyada 2020 model: χ, the break point α*,
/// its sharpness a1 and the hysteresis τ2 enter nonlinearly), from the
/// model file's values (equation error cannot fit the stall model), sensor
/// noise. The EKF lands within 2 % of every truth value (measured worst
/// 1.3 % in 4 passes, 0.9 s), the UKF within 3 % (measured worst 2.9 %,
/// CL_0, in 1 pass, 0.4 s). The EKF's first pass innovations are 3–11
/// times (RMS) larger than predicted from this start (its linearisation
/// misses the break); the UKF's are consistent from the first pass. The
/// EKF's σ cover its errors (worst 3.2σ); the UKF's do not (worst 10.4σ:
/// one pass with no process noise, σ 2–3 times smaller than the EKF's,
/// whose passes raised the process noise). The UKF's 3 % is this record's
/// (the scenario's seed) and no more: over recorder seeds 1–6 its worst
/// error is 2.9–10 % (docs/findings.md).
#[test]
fn stall_model_ekf_and_ukf() {
    let scenario = Scenario::load("attas-stall").unwrap();
    let structure = ModelStructure::load("attas-stall").unwrap();
    let profile = flight_test_variant("filters-stall", is_control);
    let (record, truth) = record_scenario(&scenario, &profile).unwrap();
    let settings = FilterSettings {
        interpolation: Interpolation::Linear.into(),
        ..FilterSettings::default()
    };
    for filter in [Filter::Extended, Filter::Unscented] {
        let started = std::time::Instant::now();
        let run = run(filter, &record, &structure, &settings);
        let (relative, worst, text) = report(&run.estimate, |n| truth.parameters[n]);
        println!(
            "{filter:?}: {:.2?}, worst {relative:.2e} relative, {worst:.2} σ\n{text}",
            started.elapsed()
        );
        assert_eq!(run.estimate.status, Status::Converged, "{text}");
        let tolerance = match filter {
            Filter::Extended => 0.02,
            Filter::Unscented => 0.03,
        };
        assert!(relative < tolerance, "{filter:?}: {relative}\n{text}");
        if filter == Filter::Extended {
            assert!(worst <= 4.0, "{worst}\n{text}");
        }
    }
}

/// Cm_alpha drops from −0.176 to −0.1408 at 30 s (`attas-cm-alpha-step`,
/// elevator retrimmed at the change). With pseudonoise on Cm_alpha
/// (0.02·|θ₀| per √s) the EKF follows: from 35 s to the end of the record
/// its estimate is within 2σ of the new value at every grid point and more
/// than 4σ from the old one; before the change within 2σ of the old one.
/// Cm_0 and Cm_de are held at their true values: free, they are so
/// correlated with Cm_alpha in this manoeuvre (α stays near its trim 9°)
/// that σ(Cm_alpha) ≈ 0.018, more than half the step, and "within 2σ of the
/// new value" would not tell the new value from the old (measured with
/// them free: within 1.2σ of the new value and 0.9–1.8σ from the old one
/// from 35 s on). Measured: at 32 s within 0.9σ (σ 0.0025); from 35 s worst
/// 1.3σ from the new value, ≥ 13σ from the old. The histories are written
/// as CSV and read back.
#[test]
fn ekf_tracks_a_parameter_that_changes_in_flight() {
    let scenario = Scenario::load("attas-cm-alpha-step").unwrap();
    let mut structure = ModelStructure::load("attas-longitudinal").unwrap();
    let profile = flight_test_variant("filters-step", is_control);
    let (record, truth) = record_scenario(&scenario, &profile).unwrap();
    for name in ["Cm_0", "Cm_de"] {
        let i = structure.aircraft.aero.parameters.index(name).unwrap();
        structure.free[i] = false;
        structure
            .aircraft
            .aero
            .parameters
            .set(name, truth.parameters[name])
            .unwrap();
    }
    let settings = FilterSettings {
        interpolation: Interpolation::Linear.into(),
        pseudonoise_for: [("Cm_alpha".to_string(), 0.02)].into(),
        ..FilterSettings::default()
    };
    let run = run(Filter::Extended, &record, &structure, &settings);
    let history = &run.history;
    let j = history.names.iter().position(|n| n == "Cm_alpha").unwrap();
    let (old, new) = (
        truth.parameter_at("Cm_alpha", 0.0).unwrap(),
        truth.parameter_at("Cm_alpha", 59.0).unwrap(),
    );
    for (k, &t) in history.times.iter().enumerate() {
        let (value, sigma) = (history.values[k][j], history.sigmas[k][j]);
        let line = format!("t {t}: {value} ± {sigma} (old {old}, new {new})");
        if (20.0..30.0).contains(&t) {
            assert!((value - old).abs() <= 2.0 * sigma, "{line}");
        }
        if t >= 35.0 {
            assert!((value - new).abs() <= 2.0 * sigma, "{line}");
            assert!((value - old).abs() > 4.0 * sigma, "{line}");
        }
    }
    let folder = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-history-{}", std::process::id()));
    std::fs::create_dir_all(&folder).unwrap();
    let path = folder.join("history.csv");
    history.write_csv(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), history.times.len() + 1);
    assert!(lines[0].starts_with("time,") && lines[0].contains(",Cm_alpha,sigma_Cm_alpha"));
    let last: Vec<f64> = lines[lines.len() - 1]
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(
        last[1 + 2 * j],
        *history.values.last().unwrap().get(j).unwrap()
    );
}

/// Bad settings are refused naming the key; a pseudonoise on a parameter
/// the model does not estimate is refused when the problem is run.
#[test]
fn bad_settings_are_refused_by_name() {
    let refused = |method: &str, key: &str, value: serde_json::Value| {
        let mut settings = Settings::new();
        settings.insert(key.to_string(), value);
        let error = crate::common::registry()
            .find(method)
            .unwrap()
            .check_settings(&settings)
            .unwrap_err()
            .to_string();
        assert!(error.contains(key), "{method} {key}: {error}");
    };
    for method in ["ekf", "ukf"] {
        refused(method, "passes", 0.into());
        refused(method, "pseudonoise", (-1.0).into());
        refused(method, "initial_uncertainty", 0.0.into());
        refused(method, "motion_bandwidth", 0.0.into());
        refused(method, "step", "-1 s".into());
        refused(
            method,
            "pseudonoise_for",
            serde_json::json!({ "Cn_beta": -0.1 }),
        );
        refused(method, "no_such_key", 1.into());
    }
    refused("ekf", "alpha", 0.5.into());
    refused("ukf", "alpha", 0.0.into());
    refused("ukf", "alpha", 1.5.into());
    refused("ukf", "kappa", (-1.0).into());
    let (scenario, structure) = lateral();
    let (record, _) =
        record_scenario(&scenario, &Profile::load("flight-test-25hz", None).unwrap()).unwrap();
    let mut table = toml::Table::new();
    table.insert(
        "pseudonoise_for".into(),
        toml::Value::Table(toml::from_str("Cm_alpha = 0.1").unwrap()),
    );
    let layers = [("ekf".to_string(), table)].into();
    let problem = crate::common::registry()
        .problem("ekf", vec![record], structure, &[&layers])
        .unwrap();
    let error = crate::common::registry()
        .estimate(&problem, None)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("pseudonoise_for") && error.contains("Cm_alpha"),
        "{error}"
    );
}

/// The filters' integration step is never a silent bias either: on the
/// HANSA-3 multistep recorded at 1.25 Hz (as output error's
/// `coarse_records_are_integrated_in_sub_steps`) the EKF, the UKF and
/// filter error predict through sub-steps of h·|λ| ≤ 0.5 and say so. With
/// the sample period as the step (RK4 at h·|λ| = 2.3 for the short period)
/// the EKF's and UKF's model departs mid-record; in sub-steps they reach
/// the end, though 60 s at 1.25 Hz leave most parameters unidentified
/// (their variances stay near the prior: measured, a finding). Filter
/// error converges, and halving its step moves no estimate by more than
/// 0.1σ (measured 0.015σ).
#[test]
fn coarse_records_are_filtered_in_sub_steps() {
    let record = common::hansa3_at_1_25_hz();
    let structure = ModelStructure::load("hansa3-longitudinal").unwrap();
    for method in ["ekf", "ukf", "fem"] {
        let fit = |step: Option<f64>| {
            let mut table = toml::Table::new();
            if let Some(step) = step {
                table.insert("step".into(), format!("{step} s").into());
            }
            if method == "fem" {
                // Near its minimum on this record filter error's relaxation
                // of R moves the cost by about 1e-4 of its value from one
                // iteration to the next, and the fit needs more than the
                // default 30 iterations (measured from the model file's
                // values: 29 with the sensitivity Jacobian, 37 with whole
                // passes differenced).
                table.insert("max_iterations".into(), 60.into());
            }
            let mut layer = aeroid::estimation::estimator::MethodTables::default();
            layer.insert(method.to_string(), table);
            let problem = crate::common::registry()
                .problem(method, vec![record.clone()], structure.clone(), &[&layer])
                .unwrap();
            crate::common::registry().estimate(&problem, None).unwrap()
        };
        let auto = fit(None);
        let (note, step) = common::integration_step_note(&auto);
        assert!(
            step < 0.8 && (0.8 / step - (0.8 / step).round()).abs() < 1e-3,
            "{method}: {note}"
        );
        let coarse = fit(Some(0.8));
        println!(
            "{method}: {}; {note}; at the sample period: {}",
            auto.status, coarse.status
        );
        if method == "fem" {
            let halved = fit(Some(step / 2.0));
            let moved = common::largest_move_in_sigma(&auto, &halved);
            println!(
                "fem, step halved: {}, worst move {moved:.3}σ",
                halved.status
            );
            assert_eq!(auto.status, Status::Converged);
            assert!(
                !matches!(halved.status, Status::Diverged(_)),
                "{}",
                halved.status
            );
            assert!(
                moved <= 0.1,
                "fem: halving the step moved an estimate by {moved}σ"
            );
        } else {
            assert!(
                !matches!(auto.status, Status::Diverged(_)),
                "{method}: {}",
                auto.status
            );
            assert!(
                matches!(&coarse.status, Status::Diverged(reason) if reason.contains("departed")),
                "{method} at the sample period: {}",
                coarse.status
            );
        }
    }
}
