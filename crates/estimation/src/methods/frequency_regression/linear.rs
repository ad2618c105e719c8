//! Fourier-transform regression of a linear structure (`kind = "linear"`)
//! whose states are all measured: the parent module's method with one
//! complex least-squares regression per state equation and per direct
//! output, on the transforms of the measured states, inputs and outputs
//! (the state derivatives' transforms by fourier Eq. 3, not by
//! differentiation; Klein & Morelli §7.3, the form of SIDPAC's `fdoe`).
//! A free parameter that sets several entries is refused
//! ([`refusals::one_entry_each`]): each regression holds one equation.

use super::{FrequencyRegressionOptions, METHOD, local_variances, transforms_note};
use crate::error::{Error, Result};
use crate::estimate::{Estimate, OutputFit, ParameterEstimate, Status};
use crate::estimator::Refusal;
use crate::linear_structure::LinearStructure;
use crate::methods::common::{refusals, regression};
use crate::model::linear::Matrix;
use crate::reconstruction::control_steps;
use aeroid_numerics::fourier::{FourierTransform, breaks_at};
use aeroid_record::FlightRecord;
use nalgebra::{Complex, DMatrix, DVector};

/// Fourier-transform regression of a linear structure (`kind = "linear"`)
/// whose states are all measured: per state i with a free entry in row i
/// of A, B or b, `(ẋ_i)~ − fixed terms = Σ A_ij·x̃_j + Σ B_ik·ũ_k + b_i·1̃`
/// with (ẋ)~ from the state's transform (fourier Eq. 3, no
/// differentiation; Klein & Morelli §7.3, the form of SIDPAC's `fdoe`),
/// and per output o with a free entry in C, D or c, `ỹ_o − fixed terms =
/// Σ C_oj·x̃_j + Σ D_ok·ũ_k + c_o·1̃`. Complex least squares and bounds as
/// for the 6-DOF equations.
pub fn linear_frequency_regression(
    record: &FlightRecord,
    structure: &LinearStructure,
    options: &FrequencyRegressionOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    refusals::one_entry_each(METHOD, structure)?;
    check_measured(record, structure)?;
    let (model, _) = structure.for_record(record, None, None)?;
    let (start, step, count) = (model.start, model.step, model.inputs.len());
    let times: Vec<f64> = (0..count).map(|k| start + k as f64 * step).collect();
    let signals = signals(record, structure, &model.inputs, &times)?;
    let constant_free = (0..structure.names.len()).any(|i| {
        structure.free[i]
            && matches!(
                structure.entries[i][0].matrix,
                Matrix::StateBias | Matrix::OutputBias
            )
    });
    let n = structure.states.len();
    let controls: Vec<(&str, Vec<f64>)> = structure
        .inputs
        .iter()
        .enumerate()
        .map(|(j, name)| {
            (
                name.as_str(),
                signals.column(n + j).iter().copied().collect(),
            )
        })
        .collect();
    let zero = options.zero_frequency.unwrap_or(constant_free);
    let (omegas, band_note) =
        options
            .band
            .frequencies(METHOD, &controls, (start, step, count), zero)?;
    let breaks = breaks_at(start, step, count, &control_steps(record));
    let transform = FourierTransform::with_breaks(&omegas, start, step, count, &breaks)?;
    let columns = transform.transform_columns(&signals)?;
    let equations = Equations {
        structure,
        signals: &signals,
        transform: &transform,
        columns: &columns,
        omegas: &omegas,
    };
    let direct = structure.outputs.len() - structure.rate_states.len();
    let mut fitted = Vec::new();
    let mut problems = Vec::new();
    // One regression per equation: (is a state equation, row).
    for (state, row) in (0..n)
        .map(|i| (true, i))
        .chain((0..direct).map(|o| (false, o)))
    {
        fitted.extend(equations.fit(state, row, &mut problems));
    }
    let note = transforms_note(transform.samples, breaks.len(), &band_note);
    let mut estimate = estimate(record, structure, fitted, problems, note);
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate.assess())
}

/// An error (a refusal) unless the record has every channel the
/// structure needs and measures every state.
fn check_measured(record: &FlightRecord, structure: &LinearStructure) -> Result<()> {
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    if let Some(refusal) = Refusal::missing(METHOD, structure.missing_channels(record), present) {
        return Err(Error::Refused(refusal));
    }
    let unmeasured: Vec<&str> = structure
        .states
        .iter()
        .filter(|s| record.channel(s).is_err())
        .map(String::as_str)
        .collect();
    if !unmeasured.is_empty() {
        return Err(Error::Refused(Refusal::UnsuitableModel {
            method: METHOD.into(),
            model: structure.name.clone(),
            reason: format!(
                "equation error needs every state measured; no channel records {}",
                unmeasured.join(", ")
            ),
        }));
    }
    Ok(())
}

/// The time signals at `times`, one column each: the states, the inputs
/// (`inputs`, u at each grid point), the direct outputs, then the
/// constant 1; an error names the first sample without a value.
fn signals(
    record: &FlightRecord,
    structure: &LinearStructure,
    inputs: &[DVector<f64>],
    times: &[f64],
) -> Result<DMatrix<f64>> {
    let count = times.len();
    let (n, m) = (structure.states.len(), structure.inputs.len());
    let direct = structure.outputs.len() - structure.rate_states.len();
    let mut signals = DMatrix::zeros(count, n + m + direct + 1);
    for (i, name) in structure.states.iter().enumerate() {
        signals.set_column(
            i,
            &DVector::from_vec(record.channel(name)?.values_at(times)?),
        );
    }
    for k in 0..count {
        for j in 0..m {
            signals[(k, n + j)] = inputs[k][j];
        }
        signals[(k, n + m + direct)] = 1.0;
    }
    for (o, name) in structure.outputs.iter().take(direct).enumerate() {
        signals.set_column(
            n + m + o,
            &DVector::from_vec(record.channel(name)?.values_at(times)?),
        );
    }
    if let Some((k, i)) = (0..count)
        .flat_map(|k| (0..signals.ncols()).map(move |i| (k, i)))
        .find(|&(k, i)| !signals[(k, i)].is_finite())
    {
        return Err(Error::Data {
            reason: format!(
                "{METHOD}: a channel of the linear model has no value at {:.3} s (column {i}); the Fourier transform needs every sample",
                times[k]
            ),
        });
    }
    Ok(signals)
}

/// What the equations' regressions read: the time signals ([`signals`]),
/// their transforms at the band's frequencies `omegas`, and the transform
/// itself (for the state derivatives).
struct Equations<'a> {
    structure: &'a LinearStructure,
    signals: &'a DMatrix<f64>,
    transform: &'a FourierTransform,
    columns: &'a [Vec<Complex<f64>>],
    omegas: &'a [f64],
}

/// One equation's regression: its free entries (by index in the
/// structure), their estimates, covariance and standard errors, and the
/// fit of its left side.
struct Fitted {
    free: Vec<usize>,
    theta: DVector<f64>,
    covariance: DMatrix<f64>,
    fit: OutputFit,
}

impl Equations<'_> {
    /// The regression of state equation `row` (`state`) or direct output
    /// `row`: None when it has no free entry, or when it has no more real
    /// equations than parameters (the problem pushed to `problems`).
    fn fit(&self, state: bool, row: usize, problems: &mut Vec<String>) -> Option<Fitted> {
        let structure = self.structure;
        let columns = self.columns;
        let (n, m) = (structure.states.len(), structure.inputs.len());
        let direct = structure.outputs.len() - structure.rate_states.len();
        let of_equation = |matrix: Matrix| {
            matches!(
                (state, matrix),
                (true, Matrix::A | Matrix::B | Matrix::StateBias)
                    | (false, Matrix::C | Matrix::D | Matrix::OutputBias)
            )
        };
        let free: Vec<usize> = (0..structure.names.len())
            .filter(|&i| {
                let entry = &structure.entries[i][0];
                entry.row == row && of_equation(entry.matrix)
            })
            .filter(|&i| structure.free[i])
            .collect();
        if free.is_empty() {
            return None;
        }
        let regressor = |i: usize| -> &Vec<Complex<f64>> {
            let entry = &structure.entries[i][0];
            match entry.matrix {
                Matrix::A | Matrix::C => &columns[entry.column],
                Matrix::B | Matrix::D => &columns[n + entry.column],
                _ => &columns[n + m + direct],
            }
        };
        let z = self.left_side(state, row, &free);
        let rows: Vec<(usize, bool)> = self
            .omegas
            .iter()
            .enumerate()
            .flat_map(|(f, &w)| std::iter::once((f, false)).chain((w > 0.0).then_some((f, true))))
            .collect();
        let part = |c: Complex<f64>, imaginary: bool| if imaginary { c.im } else { c.re };
        let name = if state {
            format!("d{}/dt", structure.states[row])
        } else {
            structure.outputs[row].clone()
        };
        if rows.len() <= free.len() {
            problems.push(format!(
                "{name}: {} real equations for {} parameters",
                rows.len(),
                free.len()
            ));
            return None;
        }
        let x = DMatrix::from_fn(rows.len(), free.len(), |r, c| {
            part(regressor(free[c])[rows[r].0], rows[r].1)
        });
        let zs = DVector::from_fn(rows.len(), |r, _| part(z[rows[r].0], rows[r].1));
        let fit = aeroid_numerics::regression::LeastSquares::fit(&x, &zs);
        let covariance = fit.weighted_covariance(
            &x,
            &local_variances(&rows, &fit.residuals, self.omegas.len(), free.len()),
        );
        let predicted: Vec<f64> = (0..zs.len()).map(|r| zs[r] - fit.residuals[r]).collect();
        Some(Fitted {
            free,
            theta: fit.theta,
            covariance,
            fit: OutputFit::new(
                &format!("{name} (Fourier transforms)"),
                zs.as_slice(),
                &predicted,
            ),
        })
    }

    /// The equation's left side: the transform of the state's derivative
    /// or of the output, less every term whose entry is fixed (at its
    /// value; the `free` ones are the regressors).
    fn left_side(&self, state: bool, row: usize, free: &[usize]) -> Vec<Complex<f64>> {
        let structure = self.structure;
        let columns = self.columns;
        let (n, m) = (structure.states.len(), structure.inputs.len());
        let direct = structure.outputs.len() - structure.rate_states.len();
        let mut z: Vec<Complex<f64>> = if state {
            let series: Vec<f64> = self.signals.column(row).iter().copied().collect();
            self.transform.derivative(&columns[row], &series)
        } else {
            columns[n + m + row].clone()
        };
        let matrices = &structure.matrices;
        let fixed = |matrix: Matrix, j: usize| -> f64 {
            match matrix {
                Matrix::A => matrices.a[(row, j)],
                Matrix::B => matrices.b[(row, j)],
                Matrix::C => matrices.c[(row, j)],
                Matrix::D => matrices.d[(row, j)],
                Matrix::StateBias => matrices.state_bias[row],
                Matrix::OutputBias => matrices.output_bias[row],
            }
        };
        let (states, inputs, constant) = if state {
            (Matrix::A, Matrix::B, Matrix::StateBias)
        } else {
            (Matrix::C, Matrix::D, Matrix::OutputBias)
        };
        let terms = (0..n)
            .map(|j| (states, j, &columns[j]))
            .chain((0..m).map(|j| (inputs, j, &columns[n + j])))
            .chain(std::iter::once((constant, 0, &columns[n + m + direct])));
        for (matrix, j, series) in terms {
            let is_free = free.iter().any(|&i| {
                let e = &structure.entries[i][0];
                e.matrix == matrix && e.column == j
            });
            let value = fixed(matrix, j);
            if !is_free && value != 0.0 {
                for (zv, x) in z.iter_mut().zip(series) {
                    *zv -= x * value;
                }
            }
        }
        z
    }
}

/// The estimate of the equations' regressions: the parameters in the
/// structure's order, the covariance of each equation's block (the
/// equations' estimates independent), converged unless an equation had
/// a problem; `note` on the transforms.
fn estimate(
    record: &FlightRecord,
    structure: &LinearStructure,
    fitted: Vec<Fitted>,
    problems: Vec<String>,
    note: String,
) -> Estimate {
    let starts = structure.parameter_values();
    let mut parameters: Vec<(usize, f64, f64)> = Vec::new();
    let mut blocks = Vec::new();
    let mut fits = Vec::new();
    for equation in fitted {
        for (c, &i) in equation.free.iter().enumerate() {
            parameters.push((i, equation.theta[c], equation.covariance[(c, c)].sqrt()));
        }
        blocks.push((equation.free, equation.covariance));
        fits.push(equation.fit);
    }
    parameters.sort_by_key(|p| p.0);
    let position = |i: usize| parameters.iter().position(|p| p.0 == i).unwrap_or(0);
    let mut covariance = vec![vec![0.0; parameters.len()]; parameters.len()];
    for (indices, block) in &blocks {
        for (a, &i) in indices.iter().enumerate() {
            for (b, &j) in indices.iter().enumerate() {
                covariance[position(i)][position(j)] = block[(a, b)];
            }
        }
    }
    Estimate {
        method: METHOD.to_string(),
        model: structure.name.clone(),
        record: regression::record_name(record),
        diagnoses: Vec::new(),
        status: if problems.is_empty() {
            Status::Converged
        } else {
            Status::Diverged(problems.join("; "))
        },
        parameters: parameters
            .iter()
            .map(|&(i, value, standard_error)| ParameterEstimate {
                name: structure.names[i].clone(),
                value,
                standard_error,
                start: starts[i],
            })
            .collect(),
        covariance,
        fits,
        iterations: 1,
        cost_history: Vec::new(),
        wall_time: 0.0,
        notes: vec![note],
        details: String::new(),
        network: None,
        distributions: Vec::new(),
        histories: Vec::new(),
    }
}
