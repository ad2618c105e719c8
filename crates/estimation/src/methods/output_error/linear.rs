//! Output error on a linear state-space structure.

use super::*;

/// Output error on a linear structure: the filter-error fit with no
/// process noise, whose filter is the model's exact simulation
/// ([`filter_fit::linear_fit`]), or with `segment` multiple shooting
/// ([`linear_shooting`]); then the fitted model's modes
/// ([`modes::diagnose`]). The settings a linear model does not take are
/// refused by name ([`LINEAR_UNSUPPORTED`]).
pub(super) fn linear_output_error(
    problem: &EstimationProblem,
    structure: &LinearStructure,
    options: &OutputErrorOptions,
) -> Result<Estimate> {
    crate::estimator::one_record(METHOD, problem)?;
    crate::estimator::refuse_for_linear(
        METHOD,
        &problem.settings,
        &structure.name,
        LINEAR_UNSUPPORTED,
    )?;
    let record = problem.record();
    let mut estimate = match options.segment {
        Some(segment) => linear_shooting::fit(
            METHOD,
            record,
            structure,
            &linear_shooting::ShootingOptions {
                max_iterations: options.max_iterations,
                step: options.step,
                window: options.window,
                segment,
                decrease: CONVERGED_DECREASE,
            },
        )?,
        None => filter_fit::linear_fit(
            METHOD,
            record,
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
        )?,
    };
    let (from, to) = fitting_window(record, &structure.outputs, options.window)?;
    let horizon = options.segment.map_or(to - from, |s| s.min(to - from));
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
        "estimate_initial_state",
        "a linear model's states start from the record; with `segment` each piece's initial state is estimated",
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
