//! The integration of a driven model over its grid ([`DrivenSimulation`]):
//! plain RK4 steps of the integrated states, the others the measured
//! pseudo-controls (linear inside a step, their rates centred differences),
//! each control held or linear; and the sensitivities S = ∂x/∂θ by the
//! matching RK4 step of Ṡ = (∂f/∂x)·S + ∂f/∂θ ([`rk4_linear_step`]),
//! linearised at every stage or at the grid points only ([`Linearise`]),
//! ∂y/∂θ = ∂g/∂x·S + ∂g/∂θ. The step from one grid point, for one state or
//! many ([`PlainSteps`]: an unscented filter's sigma points), is the same
//! function of its start state.

use super::directions::{Directions, Response, Source, state_step};
use super::kinematics::{Angles, PseudoRates, derivative, derivative_at, kinematics};
use super::linearise::Linearization;
use super::measured::Ambient;
use super::memo::{Frozen, Memo, between};
use super::observables::Column;
use super::{AIRSPEED, ALPHA, BETA, CHI, FLIGHT_PATH_SIZE, FlightPathState};
use crate::input_timing::{Chosen, InputInterpolation};
use crate::structure::Observable;
use crate::{Error, Result};
use aeroid_sim::atmosphere::Atmosphere;
use aeroid_sim::dynamics::{FlightModel, Forcing, Kinematics};
use aeroid_sim::integrator::{Interpolation, affine, rk4_linear_step, rk4_step};
use aeroid_sim::state::{CONTROL_COUNT, Controls};
use nalgebra::DMatrix;

/// Where [`DrivenSimulation::simulate`] linearises the model for the
/// sensitivity equations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Linearise {
    /// At every RK4 stage state (four linearisations per step): S is the
    /// exact derivative of the discrete simulation, for the information
    /// matrix and Cramér–Rao bounds.
    Stages,
    /// At the grid points only (one per step), their mean at the middle
    /// stages: within O(h²) of the exact derivative where the model varies
    /// smoothly, and O(h) at a step in a held control (∂f/∂x there keeps the
    /// new value). Measured: 5e-4 of a column on the ATTAS lateral model,
    /// 1.5 % on the longitudinal one at a 3211's switches, 3 % on the
    /// stall model's τ1 through the break. Good enough to steer
    /// Gauss–Newton (an approximate Jacobian changes the path, not the
    /// optimum it stops at to within the noise; see `output_error`), at
    /// about half the cost of the stage linearisation (docs/performance.md).
    GridPoints,
}

/// A postulated model's inputs and pseudo-controls on an integration grid.
#[derive(Debug, Clone)]
pub struct DrivenSimulation {
    pub start: f64,
    pub step: f64,
    /// How each control is taken inside a step (by [`Control::index`](aeroid_sim::state::Control::index)).
    pub holds: [Interpolation; CONTROL_COUNT],
    /// The controls the record has, each with its interpolation and why.
    pub input_timing: Vec<Chosen>,
    /// Which flight-path states are integrated (others are measured).
    pub integrate: [bool; FLIGHT_PATH_SIZE],
    pub controls: Vec<Controls>,
    /// Measured flight-path states at the grid points (integrated entries unused).
    pub(super) measured: Vec<FlightPathState>,
    /// The record's measured density and thrust at the grid points.
    pub(super) ambient: Vec<Ambient>,
    pub(super) frozen: Frozen,
    /// Notes for the user (a control held constant because its channel is
    /// absent, a measured quantity used).
    pub notes: Vec<String>,
    /// The notes that name a measured quantity the model takes from the
    /// record instead of its own (also in `notes`).
    pub measured_quantities: Vec<String>,
}

impl DrivenSimulation {
    /// Measured flight-path states at the grid points (integrated entries unused).
    pub fn measured(&self) -> &[FlightPathState] {
        &self.measured
    }

    /// The record's measured density and thrust at grid point k.
    pub fn ambient(&self, k: usize) -> Ambient {
        self.ambient[k]
    }

    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.controls.len()
    }

    pub fn is_empty(&self) -> bool {
        self.controls.is_empty()
    }

    pub fn time(&self, k: usize) -> f64 {
        self.start + k as f64 * self.step
    }

    /// Rates at grid point k of the measured airspeed and sideslip, where
    /// they are not integrated: the centred difference
    /// (x[k+1] − x[k−1])/(2·Δt) (one-sided at the ends), interpolated
    /// linearly inside a step like the measured signals themselves. The rate
    /// at a grid point then leaves out that point's own sample: a rate
    /// sharing a sample's noise, multiplied by the same noisy measured β in
    /// V̇ (Eq. in [`derivative`]), has a non-zero mean, −σ²/Δt, an
    /// errors-in-variables bias on drag; with the centred difference the
    /// product's noise has zero mean at every point of the step (the two
    /// shared-sample terms cancel: θ(1−θ)σ² − (1−θ)θσ²). The rates are
    /// continuous at the grid points, so a step's last stage and the next
    /// grid point see the same model (what the grid-point linearisation of
    /// [`DrivenSimulation::simulate`] relies on).
    pub(in crate::model) fn pseudo_rates(&self, k: usize) -> PseudoRates {
        let last = self.len() - 1;
        let (previous, next) = (k.saturating_sub(1), (k + 1).min(last));
        if next == previous {
            return PseudoRates::default();
        }
        let span = (next - previous) as f64 * self.step;
        let rate = |i: usize| {
            (!self.integrate[i])
                .then(|| (self.measured[next][i] - self.measured[previous][i]) / span)
        };
        PseudoRates {
            airspeed: rate(AIRSPEED),
            beta: rate(BETA),
        }
    }

    /// The state at grid point k: integrated entries from `x`, the rest measured.
    fn merge(&self, x: &FlightPathState, measured: &FlightPathState) -> FlightPathState {
        FlightPathState::from_fn(|i, _| if self.integrate[i] { x[i] } else { measured[i] })
    }

    /// Which flight-path states `model` integrates (1) and which are
    /// measured (0): the structure's integrated states, and χ wherever the
    /// model makes it a state (fed back from α when not integrated).
    /// Whether [`DrivenSimulation::mask`] of `model` is `mask`, for a
    /// `mask` this simulation gave (for any model): the two can differ
    /// only in χ, a state where the simulation integrates it or the
    /// model's stall makes it one.
    pub(in crate::model) fn gives_mask(&self, model: &FlightModel, mask: &FlightPathState) -> bool {
        let chi = self.integrate[CHI] || model.aircraft.aero.chi_is_state();
        (mask[CHI] == 1.0) == chi
    }

    pub(in crate::model) fn mask(&self, model: &FlightModel) -> FlightPathState {
        let chi_is_state = model.aircraft.aero.chi_is_state();
        FlightPathState::from_fn(|i, _| {
            if self.integrate[i] || (i == CHI && chi_is_state) {
                1.0
            } else {
                0.0
            }
        })
    }

    /// The controls a fraction `fraction` ∈ [0, 1] into step k (k + 1 a
    /// grid point): each blended by its own weight,
    /// u_k + w(θ)∘(u_k+1 − u_k), w_i = 0 held, θ linear.
    pub(in crate::model) fn controls_inside(&self, k: usize, fraction: f64) -> Controls {
        let weights = Controls::from_fn(|i, _| self.holds[i].weight(fraction));
        self.controls[k] + (self.controls[k + 1] - self.controls[k]).component_mul(&weights)
    }

    /// The setting that reproduces this simulation's choice per control on
    /// any record (a record with the inputs' noise drawn again).
    pub fn fixed_interpolation(&self) -> InputInterpolation {
        InputInterpolation::fixed(&self.input_timing)
    }

    /// The measured states, controls and pseudo-control rates a fraction
    /// `fraction` ∈ [0, 1] into step k (k the last grid point: its own,
    /// fraction 0): measured pseudo-controls are continuous states, always
    /// linear inside the step (consistent with their rates in
    /// [`DrivenSimulation::pseudo_rates`]); each control held or linear
    /// ([`DrivenSimulation::controls_inside`]; under a hold the step's end
    /// sees the start's value). At fraction 0 the grid point's samples themselves.
    pub(in crate::model) fn inputs_at(
        &self,
        k: usize,
        fraction: f64,
    ) -> (FlightPathState, Controls, PseudoRates, Ambient) {
        if fraction == 0.0 || k + 1 >= self.len() {
            return (
                self.measured[k],
                self.controls[k],
                self.pseudo_rates(k),
                self.ambient[k],
            );
        }
        let ends = (self.pseudo_rates(k), self.pseudo_rates(k + 1));
        self.inputs_inside(k, fraction, ends)
    }

    /// [`DrivenSimulation::inputs_at`] a fraction in (0, 1] into step k,
    /// given the pseudo-control rates at the step's two ends.
    pub(in crate::model) fn inputs_inside(
        &self,
        k: usize,
        fraction: f64,
        (start, end): (PseudoRates, PseudoRates),
    ) -> (FlightPathState, Controls, PseudoRates, Ambient) {
        let (measured, ambient) = if fraction == 1.0 {
            (self.measured[k + 1], self.ambient[k + 1])
        } else {
            (
                between(&self.measured[k], &self.measured[k + 1], fraction),
                self.ambient[k].between(self.ambient[k + 1], fraction),
            )
        };
        let controls = self.controls_inside(k, fraction);
        (measured, controls, start.blend(end, fraction), ambient)
    }

    /// The flight-path state at grid point k (or a fraction into step k)
    /// with the `mask`ed states from `x` and the others from `measured`.
    pub(in crate::model) fn merged(
        x: &FlightPathState,
        measured: &FlightPathState,
        mask: &FlightPathState,
    ) -> FlightPathState {
        FlightPathState::from_fn(|i, _| if mask[i] == 1.0 { x[i] } else { measured[i] })
    }

    /// The measured states, controls and pseudo-control rates at the
    /// later RK4 stage times of step k, its midpoint and its end
    /// ([`DrivenSimulation::inputs_inside`]): the same for every state the
    /// step starts from.
    pub(in crate::model) fn stage_inputs(&self, k: usize) -> StageInputs {
        let ends = (self.pseudo_rates(k), self.pseudo_rates(k + 1));
        let at = |fraction: f64| {
            let (measured, controls, pseudo, _) = self.inputs_inside(k, fraction, ends);
            (measured, controls, pseudo)
        };
        StageInputs {
            k,
            middle: at(0.5),
            end: at(1.0),
        }
    }

    /// The one integration step of the postulated model: RK4
    /// ([`rk4_step`]) from the state `x` at grid point k (`first` its
    /// rates, evaluated by the caller) to grid point k + 1, the `mask`ed
    /// states integrated and the others the next grid point's measured
    /// values, the later stages' inputs `inputs` (step k's,
    /// [`DrivenSimulation::stage_inputs`]). `rates(state, controls, pseudo,
    /// memo)` evaluates ẋ at the three later stages, given the stage's
    /// merged state and inputs with `memo` at its frozen point.
    /// Both [`DrivenSimulation::simulate`] and the state-space view's step
    /// ([`crate::model::state_space`], through [`PlainSteps`]) take their steps
    /// here.
    pub(super) fn step_from(
        &self,
        inputs: &StageInputs,
        x: &FlightPathState,
        mask: &FlightPathState,
        first: &FlightPathState,
        memo: &mut Memo,
        mut rates: impl FnMut(&FlightPathState, &Controls, PseudoRates, &mut Memo) -> FlightPathState,
    ) -> FlightPathState {
        let k = inputs.k;
        let next = rk4_step(x, self.step, |x, fraction| {
            // The first stage is the grid point, evaluated by the caller.
            if fraction == 0.0 {
                return first.component_mul(mask);
            }
            // The step's end is the next grid point; the middle stages are
            // at the step's midpoint.
            let (point, (measured, controls, pseudo)) = if fraction == 1.0 {
                (2 * k + 2, &inputs.end)
            } else {
                (2 * k + 1, &inputs.middle)
            };
            memo.at_point(point);
            let merged = Self::merged(x, measured, mask);
            rates(&merged, controls, *pseudo, memo).component_mul(mask)
        });
        Self::merged(&next, &self.measured[k + 1], mask)
    }

    /// Plain steps of `model`'s form (which states `mask` integrates, the
    /// air of `atmosphere`) from grid point k, for many start states
    /// ([`PlainSteps::step`]).
    pub(in crate::model) fn plain_steps<'a>(
        &'a self,
        k: usize,
        mask: &FlightPathState,
        atmosphere: &Atmosphere,
    ) -> PlainSteps<'a> {
        let measured_states = std::array::from_fn(|i| mask[i] == 0.0);
        let frozen = self.frozen.for_memo(&self.measured, atmosphere);
        let mut memo = Memo::new(measured_states, frozen);
        memo.at_point(2 * k);
        PlainSteps {
            simulation: self,
            mask: *mask,
            atmosphere: *atmosphere,
            inputs: self.stage_inputs(k),
            start: (self.controls[k], self.pseudo_rates(k)),
            memo,
            first: None,
        }
    }

    /// Simulates from `initial`, calling `sink(k, y, (∂y/∂θ)ᵀ)` at every
    /// grid point with the `outputs` and their sensitivities to the unknowns
    /// described by `columns` (none: a plain simulation), an output's
    /// sensitivities a column of the transposed matrix. The state takes
    /// plain RK4 steps; the model is linearised at the grid points only, and
    /// the sensitivities S = ∂x/∂θ of the integrated states take the
    /// matching RK4 step of Ṡ = (∂f/∂x)·S + ∂f/∂θ with the linearisations
    /// of the step's two ends ([`rk4_linear_step`]): one linearisation per
    /// step instead of one per stage, for a Jacobian within O(h²) of the
    /// derivative of the discrete simulation (measured in the output-error
    /// test against central differences); ∂y/∂θ = ∂g/∂x·S + ∂g/∂θ. ∂f/∂x
    /// and ∂g/∂x are exact, by dual numbers along the integrated states
    /// (forward-mode automatic differentiation, [`aeroid_numerics::dual`]; the first
    /// pass's values are the evaluation at x), except along the altitude and
    /// for models whose forces depend on α̇, where they are forward
    /// differences; for a term C_term of coefficient C, f is linear
    /// in C, and ∂f/∂θ = (∂f/∂C)·regressor with ∂f/∂C exact from the
    /// evaluation (`Response::Offset`), or the difference quotient of an
    /// offset on C where the forces depend on α̇; a nonlinear parameter's is
    /// a forward difference.
    /// Err with the time when the model departs (non-finite, |α| or |β|
    /// beyond 90°, airspeed not positive).
    pub fn simulate(
        &self,
        model: &FlightModel,
        initial: &FlightPathState,
        outputs: &[Observable],
        columns: &[Column],
        linearise: Linearise,
        mut sink: impl FnMut(usize, &[f64], &DMatrix<f64>),
    ) -> Result<()> {
        // One pass over the grid: the state, S and the two grid points'
        // linearisations advance together, and the stage closure borrows
        // the stage linearisations; the setup of S and the outputs, and the
        // grid-point sensitivity step, are split out.
        let aero = &model.aircraft.aero;
        let mut x = self.merge(initial, &self.measured[0]);
        let chi_from_alpha = aero.chi_is_state() && !self.integrate[CHI];
        if chi_from_alpha {
            x[CHI] = aero.steady_separation(x[ALPHA]);
        }
        let mask = self.mask(model);
        let active: Vec<usize> = (0..FLIGHT_PATH_SIZE).filter(|&i| mask[i] == 1.0).collect();
        let linearised: &[usize] = if columns.is_empty() { &[] } else { &active };
        let directions = Directions::new(model, columns, linearised, false);
        let mut sensitivity = initial_sensitivity(model, &directions, columns, &x, chi_from_alpha);
        let mut table = OutputTable::new(outputs, &directions.states, columns.len());
        let mut point = Linearization::new(&directions, table.computed.len());
        let mut next_point = Linearization::new(&directions, table.computed.len());
        let exact = linearise == Linearise::Stages && !columns.is_empty();
        let mut stages: Vec<Linearization> = (0..if exact { 3 } else { 0 })
            .map(|_| Linearization::new(&directions, 0))
            .collect();
        let mut scratch = SensitivityScratch::new(directions.states.len(), columns.len());
        let atmosphere = &model.environment.atmosphere;
        let measured_states = std::array::from_fn(|i| mask[i] == 0.0);
        let frozen = self.frozen.for_memo(&self.measured, atmosphere);
        let mut memo = Memo::new(measured_states, frozen);
        point.at(
            model,
            &directions,
            &x,
            &self.controls[0],
            self.pseudo_rates(0),
            &table.computed,
            &mut memo,
        );
        for k in 0..self.len() {
            check_departure(&x, self.time(k))?;
            let (values, output_sensitivity) = table.at(&x, &point, &sensitivity);
            sink(k, values, output_sensitivity);
            if k + 1 == self.len() {
                break;
            }
            let end_pseudo = self.pseudo_rates(k + 1);
            let mut stage = 0;
            x = self.step_from(
                &self.stage_inputs(k),
                &x,
                &mask,
                &point.rates,
                &mut memo,
                |merged, controls, pseudo, memo| {
                    if exact {
                        let linearization = &mut stages[stage];
                        stage += 1;
                        linearization.at(model, &directions, merged, controls, pseudo, &[], memo);
                        linearization.rates
                    } else {
                        let (angles, air) = memo.of(merged, atmosphere);
                        derivative(model, merged, &angles, &air, controls, pseudo).0
                    }
                },
            );
            memo.restart();
            memo.at_point(2 * (k + 1));
            next_point.at(
                model,
                &directions,
                &x,
                &self.controls[k + 1],
                end_pseudo,
                &table.computed,
                &mut memo,
            );
            if exact {
                let stages = [
                    (&point.a, &point.b),
                    (&stages[0].a, &stages[0].b),
                    (&stages[1].a, &stages[1].b),
                    (&stages[2].a, &stages[2].b),
                ];
                rk4_linear_step(&mut sensitivity, self.step, stages, &mut scratch.work);
            } else if !columns.is_empty() {
                let ends = (&point, &mut next_point);
                self.grid_point_step(k, model, &directions, ends, &mut sensitivity, &mut scratch);
            }
            std::mem::swap(&mut point, &mut next_point);
        }
        Ok(())
    }

    /// The sensitivities' RK4 step over step k with the model linearised at
    /// its two grid points only (`Linearise::GridPoints`): the middle
    /// stages take the mean of the two linearisations.
    fn grid_point_step(
        &self,
        k: usize,
        model: &FlightModel,
        directions: &Directions,
        (point, next_point): (&Linearization, &mut Linearization),
        sensitivity: &mut DMatrix<f64>,
        scratch: &mut SensitivityScratch,
    ) {
        let SensitivityScratch {
            work,
            middle_a,
            middle_b,
            end_b,
        } = scratch;
        // The step's last stage sees the controls at θ = 1, which
        // under a hold are the step's start values: the terms'
        // regressors are taken with those (∂f/∂x keeps the grid
        // point's controls: part of the O(h) approximation at a
        // control step that `Linearise::GridPoints` accepts).
        let end_b = if self.holds.iter().all(|h| h.weight(1.0) == 1.0) {
            &next_point.b
        } else {
            let controls = self.controls_inside(k, 1.0);
            next_point.b_with_controls(model, directions, &controls, end_b);
            &*end_b
        };
        mean(&point.a, &next_point.a, middle_a);
        mean(&point.b, end_b, middle_b);
        let stages = [
            (&point.a, &point.b),
            (&*middle_a, &*middle_b),
            (&*middle_a, &*middle_b),
            (&next_point.a, end_b),
        ];
        rk4_linear_step(sensitivity, self.step, stages, work);
    }
}

/// S(0) over the active states (the others are measured, independent of
/// θ): a unit column for an integrated state's initial value, and where χ
/// is fed back from α, χ(0) = χ∞(α(0)) moving with α(0) and the stall
/// parameters (forward differences).
fn initial_sensitivity(
    model: &FlightModel,
    directions: &Directions,
    columns: &[Column],
    x: &FlightPathState,
    chi_from_alpha: bool,
) -> DMatrix<f64> {
    let states = &directions.states;
    let row = |state: usize| states.iter().position(|&i| i == state);
    let mut sensitivity = DMatrix::zeros(states.len(), columns.len());
    for (j, column) in columns.iter().enumerate() {
        if let Column::Initial(i) = *column {
            sensitivity[(row(i).expect("an integrated state"), j)] = 1.0;
        }
        if let (true, Some(chi)) = (chi_from_alpha, row(CHI)) {
            // χ(0) = χ∞(α(0)) moves with α(0) and the stall parameters.
            let target =
                |model: &FlightModel, alpha: f64| model.aircraft.aero.steady_separation(alpha);
            sensitivity[(chi, j)] = match (*column, directions.sources[j]) {
                (Column::Initial(ALPHA), _) => {
                    let step = state_step(x[ALPHA]);
                    (target(model, x[ALPHA] + step) - x[CHI]) / step
                }
                (_, Source::Direction(d)) => match directions.responses[d] {
                    Response::Model(m) => {
                        let (perturbed, step, _) = &directions.models[m];
                        (target(perturbed, x[ALPHA]) - x[CHI]) / step
                    }
                    Response::Offset(_) => 0.0,
                },
                _ => 0.0,
            };
        }
    }
    sensitivity
}

/// The scratch of the sensitivities' RK4 step: its work matrices, and the
/// grid-point linearisation's middle-stage ∂f/∂x and ∂f/∂θ and its end
/// ∂f/∂θ under held controls.
struct SensitivityScratch {
    work: [DMatrix<f64>; 3],
    middle_a: DMatrix<f64>,
    middle_b: DMatrix<f64>,
    end_b: DMatrix<f64>,
}

impl SensitivityScratch {
    fn new(states: usize, columns: usize) -> SensitivityScratch {
        let shape = || DMatrix::zeros(states, columns);
        SensitivityScratch {
            work: [(); 3].map(|_| shape()),
            middle_a: DMatrix::zeros(states, states),
            middle_b: shape(),
            end_b: shape(),
        }
    }
}

/// A simulation's outputs at a grid point and their sensitivities:
/// outputs that are states are x's entries, their sensitivities S's rows
/// (none for a measured state); the others are linearised, ∂y/∂θ =
/// ∂g/∂x·S + ∂g/∂θ.
struct OutputTable {
    sources: Vec<OutputSource>,
    /// The linearised outputs.
    computed: Vec<Observable>,
    values: Vec<f64>,
    /// (∂y/∂θ)ᵀ: each output's sensitivities contiguous.
    output_sensitivity: DMatrix<f64>,
    computed_sensitivity: DMatrix<f64>,
    /// Whether there are unknowns (else no sensitivities).
    sensitivities: bool,
}

impl OutputTable {
    fn new(outputs: &[Observable], states: &[usize], columns: usize) -> OutputTable {
        let row = |state: usize| states.iter().position(|&i| i == state);
        let mut computed = Vec::new();
        let sources: Vec<OutputSource> = outputs
            .iter()
            .map(|output| match *output {
                Observable::State(index) => OutputSource::State {
                    index,
                    row: row(index),
                },
                other => {
                    computed.push(other);
                    OutputSource::Linearised(computed.len() - 1)
                }
            })
            .collect();
        OutputTable {
            sources,
            values: vec![0.0; outputs.len()],
            output_sensitivity: DMatrix::zeros(columns, outputs.len()),
            computed_sensitivity: DMatrix::zeros(computed.len(), columns),
            computed,
            sensitivities: columns > 0,
        }
    }

    /// The outputs y and (∂y/∂θ)ᵀ at a grid point: x, its linearisation
    /// `point` and the sensitivities S there.
    fn at(
        &mut self,
        x: &FlightPathState,
        point: &Linearization,
        sensitivity: &DMatrix<f64>,
    ) -> (&[f64], &DMatrix<f64>) {
        let sensitivities = self.sensitivities;
        if sensitivities {
            // ∂y/∂θ = ∂g/∂x·S + ∂g/∂θ
            affine(
                &point.gx,
                sensitivity,
                &point.gtheta,
                &mut self.computed_sensitivity,
            );
        }
        for (o, source) in self.sources.iter().enumerate() {
            let mut into = self.output_sensitivity.column_mut(o);
            match *source {
                OutputSource::State { index, row } => {
                    self.values[o] = x[index];
                    match row {
                        Some(r) if sensitivities => into.tr_copy_from(&sensitivity.row(r)),
                        _ => into.fill(0.0),
                    }
                }
                OutputSource::Linearised(c) => {
                    self.values[o] = point.outputs[c];
                    if sensitivities {
                        into.tr_copy_from(&self.computed_sensitivity.row(c));
                    }
                }
            }
        }
        (&self.values, &self.output_sensitivity)
    }
}

/// The inputs of step k's later RK4 stages ([`DrivenSimulation::stage_inputs`]):
/// the measured state, controls and pseudo-control rates at its midpoint
/// and at its end.
pub(in crate::model) struct StageInputs {
    pub(super) k: usize,
    pub(super) middle: (FlightPathState, Controls, PseudoRates),
    pub(super) end: (FlightPathState, Controls, PseudoRates),
}

/// Plain steps from one grid point for many start states (and models that
/// differ in their parameters only: the sigma points of an unscented
/// filter), with what they share taken once: the stages' inputs and
/// frozen points, and the first stage's angles and air for start states
/// equal to the last one's, with their kinematics and forcing
/// ([`DrivenSimulation::plain_steps`]). Each step
/// is the one a fresh simulation takes from its start state, bit for bit.
pub(in crate::model) struct PlainSteps<'a> {
    pub(super) simulation: &'a DrivenSimulation,
    pub(super) mask: FlightPathState,
    pub(super) atmosphere: Atmosphere,
    pub(super) inputs: StageInputs,
    /// The controls and pseudo-control rates at the grid point.
    pub(super) start: (Controls, PseudoRates),
    /// A fresh memo at the grid point.
    pub(super) memo: Memo<'a>,
    /// The last start state, its memo after the first stage and the
    /// angles, kinematics and forcing that stage took.
    pub(super) first: Option<(FlightPathState, Memo<'a>, Angles, Kinematics, Forcing)>,
}

impl PlainSteps<'_> {
    /// One plain step of `model` from the full flight-path state `x`
    /// ([`DrivenSimulation::step_from`]). `model` has the form the steps
    /// were made for (its atmosphere, the states it integrates).
    pub(in crate::model) fn step(
        &mut self,
        model: &FlightModel,
        x: &FlightPathState,
    ) -> FlightPathState {
        let (controls, pseudo) = &self.start;
        let (_, memo, angles, kinematics, forcing) = match &self.first {
            Some(first) if first.0 == *x => first,
            _ => {
                let mut memo = self.memo;
                let (angles, air) = memo.of(x, &self.atmosphere);
                let kinematics = kinematics(x, &angles, &air);
                let forcing = model.forcing(&kinematics, controls);
                &*self.first.insert((*x, memo, angles, kinematics, forcing))
            }
        };
        let mut memo = *memo;
        let (first, _) = derivative_at(model, x, angles, kinematics, forcing, *pseudo);
        let atmosphere = &self.atmosphere;
        self.simulation.step_from(
            &self.inputs,
            x,
            &self.mask,
            &first,
            &mut memo,
            |x, controls, pseudo, memo| {
                let (angles, air) = memo.of(x, atmosphere);
                derivative(model, x, &angles, &air, controls, pseudo).0
            },
        )
    }
}

/// Where a simulation's output comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum OutputSource {
    /// A state (index into x): its value, and its sensitivities the row of
    /// S (None: a measured state, independent of θ).
    State { index: usize, row: Option<usize> },
    /// A linearised output (index into the linearisation's outputs).
    Linearised(usize),
}

/// into = (a + b)/2.
fn mean(a: &DMatrix<f64>, b: &DMatrix<f64>, into: &mut DMatrix<f64>) {
    into.as_mut_slice()
        .iter_mut()
        .zip(a.as_slice().iter().zip(b.as_slice()))
        .for_each(|(into, (a, b))| *into = 0.5 * (a + b));
}

pub(in crate::model) fn check_departure(x: &FlightPathState, time: f64) -> Result<()> {
    let limit = std::f64::consts::FRAC_PI_2;
    if !x.iter().all(|v| v.is_finite())
        || x[ALPHA].abs() > limit
        || x[BETA].abs() > limit
        || x[AIRSPEED] <= 0.0
    {
        return Err(Error::ModelDeparted { time });
    }
    Ok(())
}
