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

use crate::dynamics::{Evaluation, Exogenous, FlightModel};
use crate::error::{Error, Result};
use crate::estimation::structure::FLIGHT_PATH_STATES;
use crate::integrator::{Interpolation, rk4_step};
use crate::record::FlightRecord;
use crate::state::{self, CONTROL_COUNT, Control, Controls, EulerAngles, StateVector};
use crate::units::STANDARD_GRAVITY;
use nalgebra::SVector;

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

/// A model output by record channel name, from the state and its evaluation.
pub fn observe(name: &str, x: &FlightPathState, evaluation: &Evaluation) -> Option<f64> {
    if let Some(i) = FLIGHT_PATH_STATES.iter().position(|s| *s == name) {
        return Some(x[i]);
    }
    let f = &evaluation.specific_force;
    let c = &evaluation.coefficients;
    Some(match name {
        "nx" => f.x / STANDARD_GRAVITY,
        "ny" => f.y / STANDARD_GRAVITY,
        "nz" => -f.z / STANDARD_GRAVITY,
        "p_dot" => evaluation.angular_acceleration.x,
        "q_dot" => evaluation.angular_acceleration.y,
        "r_dot" => evaluation.angular_acceleration.z,
        "mach" => evaluation.air_data.mach,
        "dynamic_pressure" => evaluation.air_data.dynamic_pressure,
        "CX" => c.force.x,
        "CY" => c.force.y,
        "CZ" => c.force.z,
        "CL" => c.lift,
        "CD" => c.drag,
        "Cl" => c.moment.x,
        "Cm" => c.moment.y,
        "Cn" => c.moment.z,
        _ => return None,
    })
}

/// True when `observe` knows the name.
pub fn is_observable(name: &str) -> bool {
    observe(name, &FlightPathState::zeros(), &Evaluation::default()).is_some()
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

    /// Rates over step k of the measured airspeed and sideslip, where they
    /// are not integrated: the centred difference (x[k+2] − x[k−1])/(3·Δt),
    /// which leaves out the two samples the step interpolates between. A
    /// rate from those same samples would share their noise, and the product
    /// of a noisy measured β with its own noisy rate in V̇ (Eq. in
    /// [`derivative`]) has a non-zero mean, −σ²/Δt: an errors-in-variables
    /// bias on drag. Near the ends the window shrinks to what exists.
    fn pseudo_rates(&self, k: usize) -> PseudoRates {
        let last = self.len() - 1;
        let (previous, next) = (k.saturating_sub(1), (k + 2).min(last));
        let (previous, next) = if next > previous {
            (previous, next)
        } else {
            (last.saturating_sub(1), last)
        };
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

    /// Simulates from `initial`, calling `sink(k, x, evaluation)` at every grid
    /// point. Err with the time when the model departs (non-finite, |α| or |β|
    /// beyond 90°, airspeed not positive).
    pub fn simulate(
        &self,
        model: &FlightModel,
        initial: &FlightPathState,
        mut sink: impl FnMut(usize, &FlightPathState, &Evaluation),
    ) -> std::result::Result<(), String> {
        let mut x = self.merge(initial, &self.measured[0]);
        if model.aircraft.aero.chi_is_state() && !self.integrate[CHI] {
            x[CHI] = model.aircraft.aero.separation_target(x[ALPHA], 0.0);
        }
        let mask = FlightPathState::from_fn(|i, _| {
            if self.integrate[i] || (i == CHI && model.aircraft.aero.chi_is_state()) {
                1.0
            } else {
                0.0
            }
        });
        for k in 0..self.len() {
            let pseudo = self.pseudo_rates(k);
            let (_, evaluation) = derivative(model, &x, &self.controls[k], pseudo);
            check_departure(&x, self.time(k))?;
            sink(k, &x, &evaluation);
            if k + 1 == self.len() {
                break;
            }
            let stage = |theta: f64| {
                // Measured pseudo-controls are continuous states: always
                // linear inside the step (consistent with their rates in
                // `pseudo_rates`); controls follow the model's option.
                let measured = self.measured[k] + (self.measured[k + 1] - self.measured[k]) * theta;
                let w = self.interpolation.weight(theta);
                let controls = self.controls[k] + (self.controls[k + 1] - self.controls[k]) * w;
                (measured, controls)
            };
            let next = rk4_step(&x, self.step, |x, theta| {
                let (measured, controls) = stage(theta);
                let merged =
                    FlightPathState::from_fn(
                        |i, _| if mask[i] == 1.0 { x[i] } else { measured[i] },
                    );
                derivative(model, &merged, &controls, pseudo)
                    .0
                    .component_mul(&mask)
            });
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
