//! Tests of `feedforward`.

use super::levenberg_marquardt::{
    Samples, Workspace, accumulate, damped_step, information, training_sum_of_squares,
};
use super::*;
use nalgebra::DVector;

/// Inputs in [−1, 1]³ from an additive recurrence (quasi-random, no RNG).
fn inputs(count: usize) -> Vec<Vec<f64>> {
    let steps = [0.618_033_988_7, 0.754_877_666_2, 0.569_840_290_9];
    (0..count)
        .map(|k| {
            steps
                .iter()
                .map(|a| 2.0 * ((k as f64 + 0.5) * a).fract() - 1.0)
                .collect()
        })
        .collect()
}

/// A smooth map of three inputs to two outputs.
fn smooth(x: &[f64]) -> Vec<f64> {
    vec![
        0.5 * (2.0 * x[0]).sin() + 0.3 * x[1] * x[2],
        (x[0] + x[1]).tanh() - 0.2 * x[2] * x[2],
    ]
}

/// The back-propagated Jacobian equals central differences of the
/// network's output to 1e-7 relative (the differences' own truncation
/// and rounding error with h = 1e-6 is about 1e-10).
#[test]
fn back_propagated_jacobian_equals_central_differences() {
    let network = FeedForward::new(3, 5, 2, 7).unwrap();
    let x = [0.3, -0.7, 0.1];
    let mut hidden = vec![0.0; 5];
    let mut jacobian = DMatrix::zeros(2, network.weights.len());
    network.jacobian(&x, &mut hidden, &mut jacobian);
    let scale = jacobian.amax();
    let h = 1e-6;
    for k in 0..network.weights.len() {
        let (mut plus, mut minus) = (network.clone(), network.clone());
        plus.weights[k] += h;
        minus.weights[k] -= h;
        let (mut yp, mut ym) = ([0.0; 2], [0.0; 2]);
        plus.predict(&x, &mut yp);
        minus.predict(&x, &mut ym);
        for o in 0..2 {
            let difference = (yp[o] - ym[o]) / (2.0 * h);
            assert!(
                (difference - jacobian[(o, k)]).abs() <= 1e-7 * scale,
                "output {o}, weight {k}: {difference} against {}",
                jacobian[(o, k)]
            );
        }
    }
}

/// The normal equations accumulated block by block from the
/// Kronecker structure equal JᵀJ and Jᵀe formed from the full
/// back-propagated Jacobian, to rounding (1e-12 relative), for a
/// sample count that is not a multiple of the block.
#[test]
fn accumulated_normal_equations_equal_the_full_jacobian_ones() {
    let network = FeedForward::new(3, 4, 2, 3).unwrap();
    let x = inputs(BLOCK + 7);
    let t: Vec<Vec<f64>> = x.iter().map(|x| smooth(x)).collect();
    let samples = Samples {
        inputs: &x,
        targets: &t,
        training: (0..x.len()).collect(),
        held_out: Vec::new(),
    };
    let parameters = network.weights.len();
    let mut work = Workspace::new(3, 4, 2, x.len());
    training_sum_of_squares(&network, &samples, &mut work.kept);
    let normal_gradient = accumulate(&network, &samples, &mut work);
    let normal_information = information(&network, &work);
    let mut information = DMatrix::zeros(parameters, parameters);
    let mut gradient = DVector::zeros(parameters);
    let mut jacobian = DMatrix::zeros(2, parameters);
    let mut hidden = vec![0.0; 4];
    let mut y = [0.0; 2];
    for (x, t) in x.iter().zip(&t) {
        network.jacobian(x, &mut hidden, &mut jacobian);
        network.predict(x, &mut y);
        let e = DVector::from_fn(2, |o, _| y[o] - t[o]);
        information += jacobian.tr_mul(&jacobian);
        gradient += jacobian.tr_mul(&e);
    }
    assert!((normal_information - &information).amax() <= 1e-12 * information.amax());
    assert!((&normal_gradient - &gradient).amax() <= 1e-12 * gradient.amax());
    // The step by eliminating the output weights equals the Cholesky
    // solution of the whole damped system to 1e-9 relative, for a
    // small and a large damping.
    for mu in [1e-6, 10.0] {
        let mut damped = information.clone();
        for i in 0..parameters {
            damped[(i, i)] += mu;
        }
        let full = damped.cholesky().unwrap().solve(&(-&gradient));
        let step = damped_step(&network, &work, &normal_gradient, mu).unwrap();
        assert!(
            (&step - &full).amax() <= 1e-9 * full.amax(),
            "μ = {mu}: {step} against {full}"
        );
    }
}

/// An evaluation continued from the state after the leading inputs
/// equals the whole evaluation bit for bit.
#[test]
fn prediction_from_a_partial_state_is_the_prediction() {
    let network = FeedForward::new(5, 7, 3, 4).unwrap();
    let x = [0.3, -0.7, 0.1, 0.9, -0.25];
    let (mut whole, mut continued) = ([0.0; 3], [0.0; 3]);
    Network::predict(&network, &x, &mut whole);
    for from in 1..5 {
        let mut state = vec![0.0; network.partial_size()];
        network.partial(&x[..from], &mut state);
        network.predict_from(&state, from, &x, &mut continued);
        assert_eq!(whole.map(f64::to_bits), continued.map(f64::to_bits));
    }
}

/// Training fits the smooth map of three inputs and two outputs
/// (600 samples, 10 tanh neurons, 200 epochs) to an MSE below 1e-6 on
/// the training samples, the held-out ones and 400 points it never saw
/// (measured 3.4e-7, 5.1e-7 and 4.0e-7: an RMS error of 0.06 % of the
/// outputs' range of about 2; the bound is twice the worst, room for
/// rounding across machines, not for a worse fit). The training error
/// never rises over the accepted steps.
#[test]
fn fits_a_smooth_map_and_never_raises_the_training_error() {
    let x = inputs(600);
    let t: Vec<Vec<f64>> = x.iter().map(|x| smooth(x)).collect();
    let trainer = LevenbergMarquardt::default();
    let (network, training) = trainer.train(&x, &t).unwrap();
    assert!(
        training.training_mse.windows(2).all(|w| w[1] <= w[0]),
        "{:?}",
        training.training_mse
    );
    let best = training.best_epoch;
    eprintln!(
        "epochs {} stop {:?} best {best} training {:e} held-out {:e}",
        training.epochs, training.stop, training.training_mse[best], training.held_out_mse[best]
    );
    assert!(training.training_mse[best] < 1e-6);
    assert!(training.held_out_mse[best] < 1e-6);
    let fresh: Vec<Vec<f64>> = inputs(1000).split_off(600);
    let mut y = [0.0; 2];
    let mse = fresh
        .iter()
        .map(|x| {
            network.predict(x, &mut y);
            let t = smooth(x);
            (y[0] - t[0]).powi(2) + (y[1] - t[1]).powi(2)
        })
        .sum::<f64>()
        / (2.0 * fresh.len() as f64);
    eprintln!("unseen mse {mse:e}");
    assert!(mse < 1e-6, "{mse}");
    let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
    let report = report(&network, &training, 1, &x, &t, &names, &names[..2]);
    assert_eq!(
        (report.hidden, report.seed, report.kind.as_str()),
        (10, 1, "feed-forward")
    );
    assert!(report.r_squared > 0.9999, "{}", report.r_squared);
}

/// The neurons' tanh is the library's to 4·10⁻¹⁶ absolutely over
/// [−40, 40] (measured worst 2.2e-16), odd, and saturates at ±1.
#[test]
fn tanh_is_the_library_tanh() {
    let worst = (-400_000..=400_000)
        .map(|k| k as f64 * 1e-4 + 1.234_567e-6)
        .map(|s| (tanh(s) - s.tanh()).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 4e-16, "{worst:e}");
    assert_eq!(tanh(-0.3), -tanh(0.3));
    assert_eq!((tanh(800.0), tanh(-800.0), tanh(0.0)), (1.0, -1.0, 0.0));
}

/// A seed gives the same weights bit for bit; another seed other ones.
#[test]
fn same_seed_same_weights() {
    let x = inputs(200);
    let t: Vec<Vec<f64>> = x.iter().map(|x| smooth(x)).collect();
    let trainer = LevenbergMarquardt {
        hidden: 6,
        max_epochs: 20,
        ..LevenbergMarquardt::default()
    };
    let (a, _) = trainer.train(&x, &t).unwrap();
    let (b, _) = trainer.train(&x, &t).unwrap();
    assert!(
        a.weights
            .iter()
            .zip(&b.weights)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    let other = LevenbergMarquardt { seed: 2, ..trainer };
    let (c, _) = other.train(&x, &t).unwrap();
    assert_ne!(a.weights, c.weights);
}

/// Few noisy samples and many neurons: the network over-trains, the
/// held-out error rises for `patience` epochs after its best, training
/// stops and keeps the weights of the best epoch, whose held-out
/// error is the lowest of the run. Measured (80 samples, noise
/// σ = 0.1, 20 neurons, 157 weights): best epoch 7 with training MSE
/// 0.0056 and held-out 0.021; six epochs later the training MSE is
/// 0.0046, below the noise variance 0.01 (fitting the noise), and the
/// held-out MSE 0.023.
#[test]
fn stops_early_when_the_held_out_error_rises() {
    let x = inputs(100);
    let mut rng = stream(11, 99);
    let t: Vec<Vec<f64>> = x
        .iter()
        .map(|x| {
            smooth(x)
                .into_iter()
                .map(|y| y + 0.1 * rng.sample::<f64, _>(StandardNormal))
                .collect()
        })
        .collect();
    let trainer = LevenbergMarquardt {
        hidden: 20,
        ..LevenbergMarquardt::default()
    };
    let (network, training) = trainer.train(&x, &t).unwrap();
    eprintln!("{training:?}");
    assert_eq!(training.stop, Stop::HeldOutRose);
    assert_eq!(training.epochs, training.best_epoch + trainer.patience);
    let lowest = training
        .held_out_mse
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    assert_eq!(training.held_out_mse[training.best_epoch], lowest);
    let held: Vec<usize> = (0..100).filter(|k| k % 5 == 4).collect();
    let mut y = [0.0; 2];
    let kept = held
        .iter()
        .map(|&k| {
            network.predict(&x[k], &mut y);
            (y[0] - t[k][0]).powi(2) + (y[1] - t[k][1]).powi(2)
        })
        .sum::<f64>()
        / (2.0 * held.len() as f64);
    assert!((kept - lowest).abs() <= 1e-12 * lowest);
}
