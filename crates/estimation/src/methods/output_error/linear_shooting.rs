//! Output error on a linear structure with estimated initial states, by
//! multiple shooting (`segment`; Jategaonkar, "Flight Vehicle System
//! Identification", 2nd ed., ch. 9, the multiple-shooting method for
//! unstable aircraft; Bock's multiple shooting): each record's fitting
//! window is cut into pieces of about `segment` seconds (one piece per
//! record without it: `estimate_initial_state`, or several records fitted
//! jointly), and each piece i is simulated from its own initial state x₀ⁱ,
//! an unknown of the fit beside the model's free parameters θ, shared by
//! every record:
//!
//!   x_{s_i} = x₀ⁱ,   x_{k+1} = Φ(θ)·x_k + Γ₀(θ)·(u_k, 1)   (s_i ≤ k < e_i),
//!   y_k = C·x_k + D·u_k + c,
//!
//! the model's exact discrete step ([`crate::model::linear`]).
//! An unstable mode of the model then grows over one piece only, by
//! 2^(segment/T₂), T₂ its time to double, instead of over the whole
//! record: the simulation stays near the flight and the cost near
//! quadratic in θ, where a simulation of the whole record from the first
//! samples diverges from the flight with any error of its initial state or
//! inputs (the failure of plain output error on an unstable aircraft). The
//! pieces are not tied together (no continuity constraint): each piece's
//! initial state is free, which costs n unknowns per piece and the
//! information its first samples would carry.
//!
//! The cost is output error's (module [`super`]): the negative
//! log-likelihood with a diagonal R re-estimated from the residuals of all
//! pieces at every iteration, R_oo the mean square residual of output o
//! ([`super::diagonal_weights`]), minimised by Gauss–Newton on the
//! whitened residuals ([`gauss_newton`]) with the Jacobian by central
//! differences of the pieces' simulations (step 10⁻⁶·max(|u|, typical)).
//! Cramér–Rao bounds from the information matrix at the solution, the
//! initial states' among the unknowns (they are in the estimate as
//! `x0[i].state`, pieces numbered through the records in turn). Each
//! record keeps its own grid and inputs. The pieces are those of the
//! 6-DOF path: the window's length over `segment`, rounded, equal pieces,
//! a sample on a boundary belonging to the later piece. A record's first
//! piece starts the search from the file's `initial_state` (else the
//! record's states), a later piece from the record's states.

use crate::error::{Error, Result};
use crate::estimate::{Estimate, OutputFit};
use crate::linear_structure::LinearStructure;
use crate::methods::common::linear_data::{LinearData, linear_data};
use crate::methods::common::refusals::enough_data;
use crate::model::linear::LinearStateSpace;
use crate::model::observations::Observations;
use crate::model::state_space::StateSpaceModel;
use aeroid_numerics::gauss_newton::{self, LeastSquaresObjective, Options};
use aeroid_record::FlightRecord;
use nalgebra::DVector;

/// How [`fit`] runs.
pub(crate) struct ShootingOptions {
    pub max_iterations: usize,
    pub step: Option<f64>,
    pub window: Option<(f64, f64)>,
    /// The pieces' length (s); None: one piece per record.
    pub segment: Option<f64>,
    /// The convergence threshold on the predicted decrease.
    pub decrease: f64,
}

/// One record's model (its grid and inputs) and observations.
struct Flight {
    model: LinearStateSpace,
    observations: Observations,
}

/// A piece: the record it is of, its first and last grid points.
#[derive(Debug, Clone, Copy)]
struct Piece {
    flight: usize,
    first: usize,
    last: usize,
}

/// Output error with multiple shooting on `structure` over `records`, θ
/// shared (module documentation).
pub(crate) fn fit(
    method: &str,
    records: &[&FlightRecord],
    structure: &LinearStructure,
    options: &ShootingOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let mut flights = Vec::new();
    let mut pieces = Vec::new();
    let mut start = Vec::new();
    let mut notes: Vec<String> = Vec::new();
    let mut free = Vec::new();
    for (f, record) in records.iter().enumerate() {
        let LinearData {
            free: free_here,
            model,
            initial,
            step,
            observations,
        } = linear_data(method, record, structure, options.step, options.window)?;
        free = free_here;
        let cut = match options.segment {
            Some(segment) => pieces_of(method, record, &observations, step, segment)?,
            None => vec![(0, observations.at.len() - 1)],
        };
        for (first, last) in cut {
            let x0 = if first == 0 {
                initial.clone()
            } else {
                structure.recorded_state(record, model.time(first))
            };
            start.push(x0);
            pieces.push(Piece {
                flight: f,
                first,
                last,
            });
        }
        notes.extend(observations.note(step));
        let timing = format!(
            "linear model, {}, started from the model file's values",
            crate::input_timing::note(&model.input_timing)
        );
        if !notes.contains(&timing) {
            notes.push(timing);
        }
        flights.push(Flight {
            model,
            observations,
        });
    }
    let n = structure.states.len();
    let observed: Vec<&Observations> = flights.iter().map(|f| &f.observations).collect();
    enough_data(method, &observed, free.len() + n * pieces.len())?;
    let theta = structure.parameter_values();
    let start = DVector::from_iterator(
        free.len() + n * pieces.len(),
        free.iter()
            .map(|&i| theta[i])
            .chain(start.iter().flat_map(|x0| x0.iter().copied())),
    );
    let mut names: Vec<String> = free.iter().map(|&i| structure.names[i].clone()).collect();
    for i in 0..pieces.len() {
        names.extend(structure.states.iter().map(|s| format!("x0[{i}].{s}")));
    }
    let mut problem = Shooting {
        flights: &flights,
        pieces: &pieces,
        theta,
        free: free.clone(),
        states: n,
        weights: vec![1.0; structure.outputs.len()],
        names: names.clone(),
    };
    problem.reweight(&start)?;
    let mut solver = Options::new(start.len());
    solver.max_iterations = options.max_iterations;
    solver.decrease_tolerance = Some(options.decrease);
    for (j, &i) in free.iter().enumerate() {
        solver.bounds[j] = structure.bounds[i];
        solver.typical[j] = 1e-3_f64.max(1e-2 * problem.theta[i].abs());
    }
    let solution = gauss_newton::solve(&mut problem, &start, &solver);
    let fits = problem
        .predicted(&solution.theta)
        .map(|(measured, predicted)| {
            (0..structure.outputs.len())
                .map(|o| OutputFit::new(&structure.outputs[o], &measured[o], &predicted[o]))
                .collect()
        })
        .unwrap_or_default();
    notes.push(shooting_note(records, &pieces, options.segment));
    let determinant: f64 = problem.weights.iter().map(|w| w.powi(-2)).product();
    notes.push(format!(
        "R is diagonal; det(R) = {determinant:.4e} at the solution"
    ));
    let record = records
        .iter()
        .map(|r| r.scenario.clone())
        .collect::<Vec<_>>()
        .join(", ");
    Ok(Estimate {
        fits,
        notes,
        wall_time: started.elapsed().as_secs_f64(),
        ..Estimate::from_solution(
            (method, structure.name.clone(), record),
            &names,
            &start,
            &solution,
        )
    })
}

/// What the pieces are, and with several records which are whose.
fn shooting_note(records: &[&FlightRecord], pieces: &[Piece], segment: Option<f64>) -> String {
    let how = match segment {
        Some(segment) => format!(
            "multiple shooting: {} pieces of about {segment} s",
            pieces.len()
        ),
        None => format!(
            "initial states estimated: {} piece(s), one per record",
            pieces.len()
        ),
    };
    let whose = (records.len() > 1).then(|| {
        let per_record: Vec<String> = records
            .iter()
            .enumerate()
            .map(|(f, record)| {
                let numbers: Vec<usize> = (0..pieces.len())
                    .filter(|&i| pieces[i].flight == f)
                    .collect();
                match (numbers.first(), numbers.last()) {
                    (Some(a), Some(b)) if a != b => {
                        format!("record {} '{}' x0[{a}–{b}]", f + 1, record.scenario)
                    }
                    (Some(a), _) => format!("record {} '{}' x0[{a}]", f + 1, record.scenario),
                    _ => format!("record {} '{}' none", f + 1, record.scenario),
                }
            })
            .collect();
        format!(" ({})", per_record.join(", "))
    });
    format!(
        "{how}, each simulated from its own estimated initial state{}",
        whose.unwrap_or_default()
    )
}

/// The pieces' first and last grid points: the window's length over
/// `segment`, rounded (at least 1), in equal pieces; an error naming the
/// setting when a piece holds fewer than two samples of an output.
fn pieces_of(
    method: &str,
    record: &FlightRecord,
    observations: &Observations,
    step: f64,
    segment: f64,
) -> Result<Vec<(usize, usize)>> {
    let intervals = observations.at.len() - 1;
    let count = ((intervals as f64 * step) / segment).round().max(1.0) as usize;
    let boundary = |i: usize| (i * intervals + count / 2) / count;
    let pieces: Vec<(usize, usize)> = (0..count)
        .map(|i| {
            let last = if i + 1 == count {
                intervals
            } else {
                boundary(i + 1) - 1
            };
            (boundary(i), last)
        })
        .collect();
    for (o, name) in observations.names.iter().enumerate() {
        for &(first, last) in &pieces {
            let samples = observations.at[first..=last]
                .iter()
                .filter(|point| point.iter().any(|(output, _)| *output == o))
                .count();
            if samples < 2 {
                return Err(Error::Setting {
                    method: method.to_string(),
                    reason: format!(
                        "segment = {segment} s: the piece {:.3}–{:.3} s of '{}' holds {samples} sample(s) of '{name}'; give a longer segment",
                        first as f64 * step,
                        last as f64 * step,
                        record.scenario
                    ),
                });
            }
        }
    }
    Ok(pieces)
}

/// The least-squares problem: unknowns θ's free entries, then each piece's
/// initial state.
struct Shooting<'a> {
    flights: &'a [Flight],
    pieces: &'a [Piece],
    /// Every parameter's value; the free ones are overwritten from the unknowns.
    theta: DVector<f64>,
    free: Vec<usize>,
    states: usize,
    /// 1/σ per output.
    weights: Vec<f64>,
    names: Vec<String>,
}

/// Per output: the measured values and the predicted ones, pieces in turn.
type Series = (Vec<Vec<f64>>, Vec<Vec<f64>>);

impl Shooting<'_> {
    /// Every output's measured and predicted samples at the unknowns `u`;
    /// an error where a piece's simulation is not finite.
    fn predicted(&self, u: &DVector<f64>) -> crate::Result<Series> {
        let mut theta = self.theta.clone();
        for (j, &i) in self.free.iter().enumerate() {
            theta[i] = u[j];
        }
        let outputs = self.weights.len();
        let (mut measured, mut predicted) = (vec![Vec::new(); outputs], vec![Vec::new(); outputs]);
        let p = self.free.len();
        for (i, piece) in self.pieces.iter().enumerate() {
            let Flight {
                model,
                observations,
            } = &self.flights[piece.flight];
            let mut x = DVector::from_iterator(
                self.states,
                u.rows(p + i * self.states, self.states).iter().copied(),
            );
            for k in piece.first..=piece.last {
                if k > piece.first {
                    x = model.step(k - 1, x.as_slice(), theta.as_slice())?;
                }
                let present = &observations.at[k];
                if present.is_empty() {
                    continue;
                }
                let y = model.outputs(model.time(k), x.as_slice(), theta.as_slice())?;
                for &(o, z) in present {
                    if !y[o].is_finite() {
                        return Err(Error::PieceDeparted {
                            piece: i,
                            time: model.time(k),
                        });
                    }
                    measured[o].push(z);
                    predicted[o].push(y[o]);
                }
            }
        }
        Ok((measured, predicted))
    }
}

impl LeastSquaresObjective for Shooting<'_> {
    type Error = crate::Error;

    fn residuals(&mut self, u: &DVector<f64>) -> crate::Result<DVector<f64>> {
        let (measured, predicted) = self.predicted(u)?;
        Ok(DVector::from_iterator(
            measured.iter().map(Vec::len).sum(),
            measured
                .iter()
                .zip(&predicted)
                .zip(&self.weights)
                .flat_map(|((z, y), w)| z.iter().zip(y).map(move |(z, y)| (z - y) * w)),
        ))
    }

    fn unknown_name(&self, index: usize) -> Option<String> {
        self.names.get(index).cloned()
    }

    fn reweight(&mut self, u: &DVector<f64>) -> crate::Result<bool> {
        let (measured, predicted) = self.predicted(u)?;
        let errors: Vec<Vec<f64>> = measured
            .iter()
            .zip(&predicted)
            .map(|(z, y)| z.iter().zip(y).map(|(z, y)| z - y).collect())
            .collect();
        let weights = super::diagonal_weights(&errors, &measured);
        let changed = weights != self.weights;
        self.weights = weights;
        Ok(changed)
    }
}
