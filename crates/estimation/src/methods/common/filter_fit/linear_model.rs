//! Output error and filter error on a linear structure ([`linear_fit`]).

use super::*;
use crate::methods::common::linear_data::{LinearData, linear_data};

/// How [`linear_fit`] fits a linear structure.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LinearFitOptions {
    pub max_iterations: usize,
    /// The grid step; None: the fastest output's period.
    pub step: Option<f64>,
    pub window: Option<(f64, f64)>,
    /// The states driven by process noise (filter error); None or empty:
    /// none, and the fit is output error (the filter is the simulation).
    pub process_noise: Option<Vec<String>>,
    /// The filter in the loop (filter error).
    pub gain: Gain,
    /// P0's diagonal by state name (time-varying gain).
    pub initial_variance: BTreeMap<String, f64>,
    /// The steady gain's R (with process noise).
    pub innovation_covariance: InnovationForm,
}

/// Output error (no process noise) or filter error on a linear structure:
/// the [`FilterErrorFit`] of its exact discrete model driven by the
/// record's input channels, from the file's parameter values, the initial
/// state the file's `initial_state`, else the record's value of each state
/// named like a channel (else 0).
/// `method` names the estimate.
pub(crate) fn linear_fit(
    method: &str,
    record: &FlightRecord,
    structure: &LinearStructure,
    options: &LinearFitOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let LinearData {
        free,
        model,
        initial,
        step,
        observations,
    } = linear_data(method, record, structure, options.step, options.window)?;
    let noisy = noisy_states_named(method, structure, options.process_noise.as_deref())?;
    enough_data(method, &[&observations], free.len() + noisy.len())?;
    let mut notes: Vec<String> = observations.note(step).into_iter().collect();
    notes.push("linear model, started from the model file's values".to_string());
    notes.push(format!(
        "{} (the model file's `interpolation`)",
        input_timing::note(&model.input_timing)
    ));
    let biased = structure.started_through_a_bias();
    if !biased.is_empty() {
        notes.push(format!(
            "the states {} start from their recorded channels, which carry their outputs' free biases: the estimates are biased by them; state the model's `initial_state`, or fit with oem, which estimates it",
            biased.join(", ")
        ));
    }
    let theta = structure.parameter_values();
    let names = Names {
        parameters: free.iter().map(|&i| structure.names[i].clone()).collect(),
        noise: noise_names(
            noisy.iter().map(|&i| structure.states[i].as_str()),
            &structure.outputs,
            options.gain,
        ),
        states: structure.states.clone(),
    };
    let mut fit = FilterErrorFit::new(
        &model,
        &observations,
        initial,
        theta.clone(),
        free.clone(),
        noisy.clone(),
    )?
    .with_names(names.unknowns());
    if options.gain == Gain::TimeVarying {
        let names: Vec<&str> = structure.states.iter().map(String::as_str).collect();
        let covariance = initial_covariance(method, &names, &options.initial_variance)?;
        fit = fit.with_time_varying_gain(covariance)?;
    }
    let mut fit = fit.with_innovation_form(options.innovation_covariance, &mut notes);
    let mut solver = Options::maximum_likelihood(
        &free,
        &structure.bounds,
        options.max_iterations,
        CONVERGED_DECREASE,
    );
    for (j, &i) in free.iter().enumerate() {
        solver.typical[j] = 1e-3_f64.max(1e-2 * theta[i].abs());
    }
    let result = fit.fit(&theta, solver)?;
    Ok(assemble(
        (method, &structure.name, &structure.outputs),
        record,
        &fit,
        &result,
        &names,
        notes,
        started.elapsed().as_secs_f64(),
    ))
}

/// The states of a linear structure named in `process_noise` (indices
/// into x); an error naming one that is not a state.
fn noisy_states_named(
    method: &str,
    structure: &LinearStructure,
    process_noise: Option<&[String]>,
) -> Result<Vec<usize>> {
    process_noise
        .iter()
        .copied()
        .flatten()
        .map(|name| {
            structure
                .states
                .iter()
                .position(|s| s == name)
                .ok_or_else(|| Error::Setting {
                    method: method.to_string(),
                    reason: format!(
                        "process_noise: '{name}' is not a state of the model ({})",
                        structure.states.join(", ")
                    ),
                })
        })
        .collect()
}
