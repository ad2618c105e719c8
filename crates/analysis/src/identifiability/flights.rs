//! The flights of an identifiability analysis: the scenario flown again
//! with a parameter or a segment's initial state moved, recorded without
//! random errors, and the weighted central differences, bounds and
//! first-order model errors taken from them (the parent module's header).

use super::{ChannelUse, IdentifiabilityOptions};
use crate::error::{Error, Result};
use aeroid_numerics::gauss_newton::{pseudo_inverse_or_infinite, unit_diagonal_scale};
use aeroid_record::FlightRecord;
use aeroid_record::recorder::Profile;
use aeroid_sim::Simulation;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::state::{self, CONTROL_COUNT, Control, StateVector};
use aeroid_sim::trace::TruthTrace;
use nalgebra::{DMatrix, DVector, Dyn, SVD, UnitQuaternion, Vector3};

/// What the flights of one analysis share: the scenario, the profile and
/// its deterministic parts (`clean`), the parameters and their truths,
/// the channels used and each row's segment, and the segments' length in
/// steps and the unknowns (`columns`: parameters, then each segment's
/// initial state).
pub(super) struct Flights<'a> {
    pub(super) scenario: &'a Scenario,
    pub(super) profile: &'a Profile,
    pub(super) options: &'a IdentifiabilityOptions,
    pub(super) clean: Profile,
    pub(super) names: &'a [String],
    pub(super) truths: &'a [f64],
    pub(super) uses: &'a [ChannelUse],
    pub(super) segment_of_row: &'a [usize],
    pub(super) segment_steps: usize,
    pub(super) columns: usize,
}

impl Flights<'_> {
    /// Flies `simulation` with one parameter changed or one initial-state
    /// component moved in every segment, restarting every segment from
    /// the nominal flight's state there; its record.
    fn fly(
        &self,
        simulation: &Simulation,
        nominal_states: &[StateVector],
        parameter: Option<(&str, f64)>,
        nuisance: Option<(usize, f64)>,
    ) -> Result<FlightRecord> {
        let mut simulation = simulation.clone();
        if let Some((name, value)) = parameter {
            simulation.model.aircraft.aero.parameters.set(name, value)?;
        }
        let segment_steps = self.segment_steps;
        let trace = simulation
            .run_with_restarts(|k| {
                (k % segment_steps == 0).then(|| match nuisance {
                    Some((component, delta)) => {
                        perturbed_state(&nominal_states[k], component, delta)
                    }
                    None => nominal_states[k],
                })
            })
            .map_err(|error| Error::Identifiability {
                scenario: self.scenario.name.clone(),
                reason: format!("a perturbed flight failed: {error}"),
            })?;
        Ok(self
            .clean
            .record(&trace, &self.scenario.aircraft, self.scenario.seed)?)
    }

    /// Weighted central difference of the recorded channels, row by row.
    fn difference(&self, plus: &FlightRecord, minus: &FlightRecord, h: f64) -> Result<Vec<f64>> {
        let wraps = |name: &str| {
            self.profile
                .channels
                .iter()
                .any(|c| c.measurand.name == name && c.measurand.wraps)
        };
        let mut column = Vec::with_capacity(self.segment_of_row.len());
        for channel in self.uses {
            let (up, down) = (plus.channel(&channel.name)?, minus.channel(&channel.name)?);
            let angle = wraps(&channel.name);
            for (a, b) in up.values.iter().zip(&down.values) {
                let mut d = a - b;
                if angle {
                    // Heading-like channels wrap at 2π; a tiny perturbation never moves π.
                    d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
                }
                column.push(d / (2.0 * h) / channel.sigma);
            }
        }
        Ok(column)
    }

    /// The weighted sensitivities of a flight (its simulation and states)
    /// to the parameters, then to each segment's initial state.
    fn sensitivities(
        &self,
        simulation: &Simulation,
        states: &[StateVector],
    ) -> Result<DMatrix<f64>> {
        let mut sensitivities = DMatrix::zeros(self.segment_of_row.len(), self.columns);
        for (j, (name, truth)) in self.names.iter().zip(self.truths).enumerate() {
            let h = self.options.parameter_step(*truth);
            let plus = self.fly(simulation, states, Some((name, truth + h)), None)?;
            let minus = self.fly(simulation, states, Some((name, truth - h)), None)?;
            for (row, value) in self.difference(&plus, &minus, h)?.into_iter().enumerate() {
                sensitivities[(row, j)] = value;
            }
        }
        // An initial-state component moved in every segment at once:
        // segments are independent, so each row's difference belongs to
        // its own segment's unknown.
        for component in 0..NUISANCE {
            let h = nuisance_step(component);
            let plus = self.fly(simulation, states, None, Some((component, h)))?;
            let minus = self.fly(simulation, states, None, Some((component, -h)))?;
            for (row, value) in self.difference(&plus, &minus, h)?.into_iter().enumerate() {
                let column = self.names.len() + NUISANCE * self.segment_of_row[row] + component;
                sensitivities[(row, column)] = value;
            }
        }
        Ok(sensitivities)
    }

    /// The bounds σ_j of the parameters from a flight's sensitivities.
    fn bounds(&self, sensitivities: &DMatrix<f64>) -> Vec<f64> {
        let count = self.names.len();
        let information = sensitivities.transpose() * sensitivities;
        let covariance = pseudo_inverse_or_infinite(&marginal_information(&information, count));
        (0..count)
            .map(|j| covariance[(j, j)].max(0.0).sqrt())
            .collect::<Vec<f64>>()
    }

    /// The model errors: the record of a flight (its states and record)
    /// minus the record of the flight an estimator's model flies, weighted
    /// as the sensitivities.
    pub(super) fn errors(
        &self,
        flight: &Simulation,
        states: &[StateVector],
        nominal: &FlightRecord,
        what: &str,
    ) -> Result<DVector<f64>> {
        let segment_steps = self.segment_steps;
        let trace = flight
            .run_with_restarts(|k| (k % segment_steps == 0).then(|| states[k]))
            .map_err(|error| Error::Identifiability {
                scenario: self.scenario.name.clone(),
                reason: format!("the flight {what} failed: {error}"),
            })?;
        let modelled = self
            .clean
            .record(&trace, &self.scenario.aircraft, self.scenario.seed)?;
        // (nominal − modelled)/(2·1): `difference` divides by 2h.
        Ok(DVector::from_vec(self.difference(nominal, &modelled, 0.5)?))
    }

    /// The bounds and the recorded inputs' errors of the flight `calm`
    /// (flown and recorded here).
    pub(super) fn analyse_calm(&self, calm: &Simulation) -> Result<(Vec<f64>, DVector<f64>)> {
        let trace = calm.run()?;
        let states: Vec<StateVector> = trace.samples.iter().map(|s| s.state).collect();
        let record = self
            .clean
            .record(&trace, &self.scenario.aircraft, self.scenario.seed)?;
        let (sigmas, input_error, _) = self.analyse_flight(calm, &trace, &states, &record)?;
        Ok((sigmas, input_error))
    }

    /// A flight's bounds, its least-squares solver and the first-order
    /// error of the controls as the recorder writes them (at their rate,
    /// slot, delay and lag, and quantized to their resolution), from the
    /// flight's trace, its states and its record.
    pub(super) fn analyse_flight(
        &self,
        simulation: &Simulation,
        trace: &TruthTrace,
        states: &[StateVector],
        record: &FlightRecord,
    ) -> Result<(Vec<f64>, DVector<f64>, LeastSquares)> {
        let sensitivities = self.sensitivities(simulation, states)?;
        let solver = LeastSquares::new(&sensitivities);
        let controls = self.profile.without_noise().record(
            trace,
            &self.scenario.aircraft,
            self.scenario.seed,
        )?;
        let input_error = solver.solve(&self.errors(
            &with_recorded_inputs(simulation, &controls)?,
            states,
            record,
            "with the inputs as recorded",
        )?);
        Ok((self.bounds(&sensitivities), input_error, solver))
    }
}

/// Unknown initial-state components of a segment: u, v, w, p, q, r, three
/// small body-axis rotations of the attitude, and the altitude.
pub(super) const NUISANCE: usize = 10;

/// The state `x` with nuisance component `component` moved by `delta`.
fn perturbed_state(x: &StateVector, component: usize, delta: f64) -> StateVector {
    let mut x = *x;
    match component {
        0..=5 => x[state::U + component] += delta,
        6..=8 => {
            let mut axis = Vector3::zeros();
            axis[component - 6] = delta;
            let attitude = state::attitude(&x) * UnitQuaternion::from_scaled_axis(axis);
            state::set_attitude(&mut x, &attitude);
        }
        _ => x[state::DOWN] -= delta,
    }
    x
}

/// Central-difference step of nuisance component `component` (m/s, rad/s, rad, m).
fn nuisance_step(component: usize) -> f64 {
    match component {
        0..=2 => 1e-2,
        3..=5 => 1e-4,
        6..=8 => 1e-4,
        _ => 0.1,
    }
}

/// δ = S⁺·r for a weighted output error r: the first-order move of every
/// unknown (parameters, then the segments' initial states) of a
/// least-squares fit, by the SVD of S with unit-norm columns; directions
/// the data cannot separate (σ = ∞) drop out.
pub(super) struct LeastSquares {
    /// 1/‖column‖ of S (0 for a zero column).
    norms: Vec<f64>,
    svd: SVD<f64, Dyn, Dyn>,
    tolerance: f64,
}

impl LeastSquares {
    /// The solver of the sensitivities S.
    fn new(sensitivities: &DMatrix<f64>) -> LeastSquares {
        let norms: Vec<f64> = sensitivities
            .column_iter()
            .map(|c| {
                let n = c.norm();
                if n > 0.0 { 1.0 / n } else { 0.0 }
            })
            .collect();
        let scaled = DMatrix::from_fn(sensitivities.nrows(), sensitivities.ncols(), |i, j| {
            sensitivities[(i, j)] * norms[j]
        });
        let svd = scaled.svd(true, true);
        let tolerance = 1e-12 * svd.singular_values.max();
        LeastSquares {
            norms,
            svd,
            tolerance,
        }
    }

    /// δ = S⁺·r.
    pub(super) fn solve(&self, residual: &DVector<f64>) -> DVector<f64> {
        let norms = &self.norms;
        let solution = self
            .svd
            .solve(residual, self.tolerance)
            .unwrap_or_else(|_| DVector::zeros(norms.len()));
        DVector::from_iterator(norms.len(), solution.iter().zip(norms).map(|(x, n)| x * n))
    }
}

/// The flight with the controls an estimator knows: each control channel
/// of the (noise-free) record, split surfaces combined, reconstructed at
/// every simulation step by the scenario's interpolation; a control the
/// record lacks stays as flown.
fn with_recorded_inputs(simulation: &Simulation, record: &FlightRecord) -> Result<Simulation> {
    let (record, _) = aeroid_record::prep::surfaces::with_combined_surfaces(record)?;
    let times: Vec<f64> = (0..simulation.exogenous.len())
        .map(|k| k as f64 * simulation.step)
        .collect();
    let mut flight = simulation.clone();
    for control in Control::ALL {
        let Ok(channel) = record.channel(control.name()) else {
            continue;
        };
        let values = channel.sampled_at(&times, simulation.interpolation)?;
        for (exogenous, value) in flight.exogenous.iter_mut().zip(values) {
            if value.is_finite() {
                exogenous[control.index()] = value;
            }
        }
    }
    Ok(flight)
}

/// The flight in the scenario's steady wind, without gusts or turbulence,
/// the controls as flown.
pub(super) fn without_gusts(scenario: &Scenario, simulation: &Simulation) -> Result<Simulation> {
    let mut calm = scenario.clone();
    calm.wind.gusts.clear();
    calm.wind.turbulence = None;
    let calm = Simulation::prepare(&calm)?;
    let mut flight = simulation.clone();
    for (exogenous, steady) in flight.exogenous.iter_mut().zip(&calm.exogenous) {
        for i in CONTROL_COUNT..exogenous.len() {
            exogenous[i] = steady[i];
        }
    }
    flight.winds = calm.winds;
    Ok(flight)
}

/// The information about the first `count` unknowns with the others
/// (nuisance initial states) marginalised: the Schur complement
/// M_θθ − M_θn·M_nn⁺·M_nθ. Nuisance directions that the data cannot
/// separate (two initial-state components with the same effect) drop out of
/// the pseudo-inverse instead of making parameters look unidentifiable.
fn marginal_information(information: &DMatrix<f64>, count: usize) -> DMatrix<f64> {
    let total = information.nrows();
    if total == count {
        return information.clone();
    }
    let nuisance = information
        .view((count, count), (total - count, total - count))
        .into_owned();
    let scale = unit_diagonal_scale(&nuisance);
    let scaled = DMatrix::from_fn(total - count, total - count, |i, j| {
        nuisance[(i, j)] * scale[i] * scale[j]
    });
    let svd = scaled.svd(true, true);
    let tolerance = 1e-12 * svd.singular_values.max();
    let inverse = svd
        .pseudo_inverse(tolerance)
        .unwrap_or_else(|_| DMatrix::zeros(total - count, total - count));
    let inverse = DMatrix::from_fn(total - count, total - count, |i, j| {
        inverse[(i, j)] * scale[i] * scale[j]
    });
    let cross = information.view((0, count), (count, total - count));
    information.view((0, 0), (count, count)) - cross * inverse * cross.transpose()
}
