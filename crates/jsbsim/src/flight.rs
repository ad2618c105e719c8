//! Flying an aircraft in JSBSim on aeroid's time grid, with aeroid's controls,
//! and reading it back as aeroid's truth samples: the one flight loop behind
//! the cross-check of an exported aircraft ([`super::crosscheck`]) and the
//! flights of JSBSim's own aircraft ([`super::own`]).
//!
//! Timing (see also docs/jsbsim.md, "Convention differences"): JSBSim integrates
//! explicitly with the derivatives of the previous frame; one `Run` first
//! advances the state, then evaluates the forces at the new state with the
//! controls set at that moment. So the controls of step k+1 are written
//! before the last `Run` that produces state k+1, which reproduces aeroid's
//! zero-order hold; with linear interpolation the controls are interpolated
//! between steps k and k+1 at the end of every substep (DESIGN.md,
//! "Conventions": input interpolation is an explicit scenario option). The
//! flight uses third-order Adams–Bashforth for all four integrations, with
//! `substeps` JSBSim steps per aeroid step.
//!
//! A [`TruthSample`] read from JSBSim (DESIGN.md conventions: SI, radians,
//! body axes x forward, z down):
//! - state: `velocities/{u,v,w}-fps` (relative to the planet), `{p,q,r}`,
//!   the attitude quaternion of `attitude/{phi,theta,psi}-rad`, the position
//!   north and east of the start (`position/from-start-neu-*`), the altitude
//!   above sea level; χ = 1;
//! - air data, α̇, β̇, temperature, pressure and density are JSBSim's own; the
//!   log density ratio is taken against aeroid's sea-level density;
//! - coefficients: CL, CD (stability axes), CY and the moments about the
//!   centre of gravity from [`super::derivatives::coefficients`], CX and CZ
//!   from the body-axis aerodynamic force;
//! - specific force: JSBSim's total non-gravitational force
//!   (`forces/fb*-total-lbs`, aerodynamics, propulsion, ground and external
//!   reactions) over the mass; angular acceleration `accelerations/*dot`;
//! - the state derivative holds u̇, v̇, ẇ, ṗ, q̇, ṙ and the NED velocity (the
//!   quaternion and χ rates are left zero: nothing downstream reads them);
//! - controls: each read as the flight was set up ([`ControlReading`]);
//!   thrust: the magnitude of JSBSim's propulsion force (zero for an exported
//!   aircraft, whose thrust is an external force JSBSim has no property for).

use super::derivatives::coefficients;
use super::{Exec, FT, LBF, Property, SLUG};
use crate::error::{Error, Result};
use aeroid_sim::aero::{AeroCoefficients, AeroInput};
use aeroid_sim::atmosphere::{Air, SEA_LEVEL_DENSITY};
use aeroid_sim::dynamics::{AirData, Evaluation};
use aeroid_sim::integrator::Interpolation;
use aeroid_sim::state::{self, CONTROL_COUNT, Controls, EulerAngles, StateVector};
use aeroid_sim::trace::TruthSample;
use aeroid_sim::wind::WindSample;
use nalgebra::Vector3;

/// JSBSim's integrators for aeroid's flights: third-order Adams–Bashforth.
const INTEGRATORS: [&str; 4] = [
    "simulation/integrator/rate/rotational",
    "simulation/integrator/rate/translational",
    "simulation/integrator/position/rotational",
    "simulation/integrator/position/translational",
];
const ADAMS_BASHFORTH_3: f64 = 4.0;

/// The properties a sample reads, in the order of the `R_*` indices.
const READINGS: [&str; 40] = [
    "velocities/u-fps",
    "velocities/v-fps",
    "velocities/w-fps",
    "velocities/p-rad_sec",
    "velocities/q-rad_sec",
    "velocities/r-rad_sec",
    "attitude/phi-rad",
    "attitude/theta-rad",
    "attitude/psi-rad",
    "position/from-start-neu-n-ft",
    "position/from-start-neu-e-ft",
    "position/h-sl-ft",
    "velocities/v-north-fps",
    "velocities/v-east-fps",
    "velocities/v-down-fps",
    "velocities/vt-fps",
    "aero/alpha-rad",
    "aero/beta-rad",
    "velocities/mach",
    "aero/qbar-psf",
    "velocities/u-aero-fps",
    "velocities/v-aero-fps",
    "velocities/w-aero-fps",
    "aero/alphadot-rad_sec",
    "aero/betadot-rad_sec",
    "atmosphere/T-R",
    "atmosphere/P-psf",
    "atmosphere/rho-slugs_ft3",
    "atmosphere/a-fps",
    "forces/fbx-total-lbs",
    "forces/fby-total-lbs",
    "forces/fbz-total-lbs",
    "inertia/mass-slugs",
    "accelerations/pdot-rad_sec2",
    "accelerations/qdot-rad_sec2",
    "accelerations/rdot-rad_sec2",
    "accelerations/udot-ft_sec2",
    "accelerations/vdot-ft_sec2",
    "accelerations/wdot-ft_sec2",
    "forces/fbx-aero-lbs",
];
const R_UVW: usize = 0;
const R_PQR: usize = 3;
const R_EULER: usize = 6;
const R_NORTH: usize = 9;
const R_EAST: usize = 10;
const R_ALTITUDE: usize = 11;
const R_NED_VELOCITY: usize = 12;
const R_AIRSPEED: usize = 15;
const R_ALPHA: usize = 16;
const R_BETA: usize = 17;
const R_MACH: usize = 18;
const R_QBAR: usize = 19;
const R_AIR_VELOCITY: usize = 20;
const R_ALPHA_DOT: usize = 23;
const R_BETA_DOT: usize = 24;
const R_TEMPERATURE: usize = 25;
const R_PRESSURE: usize = 26;
const R_DENSITY: usize = 27;
const R_SOUND: usize = 28;
const R_FORCE: usize = 29;
const R_MASS: usize = 32;
const R_PQR_DOT: usize = 33;
const R_UVW_DOT: usize = 36;
const R_AERO_X: usize = 39;

/// JSBSim's propulsion force, body axes (only with engines).
const PROPULSION: [&str; 3] = [
    "forces/fbx-prop-lbs",
    "forces/fby-prop-lbs",
    "forces/fbz-prop-lbs",
];

/// Pound-force per square foot in pascals.
const PSF: f64 = LBF / (FT * FT);

/// How one of aeroid's controls is written into JSBSim: every property in
/// `commands` gets `base_command + per_unit·(value − base_value)`, where
/// `value` is aeroid's control (rad, or throttle fraction).
#[derive(Debug, Clone)]
pub struct ControlCommand {
    pub commands: Vec<Property>,
    pub base_command: f64,
    pub base_value: f64,
    pub per_unit: f64,
}

/// How a sample reads one of aeroid's controls back from JSBSim.
#[derive(Debug, Clone, Copy)]
pub enum ControlReading {
    /// `scale × property` (a surface position in aeroid's sign).
    Property { property: Property, scale: f64 },
    /// The propulsion force as a fraction of this thrust (N): a measured
    /// thrust in the units of aeroid's throttle, T = δT·Tmax.
    ThrustFraction { max_thrust: f64 },
    /// A control the flight holds (e.g. flaps of a JSBSim aircraft).
    Constant(f64),
}

/// An aircraft loaded in JSBSim, flying on aeroid's step.
pub struct JsbsimFlight {
    exec: Exec,
    /// Per aeroid control ([`aeroid_sim::state::Control::ALL`] order), if it is written.
    commands: Vec<Option<ControlCommand>>,
    readings: [ControlReading; CONTROL_COUNT],
    properties: Vec<Property>,
    /// The propulsion force's properties, when the aircraft has engines.
    propulsion: Option<[Property; 3]>,
    geometry: [f64; 3],
    step: f64,
    substeps: usize,
    interpolation: Interpolation,
    /// The controls of the current step.
    current: Controls,
}

impl JsbsimFlight {
    /// Prepares a loaded executive whose initial conditions are set: sets the
    /// integrators and the time step (`step / substeps`), writes the controls
    /// of step 0 and runs the initial conditions.
    pub fn start(
        mut exec: Exec,
        commands: Vec<Option<ControlCommand>>,
        readings: [ControlReading; CONTROL_COUNT],
        timing: (f64, usize, Interpolation),
        controls: &Controls,
    ) -> Result<Self> {
        let (step, substeps, interpolation) = timing;
        for integrator in INTEGRATORS {
            exec.set(integrator, ADAMS_BASHFORTH_3)?;
        }
        let substeps = substeps.max(1);
        exec.set_dt(step / substeps as f64)?;
        let properties = READINGS
            .iter()
            .map(|name| exec.property(name))
            .collect::<Result<_>>()?;
        let propulsion = if exec.has_property(PROPULSION[0])? {
            Some([
                exec.property(PROPULSION[0])?,
                exec.property(PROPULSION[1])?,
                exec.property(PROPULSION[2])?,
            ])
        } else {
            None
        };
        let geometry = [
            exec.get("metrics/Sw-sqft")? * FT * FT,
            exec.get("metrics/bw-ft")? * FT,
            exec.get("metrics/cbarw-ft")? * FT,
        ];
        let mut flight = JsbsimFlight {
            exec,
            commands,
            readings,
            properties,
            propulsion,
            geometry,
            step,
            substeps,
            interpolation,
            current: *controls,
        };
        flight.set_controls(controls)?;
        flight.exec.run_ic()?;
        Ok(flight)
    }

    /// JSBSim steps per aeroid step.
    pub fn substeps(&self) -> usize {
        self.substeps
    }

    /// The executive (for reading properties).
    pub fn exec(&self) -> &Exec {
        &self.exec
    }

    fn set_controls(&mut self, controls: &Controls) -> Result<()> {
        for (value, command) in controls.iter().zip(&self.commands) {
            let Some(command) = command else { continue };
            let written = command.base_command + command.per_unit * (value - command.base_value);
            for property in &command.commands {
                self.exec.set_cached(*property, written)?;
            }
        }
        Ok(())
    }

    /// Flies from step k to step k + 1 with `next` the controls of step k + 1:
    /// they enter with the last substep (zero-order hold), or the controls
    /// are interpolated at the end of every substep (linear).
    pub fn advance(&mut self, k: usize, next: &Controls) -> Result<()> {
        let step = self.step;
        let at_time = |e: Error| match e {
            Error::Jsbsim { context, message } => Error::Jsbsim {
                context: format!("t = {:.3} s: {context}", k as f64 * step),
                message,
            },
            other => other,
        };
        for j in 1..=self.substeps {
            if j == self.substeps {
                self.set_controls(next)?;
            } else if self.interpolation == Interpolation::Linear {
                let fraction = j as f64 / self.substeps as f64;
                let between = self.current + (next - self.current) * fraction;
                self.set_controls(&between)?;
            }
            self.exec.step().map_err(at_time)?;
        }
        self.current = *next;
        Ok(())
    }

    fn read(&self, index: usize) -> Result<f64> {
        self.exec.get_cached(self.properties[index])
    }

    fn read3(&self, index: usize, scale: f64) -> Result<Vector3<f64>> {
        Ok(Vector3::new(
            self.read(index)?,
            self.read(index + 1)?,
            self.read(index + 2)?,
        ) * scale)
    }

    /// The aircraft now, as aeroid's truth sample at `time`.
    pub fn sample(&self, time: f64) -> Result<TruthSample> {
        let mut x = StateVector::zeros();
        x.fixed_rows_mut::<3>(state::U)
            .copy_from(&self.read3(R_UVW, FT)?);
        x.fixed_rows_mut::<3>(state::P)
            .copy_from(&self.read3(R_PQR, 1.0)?);
        let euler = EulerAngles {
            roll: self.read(R_EULER)?,
            pitch: self.read(R_EULER + 1)?,
            yaw: self.read(R_EULER + 2)?,
        };
        state::set_attitude(&mut x, &state::quaternion_from_euler(euler));
        x[state::NORTH] = self.read(R_NORTH)? * FT;
        x[state::EAST] = self.read(R_EAST)? * FT;
        x[state::DOWN] = -self.read(R_ALTITUDE)? * FT;
        x[state::CHI] = 1.0;

        let density = self.read(R_DENSITY)? * SLUG / FT.powi(3);
        let air = Air {
            temperature: self.read(R_TEMPERATURE)? / 1.8,
            pressure: self.read(R_PRESSURE)? * PSF,
            density,
            speed_of_sound: self.read(R_SOUND)? * FT,
            log_density_ratio: (density / SEA_LEVEL_DENSITY).ln(),
            mach: None,
        };
        let alpha = self.read(R_ALPHA)?;
        let air_data = AirData {
            airspeed: self.read(R_AIRSPEED)? * FT,
            alpha,
            alpha_sin_cos: alpha.sin_cos(),
            beta: self.read(R_BETA)?,
            mach: self.read(R_MACH)?,
            dynamic_pressure: self.read(R_QBAR)? * PSF,
            velocity: self.read3(R_AIR_VELOCITY, FT)?,
        };
        let [cl, cy, cd, roll, pitch, yaw] = coefficients(&self.exec)?;
        let qs = air_data.dynamic_pressure * self.geometry[0];
        let (sin_alpha, cos_alpha) = air_data.alpha_sin_cos;
        let coefficients = AeroCoefficients {
            force: Vector3::new(
                self.read(R_AERO_X)? * LBF / qs,
                cy,
                -cd * sin_alpha - cl * cos_alpha,
            ),
            moment: Vector3::new(roll, pitch, yaw),
            lift: cl,
            drag: cd,
        };
        let mass = self.read(R_MASS)? * SLUG;
        let thrust = match &self.propulsion {
            Some(force) => {
                let mut total = 0.0;
                for property in force {
                    total += (self.exec.get_cached(*property)? * LBF).powi(2);
                }
                total.sqrt()
            }
            None => 0.0,
        };
        let mut controls = Controls::zeros();
        for (control, reading) in controls.iter_mut().zip(&self.readings) {
            *control = match *reading {
                ControlReading::Property { property, scale } => {
                    scale * self.exec.get_cached(property)?
                }
                ControlReading::ThrustFraction { max_thrust } => thrust / max_thrust,
                ControlReading::Constant(value) => value,
            };
        }
        let mut derivative = StateVector::zeros();
        derivative
            .fixed_rows_mut::<3>(state::U)
            .copy_from(&self.read3(R_UVW_DOT, FT)?);
        let angular_acceleration = self.read3(R_PQR_DOT, 1.0)?;
        derivative
            .fixed_rows_mut::<3>(state::P)
            .copy_from(&angular_acceleration);
        derivative
            .fixed_rows_mut::<3>(state::NORTH)
            .copy_from(&self.read3(R_NED_VELOCITY, FT)?);
        let alpha_dot = self.read(R_ALPHA_DOT)?;
        let evaluation = Evaluation {
            derivative,
            air,
            air_data,
            alpha_dot,
            beta_dot: self.read(R_BETA_DOT)?,
            chi: 1.0,
            coefficients,
            aero_input: AeroInput {
                alpha: air_data.alpha,
                beta: air_data.beta,
                airspeed: air_data.airspeed,
                mach: air_data.mach,
                rates: state::rates(&x),
                alpha_dot,
                measured_alpha_dot: None,
                controls,
                chi: 1.0,
            },
            controls,
            thrust,
            specific_force: self.read3(R_FORCE, LBF)? / mass,
            angular_acceleration,
        };
        Ok(TruthSample::new(time, x, evaluation, WindSample::default()))
    }
}
