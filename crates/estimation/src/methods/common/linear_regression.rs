//! Equation error (method `ee`, [`crate::methods::equation_error`]) on a linear
//! structure ([`LinearStructure`]): least squares on each state equation
//! ẋ_i = Σ_j A_ij·x_j + Σ_j B_ij·u_j + b_i and each output equation
//! y_o = Σ_j C_oj·x_j + Σ_j D_oj·u_j + c_o that has a free entry
//! (Klein & Morelli, "Aircraft System Identification", AIAA 2006, ch. 5:
//! z = X·θ + ε, one regression per equation), with every state measured.
//!
//! - Regressors: every state from the record's channel of its name, every
//!   input from its channel, a column of ones for a free bias, on the grid
//!   of the states' fastest channel over the window where they all have
//!   samples. z is the equation's left side minus its fixed entries' terms.
//!   A free parameter that sets several entries (even in one row) is
//!   refused ([`super::refusals::one_entry_each`]): output error fits it.
//! - State derivatives: a rate output of the state (`rate_outputs`, e.g.
//!   `p_dot` for `p`) when the record has it; otherwise the state's channel
//!   differentiated by the local polynomial differentiator
//!   ([`aeroid_record::prep::differentiation`], the `[methods.ee]` `differentiator`),
//!   its windows not crossing a control step
//!   ([`reconstruction::control_corners`]: ẋ jumps where a step input does),
//!   the samples next to a step left out.
//! - Solution and bounds by the shared least squares
//!   ([`LeastSquares`]): θ̂ by SVD, the Cramér–Rao bound corrected for
//!   coloured residuals (Morelli & Klein 1997) to `correlation_lag`,
//!   reported as each parameter's standard error; the white bound in the
//!   notes. The covariance is block-diagonal (one block per equation).
//!
//! The regressors are measured states: their noise biases the estimates
//! towards zero (errors in variables), as on the 6-DOF structures; the
//! bias is not in the Cramér–Rao bound (tests/estimators/linear_models.rs measures
//! it on the linear lateral flight).

use super::EQUATION_ERROR as METHOD;
use super::regression::{CoefficientResult, assemble_named, white_bound_notes_named};
use crate::error::{Error, Result};
use crate::estimate::{Estimate, OutputFit};
use crate::estimator::{MissingChannel, Refusal};
use crate::linear_structure::LinearStructure;
use crate::model::linear::Matrix;
use crate::model::state_space::{fitting_window, integration_step};
use crate::reconstruction;
use aeroid_numerics::regression::{LagWindow, LeastSquares};
use aeroid_record::FlightRecord;
use aeroid_record::prep::differentiation::Differentiator;
use nalgebra::{DMatrix, DVector};

/// One equation's regression: the parameters (indices into the
/// structure's) and the regressor of each, its left side and its name.
struct Equation {
    name: String,
    columns: Vec<usize>,
    regressors: Vec<Regressor>,
    /// Row of the matrices: a state's (A, B, b) or an output's (C, D, c).
    row: usize,
    state: bool,
}

#[derive(Clone, Copy)]
enum Regressor {
    State(usize),
    Input(usize),
    One,
}

/// The equations with a free entry, state equations first.
fn equations(structure: &LinearStructure) -> Vec<Equation> {
    let n = structure.states.len();
    let outputs = structure.matrices.c.nrows();
    let rows = (0..n)
        .map(|i| (true, i, format!("{}_dot", structure.states[i])))
        .chain((0..outputs).map(|o| (false, o, structure.outputs[o].clone())));
    rows.filter_map(|(state, row, name)| {
        let (columns, regressors): (Vec<usize>, Vec<Regressor>) = structure
            .entries
            .iter()
            .enumerate()
            .filter_map(|(p, set)| Some((p, set.first()?)))
            .filter(|(p, entry)| structure.free[*p] && entry.row == row)
            .filter_map(|(p, entry)| {
                let regressor = match (entry.matrix, state) {
                    (Matrix::A, true) | (Matrix::C, false) => Regressor::State(entry.column),
                    (Matrix::B, true) | (Matrix::D, false) => Regressor::Input(entry.column),
                    (Matrix::StateBias, true) | (Matrix::OutputBias, false) => Regressor::One,
                    _ => return None,
                };
                Some((p, regressor))
            })
            .unzip();
        (!columns.is_empty()).then_some(Equation {
            name,
            columns,
            regressors,
            row,
            state,
        })
    })
    .collect()
}

/// Equation error on a linear structure (module header); `differentiator`
/// and `correlation_lag` (s) as `[methods.ee]` gives them.
pub fn linear_equation_error(
    record: &FlightRecord,
    structure: &LinearStructure,
    differentiator: &Differentiator,
    correlation_lag: f64,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    super::refusals::one_entry_each(METHOD, structure)?;
    let equations = equations(structure);
    if equations.is_empty() {
        return Err(Error::Refused(Refusal::NothingToEstimate {
            method: METHOD.to_string(),
            model: structure.name.clone(),
        }));
    }
    check_channels(record, structure, &equations)?;
    let window = fitting_window(record, &structure.states, None)?;
    let step = integration_step(record, &structure.states, None)?;
    let count = ((window.1 - window.0) / step + 1e-9).floor() as usize + 1;
    let times: Vec<f64> = (0..count).map(|k| window.0 + k as f64 * step).collect();
    let values = |name: &str| record.channel(name).and_then(|c| c.values_at(&times));
    let states: Vec<Vec<f64>> = structure
        .states
        .iter()
        .map(|s| values(s))
        .collect::<aeroid_record::Result<_>>()?;
    let inputs: Vec<Vec<f64>> = structure
        .inputs
        .iter()
        .map(|u| values(u))
        .collect::<aeroid_record::Result<_>>()?;
    let steps = reconstruction::control_corners(record);
    let mut notes = vec![format!(
        "linear model: {} state and {} output equation(s) by least squares on {} grid points of {step} s; state rates not recorded as rate outputs by differentiation ({})",
        equations.iter().filter(|e| e.state).count(),
        equations.iter().filter(|e| !e.state).count(),
        count,
        differentiator.describe(1.0 / step)
    )];
    let mut results = Vec::new();
    for equation in &equations {
        let left: Vec<f64> = if equation.state {
            state_rate(
                record,
                structure,
                equation.row,
                differentiator,
                &steps,
                &times,
                &mut notes,
            )?
        } else {
            values(&structure.outputs[equation.row])?
        };
        results.push(fit_equation(
            structure,
            equation,
            &left,
            (&states, &inputs),
            (correlation_lag / step).round() as usize,
        ));
    }
    let mut estimate = assemble_named(
        record,
        &structure.name,
        (&structure.names, &structure.starts),
        METHOD,
        &results,
    );
    estimate
        .notes
        .extend(results.iter().filter_map(|r| r.window_note.clone()));
    estimate
        .notes
        .extend(white_bound_notes_named(&structure.names, &results));
    estimate.notes.extend(notes);
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate)
}

/// A refusal unless the record has every state, every input and every
/// fitted output's channel.
fn check_channels(
    record: &FlightRecord,
    structure: &LinearStructure,
    equations: &[Equation],
) -> Result<()> {
    let mut needed: Vec<(&String, &str)> = structure
        .states
        .iter()
        .map(|s| (s, "a state, measured: a regressor of equation error"))
        .chain(
            structure
                .inputs
                .iter()
                .map(|u| (u, "an input of the linear model")),
        )
        .collect();
    for equation in equations.iter().filter(|e| !e.state) {
        needed.push((&structure.outputs[equation.row], "a fitted output equation"));
    }
    let missing: Vec<MissingChannel> = needed
        .iter()
        .filter(|(name, _)| record.channel(name).is_err())
        .map(|(name, purpose)| MissingChannel {
            name: name.to_string(),
            purpose: purpose.to_string(),
        })
        .collect();
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    match Refusal::missing(METHOD, missing, present) {
        Some(refusal) => Err(Error::Refused(refusal)),
        None => Ok(()),
    }
}

/// ẋ_i on the grid: its rate output when recorded, else its channel
/// differentiated with breaks at the control steps' corners (NaN where no window fits).
fn state_rate(
    record: &FlightRecord,
    structure: &LinearStructure,
    state: usize,
    differentiator: &Differentiator,
    steps: &[f64],
    times: &[f64],
    notes: &mut Vec<String>,
) -> Result<Vec<f64>> {
    let name = &structure.states[state];
    let rate_output = structure
        .rate_states
        .iter()
        .position(|&s| s == state)
        .map(|r| &structure.outputs[structure.matrices.c.nrows() + r])
        .filter(|output| record.channel(output).is_ok());
    if let Some(output) = rate_output {
        notes.push(format!("{name}_dot: the recorded rate output '{output}'"));
        return Ok(record.channel(output)?.values_at(times)?);
    }
    let derivative = differentiator.differentiate_with_breaks(record.channel(name)?, steps);
    let (first, last) = match (derivative.times.first(), derivative.times.last()) {
        (Some(&first), Some(&last)) => (first, last),
        _ => {
            return Err(Error::Data {
                reason: format!("channel '{name}' is too short to differentiate"),
            });
        }
    };
    let inside = derivative.values_at_unbridged(times);
    Ok(times
        .iter()
        .zip(inside)
        .map(|(&t, v)| {
            if t >= first - 1e-9 && t <= last + 1e-9 {
                v
            } else {
                f64::NAN
            }
        })
        .collect())
}

/// Per sample, the sum of the row's fixed entries' terms (the fixed
/// entries at their values, the free ones at 0).
fn fixed_terms(
    structure: &LinearStructure,
    equation: &Equation,
    (states, inputs): (&[Vec<f64>], &[Vec<f64>]),
    len: usize,
) -> Vec<f64> {
    // The fixed entries of the row at their values, the free ones at 0.
    let m = &structure.matrices;
    let free_here = |matrix: Matrix, column: usize| {
        structure.entries.iter().enumerate().any(|(p, set)| {
            structure.free[p]
                && set
                    .iter()
                    .any(|e| e.matrix == matrix && e.row == equation.row && e.column == column)
        })
    };
    let (state_matrix, input_matrix, bias_matrix) = if equation.state {
        (Matrix::A, Matrix::B, Matrix::StateBias)
    } else {
        (Matrix::C, Matrix::D, Matrix::OutputBias)
    };
    let (state_row, input_row, bias) = if equation.state {
        (
            m.a.row(equation.row),
            m.b.row(equation.row),
            m.state_bias[equation.row],
        )
    } else {
        (
            m.c.row(equation.row),
            m.d.row(equation.row),
            m.output_bias[equation.row],
        )
    };
    (0..len)
        .map(|k| {
            let mut sum = if free_here(bias_matrix, 0) { 0.0 } else { bias };
            for (j, x) in states.iter().enumerate() {
                if !free_here(state_matrix, j) {
                    sum += state_row[j] * x[k];
                }
            }
            for (j, u) in inputs.iter().enumerate() {
                if !free_here(input_matrix, j) {
                    sum += input_row[j] * u[k];
                }
            }
            sum
        })
        .collect()
}

/// The result of an equation with no more usable samples (`usable`) than
/// parameters: no estimate, infinite bounds.
fn too_few_samples(equation: &Equation, usable: usize) -> CoefficientResult {
    let width = equation.columns.len();
    CoefficientResult {
        parameters: equation
            .columns
            .iter()
            .map(|&p| (p, f64::NAN, f64::INFINITY, f64::INFINITY))
            .collect(),
        covariance: DMatrix::from_element(width, width, f64::INFINITY),
        fit: OutputFit::new(&equation.name, &[], &[]),
        problem: Some(format!(
            "{}: {usable} usable samples for {width} parameters",
            equation.name
        )),
        window_note: None,
    }
}

/// The least-squares fit of one equation: its left side `left` less the
/// fixed entries' terms on the free entries' regressors, over the samples
/// where all are finite, with the bounds corrected for residual
/// correlation up to `lag` samples.
fn fit_equation(
    structure: &LinearStructure,
    equation: &Equation,
    left: &[f64],
    (states, inputs): (&[Vec<f64>], &[Vec<f64>]),
    lag: usize,
) -> CoefficientResult {
    let fixed = fixed_terms(structure, equation, (states, inputs), left.len());
    let fixed = |k: usize| fixed[k];
    let regressor = |r: Regressor, k: usize| match r {
        Regressor::State(j) => states[j][k],
        Regressor::Input(j) => inputs[j][k],
        Regressor::One => 1.0,
    };
    let rows: Vec<usize> = (0..left.len())
        .filter(|&k| {
            left[k].is_finite()
                && fixed(k).is_finite()
                && equation
                    .regressors
                    .iter()
                    .all(|&r| regressor(r, k).is_finite())
        })
        .collect();
    let width = equation.columns.len();
    if rows.len() <= width {
        return too_few_samples(equation, rows.len());
    }
    let x = DMatrix::from_fn(rows.len(), width, |r, j| {
        regressor(equation.regressors[j], rows[r])
    });
    let z = DVector::from_fn(rows.len(), |r, _| left[rows[r]] - fixed(rows[r]));
    let fit = LeastSquares::fit(&x, &z);
    let (covariance, window) = fit.corrected_covariance(&x, lag);
    let white = fit.white_covariance();
    let measured: Vec<f64> = rows.iter().map(|&k| left[k]).collect();
    let predicted: Vec<f64> = (0..rows.len())
        .map(|r| measured[r] - fit.residuals[r])
        .collect();
    let problem = (!fit.unidentifiable.is_empty()).then(|| {
        let names: Vec<&str> = fit
            .unidentifiable
            .iter()
            .map(|&j| structure.names[equation.columns[j]].as_str())
            .collect();
        format!(
            "{}: the regressors of {} are not independent in this record (not excited, or excited together)",
            equation.name,
            names.join(", ")
        )
    });
    CoefficientResult {
        parameters: equation
            .columns
            .iter()
            .enumerate()
            .map(|(j, &p)| {
                (
                    p,
                    fit.theta[j],
                    covariance[(j, j)].sqrt(),
                    white[(j, j)].sqrt(),
                )
            })
            .collect(),
        covariance,
        fit: OutputFit::new(&equation.name, &measured, &predicted),
        problem,
        window_note: (window == LagWindow::Bartlett).then(|| {
            format!(
                "{}: the truncated residual autocorrelation sum was not positive definite; its standard errors use Bartlett (triangular) lag weights",
                equation.name
            )
        }),
    }
}
