//! Trim: wings-level steady flight at a given true airspeed, altitude,
//! flight-path angle (relative to the air mass) and heading.
//!
//! Unknowns: α, β, elevator, aileron, rudder, throttle (flap given). Residuals:
//! the six body-axis accelerations u̇, v̇, ẇ, ṗ, q̇, ṙ. With roll angle φ = 0 the
//! flight-path angle fixes pitch: sin γ = cos β·sin(θ − α). Solved by Newton's
//! method with a central-difference Jacobian and an SVD pseudo-inverse, so that
//! unknowns with no effect (a model without lateral terms) stay at zero.
//! Controls are checked against the aircraft's limits after convergence: a
//! trim that needs more than full throttle or elevator than the stop is
//! reported as no trim, with the values it would need.

use crate::dynamics::{Exogenous, FlightModel};
use crate::error::{Error, Result};
use crate::state::{self, CHI, Control, Controls, DOWN, EulerAngles, StateVector, U};
use crate::wind::WindSample;
use nalgebra::{SMatrix, SVector, Vector3};

/// The flight condition to trim at (SI, rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrimCondition {
    pub airspeed: f64,
    pub altitude: f64,
    pub flight_path_angle: f64,
    pub heading: f64,
    pub flap: f64,
}

/// A converged trim.
#[derive(Debug, Clone, PartialEq)]
pub struct Trim {
    pub state: StateVector,
    pub controls: Controls,
    pub alpha: f64,
    pub beta: f64,
    pub pitch: f64,
    /// Largest remaining acceleration residual (m/s² or rad/s²).
    pub residual: f64,
    pub iterations: usize,
}

type Unknowns = SVector<f64, 6>;

const TOLERANCE: f64 = 1e-11;
const MAX_ITERATIONS: usize = 60;

/// Trims `model` at `condition` in the steady `wind`.
pub fn trim(model: &FlightModel, condition: &TrimCondition, wind: &WindSample) -> Result<Trim> {
    check_condition(condition)?;
    let mut unlimited = model.clone();
    unlimited.aircraft.limits = [(f64::NEG_INFINITY, f64::INFINITY); crate::state::CONTROL_COUNT];
    let solver = TrimEquations {
        model: &unlimited,
        condition,
        wind,
    };
    let mut z = Unknowns::from_column_slice(&[0.05, 0.0, 0.0, 0.0, 0.0, 0.5]);
    let mut residual = solver.residual(&z);
    let mut iterations = 0;
    while residual.amax() > TOLERANCE && iterations < MAX_ITERATIONS {
        iterations += 1;
        let step = solver.newton_step(&z, &residual);
        z = solver.damped_update(&z, &step, &residual);
        residual = solver.residual(&z);
    }
    if !residual.amax().is_finite() || residual.amax() > 1e-8 {
        return Err(Error::Trim(format!(
            "Newton iteration did not converge at V = {:.2} m/s, h = {:.0} m (largest acceleration residual {:.3e} after {iterations} iterations; α = {:.2}°)",
            condition.airspeed,
            condition.altitude,
            residual.amax(),
            z[0].to_degrees()
        )));
    }
    let (state, controls) = solver.state_and_controls(&z);
    check_limits(model, &controls)?;
    Ok(Trim {
        state,
        controls,
        alpha: z[0],
        beta: z[1],
        pitch: solver.pitch(&z),
        residual: residual.amax(),
        iterations,
    })
}

fn check_condition(condition: &TrimCondition) -> Result<()> {
    if condition.airspeed.is_nan() || condition.airspeed <= 0.0 {
        return Err(Error::Trim(format!(
            "airspeed must be positive, is {}",
            condition.airspeed
        )));
    }
    if condition.flight_path_angle.is_nan()
        || condition.flight_path_angle.abs() >= std::f64::consts::FRAC_PI_2
    {
        return Err(Error::Trim(
            "the flight-path angle must be within ±90°".into(),
        ));
    }
    Ok(())
}

fn check_limits(model: &FlightModel, controls: &Controls) -> Result<()> {
    for control in Control::ALL {
        let (low, high) = model.aircraft.limits[control.index()];
        let value = controls[control.index()];
        if value < low - 1e-12 || value > high + 1e-12 {
            let shown = |v: f64| {
                if control == Control::Throttle {
                    format!("{v:.3}")
                } else {
                    format!("{:.2}°", v.to_degrees())
                }
            };
            return Err(Error::Trim(format!(
                "needs {} = {}, outside its range [{}, {}]",
                control.name(),
                shown(value),
                shown(low),
                shown(high)
            )));
        }
    }
    Ok(())
}

struct TrimEquations<'a> {
    model: &'a FlightModel,
    condition: &'a TrimCondition,
    wind: &'a WindSample,
}

impl TrimEquations<'_> {
    fn pitch(&self, z: &Unknowns) -> f64 {
        z[0] + (self.condition.flight_path_angle.sin() / z[1].cos())
            .clamp(-1.0, 1.0)
            .asin()
    }

    fn state_and_controls(&self, z: &Unknowns) -> (StateVector, Controls) {
        let (alpha, beta) = (z[0], z[1]);
        let airspeed = self.condition.airspeed;
        let air_velocity = Vector3::new(
            alpha.cos() * beta.cos(),
            beta.sin(),
            alpha.sin() * beta.cos(),
        ) * airspeed;
        let mut x = StateVector::zeros();
        let attitude = state::quaternion_from_euler(EulerAngles {
            roll: 0.0,
            pitch: self.pitch(z),
            yaw: self.condition.heading,
        });
        state::set_attitude(&mut x, &attitude);
        let wind_body = state::body_to_ned(&x).transpose() * self.wind.ned + self.wind.body;
        x.fixed_rows_mut::<3>(U)
            .copy_from(&(air_velocity + wind_body));
        x[DOWN] = -self.condition.altitude;
        x[CHI] = self.model.aircraft.aero.steady_separation(alpha);
        let mut controls = Controls::zeros();
        controls[Control::Elevator.index()] = z[2];
        controls[Control::Aileron.index()] = z[3];
        controls[Control::Rudder.index()] = z[4];
        controls[Control::Flap.index()] = self.condition.flap;
        controls[Control::Throttle.index()] = z[5];
        (x, controls)
    }

    fn residual(&self, z: &Unknowns) -> SVector<f64, 6> {
        let (x, controls) = self.state_and_controls(z);
        let exogenous = Exogenous {
            controls,
            wind: *self.wind,
            wind_rate: WindSample::default(),
        };
        self.model
            .derivative(&x, &exogenous)
            .fixed_rows::<6>(U)
            .into()
    }

    fn newton_step(&self, z: &Unknowns, residual: &SVector<f64, 6>) -> Unknowns {
        let mut jacobian = SMatrix::<f64, 6, 6>::zeros();
        for j in 0..6 {
            let h = 1e-6 * (1.0 + z[j].abs());
            let (mut plus, mut minus) = (*z, *z);
            plus[j] += h;
            minus[j] -= h;
            jacobian.set_column(
                j,
                &((self.residual(&plus) - self.residual(&minus)) / (2.0 * h)),
            );
        }
        let svd = jacobian.svd(true, true);
        let threshold = svd.singular_values.max() * 1e-10;
        svd.solve(&(-residual), threshold)
            .unwrap_or(Unknowns::zeros())
    }

    /// Limits α and β to 0.1 rad per iteration and halves the step while the residual grows.
    fn damped_update(&self, z: &Unknowns, step: &Unknowns, residual: &SVector<f64, 6>) -> Unknowns {
        let largest_angle = step[0].abs().max(step[1].abs());
        let mut scale = if largest_angle > 0.1 {
            0.1 / largest_angle
        } else {
            1.0
        };
        for _ in 0..20 {
            let candidate = z + step * scale;
            if self.residual(&candidate).amax() < residual.amax() {
                return candidate;
            }
            scale *= 0.5;
        }
        z + step * scale
    }
}
