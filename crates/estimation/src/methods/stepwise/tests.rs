use super::*;
use aeroid_sim::aero::REGRESSOR_COUNT;

#[test]
fn candidates_parse_products_and_squares() {
    let square = Candidate::parse("alpha^2").unwrap();
    assert_eq!(square.factors, [Regressor::Alpha, Regressor::Alpha]);
    let product = Candidate::parse("alpha*de").unwrap();
    assert_eq!(product.factors, [Regressor::Alpha, Regressor::Elevator]);
    let cubic = Candidate::parse("alpha^2*de").unwrap();
    assert_eq!(
        cubic.factors,
        [Regressor::Alpha, Regressor::Alpha, Regressor::Elevator]
    );
    for bad in ["bogus", "0", "de*alpha", "alpha*0", "alpha^0"] {
        let message = Candidate::parse(bad).unwrap_err().to_string();
        assert!(
            message.contains(bad) && message.contains("alpha"),
            "{message}"
        );
    }
    let means = [0.0; REGRESSOR_COUNT];
    let mut regressors = [0.0; REGRESSOR_COUNT];
    regressors[Regressor::Alpha as usize] = 0.1;
    let mut centred = means;
    centred[Regressor::Alpha as usize] = 0.04;
    assert!((square.value(&regressors, &centred) - 0.0036).abs() < 1e-15);
}

/// The textbook case for the removal step: z = 1 + x1 + x2 with x3 =
/// x1 + x2 + small noise. x3 correlates best with z and enters first;
/// x1 and x2 follow; x3 then adds nothing and is removed (partial F < 3.9).
/// Candidates stand in as α (x1), β (x2) and δe (x3).
#[test]
fn redundant_early_term_is_removed() {
    let count = 600;
    let mut rng = aeroid_core::random::stream(3, 0);
    let mut noise =
        || -> f64 { rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng) };
    let mut regressors = Vec::with_capacity(count);
    let mut z = Vec::with_capacity(count);
    for k in 0..count {
        let (x1, x2) = ((k as f64 * 0.05).sin(), (k as f64 * 0.031).cos());
        let mut row = [0.0; REGRESSOR_COUNT];
        row[Regressor::Alpha as usize] = x1;
        row[Regressor::Beta as usize] = x2;
        row[Regressor::Elevator as usize] = x1 + x2 + 0.3 * noise();
        regressors.push(row);
        z.push(1.0 + x1 + x2 + 0.01 * noise());
    }
    let mut coefficients: [Option<Vec<f64>>; 6] = Default::default();
    coefficients[Coefficient::Pitch as usize] = Some(z);
    let data = Reconstruction {
        times: (0..count).map(|k| k as f64).collect(),
        coefficients,
        regressors,
        reference_channel: "test".into(),
        dynamic_pressure: Vec::new(),
        rate: 1.0,
        notes: Vec::new(),
    };
    let candidates: Vec<Candidate> = ["alpha", "beta", "de"]
        .iter()
        .map(|n| Candidate::parse(n).unwrap())
        .collect();
    let problem = SearchData::new(&data, Coefficient::Pitch, &candidates);
    let search = problem.search(&StepwiseOptions::default());
    let actions: Vec<(Action, Option<&str>)> = search
        .steps
        .iter()
        .map(|s| (s.action, s.term.as_deref()))
        .collect();
    assert_eq!(actions[0], (Action::Start, None));
    assert_eq!(actions[1], (Action::Enter, Some("de")));
    assert_eq!(actions.last().unwrap(), &(Action::Remove, Some("de")));
    let mut terms = search.steps.last().unwrap().terms.clone();
    terms.sort();
    assert_eq!(terms, ["alpha", "beta"]);
    assert!(
        search.stop_reason.contains("F-to-enter"),
        "{}",
        search.stop_reason
    );
}

/// The reconstruction of z(α) on a slow sine of α around 0.1 rad.
fn quadratic_data(z: impl Fn(f64, usize) -> f64) -> Reconstruction {
    let count = 400;
    let mut regressors = Vec::with_capacity(count);
    let mut values = Vec::with_capacity(count);
    for k in 0..count {
        let alpha = 0.1 + 0.05 * (k as f64 * 0.05).sin();
        let mut row = [0.0; REGRESSOR_COUNT];
        row[Regressor::Alpha as usize] = alpha;
        regressors.push(row);
        values.push(z(alpha, k));
    }
    let mut coefficients: [Option<Vec<f64>>; 6] = Default::default();
    coefficients[Coefficient::Drag as usize] = Some(values);
    Reconstruction {
        times: (0..count).map(|k| k as f64).collect(),
        coefficients,
        regressors,
        reference_channel: "test".into(),
        dynamic_pressure: Vec::new(),
        rate: 1.0,
        notes: Vec::new(),
    }
}

/// The estimates of a model, in the plain basis, with the white covariance.
fn plain_estimates(
    problem: &SearchData,
    model: &[usize],
) -> (Vec<String>, DVector<f64>, DMatrix<f64>) {
    let fit = LeastSquares::fit(&problem.matrix(model), &problem.z);
    let (terms, transform) = problem.plain_basis(model);
    let covariance = &transform * fit.white_covariance() * transform.transpose();
    (terms, &transform * &fit.theta, covariance)
}

/// Ideal data CD = 0.02 + 0.1·α + 0.8·α², α² searched mean-removed: the
/// estimates come back in the model's basis, near-exact (1e-12).
#[test]
fn squares_are_reported_in_the_plain_basis() {
    let data = quadratic_data(|alpha, _| 0.02 + 0.1 * alpha + 0.8 * alpha * alpha);
    let candidates: Vec<Candidate> = ["alpha", "alpha^2"]
        .iter()
        .map(|n| Candidate::parse(n).unwrap())
        .collect();
    let problem = SearchData::new(&data, Coefficient::Drag, &candidates);
    let (terms, theta, _) = plain_estimates(&problem, &[0, 1]);
    assert_eq!(terms, ["0", "alpha", "alpha^2"]);
    for (value, truth) in theta.iter().zip([0.02, 0.1, 0.8]) {
        assert!((value - truth).abs() < 1e-12, "{theta}");
    }
    // Only the square selected, CD = 0.02 + 0.8·(α − ᾱ)²: its linear
    // part −2ᾱ·0.8·α is carried by an added alpha term.
    let mean = problem.means[Regressor::Alpha as usize];
    let data = quadratic_data(|alpha, _| 0.02 + 0.8 * (alpha - mean).powi(2));
    let problem = SearchData::new(&data, Coefficient::Drag, &candidates[1..]);
    let (terms, theta, _) = plain_estimates(&problem, &[0]);
    assert_eq!(terms, ["0", "alpha^2", "alpha"]);
    let expected = [0.02 + 0.8 * mean * mean, 0.8, -1.6 * mean];
    for (value, truth) in theta.iter().zip(expected) {
        assert!((value - truth).abs() < 1e-12, "{theta}");
    }
}

/// A cubic searched alone, CD = 0.02 + 2·(α − ᾱ)³, comes back as the
/// plain polynomial with the square and linear terms it needs added:
/// 2·(α³ − 3ᾱα² + 3ᾱ²α − ᾱ³).
#[test]
fn cubes_are_reported_in_the_plain_basis() {
    let mean = quadratic_data(|_, _| 0.0)
        .regressors
        .iter()
        .map(|r| r[1])
        .sum::<f64>()
        / 400.0;
    let data = quadratic_data(|alpha, _| 0.02 + 2.0 * (alpha - mean).powi(3));
    let candidates = [Candidate::parse("alpha^3").unwrap()];
    let problem = SearchData::new(&data, Coefficient::Drag, &candidates);
    let (terms, theta, _) = plain_estimates(&problem, &[0]);
    assert_eq!(terms, ["0", "alpha^3", "alpha", "alpha^2"]);
    let expected = [
        0.02 - 2.0 * mean.powi(3),
        2.0,
        6.0 * mean * mean,
        -6.0 * mean,
    ];
    for (value, truth) in theta.iter().zip(expected) {
        assert!((value - truth).abs() < 1e-10, "{theta}");
    }
}

/// With noise, the transformed estimates and covariance equal those of
/// the regression on the plain regressors 1, α, α² (the same column
/// space): the covariance is transformed consistently.
#[test]
fn the_plain_basis_covariance_is_that_of_the_plain_regression() {
    let mut rng = aeroid_core::random::stream(5, 0);
    let noise: Vec<f64> = (0..400)
        .map(|_| rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng))
        .collect();
    let data =
        quadratic_data(|alpha, k| 0.02 + 0.1 * alpha + 0.8 * alpha * alpha + 1e-3 * noise[k]);
    let candidates: Vec<Candidate> = ["alpha", "alpha^2"]
        .iter()
        .map(|n| Candidate::parse(n).unwrap())
        .collect();
    let problem = SearchData::new(&data, Coefficient::Drag, &candidates);
    let (_, theta, covariance) = plain_estimates(&problem, &[0, 1]);
    let x = DMatrix::from_fn(data.times.len(), 3, |k, j| {
        data.regressors[k][Regressor::Alpha as usize].powi(j as i32)
    });
    let plain = LeastSquares::fit(&x, &problem.z);
    let plain_covariance = plain.white_covariance();
    for i in 0..3 {
        assert!((theta[i] - plain.theta[i]).abs() < 1e-9 * plain.theta[i].abs().max(1.0));
        for j in 0..3 {
            let scale = (plain_covariance[(i, i)] * plain_covariance[(j, j)]).sqrt();
            assert!(
                (covariance[(i, j)] - plain_covariance[(i, j)]).abs() < 1e-8 * scale,
                "({i}, {j}): {} vs {}",
                covariance[(i, j)],
                plain_covariance[(i, j)]
            );
        }
    }
}
