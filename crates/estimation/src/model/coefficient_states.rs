//! The six-degree-of-freedom kinematics with the six aerodynamic
//! coefficients as third-order Gauss–Markov states: the state-space model
//! of "estimation before modelling" (Wang et al. 2012, "Aerodynamic
//! modeling and parameter estimation from QAR data of an airplane
//! approaching a high-altitude airport", Chinese J. Aeronautics 25,
//! Eqs. 7–9).
//!
//! State (28): u, v, w (body-axis velocity, m/s), p, q, r (rad/s),
//! φ, θ, ψ (rad), h (m), then for each of CX, CY, CZ, Cl, Cm, Cn the
//! coefficient, its first and its second time derivative. Equations (Eq. 7;
//! the transcript's Eq. 7 is damaged, so the textbook form is written here,
//! the simulator's equations of motion over a flat earth in still air,
//! `crates/sim/src/dynamics.rs`, with Euler angles for the quaternion):
//!
//! ```text
//! u̇ = r·v − q·w − g·sin θ           + (q̄S·CX + T_x)/m
//! v̇ = p·w − r·u + g·cos θ·sin φ     + (q̄S·CY + T_y)/m
//! ẇ = q·u − p·v + g·cos θ·cos φ     + (q̄S·CZ + T_z)/m
//! ω̇ = I⁻¹·(q̄S·(b·Cl, c̄·Cm, b·Cn) + r_T × T − ω × I·ω)
//! φ̇ = p + tan θ·(q·sin φ + r·cos φ),  θ̇ = q·cos φ − r·sin φ,
//! ψ̇ = (q·sin φ + r·cos φ)/cos θ
//! ḣ = u·sin θ − v·sin φ·cos θ − w·cos φ·cos θ
//! Ċ = C′,  Ċ′ = C″,  Ċ″ = w_C  (white; each of the six coefficients)
//! ```
//!
//! q̄ = ½·ρ(h)·(u² + v² + w²) (ISA), thrust T = δT·Tmax·(ρ/ρ0)ⁿ along the
//! thrust line from the recorded throttle (the simulator's engine model,
//! [`aeroid_sim::aircraft::Propulsion::thrust`]), or the record's measured
//! thrust ([`CoefficientStates::with_measured_thrust`]). The paper writes the
//! inertia terms with its A_ij constants, which are the components of
//! I⁻¹·(−ω × I·ω) for I with Ixz; the vector form above is the same. The
//! transcript's Eq. 7 treats the thrust as along body x only (X + P); here
//! it is the full thrust vector and its moment.
//!
//! Outputs (Eq. 8, textbook form: the transcript is damaged): the load
//! factors n_x = (q̄S·CX + T_x)/(m·g0), n_y = (q̄S·CY + T_y)/(m·g0),
//! n_z = −(q̄S·CZ + T_z)/(m·g0) (nz positive up, as the recorder writes
//! it), φ, θ, ψ, V = √(u² + v² + w²), h; and, when asked, α = atan2(w, u),
//! β = asin(v/V), p, q, r. No angular rate is needed.
//!
//! The Jacobians are analytic (written out in [`CoefficientStates::jacobians_into`];
//! checked against central differences in the tests); one step is the
//! project's RK4 ([`aeroid_sim::integrator::rk4_step`]) with the throttle
//! linear between grid points.

use super::state_space::{Jacobians, StateSpaceModel};
use crate::error::{Error, Result};
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::kalman::resize_vector;
use aeroid_sim::aircraft::Aircraft;
use aeroid_sim::atmosphere::{Air, Atmosphere, GAS_CONSTANT};
use nalgebra::{DMatrix, DVector, Matrix3, SVector, Vector3};

/// The number of states.
pub(crate) const STATE_COUNT: usize = 28;
/// The state vector.
pub type State = SVector<f64, STATE_COUNT>;

pub const U: usize = 0;
pub const P: usize = 3;
pub const PHI: usize = 6;
pub const THETA: usize = 7;
pub const PSI: usize = 8;
pub const H: usize = 9;
/// The first coefficient state (CX); coefficient i's value, first and
/// second derivative at `COEFFICIENTS + 3·i + 0, 1, 2`.
pub const COEFFICIENTS: usize = 10;

/// The coefficient states' names, in order (body-axis forces, then moments).
pub const COEFFICIENT_NAMES: [&str; 6] = ["CX", "CY", "CZ", "Cl", "Cm", "Cn"];

/// The state names, in order.
pub fn state_names() -> Vec<String> {
    let mut names: Vec<String> = [
        "u", "v", "w", "p", "q", "r", "roll", "pitch", "yaw", "altitude",
    ]
    .map(String::from)
    .to_vec();
    for name in COEFFICIENT_NAMES {
        names.extend([
            name.to_string(),
            format!("{name}_dot"),
            format!("{name}_ddot"),
        ]);
    }
    names
}

/// The index of coefficient `i`'s value (0 CX … 5 Cn).
pub fn coefficient(i: usize) -> usize {
    COEFFICIENTS + 3 * i
}

/// An output the model can compare with a record channel (named as the channel).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    Nx,
    Ny,
    Nz,
    Roll,
    Pitch,
    Yaw,
    Airspeed,
    Altitude,
    Alpha,
    Beta,
    P,
    Q,
    R,
}

impl Output {
    pub const ALL: [Output; 13] = [
        Output::Nx,
        Output::Ny,
        Output::Nz,
        Output::Roll,
        Output::Pitch,
        Output::Yaw,
        Output::Airspeed,
        Output::Altitude,
        Output::Alpha,
        Output::Beta,
        Output::P,
        Output::Q,
        Output::R,
    ];

    /// The record channel it is compared with.
    pub fn channel(self) -> &'static str {
        match self {
            Output::Nx => "nx",
            Output::Ny => "ny",
            Output::Nz => "nz",
            Output::Roll => "roll",
            Output::Pitch => "pitch",
            Output::Yaw => "yaw",
            Output::Airspeed => "airspeed",
            Output::Altitude => "altitude",
            Output::Alpha => "alpha",
            Output::Beta => "beta",
            Output::P => "p",
            Output::Q => "q",
            Output::R => "r",
        }
    }

    pub fn parse(name: &str) -> Option<Output> {
        Output::ALL.into_iter().find(|o| o.channel() == name)
    }
}

/// d ln ρ/dh of the standard atmosphere at `air` (1/m): −g/(R·T) + L/T
/// below the tropopause (T = T0 − L·h), −g/(R·T) above it.
fn log_density_slope(altitude: f64, air: &Air) -> f64 {
    const LAPSE_RATE: f64 = 0.0065;
    const TROPOPAUSE: f64 = 11_000.0;
    let hydrostatic = -STANDARD_GRAVITY / (GAS_CONSTANT * air.temperature);
    if altitude <= TROPOPAUSE {
        hydrostatic + LAPSE_RATE / air.temperature
    } else {
        hydrostatic
    }
}

/// The cross-product matrix [a]×: [a]×·b = a × b.
fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// What the forces need at one state.
struct Loads {
    air: Air,
    /// q̄·S (N per unit coefficient).
    scale: f64,
    /// Thrust force, body axes (N).
    thrust: Vector3<f64>,
    /// d ln ρ/dh.
    log_density_slope: f64,
}

/// The state-space model of module header on a grid t_k = start + k·step.
#[derive(Debug, Clone)]
pub struct CoefficientStates {
    aircraft: Aircraft,
    atmosphere: Atmosphere,
    start: f64,
    step: f64,
    /// Throttle at each grid point (0 without propulsion), or the thrust
    /// (N) when `thrust_measured`.
    throttle: Vec<f64>,
    /// `throttle` holds the measured thrust magnitude along the thrust line.
    thrust_measured: bool,
    outputs: Vec<Output>,
}

impl CoefficientStates {
    /// The model of `aircraft` on the grid of `throttle.len()` points from
    /// `start` by `step`, comparing `outputs`.
    pub fn new(
        aircraft: Aircraft,
        start: f64,
        step: f64,
        throttle: Vec<f64>,
        outputs: Vec<Output>,
    ) -> Result<CoefficientStates> {
        if throttle.len() < 2 || !(step > 0.0 && step.is_finite()) {
            return Err(Error::Grid { reason: "the coefficient-state model needs a grid of at least two points and a positive step".into(), });
        }
        if throttle.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical {
                reason: "the throttle is not finite at every grid point".into(),
            });
        }
        Ok(CoefficientStates {
            aircraft,
            atmosphere: Atmosphere::default(),
            start,
            step,
            throttle,
            thrust_measured: false,
            outputs,
        })
    }

    /// The same model with the grid's values read as the measured thrust
    /// (N, along the thrust line) instead of the throttle: no engine model,
    /// no thrust lapse with altitude.
    pub fn with_measured_thrust(mut self) -> CoefficientStates {
        self.thrust_measured = true;
        self
    }

    pub fn observed(&self) -> &[Output] {
        &self.outputs
    }

    pub fn aircraft(&self) -> &Aircraft {
        &self.aircraft
    }

    /// The throttle at t (linear between grid points, held outside).
    fn throttle_at(&self, t: f64) -> f64 {
        let last = self.throttle.len() - 1;
        let position = ((t - self.start) / self.step).clamp(0.0, last as f64);
        let k = (position.floor() as usize).min(last - 1);
        let fraction = position - k as f64;
        self.throttle[k] + (self.throttle[k + 1] - self.throttle[k]) * fraction
    }

    fn loads(&self, x: &[f64], throttle: f64) -> Loads {
        let altitude = x[H];
        let air = self.atmosphere.at(altitude);
        let speed_squared = x[U] * x[U] + x[U + 1] * x[U + 1] + x[U + 2] * x[U + 2];
        let propulsion = &self.aircraft.propulsion;
        let thrust_magnitude = if self.thrust_measured {
            throttle
        } else if propulsion.max_thrust == 0.0 {
            0.0
        } else {
            propulsion.thrust(throttle, air.log_density_ratio)
        };
        Loads {
            scale: 0.5 * air.density * speed_squared * self.aircraft.wing_area,
            thrust: propulsion.direction * thrust_magnitude,
            log_density_slope: log_density_slope(altitude, &air),
            air,
        }
    }

    /// (CX, CY, CZ) and (Cl, Cm, Cn) of a state.
    fn coefficients(x: &[f64]) -> (Vector3<f64>, Vector3<f64>) {
        let c = |i: usize| x[coefficient(i)];
        (
            Vector3::new(c(0), c(1), c(2)),
            Vector3::new(c(3), c(4), c(5)),
        )
    }

    /// The moment arms of the moment coefficients: (b, c̄, b).
    fn arms(&self) -> Vector3<f64> {
        let g = &self.aircraft.geometry;
        Vector3::new(g.span, g.chord, g.span)
    }

    /// ẋ at a state with the throttle `throttle`.
    fn derivative(&self, x: &[f64], throttle: f64) -> State {
        let loads = self.loads(x, throttle);
        let mass = &self.aircraft.mass;
        let (force, moment) = Self::coefficients(x);
        let velocity = Vector3::new(x[U], x[U + 1], x[U + 2]);
        let omega = Vector3::new(x[P], x[P + 1], x[P + 2]);
        let (sin_phi, cos_phi) = x[PHI].sin_cos();
        let (sin_theta, cos_theta) = x[THETA].sin_cos();
        let gravity =
            Vector3::new(-sin_theta, sin_phi * cos_theta, cos_phi * cos_theta) * STANDARD_GRAVITY;
        let specific = (force * loads.scale + loads.thrust) / mass.mass;
        let velocity_rate = specific + gravity - omega.cross(&velocity);
        let aero_moment = moment.component_mul(&self.arms()) * loads.scale;
        let thrust_moment = self.aircraft.propulsion.position.cross(&loads.thrust);
        let angular = mass.inertia_inverse
            * (aero_moment + thrust_moment - omega.cross(&(mass.inertia * omega)));
        let euler =
            aeroid_sim::state::euler_rates_of((sin_phi, cos_phi), (sin_theta, cos_theta), &omega);
        let mut rates = State::zeros();
        rates.fixed_rows_mut::<3>(U).copy_from(&velocity_rate);
        rates.fixed_rows_mut::<3>(P).copy_from(&angular);
        rates.fixed_rows_mut::<3>(PHI).copy_from(&euler);
        rates[H] = velocity.x * sin_theta
            - velocity.y * sin_phi * cos_theta
            - velocity.z * cos_phi * cos_theta;
        for i in 0..6 {
            let c = coefficient(i);
            rates[c] = x[c + 1];
            rates[c + 1] = x[c + 2];
        }
        rates
    }

    fn check(&self, x: &[f64]) -> Result<()> {
        if x.len() == STATE_COUNT {
            Ok(())
        } else {
            Err(Error::Shape {
                reason: format!(
                    "x has {} values; the coefficient-state model has {STATE_COUNT}",
                    x.len()
                ),
            })
        }
    }

    /// The load factors (nx, ny, nz) of a state.
    fn load_factors(&self, x: &[f64], loads: &Loads) -> Vector3<f64> {
        let (force, _) = Self::coefficients(x);
        let specific =
            (force * loads.scale + loads.thrust) / (self.aircraft.mass.mass * STANDARD_GRAVITY);
        Vector3::new(specific.x, specific.y, -specific.z)
    }

    /// y = h(x) of the observed outputs into `into` (one value per output).
    fn write_outputs(&self, x: &[f64], loads: &Loads, into: &mut [f64]) {
        let n = self.load_factors(x, loads);
        let (u, v, w) = (x[U], x[U + 1], x[U + 2]);
        let speed = (u * u + v * v + w * w).sqrt();
        for (into, output) in into.iter_mut().zip(&self.outputs) {
            *into = match output {
                Output::Nx => n.x,
                Output::Ny => n.y,
                Output::Nz => n.z,
                Output::Roll => x[PHI],
                Output::Pitch => x[THETA],
                Output::Yaw => x[PSI],
                Output::Airspeed => speed,
                Output::Altitude => x[H],
                Output::Alpha => w.atan2(u),
                Output::Beta => (v / speed).clamp(-1.0, 1.0).asin(),
                Output::P => x[P],
                Output::Q => x[P + 1],
                Output::R => x[P + 2],
            };
        }
    }

    /// ∂f/∂x at `x` into `a` and ∂h/∂x into `outputs`
    /// ([`StateSpaceModel::jacobians_into`]'s equations), every entry
    /// written.
    // Called at every grid point of a filter pass: the state and output Jacobians share the loads' derivatives (force, thrust_by_h, the speeds); split, each part would recompute or carry them.
    fn linearise(
        &self,
        x: &[f64],
        loads: &Loads,
        a: &mut DMatrix<f64>,
        outputs: &mut DMatrix<f64>,
    ) {
        let mass = &self.aircraft.mass;
        let (force, moment) = Self::coefficients(x);
        let velocity = Vector3::new(x[U], x[U + 1], x[U + 2]);
        let omega = Vector3::new(x[P], x[P + 1], x[P + 2]);
        let (sin_phi, cos_phi) = x[PHI].sin_cos();
        let (sin_theta, cos_theta) = x[THETA].sin_cos();
        let density = loads.air.density;
        let area = self.aircraft.wing_area;
        let slope = loads.log_density_slope;
        let lapse = if self.thrust_measured {
            0.0
        } else {
            self.aircraft.propulsion.density_exponent
        };
        let arms = self.arms();
        zeroed(a, STATE_COUNT, STATE_COUNT);
        // Translational: F/m, gravity, −ω × V.
        let thrust_by_h = loads.thrust * (lapse * slope);
        for j in 0..3 {
            let by_speed = force * (density * area * velocity[j]) / mass.mass;
            for i in 0..3 {
                a[(U + i, U + j)] += by_speed[i];
            }
            a[(U + j, coefficient(j))] = loads.scale / mass.mass;
        }
        let by_h = (force * (loads.scale * slope) + thrust_by_h) / mass.mass;
        for i in 0..3 {
            a[(U + i, H)] += by_h[i];
        }
        // −ω × V = V × ω: ∂/∂V = −[ω]×, ∂/∂ω = [V]×.
        let minus_omega = -skew(&omega);
        let velocity_skew = skew(&velocity);
        for i in 0..3 {
            for j in 0..3 {
                a[(U + i, U + j)] += minus_omega[(i, j)];
                a[(U + i, P + j)] += velocity_skew[(i, j)];
            }
        }
        let g = STANDARD_GRAVITY;
        a[(U + 1, PHI)] += g * cos_phi * cos_theta;
        a[(U + 2, PHI)] += -g * sin_phi * cos_theta;
        a[(U, THETA)] += -g * cos_theta;
        a[(U + 1, THETA)] += -g * sin_phi * sin_theta;
        a[(U + 2, THETA)] += -g * cos_phi * sin_theta;
        // Rotational: I⁻¹·(M − ω × I·ω).
        let inverse = &mass.inertia_inverse;
        let arm_moment = moment.component_mul(&arms);
        for j in 0..3 {
            let by_speed = inverse * arm_moment * (density * area * velocity[j]);
            for i in 0..3 {
                a[(P + i, U + j)] = by_speed[i];
            }
        }
        let thrust_moment_by_h = self.aircraft.propulsion.position.cross(&thrust_by_h);
        let moment_by_h = inverse * (arm_moment * (loads.scale * slope) + thrust_moment_by_h);
        let gyroscopic = inverse * (skew(&omega) * mass.inertia - skew(&(mass.inertia * omega)));
        for i in 0..3 {
            a[(P + i, H)] = moment_by_h[i];
            for j in 0..3 {
                a[(P + i, P + j)] = -gyroscopic[(i, j)];
                a[(P + i, coefficient(3 + j))] = inverse[(i, j)] * arms[j] * loads.scale;
            }
        }
        // Euler kinematics.
        let (q, r) = (omega.y, omega.z);
        let tan_theta = sin_theta / cos_theta;
        let turn = q * sin_phi + r * cos_phi;
        let turn_by_phi = q * cos_phi - r * sin_phi;
        a[(PHI, P)] = 1.0;
        a[(PHI, P + 1)] = tan_theta * sin_phi;
        a[(PHI, P + 2)] = tan_theta * cos_phi;
        a[(PHI, PHI)] = tan_theta * turn_by_phi;
        a[(PHI, THETA)] = turn / (cos_theta * cos_theta);
        a[(THETA, P + 1)] = cos_phi;
        a[(THETA, P + 2)] = -sin_phi;
        a[(THETA, PHI)] = -turn;
        a[(PSI, P + 1)] = sin_phi / cos_theta;
        a[(PSI, P + 2)] = cos_phi / cos_theta;
        a[(PSI, PHI)] = turn_by_phi / cos_theta;
        a[(PSI, THETA)] = turn * sin_theta / (cos_theta * cos_theta);
        // Height rate.
        let (u, v, w) = (velocity.x, velocity.y, velocity.z);
        a[(H, U)] = sin_theta;
        a[(H, U + 1)] = -sin_phi * cos_theta;
        a[(H, U + 2)] = -cos_phi * cos_theta;
        a[(H, PHI)] = -v * cos_phi * cos_theta + w * sin_phi * cos_theta;
        a[(H, THETA)] = u * cos_theta + v * sin_phi * sin_theta + w * cos_phi * sin_theta;
        // Gauss–Markov chains.
        for i in 0..6 {
            let c = coefficient(i);
            a[(c, c + 1)] = 1.0;
            a[(c + 1, c + 2)] = 1.0;
        }
        // Outputs.
        zeroed(outputs, self.outputs.len(), STATE_COUNT);
        let weight = mass.mass * g;
        let speed_squared = u * u + v * v + w * w;
        let speed = speed_squared.sqrt();
        for (row, output) in self.outputs.iter().enumerate() {
            let mut set = |column: usize, value: f64| outputs[(row, column)] = value;
            let load_factor = |i: usize, sign: f64, set: &mut dyn FnMut(usize, f64)| {
                for j in 0..3 {
                    set(
                        U + j,
                        sign * force[i] * density * area * velocity[j] / weight,
                    );
                }
                set(
                    H,
                    sign * (force[i] * loads.scale * slope + thrust_by_h[i]) / weight,
                );
                set(coefficient(i), sign * loads.scale / weight);
            };
            match output {
                Output::Nx => load_factor(0, 1.0, &mut set),
                Output::Ny => load_factor(1, 1.0, &mut set),
                Output::Nz => load_factor(2, -1.0, &mut set),
                Output::Roll => set(PHI, 1.0),
                Output::Pitch => set(THETA, 1.0),
                Output::Yaw => set(PSI, 1.0),
                Output::Airspeed => {
                    for j in 0..3 {
                        set(U + j, velocity[j] / speed);
                    }
                }
                Output::Altitude => set(H, 1.0),
                Output::Alpha => {
                    let plane = u * u + w * w;
                    set(U, -w / plane);
                    set(U + 2, u / plane);
                }
                Output::Beta => {
                    let plane = (u * u + w * w).sqrt();
                    set(U, -u * v / (speed_squared * plane));
                    set(U + 1, plane / speed_squared);
                    set(U + 2, -v * w / (speed_squared * plane));
                }
                Output::P => set(P, 1.0),
                Output::Q => set(P + 1, 1.0),
                Output::R => set(P + 2, 1.0),
            }
        }
    }
}

/// `matrix` as a `rows` × `columns` matrix of zeros, its storage kept when
/// the shape is already that.
fn zeroed(matrix: &mut DMatrix<f64>, rows: usize, columns: usize) {
    if matrix.shape() == (rows, columns) {
        // The slice's fill is a memset; the matrix's goes element by element.
        matrix.as_mut_slice().fill(0.0);
    } else {
        *matrix = DMatrix::zeros(rows, columns);
    }
}

impl StateSpaceModel for CoefficientStates {
    fn state_count(&self) -> usize {
        STATE_COUNT
    }

    fn output_count(&self) -> usize {
        self.outputs.len()
    }

    fn parameter_count(&self) -> usize {
        0
    }

    fn len(&self) -> usize {
        self.throttle.len()
    }

    fn time(&self, k: usize) -> f64 {
        self.start + k as f64 * self.step
    }

    fn rates(&self, t: f64, x: &[f64], _theta: &[f64]) -> Result<DVector<f64>> {
        self.check(x)?;
        Ok(DVector::from_column_slice(
            self.derivative(x, self.throttle_at(t)).as_slice(),
        ))
    }

    /// ∂f/∂x and ∂h/∂x, analytic: the force and moment terms through
    /// q̄S = ½ρ(h)·S·(u² + v² + w²) (∂q̄S/∂u = ρ·S·u, ∂q̄S/∂h = q̄S·d ln ρ/dh)
    /// and the thrust lapse (∂T/∂h = n·T·d ln ρ/dh); the gyroscopic term
    /// ∂(ω × I·ω)/∂ω = \[ω\]×·I − \[I·ω\]×; gravity, Euler kinematics and
    /// ḣ differentiated term by term; the Gauss–Markov chains' ones.
    /// Into `into`'s buffers (grown on the first call, then written in
    /// place: no allocation), with `outputs` h(x) into it from the same
    /// loads: the same numbers bit for bit.
    fn jacobians_into(
        &self,
        t: f64,
        x: &[f64],
        _theta: &[f64],
        into: &mut Jacobians,
        outputs: Option<&mut DVector<f64>>,
    ) -> Result<()> {
        self.check(x)?;
        let loads = self.loads(x, self.throttle_at(t));
        if let Some(outputs) = outputs {
            resize_vector(outputs, self.outputs.len());
            self.write_outputs(x, &loads, outputs.as_mut_slice());
        }
        self.linearise(
            x,
            &loads,
            &mut into.rates_by_state,
            &mut into.outputs_by_state,
        );
        zeroed(&mut into.rates_by_parameter, STATE_COUNT, 0);
        zeroed(&mut into.outputs_by_parameter, self.outputs.len(), 0);
        Ok(())
    }

    fn outputs_into(
        &self,
        t: f64,
        x: &[f64],
        _theta: &[f64],
        into: &mut DVector<f64>,
    ) -> Result<()> {
        self.check(x)?;
        let loads = self.loads(x, self.throttle_at(t));
        resize_vector(into, self.outputs.len());
        self.write_outputs(x, &loads, into.as_mut_slice());
        Ok(())
    }

    /// One RK4 step from grid point k, the throttle linear inside it, into
    /// `into` (the step itself on the stack; `into` grown on the first call
    /// only).
    fn step_into(
        &self,
        k: usize,
        x: &[f64],
        _theta: &[f64],
        into: &mut DVector<f64>,
    ) -> Result<()> {
        self.check(x)?;
        if k + 1 >= self.len() {
            return Err(Error::Grid {
                reason: format!(
                    "no integration step from grid point {k}: the grid has {} points",
                    self.len()
                ),
            });
        }
        let (start, end) = (self.throttle[k], self.throttle[k + 1]);
        let state = State::from_column_slice(x);
        let next = aeroid_sim::integrator::rk4_step(&state, self.step, |x, theta| {
            self.derivative(x.as_slice(), start + (end - start) * theta)
        });
        if !next.iter().all(|v| v.is_finite()) || next[U] <= 0.0 {
            return Err(Error::Numerical {
                reason: format!(
                    "the coefficient-state model departed after t = {} s (a state not finite, or u ≤ 0)",
                    self.time(k)
                ),
            });
        }
        resize_vector(into, STATE_COUNT);
        into.copy_from(&next);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> CoefficientStates {
        let scenario = aeroid_sim::scenario::Scenario::load("attas-trim").unwrap();
        CoefficientStates::new(
            scenario.aircraft.clone(),
            0.0,
            0.04,
            vec![0.4, 0.45, 0.5],
            Output::ALL.to_vec(),
        )
        .unwrap()
    }

    /// A state away from trim: every term of f and h non-zero.
    fn state() -> Vec<f64> {
        let mut x = vec![0.0; STATE_COUNT];
        x[..10].copy_from_slice(&[101.0, 3.0, 7.0, 0.1, -0.05, 0.08, 0.2, 0.07, 0.3, 4800.0]);
        let values = [-0.03, 0.02, -0.6, 0.004, -0.01, 0.003];
        for (i, value) in values.iter().enumerate() {
            x[coefficient(i)] = *value;
            x[coefficient(i) + 1] = 0.1 * value;
            x[coefficient(i) + 2] = -0.2 * value;
        }
        x
    }

    /// The analytic ∂f/∂x and ∂h/∂x agree with central differences of f
    /// and h (step 10⁻⁶·max(|x|, 1); truncation ~step²·f‴ ≲ 10⁻¹⁰,
    /// rounding ~ε·|f|/step ≲ 10⁻⁹ of each column's scale) to 10⁻⁶ of the
    /// column's largest entry, between grid points (throttle interpolated).
    #[test]
    fn jacobians_match_central_differences() {
        let model = model();
        let x = state();
        let t = 0.05;
        let jacobians = model.jacobians(t, &x, &[]).unwrap();
        for (name, exact, function) in [
            (
                "∂f/∂x",
                &jacobians.rates_by_state,
                &(|x: &[f64]| model.rates(t, x, &[]).unwrap()) as &dyn Fn(&[f64]) -> DVector<f64>,
            ),
            ("∂h/∂x", &jacobians.outputs_by_state, &|x: &[f64]| {
                model.outputs(t, x, &[]).unwrap()
            }),
        ] {
            for j in 0..STATE_COUNT {
                let h = 1e-6 * x[j].abs().max(1.0);
                let (mut up, mut down) = (x.clone(), x.clone());
                up[j] += h;
                down[j] -= h;
                let numeric = (function(&up) - function(&down)) / (2.0 * h);
                let scale = numeric.amax().max(exact.column(j).amax()).max(1e-12);
                let error = (exact.column(j) - &numeric).amax();
                assert!(
                    error <= 1e-6 * scale,
                    "{name} column {} ({}): error {error:.3e} of {scale:.3e}\n{}\nvs\n{}",
                    j,
                    state_names()[j],
                    exact.column(j),
                    numeric
                );
            }
        }
    }

    /// The model's accelerations are the simulator's: at a trimmed ATTAS
    /// state with rates, deflected controls and the coefficients the
    /// simulator's aero model gives there as states, u̇ v̇ ẇ, ṗ q̇ ṙ, the
    /// Euler rates, ḣ and the load factors agree with `dynamics.rs` to 1e-10.
    #[test]
    fn rates_and_outputs_are_the_simulators() {
        use aeroid_sim::dynamics::Exogenous;
        use aeroid_sim::state::{self as sim_state, Control};
        let scenario = aeroid_sim::scenario::Scenario::load("attas-trim").unwrap();
        let simulation = aeroid_sim::Simulation::prepare(&scenario).unwrap();
        let mut s = simulation.trim.state;
        (s[sim_state::P], s[sim_state::Q], s[sim_state::R]) = (0.1, -0.05, 0.08);
        let attitude = sim_state::quaternion_from_euler(sim_state::EulerAngles {
            roll: 0.3,
            pitch: 0.1,
            yaw: -0.4,
        });
        sim_state::set_attitude(&mut s, &attitude);
        let mut controls = simulation.trim.controls;
        controls[Control::Elevator.index()] += 0.02;
        controls[Control::Aileron.index()] -= 0.03;
        let throttle = controls[Control::Throttle.index()];
        let exogenous = Exogenous {
            controls,
            ..Default::default()
        };
        let evaluation = simulation.model.evaluate(&s, &exogenous);
        let euler = sim_state::euler(&s);
        let mut x = vec![0.0; STATE_COUNT];
        x[..10].copy_from_slice(&[
            s[0],
            s[1],
            s[2],
            s[3],
            s[4],
            s[5],
            euler.roll,
            euler.pitch,
            euler.yaw,
            sim_state::altitude(&s),
        ]);
        let c = &evaluation.coefficients;
        for (i, value) in [
            c.force.x, c.force.y, c.force.z, c.moment.x, c.moment.y, c.moment.z,
        ]
        .iter()
        .enumerate()
        {
            x[coefficient(i)] = *value;
        }
        let model = CoefficientStates::new(
            scenario.aircraft.clone(),
            0.0,
            0.01,
            vec![throttle; 3],
            Output::ALL.to_vec(),
        )
        .unwrap();
        let rates = model.rates(0.0, &x, &[]).unwrap();
        let d = &evaluation.derivative;
        let euler_rates =
            sim_state::euler_rates(euler.roll, euler.pitch, &Vector3::new(s[3], s[4], s[5]));
        let expected = [
            d[0],
            d[1],
            d[2],
            d[3],
            d[4],
            d[5],
            euler_rates.x,
            euler_rates.y,
            euler_rates.z,
            -d[sim_state::DOWN],
        ];
        for (i, e) in expected.iter().enumerate() {
            assert!(
                (rates[i] - e).abs() < 1e-10 * e.abs().max(1.0),
                "{}: {} vs {e}",
                state_names()[i],
                rates[i]
            );
        }
        let y = model.outputs(0.0, &x, &[]).unwrap();
        let f = evaluation.specific_force / STANDARD_GRAVITY;
        let air = &evaluation.air_data;
        let expected = [
            f.x,
            f.y,
            -f.z,
            euler.roll,
            euler.pitch,
            euler.yaw,
            air.airspeed,
            sim_state::altitude(&s),
            air.alpha,
            air.beta,
            s[3],
            s[4],
            s[5],
        ];
        for (i, e) in expected.iter().enumerate() {
            assert!(
                (y[i] - e).abs() < 1e-10 * e.abs().max(1.0),
                "{:?}: {} vs {e}",
                Output::ALL[i],
                y[i]
            );
        }
    }
}
