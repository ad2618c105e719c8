//! Output error on a linear state-space structure.

use super::*;

/// Output error on a linear structure: the filter-error fit with no
/// process noise, whose filter is the model's exact simulation
/// ([`filter_fit::linear_fit`]); with `segment`, `estimate_initial_state`
/// or several records (fitted jointly, θ shared), multiple shooting
/// ([`linear_shooting`]), each piece or record from its own estimated
/// initial state, as also when a state would start from a channel that
/// carries a free output bias ([`LinearStructure::started_through_a_bias`]);
/// then the fitted model's modes ([`modes::diagnose`]).
/// The settings a linear model does not take are refused by name
/// ([`LINEAR_UNSUPPORTED`]).
pub(super) fn linear_output_error(
    problem: &EstimationProblem,
    structure: &LinearStructure,
    options: &OutputErrorOptions,
) -> Result<Estimate> {
    crate::estimator::refuse_for_linear(
        METHOD,
        &problem.settings,
        &structure.name,
        LINEAR_UNSUPPORTED,
    )?;
    let records: Vec<&FlightRecord> = problem.records.iter().collect();
    let biased = structure.started_through_a_bias();
    let shooting = options.segment.is_some()
        || options.estimate_initial_state
        || records.len() > 1
        || !biased.is_empty();
    let mut estimate = if shooting {
        linear_shooting::fit(
            METHOD,
            &records,
            structure,
            &linear_shooting::ShootingOptions {
                max_iterations: options.max_iterations,
                step: options.step,
                window: options.window,
                segment: options.segment,
                decrease: CONVERGED_DECREASE,
            },
        )?
    } else {
        filter_fit::linear_fit(
            METHOD,
            problem.record(),
            structure,
            &filter_fit::LinearFitOptions {
                max_iterations: options.max_iterations,
                step: options.step,
                window: options.window,
                process_noise: None,
                gain: filter_fit::Gain::Steady,
                initial_variance: Default::default(),
                innovation_covariance: filter_fit::InnovationForm::Diagonal,
            },
        )?
    };
    if !biased.is_empty() && !options.estimate_initial_state {
        estimate.notes.push(format!(
            "the initial state is estimated: the recorded {} carry their outputs' free biases, so they are not the states' start",
            biased.join(", ")
        ));
    }
    // The longest stretch simulated from one initial state.
    let mut horizon: f64 = 0.0;
    for record in &records {
        let (from, to) = fitting_window(record, &structure.outputs, options.window)?;
        horizon = horizon.max(options.segment.map_or(to - from, |s| s.min(to - from)));
    }
    let eigenvalues = modes::linear_eigenvalues(structure, &estimate);
    modes::diagnose(
        &mut estimate,
        &eigenvalues,
        &structure.states,
        horizon,
        options.segment.is_some(),
    );
    Ok(estimate)
}

/// The `[methods.oem]` keys a linear structure does not take, and why.
pub(super) const LINEAR_UNSUPPORTED: &[(&str, &str)] = &[
    (
        "start",
        "a linear model's fit starts from its file's values: only \"model\"",
    ),
    (
        "interpolation",
        "a linear model states its inputs' interpolation in its file",
    ),
    (
        "output_biases",
        "a linear model states its biases as `state_bias` and `output_bias` parameters",
    ),
    ("starts", "several starts are for 6-DOF structures"),
    ("start_spread", "several starts are for 6-DOF structures"),
    ("start_seed", "several starts are for 6-DOF structures"),
    (
        "correlation_lag",
        "coloured-residual bounds are for 6-DOF structures",
    ),
    ("input_noise", "input-noise bounds are for 6-DOF structures"),
    (
        "input_noise_draws",
        "input-noise bounds are for 6-DOF structures",
    ),
    (
        "input_noise_seed",
        "input-noise bounds are for 6-DOF structures",
    ),
];
