//! No per-sample heap allocation where the work is per sample: the RK4
//! step of the 6-DOF (fixed-size nalgebra types throughout), the neural
//! Gauss–Newton's network, the RBF network of the Delta method. A counting
//! global allocator proves it.

use aeroid::sim::Simulation;
use aeroid::sim::scenario::Scenario;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct CountingAllocator;

thread_local! {
    /// Allocations made by this thread (the test harness's own threads are not counted).
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|count| count.set(count.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Runs `f` twice and returns the second result with the allocations it
/// made (the first grows whatever buffers `f` keeps).
fn second_run<T>(f: impl Fn() -> T) -> (T, usize) {
    f();
    let before = ALLOCATIONS.with(Cell::get);
    let result = f();
    (result, ALLOCATIONS.with(Cell::get) - before)
}

/// Bit for bit.
fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits())
}

/// The buffered calls of `model` (`rate_jacobians_into`, `jacobians_into`,
/// `outputs_into`, `step_into` from grid point `k`) at (t, x) give the
/// plain calls' numbers bit for bit, and allocate nothing once their
/// buffers have grown. Returns the plain Jacobians.
fn buffered_calls_are_the_plain_ones(
    model: &impl aeroid::estimation::model::state_space::StateSpaceModel,
    k: usize,
    t: f64,
    x: &[f64],
) -> aeroid::estimation::model::state_space::Jacobians {
    use aeroid::estimation::model::state_space::Jacobians;
    use nalgebra::DVector;
    let (mut rates, mut full) = (Jacobians::empty(), Jacobians::empty());
    let (mut outputs, mut next) = (DVector::zeros(0), DVector::zeros(0));
    let mut call = |rates: &mut Jacobians, full: &mut Jacobians| {
        model.rate_jacobians_into(t, x, &[], rates).unwrap();
        model
            .jacobians_into(t, x, &[], full, Some(&mut outputs))
            .unwrap();
        model.step_into(k, x, &[], &mut next).unwrap();
    };
    call(&mut rates, &mut full);
    // Again into the grown buffers: no allocation.
    let before = ALLOCATIONS.with(Cell::get);
    call(&mut rates, &mut full);
    model.outputs_into(t, x, &[], &mut outputs).unwrap();
    assert_eq!(
        ALLOCATIONS.with(Cell::get),
        before,
        "the buffered calls allocate"
    );
    let plain = model.jacobians(t, x, &[]).unwrap();
    assert!(same(
        plain.rates_by_state.as_slice(),
        rates.rates_by_state.as_slice()
    ));
    assert!(same(
        plain.rates_by_state.as_slice(),
        full.rates_by_state.as_slice()
    ));
    assert!(same(
        plain.outputs_by_state.as_slice(),
        full.outputs_by_state.as_slice()
    ));
    assert!(same(
        model.outputs(t, x, &[]).unwrap().as_slice(),
        outputs.as_slice()
    ));
    assert!(same(
        model.step(k, x, &[]).unwrap().as_slice(),
        next.as_slice()
    ));
    plain
}

#[test]
fn rk4_step_does_not_allocate() {
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario.duration = 1.0;
    let simulation = Simulation::prepare(&scenario).unwrap();
    let mut x = simulation.trim.state;
    let before = ALLOCATIONS.with(Cell::get);
    for k in 0..100 {
        x = simulation.advance(&x, k);
    }
    let after = ALLOCATIONS.with(Cell::get);
    let probe = Box::new(std::hint::black_box(7u64));
    drop(probe);
    assert_eq!(
        ALLOCATIONS.with(Cell::get),
        after + 1,
        "the counter sees this thread's allocations"
    );
    assert!(x.iter().all(|v| v.is_finite()));
    assert_eq!(after - before, 0, "heap allocations inside 100 RK4 steps");
}

/// No per-sample heap allocation: a prediction allocates nothing, and in
/// training the only allocations that grow with the samples are the
/// packing buffers of the two matrix products per block of `BLOCK` (64)
/// samples that add them to the sums JᵀJ is made of. Five epochs on 800
/// samples against 400: at most 5·2·(400/64 + 1) = 70 more allocations,
/// never 5·400 (measured: 314 on 400 samples, 360 on 800, 46 more).
#[test]
fn feed_forward_training_and_prediction_allocate_nothing_per_sample() {
    use aeroid::estimation::neural::feedforward::{BLOCK, FeedForward, LevenbergMarquardt};
    let samples = |count: usize| -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        (0..count)
            .map(|k| {
                let x: Vec<f64> = (1..=4).map(|i| ((k * i) as f64 * 0.37).sin()).collect();
                let t = vec![x[0] * x[1], (x[2] + x[3]).tanh()];
                (x, t)
            })
            .unzip()
    };
    let trainer = LevenbergMarquardt {
        hidden: 6,
        max_epochs: 5,
        held_out_every: 0,
        ..LevenbergMarquardt::default()
    };
    let count = |n: usize| {
        let (inputs, targets) = samples(n);
        let before = ALLOCATIONS.with(Cell::get);
        let (network, training) = trainer.train(&inputs, &targets).unwrap();
        let after = ALLOCATIONS.with(Cell::get);
        assert_eq!(training.epochs, 5);
        (after - before, network)
    };
    let (small, network) = count(400);
    let (large, _) = count(800);
    let per_block = 5 * 2 * (400 / BLOCK + 1);
    assert!(
        large >= small && large - small <= per_block,
        "{small} allocations for 400 samples, {large} for 800"
    );
    let network: FeedForward = network;
    let mut output = [0.0; 2];
    let before = ALLOCATIONS.with(Cell::get);
    for k in 0..1000 {
        network.predict(&[k as f64 * 1e-3, 0.1, -0.2, 0.3], &mut output);
    }
    assert_eq!(ALLOCATIONS.with(Cell::get), before);
}

/// The per-sample work of the Delta method allocates nothing: prediction,
/// central differences and the analytic gradient write into the caller's
/// buffers.
#[test]
fn rbf_per_sample_evaluations_do_not_allocate() {
    use aeroid::estimation::neural::rbf::{RbfNetwork, RbfOptions};
    let rows: Vec<Vec<f64>> = (0..400)
        .map(|k| {
            let t = k as f64 * 0.05;
            vec![t.sin(), (0.7 * t).cos(), (0.3 * t).sin()]
        })
        .collect();
    let targets: Vec<f64> = rows.iter().map(|r| r[0] + 0.5 * r[1] * r[2]).collect();
    let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
    let network = RbfNetwork::train(&rows, &names, &targets, &RbfOptions::default()).unwrap();
    let mut buffer = [0.0; 3];
    let mut gradient = [0.0; 3];
    let mut sum = 0.0;
    let before = ALLOCATIONS.with(Cell::get);
    for row in &rows {
        sum += network.predict(row, &mut buffer);
        for j in 0..3 {
            sum += network.central_difference(&mut buffer, j, 0.01) * network.derivative_factor(j);
        }
        network.scaled_gradient(&buffer, &mut gradient);
        sum += gradient.iter().sum::<f64>();
    }
    let after = ALLOCATIONS.with(Cell::get);
    assert!(sum.is_finite());
    assert_eq!(after - before, 0, "heap allocations in 400 samples");
}

/// The work of an extended Kalman filter's step on the augmented ATTAS
/// lateral model (4 kinematic states, 18 parameter states) allocates
/// nothing once its buffers have grown: the time update's linearisation
/// (∂f/∂x and ∂f/∂θ only), Φ = e^{A·h} and its non-zeros, the RK4 step of
/// the state, P⁻ = Φ·P·Φᵀ, and the measurement update's linearisation
/// with the outputs, 100 grid points after a first one. (The measurement
/// update's S, S⁻¹ and K are the pass's kept results, allocated as it
/// keeps them.) The buffered calls give the plain calls' numbers bit for
/// bit: the state, the outputs and every Jacobian.
#[test]
fn an_ekf_steps_work_on_the_augmented_model_does_not_allocate() {
    use aeroid::estimation::model::augmented::Augmented;
    use aeroid::estimation::model::state_space::{Jacobians, StateSpaceModel};
    use aeroid::numerics::kalman::{self, Exponential, SparseRows};
    use nalgebra::{DMatrix, DVector};

    let (_, structure, view, x0) = attas_lateral_view();
    let theta = view.parameters();
    let free: Vec<usize> = (0..theta.len()).filter(|&i| structure.free[i]).collect();
    let model = Augmented::new(&view, theta.as_slice(), free).unwrap();
    let n = model.state_count();
    assert_eq!((x0.len(), n), (4, 22));
    let (mut rates, mut full) = (Jacobians::empty(), Jacobians::empty());
    let (mut outputs, mut next) = (DVector::zeros(0), DVector::zeros(0));
    let mut exponential = Exponential::default();
    let (mut transition, mut sparse) = (DMatrix::zeros(0, 0), SparseRows::default());
    let mut work = [DMatrix::zeros(0, 0), DMatrix::zeros(0, 0)];
    let mut covariance = DMatrix::from_diagonal_element(n, n, 1e-4);
    let mut state = model.state(x0.as_slice());
    let h = model.time(1) - model.time(0);
    let mut step = |k: usize, state: &mut DVector<f64>, covariance: &mut DMatrix<f64>| {
        model
            .rate_jacobians_into(model.time(k), state.as_slice(), &[], &mut rates)
            .unwrap();
        let leading = exponential.of_scaled(&rates.rates_by_state, h, &mut transition);
        sparse.set_leading(&transition, leading);
        model
            .step_into(k, state.as_slice(), &[], &mut next)
            .unwrap();
        std::mem::swap(state, &mut next);
        kalman::predict_covariance_from(None, covariance.as_mut_slice(), &sparse, None, &mut work);
        model
            .jacobians_into(
                model.time(k + 1),
                state.as_slice(),
                &[],
                &mut full,
                Some(&mut outputs),
            )
            .unwrap();
        leading
    };
    assert_eq!(step(0, &mut state, &mut covariance), 4, "Φ's dynamic rows");
    let before = ALLOCATIONS.with(Cell::get);
    for k in 1..=100 {
        step(k, &mut state, &mut covariance);
    }
    let after = ALLOCATIONS.with(Cell::get);
    assert_eq!(after - before, 0, "heap allocations in 100 steps' work");

    // The buffered calls are the plain ones, bit for bit.
    let t = model.time(101);
    let plain = buffered_calls_are_the_plain_ones(&model, 101, t, state.as_slice());
    model
        .rate_jacobians_into(t, state.as_slice(), &[], &mut rates)
        .unwrap();
    assert!(same(
        plain.rates_by_state.as_slice(),
        rates.rates_by_state.as_slice()
    ));
    // Φ from the scaled exponential is the exponential of A·h.
    let mut scaled = DMatrix::zeros(0, 0);
    let leading = exponential.of_scaled(&rates.rates_by_state, h, &mut transition);
    Exponential::default().of(&(&rates.rates_by_state * h), &mut scaled);
    assert!(same(transition.as_slice(), scaled.as_slice()));
    assert_eq!(leading, 4);
    assert!(
        transition
            .rows(4, n - 4)
            .columns(0, 4)
            .iter()
            .all(|&v| v == 0.0)
    );
    assert!(
        transition
            .view((4, 4), (n - 4, n - 4))
            .into_owned()
            .is_identity(0.0)
    );
}

/// A whole EKF pass over the augmented ATTAS lateral record (1501 grid
/// points, 22 states) allocates nothing per grid point, whatever it keeps:
/// what it keeps goes into buffers reserved once per pass
/// (`aeroid::numerics::kept`), the update's S, S⁻¹ and K into
/// the update's own buffers (no packing buffer of a matrix product), so a
/// pass makes a fixed set-up's allocations (the pass's buffers, the
/// step's buffers' first growth): under a hundred over 1501 points, where
/// a single allocation per point would make 1501.
#[test]
fn an_ekf_pass_allocates_nothing_per_grid_point() {
    use aeroid::estimation::model::state_space::StateSpaceModel;
    use aeroid::estimation::solver::extended_kalman::{self, Discretisation, Keep, Noise};
    use nalgebra::{DMatrix, DVector};

    with_augmented_lateral(|model, initial, observations, (outputs, _)| {
        let (n, len) = (model.state_count(), model.len());
        let noise = Noise {
            process: DMatrix::zeros(n, n),
            measurement: DVector::from_element(outputs, 1e-5),
        };
        let measured = observations.at.iter().filter(|a| !a.is_empty()).count();
        let count = |keep: Keep| {
            let initial = initial.clone();
            let before = ALLOCATIONS.with(Cell::get);
            let pass = extended_kalman::filter_with(
                model,
                &[],
                initial,
                &noise,
                observations,
                Discretisation::Exact,
                keep,
            )
            .unwrap();
            let after = ALLOCATIONS.with(Cell::get);
            assert!(pass.negative_log_likelihood.is_finite());
            after - before
        };
        // A first pass makes the model's own buffers (kept between calls).
        count(Keep::UPDATES);
        for keep in [
            Keep::UPDATES,
            Keep::SMOOTHER,
            Keep::SEQUENTIAL_SMOOTHER,
            Keep::ALL,
        ] {
            let allocations = count(keep);
            println!("{keep:?}: {allocations} allocations over {len} points ({measured} measured)");
            assert!(
                allocations < 100,
                "{allocations} allocations in a pass keeping {keep:?} over {len} points ({measured} measured)"
            );
        }
    });
}

/// The ATTAS lateral multistep recorded by flight-test-25hz, the
/// `attas-lateral` structure, its driven view and initial state: the
/// record the filter benches run on.
fn attas_lateral_view() -> (
    aeroid::record::FlightRecord,
    aeroid::estimation::structure::ModelStructure,
    aeroid::estimation::model::state_space::DrivenStateSpace,
    nalgebra::DVector<f64>,
) {
    use aeroid::estimation::model::state_space::DrivenStateSpace;
    use aeroid::estimation::structure::ModelStructure;
    use aeroid::record::recorder::{Profile, record_scenario};
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let (view, x0) =
        DrivenStateSpace::for_record(&record, &structure, &Default::default(), None, None).unwrap();
    (record, structure, view, x0)
}

/// The unscented filter's evaluations of its sigma points: a step's 45
/// points (the mean, and ± a spread in each of the 4 kinematic and 18
/// parameter states, as the filter draws them) stepped and their outputs
/// evaluated in one call each ([`StateSpaceModel::step_points_into`],
/// [`StateSpaceModel::outputs_points_into`]) give the per-point calls'
/// numbers bit for bit (the batch shares the step's inputs, the kept
/// model and, among the 37 points at one kinematic state, the first
/// stage's angles, kinematics and forcing: sharing must not change a
/// bit), and after the first call the batched calls allocate nothing in
/// 100 steps.
#[test]
fn a_ukf_steps_sigma_point_evaluations_do_not_allocate() {
    use aeroid::estimation::model::augmented::Augmented;
    use aeroid::estimation::model::state_space::{Points, StateSpaceModel};
    use nalgebra::{DMatrix, DVector};

    let (_, structure, view, x0) = attas_lateral_view();
    let theta = view.parameters();
    let free: Vec<usize> = (0..theta.len()).filter(|&i| structure.free[i]).collect();
    let model = Augmented::new(&view, theta.as_slice(), free).unwrap();
    let n = model.state_count();
    let mean = model.state(x0.as_slice());
    let mut points = DMatrix::zeros(n, 2 * n + 1);
    for j in 0..2 * n + 1 {
        points.set_column(j, &mean);
    }
    for i in 0..n {
        let spread = 1e-3 * mean[i].abs().max(0.01);
        points[(i, 1 + i)] += spread;
        points[(i, 1 + n + i)] -= spread;
    }
    let m = model.output_count();
    let (mut moved, mut outputs) = (DMatrix::zeros(n, 2 * n + 1), DMatrix::zeros(m, 2 * n + 1));
    let batch = |k: usize, moved: &mut DMatrix<f64>, outputs: &mut DMatrix<f64>| {
        model
            .step_points_into(k, Points::shared(&points, &[]), moved.as_mut_slice(), n)
            .unwrap();
        model
            .outputs_points_into(
                model.time(k),
                Points::shared(&points, &[]),
                outputs.as_mut_slice(),
                m,
            )
            .unwrap();
    };
    batch(0, &mut moved, &mut outputs);
    let before = ALLOCATIONS.with(Cell::get);
    for k in 1..=100 {
        batch(k, &mut moved, &mut outputs);
    }
    let after = ALLOCATIONS.with(Cell::get);
    assert_eq!(after - before, 0, "heap allocations in 100 steps' batches");

    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits())
    };
    let k = 101;
    batch(k, &mut moved, &mut outputs);
    let mut value = DVector::zeros(0);
    for j in 0..2 * n + 1 {
        let point = points.column(j).clone_owned();
        model
            .step_into(k, point.as_slice(), &[], &mut value)
            .unwrap();
        assert!(
            same(value.as_slice(), moved.column(j).as_slice()),
            "step of point {j}"
        );
        let plain = model.step(k, point.as_slice(), &[]).unwrap();
        assert!(
            same(plain.as_slice(), value.as_slice()),
            "step of point {j}"
        );
        let y = model.outputs(model.time(k), point.as_slice(), &[]).unwrap();
        assert!(
            same(y.as_slice(), outputs.column(j).as_slice()),
            "outputs of point {j}"
        );
    }
    // The parameter points moved only the kinematic states.
    assert_eq!(moved.rows(4, n - 4), points.rows(4, n - 4));
}

/// A whole UKF pass (`unscented_kalman::filter`, ATTAS lateral: 4
/// kinematic and 18 parameter states, 45 sigma points, 1501 points)
/// allocates nothing per grid point: its step's buffers, what it keeps
/// (reserved once per pass, `kept`) and its set-up (the weights, read from
/// the sigma points of (0, I); the process noise's root; the initial
/// factor) make a fixed number of allocations, under a hundred over 1501
/// points, where a single allocation per point would make 1501 — with
/// process noise (the time update's Φ·G and its noise rows) and without.
#[test]
fn a_ukf_pass_allocates_nothing_per_grid_point() {
    use aeroid::estimation::model::state_space::StateSpaceModel;
    use aeroid::estimation::solver::extended_kalman::Noise;
    use aeroid::estimation::solver::unscented_kalman;
    use aeroid::numerics::kalman::Unscented;
    use nalgebra::{DMatrix, DVector};

    with_augmented_lateral(|model, initial, observations, (outputs, kinematic)| {
        let (n, len) = (model.state_count(), model.len());
        let measured = observations.at.iter().filter(|a| !a.is_empty()).count();
        let unscented = Unscented {
            alpha: 0.5,
            ..Unscented::default()
        };
        let count = |process: f64| {
            let mut noise = Noise {
                process: DMatrix::zeros(n, n),
                measurement: DVector::from_element(outputs, 1e-5),
            };
            for i in 0..kinematic {
                noise.process[(i, i)] = process;
            }
            let initial = initial.clone();
            let before = ALLOCATIONS.with(Cell::get);
            let pass =
                unscented_kalman::filter(model, &[], initial, &noise, observations, &unscented)
                    .unwrap();
            let after = ALLOCATIONS.with(Cell::get);
            assert!(pass.negative_log_likelihood.is_finite());
            assert_eq!(pass.filtered.len(), len);
            after - before
        };
        // A first pass makes the model's own buffers (kept between calls).
        count(0.0);
        for process in [0.0, 1e-6] {
            let allocations = count(process);
            println!(
                "Q_c {process}: {allocations} allocations over {len} points ({measured} measured)"
            );
            assert!(
                allocations < 100,
                "{allocations} allocations in a UKF pass (Q_c {process}) over {len} points ({measured} measured)"
            );
        }
    });
}

/// The augmented ATTAS lateral filter's set-up both pass tests share: the
/// model (4 kinematic and 18 parameter states), its initial Gaussian
/// (kinematic variance 10⁻⁵, parameters 10⁻²), the observations on its
/// grid, and the numbers of outputs and of kinematic states, handed to
/// `run`.
fn with_augmented_lateral(
    run: impl FnOnce(
        &aeroid::estimation::model::augmented::Augmented<
            '_,
            aeroid::estimation::model::state_space::DrivenStateSpace,
        >,
        &aeroid::numerics::kalman::Gaussian,
        &aeroid::estimation::model::observations::Observations,
        (usize, usize),
    ),
) {
    use aeroid::estimation::model::augmented::Augmented;
    use aeroid::estimation::model::observations::Observations;
    use aeroid::estimation::model::state_space::StateSpaceModel;
    use aeroid::numerics::kalman::Gaussian;
    use nalgebra::DMatrix;

    let (record, structure, view, x0) = attas_lateral_view();
    let theta = view.parameters();
    let free: Vec<usize> = (0..theta.len()).filter(|&i| structure.free[i]).collect();
    let model = Augmented::new(&view, theta.as_slice(), free).unwrap();
    let n = model.state_count();
    let mut prior = DMatrix::from_diagonal_element(n, n, 1e-5);
    for i in x0.len()..n {
        prior[(i, i)] = 1e-2;
    }
    let initial = Gaussian {
        mean: model.state(x0.as_slice()),
        covariance: prior,
    };
    let observations = Observations::from_record(
        &record,
        &structure.outputs,
        view.time(0),
        view.time(1) - view.time(0),
        model.len(),
    )
    .unwrap();
    run(
        &model,
        &initial,
        &observations,
        (structure.outputs.len(), x0.len()),
    );
}

/// The ATTAS lateral multistep recorded by flight-test-25hz over its first
/// `duration` seconds, with the `attas-lateral` structure.
fn attas_lateral_record(
    duration: f64,
) -> (
    aeroid::record::FlightRecord,
    aeroid::estimation::structure::ModelStructure,
) {
    use aeroid::estimation::structure::ModelStructure;
    use aeroid::record::recorder::{Profile, record_scenario};
    let mut scenario = Scenario::load("attas-lateral-multistep").unwrap();
    scenario.duration = duration;
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    (record, ModelStructure::load("attas-lateral").unwrap())
}

/// The `ebm` pass (EKF + modified Bryson–Frazier smoother on the 28
/// coefficient states, 13 outputs) allocates nothing per grid point in its
/// forward pass: over the first 30 s of the ATTAS lateral record (751
/// points) and over all 60 s (1501 points) the EKF makes the same number
/// of allocations (each after a pass of its length), keeping the scalar
/// updates (as `ebm` runs it) or the vector ones — the model's linearisation, step and outputs write into
/// the filter's buffers ([`CoefficientStates`]' `jacobians_into`,
/// `rate_jacobians_into`, `step_into`, `outputs_into`), what the pass keeps
/// is reserved once. The backward smoother's only allocations per grid
/// point are the two vectors of its result there (the smoothed mean and
/// variances that `kalman::mbf_smooth_variances` returns): exactly
/// 2 · 750 more over the longer record, none in its sweep back through
/// the scalar updates (the vector updates' sweep, which `ebm` does not
/// run, is not counted here).
/// The buffered calls give the plain calls' numbers bit for bit.
///
/// [`CoefficientStates`]: aeroid::estimation::model::coefficient_states::CoefficientStates
#[test]
fn an_ebm_pass_allocates_nothing_per_grid_point() {
    use aeroid::estimation::methods::smoothed_regression::SmootherSetup;
    use aeroid::estimation::model::state_space::StateSpaceModel;
    use aeroid::estimation::solver::extended_kalman::Keep;

    let setups: Vec<SmootherSetup> = [30.0, 60.0]
        .map(|duration| {
            let (record, structure) = attas_lateral_record(duration);
            SmootherSetup::new(&record, &structure, &Default::default()).unwrap()
        })
        .into_iter()
        .collect();
    let lengths: Vec<usize> = setups.iter().map(|s| s.model.len()).collect();
    assert_eq!(lengths, [751, 1501]);
    assert_eq!(setups[1].model.state_count(), 28);
    assert_eq!(setups[1].model.output_count(), 13);
    for keep in [Keep::SEQUENTIAL_SMOOTHER, Keep::SMOOTHER] {
        let mut forward = Vec::new();
        let mut backward = Vec::new();
        for setup in &setups {
            // A first pass at this length leaves its kept buffers in the
            // thread's pool (`kept`), as a pass of a fit leaves them for
            // the next: the counted pass reuses them.
            drop(setup.filter(keep).unwrap());
            let before = ALLOCATIONS.with(Cell::get);
            let pass = setup.filter(keep).unwrap();
            let filtered = ALLOCATIONS.with(Cell::get);
            let smoothed = SmootherSetup::smooth(&pass, keep);
            let after = ALLOCATIONS.with(Cell::get);
            assert!(pass.negative_log_likelihood.is_finite());
            assert_eq!(smoothed.len(), setup.model.len());
            assert!(smoothed.iter().all(|(mean, variances)| {
                mean.iter().all(|v| v.is_finite()) && variances.iter().all(|v| v.is_finite())
            }));
            forward.push(filtered - before);
            backward.push(after - filtered);
        }
        println!(
            "{keep:?}: forward {forward:?}, backward {backward:?} allocations over {lengths:?} points"
        );
        assert_eq!(
            forward[0], forward[1],
            "the EKF's allocations over {lengths:?} points keeping {keep:?}"
        );
        if keep.sequential {
            assert_eq!(
                backward[1] - backward[0],
                2 * (lengths[1] - lengths[0]),
                "the smoother's allocations over {lengths:?} points: its two result vectors a point, nothing else"
            );
        }
    }

    // The buffered calls are the plain ones, bit for bit, at a state the
    // filter reached (every Jacobian term non-zero).
    let setup = &setups[1];
    let model = &setup.model;
    let pass = setup.filter(Keep::UPDATES).unwrap();
    let x = pass.filtered.get(700).unwrap().mean.clone_owned();
    let t = model.time(700) + 0.013;
    let plain = buffered_calls_are_the_plain_ones(model, 700, t, x.as_slice());
    assert!(plain.rates_by_state.iter().filter(|&&v| v != 0.0).count() > 60);
    assert_eq!(plain.rates_by_parameter.shape(), (28, 0));
    assert_eq!(plain.outputs_by_parameter.shape(), (13, 0));
}

/// The filter error method's passes at given θ, F and R allocate nothing
/// per grid point: on the ATTAS lateral driven view (the model `fem`
/// fits), F on the first three states, over the first 30 s of the record
/// (751 points) and over all 60 s (1501 points), the steady-gain pass
/// (diagonal R, and full R with its whitening) and the time-varying-gain
/// pass (the EKF, then its innovations and S_k copied into buffers
/// reserved once) each make the same number of allocations: their set-up
/// (the gain's Riccati solution, the pass's buffers), which does not grow
/// with the record. Each view's second pass is counted (its first grows
/// the view's own buffers).
#[test]
fn filter_error_passes_allocate_nothing_per_grid_point() {
    use aeroid::estimation::methods::filter_error::{
        InnovationCovariance, steady_state_pass, time_varying_pass,
    };
    use aeroid::estimation::model::observations::Observations;
    use aeroid::estimation::model::state_space::{DrivenStateSpace, StateSpaceModel};
    use aeroid::numerics::kalman::Gaussian;
    use nalgebra::{DMatrix, DVector};

    let deg = std::f64::consts::PI / 180.0;
    let variances = DVector::from_vec(
        [0.1 * deg, 0.002, 0.002, 0.1 * deg, 0.02 / 9.80665]
            .iter()
            .map(|s| 4.0 * s * s)
            .collect(),
    );
    let mut counts = Vec::new();
    let mut lengths = Vec::new();
    for duration in [30.0, 60.0] {
        let (record, structure) = attas_lateral_record(duration);
        let (view, x0) =
            DrivenStateSpace::for_record(&record, &structure, &Default::default(), None, None)
                .unwrap();
        let theta = view.parameters();
        let n = view.state_count();
        let observations = Observations::from_record(
            &record,
            &structure.outputs,
            view.time(0),
            view.time(1) - view.time(0),
            view.len(),
        )
        .unwrap();
        let measurements: usize = observations.at.iter().map(Vec::len).sum();
        let distribution = DVector::from_fn(n, |i, _| if i < 3 { 1e-3 } else { 0.0 });
        let diagonal = InnovationCovariance::diagonal(&variances);
        let full = InnovationCovariance::full(DMatrix::from_diagonal(&variances)).unwrap();
        let steady = |innovation: &InnovationCovariance| {
            let (pass, allocations) = second_run(|| {
                steady_state_pass(
                    &view,
                    theta.as_slice(),
                    &x0,
                    &distribution,
                    innovation,
                    &observations,
                )
                .unwrap()
            });
            assert_eq!(pass.innovations.len(), measurements);
            assert!(pass.negative_log_likelihood.is_finite());
            assert!(pass.steady.gain.amax() > 0.0, "process noise gives a gain");
            allocations
        };
        let initial = Gaussian {
            mean: x0.clone(),
            covariance: DMatrix::from_diagonal_element(n, n, 1e-4),
        };
        let time_varying = || {
            let (pass, allocations) = second_run(|| {
                time_varying_pass(
                    &view,
                    theta.as_slice(),
                    &initial,
                    &distribution,
                    &variances,
                    &observations,
                )
                .unwrap()
            });
            assert_eq!(pass.innovations.len(), measurements);
            assert!(pass.negative_log_likelihood.is_finite());
            // The updates read back the pass's innovations, in order, and
            // each S_k is symmetric with R's variances as its floor.
            let mut read = Vec::new();
            for (outputs, innovation, covariance) in pass.updates() {
                assert_eq!(outputs.len(), innovation.len());
                assert_eq!(covariance.shape(), (outputs.len(), outputs.len()));
                let asymmetry = (covariance - covariance.transpose()).amax();
                assert!(asymmetry <= 1e-12 * covariance.amax(), "{covariance}");
                for (i, &o) in outputs.iter().enumerate() {
                    assert!(covariance[(i, i)] >= variances[o]);
                }
                read.extend(innovation.iter().copied());
            }
            assert_eq!(read, pass.innovations);
            allocations
        };
        counts.push([steady(&diagonal), steady(&full), time_varying()]);
        lengths.push(view.len());
    }
    println!(
        "steady (diagonal R, full R), time-varying: {counts:?} allocations over {lengths:?} points"
    );
    assert_eq!(lengths, [751, 1501]);
    assert_eq!(
        counts[0], counts[1],
        "allocations over {lengths:?} points: steady (diagonal R, full R), time-varying"
    );
}
