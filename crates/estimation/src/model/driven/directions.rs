//! What a linearisation of a driven model differentiates along
//! ([`Directions`]): the active states, by dual numbers [`LANES`] at a time
//! or by forward differences (the altitude, and every state where the
//! forces depend on α̇), and the unknowns: a term's ∂f/∂θ = ∂f/∂C·regressor
//! with ∂f/∂C a coefficient's exact response or the difference quotient of
//! an offset, a nonlinear parameter's a forward or central difference;
//! with the difference steps (truncation and rounding errors balanced:
//! 10⁻⁷ relative forward, ε^⅓ ≈ 10⁻⁵ central).

use super::ALTITUDE;
use super::observables::Column;
use aeroid_numerics::dual::LANES;
use aeroid_sim::aero::{Coefficient, TermRegressors};
use aeroid_sim::dynamics::FlightModel;

/// Forward-difference step of a state: 10⁻⁷·max(|x|, 1) (truncation and
/// rounding errors then both ~10⁻⁸ relative).
pub(super) fn state_step(value: f64) -> f64 {
    1e-7 * value.abs().max(1.0)
}

/// Step of a coefficient offset, where ∂f/∂C is a difference quotient (the
/// forces depend on α̇; f is then not affine in C).
const OFFSET_STEP: f64 = 1e-6;

/// Forward-difference step of a nonlinear parameter: 10⁻⁷·max(|θ|, 10⁻²).
fn parameter_step(value: f64) -> f64 {
    1e-7 * value.abs().max(1e-2)
}

/// Central-difference step of a nonlinear parameter: 10⁻⁵·max(|θ|, 10⁻²),
/// about ε^⅓ relative (truncation error ~step²·f‴/6 and rounding error
/// ~ε·|f|/step then both ~10⁻¹⁰ relative, 10⁻⁸ through a stall break).
fn central_parameter_step(value: f64) -> f64 {
    1e-5 * value.abs().max(1e-2)
}

/// Where the ∂f/∂θ of one column comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Source {
    None,
    /// A response (index into [`Directions::responses`]).
    Direction(usize),
    /// A coefficient's response times the term's regressor (its slot in
    /// [`TermRegressors`]).
    Term {
        direction: usize,
        regressor: usize,
    },
}

/// A column of ∂f/∂θ and ∂g/∂θ that is not 0: unknown `column` is
/// response `response` times the regressor in slot `factor` of
/// [`TermRegressors`] ([`TermRegressors::ONE`] for a direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Filled {
    pub(super) column: usize,
    pub(super) response: usize,
    pub(super) factor: usize,
}

/// A response of ẋ and y to a change of the model: ∂/∂C of a coefficient,
/// or ∂/∂θ of a nonlinear parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Response {
    /// The difference quotient of a perturbed model (index into `models`).
    Model(usize),
    /// A coefficient's, exact from the evaluation (f is affine in C when the
    /// forces do not depend on α̇): [`aeroid_sim::aero::AeroModel::offset_response`] through
    /// [`FlightModel::acceleration_response`], χ̇ moving with α̇.
    Offset(Coefficient),
}

/// What a linearisation differentiates along: the active states
/// (perturbed in x) and the responses to model changes; perturbed models
/// (a coefficient offset or a nonlinear parameter moved by a step) with the
/// step of each.
pub(super) struct Directions {
    pub(super) states: Vec<usize>,
    /// The states ∂f/∂x and ∂g/∂x are differentiated along by dual numbers
    /// ([`aeroid_numerics::dual`]), [`LANES`] at a time, each with its column in
    /// ∂f/∂x; the others (the altitude, whose air comes from the
    /// atmosphere table, and every state of a model whose forces depend on
    /// α̇, solved for by iteration) by forward differences.
    pub(super) dual_lanes: Vec<Vec<(usize, usize)>>,
    pub(super) differenced: Vec<(usize, usize)>,
    /// Each perturbed model: moved by +step, its step, and (central
    /// differences) moved by −step.
    pub(super) models: Vec<(FlightModel, f64, Option<FlightModel>)>,
    /// Whether the perturbed models' quotients are central differences.
    pub(super) central: bool,
    pub(super) responses: Vec<Response>,
    /// Per unknown; a `Direction` or `Term` names a response.
    pub(super) sources: Vec<Source>,
    /// The columns with a source, terms first (`terms` of them).
    pub(super) filled: Vec<Filled>,
    pub(super) terms: usize,
}

impl Directions {
    /// Differentiates along `states` (none for a plain simulation) and
    /// the unknowns `columns`; the perturbed models' difference quotients
    /// forward, or `central`.
    pub(super) fn new(
        model: &FlightModel,
        columns: &[Column],
        states: &[usize],
        central: bool,
    ) -> Directions {
        let states = states.to_vec();
        let dual = !model.aircraft.aero.forces_depend_on_alpha_dot();
        // (column in ∂f/∂x, state)
        type Lane = (usize, usize);
        let (by_dual, differenced): (Vec<Lane>, Vec<Lane>) = states
            .iter()
            .copied()
            .enumerate()
            .partition(|&(_, i)| dual && i != ALTITUDE);
        let mut directions = Directions {
            dual_lanes: by_dual.chunks(LANES).map(<[_]>::to_vec).collect(),
            differenced,
            states,
            models: Vec::new(),
            central,
            responses: Vec::new(),
            sources: Vec::with_capacity(columns.len()),
            filled: Vec::new(),
            terms: 0,
        };
        let mut offsets: [Option<usize>; 6] = [None; 6];
        let aero = &model.aircraft.aero;
        let affine = aero.offset_response_is_exact();
        for column in columns {
            let source = match *column {
                Column::Term(j) => match aero.term_of(j) {
                    Some((coefficient, monomial)) => {
                        let c = coefficient as usize;
                        let direction = *offsets[c].get_or_insert_with(|| {
                            if affine {
                                directions.push_response(Response::Offset(coefficient))
                            } else {
                                directions.push_model(model, OFFSET_STEP, |model, step| {
                                    model.aircraft.aero.offsets[c] += step
                                })
                            }
                        });
                        Source::Term {
                            direction,
                            regressor: aero.term_slot(coefficient, monomial),
                        }
                    }
                    None => directions.nonlinear(model, j),
                },
                Column::Nonlinear(j) => directions.nonlinear(model, j),
                Column::Initial(_) | Column::Unused => Source::None,
            };
            directions.sources.push(source);
        }
        let filled = |(column, source): (usize, &Source)| match *source {
            Source::None => None,
            Source::Direction(response) => Some(Filled {
                column,
                response,
                factor: TermRegressors::ONE,
            }),
            Source::Term {
                direction,
                regressor,
            } => Some(Filled {
                column,
                response: direction,
                factor: regressor,
            }),
        };
        let (mut filled, directed): (Vec<Filled>, Vec<Filled>) =
            (directions.sources.iter().enumerate())
                .filter_map(filled)
                .partition(|f| f.factor != TermRegressors::ONE);
        directions.terms = filled.len();
        filled.extend(directed);
        directions.filled = filled;
        directions
    }

    /// A response by the difference quotient of `model` moved by
    /// `step` (and by −step when central).
    fn push_model(
        &mut self,
        model: &FlightModel,
        step: f64,
        moved: impl Fn(&mut FlightModel, f64),
    ) -> usize {
        let by = |step: f64| {
            let mut perturbed = model.clone();
            moved(&mut perturbed, step);
            perturbed
        };
        let minus = self.central.then(|| by(-step));
        self.models.push((by(step), step, minus));
        self.push_response(Response::Model(self.models.len() - 1))
    }

    fn push_response(&mut self, response: Response) -> usize {
        self.responses.push(response);
        self.responses.len() - 1
    }

    pub(super) fn nonlinear(&mut self, model: &FlightModel, parameter: usize) -> Source {
        let value = model.aircraft.aero.parameters.values()[parameter];
        let step = if self.central {
            central_parameter_step(value)
        } else {
            parameter_step(value)
        };
        Source::Direction(self.push_model(model, step, |model, step| {
            model.aircraft.aero.parameters.values_mut()[parameter] += step
        }))
    }
}
