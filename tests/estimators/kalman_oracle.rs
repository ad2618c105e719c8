//! The filters against an independent linear Kalman filter and RTS
//! smoother (the `adskalman` crate) on a linear time-invariant model: the
//! ATTAS lateral-directional motion (v, p, r, φ) linearised at trim
//! ([`aeroid::analysis::linearize`]), driven by process noise and measured
//! with noise. On such a model aeroid's extended Kalman filter
//! ([`aeroid::estimation::solver::extended_kalman`]) is a linear Kalman
//! filter (the linear model's step is exact, so Φ = e^{A·h} is both its
//! step and its linearisation) and its smoothers are the linear ones; the
//! two implementations share nothing but nalgebra. Agreement to 1e-9
//! relative is what double-precision arithmetic leaves after a 1 500-step
//! recursion of 4 × 4 products (both use Joseph's form; the residual
//! differences, ~1e-13, come from the order of operations).

use adskalman::{
    KalmanFilterNoControl, ObservationModel, StateAndCovariance, TransitionModelLinearNoControl,
};
use aeroid::analysis::linearize::{self, LATERAL};
use aeroid::estimation::model::linear::LinearStateSpace;
use aeroid::estimation::model::observations::Observations;
use aeroid::estimation::solver::extended_kalman::{self, Noise, Pass};
use aeroid::estimation::solver::unscented_kalman;
use aeroid::numerics::kalman::{self, Gaussian};
use aeroid::sim::Simulation;
use aeroid::sim::scenario::Scenario;
use nalgebra::{DMatrix, DVector, SMatrix, SVector, U4};
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

type Matrix4 = SMatrix<f64, 4, 4>;
type Vector4 = SVector<f64, 4>;
/// adskalman's estimates at grid points 1 … N.
type Estimates = Vec<StateAndCovariance<f64, U4>>;

const STEP: f64 = 0.04;
const POINTS: usize = 1500;

/// The lateral block of ATTAS's linearisation at its trim (103 m/s, 4877 m).
fn attas_lateral() -> DMatrix<f64> {
    let scenario = Scenario::load("attas-trim").unwrap();
    let simulation = Simulation::prepare(&scenario).unwrap();
    let linear = linearize::linearize(&simulation.model, &simulation.trim, &simulation.winds[0]);
    linear.block(&LATERAL, &LATERAL)
}

/// The case: the model, its noise and a noisy free response to a sideslip.
struct Case {
    model: LinearStateSpace,
    noise: Noise,
    observations: Observations,
    initial: Gaussian,
    discrete: kalman::Discrete,
}

fn case() -> Case {
    let a = attas_lateral();
    let inputs = vec![DVector::zeros(1); POINTS];
    let model = LinearStateSpace::new(
        [
            a.clone(),
            DMatrix::zeros(4, 1),
            DMatrix::identity(4, 4),
            DMatrix::zeros(4, 1),
        ],
        Vec::new(),
        0.0,
        STEP,
        inputs,
    )
    .unwrap();
    // Turbulence-like process noise on the side velocity and rates.
    let process = DMatrix::from_diagonal(&DVector::from_vec(vec![0.5, 1e-4, 1e-4, 0.0]));
    let measurement: DVector<f64> = DVector::from_vec(vec![0.04, 1e-6, 1e-6, 1e-5]);
    let discrete = kalman::discretise(&a, &DMatrix::zeros(4, 0), Some(&process), STEP);
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let mut gaussian = || rng.sample::<f64, _>(StandardNormal);
    let root = discrete.process_noise.clone().cholesky().unwrap().unpack();
    let mut x = DVector::from_vec(vec![2.0, 0.01, -0.01, 0.03]);
    let mut at = Vec::with_capacity(POINTS);
    for _ in 0..POINTS {
        at.push(
            (0..4)
                .map(|i| (i, x[i] + measurement[i].sqrt() * gaussian()))
                .collect(),
        );
        let w = DVector::from_fn(4, |_, _| gaussian());
        x = &discrete.transition * &x + &root * w;
    }
    let observations = Observations {
        names: ["v", "p", "r", "roll"].map(String::from).to_vec(),
        at,
        moved: 0,
    };
    Case {
        model,
        noise: Noise {
            process,
            measurement,
        },
        observations,
        initial: Gaussian {
            mean: DVector::zeros(4),
            covariance: DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, 1e-3, 1e-3, 1e-2])),
        },
        discrete,
    }
}

struct Transition {
    f: Matrix4,
    ft: Matrix4,
    q: Matrix4,
}

impl TransitionModelLinearNoControl<f64, U4> for Transition {
    fn F(&self) -> &Matrix4 {
        &self.f
    }
    fn FT(&self) -> &Matrix4 {
        &self.ft
    }
    fn Q(&self) -> &Matrix4 {
        &self.q
    }
}

struct Observation {
    h: Matrix4,
    r: Matrix4,
}

impl ObservationModel<f64, U4, U4> for Observation {
    fn H(&self) -> &Matrix4 {
        &self.h
    }
    fn HT(&self) -> &Matrix4 {
        &self.h
    }
    fn R(&self) -> &Matrix4 {
        &self.r
    }
}

fn fixed(m: &DMatrix<f64>) -> Matrix4 {
    Matrix4::from_fn(|i, j| m[(i, j)])
}

fn relative(a: &[f64], b: &[f64]) -> f64 {
    let difference: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let scale: f64 = b.iter().map(|y| y * y).sum();
    (difference / scale.max(1e-300)).sqrt()
}

/// aeroid's pass and adskalman's filtered and smoothed estimates for grid
/// points 1 … N (adskalman starts from aeroid's estimate at point 0 and
/// predicts before every update).
fn both() -> (Case, Pass, Estimates, Estimates) {
    let case = case();
    let pass = extended_kalman::filter(
        &case.model,
        &[],
        case.initial.clone(),
        &case.noise,
        &case.observations,
    )
    .unwrap();
    let transition = Transition {
        f: fixed(&case.discrete.transition),
        ft: fixed(&case.discrete.transition.transpose()),
        q: fixed(&case.discrete.process_noise),
    };
    let observation = Observation {
        h: Matrix4::identity(),
        r: Matrix4::from_diagonal(&Vector4::from_iterator(
            case.noise.measurement.iter().copied(),
        )),
    };
    let filter = KalmanFilterNoControl::new(&transition, &observation);
    let start = StateAndCovariance::new(
        Vector4::from_iterator(pass.filtered.get(0).unwrap().mean.iter().copied()),
        fixed(&pass.filtered.get(0).unwrap().covariance.into_owned()),
    );
    let measurements: Vec<Vector4> = case.observations.at[1..]
        .iter()
        .map(|point| Vector4::from_iterator(point.iter().map(|&(_, z)| z)))
        .collect();
    let filtered = filter.filter(&start, &measurements).unwrap();
    let smoothed = filter.smooth(&start, &measurements).unwrap();
    (case, pass, filtered, smoothed)
}

#[test]
fn extended_filter_on_a_linear_model_is_the_linear_kalman_filter() {
    let (_, pass, filtered, _) = both();
    let mut worst: (f64, f64) = (0.0, 0.0);
    for (ours, theirs) in pass.filtered.to_vec()[1..].iter().zip(&filtered) {
        worst.0 = worst
            .0
            .max(relative(ours.mean.as_slice(), theirs.state().as_slice()));
        worst.1 = worst.1.max(relative(
            ours.covariance.as_slice(),
            theirs.covariance().as_slice(),
        ));
    }
    assert!(
        worst.0 < 1e-9 && worst.1 < 1e-9,
        "worst relative errors {worst:?}"
    );
}

#[test]
fn rts_and_mbf_smoothers_are_the_linear_rts_smoother() {
    let (_, pass, _, smoothed) = both();
    let rts = kalman::rts_smooth(&pass.filtered, &pass.predicted, &pass.transitions).unwrap();
    let mbf = kalman::mbf_smooth(&pass.predicted, &pass.measured, &pass.transitions);
    for (name, ours) in [("RTS", &rts), ("MBF", &mbf)] {
        let mut worst: (f64, f64) = (0.0, 0.0);
        for (ours, theirs) in ours[1..].iter().zip(&smoothed) {
            worst.0 = worst
                .0
                .max(relative(ours.mean.as_slice(), theirs.state().as_slice()));
            worst.1 = worst.1.max(relative(
                ours.covariance.as_slice(),
                theirs.covariance().as_slice(),
            ));
        }
        assert!(
            worst.0 < 1e-9 && worst.1 < 1e-9,
            "{name}: worst relative errors {worst:?}"
        );
    }
}

#[test]
fn innovations_of_the_right_model_are_white_and_match_their_variance() {
    // With the model that generated the data, the innovations are white
    // (Jategaonkar §5.2) and ν²/S averages 1: over 1 500 samples its mean
    // has a standard error of √(2/1500) = 0.037, so 1 ± 0.15 is 4σ.
    let (_, pass, _, _) = both();
    for (output, innovations) in pass.innovations.iter().enumerate() {
        let values: Vec<f64> = innovations.iter().map(|i| i.value).collect();
        let whiteness = kalman::whiteness(&values, 40);
        assert!(whiteness >= 0.9, "output {output}: {whiteness}");
        let normalised = innovations
            .iter()
            .map(|i| i.value * i.value / i.variance)
            .sum::<f64>()
            / innovations.len() as f64;
        assert!(
            (normalised - 1.0).abs() < 0.15,
            "output {output}: {normalised}"
        );
    }
}

/// adskalman's filtered estimates for grid points 1 … N of `case` from
/// `start` (aeroid's estimate at point 0), with the discrete transition Φ
/// and process noise `process_noise`.
fn linear_filter(case: &Case, start: &Gaussian, process_noise: &DMatrix<f64>) -> Estimates {
    let transition = Transition {
        f: fixed(&case.discrete.transition),
        ft: fixed(&case.discrete.transition.transpose()),
        q: fixed(process_noise),
    };
    let observation = Observation {
        h: Matrix4::identity(),
        r: Matrix4::from_diagonal(&Vector4::from_iterator(
            case.noise.measurement.iter().copied(),
        )),
    };
    let filter = KalmanFilterNoControl::new(&transition, &observation);
    let start = StateAndCovariance::new(
        Vector4::from_iterator(start.mean.iter().copied()),
        fixed(&start.covariance),
    );
    let measurements: Vec<Vector4> = case.observations.at[1..]
        .iter()
        .map(|point| Vector4::from_iterator(point.iter().map(|&(_, z)| z)))
        .collect();
    filter.filter(&start, &measurements).unwrap()
}

/// The worst relative errors of the means and covariances of `ours`
/// (points 1 … N) against `theirs`.
fn worst_of(ours: &[Gaussian], theirs: impl Iterator<Item = (Vec<f64>, Vec<f64>)>) -> (f64, f64) {
    let mut worst: (f64, f64) = (0.0, 0.0);
    for (ours, (mean, covariance)) in ours[1..].iter().zip(theirs) {
        worst.0 = worst.0.max(relative(ours.mean.as_slice(), &mean));
        worst.1 = worst
            .1
            .max(relative(ours.covariance.as_slice(), &covariance));
    }
    worst
}

/// The square-root UKF on the linear model is the linear Kalman filter,
/// for the method's default α = 0.5 (W₀ᶜ = −0.25: the zeroth
/// sigma point a Cholesky downdate) and α = 1 (W₀ᶜ = 2: an update). The
/// unscented transform is exact on a linear step, so its statistical
/// transition is Φ = e^{A·h}; its process noise is the trapezoidal
/// (Q_c + Φ·Q_c·Φᵀ)·h/2 (module header of `unscented_kalman`), which is
/// what adskalman is given here. Without process noise the same pass is
/// checked against aeroid's EKF. Both to 1e-9 relative, as the EKF
/// against adskalman above: what is left after 1 500 steps of rounding in
/// two different orders of operations (measured: 6e-14 against
/// adskalman; against the EKF 4e-13 for the mean and 2e-11 for the
/// covariance, which without process noise shrinks by orders of magnitude
/// over the record while the rounding of its factors does not).
/// One pass of the square-root UKF over the case with sigma-point spread `alpha`.
fn unscented_pass(case: &Case, alpha: f64) -> aeroid::estimation::solver::extended_kalman::Pass {
    let unscented = kalman::Unscented {
        alpha,
        ..kalman::Unscented::default()
    };
    unscented_kalman::filter(
        &case.model,
        &[],
        case.initial.clone(),
        &case.noise,
        &case.observations,
        &unscented,
    )
    .unwrap()
}

#[test]
fn square_root_unscented_filter_on_a_linear_model_is_the_linear_kalman_filter() {
    let mut case = case();
    let h = STEP;
    let phi = &case.discrete.transition;
    let trapezoidal =
        (&case.noise.process + phi * &case.noise.process * phi.transpose()) * (0.5 * h);
    for alpha in [0.5, 1.0] {
        let pass = unscented_pass(&case, alpha);
        let filtered = linear_filter(
            &case,
            &pass.filtered.get(0).unwrap().to_gaussian(),
            &trapezoidal,
        );
        let worst = worst_of(
            &pass.filtered.to_vec(),
            filtered.iter().map(|e| {
                (
                    e.state().as_slice().to_vec(),
                    e.covariance().as_slice().to_vec(),
                )
            }),
        );
        println!("α {alpha}, against adskalman: worst relative errors {worst:?}");
        assert!(
            worst.0 < 1e-9 && worst.1 < 1e-9,
            "α {alpha}: worst relative errors {worst:?}"
        );
        for (ours, theirs) in pass.transitions.iter().zip(std::iter::repeat(phi)).take(10) {
            let error = (ours - theirs).norm() / theirs.norm();
            assert!(error < 1e-9, "α {alpha}: transition {error:e}");
        }
    }
    case.noise.process = DMatrix::zeros(4, 4);
    let extended = extended_kalman::filter(
        &case.model,
        &[],
        case.initial.clone(),
        &case.noise,
        &case.observations,
    )
    .unwrap();
    for alpha in [0.5, 1.0] {
        let pass = unscented_pass(&case, alpha);
        let worst = worst_of(
            &pass.filtered.to_vec(),
            extended.filtered.to_vec()[1..]
                .iter()
                .map(|e| (e.mean.as_slice().to_vec(), e.covariance.as_slice().to_vec())),
        );
        println!("α {alpha}, against the EKF without process noise: {worst:?}");
        assert!(
            worst.0 < 1e-9 && worst.1 < 1e-9,
            "α {alpha}: worst relative errors {worst:?}"
        );
        let error = (pass.negative_log_likelihood - extended.negative_log_likelihood).abs()
            / extended.negative_log_likelihood.abs();
        assert!(error < 1e-9, "α {alpha}: −ln L {error:e}");
    }
}
