//! The simulation executive: trim, build the exogenous signals (trim controls
//! plus inputs, wind) at every step instant, integrate with RK4, record the
//! truth trace at every step, and stop with a [`Departure`] (beside the trace
//! so far) when the flight leaves its limits. Which simulator flies a
//! scenario is its [`FlightSource`].
//!
//! A scheduled parameter change (scenario `[[parameter_changes]]`) at
//! t = K·step takes effect at that step boundary: the samples before t_K and
//! the state at t_K are those of the flight without the change; the
//! coefficients of the sample at t_K and every step from t_K on use the new
//! value.
//!
//! # Example
//!
//! Fly a bundled scenario ([`scenario::Scenario::load`] finds it by name in
//! the data folder's `scenarios/`) and read its truth:
//!
//! ```
//! use aeroid_sim::scenario::Scenario;
//!
//! let scenario = Scenario::load("attas-elevator-3211")?;
//! let (trace, truth) = aeroid_sim::fly(&scenario)?;
//!
//! // One sample per 0.01 s integration step over the 60 s flight.
//! assert_eq!(trace.samples.len(), 6001);
//! // Trimmed: no pitch rate until the elevator 3-2-1-1 starts at 3 s, then
//! // the short period answers.
//! let q = trace.values("q")?;
//! assert!(q[..300].iter().all(|q| q.abs() < 1e-6));
//! assert!(q.iter().any(|q| q.abs() > 0.02));
//! // The truth an estimate is scored against: the aircraft file's values.
//! assert_eq!(truth.parameters["Cm_alpha"], -0.176);
//! # Ok::<(), aeroid_sim::Error>(())
//! ```

pub mod aero;
pub mod aircraft;
pub mod atmosphere;
pub mod dynamics;
pub mod engine;
pub mod error;
pub mod feedback;
pub mod foreign;
pub mod inputs;
pub mod integrator;
pub(crate) mod params;
pub mod scenario;
pub mod source;
pub mod state;
pub mod trace;
pub mod trim;
pub mod truth;
pub mod wind;

use crate::dynamics::{Exogenous, ExogenousVector, FlightModel};
use crate::feedback::Augmentation;
use crate::integrator::{Interpolation, rk4_step};
use crate::scenario::{DepartureLimits, Scenario};
pub use crate::source::{Departure, Flight, FlightSource};
use crate::state::{Controls, Q0, StateVector};
use crate::trace::{TruthSample, TruthTrace};
use crate::trim::{Trim, trim};
use crate::truth::RunTruth;
use crate::wind::{FlightConditions, WindSample};
pub use error::{Error, Result};

/// A scenario made ready to fly: trimmed, with its signals sampled at every step.
#[derive(Debug, Clone)]
pub struct Simulation {
    pub name: String,
    /// The flight model at the start (trimmed with), until the first change.
    pub model: FlightModel,
    /// The flight model from each scheduled parameter change on: (the step
    /// it first flies, model), in step order, one per step with changes.
    pub changed_models: Vec<(usize, FlightModel)>,
    pub trim: Trim,
    pub step: f64,
    pub interpolation: Interpolation,
    pub departure: DepartureLimits,
    /// Controls and wind at t_k = k·step, k = 0..=steps.
    pub exogenous: Vec<ExogenousVector>,
    pub winds: Vec<WindSample>,
    /// The stability augmentation (`[feedback]`) with its variables' trim
    /// values: its command is added to the control at every step.
    pub feedback: Option<(Augmentation, Vec<f64>)>,
}

impl Simulation {
    /// Trims the aircraft and samples inputs and wind for the whole run.
    pub fn prepare(scenario: &Scenario) -> Result<Simulation> {
        if let FlightSource::Jsbsim(_) = scenario.source() {
            return Err(aeroid_core::Error::Invalid {
                path: scenario.path.clone(),
                problems: vec![aeroid_core::error::FieldError {
                    field: "aircraft".into(),
                    message: "is one of JSBSim's own aircraft: aeroid's simulator does not fly it; `aeroid simulate`, `record` and `run` fly it in JSBSim".into(),
                }],
            }.into());
        }
        scenario.check_size()?;
        let model = FlightModel::new(scenario.aircraft.clone(), scenario.environment);
        let steps = scenario.step_count();
        let conditions = FlightConditions {
            airspeed: scenario.trim.airspeed,
            altitude: scenario.trim.altitude,
        };
        let winds = scenario
            .wind
            .generate(&conditions, scenario.step, steps + 1, scenario.seed)
            .map_err(|message| aeroid_core::Error::Invalid {
                path: scenario.path.clone(),
                problems: vec![aeroid_core::error::FieldError {
                    field: "wind".into(),
                    message: message.to_string(),
                }],
            })?;
        let steady = WindSample {
            ned: winds.first().map_or_else(Default::default, |w| w.ned),
            body: Default::default(),
        };
        let trim = trim(&model, &scenario.trim, &steady)?;
        let exogenous: Vec<ExogenousVector> = winds
            .iter()
            .enumerate()
            .map(|(k, wind)| {
                let controls: Controls =
                    trim.controls + scenario.inputs.deviation(k as f64 * scenario.step);
                Exogenous::pack(&controls, wind)
            })
            .collect();
        let changed_models = changed_models(scenario, &model)?;
        let feedback = scenario.feedback.clone().map(|augmentation| {
            let start = Exogenous::at_stage(
                &exogenous[0],
                &exogenous[0],
                0.0,
                scenario.interpolation,
                scenario.step,
            );
            let reference = augmentation.values(&trim.state, &model.evaluate(&trim.state, &start));
            (augmentation, reference)
        });
        Ok(Simulation {
            name: scenario.name.clone(),
            model,
            changed_models,
            trim,
            step: scenario.step,
            interpolation: scenario.interpolation,
            departure: scenario.departure,
            exogenous,
            winds,
            feedback,
        })
    }

    /// Integrates from trim over all steps; a departure is an [`Error::Departed`].
    pub fn run(&self) -> Result<TruthTrace> {
        self.run_with_restarts(|_| None)
    }

    /// Integrates from trim over all steps or until the flight departs: the
    /// trace (up to the last step before a departure) and the departure.
    pub fn fly(&self) -> (TruthTrace, Option<Departure>) {
        self.fly_with_restarts(|_| None)
    }

    /// Simulates from the trim state, but at every step k where `restart(k)`
    /// gives a state, continues from that state instead (multiple shooting:
    /// an analysis of short segments of a long flight restarts each segment
    /// from a known state). A departure is an [`Error::Departed`].
    pub fn run_with_restarts(
        &self,
        restart: impl Fn(usize) -> Option<StateVector>,
    ) -> Result<TruthTrace> {
        match self.fly_with_restarts(restart) {
            (trace, None) => Ok(trace),
            (_, Some(departure)) => Err(departure.into_error()),
        }
    }

    /// [`Simulation::run_with_restarts`] that keeps the trace up to a departure.
    pub fn fly_with_restarts(
        &self,
        restart: impl Fn(usize) -> Option<StateVector>,
    ) -> (TruthTrace, Option<Departure>) {
        let steps = self.exogenous.len() - 1;
        let mut trace = TruthTrace {
            scenario: self.name.clone(),
            step: self.step,
            samples: Vec::with_capacity(steps + 1),
        };
        let mut x = self.trim.state;
        let mut command = 0.0;
        for k in 0..=steps {
            if let Some(state) = restart(k) {
                x = state;
            }
            let time = k as f64 * self.step;
            let mut evaluation = self
                .model_at(k)
                .evaluate(&x, &self.exogenous_at(k, 0.0, command));
            if let Some((augmentation, reference)) = &self.feedback
                && k % augmentation.frame_steps == 0
            {
                command = augmentation.command(&x, &evaluation, reference);
                evaluation = self
                    .model_at(k)
                    .evaluate(&x, &self.exogenous_at(k, 0.0, command));
            }
            if let Some(reason) = departure_reason(&self.departure, &x, &evaluation) {
                return (trace, Some(Departure { time, reason }));
            }
            trace
                .samples
                .push(TruthSample::new(time, x, evaluation, self.winds[k]));
            if k < steps {
                x = self.step_commanded(&x, k, command);
            }
        }
        (trace, None)
    }

    /// The flight model in effect from t_k to t_k+1 (after the parameter
    /// changes scheduled at or before t_k).
    pub fn model_at(&self, k: usize) -> &FlightModel {
        self.changed_models
            .iter()
            .rev()
            .find(|(first, _)| *first <= k)
            .map_or(&self.model, |(_, model)| model)
    }

    /// One RK4 step from t_k, with the quaternion renormalised afterwards
    /// (the stability augmentation's command, if any, held at zero).
    pub fn advance(&self, x: &StateVector, k: usize) -> StateVector {
        self.step_commanded(x, k, 0.0)
    }

    /// One RK4 step from t_k with the augmentation's `command` added to its
    /// control over the step.
    fn step_commanded(&self, x: &StateVector, k: usize, command: f64) -> StateVector {
        let model = self.model_at(k);
        let mut next = rk4_step(x, self.step, |x, theta| {
            model.derivative(x, &self.exogenous_at(k, theta, command))
        });
        let norm = next.fixed_rows::<4>(Q0).norm();
        next.fixed_rows_mut::<4>(Q0).unscale_mut(norm);
        next
    }

    /// The controls and wind at t_k + θ·step, the augmentation's `command`
    /// added to its control.
    fn exogenous_at(&self, k: usize, theta: f64, command: f64) -> Exogenous {
        let end = self.exogenous.get(k + 1).unwrap_or(&self.exogenous[k]);
        let mut exogenous = Exogenous::at_stage(
            &self.exogenous[k],
            end,
            theta,
            self.interpolation,
            self.step,
        );
        if let Some((augmentation, _)) = &self.feedback {
            exogenous.controls[augmentation.control.index()] += command;
        }
        exogenous
    }
}

/// The flight model after each step with scheduled parameter changes: the
/// step is t/step rounded (the scenario puts every change on the grid), and
/// each model carries every change up to its step.
fn changed_models(scenario: &Scenario, start: &FlightModel) -> Result<Vec<(usize, FlightModel)>> {
    let mut changes: Vec<_> = scenario
        .parameter_changes
        .iter()
        .map(|change| ((change.time / scenario.step).round() as usize, change))
        .collect();
    changes.sort_by_key(|(step, _)| *step);
    let mut models: Vec<(usize, FlightModel)> = Vec::new();
    let mut current = start.clone();
    for (step, change) in changes {
        current
            .aircraft
            .aero
            .parameters
            .set(&change.parameter, change.value)?;
        match models.last_mut() {
            Some((last, model)) if *last == step => *model = current.clone(),
            _ => models.push((step, current.clone())),
        }
    }
    Ok(models)
}

/// Why a flight has departed at state `x`, if it has: the state is no longer
/// finite, or α, β, airspeed or altitude left the scenario's limits.
pub fn departure_reason(
    limits: &DepartureLimits,
    x: &StateVector,
    evaluation: &crate::dynamics::Evaluation,
) -> Option<String> {
    let air = &evaluation.air_data;
    if !x.iter().all(|v| v.is_finite()) {
        return Some("the state is no longer finite".into());
    }
    if air.alpha.abs() > limits.max_alpha {
        return Some(format!(
            "|α| = {:.1}° exceeds {:.1}°",
            air.alpha.to_degrees(),
            limits.max_alpha.to_degrees()
        ));
    }
    if air.beta.abs() > limits.max_beta {
        return Some(format!(
            "|β| = {:.1}° exceeds {:.1}°",
            air.beta.to_degrees(),
            limits.max_beta.to_degrees()
        ));
    }
    if !(limits.min_airspeed..=limits.max_airspeed).contains(&air.airspeed) {
        return Some(format!(
            "airspeed {:.1} m/s left [{:.1}, {:.1}] m/s",
            air.airspeed, limits.min_airspeed, limits.max_airspeed
        ));
    }
    let altitude = state::altitude(x);
    (altitude < limits.min_altitude).then(|| {
        format!(
            "altitude {altitude:.1} m is below {:.1} m",
            limits.min_altitude
        )
    })
}

/// Flies a scenario with its [`FlightSource`] to its end or its departure.
pub fn simulate(scenario: &Scenario) -> Result<Flight> {
    scenario.source().fly(scenario)
}

/// Flies a scenario with its [`FlightSource`] and gives the truth trace and
/// the run's truth: aeroid's simulator with the exact truth, or JSBSim with
/// its local derivatives. A departure is an [`Error::Departed`].
pub fn fly(scenario: &Scenario) -> Result<(TruthTrace, RunTruth)> {
    simulate(scenario)?.complete()
}
