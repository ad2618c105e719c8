//! The postulated model as a state-space system, the view that every
//! method that simulates or filters shares (Jategaonkar, "Flight Vehicle
//! System Identification", ch. 4: the system of the output-error method,
//! and §4.6, the sensitivity equations built from its Jacobians):
//!
//!   ẋ(t) = f(t, x, u, θ),   y(t) = h(t, x, u, θ),
//!
//! x the integrated states, u the record's inputs at t (controls and
//! measured pseudo-controls, read by the model itself), θ the parameters,
//! passed to every call (no model for the caller to mutate). Besides f and
//! h, the view gives the Jacobians ∂f/∂x, ∂f/∂θ, ∂h/∂x, ∂h/∂θ at any point
//! (what an extended Kalman filter linearises, and what the sensitivity
//! equations Ṡ = ∂f/∂x·S + ∂f/∂θ, ∂y/∂θ = ∂h/∂x·S + ∂h/∂θ integrate) and
//! one integration step from any state, k → k + 1 on the model's
//! integration grid (what a filter's time update propagates).
//!
//! [`DrivenStateSpace`] is the view of the nonlinear model driven by a
//! flight record ([`super::driven`]): its step is the one the
//! whole-trajectory simulation ([`DrivenSimulation::simulate`], output
//! error's) takes, bit for bit; its Jacobians are that simulation's
//! (dual numbers, exact coefficient responses, forward differences where
//! it takes them). How those are made fast stays in [`super::driven`].

use super::driven::{
    self, Ambient, DrivenSimulation, FLIGHT_PATH_SIZE, FlightPathState, LinearisationBuffers,
    Observable, PointMemo, PseudoRates,
};
use crate::error::{Error, Result};
use crate::input_timing::InputInterpolation;
use crate::structure::FLIGHT_PATH_STATES;
use crate::structure::ModelStructure;
use aeroid_record::FlightRecord;
use aeroid_sim::dynamics::FlightModel;
use aeroid_sim::integrator::rk4_linear_step;
use aeroid_sim::state::{Control, Controls};
use nalgebra::{DMatrix, DVector};

pub use super::jacobians::Jacobians;
pub use super::points::Points;
pub(crate) use super::points::Scratch;

/// The window of a record where every channel in `outputs` has samples,
/// inside `limit` if given.
pub(crate) fn fitting_window(
    record: &FlightRecord,
    outputs: &[String],
    limit: Option<(f64, f64)>,
) -> Result<(f64, f64)> {
    let mut range = limit.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    for name in outputs {
        let channel = record.channel(name)?;
        let (first, last) = (
            channel.times.first().copied(),
            channel.times.last().copied(),
        );
        let (Some(first), Some(last)) = (first, last) else {
            return Err(Error::Data {
                reason: format!("channel '{name}' is empty"),
            });
        };
        range = (range.0.max(first), range.1.min(last));
    }
    if range.1 <= range.0 {
        return Err(Error::Data {
            reason: format!(
                "record '{}': the output channels share no time window",
                record.scenario
            ),
        });
    }
    Ok(range)
}

/// The model outputs a structure compares, parsed.
pub(crate) fn observables(structure: &ModelStructure) -> Result<Vec<Observable>> {
    structure
        .outputs
        .iter()
        .map(|name| {
            Observable::parse(name).ok_or_else(|| Error::Method {
                reason: format!(
                    "model '{}': output '{name}' is not a model output",
                    structure.name
                ),
            })
        })
        .collect()
}

/// The integration step: `step` if given, else the period of the fastest
/// channel in `outputs`.
pub(crate) fn integration_step(
    record: &FlightRecord,
    outputs: &[String],
    step: Option<f64>,
) -> Result<f64> {
    if let Some(step) = step {
        return Ok(step);
    }
    let mut fastest: f64 = 0.0;
    for name in outputs {
        fastest = fastest.max(record.channel(name)?.rate);
    }
    Ok(1.0 / fastest)
}

/// The most sub-steps of the fastest output's period [`observation_step`]
/// tries.
pub(crate) const MAX_OBSERVATION_SUBDIVISION: usize = 8;

/// The grid step of a fit: `step` if given, else the fastest output's
/// period divided into the fewest equal parts (at most
/// `MAX_OBSERVATION_SUBDIVISION`) for which every sample of the outputs
/// and of the `inputs` (the channels that drive the model; those the
/// record lacks are skipped) inside the window starting at `start` falls
/// on a grid point. A channel sampled later in the recorder's frame
/// (word-slot skew) is then compared with the model at its own instant,
/// and an input is reconstructed between its own samples as the
/// interpolation convention says, not between values interpolated to an
/// offset grid. Where no such division exists, the period: output
/// samples are then taken at the nearest grid point by the filters
/// ([`crate::model::observations`] counts them and the
/// estimate says so) and interpolated by output error.
pub fn observation_step(
    record: &FlightRecord,
    outputs: &[String],
    inputs: &[&str],
    step: Option<f64>,
    start: f64,
) -> Result<f64> {
    let period = integration_step(record, outputs, step)?;
    if step.is_some() {
        return Ok(period);
    }
    let mut offsets = Vec::with_capacity(outputs.len() + inputs.len());
    let channels = outputs
        .iter()
        .map(|name| record.channel(name).map(Some))
        .chain(inputs.iter().map(|name| Ok(record.channel(name).ok())));
    for channel in channels {
        let Some(channel) = channel? else { continue };
        if let Some(&first) = channel.times.iter().find(|&&t| t >= start - 1e-9 * period) {
            offsets.push((first - start, 1.0 / channel.rate));
        }
    }
    let on_grid = |value: f64, h: f64| {
        let position = value / h;
        (position - position.round()).abs() <= 1e-6
    };
    Ok((1..=MAX_OBSERVATION_SUBDIVISION)
        .map(|m| period / m as f64)
        .find(|&h| {
            offsets
                .iter()
                .all(|&(offset, own)| on_grid(offset, h) && on_grid(own, h))
        })
        .unwrap_or(period))
}

/// The record channels that drive a 6-DOF structure's simulation: the
/// controls, the flight-path states it does not integrate and the
/// measured quantities that replace the model's own
/// ([`DrivenSimulation::from_record`]).
pub(crate) fn driving_channels(structure: &ModelStructure) -> Vec<&'static str> {
    Control::ALL
        .iter()
        .map(|c| c.name())
        .chain(driven::MEASURED_QUANTITIES)
        .chain(
            FLIGHT_PATH_STATES
                .iter()
                .enumerate()
                .filter(|(i, _)| !structure.integrate.contains(i))
                .map(|(_, name)| *name),
        )
        .collect()
}

/// The largest h·|λ| an RK4 step of the postulated model may take, λ the
/// model's fastest eigenvalue: RK4's error over one step is
/// (hλ)⁵/120 relative, 2.6e-4 at 0.5, and the estimates then move by
/// well under 0.1σ when the step is halved.
pub(crate) const RK4_STEP_LIMIT: f64 = 0.5;

/// The largest h·|λ| of the model's fastest mode at which a θ is simulated
/// on the grid of the iteration's start: RK4 is stable to 2.78 and, from
/// the grid's h·|λ| of 0.4 to 1, this lets a step speed the mode up two-
/// to fivefold (τ1 fall to a half or a fifth); beyond it the simulation is
/// refused and the step shortened. The next iteration's grid resolves the
/// new θ.
pub(crate) const RK4_STEP_REACH: f64 = 2.0;

/// The most RK4 steps a grid interval is divided into as the parameters
/// move: every grid point's sensitivities are kept, so the memory grows
/// with them (32 on a 60 s record at 100 Hz with 17 unknowns and 6
/// outputs: about 160 MB per simulation). A θ whose fastest mode needs
/// more is not simulated, and a fit that goes there stops at that edge.
pub(crate) const MAX_SUBSTEPS: usize = 32;

/// The simulation of `structure` driven by `record` over `window`, on a
/// grid of `step` if the user gave one, else of the fastest output's
/// sample period divided into the fewest equal sub-steps that keep h·|λ|
/// within [`RK4_STEP_LIMIT`], λ the fastest eigenvalue of the model
/// linearised at the window's start with its start values
/// ([`fastest_mode`]). Returns it and the notes that say why the sample
/// period is divided, if it is: the channels' instants, then the model's
/// fastest mode ([`substep_note`]).
pub(crate) fn driven_simulation(
    record: &FlightRecord,
    structure: &ModelStructure,
    interpolation: &InputInterpolation,
    step: Option<f64>,
    window: (f64, f64),
) -> Result<(DrivenSimulation, Vec<String>)> {
    let inputs = driving_channels(structure);
    let sample_period = integration_step(record, &structure.outputs, step)?;
    let period = observation_step(record, &structure.outputs, &inputs, step, window.0)?;
    let alpha_dot = structure.aircraft.aero.takes_measured_alpha_dot();
    let simulate = |step: f64| {
        DrivenSimulation::from_record(
            record,
            &structure.integrate,
            interpolation,
            step,
            window,
            alpha_dot,
        )
    };
    let simulation = simulate(period)?;
    if step.is_some() {
        return Ok((simulation, Vec::new()));
    }
    let mut notes: Vec<String> = (period < sample_period)
        .then(|| {
            format!(
                "grid step {period:.4} s, 1/{:.0} of the sample period {sample_period} s: the channels' samples lie at different instants of the recorder's frame, and each falls on a grid point",
                sample_period / period
            )
        })
        .into_iter()
        .collect();
    let initial = recorded_initial_state(record, structure, &simulation, window.0);
    let model = FlightModel::new(structure.aircraft.clone(), Default::default());
    let fastest = fastest_mode(&simulation, &model, &initial)?;
    let substeps = rk4_substeps(period, fastest).min(MAX_SUBSTEPS);
    // A model file whose start values make a mode too fast for the finest
    // grid (a derivative of 1e30) is refused here, before a grid of
    // billions of points is allocated.
    check_step_reach(period, substeps, fastest)?;
    if substeps == 1 {
        return Ok((simulation, notes));
    }
    notes.push(substep_note(period, substeps, fastest, "at the start"));
    Ok((simulate(period / substeps as f64)?, notes))
}

/// The largest |λ| of `model` (with its parameters' values) driven as
/// `simulation` drives it, linearised at the simulation's start at the
/// flight-path state `initial` (reading its first grid points only).
pub(crate) fn fastest_mode(
    simulation: &DrivenSimulation,
    model: &FlightModel,
    initial: &FlightPathState,
) -> Result<f64> {
    Ok(mode_eigenvalues(simulation, model, initial)?
        .iter()
        .map(|lambda| lambda.norm())
        .fold(0.0, f64::max))
}

/// The eigenvalues of ∂f/∂x of `model` driven as `simulation` drives it,
/// at its start and the flight-path state `initial` (as [`fastest_mode`]):
/// the modes of the model linearised there, over its integrated states.
pub(crate) fn mode_eigenvalues(
    simulation: &DrivenSimulation,
    model: &FlightModel,
    initial: &FlightPathState,
) -> Result<Vec<nalgebra::Complex<f64>>> {
    let view = DrivenStateSpace::new(simulation.head(3), model.clone(), Vec::new())?;
    let x0 = view.state_of(initial);
    let theta = view.parameters();
    let a = view
        .jacobians(simulation.start, x0.as_slice(), theta.as_slice())?
        .rates_by_state;
    // No integrated state (`integrate = []`): no mode.
    if a.is_empty() {
        return Ok(Vec::new());
    }
    Ok(a.complex_eigenvalues().iter().copied().collect())
}

/// An error when the fastest mode |λ| = `fastest` is beyond what RK4
/// steps of `period`/`substeps` integrate (h·|λ| above `RK4_STEP_REACH`),
/// saying so when the steps are already the finest a fit takes.
pub fn check_step_reach(period: f64, substeps: usize, fastest: f64) -> Result<()> {
    let step = period / substeps as f64;
    if step * fastest > RK4_STEP_REACH {
        return Err(Error::BeyondStepReach {
            fastest,
            step,
            reach: RK4_STEP_REACH,
            finest: (substeps >= MAX_SUBSTEPS).then_some(MAX_SUBSTEPS),
        });
    }
    Ok(())
}

/// The fewest equal RK4 steps of a grid interval `period` that keep
/// h·|λ| within [`RK4_STEP_LIMIT`] for the fastest mode |λ| = `fastest`;
/// 1 where one step does, or `fastest` is not a number.
pub(crate) fn rk4_substeps(period: f64, fastest: f64) -> usize {
    let substeps = (period * fastest / RK4_STEP_LIMIT).ceil();
    if substeps > 1.0 && substeps.is_finite() {
        substeps as usize
    } else {
        1
    }
}

/// The note of a grid interval `period` integrated in `substeps` RK4
/// steps for the model's fastest mode |λ| = `fastest` (`when`: at the
/// start, at the estimate).
pub(crate) fn substep_note(period: f64, substeps: usize, fastest: f64, when: &str) -> String {
    format!(
        "integration step {:.4} s: the grid step {period} s would be h·|λ| = {:.2} for the model's fastest mode (|λ| = {fastest:.2}/s {when}), so each grid interval is integrated in {substeps} RK4 steps (`step` sets it)",
        period / substeps as f64,
        period * fastest
    )
}

/// The full flight-path state a simulation of `structure` starts from at
/// `start`: the integrated states as recorded there (0 where a channel is
/// absent), the others the simulation's measured values, χ at its
/// steady value for the recorded α.
pub(crate) fn recorded_initial_state(
    record: &FlightRecord,
    structure: &ModelStructure,
    simulation: &DrivenSimulation,
    start: f64,
) -> FlightPathState {
    let mut initial = simulation.measured()[0];
    for &i in &structure.integrate {
        initial[i] = record
            .channel(FLIGHT_PATH_STATES[i])
            .ok()
            .and_then(|c| c.value_at(start))
            .unwrap_or(0.0);
    }
    initial[10] = structure.aircraft.aero.steady_separation(initial[1]);
    initial
}

/// A postulated model as ẋ = f(t, x, u, θ), y = h(t, x, u, θ) on an
/// integration grid t_k = start + k·step, k = 0 … len − 1, its inputs u
/// its own (read from the record it is driven by). Every call takes θ.
///
/// A model implements each operation once, in its workspace form (the
/// result written into a buffer the caller keeps: `outputs_into`,
/// `jacobians_into`, `step_into`); the allocating forms (`outputs`,
/// `jacobians`, `step`) are provided from them. The batched forms
/// (`step_points_into`, `outputs_points_into`) have defaults from the
/// single forms, for a model that can share work between points to
/// override (the UKF's sigma points).
pub trait StateSpaceModel {
    /// The number of states n (the length of x).
    fn state_count(&self) -> usize;
    /// The number of outputs (the length of y).
    fn output_count(&self) -> usize;
    /// The number of parameters (the length of θ).
    fn parameter_count(&self) -> usize;
    /// The number of grid points.
    fn len(&self) -> usize;
    /// Whether the grid has no points.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The time of grid point k.
    fn time(&self, k: usize) -> f64;
    /// ẋ = f(t, x, u(t), θ).
    fn rates(&self, t: f64, x: &[f64], theta: &[f64]) -> Result<DVector<f64>>;
    /// y = h(t, x, u(t), θ), written into `into` (resized to the output
    /// count).
    fn outputs_into(&self, t: f64, x: &[f64], theta: &[f64], into: &mut DVector<f64>)
    -> Result<()>;
    /// ∂f/∂x, ∂f/∂θ, ∂h/∂x, ∂h/∂θ at (t, x, θ), written into `into`'s
    /// matrices (resized as needed), and with `outputs` y = h(t, x, u, θ)
    /// into it, the same numbers as [`StateSpaceModel::outputs_into`]'s.
    fn jacobians_into(
        &self,
        t: f64,
        x: &[f64],
        theta: &[f64],
        into: &mut Jacobians,
        outputs: Option<&mut DVector<f64>>,
    ) -> Result<()>;
    /// The state at grid point k + 1 after one integration step from x at
    /// grid point k, written into `into` (resized to the state count).
    fn step_into(&self, k: usize, x: &[f64], theta: &[f64], into: &mut DVector<f64>) -> Result<()>;

    /// [`StateSpaceModel::outputs_into`] into a new vector.
    fn outputs(&self, t: f64, x: &[f64], theta: &[f64]) -> Result<DVector<f64>> {
        let mut outputs = DVector::zeros(self.output_count());
        self.outputs_into(t, x, theta, &mut outputs)?;
        Ok(outputs)
    }
    /// [`StateSpaceModel::jacobians_into`] into new matrices.
    fn jacobians(&self, t: f64, x: &[f64], theta: &[f64]) -> Result<Jacobians> {
        let mut jacobians = Jacobians::empty();
        self.jacobians_into(t, x, theta, &mut jacobians, None)?;
        Ok(jacobians)
    }
    /// [`StateSpaceModel::step_into`] into a new vector.
    fn step(&self, k: usize, x: &[f64], theta: &[f64]) -> Result<DVector<f64>> {
        let mut next = DVector::zeros(self.state_count());
        self.step_into(k, x, theta, &mut next)?;
        Ok(next)
    }
    /// [`StateSpaceModel::step_into`] from grid point k for many points
    /// (x_j, θ_j) at once, x_{j+1} written into column j of `into` (columns
    /// `stride` apart, [`Points::check_into`]): the same numbers as one
    /// call per point. A model that can takes what the points share (the
    /// step's inputs, its kept buffers) once; the default calls
    /// [`StateSpaceModel::step_into`] per point. An error (the first
    /// point's that fails) leaves `into` unspecified.
    fn step_points_into(
        &self,
        k: usize,
        points: Points,
        into: &mut [f64],
        stride: usize,
    ) -> Result<()> {
        points.each_into(into, stride, self.state_count(), |j, value| {
            self.step_into(k, points.state(j), points.theta(j), value)
        })
    }
    /// [`StateSpaceModel::outputs_into`] at t for many points (x_j, θ_j) at
    /// once, y_j written into column j of `into` (columns `stride` apart):
    /// the same numbers as one call per point, what the points share taken
    /// once where the model can ([`StateSpaceModel::step_points_into`]).
    fn outputs_points_into(
        &self,
        t: f64,
        points: Points,
        into: &mut [f64],
        stride: usize,
    ) -> Result<()> {
        points.each_into(into, stride, self.output_count(), |j, value| {
            self.outputs_into(t, points.state(j), points.theta(j), value)
        })
    }

    /// [`StateSpaceModel::step`] with the sensitivities S = ∂x/∂u carried
    /// through it: S ← (∂step/∂x)·S + ∂step/∂u, the step's exact
    /// derivative. Column j of S is the derivative by an unknown u_j,
    /// `columns[j]` the parameter it is (an index into θ), or None for an
    /// unknown that does not enter f (it moves x only through S). Returns
    /// the step's value (the same as [`StateSpaceModel::step`]'s), or None
    /// for a model that does not propagate sensitivities (the default; a
    /// caller then differences whole steps or passes).
    fn step_sensitivity(
        &self,
        _k: usize,
        _x: &[f64],
        _theta: &[f64],
        _columns: &[Option<usize>],
        _sensitivity: &mut DMatrix<f64>,
    ) -> Result<Option<DVector<f64>>> {
        Ok(None)
    }
}

/// A copy of a view's flight model with θ written in, the buffers of its
/// linearisation, and the angles and air of the last state its outputs
/// were evaluated at.
struct ModelScratch {
    model: FlightModel,
    linearisation: LinearisationBuffers,
    points: PointMemo,
}

/// The state-space view of a nonlinear postulated model driven by a
/// record ([`DrivenSimulation`]). x holds the integrated flight-path states
/// in the order of `FLIGHT_PATH_STATES` (with χ wherever the aerodynamic
/// model makes it a state); the others are the record's measured
/// pseudo-controls. θ holds every aerodynamic parameter of the model, in
/// the order of its parameter set. The inputs at t: each control held or
/// linear as the `interpolation` setting chooses for it (a hold takes the
/// value of the step t starts, so at a grid time the new sample),
/// measured pseudo-controls and their rates linear between grid points.
#[derive(Debug, Clone)]
pub struct DrivenStateSpace {
    simulation: DrivenSimulation,
    model: FlightModel,
    outputs: Vec<Observable>,
    /// The flight-path states in x.
    states: Vec<usize>,
    mask: FlightPathState,
    scratch: Scratch<ModelScratch>,
}

/// Times within this fraction of a step of a grid point or of a step's
/// midpoint are taken as that point (the RK4 stage times).
const TIME_SNAP: f64 = 1e-9;

impl DrivenStateSpace {
    /// The view of `model` (its parameters' values are the default θ,
    /// [`DrivenStateSpace::parameters`]) driven as `simulation` drives it,
    /// with outputs `outputs`.
    pub fn new(
        simulation: DrivenSimulation,
        model: FlightModel,
        outputs: Vec<Observable>,
    ) -> Result<DrivenStateSpace> {
        if simulation.len() < 2 {
            return Err(Error::Grid {
                reason: "a state-space view needs at least two grid points".into(),
            });
        }
        let mask = simulation.mask(&model);
        let states = (0..FLIGHT_PATH_SIZE).filter(|&i| mask[i] == 1.0).collect();
        Ok(DrivenStateSpace {
            simulation,
            model,
            outputs,
            states,
            mask,
            scratch: Scratch::default(),
        })
    }

    /// The view of `structure` driven by `record` as output error drives
    /// it: over the window where every output has samples (inside `limit`),
    /// on `driven_simulation`'s grid (`step` if given, else the fastest
    /// output's period divided for the channels' instants and for RK4's
    /// accuracy on the model's fastest mode; the simulation's notes say
    /// why when it is divided), with the state x₀ the record gives at
    /// the window's start (`recorded_initial_state`). Returns the view
    /// and x₀.
    pub fn for_record(
        record: &FlightRecord,
        structure: &ModelStructure,
        interpolation: &InputInterpolation,
        step: Option<f64>,
        limit: Option<(f64, f64)>,
    ) -> Result<(DrivenStateSpace, DVector<f64>)> {
        let window = fitting_window(record, &structure.outputs, limit)?;
        let (mut simulation, grid_note) =
            driven_simulation(record, structure, interpolation, step, window)?;
        simulation.notes.extend(grid_note);
        let initial = recorded_initial_state(record, structure, &simulation, window.0);
        let outputs = observables(structure)?;
        let model = FlightModel::new(structure.aircraft.clone(), Default::default());
        let view = DrivenStateSpace::new(simulation, model, outputs)?;
        let x0 = view.state_of(&initial);
        Ok((view, x0))
    }

    /// The flight-path states in x (indices into `FLIGHT_PATH_STATES`).
    pub fn states(&self) -> &[usize] {
        &self.states
    }

    /// The names of the states in x.
    pub fn state_names(&self) -> Vec<&'static str> {
        self.states.iter().map(|&i| FLIGHT_PATH_STATES[i]).collect()
    }

    /// The model's own parameter values (θ as the model file gives it).
    pub fn parameters(&self) -> DVector<f64> {
        DVector::from_column_slice(self.model.aircraft.aero.parameters.values())
    }

    /// The driven simulation underneath.
    pub fn simulation(&self) -> &DrivenSimulation {
        &self.simulation
    }

    /// The outputs, in the order of y.
    pub fn observables(&self) -> &[Observable] {
        &self.outputs
    }

    /// x of a full flight-path state.
    pub fn state_of(&self, full: &FlightPathState) -> DVector<f64> {
        DVector::from_iterator(self.states.len(), self.states.iter().map(|&i| full[i]))
    }

    /// The model with θ written in; an error for a θ of the wrong length,
    /// or one that changes which states are integrated (the stall model's
    /// χ is a state only while τ1 > 0).
    pub(crate) fn model_at(&self, theta: &[f64]) -> Result<FlightModel> {
        let mut model = self.model.clone();
        self.write_parameters(&mut model, theta)?;
        Ok(model)
    }

    /// Writes θ into `model` (a copy of the view's): the checks of
    /// [`DrivenStateSpace::model_at`].
    fn write_parameters(&self, model: &mut FlightModel, theta: &[f64]) -> Result<()> {
        let count = self.parameter_count();
        if theta.len() != count {
            return Err(Error::Shape {
                reason: format!(
                    "θ has {} values; the model has {count} parameters",
                    theta.len()
                ),
            });
        }
        model
            .aircraft
            .aero
            .parameters
            .values_mut()
            .copy_from_slice(theta);
        if !self.simulation.gives_mask(model, &self.mask) {
            return Err(Error::Method {
                reason:
                    "θ changes which states the model integrates (χ is a state only while τ1 > 0)"
                        .into(),
            });
        }
        Ok(())
    }

    /// The driven model linearised at (t, x) with θ written in, its
    /// outputs' derivatives too, handed to `read`.
    fn linearised<R>(
        &self,
        t: f64,
        x: &[f64],
        theta: &[f64],
        read: impl FnOnce(&LinearisationBuffers) -> R,
    ) -> Result<R> {
        let (full, (controls, pseudo, ambient)) = self.point(t, x)?;
        self.with_model(theta, |model, buffers, _| {
            driven::linearise_with(
                model,
                &full,
                (&controls, pseudo, ambient),
                &self.states,
                &self.outputs,
                true,
                buffers,
            );
            read(buffers)
        })
    }

    /// `f` on the model at θ ([`DrivenStateSpace::model_at`]) and the
    /// linearisation's buffers, from the view's scratch: θ is written into
    /// a kept copy of the model instead of a fresh clone.
    fn with_model<R>(
        &self,
        theta: &[f64],
        f: impl FnOnce(&FlightModel, &mut LinearisationBuffers, &mut PointMemo) -> R,
    ) -> Result<R> {
        self.scratch.with(
            || self.fresh_scratch(),
            |scratch| {
                self.write_parameters(&mut scratch.model, theta)?;
                Ok(f(
                    &scratch.model,
                    &mut scratch.linearisation,
                    &mut scratch.points,
                ))
            },
        )
    }

    /// `f(model, j, x_j, memo)` for every point j in turn, on the kept
    /// model with θ_j written in (once for all points when they share θ)
    /// and the kept outputs' memo; the first error stops it.
    fn with_points(
        &self,
        points: Points,
        mut f: impl FnMut(&FlightModel, usize, &[f64], &mut PointMemo) -> Result<()>,
    ) -> Result<()> {
        self.scratch.with(
            || self.fresh_scratch(),
            |scratch| {
                for j in 0..points.len() {
                    if j == 0 || !points.share_parameters() {
                        self.write_parameters(&mut scratch.model, points.theta(j))?;
                    }
                    f(&scratch.model, j, points.state(j), &mut scratch.points)?;
                }
                Ok(())
            },
        )
    }

    /// The kept buffers as first made: a copy of the view's model.
    fn fresh_scratch(&self) -> ModelScratch {
        ModelScratch {
            model: self.model.clone(),
            linearisation: LinearisationBuffers::default(),
            points: PointMemo::default(),
        }
    }

    /// The full flight-path state with x in its integrated entries and
    /// `measured` in the others.
    #[inline(always)]
    fn full(&self, x: &[f64], measured: &FlightPathState) -> Result<FlightPathState> {
        if x.len() != self.states.len() {
            return Err(Error::Shape {
                reason: format!(
                    "x has {} values; the model has {} states ({})",
                    x.len(),
                    self.states.len(),
                    self.state_names().join(", ")
                ),
            });
        }
        let mut full = *measured;
        for (&i, &value) in self.states.iter().zip(x) {
            full[i] = value;
        }
        Ok(full)
    }

    /// The grid step t falls in and the fraction into it (the last grid
    /// point: its own, fraction 0); an error outside the grid.
    fn locate(&self, t: f64) -> Result<(usize, f64)> {
        let simulation = &self.simulation;
        let last = simulation.len() - 1;
        let position = (t - simulation.start) / simulation.step;
        if !position.is_finite() || position < -TIME_SNAP || position > last as f64 + TIME_SNAP {
            return Err(Error::Grid {
                reason: format!(
                    "t = {t} s is outside the record's integration grid ({} s to {} s)",
                    simulation.time(0),
                    simulation.time(last)
                ),
            });
        }
        let halves = (2.0 * position).round();
        let position = if (position - 0.5 * halves).abs() <= TIME_SNAP {
            0.5 * halves
        } else {
            position
        };
        let k = (position.floor().max(0.0) as usize).min(last);
        Ok((k, if k == last { 0.0 } else { position - k as f64 }))
    }

    /// The full state and the inputs at t.
    fn point(
        &self,
        t: f64,
        x: &[f64],
    ) -> Result<(FlightPathState, (Controls, PseudoRates, Ambient))> {
        let (k, fraction) = self.locate(t)?;
        let (measured, controls, pseudo, ambient) = self.simulation.inputs_at(k, fraction);
        Ok((self.full(x, &measured)?, (controls, pseudo, ambient)))
    }
}

impl StateSpaceModel for DrivenStateSpace {
    fn state_count(&self) -> usize {
        self.states.len()
    }

    fn output_count(&self) -> usize {
        self.outputs.len()
    }

    fn parameter_count(&self) -> usize {
        self.model.aircraft.aero.parameters.values().len()
    }

    fn len(&self) -> usize {
        self.simulation.len()
    }

    fn time(&self, k: usize) -> f64 {
        self.simulation.time(k)
    }

    /// The flight-path rates of the integrated states ([`super::driven`]'s
    /// module header gives the equations).
    fn rates(&self, t: f64, x: &[f64], theta: &[f64]) -> Result<DVector<f64>> {
        let (full, (controls, pseudo, ambient)) = self.point(t, x)?;
        let (rates, _) = self.with_model(theta, |model, _, _| {
            driven::evaluate(model, &full, &controls, pseudo, ambient, &[])
        })?;
        Ok(self.state_of(&rates))
    }

    fn outputs_into(
        &self,
        t: f64,
        x: &[f64],
        theta: &[f64],
        into: &mut DVector<f64>,
    ) -> Result<()> {
        if into.len() != self.outputs.len() {
            *into = DVector::zeros(self.outputs.len());
        }
        let m = self.outputs.len();
        self.outputs_points_into(t, Points::one(x, theta), into.as_mut_slice(), m)
    }

    /// The outputs at t of every point, the time located, the inputs
    /// interpolated and the kept model taken once; θ written into it once
    /// per point (once for all when they share it), the angles and air
    /// shared by consecutive points at one full state.
    fn outputs_points_into(
        &self,
        t: f64,
        points: Points,
        into: &mut [f64],
        stride: usize,
    ) -> Result<()> {
        let m = self.outputs.len();
        points.check_into(into.len(), stride, m)?;
        let (k, fraction) = self.locate(t)?;
        let (measured, controls, pseudo, ambient) = self.simulation.inputs_at(k, fraction);
        self.with_points(points, |model, j, x, memo| {
            let full = self.full(x, &measured)?;
            driven::evaluate_into(
                model,
                &full,
                &controls,
                pseudo,
                ambient,
                &self.outputs,
                &mut into[j * stride..j * stride + m],
                memo,
            );
            Ok(())
        })
    }

    /// The Jacobians by the sensitivity equations' own linearisation
    /// (Jategaonkar §4.6): ∂f/∂x and ∂h/∂x by dual numbers
    /// (forward differences along the altitude and where the forces depend
    /// on α̇), a term's ∂f/∂θ and ∂h/∂θ exact (f is affine in each
    /// coefficient: its response times the term's regressor), a nonlinear
    /// parameter's (e, the stall parameters) a central difference of step
    /// 10⁻⁵·max(|θ|, 10⁻²). Computed in the view's kept buffers, its outputs the
    /// linearisation's values (the evaluation's: the dual numbers' values
    /// are the f64 ones).
    fn jacobians_into(
        &self,
        t: f64,
        x: &[f64],
        theta: &[f64],
        into: &mut Jacobians,
        outputs: Option<&mut DVector<f64>>,
    ) -> Result<()> {
        self.linearised(t, x, theta, |buffers| buffers.copy_into(into, outputs))
    }

    /// The step's exact derivative: the sensitivity equations
    /// Ṡ = (∂f/∂x)·S + ∂f/∂u taken through the RK4 step with the model
    /// linearised at each of its four stages, at the stage's state and
    /// inputs ([`rk4_linear_step`], as output error's exact Jacobian;
    /// Jategaonkar §4.6): the derivative of the discrete step itself.
    fn step_sensitivity(
        &self,
        k: usize,
        x: &[f64],
        theta: &[f64],
        columns: &[Option<usize>],
        sensitivity: &mut DMatrix<f64>,
    ) -> Result<Option<DVector<f64>>> {
        let next = self.step(k, x, theta)?;
        let (n, m) = (self.states.len(), columns.len());
        super::jacobians::check_sensitivity_shape(sensitivity, n, columns, theta.len())?;
        let simulation = &self.simulation;
        let h = simulation.step;
        let ends = (simulation.pseudo_rates(k), simulation.pseudo_rates(k + 1));
        let mut a: [DMatrix<f64>; 4] = std::array::from_fn(|_| DMatrix::zeros(n, n));
        let mut b: [DMatrix<f64>; 4] = std::array::from_fn(|_| DMatrix::zeros(n, m));
        self.with_model(theta, |model, buffers, _| -> Result<()> {
            let start = DVector::from_column_slice(x);
            let mut stage = start.clone();
            for (i, (fraction, next_offset)) in [(0.0, 0.5), (0.5, 0.5), (0.5, 1.0), (1.0, 0.0)]
                .into_iter()
                .enumerate()
            {
                let (measured, controls, pseudo, ambient) = if i == 0 {
                    simulation.inputs_at(k, 0.0)
                } else {
                    simulation.inputs_inside(k, fraction, ends)
                };
                let full = self.full(stage.as_slice(), &measured)?;
                driven::linearise_with(
                    model,
                    &full,
                    (&controls, pseudo, ambient),
                    &self.states,
                    &self.outputs,
                    false,
                    buffers,
                );
                let (rates, by_state, by_parameter) =
                    buffers.rates_and_jacobians().ok_or_else(|| Error::Shape {
                        reason: "no linearisation".into(),
                    })?;
                a[i].copy_from(by_state);
                for (j, column) in columns.iter().enumerate() {
                    if let Some(p) = *column {
                        b[i].set_column(j, &by_parameter.column(p));
                    }
                }
                if i < 3 {
                    stage.copy_from(&start);
                    for (s, &state) in stage.iter_mut().zip(&self.states) {
                        *s += next_offset * h * rates[state];
                    }
                }
            }
            Ok(())
        })??;
        let mut work: [DMatrix<f64>; 3] = std::array::from_fn(|_| DMatrix::zeros(n, m));
        rk4_linear_step(
            sensitivity,
            h,
            [
                (&a[0], &b[0]),
                (&a[1], &b[1]),
                (&a[2], &b[2]),
                (&a[3], &b[3]),
            ],
            &mut work,
        );
        Ok(Some(next))
    }

    /// One RK4 step (the project's integrator, [`aeroid_sim::integrator`])
    /// of the integrated states, the inputs inside the step as the
    /// whole-trajectory simulation takes them: the same routine as
    /// [`DrivenSimulation::simulate`]'s, so the same state bit for bit.
    /// An error when k is not a step of the grid, or when the model departs
    /// (a non-finite state, |α| or |β| beyond 90°, airspeed not positive).
    fn step_into(&self, k: usize, x: &[f64], theta: &[f64], into: &mut DVector<f64>) -> Result<()> {
        let n = self.states.len();
        if into.len() != n {
            *into = DVector::zeros(n);
        }
        self.step_points_into(k, Points::one(x, theta), into.as_mut_slice(), n)
    }

    /// The steps of every point from grid point k, what they share taken
    /// once (`driven::PlainSteps`): the stages' inputs, the kept model
    /// (θ written in once per point, once for all when they share it), and
    /// the first stage's angles and air for consecutive points at one full
    /// state (the sigma points that move only parameters).
    fn step_points_into(
        &self,
        k: usize,
        points: Points,
        into: &mut [f64],
        stride: usize,
    ) -> Result<()> {
        let simulation = &self.simulation;
        if k + 1 >= simulation.len() {
            return Err(Error::Grid {
                reason: format!(
                    "no integration step from grid point {k}: the grid has {} points",
                    simulation.len()
                ),
            });
        }
        let n = self.states.len();
        points.check_into(into.len(), stride, n)?;
        let mut steps = simulation.plain_steps(k, &self.mask, &self.model.environment.atmosphere);
        let measured = &simulation.measured()[k];
        self.with_points(points, |model, j, x, _| {
            let full = self.full(x, measured)?;
            driven::check_departure(&full, simulation.time(k))?;
            let next = steps.step(model, &full);
            driven::check_departure(&next, simulation.time(k + 1))?;
            for (into, &i) in into[j * stride..j * stride + n]
                .iter_mut()
                .zip(&self.states)
            {
                *into = next[i];
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests;
