use super::*;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

/// A motion-like signal (a trend from one end value to another, a
/// 0.3 Hz oscillation, a 1.1 Hz one) plus white noise of σ = 0.01 at
/// 25 Hz for 60 s: the spectrum above 2 Hz gives σ within 5 % (the
/// estimate averages 1 500 − 2·120 − 1 = 1 259 bins of χ²₂/2 power:
/// relative σ of the variance 1/√1259 = 2.8 %, of σ 1.4 %). Without the
/// detrending the jump between the ends would leak into every bin.
/// Dropouts are bridged; a constant signal has no noise; too few
/// samples give NaN.
#[test]
fn fourier_noise_floor_recovers_white_noise() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (rate, n, sigma) = (25.0, 1500, 0.01);
    let mut values: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / rate;
            let motion = 0.3 * t / 60.0
                + 0.05 * (2.0 * std::f64::consts::PI * 0.3 * t).sin()
                + 0.02 * (2.0 * std::f64::consts::PI * 1.1 * t).cos();
            motion + sigma * rng.sample::<f64, _>(rand_distr::StandardNormal)
        })
        .collect();
    let estimate = fourier_noise_variance(&values, rate, 2.0).sqrt();
    assert!((estimate / sigma - 1.0).abs() < 0.05, "{estimate}");
    values[700] = f64::NAN;
    values[701] = f64::NAN;
    let bridged = fourier_noise_variance(&values, rate, 2.0).sqrt();
    assert!((bridged / sigma - 1.0).abs() < 0.05, "{bridged}");
    assert_eq!(fourier_noise_variance(&vec![3.0; 100], rate, 2.0), 0.0);
    assert!(fourier_noise_variance(&values[..10], rate, 2.0).is_nan());
}

/// The settled/identified/consistent judgement on hand-made histories:
/// a parameter still moving by 5σ in the last tenth is unsettled, one
/// whose σ stayed at its prior unidentified, an output with mean
/// ν²/S 2 converged with its innovations diagnosed inconsistent, and
/// everything sound converged without a diagnosis.
#[test]
fn status_names_what_is_not_settled() {
    let names = vec!["a".to_string()];
    let prior = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 1.0]));
    let history = |values: Vec<f64>, sigma: f64| History {
        names: names.clone(),
        times: (0..values.len()).map(|k| k as f64).collect(),
        sigmas: vec![vec![sigma]; values.len()],
        values: values.into_iter().map(|v| vec![v]).collect(),
    };
    let judge =
        |h: &History, ratio: f64| status_of(&prior, 1, &names, h, &[ratio], &["y".to_string()]);
    let steady = history(vec![1.0; 100], 0.01);
    assert_eq!(judge(&steady, 1.0), (Status::Converged, Vec::new()));
    let mut moving: Vec<f64> = vec![1.0; 100];
    for (k, v) in moving.iter_mut().enumerate().skip(90) {
        *v = 1.0 + 0.05 * (k - 90) as f64 / 9.0;
    }
    assert!(
        matches!(judge(&history(moving, 0.01), 1.0).0, Status::Unsettled(r) if r.contains("a"))
    );
    assert_eq!(
        judge(&history(vec![1.0; 100], 0.9), 1.0).0,
        Status::Unidentified(names.clone())
    );
    let (status, diagnoses) = judge(&steady, 2.0);
    assert_eq!(status, Status::Converged);
    assert_eq!(diagnoses.len(), 1);
    assert_eq!(diagnoses[0].kind, DiagnosisKind::InconsistentInnovations);
    assert_eq!(
        (diagnoses[0].about.clone(), diagnoses[0].measures.clone()),
        (vec!["y".to_string()], vec![2.0])
    );
}
