//! The fit as a problem: its unknowns, its records' segments and the simulation of one parameter vector.

use super::*;

/// An unknown of the fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Unknown {
    Aero(usize),
    Initial { segment: usize, state: usize },
    Bias { output: usize },
}

/// Recorded samples of one output in one manoeuvre.
#[derive(Debug, Clone)]
pub(super) struct Measured {
    pub(super) times: Vec<f64>,
    pub(super) values: Vec<f64>,
    /// Where each sample lies on the segment's integration grid
    /// ([`grid_bracket`]): found once, used by every prediction and Jacobian.
    pub(super) brackets: Vec<(usize, f64)>,
}

/// One manoeuvre: its driven simulation, initial state and measured outputs.
#[derive(Debug, Clone)]
pub(super) struct Segment<'a> {
    pub(super) simulation: DrivenSimulation,
    pub(super) initial: FlightPathState,
    pub(super) outputs: Vec<Measured>,
    /// The record and window it is driven by, for a new integration step.
    pub(super) record: &'a FlightRecord,
    pub(super) window: (f64, f64),
    /// The grid step the samples fall on, and the RK4 steps each of its
    /// intervals is integrated in ([`Segment::resolve`]); None where the
    /// user gave the step.
    pub(super) substeps: Option<(f64, usize)>,
    /// The notes of the grid that stay when the step is re-chosen (the
    /// channels' instants).
    pub(super) grid_notes: Vec<String>,
    /// How often the sub-steps were re-chosen as the parameters moved, and
    /// the fastest |λ| at the last choice.
    pub(super) rechosen: usize,
    pub(super) fastest: f64,
}

pub(super) struct Objective<'a> {
    pub(super) model: FlightModel,
    pub(super) segments: Vec<Segment<'a>>,
    /// Every unknown of the fit: the simulations' sensitivity columns.
    pub(super) all: Vec<Unknown>,
    /// The unknowns the solver adjusts now (all of them, or all but the
    /// initial states in the first stage); the others keep their values.
    pub(super) unknowns: Vec<Unknown>,
    pub(super) outputs: Vec<String>,
    pub(super) observables: Vec<Observable>,
    /// 1/σ per output (R = diag(σ²)).
    pub(super) weights: Vec<f64>,
    /// Where the sensitivity equations are linearised (see [`Linearise`]).
    pub(super) linearise: Linearise,
    /// Whether [`LeastSquaresObjective::refine`] may switch the linearisation
    /// to [`Linearise::Stages`] (the last stage of a fit).
    pub(super) refinable: bool,
    /// The last θ simulated, its predictions and its grids: the solver asks
    /// for the residuals at an accepted step's θ again (re-weighting) and
    /// then for the Jacobian there, which the grids' sensitivities give.
    pub(super) simulated: Option<Simulated>,
    /// The simulation whose Jacobian is held
    /// ([`LeastSquaresObjective::hold`]): while Some, simulations are plain
    /// and the Jacobian is its grids'.
    pub(super) held: Option<Simulated>,
    /// How the segments are simulated: the integrated states, the inputs'
    /// interpolation, and whether χ takes the measured α̇.
    pub(super) integrate: Vec<usize>,
    pub(super) interpolation: InputInterpolation,
    pub(super) alpha_dot: bool,
    /// Whether χ is a state (τ1 > 0): a θ that changes it cannot be simulated.
    pub(super) chi_is_state: bool,
    /// Whether the last re-weighting re-chose a grid ([`Objective::resolve_steps`]).
    pub(super) regridded: bool,
}

/// A simulation at θ: predictions at the samples, and the grids with
/// sensitivities to every unknown (in the `Linearise` mode recorded) when
/// computed.
pub(super) struct Simulated {
    /// The values of all unknowns ([`Objective::values`]).
    pub(super) key: DVector<f64>,
    pub(super) predictions: Predictions,
    pub(super) grids: Option<(Vec<Grid>, Linearise)>,
    /// The grids' Jacobian, assembled when first asked for.
    pub(super) assembled: Option<Assembled>,
}

/// A simulation's Jacobian ∂y/∂θ at the samples (unweighted; the residuals'
/// Jacobian is −R^{-1/2} times it, so a held one is re-weighted by scaling
/// rows) for the solver's `unknowns`, row after row, and per output the
/// Gram matrix of its rows, so that JᵀJ = Σ_o G_o/σ_o².
pub(super) struct Assembled {
    pub(super) unknowns: Vec<Unknown>,
    /// Row-major: row i is `sensitivities[i·m..(i + 1)·m]`, m unknowns.
    pub(super) sensitivities: Vec<f64>,
    /// Each output's rows.
    pub(super) rows: Vec<std::ops::Range<usize>>,
    pub(super) grams: Vec<DMatrix<f64>>,
}

impl Assembled {
    pub(super) fn row(&self, i: usize) -> &[f64] {
        let m = self.unknowns.len();
        &self.sensitivities[i * m..(i + 1) * m]
    }
}

/// Model outputs at every recorded sample: [segment][output][sample].
pub(super) type Predictions = Vec<Vec<Vec<f64>>>;

/// A segment's outputs and their sensitivities on the integration grid.
pub(super) struct Grid {
    /// [output][grid point].
    pub(super) values: Vec<Vec<f64>>,
    /// ∂y/∂θ over the grid, grid point after grid point, each point's
    /// block as the simulation gives it ((∂y/∂θ)ᵀ, all unknowns × outputs,
    /// column-major: output o's sensitivity to unknown c at
    /// `k·block + o·all + c`), so that storing a point is one copy and an
    /// output's sensitivities lie together.
    pub(super) sensitivities: Vec<f64>,
}

pub(super) fn unknowns(
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    segments: &[Segment],
) -> Vec<Unknown> {
    let mut unknowns: Vec<Unknown> = (0..structure.free.len())
        .filter(|&i| structure.free[i])
        .map(Unknown::Aero)
        .collect();
    if options.estimate_initial_state {
        for segment in 0..segments.len() {
            unknowns.extend(
                structure
                    .integrate
                    .iter()
                    .filter(|&&s| s != 10)
                    .map(|&state| Unknown::Initial { segment, state }),
            );
        }
    }
    for name in &options.output_biases {
        if let Some(output) = structure.outputs.iter().position(|o| o == name) {
            unknowns.push(Unknown::Bias { output });
        }
    }
    unknowns
}

impl<'a> Objective<'a> {
    pub(super) fn new(
        records: &[&'a FlightRecord],
        structure: &ModelStructure,
        options: &OutputErrorOptions,
    ) -> Result<Objective<'a>> {
        let observables = observables(structure)?;
        let mut segments = Vec::with_capacity(records.len());
        for record in records {
            match options.segment {
                None => segments.push(segment(record, structure, options)?),
                Some(length) => {
                    for window in pieces(record, structure, options, length)? {
                        let piece = OutputErrorOptions {
                            window: Some(window),
                            ..options.clone()
                        };
                        segments.push(segment(record, structure, &piece)?);
                    }
                }
            }
        }
        let all = unknowns(structure, options, &segments);
        let model = FlightModel::new(structure.aircraft.clone(), Default::default());
        Ok(Objective::from_segments(
            model,
            segments,
            all,
            observables,
            structure,
            options,
        ))
    }

    /// The objective of `model` over `segments` with the unknowns `all`,
    /// all of them free, comparing `observables` (the structure's outputs),
    /// every output weighted 1, nothing simulated yet.
    pub(super) fn from_segments(
        model: FlightModel,
        segments: Vec<Segment<'a>>,
        all: Vec<Unknown>,
        observables: Vec<Observable>,
        structure: &ModelStructure,
        options: &OutputErrorOptions,
    ) -> Objective<'a> {
        Objective {
            model,
            unknowns: all.clone(),
            all,
            segments,
            outputs: structure.outputs.clone(),
            observables,
            weights: vec![1.0; structure.outputs.len()],
            linearise: Linearise::GridPoints,
            refinable: false,
            simulated: None,
            held: None,
            integrate: structure.integrate.clone(),
            interpolation: options.interpolation.clone(),
            alpha_dot: structure.aircraft.aero.takes_measured_alpha_dot(),
            chi_is_state: structure.aircraft.aero.chi_is_state(),
            regridded: false,
        }
    }

    /// Re-chooses each segment's RK4 sub-steps for the model at θ
    /// ([`Segment::resolve`]); a changed grid drops the simulations made
    /// on the old one. Returns whether any grid changed.
    pub(super) fn resolve_steps(&mut self, theta: &DVector<f64>) -> crate::Result<bool> {
        self.apply(theta);
        if self.model.aircraft.aero.chi_is_state() != self.chi_is_state {
            return Err(crate::Error::Tau1Sign);
        }
        let mut changed = false;
        for segment in &mut self.segments {
            changed |= segment.resolve(
                &self.model,
                &self.integrate,
                &self.interpolation,
                self.alpha_dot,
            )?;
        }
        if changed {
            self.simulated = None;
            self.held = None;
        }
        self.regridded = changed;
        Ok(changed)
    }

    /// The current values of the solver's unknowns.
    pub(super) fn current(&self) -> DVector<f64> {
        self.values(&self.unknowns, &vec![0.0; self.outputs.len()])
    }

    /// Moves the aerodynamic values to equation error's estimates on
    /// `record` (white bounds only: they are not used) when the structure
    /// allows equation error and they fit better than the current values
    /// ([`Objective::start_cost`]); returns whether it did, with a note either way.
    pub(super) fn start_from_equation_error(
        &mut self,
        record: &FlightRecord,
        structure: &ModelStructure,
        given: Option<&Estimate>,
        notes: &mut Vec<String>,
    ) -> bool {
        let estimate = match start_estimate(record, structure, given) {
            Ok(estimate) => estimate,
            Err(reason) => {
                notes.push(format!("started from the model file's values: {reason}"));
                return false;
            }
        };
        let file = self.current();
        let mut regression = file.clone();
        let names = self.model.aircraft.aero.parameters.names();
        for (j, unknown) in self.unknowns.iter().enumerate() {
            if let Unknown::Aero(i) = *unknown
                && let Some(p) = estimate.parameters.iter().find(|p| p.name == names[i])
            {
                let (low, high) = structure.bounds[i];
                regression[j] = p.value.clamp(low, high);
            }
        }
        // The file's values without sensitivities, then equation error's
        // with them: the likely start's simulation is the first iteration's.
        let file_cost = self.start_cost(&file, false);
        let costs = (self.start_cost(&regression, true), file_cost);
        let chosen = match costs {
            (Ok(regression_cost), Ok(file_cost)) if regression_cost < file_cost => {
                notes.push(format!(
                    "started from equation error's estimates (cost ½·Σ N·ln R {regression_cost:.1}, the model file's values {file_cost:.1})"
                ));
                true
            }
            (Ok(regression_cost), Ok(file_cost)) => {
                notes.push(format!(
                    "started from the model file's values (cost ½·Σ N·ln R {file_cost:.1}, equation error's estimates {regression_cost:.1})"
                ));
                false
            }
            (Err(reason), _) => {
                notes.push(format!(
                    "started from the model file's values: equation error's estimates cannot be simulated ({reason})"
                ));
                false
            }
            (Ok(_), Err(_)) => {
                notes.push(
                    "started from equation error's estimates: the model file's values cannot be simulated".into(),
                );
                true
            }
        };
        self.apply(if chosen { &regression } else { &file });
        chosen
    }

    /// The maximum-likelihood cost with R estimated, ½·Σ_o N_o·ln R_oo
    /// (R_oo the mean square residual of output o), from a simulation (with
    /// `sensitivities`, kept for the iterations).
    pub(super) fn start_cost(
        &mut self,
        theta: &DVector<f64>,
        sensitivities: bool,
    ) -> crate::Result<f64> {
        self.simulate(theta, sensitivities)?;
        let errors = self.errors(theta)?;
        Ok(errors
            .iter()
            .filter(|e| !e.is_empty())
            .map(|e| {
                let count = e.len() as f64;
                let mean_square = e.iter().map(|v| v * v).sum::<f64>() / count;
                0.5 * count * mean_square.max(f64::MIN_POSITIVE).ln()
            })
            .sum())
    }

    /// The values of `unknowns` in the model, the initial states and `biases`.
    pub(super) fn values(&self, unknowns: &[Unknown], biases: &[f64]) -> DVector<f64> {
        DVector::from_iterator(
            unknowns.len(),
            unknowns.iter().map(|unknown| match *unknown {
                Unknown::Aero(i) => self.model.aircraft.aero.parameters.values()[i],
                Unknown::Initial { segment, state } => self.segments[segment].initial[state],
                Unknown::Bias { output } => biases[output],
            }),
        )
    }

    pub(super) fn name(&self, unknown: Unknown) -> String {
        match unknown {
            Unknown::Aero(i) => self.model.aircraft.aero.parameters.names()[i].clone(),
            Unknown::Initial { segment, state } => {
                format!("x0[{segment}].{}", FLIGHT_PATH_STATES[state])
            }
            Unknown::Bias { output } => format!("bias.{}", self.outputs[output]),
        }
    }

    /// The modes at θ: the eigenvalues of ∂f/∂x at the first segment's
    /// start ([`mode_eigenvalues`]); None where they cannot be computed.
    pub(super) fn modes(&mut self, theta: &DVector<f64>) -> Option<Vec<nalgebra::Complex<f64>>> {
        self.apply(theta);
        let segment = self.segments.first()?;
        mode_eigenvalues(&segment.simulation, &self.model, &segment.initial).ok()
    }

    /// Sets θ, returning the output biases.
    pub(super) fn apply(&mut self, theta: &DVector<f64>) -> Vec<f64> {
        let mut biases = vec![0.0; self.outputs.len()];
        for (unknown, &value) in self.unknowns.iter().zip(theta.iter()) {
            match *unknown {
                Unknown::Aero(i) => self.model.aircraft.aero.parameters.values_mut()[i] = value,
                Unknown::Initial { segment, state } => {
                    self.segments[segment].initial[state] = value
                }
                Unknown::Bias { output } => biases[output] = value,
            }
        }
        biases
    }

    /// How each unknown (all of them) enters segment `index`'s simulation.
    pub(super) fn columns(&self, index: usize) -> Vec<Column> {
        let aero = &self.model.aircraft.aero;
        self.all
            .iter()
            .map(|unknown| match *unknown {
                Unknown::Aero(i) if aero.term_of(i).is_some() => Column::Term(i),
                Unknown::Aero(i) => Column::Nonlinear(i),
                Unknown::Initial { segment, state } if segment == index => Column::Initial(state),
                Unknown::Initial { .. } | Unknown::Bias { .. } => Column::Unused,
            })
            .collect()
    }

    /// Simulates segment `index` at the applied θ: outputs on the grid, with
    /// their sensitivities to every unknown when `sensitivities`.
    pub(super) fn grid(&self, index: usize, sensitivities: bool) -> crate::Result<Grid> {
        let segment = &self.segments[index];
        let columns = if sensitivities {
            self.columns(index)
        } else {
            Vec::new()
        };
        let points = segment.simulation.len();
        let mut grid = Grid {
            values: vec![Vec::with_capacity(points); self.outputs.len()],
            sensitivities: Vec::with_capacity(points * self.outputs.len() * columns.len()),
        };
        segment.simulation.simulate(
            &self.model,
            &segment.initial,
            &self.observables,
            &columns,
            self.linearise,
            |k, y, dy| {
                debug_assert_eq!(grid.values[0].len(), k);
                for (values, y) in grid.values.iter_mut().zip(y) {
                    values.push(*y);
                }
                grid.sensitivities.extend_from_slice(dy.as_slice());
            },
        )?;
        Ok(grid)
    }

    /// Simulates θ: model outputs at every recorded sample, and the grids
    /// with sensitivities when asked (kept with the predictions for the
    /// Jacobian at the same θ).
    pub(super) fn simulate(
        &mut self,
        theta: &DVector<f64>,
        sensitivities: bool,
    ) -> crate::Result<()> {
        self.simulated = None;
        let biases = self.apply(theta);
        if self.model.aircraft.aero.chi_is_state() != self.chi_is_state {
            return Err(crate::Error::Tau1Sign);
        }
        for segment in &self.segments {
            segment.check_reach(&self.model)?;
        }
        let key = self.values(&self.all, &biases);
        let grids = (0..self.segments.len())
            .map(|index| self.grid(index, sensitivities))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        let predictions = self
            .segments
            .iter()
            .zip(&grids)
            .map(|(segment, grid)| {
                segment
                    .outputs
                    .iter()
                    .zip(&grid.values)
                    .zip(&biases)
                    .map(|((measured, values), bias)| {
                        measured
                            .brackets
                            .iter()
                            .map(|&at| on_grid(values, at) + bias)
                            .collect()
                    })
                    .collect()
            })
            .collect();
        self.simulated = Some(Simulated {
            key,
            predictions,
            grids: sensitivities.then_some((grids, self.linearise)),
            assembled: None,
        });
        Ok(())
    }

    /// Model outputs at every recorded sample at θ (simulated once per θ).
    /// A new θ is simulated with sensitivities (the solver asks for the
    /// Jacobian at every step it accepts, and most steps are accepted),
    /// except while a Jacobian is held: then plainly.
    pub(super) fn predict(&mut self, theta: &DVector<f64>) -> crate::Result<()> {
        if !self.is_simulated(theta, None) {
            let sensitivities = !self.unknowns.is_empty() && self.held.is_none();
            self.simulate(theta, sensitivities)?;
        }
        Ok(())
    }

    /// Whether the last simulation was at θ (with the solver's unknowns at θ
    /// and the others at their values), with sensitivities linearised as
    /// `linearise` asks when Some (an exact linearisation serves any).
    pub(super) fn is_simulated(
        &mut self,
        theta: &DVector<f64>,
        linearise: Option<Linearise>,
    ) -> bool {
        let biases = self.apply(theta);
        let key = self.values(&self.all, &biases);
        match (&self.simulated, linearise) {
            (Some(simulated), None) => simulated.key == key,
            (Some(simulated), Some(wanted)) => {
                simulated.key == key
                    && matches!(simulated.grids, Some((_, mode)) if mode == wanted || mode == Linearise::Stages)
            }
            (None, _) => false,
        }
    }

    /// The predictions of the last simulation ([`Objective::predict`]).
    pub(super) fn predictions(&self) -> &Predictions {
        &self.simulated.as_ref().expect("predicted").predictions
    }

    /// Unweighted residuals z − y per output, all segments concatenated.
    pub(super) fn errors(&mut self, theta: &DVector<f64>) -> crate::Result<Vec<Vec<f64>>> {
        self.predict(theta)?;
        let mut errors = vec![Vec::new(); self.outputs.len()];
        for (segment, predicted) in self.segments.iter().zip(self.predictions()) {
            for (o, (measured, predicted)) in segment.outputs.iter().zip(predicted).enumerate() {
                errors[o].extend(measured.values.iter().zip(predicted).map(|(z, y)| z - y));
            }
        }
        Ok(errors)
    }

    pub(super) fn estimate(
        &mut self,
        structure: &ModelStructure,
        records: &[&FlightRecord],
        start: &DVector<f64>,
        solution: &gauss_newton::Solution,
        wall_time: f64,
    ) -> Estimate {
        let mut notes: Vec<String> = self
            .segments
            .iter()
            .flat_map(|s| s.simulation.notes.iter().cloned().chain(s.rechosen_note()))
            .collect();
        notes.sort();
        notes.dedup();
        // Pieces of one record each choose their step: one note says it.
        let steps: Vec<usize> = (0..notes.len())
            .filter(|&i| notes[i].starts_with("integration step"))
            .collect();
        if steps.len() > 1 && self.segments.len() > 1 {
            notes[steps[0]].push_str(&format!(
                " (the finest of {} different steps, each piece's and record's own)",
                steps.len()
            ));
            for &i in steps[1..].iter().rev() {
                notes.remove(i);
            }
        }
        let determinant: f64 = self.weights.iter().map(|w| w.powi(-2)).product();
        notes.push(format!(
            "R is diagonal; det(R) = {determinant:.4e} at the solution"
        ));
        let record = records
            .iter()
            .map(|r| r.scenario.clone())
            .collect::<Vec<_>>()
            .join(", ");
        let names: Vec<String> = self
            .unknowns
            .iter()
            .map(|&unknown| self.name(unknown))
            .collect();
        Estimate {
            fits: self.fits(&solution.theta),
            wall_time,
            notes,
            ..Estimate::from_solution(
                ("oem", structure.name.clone(), record),
                &names,
                start,
                solution,
            )
        }
    }

    /// Fit metrics per output at θ; empty when the model cannot be simulated there.
    pub(super) fn fits(&mut self, theta: &DVector<f64>) -> Vec<OutputFit> {
        self.try_fits(theta).unwrap_or_default()
    }

    pub(super) fn try_fits(&mut self, theta: &DVector<f64>) -> crate::Result<Vec<OutputFit>> {
        self.predict(theta)?;
        let predictions = self.predictions();
        Ok((0..self.outputs.len())
            .map(|o| {
                let measured: Vec<f64> = self
                    .segments
                    .iter()
                    .flat_map(|s| s.outputs[o].values.clone())
                    .collect();
                let predicted: Vec<f64> = predictions.iter().flat_map(|p| p[o].clone()).collect();
                OutputFit::new(&self.outputs[o], &measured, &predicted)
            })
            .collect())
    }
}
