//! Simulation of a postulated model driven by a flight record, in
//! flight-path coordinates x = [V, α, β, p, q, r, φ, θ, ψ, h, χ] (named as
//! record channels). A chosen subset of x is integrated; the others are
//! measured pseudo-controls read from the record at every stage — the
//! decoupled longitudinal and lateral-directional models of seed 004
//! (Eqs. 1–8) are the subsets {V, α, q, θ} and {β, p, r, φ}; the full
//! 6-DOF integrates them all. The equations are the simulator's own
//! ([`FlightModel::evaluate`], no wind: estimation models the air-relative
//! motion), converted to flight-path rates:
//! `V̇ = V·V̇_b/V`, α̇ and β̇ from the state derivative,
//! `φ̇ = p + tan θ·(q sin φ + r cos φ)`, `θ̇ = q cos φ − r sin φ`,
//! `ψ̇ = (q sin φ + r cos φ)/cos θ`, `ḣ = −ḋ`.
//! Controls and pseudo-controls are sampled on the integration grid and
//! taken inside a step with the model's [`Interpolation`] option, through
//! the one RK4 integrator.

use crate::aero::Coefficient;
use crate::dynamics::{Evaluation, Exogenous, FlightModel};
use crate::error::{Error, Result};
use crate::estimation::structure::FLIGHT_PATH_STATES;
use crate::integrator::{Interpolation, rk4_step_with_sensitivity};
use crate::record::FlightRecord;
use crate::state::{self, CONTROL_COUNT, Control, Controls, EulerAngles, StateVector};
use crate::units::STANDARD_GRAVITY;
use nalgebra::{DMatrix, SVector};

pub const FLIGHT_PATH_SIZE: usize = 11;
pub type FlightPathState = SVector<f64, FLIGHT_PATH_SIZE>;

const AIRSPEED: usize = 0;
const ALPHA: usize = 1;
const BETA: usize = 2;
const P: usize = 3;
const ROLL: usize = 6;
const PITCH: usize = 7;
const YAW: usize = 8;
const ALTITUDE: usize = 9;
const CHI: usize = 10;

/// The simulator state of a flight-path state with no wind.
pub fn to_state(x: &FlightPathState) -> StateVector {
    let (alpha, beta) = (x[ALPHA], x[BETA]);
    let mut full = StateVector::zeros();
    full[state::U] = x[AIRSPEED] * alpha.cos() * beta.cos();
    full[state::V] = x[AIRSPEED] * beta.sin();
    full[state::W] = x[AIRSPEED] * alpha.sin() * beta.cos();
    full.fixed_rows_mut::<3>(state::P)
        .copy_from(&x.fixed_rows::<3>(P));
    let attitude = state::quaternion_from_euler(EulerAngles {
        roll: x[ROLL],
        pitch: x[PITCH],
        yaw: x[YAW],
    });
    state::set_attitude(&mut full, &attitude);
    full[state::DOWN] = -x[ALTITUDE];
    full[state::CHI] = x[CHI];
    full
}

/// Measured rates of the pseudo-controls that enter the integrated states'
/// equations: the airspeed's (in β̇) and the sideslip's (in V̇).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PseudoRates {
    pub airspeed: Option<f64>,
    pub beta: Option<f64>,
}

/// Flight-path rates and the simulator's evaluation at x. A decoupled model
/// takes the other axis's motion from measurement (seed 004 Eqs. 5–8), and
/// that model has no forces on that axis, so where a measured state's rate
/// enters an integrated state's equation the measured rate is used: with the
/// airspeed measured, β̇ = (v̇ − V̇_m·sin β)/(V·cos β); with the sideslip
/// measured, V̇ = [(u·u̇ + w·ẇ)/V + V·sin β·cos β·β̇_m]/cos²β.
pub fn derivative(
    model: &FlightModel,
    x: &FlightPathState,
    controls: &Controls,
    pseudo: PseudoRates,
) -> (FlightPathState, Evaluation) {
    let exogenous = Exogenous {
        controls: *controls,
        ..Default::default()
    };
    let evaluation = model.evaluate(&to_state(x), &exogenous);
    let d = &evaluation.derivative;
    let velocity = evaluation.air_data.velocity;
    let mut rates = FlightPathState::zeros();
    let (sin_beta, cos_beta) = x[BETA].sin_cos();
    rates[AIRSPEED] = match pseudo.beta {
        Some(beta_rate) => {
            let longitudinal = (velocity.x * d[state::U] + velocity.z * d[state::W]) / x[AIRSPEED];
            (longitudinal + x[AIRSPEED] * sin_beta * cos_beta * beta_rate) / (cos_beta * cos_beta)
        }
        None => velocity.dot(&d.fixed_rows::<3>(state::U)) / evaluation.air_data.airspeed,
    };
    rates[ALPHA] = evaluation.alpha_dot;
    rates[BETA] = match pseudo.airspeed {
        Some(speed_rate) => (d[state::V] - speed_rate * sin_beta) / (x[AIRSPEED] * cos_beta),
        None => evaluation.beta_dot,
    };
    rates
        .fixed_rows_mut::<3>(P)
        .copy_from(&evaluation.angular_acceleration);
    rates
        .fixed_rows_mut::<3>(ROLL)
        .copy_from(&state::euler_rates(
            x[ROLL],
            x[PITCH],
            &x.fixed_rows::<3>(P).into(),
        ));
    rates[ALTITUDE] = -d[state::DOWN];
    rates[CHI] = d[state::CHI];
    (rates, evaluation)
}

/// A model output, resolved once from its record channel name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observable {
    /// A flight-path state (index into x).
    State(usize),
    /// Load factors nx, ny, nz (specific force / g; nz positive up).
    LoadFactor(usize),
    /// ṗ, q̇, ṙ.
    AngularAcceleration(usize),
    Mach,
    DynamicPressure,
    /// CX, CY, CZ.
    Force(usize),
    Lift,
    Drag,
    /// Cl, Cm, Cn.
    Moment(usize),
}

impl Observable {
    /// The output a record channel name stands for; None when the model has no such output.
    pub fn parse(name: &str) -> Option<Observable> {
        if let Some(i) = FLIGHT_PATH_STATES.iter().position(|s| *s == name) {
            return Some(Observable::State(i));
        }
        Some(match name {
            "nx" => Observable::LoadFactor(0),
            "ny" => Observable::LoadFactor(1),
            "nz" => Observable::LoadFactor(2),
            "p_dot" => Observable::AngularAcceleration(0),
            "q_dot" => Observable::AngularAcceleration(1),
            "r_dot" => Observable::AngularAcceleration(2),
            "mach" => Observable::Mach,
            "dynamic_pressure" => Observable::DynamicPressure,
            "CX" => Observable::Force(0),
            "CY" => Observable::Force(1),
            "CZ" => Observable::Force(2),
            "CL" => Observable::Lift,
            "CD" => Observable::Drag,
            "Cl" => Observable::Moment(0),
            "Cm" => Observable::Moment(1),
            "Cn" => Observable::Moment(2),
            _ => return None,
        })
    }

    /// The output's value at a state and its evaluation.
    pub fn value(self, x: &FlightPathState, evaluation: &Evaluation) -> f64 {
        let c = &evaluation.coefficients;
        match self {
            Observable::State(i) => x[i],
            Observable::LoadFactor(2) => -evaluation.specific_force.z / STANDARD_GRAVITY,
            Observable::LoadFactor(i) => evaluation.specific_force[i] / STANDARD_GRAVITY,
            Observable::AngularAcceleration(i) => evaluation.angular_acceleration[i],
            Observable::Mach => evaluation.air_data.mach,
            Observable::DynamicPressure => evaluation.air_data.dynamic_pressure,
            Observable::Force(i) => c.force[i],
            Observable::Lift => c.lift,
            Observable::Drag => c.drag,
            Observable::Moment(i) => c.moment[i],
        }
    }
}

/// How one unknown θ_j of a simulation with sensitivities enters the model
/// (the columns of S = ∂x/∂θ and of ∂y/∂θ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Column {
    /// A parameter `{coefficient}_{term}` (index into the aerodynamic
    /// parameters), linear in the coefficient: ∂f/∂θ = ∂f/∂C·regressor.
    Term(usize),
    /// A parameter entering nonlinearly (`e`, the stall parameters).
    Nonlinear(usize),
    /// The initial value of an integrated state (index into x): S(0) = unit column.
    Initial(usize),
    /// Enters no equation (an output bias).
    Unused,
}

/// Forward-difference step of a state: 10⁻⁷·max(|x|, 1) (truncation and
/// rounding errors then both ~10⁻⁸ relative).
fn state_step(value: f64) -> f64 {
    1e-7 * value.abs().max(1.0)
}

/// Step of a coefficient offset (f is affine in it unless the forces depend on α̇).
const OFFSET_STEP: f64 = 1e-6;

/// Forward-difference step of a nonlinear parameter: 10⁻⁷·max(|θ|, 10⁻²).
fn parameter_step(value: f64) -> f64 {
    1e-7 * value.abs().max(1e-2)
}

/// Where the ∂f/∂θ of one column comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    None,
    /// The difference quotient of a perturbed model.
    Direction(usize),
    /// A coefficient offset's difference quotient times the term's regressor.
    Term {
        direction: usize,
        lift: bool,
        regressor: usize,
    },
}

/// What a stage linearisation differentiates along: the active states
/// (perturbed in x) and perturbed models (a coefficient offset or a
/// nonlinear parameter moved by a step), with the step of each model.
struct Directions {
    states: Vec<usize>,
    models: Vec<(FlightModel, f64)>,
    sources: Vec<Source>,
}

impl Directions {
    fn new(model: &FlightModel, columns: &[Column], active: &[usize]) -> Directions {
        let mut directions = Directions {
            states: if columns.is_empty() {
                Vec::new()
            } else {
                active.to_vec()
            },
            models: Vec::new(),
            sources: Vec::with_capacity(columns.len()),
        };
        let mut offsets: [Option<usize>; 6] = [None; 6];
        let aero = &model.aircraft.aero;
        for column in columns {
            let source = match *column {
                Column::Term(j) => match aero.term_of(j) {
                    Some((coefficient, regressor)) => {
                        let c = coefficient as usize;
                        let direction = *offsets[c].get_or_insert_with(|| {
                            let mut perturbed = model.clone();
                            perturbed.aircraft.aero.offsets[c] += OFFSET_STEP;
                            directions.push_model(perturbed, OFFSET_STEP)
                        });
                        Source::Term {
                            direction,
                            lift: coefficient == Coefficient::Lift,
                            regressor: regressor as usize,
                        }
                    }
                    None => directions.nonlinear(model, j),
                },
                Column::Nonlinear(j) => directions.nonlinear(model, j),
                Column::Initial(_) | Column::Unused => Source::None,
            };
            directions.sources.push(source);
        }
        directions
    }

    fn push_model(&mut self, model: FlightModel, step: f64) -> usize {
        self.models.push((model, step));
        self.states.len() + self.models.len() - 1
    }

    fn nonlinear(&mut self, model: &FlightModel, parameter: usize) -> Source {
        let mut perturbed = model.clone();
        let value = &mut perturbed.aircraft.aero.parameters.values_mut()[parameter];
        let step = parameter_step(*value);
        *value += step;
        Source::Direction(self.push_model(perturbed, step))
    }

    fn count(&self) -> usize {
        self.states.len() + self.models.len()
    }
}

/// A model linearised at one stage: ẋ, the evaluation, and the difference
/// quotients of ẋ (and, at grid points, of the outputs) along every direction.
struct Linearization {
    rates: FlightPathState,
    evaluation: Evaluation,
    /// ∂ẋ per direction (states first, then models).
    columns: Vec<FlightPathState>,
    outputs: Vec<f64>,
    /// ∂y per direction, direction-major.
    output_columns: Vec<f64>,
}

impl Linearization {
    fn new(directions: usize, outputs: usize) -> Linearization {
        Linearization {
            rates: FlightPathState::zeros(),
            evaluation: Evaluation::default(),
            columns: vec![FlightPathState::zeros(); directions],
            outputs: vec![0.0; outputs],
            output_columns: vec![0.0; directions * outputs],
        }
    }

    /// Linearises `model` at x along `directions`; the outputs too when `outputs` is not empty.
    fn at(
        &mut self,
        model: &FlightModel,
        directions: &Directions,
        x: &FlightPathState,
        controls: &Controls,
        pseudo: PseudoRates,
        outputs: &[Observable],
    ) {
        (self.rates, self.evaluation) = derivative(model, x, controls, pseudo);
        for (o, output) in outputs.iter().enumerate() {
            self.outputs[o] = output.value(x, &self.evaluation);
        }
        let perturbed = directions
            .states
            .iter()
            .map(|&i| {
                let step = state_step(x[i]);
                let mut moved = *x;
                moved[i] += step;
                (model, moved, step)
            })
            .chain(
                directions
                    .models
                    .iter()
                    .map(|(perturbed, step)| (perturbed, *x, *step)),
            );
        for (d, (model, moved, step)) in perturbed.enumerate() {
            let (rates, evaluation) = derivative(model, &moved, controls, pseudo);
            self.columns[d] = (rates - self.rates) / step;
            for (o, output) in outputs.iter().enumerate() {
                self.output_columns[d * outputs.len() + o] =
                    (output.value(&moved, &evaluation) - self.outputs[o]) / step;
            }
        }
    }

    /// ∂ẋ/∂θ·(stage sensitivity) + ∂f/∂θ over the active rows: the stage rate of S.
    fn sensitivity_rate(
        &self,
        model: &FlightModel,
        directions: &Directions,
        stage: &DMatrix<f64>,
        rate: &mut DMatrix<f64>,
    ) {
        let regressors = model
            .aircraft
            .aero
            .term_regressors(&self.evaluation.aero_input);
        for (j, source) in directions.sources.iter().enumerate() {
            let mut column = match *source {
                Source::None => FlightPathState::zeros(),
                Source::Direction(d) => self.columns[d],
                Source::Term {
                    direction,
                    lift,
                    regressor,
                } => {
                    let values = if lift {
                        &regressors.lift
                    } else {
                        &regressors.other
                    };
                    self.columns[direction] * values[regressor]
                }
            };
            for (d, &i) in directions.states.iter().enumerate() {
                column += self.columns[d] * stage[(i, j)];
            }
            for &i in &directions.states {
                rate[(i, j)] = column[i];
            }
        }
    }

    /// The outputs' sensitivities ∂y/∂θ = ∂g/∂x·S + ∂g/∂θ at a grid point.
    fn output_sensitivity(
        &self,
        model: &FlightModel,
        directions: &Directions,
        sensitivity: &DMatrix<f64>,
        into: &mut DMatrix<f64>,
    ) {
        let outputs = self.outputs.len();
        let regressors = model
            .aircraft
            .aero
            .term_regressors(&self.evaluation.aero_input);
        let column = |d: usize| &self.output_columns[d * outputs..(d + 1) * outputs];
        for (j, source) in directions.sources.iter().enumerate() {
            for o in 0..outputs {
                into[(o, j)] = match *source {
                    Source::None => 0.0,
                    Source::Direction(d) => column(d)[o],
                    Source::Term {
                        direction,
                        lift,
                        regressor,
                    } => {
                        let values = if lift {
                            &regressors.lift
                        } else {
                            &regressors.other
                        };
                        column(direction)[o] * values[regressor]
                    }
                };
                for (d, &i) in directions.states.iter().enumerate() {
                    into[(o, j)] += column(d)[o] * sensitivity[(i, j)];
                }
            }
        }
    }
}

/// A postulated model's inputs and pseudo-controls on an integration grid.
#[derive(Debug, Clone)]
pub struct DrivenSimulation {
    pub start: f64,
    pub step: f64,
    pub interpolation: Interpolation,
    /// Which flight-path states are integrated (others are measured).
    pub integrate: [bool; FLIGHT_PATH_SIZE],
    pub controls: Vec<Controls>,
    /// Measured flight-path states at the grid points (integrated entries unused).
    pub measured: Vec<FlightPathState>,
    /// Notes for the user (a control held constant because its channel is absent).
    pub notes: Vec<String>,
}

impl DrivenSimulation {
    /// Samples controls and pseudo-controls from the record on the grid
    /// start, start + step, …, end. Control channels are reconstructed between
    /// their samples with the model's interpolation (a hold keeps a recorded
    /// step a step); measured pseudo-controls, continuous signals, linearly.
    /// A missing control channel is held at 0 (noted); a missing
    /// pseudo-control that the model needs is an error.
    pub fn from_record(
        record: &FlightRecord,
        integrate: &[usize],
        interpolation: Interpolation,
        step: f64,
        (start, end): (f64, f64),
    ) -> Result<DrivenSimulation> {
        let count = ((end - start) / step + 1e-9).floor() as usize + 1;
        let times: Vec<f64> = (0..count).map(|k| start + k as f64 * step).collect();
        let mut notes = Vec::new();
        let mut controls = vec![Controls::zeros(); count];
        for control in Control::ALL {
            match record.channel(control.name()) {
                Ok(channel) => {
                    for (sample, value) in controls
                        .iter_mut()
                        .zip(channel.sampled_at(&times, interpolation)?)
                    {
                        sample[control.index()] = value;
                    }
                }
                Err(_) => notes.push(format!("no '{}' channel: held at 0", control.name())),
            }
        }
        let mut mask = [false; FLIGHT_PATH_SIZE];
        integrate.iter().for_each(|&i| mask[i] = true);
        let mut measured = vec![FlightPathState::zeros(); count];
        for (i, name) in FLIGHT_PATH_STATES
            .iter()
            .enumerate()
            .filter(|(i, _)| !mask[*i])
        {
            match record.channel(name) {
                Ok(channel) => {
                    for (sample, value) in measured.iter_mut().zip(channel.values_at(&times)?) {
                        sample[i] = value;
                    }
                }
                Err(_) if matches!(*name, "yaw" | "chi") => {}
                Err(_) if *name == "altitude" => {
                    let altitude = record
                        .channel("pressure_altitude")
                        .map_err(|_| missing(name))?;
                    for (sample, value) in measured.iter_mut().zip(altitude.values_at(&times)?) {
                        sample[i] = value;
                    }
                }
                Err(_) => return Err(missing(name)),
            }
        }
        debug_assert_eq!(CONTROL_COUNT, 5);
        Ok(DrivenSimulation {
            start,
            step,
            interpolation,
            integrate: mask,
            controls,
            measured,
            notes,
        })
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

    /// Rates over step k (slopes of the linear interpolation) of the measured
    /// airspeed and sideslip, where they are not integrated.
    fn pseudo_rates(&self, k: usize) -> PseudoRates {
        let next = (k + 1).min(self.len() - 1);
        let previous = next.saturating_sub(1);
        let rate = |i: usize| {
            (!self.integrate[i])
                .then(|| (self.measured[next][i] - self.measured[previous][i]) / self.step)
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

    /// Simulates from `initial`, calling `sink(k, y, ∂y/∂θ)` at every grid
    /// point with the `outputs` and their sensitivities to the unknowns
    /// described by `columns` (none: a plain simulation). The sensitivities
    /// S = ∂x/∂θ of the integrated states are propagated through each RK4
    /// stage with the stage's ∂f/∂x and ∂f/∂θ ([`rk4_step_with_sensitivity`]),
    /// so that they are the derivatives of the discrete simulation itself;
    /// ∂y/∂θ = ∂g/∂x·S + ∂g/∂θ. ∂f/∂x and ∂g/∂x are forward differences in
    /// each integrated state; for a term C_term of coefficient C, f is linear
    /// in C, and ∂f/∂θ = (∂f/∂C)·regressor with ∂f/∂C the difference quotient
    /// of an offset on C; a nonlinear parameter's is a forward difference.
    /// Err with the time when the model departs (non-finite, |α| or |β|
    /// beyond 90°, airspeed not positive).
    pub fn simulate(
        &self,
        model: &FlightModel,
        initial: &FlightPathState,
        outputs: &[Observable],
        columns: &[Column],
        mut sink: impl FnMut(usize, &[f64], &DMatrix<f64>),
    ) -> std::result::Result<(), String> {
        let aero = &model.aircraft.aero;
        let mut x = self.merge(initial, &self.measured[0]);
        let chi_from_alpha = aero.chi_is_state() && !self.integrate[CHI];
        if chi_from_alpha {
            x[CHI] = aero.separation_target(x[ALPHA], 0.0);
        }
        let mask = FlightPathState::from_fn(|i, _| {
            if self.integrate[i] || (i == CHI && aero.chi_is_state()) {
                1.0
            } else {
                0.0
            }
        });
        let active: Vec<usize> = (0..FLIGHT_PATH_SIZE).filter(|&i| mask[i] == 1.0).collect();
        let directions = Directions::new(model, columns, &active);
        let mut sensitivity = DMatrix::zeros(FLIGHT_PATH_SIZE, columns.len());
        for (j, column) in columns.iter().enumerate() {
            if let Column::Initial(i) = *column {
                sensitivity[(i, j)] = 1.0;
            }
            if chi_from_alpha {
                // χ(0) = χ∞(α(0)) moves with α(0) and the stall parameters.
                let target = |model: &FlightModel, alpha: f64| {
                    model.aircraft.aero.separation_target(alpha, 0.0)
                };
                sensitivity[(CHI, j)] = match (*column, directions.sources[j]) {
                    (Column::Initial(ALPHA), _) => {
                        let step = state_step(x[ALPHA]);
                        (target(model, x[ALPHA] + step) - x[CHI]) / step
                    }
                    (_, Source::Direction(d)) => {
                        let (perturbed, step) = &directions.models[d - directions.states.len()];
                        (target(perturbed, x[ALPHA]) - x[CHI]) / step
                    }
                    _ => 0.0,
                };
            }
        }
        let mut work = [(); 3].map(|_| DMatrix::zeros(FLIGHT_PATH_SIZE, columns.len()));
        let mut output_sensitivity = DMatrix::zeros(outputs.len(), columns.len());
        let mut point = Linearization::new(directions.count(), outputs.len());
        let mut stage = Linearization::new(directions.count(), 0);
        for k in 0..self.len() {
            let pseudo = self.pseudo_rates(k);
            point.at(model, &directions, &x, &self.controls[k], pseudo, outputs);
            check_departure(&x, self.time(k))?;
            if !columns.is_empty() {
                point.output_sensitivity(model, &directions, &sensitivity, &mut output_sensitivity);
            }
            sink(k, &point.outputs, &output_sensitivity);
            if k + 1 == self.len() {
                break;
            }
            let next = rk4_step_with_sensitivity(
                &x,
                &mut sensitivity,
                self.step,
                &mut work,
                |x, theta, stage_sensitivity, rate| {
                    // The first stage is the grid point, linearised above.
                    let linearization = if theta == 0.0 {
                        &point
                    } else {
                        let w = self.interpolation.weight(theta);
                        let measured =
                            self.measured[k] + (self.measured[k + 1] - self.measured[k]) * w;
                        let controls =
                            self.controls[k] + (self.controls[k + 1] - self.controls[k]) * w;
                        let merged = FlightPathState::from_fn(|i, _| {
                            if mask[i] == 1.0 { x[i] } else { measured[i] }
                        });
                        stage.at(model, &directions, &merged, &controls, pseudo, &[]);
                        &stage
                    };
                    linearization.sensitivity_rate(model, &directions, stage_sensitivity, rate);
                    linearization.rates.component_mul(&mask)
                },
            );
            x = FlightPathState::from_fn(|i, _| {
                if mask[i] == 1.0 {
                    next[i]
                } else {
                    self.measured[k + 1][i]
                }
            });
        }
        Ok(())
    }
}

fn missing(name: &str) -> Error {
    Error::Other(format!(
        "the model needs the measured channel '{name}' (it is not integrated), but the record has none"
    ))
}

fn check_departure(x: &FlightPathState, time: f64) -> std::result::Result<(), String> {
    let limit = std::f64::consts::FRAC_PI_2;
    if !x.iter().all(|v| v.is_finite())
        || x[ALPHA].abs() > limit
        || x[BETA].abs() > limit
        || x[AIRSPEED] <= 0.0
    {
        return Err(format!("the postulated model departed at t = {time:.3} s"));
    }
    Ok(())
}
