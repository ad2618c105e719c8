//! The fit: stages, starts from equation error, and the estimate with its fit quality and diagnoses.

use super::*;

/// Fits `structure` to one or more records by output error.
pub fn output_error(
    records: &[&FlightRecord],
    structure: &ModelStructure,
    options: &OutputErrorOptions,
) -> Result<Estimate> {
    output_error_from(records, structure, options, None)
}

/// Output error with equation error's estimate on the first record given
/// (else computed when the start asks for it).
pub(crate) fn output_error_from(
    records: &[&FlightRecord],
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    regression: Option<&Estimate>,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let input_noise = check_request(records, structure, options)?;
    let mut problem = Objective::new(records, structure, options)?;
    let data: usize = problem
        .segments
        .iter()
        .flat_map(|segment| &segment.outputs)
        .map(|measured| measured.values.len())
        .sum();
    if data < problem.all.len() {
        return Err(Error::Refused(Refusal::TooFewData {
            method: METHOD.to_string(),
            data,
            unknowns: problem.all.len(),
        }));
    }
    let mut notes = Vec::new();
    let from_equation_error = options.start == Start::EquationError
        && problem.start_from_equation_error(records[0], structure, regression, &mut notes);
    let original_start = problem.current();
    let aero = &structure.aircraft.aero;
    let lag = aero
        .parameters
        .index("tau1")
        .filter(|_| aero.chi_is_state());
    let staged = if from_equation_error {
        None
    } else {
        first_stage(&mut problem, structure, options, lag)
    };
    let mut start = original_start.clone();
    if let Some((unknowns, theta, _)) = &staged {
        for (j, unknown) in problem.unknowns.iter().enumerate() {
            if let Some(k) = unknowns.iter().position(|u| u == unknown) {
                start[j] = theta[k];
            }
        }
    }
    let solution = final_fit(&mut problem, structure, options, &start);
    let mut estimate = problem.estimate(
        structure,
        records,
        &original_start,
        &solution,
        started.elapsed().as_secs_f64(),
    );
    estimate.notes.extend(notes);
    describe(&mut problem, structure, options, &solution, &mut estimate);
    corrected_bounds(
        &mut problem,
        records,
        options,
        (&solution, &input_noise),
        &mut estimate,
    );
    if let Some((unknowns, _, iterations)) = staged {
        let note = staged_note(&problem, &unknowns, lag, iterations);
        estimate.notes.push(note);
    }
    Ok(estimate.assess_residuals())
}

/// The fit of every unknown from `start`, refined near the minimum and
/// gone on with after a re-chosen grid (the comments within).
fn final_fit(
    problem: &mut Objective,
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    start: &DVector<f64>,
) -> gauss_newton::Solution {
    // Iterations steer with the grid-point linearisation (half the cost).
    // Once a step is predicted to decrease the cost by less than
    // REFINE_DECREASE, its simulation is made with the exact derivative of
    // the discrete simulation ([`LeastSquaresObjective::refine`]), and the fit
    // stops only when the exact Gauss–Newton step is under 0.014σ; the
    // information matrix and Cramér–Rao bounds are the exact ones.
    let mut final_options =
        solver_options(structure, options, &problem.unknowns, CONVERGED_DECREASE);
    final_options.refine_below = Some(REFINE_DECREASE);
    problem.refinable = true;
    let mut solution = gauss_newton::solve(problem, start, &final_options);
    // The solver re-weights once more where it stops: a grid re-chosen
    // there leaves θ the optimum of the grid before, so the fit goes on
    // from it on the new grid (at most twice more).
    for _ in 0..2 {
        if !problem.regridded || matches!(solution.status, Status::Diverged(_)) {
            break;
        }
        let mut history = solution.history;
        solution = gauss_newton::solve(problem, &solution.theta, &final_options);
        history.append(&mut solution.history);
        solution.history = history;
    }
    solution
}

/// An error unless every record has the channels the fit needs, the
/// output biases name outputs, the model suits the method and each
/// input-noise channel is an input some record has; the input-noise
/// standard deviations.
fn check_request(
    records: &[&FlightRecord],
    structure: &ModelStructure,
    options: &OutputErrorOptions,
) -> Result<Vec<(String, f64)>> {
    for record in records {
        let present = record.channels.iter().map(|c| c.name.clone()).collect();
        if let Some(refusal) =
            Refusal::missing(METHOD, missing_channels(record, structure), present)
        {
            return Err(Error::Refused(refusal));
        }
    }
    if let Some(name) = options
        .output_biases
        .iter()
        .find(|name| !structure.outputs.contains(name))
    {
        return Err(Error::Setting {
            method: METHOD.to_string(),
            reason: format!(
                "output_biases: '{name}' is not among the outputs of model '{}' ({})",
                structure.name,
                structure.outputs.join(", ")
            ),
        });
    }
    unsuitable(METHOD, structure)?;
    let input_noise = options.input_sigmas()?;
    let inputs = driving_channels(structure);
    for (name, _) in &input_noise {
        if !inputs.contains(&name.as_str()) {
            return Err(Error::Setting {
                method: METHOD.to_string(),
                reason: format!(
                    "input_noise: '{name}' is not an input of model '{}' (its inputs: {})",
                    structure.name,
                    inputs.join(", ")
                ),
            });
        }
        if records.iter().all(|record| record.channel(name).is_err()) {
            return Err(Error::Setting {
                method: METHOD.to_string(),
                reason: format!("input_noise: no record has a '{name}' channel"),
            });
        }
    }
    Ok(input_noise)
}

/// The solver's settings for `unknowns`: the fit's iteration limit, a
/// stop at a predicted decrease below `decrease`, the structure's bounds.
fn solver_options(
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    unknowns: &[Unknown],
    decrease: f64,
) -> Options {
    let mut solver_options = Options::new(unknowns.len());
    solver_options.max_iterations = options.max_iterations;
    solver_options.decrease_tolerance = Some(decrease);
    for (j, unknown) in unknowns.iter().enumerate() {
        if let Unknown::Aero(i) = unknown {
            solver_options.bounds[j] = structure.bounds[*i];
        }
    }
    solver_options
}

/// The first fit with the initial state and the stall's τ1 (`lag`) held:
/// the unknowns it fitted, its estimate and iterations; None when nothing
/// is held or it diverged. The problem's unknowns are all of them again
/// after it.
///
/// With the initial state among the unknowns, a first fit holds it at
/// the first samples: from a-priori start values the full problem can
/// fall into a wrong minimum (the stall model did: τ2 0.35 for 0.9),
/// while the aerodynamic fit alone is robust and leaves the initial
/// state a small correction. That first fit is only a start, biased by
/// the held initial state, so it stops at a predicted decrease of
/// STAGE_DECREASE (a step of about 4.5σ).
/// Its simulations carry the initial states' sensitivities too, so that
/// the second stage starts from the first's last simulation.
/// The stall's τ1 (χ a state) is held at its start value there too:
/// from a-priori values the full problem runs τ1 to 0 on the stall
/// flight, ideal record included (a valley toward the algebraic limit,
/// where τ2 alone makes the lag), while from the first fit's a1, α* and
/// τ2 it reaches the truth (docs/findings.md, "τ1 in c̄/V").
fn first_stage(
    problem: &mut Objective,
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    lag: Option<usize>,
) -> Option<(Vec<Unknown>, DVector<f64>, usize)> {
    let held_first = |u: &Unknown| {
        matches!(u, Unknown::Initial { .. }) || matches!(u, Unknown::Aero(i) if Some(*i) == lag)
    };
    let all = problem.all.clone();
    if !all.iter().any(held_first) {
        return None;
    }
    problem.unknowns = all.iter().copied().filter(|u| !held_first(u)).collect();
    let first_start = problem.current();
    let first_options = solver_options(structure, options, &problem.unknowns, STAGE_DECREASE);
    let first = gauss_newton::solve(problem, &first_start, &first_options);
    let staged = (!matches!(first.status, Status::Diverged(_)))
        .then(|| (problem.unknowns.clone(), first.theta, first.history.len()));
    problem.unknowns = all;
    staged
}

/// The estimate's bounds corrected for coloured residuals
/// (`correlation_lag`) and for the noise of the inputs (`input_noise`,
/// projected from M⁻¹ before any correction), each with its note; none
/// for a diverged fit.
fn corrected_bounds(
    problem: &mut Objective,
    records: &[&FlightRecord],
    options: &OutputErrorOptions,
    (solution, input_noise): (&gauss_newton::Solution, &[(String, f64)]),
    estimate: &mut Estimate,
) {
    // M⁻¹ before any correction: the input-noise share's projection.
    let white = (!input_noise.is_empty()).then(|| estimate.covariance.clone());
    if options.correlation_lag > 0.0 && !matches!(solution.status, Status::Diverged(_)) {
        let note = problem.coloured_bounds(solution, options.correlation_lag, estimate);
        estimate.notes.push(note);
    }
    if let Some(white) = white
        && !matches!(solution.status, Status::Diverged(_))
    {
        let note = problem.input_noise_bounds(
            records,
            solution,
            &white,
            (
                input_noise,
                options.input_noise_draws,
                options.input_noise_seed,
            ),
            estimate,
        );
        estimate.notes.push(note);
    }
}

/// The estimate's mode diagnoses at the solution and, for multiple
/// shooting, its pieces.
fn describe(
    problem: &mut Objective,
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    solution: &gauss_newton::Solution,
    estimate: &mut Estimate,
) {
    if let Some(eigenvalues) = problem.modes(&solution.theta) {
        let states: Vec<String> = structure
            .integrate
            .iter()
            .map(|&i| FLIGHT_PATH_STATES[i].to_string())
            .collect();
        let horizon = (problem.segments.iter())
            .map(|s| s.window.1 - s.window.0)
            .fold(0.0, f64::max);
        let segmented = options.segment.is_some();
        modes::diagnose(estimate, &eigenvalues, &states, horizon, segmented);
    }
    if options.segment.is_some() {
        estimate.notes.push(format!(
            "multiple shooting: {} pieces of about {} s, each simulated from {}",
            problem.segments.len(),
            options.segment.unwrap_or_default(),
            if options.estimate_initial_state {
                "its own estimated initial state"
            } else {
                "its first recorded samples"
            }
        ));
    }
}

/// The note on a first fit that held the initial state or τ1 (`lag`),
/// fitting `unknowns` in `iterations` iterations.
fn staged_note(
    problem: &Objective,
    unknowns: &[Unknown],
    lag: Option<usize>,
    iterations: usize,
) -> String {
    let mut held = Vec::new();
    if problem
        .all
        .iter()
        .any(|u| matches!(u, Unknown::Initial { .. }))
    {
        held.push(("initial state", "at the first samples"));
    }
    if lag.is_some_and(|i| {
        problem.all.contains(&Unknown::Aero(i)) && !unknowns.contains(&Unknown::Aero(i))
    }) {
        held.push(("tau1", "at its start value"));
    }
    let (names, details): (Vec<&str>, Vec<&str>) = held.into_iter().unzip();
    format!(
        "{} released after a first fit with {} held ({}; {iterations} iterations)",
        names.join(" and "),
        if names.len() > 1 { "them" } else { "it" },
        details.join(", ")
    )
}
