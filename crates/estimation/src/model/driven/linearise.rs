//! A driven model linearised at one point ([`Linearization`]): ẋ = f(x),
//! the outputs y = g(x), and ∂f/∂x, ∂f/∂θ, ∂g/∂x, ∂g/∂θ along the
//! [`Directions`] (dual numbers, difference quotients, exact coefficient
//! responses times the terms' regressors), the whole pass compiled for
//! AVX2 too ([`aeroid_numerics::simd::wide`]); and the one-point
//! evaluations and Jacobians the state-space view takes ([`evaluate`],
//! [`linearise_with`], with its buffers kept between calls).

use super::directions::{Directions, Filled, Response, state_step};
use super::kinematics::{
    Angles, Motion, PseudoRates, derivative, derivative_at, dual_derivative, motion_rates,
    offset_evaluation, offset_response,
};
use super::measured::{Ambient, Surroundings};
use super::memo::{FrozenPoints, Memo, PointMemo};
use super::observables::Column;
use super::{ALTITUDE, FLIGHT_PATH_SIZE, FlightPathState};
use crate::model::jacobians::Jacobians;
use crate::structure::Observable;
use aeroid_numerics::dual::{Dual, Real};
use aeroid_sim::aero::TermRegressors;
use aeroid_sim::dynamics::{Evaluation, FlightModel};
use aeroid_sim::state::Controls;
use nalgebra::{DMatrix, DVector};

/// A model linearised at one point (a grid point, or an RK4 stage state
/// with [`Linearise::Stages`](super::Linearise::Stages)): ẋ, the evaluation, and derivatives over the
/// active states (dual numbers or difference quotients: [`Directions`]):
/// ∂f/∂x, ∂f/∂θ, and at grid points the outputs' ∂g/∂x and ∂g/∂θ.
pub(super) struct Linearization {
    pub(super) rates: FlightPathState,
    pub(super) evaluation: Evaluation,
    /// ∂f/∂x (active × active).
    pub(super) a: DMatrix<f64>,
    /// ∂f/∂θ (active × unknowns).
    pub(super) b: DMatrix<f64>,
    pub(super) outputs: Vec<f64>,
    /// ∂g/∂x (outputs × active).
    pub(super) gx: DMatrix<f64>,
    /// ∂g/∂θ (outputs × unknowns).
    pub(super) gtheta: DMatrix<f64>,
    /// Scratch: ∂ẋ of the active states and ∂y, a column per response.
    model_rates: DMatrix<f64>,
    model_outputs: DMatrix<f64>,
}

/// The point a [`Linearization`] is at: x, its angles' sines and cosines
/// and its air, and the inputs there.
#[derive(Clone, Copy)]
struct At<'p> {
    x: &'p FlightPathState,
    angles: Angles,
    air: Surroundings,
    controls: &'p Controls,
    pseudo: PseudoRates,
}

impl Linearization {
    pub(super) fn new(directions: &Directions, outputs: usize) -> Linearization {
        let (n, m) = (directions.states.len(), directions.sources.len());
        Linearization {
            rates: FlightPathState::zeros(),
            evaluation: Evaluation::default(),
            a: DMatrix::zeros(n, n),
            b: DMatrix::zeros(n, m),
            outputs: vec![0.0; outputs],
            gx: DMatrix::zeros(outputs, n),
            gtheta: DMatrix::zeros(outputs, m),
            model_rates: DMatrix::zeros(n, directions.responses.len()),
            model_outputs: DMatrix::zeros(outputs, directions.responses.len()),
        }
    }

    /// Linearises `model` at x along `directions`, and the `outputs` too.
    /// The angles' sines and cosines and the air are computed once, and for a
    /// moved state only what it changes.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn at(
        &mut self,
        model: &FlightModel,
        directions: &Directions,
        x: &FlightPathState,
        controls: &Controls,
        pseudo: PseudoRates,
        outputs: &[Observable],
        memo: &mut Memo,
    ) {
        // The whole linearisation, the dual-number pass included, compiled
        // for AVX2 too: the passes below are `#[inline(always)]` so that they
        // are compiled inside this closure.
        aeroid_numerics::simd::wide(
            #[inline(always)]
            || {
                let atmosphere = &model.environment.atmosphere;
                let (angles, air) = memo.of(x, atmosphere);
                let point = At {
                    x,
                    angles,
                    air,
                    controls,
                    pseudo,
                };
                self.values_and_dual_lanes(model, directions, &point, outputs);
                if directions.differenced.is_empty() && directions.responses.is_empty() {
                    return;
                }
                let ambient = memo.ambient;
                self.differenced(model, directions, &point, outputs, |altitude| {
                    ambient.surroundings(atmosphere, altitude)
                });
                self.responses(model, directions, &point, outputs);
                self.parameter_columns(model, directions);
            },
        )
    }

    /// The rates, evaluation and outputs at the point, and ∂f/∂x and ∂g/∂x
    /// along the states differentiated by dual numbers. With dual lanes the
    /// first one's values are the evaluation at x (the same numbers);
    /// without, it is evaluated plainly.
    #[inline(always)]
    fn values_and_dual_lanes(
        &mut self,
        model: &FlightModel,
        directions: &Directions,
        at: &At,
        outputs: &[Observable],
    ) {
        let (x, angles, air) = (at.x, at.angles, &at.air);
        let (controls, pseudo) = (at.controls, at.pseudo);
        if directions.dual_lanes.is_empty() {
            (self.rates, self.evaluation) = derivative(model, x, &angles, air, controls, pseudo);
            for (o, output) in outputs.iter().enumerate() {
                self.outputs[o] = output.value(x, &self.evaluation);
            }
        }
        let states = &directions.states;
        for (chunk, lanes) in directions.dual_lanes.iter().enumerate() {
            let (dual_x, rates, evaluation) = dual_derivative(
                model,
                x,
                angles,
                lanes.iter().map(|&(_, i)| i),
                air,
                controls,
                pseudo,
            );
            if chunk == 0 {
                self.rates = rates.map(Dual::value);
                self.evaluation = evaluation.values();
            }
            for (lane, &(b, _)) in lanes.iter().enumerate() {
                for (a, &r) in states.iter().enumerate() {
                    self.a[(a, b)] = rates[r].tangent[lane];
                }
            }
            for (o, output) in outputs.iter().enumerate() {
                let value = output.value(&dual_x, &evaluation);
                if chunk == 0 {
                    self.outputs[o] = value.value;
                }
                for (lane, &(b, _)) in lanes.iter().enumerate() {
                    self.gx[(o, b)] = value.tangent[lane];
                }
            }
        }
    }

    /// ∂f/∂x and ∂g/∂x along the states differenced forward; `air_at`
    /// gives the air at a moved altitude.
    #[inline(always)]
    fn differenced(
        &mut self,
        model: &FlightModel,
        directions: &Directions,
        at: &At,
        outputs: &[Observable],
        air_at: impl Fn(f64) -> Surroundings,
    ) {
        let (x, angles, air) = (at.x, at.angles, at.air);
        let states = &directions.states;
        for &(b, i) in &directions.differenced {
            let step = state_step(x[i]);
            let mut moved = *x;
            moved[i] += step;
            let moved_air = if i == ALTITUDE { air_at(moved[i]) } else { air };
            let moved_angles = angles.nudged(i, moved[i] - x[i]);
            let (rates, evaluation) = derivative(
                model,
                &moved,
                &moved_angles,
                &moved_air,
                at.controls,
                at.pseudo,
            );
            for (a, &r) in states.iter().enumerate() {
                self.a[(a, b)] = (rates[r] - self.rates[r]) / step;
            }
            for (o, output) in outputs.iter().enumerate() {
                self.gx[(o, b)] = (output.value(&moved, &evaluation) - self.outputs[o]) / step;
            }
        }
    }

    /// The responses of ẋ and y to the model changes, a column each of
    /// `model_rates` and `model_outputs`: difference quotients of the
    /// perturbed models, or a coefficient's exact response.
    #[inline(always)]
    fn responses(
        &mut self,
        model: &FlightModel,
        directions: &Directions,
        at: &At,
        outputs: &[Observable],
    ) {
        let (x, angles, air) = (at.x, at.angles, &at.air);
        let (controls, pseudo) = (at.controls, at.pseudo);
        let states = &directions.states;
        let motion = Motion::of(&self.evaluation);
        for (d, response) in directions.responses.iter().enumerate() {
            match *response {
                Response::Model(m) => {
                    let (perturbed, step, minus) = &directions.models[m];
                    let (rates, evaluation) =
                        derivative(perturbed, x, &angles, air, controls, pseudo);
                    // The base of the quotient: this point (forward)
                    // or the model moved by −step (central).
                    let minus_outputs: Vec<f64>;
                    let (base_rates, base_outputs, span) = match minus {
                        None => (self.rates, self.outputs.as_slice(), *step),
                        Some(minus) => {
                            let (rates, evaluation) =
                                derivative(minus, x, &angles, air, controls, pseudo);
                            minus_outputs =
                                outputs.iter().map(|o| o.value(x, &evaluation)).collect();
                            (rates, minus_outputs.as_slice(), 2.0 * step)
                        }
                    };
                    for (into, &r) in self.model_rates.column_mut(d).iter_mut().zip(states) {
                        *into = (rates[r] - base_rates[r]) / span;
                    }
                    for (o, output) in outputs.iter().enumerate() {
                        self.model_outputs[(o, d)] =
                            (output.value(x, &evaluation) - base_outputs[o]) / span;
                    }
                }
                Response::Offset(coefficient) => {
                    let offset = offset_response(model, &self.evaluation, coefficient);
                    let response = motion.response(&offset.1, offset.2);
                    let rates = motion_rates(x, &angles, &response, pseudo.linear());
                    for (into, &r) in self.model_rates.column_mut(d).iter_mut().zip(states) {
                        *into = rates[r];
                    }
                    if !outputs.is_empty() {
                        let evaluation = offset_evaluation(&self.evaluation, &offset);
                        for (o, output) in outputs.iter().enumerate() {
                            self.model_outputs[(o, d)] =
                                output.value(x, &evaluation) - self.outputs[o];
                        }
                    }
                }
            }
        }
    }

    /// Column j of ∂f/∂θ and ∂g/∂θ: its response times its factor (the
    /// columns of unknowns with no source stay 0 from `new`).
    #[inline(always)]
    fn parameter_columns(&mut self, model: &FlightModel, directions: &Directions) {
        let regressors = if directions.terms > 0 {
            model
                .aircraft
                .aero
                .term_regressors(&self.evaluation.aero_input)
        } else {
            TermRegressors::default()
        };
        fill(
            &self.model_rates,
            &directions.filled,
            &regressors,
            &mut self.b,
        );
        fill(
            &self.model_outputs,
            &directions.filled,
            &regressors,
            &mut self.gtheta,
        );
    }

    /// ∂f/∂θ at this point with the controls replaced by `controls` (the
    /// controls a step's last stage sees: under a hold, the step's start
    /// value, not the grid point's new one): the terms' regressors are
    /// recomputed, everything else is this point's. Written into `into`.
    pub(super) fn b_with_controls(
        &self,
        model: &FlightModel,
        directions: &Directions,
        controls: &Controls,
        into: &mut DMatrix<f64>,
    ) {
        into.copy_from(&self.b);
        if directions.terms == 0 {
            return;
        }
        let mut input = self.evaluation.aero_input;
        input.controls = *controls;
        model.aircraft.saturate(&mut input.controls);
        let regressors = model.aircraft.aero.term_regressors(&input);
        fill(
            &self.model_rates,
            &directions.filled[..directions.terms],
            &regressors,
            into,
        );
    }
}

/// The `filled` columns of ∂f/∂θ or ∂g/∂θ (`into`): each its response's
/// column of `responses` times its factor from `regressors`.
#[inline(always)]
pub(super) fn fill(
    responses: &DMatrix<f64>,
    filled: &[Filled],
    regressors: &TermRegressors,
    into: &mut DMatrix<f64>,
) {
    let rows = responses.nrows();
    debug_assert_eq!(rows, into.nrows());
    aeroid_numerics::simd::fixed_rows!(
        rows,
        fill_fixed,
        |responses: &[f64], filled: &[Filled], factors: &[f64], into: &mut [f64]| {
            for f in filled {
                let response = &responses[f.response * rows..(f.response + 1) * rows];
                let into = &mut into[f.column * rows..(f.column + 1) * rows];
                for (into, response) in into.iter_mut().zip(response) {
                    *into = response * factors[f.factor];
                }
            }
        },
        (
            responses.as_slice(),
            filled,
            &regressors.values,
            into.as_mut_slice()
        )
    )
}

/// [`fill`] with R rows.
#[inline(always)]
fn fill_fixed<const R: usize>(
    responses: &[f64],
    filled: &[Filled],
    factors: &[f64],
    into: &mut [f64],
) {
    let (responses, into) = (responses.as_chunks::<R>().0, into.as_chunks_mut::<R>().0);
    for f in filled {
        let factor = factors[f.factor];
        into[f.column] = responses[f.response].map(|response| response * factor);
    }
}

/// ẋ = f and the `outputs` y = h of `model` at the full flight-path state
/// x with the given inputs: the simulator's equations ([`derivative`]),
/// the angles' sines and cosines the library's and the air the
/// atmosphere's at x's altitude with the record's measured quantities
/// ([`Ambient::air`]).
pub(in crate::model) fn evaluate(
    model: &FlightModel,
    x: &FlightPathState,
    controls: &Controls,
    pseudo: PseudoRates,
    ambient: Ambient,
    outputs: &[Observable],
) -> (FlightPathState, Vec<f64>) {
    let mut values = vec![0.0; outputs.len()];
    let rates = evaluate_into(
        model,
        x,
        controls,
        pseudo,
        ambient,
        outputs,
        &mut values,
        &mut PointMemo::default(),
    );
    (rates, values)
}

/// [`evaluate`] with the outputs written into `values` (as long as
/// `outputs`), the angles, kinematics and forcing from `memo`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(in crate::model) fn evaluate_into(
    model: &FlightModel,
    x: &FlightPathState,
    controls: &Controls,
    pseudo: PseudoRates,
    ambient: Ambient,
    outputs: &[Observable],
    values: &mut [f64],
    memo: &mut PointMemo,
) -> FlightPathState {
    let (angles, kinematics, forcing) = memo.of(model, x, controls, ambient);
    let (rates, evaluation) = derivative_at(model, x, angles, kinematics, forcing, pseudo);
    for (value, output) in values.iter_mut().zip(outputs) {
        *value = output.value(x, &evaluation);
    }
    rates
}

/// The buffers of [`linearise_with`] kept between calls: the directions while
/// they do not depend on θ (no perturbed models: every parameter a term's,
/// the forces affine in the coefficients), with the flag they were made
/// for, and the linearisation's matrices.
#[derive(Default)]
pub(in crate::model) struct LinearisationBuffers {
    pub(super) made: Option<(bool, Directions, Linearization)>,
}

/// The Jacobians of f (rows: `states`) and of the `outputs` at the full
/// flight-path state x, along `states` and every aerodynamic parameter of
/// `model`, by the machinery of [`DrivenSimulation::simulate`](super::DrivenSimulation::simulate)'s
/// sensitivity equations ([`Linearization::at`]): dual numbers along the
/// states (forward differences along the altitude, and wherever the
/// forces depend on α̇), a term's ∂f/∂θ exact from the coefficient's
/// response times its regressor, a nonlinear parameter's a central
/// difference (the simulation's forward difference is within ~10⁻⁶ of it
/// through a stall break; a filter linearises once per step, so the
/// second evaluation is cheap there).
///
/// Into `buffers`: the Jacobians are the
/// linearisation's `a`, `b`, `gx`, `gtheta` ([`LinearisationBuffers::copy_into`]),
/// the outputs its values. Without `with_outputs` the outputs and their
/// derivatives are not evaluated (`a` and `b` only:
/// [`LinearisationBuffers::copy_rates_into`]).
pub(in crate::model) fn linearise_with(
    model: &FlightModel,
    x: &FlightPathState,
    (controls, pseudo, ambient): (&Controls, PseudoRates, Ambient),
    states: &[usize],
    outputs: &[Observable],
    with_outputs: bool,
    buffers: &mut LinearisationBuffers,
) {
    let aero = &model.aircraft.aero;
    let flag = aero.forces_depend_on_alpha_dot();
    let reusable = matches!(&buffers.made, Some((made_for, directions, _))
        if *made_for == flag && directions.models.is_empty());
    if !reusable {
        buffers.made = None;
    }
    let (_, directions, linearization) = buffers.made.get_or_insert_with(|| {
        let columns: Vec<Column> = (0..aero.parameters.values().len())
            .map(|i| match aero.term_of(i) {
                Some(_) => Column::Term(i),
                None => Column::Nonlinear(i),
            })
            .collect();
        let directions = Directions::new(model, &columns, states, true);
        let linearization = Linearization::new(&directions, outputs.len());
        (flag, directions, linearization)
    });
    let mut memo = Memo::new([false; FLIGHT_PATH_SIZE], FrozenPoints::default());
    memo.ambient = ambient;
    let outputs = if with_outputs { outputs } else { &[] };
    linearization.at(model, directions, x, controls, pseudo, outputs, &mut memo);
}

impl LinearisationBuffers {
    /// The last linearisation's rates (the full flight-path state's), ∂f/∂x
    /// and ∂f/∂θ; None before the first.
    pub(in crate::model) fn rates_and_jacobians(
        &self,
    ) -> Option<(&FlightPathState, &DMatrix<f64>, &DMatrix<f64>)> {
        let (_, _, linearization) = self.made.as_ref()?;
        Some((&linearization.rates, &linearization.a, &linearization.b))
    }

    /// The last linearisation's ∂f/∂x, ∂f/∂θ, ∂h/∂x, ∂h/∂θ into `into`,
    /// and its outputs into `outputs` if given.
    pub(in crate::model) fn copy_into(
        &self,
        into: &mut Jacobians,
        outputs: Option<&mut DVector<f64>>,
    ) {
        let Some((_, _, linearization)) = &self.made else {
            return;
        };
        self.copy_rates_into(into);
        copy(&linearization.gx, &mut into.outputs_by_state);
        copy(&linearization.gtheta, &mut into.outputs_by_parameter);
        if let Some(outputs) = outputs {
            if outputs.len() != linearization.outputs.len() {
                *outputs = DVector::zeros(linearization.outputs.len());
            }
            outputs.copy_from_slice(&linearization.outputs);
        }
    }

    /// The last linearisation's ∂f/∂x and ∂f/∂θ into `into`.
    fn copy_rates_into(&self, into: &mut Jacobians) {
        let Some((_, _, linearization)) = &self.made else {
            return;
        };
        copy(&linearization.a, &mut into.rates_by_state);
        copy(&linearization.b, &mut into.rates_by_parameter);
    }
}

/// `from` into `to`, reshaped if it differs.
pub(super) fn copy(from: &DMatrix<f64>, to: &mut DMatrix<f64>) {
    if to.shape() != from.shape() {
        *to = DMatrix::zeros(from.nrows(), from.ncols());
    }
    to.copy_from(from);
}
