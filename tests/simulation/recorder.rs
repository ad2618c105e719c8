//! The recorder model: quantization, noise, sample instants, delay, lag and
//! anti-alias filter, lever-arm load factors, faults, dropouts, heading
//! wrap, determinism, and the bundled profiles.

use aeroid::record::recorder::{Profile, ProfileFile};
use aeroid::sim::Simulation;
use aeroid::sim::aircraft::Aircraft;
use aeroid::sim::dynamics::Exogenous;
use aeroid::sim::scenario::Scenario;
use aeroid::sim::state::{self, DOWN, EulerAngles, StateVector};
use aeroid::sim::trace::{TruthSample, TruthTrace};
use aeroid::units::{DEG, FOOT, STANDARD_GRAVITY};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::{PI, TAU};

/// A profile from TOML text; panics on a bad test profile.
fn profile(text: &str) -> Profile {
    let file: ProfileFile = toml::from_str(text).unwrap();
    Profile::from_file(&file, std::path::Path::new("test-profile")).unwrap()
}

/// A trace of the ATTAS whose state at time t is the trim state edited by
/// `edit`, evaluated by the flight model (so every derived quantity is
/// consistent), and `finish` applied to each sample afterwards.
fn synthetic_trace(
    duration: f64,
    step: f64,
    edit: impl Fn(f64, &mut StateVector),
    finish: impl Fn(&mut TruthSample),
) -> (TruthTrace, Aircraft) {
    let scenario = Scenario::load("attas-trim").unwrap();
    let simulation = Simulation::prepare(&scenario).unwrap();
    let exogenous = Exogenous {
        controls: simulation.trim.controls,
        ..Default::default()
    };
    let steps = (duration / step).round() as usize;
    let samples = (0..=steps)
        .map(|k| {
            let time = k as f64 * step;
            let mut x = simulation.trim.state;
            edit(time, &mut x);
            let evaluation = simulation.model.evaluate(&x, &exogenous);
            let mut sample = TruthSample::new(time, x, evaluation, Default::default());
            finish(&mut sample);
            sample
        })
        .collect();
    let trace = TruthTrace {
        scenario: "synthetic".into(),
        step,
        samples,
    };
    (trace, scenario.aircraft)
}

fn altitude_trace(
    duration: f64,
    step: f64,
    altitude: impl Fn(f64) -> f64,
) -> (TruthTrace, Aircraft) {
    synthetic_trace(duration, step, |t, x| x[DOWN] = -altitude(t), |_| {})
}

fn chi_squared(dof: f64) -> ChiSquared {
    ChiSquared::new(dof).unwrap()
}

/// Quantization to 1 ft: every error within ±LSB/2, and over 10 001 samples
/// of a ramp the errors are uniform on [−LSB/2, LSB/2]: the chi-square
/// statistic of 10 equal bins stays below the 99.9 % quantile (9 dof), and
/// the error variance is LSB²/12 within 5 %.
#[test]
fn quantization_error_is_bounded_and_uniform() {
    let ramp = |t: f64| 1000.0 + 7.3 * t;
    let (trace, aircraft) = altitude_trace(1000.0, 0.1, ramp);
    let profile = profile(
        r#"name = "quantized"
        [[channels]]
        name = "altitude"
        rate = "10 Hz"
        resolution = "1 ft""#,
    );
    let record = profile.record(&trace, &aircraft, 7).unwrap();
    let channel = record.channel("altitude").unwrap();
    let lsb = FOOT;
    let errors: Vec<f64> = channel
        .times
        .iter()
        .zip(&channel.values)
        .map(|(&t, &v)| v - ramp(t))
        .collect();
    assert_eq!(errors.len(), 10_001);
    assert!(errors.iter().all(|e| e.abs() <= lsb / 2.0 + 1e-9));
    let bins = 10;
    let mut counts = vec![0.0; bins];
    for e in &errors {
        let bin = (((e / lsb) + 0.5) * bins as f64)
            .floor()
            .clamp(0.0, bins as f64 - 1.0);
        counts[bin as usize] += 1.0;
    }
    let expected = errors.len() as f64 / bins as f64;
    let statistic: f64 = counts
        .iter()
        .map(|c| (c - expected).powi(2) / expected)
        .sum();
    let limit = chi_squared((bins - 1) as f64).inverse_cdf(0.999);
    assert!(
        statistic < limit,
        "chi-square {statistic} ≥ {limit}: {counts:?}"
    );
    let variance = errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64;
    assert!(
        (variance / (lsb * lsb / 12.0) - 1.0).abs() < 0.05,
        "variance {variance}"
    );
}

/// White noise of σ = 2 m: the sample standard deviation s of
/// (recorded − truth) over n = 10 001 samples satisfies
/// χ²(0.005) ≤ (n − 1)·s²/σ² ≤ χ²(0.995) with n − 1 degrees of freedom.
#[test]
fn noise_standard_deviation_matches_sigma() {
    let sigma = 2.0;
    let (trace, aircraft) = altitude_trace(400.0, 0.04, |t| 3000.0 + 0.5 * t);
    let profile = profile(
        r#"name = "noisy"
        [[channels]]
        name = "altitude"
        rate = "25 Hz"
        noise = "2 m""#,
    );
    let record = profile.record(&trace, &aircraft, 11).unwrap();
    let channel = record.channel("altitude").unwrap();
    let errors: Vec<f64> = channel
        .times
        .iter()
        .zip(&channel.values)
        .map(|(&t, &v)| v - (3000.0 + 0.5 * t))
        .collect();
    let n = errors.len() as f64;
    assert_eq!(errors.len(), 10_001);
    let mean = errors.iter().sum::<f64>() / n;
    let variance = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let statistic = (n - 1.0) * variance / (sigma * sigma);
    let distribution = chi_squared(n - 1.0);
    let (low, high) = (
        distribution.inverse_cdf(0.005),
        distribution.inverse_cdf(0.995),
    );
    assert!(
        (low..=high).contains(&statistic),
        "(n−1)s²/σ² = {statistic} outside [{low}, {high}]"
    );
}

/// Coloured noise, σ = 2 m with a correlation time of 0.4 s at 25 Hz
/// (a = exp(−0.04/0.4) = 0.905): over 10 001 samples the noise's lag-1
/// autocorrelation is a within 4 standard errors of its estimate,
/// √((1 − a²)/n) = 0.0043, and its variance σ² within 10 % (the
/// effective number of independent samples is n·(1 − a)/(1 + a) ≈ 500,
/// so the variance's relative standard error is √(2/500) = 6.3 %). The
/// white profile's draws are the
/// same: noise_time 0 leaves a record bit for bit as it was.
#[test]
fn coloured_noise_has_its_correlation_time() {
    let (trace, aircraft) = altitude_trace(400.0, 0.04, |t| 3000.0 + 0.5 * t);
    let spec = |extra: &str| {
        profile(&format!(
            "name = \"noisy\"\n[[channels]]\nname = \"altitude\"\nrate = \"25 Hz\"\nnoise = \"2 m\"\n{extra}"
        ))
    };
    let errors = |profile: &Profile| -> Vec<f64> {
        let record = profile.record(&trace, &aircraft, 11).unwrap();
        let channel = record.channel("altitude").unwrap();
        channel
            .times
            .iter()
            .zip(&channel.values)
            .map(|(&t, &v)| v - (3000.0 + 0.5 * t))
            .collect()
    };
    let coloured = errors(&spec("noise_time = \"0.4 s\""));
    let n = coloured.len() as f64;
    let a = (-0.04_f64 / 0.4).exp();
    let variance = coloured.iter().map(|e| e * e).sum::<f64>() / n;
    let lag_one = coloured.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (n * variance);
    let standard_error = ((1.0 - a * a) / n).sqrt();
    assert!(
        (lag_one - a).abs() < 4.0 * standard_error,
        "lag-1 autocorrelation {lag_one} against {a}"
    );
    assert!(
        (variance / 4.0 - 1.0).abs() < 0.1,
        "variance {variance} against 4 m²"
    );
    assert_eq!(errors(&spec("noise_time = \"0 s\"")), errors(&spec("")));
}

/// Bias and scale factor: recorded = k·truth + b exactly (no noise).
#[test]
fn bias_and_scale_factor_are_applied() {
    let (trace, aircraft) = altitude_trace(10.0, 0.1, |t| 2000.0 + 10.0 * t);
    let profile = profile(
        r#"name = "biased"
        [[channels]]
        name = "altitude"
        rate = "5 Hz"
        bias = "100 ft"
        scale_factor = 1.02"#,
    );
    let record = profile.record(&trace, &aircraft, 0).unwrap();
    let channel = record.channel("altitude").unwrap();
    for (&t, &v) in channel.times.iter().zip(&channel.values) {
        let expected = 1.02 * (2000.0 + 10.0 * t) + 100.0 * FOOT;
        assert!((v - expected).abs() < 1e-9, "t = {t}: {v} vs {expected}");
    }
}

/// Sample instants are exactly t = phase + slot·frame + k/rate, with the
/// slot given as a fraction or as word/words_per_frame, for fast and slow rates.
#[test]
fn sample_instants_follow_rate_phase_and_word_slot() {
    let (trace, aircraft) = altitude_trace(200.0, 0.05, |t| 1000.0 + 3.0 * t);
    let profile = profile(
        r#"name = "skewed"
        frame = "2 s"
        words_per_frame = 256
        [[channels]]
        name = "altitude"
        rate = "4 Hz"
        word = 37
        [[channels]]
        name = "pitch"
        rate = "1/64 Hz"
        phase = "6 s"
        slot = 0.25
        [[channels]]
        name = "roll"
        rate = "0.5"
        [[channels]]
        name = "mach"
        rate = "1/36 Hz"
        word = 255"#,
    );
    let record = profile.record(&trace, &aircraft, 0).unwrap();
    let expected = |offset: f64, rate: f64| -> Vec<f64> {
        (0..)
            .map(|k| offset + k as f64 / rate)
            .take_while(|&t| t <= 200.0)
            .collect()
    };
    let cases = [
        ("altitude", 2.0 * 37.0 / 256.0, 4.0),
        ("pitch", 6.0 + 0.25 * 2.0, 1.0 / 64.0),
        ("roll", 0.0, 0.5),
        ("mach", 2.0 * 255.0 / 256.0, 1.0 / 36.0),
    ];
    for (name, offset, rate) in cases {
        let channel = record.channel(name).unwrap();
        assert_eq!(channel.times, expected(offset, rate), "{name}");
        assert_eq!(channel.rate, rate);
    }
    assert_eq!(
        record.channel("pitch").unwrap().times,
        vec![6.5, 70.5, 134.5, 198.5]
    );
    // The value is the truth at the channel's own instant, not the frame's.
    let altitude = record.channel("altitude").unwrap();
    for (&t, &v) in altitude.times.iter().zip(&altitude.values) {
        assert!((v - (1000.0 + 3.0 * t)).abs() < 1e-9);
    }
}

/// Least-squares amplitude and phase of `values − mean` against sin(ωt).
fn amplitude_and_phase(times: &[f64], values: &[f64], omega: f64, mean: f64) -> (f64, f64) {
    let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&t, &v) in times.iter().zip(values) {
        let (s, c) = (omega * t).sin_cos();
        let y = v - mean;
        ss += s * s;
        sc += s * c;
        cc += c * c;
        ys += y * s;
        yc += y * c;
    }
    let determinant = ss * cc - sc * sc;
    let a = (ys * cc - yc * sc) / determinant;
    let b = (yc * ss - ys * sc) / determinant;
    (a.hypot(b), b.atan2(a))
}

fn sinusoid_record(spec: &str, frequency: f64, skip: f64) -> (f64, f64) {
    let omega = TAU * frequency;
    let (trace, aircraft) = altitude_trace(40.0, 0.01, |t| 1000.0 + 10.0 * (omega * t).sin());
    let profile = profile(&format!(
        "name = \"dynamic\"\n[[channels]]\nname = \"altitude\"\nrate = \"20 Hz\"\n{spec}"
    ));
    let record = profile.record(&trace, &aircraft, 0).unwrap();
    let channel = record.channel("altitude").unwrap();
    let (times, values): (Vec<f64>, Vec<f64>) = channel
        .times
        .iter()
        .zip(&channel.values)
        .filter(|(t, _)| **t >= skip)
        .map(|(t, v)| (*t, *v))
        .unzip();
    let (amplitude, phase) = amplitude_and_phase(&times, &values, omega, 1000.0);
    (amplitude / 10.0, phase)
}

/// A 0.3 s delay shifts a 0.5 Hz sinusoid by −ω·0.3 = −0.942 rad (within
/// 1e-4 rad; linear interpolation of the 100 Hz truth) at unchanged amplitude.
#[test]
fn delay_shifts_a_sinusoid_by_the_right_phase() {
    let (gain, phase) = sinusoid_record("delay = \"0.3 s\"", 0.5, 0.3);
    assert!((phase + TAU * 0.5 * 0.3).abs() < 1e-4, "phase {phase}");
    assert!((gain - 1.0).abs() < 1e-4, "gain {gain}");
}

/// A first-order lag of τ = 0.2 s on a 0.5 Hz sinusoid: gain 1/√(1 + (ωτ)²)
/// and phase −atan(ωτ) once the start transient (5τ) has died out.
#[test]
fn sensor_lag_has_first_order_gain_and_phase() {
    let (tau, omega) = (0.2, TAU * 0.5);
    let (gain, phase) = sinusoid_record("lag = \"0.2 s\"", 0.5, 10.0);
    assert!(
        (gain - 1.0 / (1.0 + (omega * tau).powi(2)).sqrt()).abs() < 1e-4,
        "gain {gain}"
    );
    assert!((phase + (omega * tau).atan()).abs() < 1e-4, "phase {phase}");
}

/// The anti-alias filter (2nd-order Butterworth) passes its cut-off frequency
/// at −3 dB (gain 1/√2 within 1e-3) with a 90° phase lag (within 0.01 rad).
#[test]
fn anti_alias_filter_is_minus_3_db_at_cutoff() {
    let (gain, phase) = sinusoid_record("anti_alias = \"2 Hz\"", 2.0, 10.0);
    assert!((gain - 0.5_f64.sqrt()).abs() < 1e-3, "gain {gain}");
    assert!((phase + PI / 2.0).abs() < 0.01, "phase {phase}");
}

/// In a steady roll (p constant, q = r = 0, no angular acceleration) an
/// accelerometer at r = (x, y, z) reads the CG specific force plus the
/// centripetal term ω×(ω×r) = (0, −p²y, −p²z): nx = f_x/g0,
/// ny = (f_y − p²y)/g0, nz = −(f_z − p²z)/g0 (nz positive up).
#[test]
fn load_factors_at_offset_sensor_follow_lever_arm_in_steady_roll() {
    let roll_rate = 0.5;
    let (trace, aircraft) = synthetic_trace(
        2.0,
        0.01,
        |_, x| {
            x[state::P] = roll_rate;
            x[state::Q] = 0.0;
            x[state::R] = 0.0;
        },
        |s| s.evaluation.angular_acceleration = Default::default(),
    );
    let profile = profile(
        r#"name = "lever"
        [[channels]]
        name = "nx"
        rate = "50 Hz"
        position = ["3 m", "1.5 m", "-0.8 m"]
        [[channels]]
        name = "ny"
        rate = "50 Hz"
        position = ["3 m", "1.5 m", "-0.8 m"]
        [[channels]]
        name = "nz"
        rate = "50 Hz"
        position = ["3 m", "1.5 m", "-0.8 m"]"#,
    );
    let record = profile.record(&trace, &aircraft, 0).unwrap();
    let f = trace.samples[0].evaluation.specific_force;
    let p2 = roll_rate * roll_rate;
    let expected = [
        ("nx", f.x / STANDARD_GRAVITY),
        ("ny", (f.y - p2 * 1.5) / STANDARD_GRAVITY),
        ("nz", -(f.z - p2 * -0.8) / STANDARD_GRAVITY),
    ];
    for (name, value) in expected {
        let channel = record.channel(name).unwrap();
        assert_eq!(channel.values.len(), 101);
        for v in &channel.values {
            assert!((v - value).abs() < 1e-12, "{name}: {v} vs {value}");
        }
    }
    // The lever arm matters: ny differs from the CG value by p²y/g0 = 0.038.
    assert!((expected[1].1 - f.y / STANDARD_GRAVITY).abs() > 0.03);
}

/// Seed 000's faulty AoA reads only its two levels; a stuck channel holds its
/// last good sample; dropouts are NaN at the configured rate (99 % binomial range).
#[test]
fn faults_and_dropouts() {
    let (trace, aircraft) = altitude_trace(400.0, 0.1, |t| 1000.0 + t);
    let profile = profile(
        r#"name = "faulty"
        [[channels]]
        name = "alpha"
        rate = "1/2 Hz"
        fault = { kind = "levels", values = ["109.70 deg", "108.30 deg"] }
        [[channels]]
        name = "altitude"
        rate = "1 Hz"
        fault = { kind = "stuck", from = "100 s" }
        [[channels]]
        name = "pitch"
        rate = "25 Hz"
        dropout = 0.1"#,
    );
    let record = profile.record(&trace, &aircraft, 3).unwrap();
    let alpha = &record.channel("alpha").unwrap().values;
    let levels = [109.70 * DEG, 108.30 * DEG];
    assert!(alpha.iter().all(|v| levels.contains(v)));
    assert!(levels.iter().all(|level| alpha.contains(level)));
    let altitude = record.channel("altitude").unwrap();
    for (&t, &v) in altitude.times.iter().zip(&altitude.values) {
        let expected = if t >= 100.0 { 1099.0 } else { 1000.0 + t };
        assert!((v - expected).abs() < 1e-9, "t = {t}: {v}");
    }
    let pitch = record.channel("pitch").unwrap();
    let n = pitch.values.len() as f64;
    let lost = pitch.dropouts() as f64;
    let sigma = (n * 0.1 * 0.9).sqrt();
    assert!((lost - 0.1 * n).abs() < 2.576 * sigma, "{lost} of {n} lost");
}

/// Headings are recorded in [0, 2π) and unwrapped before filtering: a lagged
/// heading sweeping through north never reads anything near south.
#[test]
fn heading_through_north_wraps_without_spikes() {
    let (trace, aircraft) = synthetic_trace(
        20.0,
        0.01,
        |t, x| {
            let euler = EulerAngles {
                roll: 0.0,
                pitch: 0.05,
                yaw: -0.2 + 0.02 * t,
            };
            state::set_attitude(x, &state::quaternion_from_euler(euler));
        },
        |_| {},
    );
    let profile = profile(
        r#"name = "heading"
        [[channels]]
        name = "yaw"
        rate = "10 Hz"
        lag = "0.5 s"
        resolution = "0.3 deg""#,
    );
    let record = profile.record(&trace, &aircraft, 0).unwrap();
    let yaw = &record.channel("yaw").unwrap().values;
    assert!(yaw.iter().all(|v| (0.0..TAU).contains(v)));
    assert!(yaw.iter().all(|v| v.min(TAU - v) < 0.25), "{yaw:?}");
    assert!(yaw.iter().any(|v| *v > PI) && yaw.iter().any(|v| *v < PI));
}

/// The same seed gives the same record bit for bit; another seed does not.
#[test]
fn records_are_bit_identical_for_a_seed() {
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario.duration = 5.0;
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let bits = |seed: u64| -> Vec<u64> {
        let record = profile.record(&trace, &scenario.aircraft, seed).unwrap();
        record
            .channels
            .iter()
            .flat_map(|c| c.times.iter().chain(&c.values).map(|v| v.to_bits()))
            .collect()
    };
    assert_eq!(bits(42), bits(42));
    assert_ne!(bits(42), bits(43));
}

/// The Monte Carlo sweep modifiers. Scaling the noise scales every sample's
/// noise exactly (same seed, same draws; the flight-test profile has no
/// quantization): noise(2) − noise(0) = 2·(noise(1) − noise(0)) to rounding
/// (headings modulo 2π),
/// and scale 0 is the noise-free record. Overriding the rate samples every
/// channel at it: 5 s at 10 Hz is 51 samples, 0.1 s apart.
#[test]
fn noise_scale_and_rate_override_modify_the_profile() {
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario.duration = 5.0;
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let values = |profile: &Profile| -> Vec<Vec<f64>> {
        let record = profile.record(&trace, &scenario.aircraft, 7).unwrap();
        record.channels.iter().map(|c| c.values.clone()).collect()
    };
    let (clean, once, twice) = (
        values(&profile.with_noise_scaled(0.0)),
        values(&profile),
        values(&profile.with_noise_scaled(2.0)),
    );
    let mut largest_noise = 0.0_f64;
    for (k, model) in profile.channels.iter().enumerate() {
        // Differences of headings, which wrap at 2π, are taken within ±π.
        let minus = |a: f64, b: f64| match model.measurand.wraps {
            true => (a - b + PI).rem_euclid(TAU) - PI,
            false => a - b,
        };
        for ((&c, &o), &t) in clean[k].iter().zip(&once[k]).zip(&twice[k]) {
            let noise = minus(o, c);
            largest_noise = largest_noise.max(noise.abs());
            assert!(
                (minus(t, c) - 2.0 * noise).abs() <= 1e-9 * (1.0 + c.abs()),
                "{c} {o} {t}"
            );
        }
    }
    assert!(largest_noise > 0.0, "the profile has noise to scale");
    let slow = profile.with_rate(10.0);
    assert!(slow.name.contains("@10Hz"));
    let record = slow.record(&trace, &scenario.aircraft, 7).unwrap();
    for channel in &record.channels {
        assert_eq!(
            (channel.rate, channel.times.len()),
            (10.0, 51),
            "{}",
            channel.name
        );
        assert!((channel.times[1] - channel.times[0] - 0.1).abs() < 1e-12);
    }
}

/// The QAR profile records exactly Wang et al. 2012, Table 1: 35 channels with its rates.
#[test]
fn qar_profile_has_table_1_channels_and_rates() {
    let profile = Profile::load("qar-seed000", None).unwrap();
    let rates: Vec<(&str, f64)> = profile
        .channels
        .iter()
        .map(|c| (c.measurand.name, c.rate))
        .collect();
    let (slow, quarter, half, mach) = (1.0 / 64.0, 0.25, 0.5, 1.0 / 36.0);
    let expected = [
        ("gross_weight", slow),
        ("exhaust_gas_temperature_left", 1.0),
        ("exhaust_gas_temperature_right", 1.0),
        ("fuel_flow_left", 1.0),
        ("fuel_flow_right", 1.0),
        ("n2_left", quarter),
        ("n2_right", quarter),
        ("nx", 1.0),
        ("ny", 1.0),
        ("nz", 1.0),
        ("pitch", 1.0),
        ("yaw", 1.0),
        ("roll", 1.0),
        ("ground_speed", 1.0),
        ("flight_path_angle", 1.0),
        ("track", 1.0),
        ("latitude", 1.0),
        ("longitude", 1.0),
        ("north", quarter),
        ("east", quarter),
        ("pressure_altitude", 1.0),
        ("elevator_left", 1.0),
        ("elevator_right", 1.0),
        ("flap_left", half),
        ("flap_right", half),
        ("rudder", 1.0),
        ("aileron_left", 1.0),
        ("aileron_right", 1.0),
        ("total_air_temperature", 1.0),
        ("baro_corrected_altitude", slow),
        ("calibrated_airspeed", 1.0),
        ("mach", mach),
        ("alpha", half),
        ("wind_speed", quarter),
        ("wind_direction", quarter),
    ];
    assert_eq!(rates, expected);
    assert!(
        ["p", "q", "r"]
            .iter()
            .all(|r| profile.absent.contains(&r.to_string()))
    );
}

/// The ideal profile has every quantity the recorder can produce, error-free.
#[test]
fn ideal_profile_records_every_measurand_without_error() {
    let profile = Profile::load("ideal", None).unwrap();
    let names: Vec<&str> = profile.channels.iter().map(|c| c.measurand.name).collect();
    let all: Vec<&str> = aeroid::record::derived::MEASURANDS
        .iter()
        .map(|m| m.name)
        .collect();
    assert_eq!(names, all);
    for c in &profile.channels {
        assert!(c.noise == 0.0 && c.bias == 0.0 && c.scale_factor == 1.0 && c.delay == 0.0);
        assert!(c.resolution.is_none() && c.fault.is_none() && c.dropout == 0.0 && c.lag == 0.0);
    }
}

/// A bad profile reports every problem at once, each with its field.
#[test]
fn bad_profile_reports_every_problem() {
    let text = r#"name = "bad"
        absent = ["warp_speed", "pitch"]
        [[channels]]
        name = "pitch"
        rate = "1/64 kt"
        noise = "-1 deg"
        slot = 1.5
        position = [0, 0, 1]
        [[channels]]
        name = "warp"
        rate = 1
        [[channels]]
        name = "roll"
        rate = 0
        word = 3
        dropout = 1.5
        saturation = ["10 deg", "-10 deg"]"#;
    let file: ProfileFile = toml::from_str(text).unwrap();
    let error = Profile::from_file(&file, std::path::Path::new("bad.toml")).unwrap_err();
    let message = error.to_string();
    for expected in [
        "channels.pitch.rate",
        "channels.pitch.noise",
        "channels.pitch.slot",
        "channels.pitch.position",
        "channels.warp.name",
        "channels.roll.rate",
        "channels.roll.word",
        "channels.roll.dropout",
        "channels.roll.saturation",
        "unknown quantity 'warp_speed'",
        "'pitch' is also recorded",
    ] {
        assert!(
            message.contains(expected),
            "missing '{expected}' in:\n{message}"
        );
    }
}
