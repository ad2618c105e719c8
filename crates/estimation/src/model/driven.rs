//! Simulation of a postulated model driven by a flight record, in
//! flight-path coordinates x = [V, α, β, p, q, r, φ, θ, ψ, h, χ] (named as
//! record channels). A chosen subset of x is integrated; the others are
//! measured pseudo-controls read from the record at every stage — the
//! decoupled longitudinal and lateral-directional models of the reflex-wing UAV paper
//! (Eqs. 1–8) are the subsets {V, α, q, θ} and {β, p, r, φ}; the full
//! 6-DOF integrates them all. The equations are the simulator's own
//! ([`FlightModel::evaluate_kinematics`], no wind: estimation models the
//! air-relative motion, so air data are V, α, β themselves and the attitude
//! is the Euler angles' rotation), converted to flight-path rates:
//! `V̇ = V·V̇_b/V`, α̇ and β̇ from the state derivative,
//! `φ̇ = p + tan θ·(q sin φ + r cos φ)`, `θ̇ = q cos φ − r sin φ`,
//! `ψ̇ = (q sin φ + r cos φ)/cos θ`, `ḣ = −ḋ`.
//! The air is the ISA's at the altitude, with the density the record's
//! `density` channel when it has one; the thrust is the record's `thrust`
//! channel (N, along the thrust line) when it has one, else the throttle
//! and engine model ([`Ambient`]).
//! Controls and pseudo-controls are sampled on the integration grid and
//! taken inside a step through the one RK4 integrator: each control held
//! or linear as the `interpolation` setting chooses for it
//! ([`super::input_timing`]: by default from its samples), the measured
//! pseudo-controls linear. Each step is a function of its start state
//! alone (`DrivenSimulation::step_from`, the caches restarted at every
//! grid point), the step of the state-space view
//! ([`super::state_space::DrivenStateSpace`]) that filters propagate with.

use super::input_timing::{self, Chosen, InputInterpolation};
use super::state_space::Jacobians;
use crate::reconstruction::control_steps;
use crate::structure::FLIGHT_PATH_STATES;
use aeroid_core::error::{Error, Result};
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::dual::{Dual, LANES, Real};
use aeroid_record::FlightRecord;
use aeroid_record::prep::differentiation::Differentiator;
use aeroid_sim::aero::{AeroCoefficients, Coefficient, TermRegressors};
use aeroid_sim::atmosphere::{Air, Atmosphere, SEA_LEVEL_DENSITY};
use aeroid_sim::dynamics::{Accelerations, AirData, Evaluation, FlightModel, Forcing, Kinematics};
use aeroid_sim::integrator::{Interpolation, affine, rk4_linear_step, rk4_step};
use aeroid_sim::state::{self, CONTROL_COUNT, Control, Controls, SinCos};
use nalgebra::{DMatrix, DVector, SVector, Vector3};
use std::sync::OnceLock;

pub const FLIGHT_PATH_SIZE: usize = 11;
pub type FlightPathState = SVector<f64, FLIGHT_PATH_SIZE>;

pub(super) const AIRSPEED: usize = 0;
const ALPHA: usize = 1;
pub(super) const BETA: usize = 2;
const P: usize = 3;
const ROLL: usize = 6;
const PITCH: usize = 7;
const ALTITUDE: usize = 9;
const CHI: usize = 10;

/// The largest move of an angle (rad) whose sine and cosine
/// [`Angles::moved_from`] takes by [`rotated`]: a simulation's integrated
/// angles move by a few hundredths of a radian within a step.
const NUDGE_LIMIT: f64 = 1.0 / 32.0;

/// The sine and cosine of an angle moved by h (|h| ≤ [`NUDGE_LIMIT`]) from
/// one whose sine and cosine are `(sin, cos)`: by the addition theorems,
/// with sin h and cos h from their Taylor series to h⁷ and h⁸ (the first
/// terms left out, h⁹/9! and h¹⁰/10!, are below 10⁻¹⁹ there), within an
/// ulp or two of the library's sine and cosine.
fn rotated((sin, cos): SinCos, h: f64) -> SinCos {
    let h2 = h * h;
    let sin_h = h * (1.0 + h2 * (-1.0 / 6.0 + h2 * (1.0 / 120.0 + h2 * (-1.0 / 5040.0))));
    let cos_h = 1.0 + h2 * (-0.5 + h2 * (1.0 / 24.0 + h2 * (-1.0 / 720.0 + h2 * (1.0 / 40320.0))));
    (sin * cos_h + cos * sin_h, cos * cos_h - sin * sin_h)
}

/// Sines and cosines of a flight-path state's angles α, β, φ, θ. The
/// heading ψ enters none of the flight-path rates (gravity in body axes and
/// the climb rate do not depend on it), so it is not needed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Angles<T: Real = f64> {
    alpha: (T, T),
    beta: (T, T),
    roll: (T, T),
    pitch: (T, T),
}

impl<T: Real> Angles<T> {
    /// The sine and cosine of state `i`, if it is one of the angles.
    fn slot(&mut self, i: usize) -> Option<&mut (T, T)> {
        match i {
            ALPHA => Some(&mut self.alpha),
            BETA => Some(&mut self.beta),
            ROLL => Some(&mut self.roll),
            PITCH => Some(&mut self.pitch),
            _ => None,
        }
    }
}

impl Angles {
    /// The sines and cosines of angles of zero (the library's).
    const ZERO: Angles = Angles {
        alpha: (0.0, 1.0),
        beta: (0.0, 1.0),
        roll: (0.0, 1.0),
        pitch: (0.0, 1.0),
    };

    fn of(x: &FlightPathState) -> Angles {
        Angles {
            alpha: x[ALPHA].sin_cos(),
            beta: x[BETA].sin_cos(),
            roll: x[ROLL].sin_cos(),
            pitch: x[PITCH].sin_cos(),
        }
    }

    /// The sine and cosine of state `i`, if it is one of the angles.
    fn get(mut self, i: usize) -> Option<SinCos> {
        self.slot(i).copied()
    }

    /// The angles after state `i` moved by a difference step `h` (|h| ≲
    /// 10⁻⁶): no sine or cosine evaluated ([`rotated`]).
    fn nudged(mut self, i: usize, h: f64) -> Angles {
        if let Some(slot) = self.slot(i) {
            *slot = rotated(*slot, h);
        }
        self
    }

    /// The angles after state `i` moved to `value` (only that one recomputed).
    fn moved(mut self, i: usize, value: f64) -> Angles {
        if let Some(slot) = self.slot(i) {
            *slot = value.sin_cos();
        }
        self
    }

    /// The angles with state `i` at `value`, its sine and cosine those of
    /// `anchor` (an angle and its sine and cosine) [`rotated`] by the move,
    /// if it is at most [`NUDGE_LIMIT`], else the library's. Returns
    /// whether the library was used.
    fn moved_from(&mut self, i: usize, (angle, sin_cos): (f64, SinCos), value: f64) -> bool {
        let h = value - angle;
        if h.abs() > NUDGE_LIMIT {
            *self = self.moved(i, value);
            return true;
        }
        if let Some(slot) = self.slot(i) {
            *slot = rotated(sin_cos, h);
        }
        false
    }

    /// The angles as dual numbers differentiating along the states of
    /// `lanes` (lane l: state lanes[l]): d sin = cos, d cos = −sin on an
    /// angle's own lane.
    fn seeded(self, lanes: impl Iterator<Item = usize>) -> Angles<Dual> {
        let lift = |(sin, cos): SinCos| (Dual::constant(sin), Dual::constant(cos));
        let mut angles = Angles {
            alpha: lift(self.alpha),
            beta: lift(self.beta),
            roll: lift(self.roll),
            pitch: lift(self.pitch),
        };
        for (lane, i) in lanes.enumerate() {
            if let Some((sin, cos)) = angles.slot(i) {
                let (value_sin, value_cos) = (sin.value, cos.value);
                sin.tangent[lane] = value_cos;
                cos.tangent[lane] = -value_sin;
            }
        }
        angles
    }
}

/// The measured signals' angle sines and cosines, the record's measured
/// quantities and the air at the points where RK4 evaluates them, the grid
/// points (index 2k) and the steps' midpoints (2k + 1): the same in every
/// simulation of a record, so computed once (the air for the first
/// atmosphere asked for, at the measured altitude).
#[derive(Debug, Clone, Default)]
struct Frozen {
    angles: Vec<Angles>,
    ambient: Vec<Ambient>,
    air: OnceLock<(Atmosphere, Vec<Surroundings>)>,
}

impl Frozen {
    fn new(measured: &[FlightPathState], ambient: &[Ambient]) -> Frozen {
        Frozen {
            angles: frozen_points(measured).map(|x| Angles::of(&x)).collect(),
            ambient: frozen_ambient(ambient).collect(),
            air: OnceLock::new(),
        }
    }

    /// The air and thrust at every point for `atmosphere` and the measured
    /// altitude; None for another atmosphere than the first.
    fn air(
        &self,
        measured: &[FlightPathState],
        atmosphere: &Atmosphere,
    ) -> Option<&[Surroundings]> {
        let (first, air) = self.air.get_or_init(|| {
            let air = frozen_points(measured)
                .zip(&self.ambient)
                .map(|(x, ambient)| ambient.surroundings(atmosphere, x[ALTITUDE]))
                .collect();
            (*atmosphere, air)
        });
        (first == atmosphere).then_some(air.as_slice())
    }

    /// The frozen points' angles and air (for `atmosphere`), and their
    /// measured quantities: what a [`Memo`] reads.
    fn for_memo<'a>(
        &'a self,
        measured: &[FlightPathState],
        atmosphere: &Atmosphere,
    ) -> FrozenPoints<'a> {
        FrozenPoints {
            angles: &self.angles,
            air: self.air(measured, atmosphere),
            ambient: &self.ambient,
        }
    }
}

/// What a [`Memo`] reads of [`Frozen`] (empty: nothing frozen).
#[derive(Debug, Clone, Copy, Default)]
struct FrozenPoints<'a> {
    angles: &'a [Angles],
    air: Option<&'a [Surroundings]>,
    ambient: &'a [Ambient],
}

/// What the record measures that replaces part of the model at one
/// instant: the air density ρ (kg/m³, the `density` channel) instead of
/// the ISA's at the altitude, and the thrust (N, the `thrust` channel,
/// along the aircraft's thrust line) instead of the throttle and engine
/// model δT·Tmax·(ρ/ρ0)ⁿ; None where the record has no such channel. And
/// the derivative of the measured α (rad/s) for a stall model whose
/// separation takes it (`measured_alpha_dot`), None for any other.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ambient {
    pub density: Option<f64>,
    pub thrust: Option<f64>,
    pub alpha_dot: Option<f64>,
}

impl Ambient {
    /// The values a fraction θ into a step from `self` to `end`: linear,
    /// as the measured pseudo-controls ([`between`]).
    fn between(self, end: Ambient, theta: f64) -> Ambient {
        let mix = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| a + (b - a) * theta);
        Ambient {
            density: mix(self.density, end.density),
            thrust: mix(self.thrust, end.thrust),
            alpha_dot: mix(self.alpha_dot, end.alpha_dot),
        }
    }

    /// The air at `altitude`: the atmosphere's, its density (and ln(ρ/ρ0),
    /// which the thrust lapse reads) the measured one when there is one.
    /// Temperature, pressure and speed of sound stay the atmosphere's at
    /// the altitude.
    pub fn air(self, atmosphere: &Atmosphere, altitude: f64) -> Air {
        let mut air = atmosphere.at(altitude);
        if let Some(density) = self.density {
            air.density = density;
            air.log_density_ratio = (density / SEA_LEVEL_DENSITY).ln();
        }
        air
    }

    /// The air at `altitude` ([`Ambient::air`]), the measured thrust and α̇.
    fn surroundings(self, atmosphere: &Atmosphere, altitude: f64) -> Surroundings {
        Surroundings {
            air: self.air(atmosphere, altitude),
            thrust: self.thrust,
            alpha_dot: self.alpha_dot,
        }
    }
}

/// The air, the measured thrust (None: the propulsion model's) and the
/// measured α̇ (None: the state's) an evaluation of the model takes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Surroundings {
    air: Air,
    thrust: Option<f64>,
    alpha_dot: Option<f64>,
}

impl From<Air> for Surroundings {
    fn from(air: Air) -> Surroundings {
        Surroundings {
            air,
            thrust: None,
            alpha_dot: None,
        }
    }
}

/// The measured quantities at the grid points and the steps' midpoints,
/// interpolated as [`frozen_points`].
fn frozen_ambient(ambient: &[Ambient]) -> impl Iterator<Item = Ambient> + '_ {
    ambient.iter().enumerate().flat_map(move |(k, &point)| {
        let midpoint = ambient.get(k + 1).map(|next| point.between(*next, 0.5));
        std::iter::once(point).chain(midpoint)
    })
}

/// The measured state a fraction θ into the step from `start` to `end`:
/// linear (measured pseudo-controls are continuous signals).
fn between(start: &FlightPathState, end: &FlightPathState, theta: f64) -> FlightPathState {
    start + (end - start) * theta
}

/// The measured states at the grid points and the steps' midpoints,
/// interpolated as [`DrivenSimulation::simulate`] does.
fn frozen_points(measured: &[FlightPathState]) -> impl Iterator<Item = FlightPathState> + '_ {
    measured.iter().enumerate().flat_map(move |(k, &point)| {
        let midpoint = measured.get(k + 1).map(|next| between(&point, next, 0.5));
        std::iter::once(point).chain(midpoint)
    })
}

/// The angles' sines and cosines and the air of the last state seen,
/// recomputed only for what moved: RK4's two middle stages share the
/// measured pseudo-controls, and a step's last stage has the next grid
/// point's, so most are reused; measured ones come from [`Frozen`] at the
/// point set by [`Memo::at_point`].
#[derive(Clone, Copy)]
struct Memo<'a> {
    x: Option<FlightPathState>,
    angles: Angles,
    /// The integrated angles where the library last gave their sines and
    /// cosines, and those: the others are moved from there
    /// ([`Angles::moved_from`]), each within an ulp or two of the library's
    /// (no error carried from one to the next).
    anchor: (FlightPathState, Angles),
    air: Surroundings,
    /// The record's measured quantities at the point, and those `air` was
    /// computed with.
    ambient: Ambient,
    air_ambient: Ambient,
    /// Which states are measured, the frozen points, and the point.
    measured: [bool; FLIGHT_PATH_SIZE],
    frozen: FrozenPoints<'a>,
    point: usize,
}

impl<'a> Memo<'a> {
    fn new(measured: [bool; FLIGHT_PATH_SIZE], frozen: FrozenPoints<'a>) -> Memo<'a> {
        Memo {
            x: None,
            angles: Angles::ZERO,
            anchor: (FlightPathState::zeros(), Angles::ZERO),
            air: Surroundings::default(),
            ambient: frozen.ambient.first().copied().unwrap_or_default(),
            air_ambient: Ambient::default(),
            measured,
            frozen,
            point: 0,
        }
    }

    /// The states that follow are at frozen point `index` (2k: grid point
    /// k; 2k + 1: the midpoint of step k).
    fn at_point(&mut self, index: usize) {
        self.point = index;
        if let Some(&ambient) = self.frozen.ambient.get(index) {
            self.ambient = ambient;
        }
    }

    /// Forgets the last state and the anchors: the next state's integrated
    /// angles are the library's. Called at every grid point, so that an
    /// integration step depends on its start state alone, not on the path
    /// that led there (a filter steps from states no simulation visited).
    fn restart(&mut self) {
        self.x = None;
    }

    fn of(&mut self, x: &FlightPathState, atmosphere: &Atmosphere) -> (Angles, Surroundings) {
        let (first, last) = (self.x.is_none(), self.x.unwrap_or(*x));
        let FrozenPoints { angles, air, .. } = self.frozen;
        let frozen_air = air.map(|air| air[self.point]);
        for i in [ALPHA, BETA, ROLL, PITCH] {
            if self.measured[i] {
                let frozen = angles[self.point].get(i);
                // The frozen point is x's (every test that simulates checks it).
                debug_assert_eq!(frozen, Some(x[i].sin_cos()));
                *self.angles.slot(i).expect("an angle") = frozen.expect("an angle");
            } else if first {
                self.angles = self.angles.moved(i, x[i]);
            } else if x[i] != last[i] {
                let (at, angles) = &mut self.anchor;
                let anchor = (at[i], angles.get(i).expect("an angle"));
                if self.angles.moved_from(i, anchor, x[i]) {
                    at[i] = x[i];
                    *angles.slot(i).expect("an angle") = self.angles.get(i).expect("an angle");
                }
            }
        }
        if first {
            self.anchor = (*x, self.angles);
        }
        match frozen_air {
            Some(air) if self.measured[ALTITUDE] => {
                debug_assert_eq!(air, self.ambient.surroundings(atmosphere, x[ALTITUDE]));
                self.air = air
            }
            _ if first || x[ALTITUDE] != last[ALTITUDE] || self.ambient != self.air_ambient => {
                self.air = self.ambient.surroundings(atmosphere, x[ALTITUDE]);
                self.air_ambient = self.ambient;
            }
            _ => {}
        }
        self.x = Some(*x);
        (self.angles, self.air)
    }
}

/// The kinematics of a flight-path state with no wind: body velocity
/// V·(cos α cos β, sin β, sin α cos β), the Euler angles' rotation (ψ = 0:
/// see [`Angles`]), air data straight from V, α, β.
#[inline(always)]
fn kinematics<T: Real>(
    x: &SVector<T, FLIGHT_PATH_SIZE>,
    angles: &Angles<T>,
    surroundings: &Surroundings,
) -> Kinematics<T> {
    let air = &surroundings.air;
    let ((sin_alpha, cos_alpha), (sin_beta, cos_beta)) = (angles.alpha, angles.beta);
    let velocity = Vector3::new(cos_alpha * cos_beta, sin_beta, sin_alpha * cos_beta) * x[AIRSPEED];
    Kinematics {
        velocity,
        omega: x.fixed_rows::<3>(P).into(),
        ned_to_body: state::ned_to_body(angles.roll, angles.pitch, (T::zero(), T::constant(1.0))),
        air: *air,
        air_data: AirData::with_alpha_sin_cos(velocity, x[ALPHA], angles.alpha, x[BETA], air),
        chi: x[CHI],
        wind_rate_body: Vector3::zeros(),
        thrust: surroundings.thrust,
        measured_alpha_dot: surroundings.alpha_dot,
    }
}

/// Measured rates of the pseudo-controls that enter the integrated states'
/// equations: the airspeed's (in β̇) and the sideslip's (in V̇).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PseudoRates {
    pub airspeed: Option<f64>,
    pub beta: Option<f64>,
}

impl PseudoRates {
    /// The same measured signals with rates 0: what the flight-path rates'
    /// part linear in the accelerations sees ([`Motion::response`]).
    fn linear(self) -> PseudoRates {
        PseudoRates {
            airspeed: self.airspeed.map(|_| 0.0),
            beta: self.beta.map(|_| 0.0),
        }
    }

    /// The rates a fraction θ into a step from `self` to `end`.
    fn blend(self, end: PseudoRates, theta: f64) -> PseudoRates {
        let mix = |a: Option<f64>, b: Option<f64>| a.zip(b).map(|(a, b)| a + (b - a) * theta);
        PseudoRates {
            airspeed: mix(self.airspeed, end.airspeed),
            beta: mix(self.beta, end.beta),
        }
    }
}

/// Flight-path rates and the simulator's evaluation at x. A decoupled model
/// takes the other axis's motion from measurement (reflex-wing UAV paper, Eqs. 5–8), and
/// that model has no forces on that axis, so where a measured state's rate
/// enters an integrated state's equation the measured rate is used: with the
/// airspeed measured, β̇ = (v̇ − V̇_m·sin β)/(V·cos β); with the sideslip
/// measured, V̇ = [(u·u̇ + w·ẇ)/V + V·sin β·cos β·β̇_m]/cos²β.
/// `angles` and `air` are x's (computed once per evaluation; [`Linearization::at`] reuses them for every perturbed model).
#[inline(always)]
fn derivative<T: Real>(
    model: &FlightModel,
    x: &SVector<T, FLIGHT_PATH_SIZE>,
    angles: &Angles<T>,
    air: &Surroundings,
    controls: &Controls,
    pseudo: PseudoRates,
) -> (SVector<T, FLIGHT_PATH_SIZE>, Evaluation<T>) {
    let kinematics = kinematics(x, angles, air);
    let forcing = model.forcing(&kinematics, controls);
    derivative_at(model, x, angles, &kinematics, &forcing, pseudo)
}

/// [`derivative`] with x's kinematics and their forcing given
/// ([`FlightModel::forcing`]): what models that differ in their
/// aerodynamic parameters share at one state and input.
#[inline(always)]
fn derivative_at<T: Real>(
    model: &FlightModel,
    x: &SVector<T, FLIGHT_PATH_SIZE>,
    angles: &Angles<T>,
    kinematics: &Kinematics<T>,
    forcing: &Forcing<T>,
    pseudo: PseudoRates,
) -> (SVector<T, FLIGHT_PATH_SIZE>, Evaluation<T>) {
    let evaluation = model.evaluate_forced(kinematics, forcing);
    (
        flight_path_rates(x, angles, &Motion::of(&evaluation), pseudo),
        evaluation,
    )
}

/// [`derivative`] over dual numbers differentiating along the states
/// `lanes` (lane l: state lanes[l]) from x and its angles' sines and
/// cosines: the seeded state, its rates and evaluation.
#[inline(always)]
fn dual_derivative(
    model: &FlightModel,
    x: &FlightPathState,
    angles: Angles,
    lanes: impl Iterator<Item = usize> + Clone,
    air: &Surroundings,
    controls: &Controls,
    pseudo: PseudoRates,
) -> (
    SVector<Dual, FLIGHT_PATH_SIZE>,
    SVector<Dual, FLIGHT_PATH_SIZE>,
    Evaluation<Dual>,
) {
    let mut dual_x = x.map(Dual::constant);
    for (lane, i) in lanes.clone().enumerate() {
        dual_x[i].tangent[lane] = 1.0;
    }
    let (rates, evaluation) =
        derivative(model, &dual_x, &angles.seeded(lanes), air, controls, pseudo);
    (dual_x, rates, evaluation)
}

/// What the flight-path rates take of an evaluation besides x: the
/// air-relative velocity, the accelerations, ḋ and χ̇.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Motion<T: Real = f64> {
    velocity: Vector3<T>,
    airspeed: T,
    /// u̇, v̇, ẇ.
    velocity_rate: Vector3<T>,
    alpha_dot: T,
    beta_dot: T,
    angular_acceleration: Vector3<T>,
    down_rate: T,
    chi_rate: T,
}

impl<T: Real> Motion<T> {
    fn of(evaluation: &Evaluation<T>) -> Motion<T> {
        let d = &evaluation.derivative;
        Motion {
            velocity: evaluation.air_data.velocity,
            airspeed: evaluation.air_data.airspeed,
            velocity_rate: d.fixed_rows::<3>(state::U).into(),
            alpha_dot: evaluation.alpha_dot,
            beta_dot: evaluation.beta_dot,
            angular_acceleration: evaluation.angular_acceleration,
            down_rate: d[state::DOWN],
            chi_rate: d[state::CHI],
        }
    }
}

impl Motion {
    /// The change of this motion by a coefficient's `response` (its
    /// accelerations, and `chi_rate` for χ̇) at the same velocity, as a
    /// motion: [`motion_rates`] of it, with the measured rates' terms
    /// removed ([`PseudoRates::linear`]), is the flight-path rates'
    /// response, their part linear in the accelerations.
    fn response(self, response: &Accelerations, chi_rate: f64) -> Motion {
        Motion {
            velocity_rate: response.velocity_rate,
            alpha_dot: response.alpha_dot,
            beta_dot: response.beta_dot,
            angular_acceleration: response.angular_acceleration,
            down_rate: 0.0,
            chi_rate,
            ..self
        }
    }
}

/// The flight-path rates of an evaluation's motion at x ([`derivative`]):
/// affine in the accelerations.
#[inline(always)]
fn flight_path_rates<T: Real>(
    x: &SVector<T, FLIGHT_PATH_SIZE>,
    angles: &Angles<T>,
    motion: &Motion<T>,
    pseudo: PseudoRates,
) -> SVector<T, FLIGHT_PATH_SIZE> {
    let mut rates = motion_rates(x, angles, motion, pseudo);
    rates
        .fixed_rows_mut::<3>(ROLL)
        .copy_from(&state::euler_rates_of(
            angles.roll,
            angles.pitch,
            &x.fixed_rows::<3>(P).into(),
        ));
    rates
}

/// The flight-path rates that depend on the motion (all but the Euler
/// angles', which are 0 here): airspeed, flow angles, angular rates,
/// altitude and χ.
#[inline(always)]
fn motion_rates<T: Real>(
    x: &SVector<T, FLIGHT_PATH_SIZE>,
    angles: &Angles<T>,
    motion: &Motion<T>,
    pseudo: PseudoRates,
) -> SVector<T, FLIGHT_PATH_SIZE> {
    let (velocity, d) = (motion.velocity, motion.velocity_rate);
    let mut rates = SVector::<T, FLIGHT_PATH_SIZE>::zeros();
    let (sin_beta, cos_beta) = angles.beta;
    rates[AIRSPEED] = match pseudo.beta {
        Some(beta_rate) => {
            let longitudinal = (velocity.x * d.x + velocity.z * d.z) / x[AIRSPEED];
            (longitudinal + x[AIRSPEED] * sin_beta * cos_beta * beta_rate) / (cos_beta * cos_beta)
        }
        None => velocity.dot(&d) / motion.airspeed,
    };
    rates[ALPHA] = motion.alpha_dot;
    rates[BETA] = match pseudo.airspeed {
        Some(speed_rate) => (d.y - sin_beta * speed_rate) / (x[AIRSPEED] * cos_beta),
        None => motion.beta_dot,
    };
    rates
        .fixed_rows_mut::<3>(P)
        .copy_from(&motion.angular_acceleration);
    rates[ALTITUDE] = -motion.down_rate;
    rates[CHI] = motion.chi_rate;
    rates
}

/// A coefficient's response at an evaluation `at` of a model whose forces
/// do not depend on α̇: the direction its offset moves the coefficients in
/// ([`aeroid_sim::aero::AeroModel::offset_response`]), the accelerations'
/// response ([`FlightModel::acceleration_response`]) and χ̇'s (through α̇:
/// exact to first order, ∂χ̇/∂α̇ times α̇'s change). The coefficients,
/// accelerations and state derivative are affine in C, and so are the
/// flight-path rates and every output, so moving by the response gives
/// ∂/∂C exactly.
fn offset_response(
    model: &FlightModel,
    at: &Evaluation,
    coefficient: Coefficient,
) -> (AeroCoefficients, Accelerations, f64) {
    let aero = &model.aircraft.aero;
    let direction = aero.offset_response(coefficient, &at.coefficients, at.air_data.alpha_sin_cos);
    let response = model.acceleration_response(&at.air_data, &direction);
    let chi_rate =
        aero.separation_rate_slope(at.air_data.alpha, at.alpha_dot, at.air_data.airspeed)
            * response.alpha_dot;
    (direction, response, chi_rate)
}

/// The evaluation `at` moved by a coefficient's response ([`offset_response`]).
fn offset_evaluation(
    at: &Evaluation,
    (direction, response, chi_rate): &(AeroCoefficients, Accelerations, f64),
) -> Evaluation {
    let mut moved = *at;
    moved.coefficients = moved.coefficients + *direction;
    moved.specific_force += response.specific_force;
    moved.angular_acceleration += response.angular_acceleration;
    moved.alpha_dot += response.alpha_dot;
    moved.beta_dot += response.beta_dot;
    let d = &mut moved.derivative;
    let velocity_rate = d.fixed_rows::<3>(state::U) + response.velocity_rate;
    d.fixed_rows_mut::<3>(state::U).copy_from(&velocity_rate);
    let angular = d.fixed_rows::<3>(state::P) + response.angular_acceleration;
    d.fixed_rows_mut::<3>(state::P).copy_from(&angular);
    d[state::CHI] += chi_rate;
    moved
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
    /// The outputs other than the flight-path states, by record channel name.
    const NAMED: [(&'static str, Observable); 16] = [
        ("nx", Observable::LoadFactor(0)),
        ("ny", Observable::LoadFactor(1)),
        ("nz", Observable::LoadFactor(2)),
        ("p_dot", Observable::AngularAcceleration(0)),
        ("q_dot", Observable::AngularAcceleration(1)),
        ("r_dot", Observable::AngularAcceleration(2)),
        ("mach", Observable::Mach),
        ("dynamic_pressure", Observable::DynamicPressure),
        ("CX", Observable::Force(0)),
        ("CY", Observable::Force(1)),
        ("CZ", Observable::Force(2)),
        ("CL", Observable::Lift),
        ("CD", Observable::Drag),
        ("Cl", Observable::Moment(0)),
        ("Cm", Observable::Moment(1)),
        ("Cn", Observable::Moment(2)),
    ];

    /// The output a record channel name stands for; None when the model has no such output.
    pub fn parse(name: &str) -> Option<Observable> {
        if let Some(i) = FLIGHT_PATH_STATES.iter().position(|s| *s == name) {
            return Some(Observable::State(i));
        }
        Observable::NAMED
            .iter()
            .find(|(named, _)| *named == name)
            .map(|(_, observable)| *observable)
    }

    /// Every output name a model structure may compare.
    pub fn names() -> impl Iterator<Item = &'static str> {
        FLIGHT_PATH_STATES
            .iter()
            .copied()
            .chain(Observable::NAMED.iter().map(|(name, _)| *name))
    }

    /// The output's value at a state and its evaluation.
    pub fn value<T: Real>(self, x: &SVector<T, FLIGHT_PATH_SIZE>, evaluation: &Evaluation<T>) -> T {
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
enum Source {
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
struct Filled {
    column: usize,
    response: usize,
    factor: usize,
}

/// A response of ẋ and y to a change of the model: ∂/∂C of a coefficient,
/// or ∂/∂θ of a nonlinear parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Response {
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
struct Directions {
    states: Vec<usize>,
    /// The states ∂f/∂x and ∂g/∂x are differentiated along by dual numbers
    /// ([`aeroid_numerics::dual`]), [`LANES`] at a time, each with its column in
    /// ∂f/∂x; the others (the altitude, whose air comes from the
    /// atmosphere table, and every state of a model whose forces depend on
    /// α̇, solved for by iteration) by forward differences.
    dual_lanes: Vec<Vec<(usize, usize)>>,
    differenced: Vec<(usize, usize)>,
    /// Each perturbed model: moved by +step, its step, and (central
    /// differences) moved by −step.
    models: Vec<(FlightModel, f64, Option<FlightModel>)>,
    /// Whether the perturbed models' quotients are central differences.
    central: bool,
    responses: Vec<Response>,
    /// Per unknown; a `Direction` or `Term` names a response.
    sources: Vec<Source>,
    /// The columns with a source, terms first (`terms` of them).
    filled: Vec<Filled>,
    terms: usize,
}

impl Directions {
    /// Differentiates along `states` (none for a plain simulation) and
    /// the unknowns `columns`; the perturbed models' difference quotients
    /// forward, or `central`.
    fn new(model: &FlightModel, columns: &[Column], states: &[usize], central: bool) -> Directions {
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

    fn nonlinear(&mut self, model: &FlightModel, parameter: usize) -> Source {
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

/// A model linearised at one point (a grid point, or an RK4 stage state
/// with [`Linearise::Stages`]): ẋ, the evaluation, and derivatives over the
/// active states (dual numbers or difference quotients: [`Directions`]):
/// ∂f/∂x, ∂f/∂θ, and at grid points the outputs' ∂g/∂x and ∂g/∂θ.
struct Linearization {
    rates: FlightPathState,
    evaluation: Evaluation,
    /// ∂f/∂x (active × active).
    a: DMatrix<f64>,
    /// ∂f/∂θ (active × unknowns).
    b: DMatrix<f64>,
    outputs: Vec<f64>,
    /// ∂g/∂x (outputs × active).
    gx: DMatrix<f64>,
    /// ∂g/∂θ (outputs × unknowns).
    gtheta: DMatrix<f64>,
    /// Scratch: ∂ẋ of the active states and ∂y, a column per response.
    model_rates: DMatrix<f64>,
    model_outputs: DMatrix<f64>,
}

impl Linearization {
    fn new(directions: &Directions, outputs: usize) -> Linearization {
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
    fn at(
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
        // for AVX2 too.
        aeroid_numerics::simd::wide(
            #[inline(always)]
            || {
                let atmosphere = &model.environment.atmosphere;
                let (angles, air) = memo.of(x, atmosphere);
                // With dual lanes the first one's values are the evaluation at x
                // (the same numbers); without, it is evaluated plainly.
                if directions.dual_lanes.is_empty() {
                    (self.rates, self.evaluation) =
                        derivative(model, x, &angles, &air, controls, pseudo);
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
                        &air,
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
                if directions.differenced.is_empty() && directions.responses.is_empty() {
                    return;
                }
                for &(b, i) in &directions.differenced {
                    let step = state_step(x[i]);
                    let mut moved = *x;
                    moved[i] += step;
                    let moved_air = if i == ALTITUDE {
                        memo.ambient.surroundings(atmosphere, moved[i])
                    } else {
                        air
                    };
                    let moved_angles = angles.nudged(i, moved[i] - x[i]);
                    let (rates, evaluation) =
                        derivative(model, &moved, &moved_angles, &moved_air, controls, pseudo);
                    for (a, &r) in states.iter().enumerate() {
                        self.a[(a, b)] = (rates[r] - self.rates[r]) / step;
                    }
                    for (o, output) in outputs.iter().enumerate() {
                        self.gx[(o, b)] =
                            (output.value(&moved, &evaluation) - self.outputs[o]) / step;
                    }
                }
                let motion = Motion::of(&self.evaluation);
                for (d, response) in directions.responses.iter().enumerate() {
                    match *response {
                        Response::Model(m) => {
                            let (perturbed, step, minus) = &directions.models[m];
                            let (rates, evaluation) =
                                derivative(perturbed, x, &angles, &air, controls, pseudo);
                            // The base of the quotient: this point (forward)
                            // or the model moved by −step (central).
                            let minus_outputs: Vec<f64>;
                            let (base_rates, base_outputs, span) = match minus {
                                None => (self.rates, self.outputs.as_slice(), *step),
                                Some(minus) => {
                                    let (rates, evaluation) =
                                        derivative(minus, x, &angles, &air, controls, pseudo);
                                    minus_outputs =
                                        outputs.iter().map(|o| o.value(x, &evaluation)).collect();
                                    (rates, minus_outputs.as_slice(), 2.0 * step)
                                }
                            };
                            for (into, &r) in self.model_rates.column_mut(d).iter_mut().zip(states)
                            {
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
                            for (into, &r) in self.model_rates.column_mut(d).iter_mut().zip(states)
                            {
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
                let regressors = if directions.terms > 0 {
                    model
                        .aircraft
                        .aero
                        .term_regressors(&self.evaluation.aero_input)
                } else {
                    TermRegressors::default()
                };
                // Column j of ∂f/∂θ and ∂g/∂θ: its response times its factor (the
                // columns of unknowns with no source stay 0 from `new`).
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
            },
        )
    }

    /// ∂f/∂θ at this point with the controls replaced by `controls` (the
    /// controls a step's last stage sees: under a hold, the step's start
    /// value, not the grid point's new one): the terms' regressors are
    /// recomputed, everything else is this point's. Written into `into`.
    fn b_with_controls(
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
fn fill(
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
pub(super) fn evaluate(
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

/// The angles' sines and cosines, the kinematics and the forcing
/// ([`FlightModel::forcing`]) of the last full state and controls an
/// evaluation was at (with the measured quantities and the atmosphere it
/// was taken with): a filter evaluates its sigma points' outputs at one
/// time, most of them (those that move only an augmented model's
/// parameters) at one state, and they share them.
#[derive(Debug, Clone, Default)]
pub(super) struct PointMemo {
    last: Option<PointKey>,
}

/// What a [`PointMemo`] keeps: the point, and what was computed there.
#[derive(Debug, Clone)]
struct PointKey {
    x: FlightPathState,
    controls: Controls,
    ambient: Ambient,
    atmosphere: Atmosphere,
    angles: Angles,
    kinematics: Kinematics,
    forcing: Forcing,
}

impl PointMemo {
    /// The library's sines and cosines of x's angles, the kinematics with
    /// the air at x's altitude ([`Ambient::surroundings`]) and their
    /// forcing by `model` with `controls`; the kept ones when x, the
    /// controls, the measured quantities and the atmosphere are the last
    /// call's (`model` differing from the last call's in its aerodynamic
    /// parameters at most).
    fn of(
        &mut self,
        model: &FlightModel,
        x: &FlightPathState,
        controls: &Controls,
        ambient: Ambient,
    ) -> (&Angles, &Kinematics, &Forcing) {
        let atmosphere = &model.environment.atmosphere;
        let kept = matches!(&self.last, Some(last) if last.x == *x
            && last.controls == *controls
            && last.ambient == ambient
            && last.atmosphere == *atmosphere);
        if !kept {
            self.last = None;
        }
        let last = self.last.get_or_insert_with(|| {
            let angles = Angles::of(x);
            let air = ambient.surroundings(atmosphere, x[ALTITUDE]);
            let kinematics = kinematics(x, &angles, &air);
            let forcing = model.forcing(&kinematics, controls);
            PointKey {
                x: *x,
                controls: *controls,
                ambient,
                atmosphere: *atmosphere,
                angles,
                kinematics,
                forcing,
            }
        });
        (&last.angles, &last.kinematics, &last.forcing)
    }
}

/// [`evaluate`] with the outputs written into `values` (as long as
/// `outputs`), the angles, kinematics and forcing from `memo`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn evaluate_into(
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

/// The Jacobians of f (rows: `states`) and of the `outputs` at the full
/// flight-path state x, along `states` and every aerodynamic parameter of
/// `model`, by the machinery of [`DrivenSimulation::simulate`]'s
/// sensitivity equations ([`Linearization::at`]): dual numbers along the
/// states (forward differences along the altitude, and wherever the
/// forces depend on α̇), a term's ∂f/∂θ exact from the coefficient's
/// response times its regressor, a nonlinear parameter's a central
/// difference (the simulation's forward difference is within ~10⁻⁶ of it
/// through a stall break; a filter linearises once per step, so the
/// second evaluation is cheap there).
pub(super) fn linearise(
    model: &FlightModel,
    x: &FlightPathState,
    (controls, pseudo, ambient): (&Controls, PseudoRates, Ambient),
    states: &[usize],
    outputs: &[Observable],
) -> Jacobians {
    let mut buffers = LinearisationBuffers::default();
    linearise_with(
        model,
        x,
        (controls, pseudo, ambient),
        states,
        outputs,
        true,
        &mut buffers,
    );
    let mut jacobians = Jacobians::empty();
    buffers.copy_into(&mut jacobians, None);
    jacobians
}

/// The buffers of [`linearise`] kept between calls: the directions while
/// they do not depend on θ (no perturbed models: every parameter a term's,
/// the forces affine in the coefficients), with the flag they were made
/// for, and the linearisation's matrices.
#[derive(Default)]
pub(super) struct LinearisationBuffers {
    made: Option<(bool, Directions, Linearization)>,
}

/// [`linearise`] into `buffers` (the same numbers): the Jacobians are the
/// linearisation's `a`, `b`, `gx`, `gtheta` ([`LinearisationBuffers::copy_into`]),
/// the outputs its values. Without `with_outputs` the outputs and their
/// derivatives are not evaluated (`a` and `b` only:
/// [`LinearisationBuffers::copy_rates_into`]).
pub(super) fn linearise_with(
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
    pub(super) fn rates_and_jacobians(
        &self,
    ) -> Option<(&FlightPathState, &DMatrix<f64>, &DMatrix<f64>)> {
        let (_, _, linearization) = self.made.as_ref()?;
        Some((&linearization.rates, &linearization.a, &linearization.b))
    }

    /// The last linearisation's ∂f/∂x, ∂f/∂θ, ∂h/∂x, ∂h/∂θ into `into`,
    /// and its outputs into `outputs` if given.
    pub(super) fn copy_into(&self, into: &mut Jacobians, outputs: Option<&mut DVector<f64>>) {
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
    pub(super) fn copy_rates_into(&self, into: &mut Jacobians) {
        let Some((_, _, linearization)) = &self.made else {
            return;
        };
        copy(&linearization.a, &mut into.rates_by_state);
        copy(&linearization.b, &mut into.rates_by_parameter);
    }
}

/// `from` into `to`, reshaped if it differs.
fn copy(from: &DMatrix<f64>, to: &mut DMatrix<f64>) {
    if to.shape() != from.shape() {
        *to = DMatrix::zeros(from.nrows(), from.ncols());
    }
    to.copy_from(from);
}

/// Where [`DrivenSimulation::simulate`] linearises the model for the
/// sensitivity equations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Linearise {
    /// At every RK4 stage state (four linearisations per step): S is the
    /// exact derivative of the discrete simulation, for the information
    /// matrix and Cramér–Rao bounds.
    Stages,
    /// At the grid points only (one per step), their mean at the middle
    /// stages: within O(h²) of the exact derivative where the model varies
    /// smoothly, and O(h) at a step in a held control (∂f/∂x there keeps the
    /// new value). Measured: 5e-4 of a column on the ATTAS lateral model,
    /// 1.5 % on the longitudinal one at a 3211's switches, 3 % on the
    /// stall model's τ1 through the break. Good enough to steer
    /// Gauss–Newton (an approximate Jacobian changes the path, not the
    /// optimum it stops at to within the noise; see `output_error`), at
    /// about half the cost of the stage linearisation (docs/performance.md).
    GridPoints,
}

/// A postulated model's inputs and pseudo-controls on an integration grid.
#[derive(Debug, Clone)]
pub struct DrivenSimulation {
    pub start: f64,
    pub step: f64,
    /// How each control is taken inside a step (by [`Control::index`]).
    pub holds: [Interpolation; CONTROL_COUNT],
    /// The controls the record has, each with its interpolation and why.
    pub input_timing: Vec<Chosen>,
    /// Which flight-path states are integrated (others are measured).
    pub integrate: [bool; FLIGHT_PATH_SIZE],
    pub controls: Vec<Controls>,
    /// Measured flight-path states at the grid points (integrated entries unused).
    measured: Vec<FlightPathState>,
    /// The record's measured density and thrust at the grid points.
    ambient: Vec<Ambient>,
    frozen: Frozen,
    /// Notes for the user (a control held constant because its channel is
    /// absent, a measured quantity used).
    pub notes: Vec<String>,
    /// The notes that name a measured quantity the model takes from the
    /// record instead of its own (also in `notes`).
    pub measured_quantities: Vec<String>,
}

/// The record's measured quantities the model takes instead of its own
/// ([`Ambient`]).
pub const MEASURED_QUANTITIES: [&str; 2] = ["density", "thrust"];

/// The channels that stand in for a missing `altitude` pseudo-control, in
/// order: pressure altitude, else the density altitude of the measured
/// density, else of the density 2·q̄/V² from the dynamic pressure and the
/// airspeed ([`DrivenSimulation::from_record`]).
pub const ALTITUDE_SUBSTITUTES: [&str; 3] = ["pressure_altitude", "density", "dynamic_pressure"];

/// The record's measured density and thrust on the grid (linear between
/// samples, as the measured pseudo-controls), and the notes saying so.
fn measured_ambient(record: &FlightRecord, times: &[f64]) -> Result<(Vec<Ambient>, Vec<String>)> {
    let mut ambient = vec![Ambient::default(); times.len()];
    let mut notes = Vec::new();
    let [density, thrust] = MEASURED_QUANTITIES;
    if let Ok(channel) = record.channel(density) {
        for (into, value) in ambient.iter_mut().zip(channel.values_at(times)?) {
            into.density = Some(value);
        }
        notes.push(
            "air density: the record's 'density' channel, not the ISA at the altitude".into(),
        );
    } else if ["altitude", ALTITUDE_SUBSTITUTES[0]]
        .iter()
        .all(|name| record.channel(name).is_err())
        && let (Ok(pressure), Ok(airspeed)) = (
            record.channel(ALTITUDE_SUBSTITUTES[2]),
            record.channel("airspeed"),
        )
    {
        let speeds = airspeed.values_at(times)?;
        for ((into, q), v) in ambient
            .iter_mut()
            .zip(pressure.values_at(times)?)
            .zip(speeds)
        {
            into.density = Some(2.0 * q / (v * v));
        }
        notes.push(
            "air density: 2·q̄/V² from the record's 'dynamic_pressure' and 'airspeed' channels (it has no density or altitude channel)".into(),
        );
    }
    if let Ok(channel) = record.channel(thrust) {
        for (into, value) in ambient.iter_mut().zip(channel.values_at(times)?) {
            into.thrust = Some(value);
        }
        notes.push(
            "thrust: the record's 'thrust' channel, along the aircraft's thrust line, not the throttle and engine model"
                .into(),
        );
    }
    let bad = |value: Option<f64>, positive: bool| {
        value.is_some_and(|v| !v.is_finite() || (positive && v <= 0.0))
    };
    for (&t, a) in times.iter().zip(&ambient) {
        if bad(a.density, true) {
            return Err(Error::Other(format!(
                "the measured air density at t = {t:.3} s is {}: it must be finite and positive (channel '{density}', or 2·q̄/V² from 'dynamic_pressure' and 'airspeed')",
                a.density.unwrap_or(f64::NAN)
            )));
        }
        if bad(a.thrust, false) {
            return Err(Error::Other(format!(
                "the record's '{thrust}' channel has no finite value at t = {t:.3} s"
            )));
        }
    }
    Ok((ambient, notes))
}

/// The smoothed derivative of the record's α, written into `ambient` at
/// `times`, and the note saying so: the project's local polynomial
/// differentiator ([`Differentiator`], its default: degree 4, ±0.1 s) with
/// no window across a control step ([`control_steps`], as the regression
/// methods differentiate), linear between its samples and, where it has
/// none (the first and last half-window of the record, and beside a
/// step), bridged from its neighbours or held at the ends.
fn measured_alpha_dot(
    record: &FlightRecord,
    times: &[f64],
    ambient: &mut [Ambient],
) -> Result<String> {
    let alpha = record.channel("alpha").map_err(|_| {
        Error::Other(
            "the stall model takes α̇ from the measured α (`alpha_dot = \"measured\"`), but the record has no 'alpha' channel".into(),
        )
    })?;
    let differentiator = Differentiator::default();
    let steps = control_steps(record);
    let derivative = differentiator.differentiate_with_breaks(alpha, &steps);
    for (into, value) in ambient.iter_mut().zip(derivative.values_at(times)?) {
        into.alpha_dot = Some(value);
    }
    let m = differentiator.half_window(alpha.rate);
    Ok(format!(
        "α̇ of the separation equation: the derivative of the record's 'alpha' (local polynomial, degree {}, ±{m} samples at {} Hz, not across {} control steps; held over the first and last {:.2} s)",
        differentiator.degree,
        aeroid_record::rate_text(alpha.rate),
        steps.len(),
        m as f64 / alpha.rate
    ))
}

impl DrivenSimulation {
    /// Samples controls and pseudo-controls from the record on the grid
    /// start, start + step, …, end. Each control channel is reconstructed
    /// between its samples as `interpolation` chooses for it (a hold keeps
    /// a recorded step a step; noted); measured pseudo-controls,
    /// continuous signals, linearly.
    /// A missing control channel is held at 0 (noted); a missing
    /// pseudo-control that the model needs is an error. The record's
    /// `density` and `thrust` channels, when it has them, are sampled
    /// linearly too and replace the ISA's density and the throttle model
    /// ([`Ambient`]); a missing altitude is the pressure altitude, else the
    /// ISA density altitude of the measured density
    /// ([`ALTITUDE_SUBSTITUTES`]). With `alpha_dot` the derivative of the
    /// record's α is sampled too (`measured_alpha_dot`), for a stall
    /// model whose separation takes it. Each is noted.
    pub fn from_record(
        record: &FlightRecord,
        integrate: &[usize],
        interpolation: &InputInterpolation,
        step: f64,
        (start, end): (f64, f64),
        alpha_dot: bool,
    ) -> Result<DrivenSimulation> {
        let count = ((end - start) / step + 1e-9).floor() as usize + 1;
        let times: Vec<f64> = (0..count).map(|k| start + k as f64 * step).collect();
        let (mut ambient, mut measured_quantities) = measured_ambient(record, &times)?;
        if alpha_dot {
            measured_quantities.push(measured_alpha_dot(record, &times, &mut ambient)?);
        }
        let mut notes = measured_quantities.clone();
        let thrust_measured = ambient.first().is_some_and(|a| a.thrust.is_some());
        let mut controls = vec![Controls::zeros(); count];
        let mut holds = [Interpolation::ZeroOrderHold; CONTROL_COUNT];
        let mut input_timing = Vec::new();
        for control in Control::ALL {
            match record.channel(control.name()) {
                Ok(channel) => {
                    let chosen = interpolation.choose(control.name(), &channel.values);
                    holds[control.index()] = chosen.interpolation;
                    for (sample, value) in controls
                        .iter_mut()
                        .zip(channel.sampled_at(&times, chosen.interpolation)?)
                    {
                        sample[control.index()] = value;
                    }
                    input_timing.push(chosen);
                }
                // With the thrust measured the throttle is not read.
                Err(_) if control == Control::Throttle && thrust_measured => {}
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
                    if let Ok(altitude) = record.channel(ALTITUDE_SUBSTITUTES[0]) {
                        for (sample, value) in measured.iter_mut().zip(altitude.values_at(&times)?)
                        {
                            sample[i] = value;
                        }
                    } else if ambient.first().is_some_and(|a| a.density.is_some()) {
                        for (sample, ambient) in measured.iter_mut().zip(&ambient) {
                            sample[i] =
                                Atmosphere::density_altitude(ambient.density.unwrap_or(f64::NAN));
                        }
                        let note = "no altitude channel: the altitude is the ISA density altitude of the measured density (the air's temperature and speed of sound the ISA's there)";
                        notes.push(note.into());
                        measured_quantities.push(note.into());
                    } else {
                        return Err(missing_altitude());
                    }
                }
                Err(_) => return Err(missing(name)),
            }
        }
        debug_assert_eq!(CONTROL_COUNT, 5);
        if !input_timing.is_empty() {
            notes.push(input_timing::note(&input_timing));
        }
        Ok(DrivenSimulation {
            start,
            step,
            holds,
            input_timing,
            integrate: mask,
            controls,
            frozen: Frozen::new(&measured, &ambient),
            measured,
            ambient,
            notes,
            measured_quantities,
        })
    }

    /// The simulation over its first `points` grid points (at least two,
    /// at most all): what a linearisation at its start reads, without a
    /// copy of the whole record's inputs.
    pub fn head(&self, points: usize) -> DrivenSimulation {
        let n = points.max(2).min(self.len());
        let measured = self.measured[..n].to_vec();
        let ambient = self.ambient[..n].to_vec();
        DrivenSimulation {
            start: self.start,
            step: self.step,
            holds: self.holds,
            input_timing: self.input_timing.clone(),
            integrate: self.integrate,
            controls: self.controls[..n].to_vec(),
            frozen: Frozen::new(&measured, &ambient),
            measured,
            ambient,
            notes: Vec::new(),
            measured_quantities: Vec::new(),
        }
    }

    /// Measured flight-path states at the grid points (integrated entries unused).
    pub fn measured(&self) -> &[FlightPathState] {
        &self.measured
    }

    /// The record's measured density and thrust at grid point k.
    pub fn ambient(&self, k: usize) -> Ambient {
        self.ambient[k]
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

    /// Rates at grid point k of the measured airspeed and sideslip, where
    /// they are not integrated: the centred difference
    /// (x[k+1] − x[k−1])/(2·Δt) (one-sided at the ends), interpolated
    /// linearly inside a step like the measured signals themselves. The rate
    /// at a grid point then leaves out that point's own sample: a rate
    /// sharing a sample's noise, multiplied by the same noisy measured β in
    /// V̇ (Eq. in [`derivative`]), has a non-zero mean, −σ²/Δt, an
    /// errors-in-variables bias on drag; with the centred difference the
    /// product's noise has zero mean at every point of the step (the two
    /// shared-sample terms cancel: θ(1−θ)σ² − (1−θ)θσ²). The rates are
    /// continuous at the grid points, so a step's last stage and the next
    /// grid point see the same model (what the grid-point linearisation of
    /// [`DrivenSimulation::simulate`] relies on).
    pub(super) fn pseudo_rates(&self, k: usize) -> PseudoRates {
        let last = self.len() - 1;
        let (previous, next) = (k.saturating_sub(1), (k + 1).min(last));
        if next == previous {
            return PseudoRates::default();
        }
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

    /// Which flight-path states `model` integrates (1) and which are
    /// measured (0): the structure's integrated states, and χ wherever the
    /// model makes it a state (fed back from α when not integrated).
    /// Whether [`DrivenSimulation::mask`] of `model` is `mask`, for a
    /// `mask` this simulation gave (for any model): the two can differ
    /// only in χ, a state where the simulation integrates it or the
    /// model's stall makes it one.
    pub(super) fn gives_mask(&self, model: &FlightModel, mask: &FlightPathState) -> bool {
        let chi = self.integrate[CHI] || model.aircraft.aero.chi_is_state();
        (mask[CHI] == 1.0) == chi
    }

    pub(super) fn mask(&self, model: &FlightModel) -> FlightPathState {
        let chi_is_state = model.aircraft.aero.chi_is_state();
        FlightPathState::from_fn(|i, _| {
            if self.integrate[i] || (i == CHI && chi_is_state) {
                1.0
            } else {
                0.0
            }
        })
    }

    /// The controls a fraction `fraction` ∈ [0, 1] into step k (k + 1 a
    /// grid point): each blended by its own weight,
    /// u_k + w(θ)∘(u_k+1 − u_k), w_i = 0 held, θ linear.
    pub(super) fn controls_inside(&self, k: usize, fraction: f64) -> Controls {
        let weights = Controls::from_fn(|i, _| self.holds[i].weight(fraction));
        self.controls[k] + (self.controls[k + 1] - self.controls[k]).component_mul(&weights)
    }

    /// The setting that reproduces this simulation's choice per control on
    /// any record (a record with the inputs' noise drawn again).
    pub fn fixed_interpolation(&self) -> InputInterpolation {
        InputInterpolation::fixed(&self.input_timing)
    }

    /// The measured states, controls and pseudo-control rates a fraction
    /// `fraction` ∈ [0, 1] into step k (k the last grid point: its own,
    /// fraction 0): measured pseudo-controls are continuous states, always
    /// linear inside the step (consistent with their rates in
    /// [`DrivenSimulation::pseudo_rates`]); each control held or linear
    /// ([`DrivenSimulation::controls_inside`]; under a hold the step's end
    /// sees the start's value). At fraction 0 the grid point's samples themselves.
    pub(super) fn inputs_at(
        &self,
        k: usize,
        fraction: f64,
    ) -> (FlightPathState, Controls, PseudoRates, Ambient) {
        if fraction == 0.0 || k + 1 >= self.len() {
            return (
                self.measured[k],
                self.controls[k],
                self.pseudo_rates(k),
                self.ambient[k],
            );
        }
        let ends = (self.pseudo_rates(k), self.pseudo_rates(k + 1));
        self.inputs_inside(k, fraction, ends)
    }

    /// [`DrivenSimulation::inputs_at`] a fraction in (0, 1] into step k,
    /// given the pseudo-control rates at the step's two ends.
    pub(super) fn inputs_inside(
        &self,
        k: usize,
        fraction: f64,
        (start, end): (PseudoRates, PseudoRates),
    ) -> (FlightPathState, Controls, PseudoRates, Ambient) {
        let (measured, ambient) = if fraction == 1.0 {
            (self.measured[k + 1], self.ambient[k + 1])
        } else {
            (
                between(&self.measured[k], &self.measured[k + 1], fraction),
                self.ambient[k].between(self.ambient[k + 1], fraction),
            )
        };
        let controls = self.controls_inside(k, fraction);
        (measured, controls, start.blend(end, fraction), ambient)
    }

    /// The flight-path state at grid point k (or a fraction into step k)
    /// with the `mask`ed states from `x` and the others from `measured`.
    pub(super) fn merged(
        x: &FlightPathState,
        measured: &FlightPathState,
        mask: &FlightPathState,
    ) -> FlightPathState {
        FlightPathState::from_fn(|i, _| if mask[i] == 1.0 { x[i] } else { measured[i] })
    }

    /// The measured states, controls and pseudo-control rates at the
    /// later RK4 stage times of step k, its midpoint and its end
    /// ([`DrivenSimulation::inputs_inside`]): the same for every state the
    /// step starts from.
    pub(super) fn stage_inputs(&self, k: usize) -> StageInputs {
        let ends = (self.pseudo_rates(k), self.pseudo_rates(k + 1));
        let at = |fraction: f64| {
            let (measured, controls, pseudo, _) = self.inputs_inside(k, fraction, ends);
            (measured, controls, pseudo)
        };
        StageInputs {
            k,
            middle: at(0.5),
            end: at(1.0),
        }
    }

    /// The one integration step of the postulated model: RK4
    /// ([`rk4_step`]) from the state `x` at grid point k (`first` its
    /// rates, evaluated by the caller) to grid point k + 1, the `mask`ed
    /// states integrated and the others the next grid point's measured
    /// values, the later stages' inputs `inputs` (step k's,
    /// [`DrivenSimulation::stage_inputs`]). `rates(state, controls, pseudo,
    /// memo)` evaluates ẋ at the three later stages, given the stage's
    /// merged state and inputs with `memo` at its frozen point.
    /// Both [`DrivenSimulation::simulate`] and the state-space view's step
    /// ([`super::state_space`], through [`PlainSteps`]) take their steps
    /// here.
    fn step_from(
        &self,
        inputs: &StageInputs,
        x: &FlightPathState,
        mask: &FlightPathState,
        first: &FlightPathState,
        memo: &mut Memo,
        mut rates: impl FnMut(&FlightPathState, &Controls, PseudoRates, &mut Memo) -> FlightPathState,
    ) -> FlightPathState {
        let k = inputs.k;
        let next = rk4_step(x, self.step, |x, fraction| {
            // The first stage is the grid point, evaluated by the caller.
            if fraction == 0.0 {
                return first.component_mul(mask);
            }
            // The step's end is the next grid point; the middle stages are
            // at the step's midpoint.
            let (point, (measured, controls, pseudo)) = if fraction == 1.0 {
                (2 * k + 2, &inputs.end)
            } else {
                (2 * k + 1, &inputs.middle)
            };
            memo.at_point(point);
            let merged = Self::merged(x, measured, mask);
            rates(&merged, controls, *pseudo, memo).component_mul(mask)
        });
        Self::merged(&next, &self.measured[k + 1], mask)
    }

    /// Plain steps of `model`'s form (which states `mask` integrates, the
    /// air of `atmosphere`) from grid point k, for many start states
    /// ([`PlainSteps::step`]).
    pub(super) fn plain_steps<'a>(
        &'a self,
        k: usize,
        mask: &FlightPathState,
        atmosphere: &Atmosphere,
    ) -> PlainSteps<'a> {
        let measured_states = std::array::from_fn(|i| mask[i] == 0.0);
        let frozen = self.frozen.for_memo(&self.measured, atmosphere);
        let mut memo = Memo::new(measured_states, frozen);
        memo.at_point(2 * k);
        PlainSteps {
            simulation: self,
            mask: *mask,
            atmosphere: *atmosphere,
            inputs: self.stage_inputs(k),
            start: (self.controls[k], self.pseudo_rates(k)),
            memo,
            first: None,
        }
    }

    /// Simulates from `initial`, calling `sink(k, y, (∂y/∂θ)ᵀ)` at every
    /// grid point with the `outputs` and their sensitivities to the unknowns
    /// described by `columns` (none: a plain simulation), an output's
    /// sensitivities a column of the transposed matrix. The state takes
    /// plain RK4 steps; the model is linearised at the grid points only, and
    /// the sensitivities S = ∂x/∂θ of the integrated states take the
    /// matching RK4 step of Ṡ = (∂f/∂x)·S + ∂f/∂θ with the linearisations
    /// of the step's two ends ([`rk4_linear_step`]): one linearisation per
    /// step instead of one per stage, for a Jacobian within O(h²) of the
    /// derivative of the discrete simulation (measured in the output-error
    /// test against central differences); ∂y/∂θ = ∂g/∂x·S + ∂g/∂θ. ∂f/∂x
    /// and ∂g/∂x are exact, by dual numbers along the integrated states
    /// (forward-mode automatic differentiation, [`aeroid_numerics::dual`]; the first
    /// pass's values are the evaluation at x), except along the altitude and
    /// for models whose forces depend on α̇, where they are forward
    /// differences; for a term C_term of coefficient C, f is linear
    /// in C, and ∂f/∂θ = (∂f/∂C)·regressor with ∂f/∂C exact from the
    /// evaluation (`Response::Offset`), or the difference quotient of an
    /// offset on C where the forces depend on α̇; a nonlinear parameter's is
    /// a forward difference.
    /// Err with the time when the model departs (non-finite, |α| or |β|
    /// beyond 90°, airspeed not positive).
    pub fn simulate(
        &self,
        model: &FlightModel,
        initial: &FlightPathState,
        outputs: &[Observable],
        columns: &[Column],
        linearise: Linearise,
        mut sink: impl FnMut(usize, &[f64], &DMatrix<f64>),
    ) -> std::result::Result<(), String> {
        let aero = &model.aircraft.aero;
        let mut x = self.merge(initial, &self.measured[0]);
        let chi_from_alpha = aero.chi_is_state() && !self.integrate[CHI];
        if chi_from_alpha {
            x[CHI] = aero.steady_separation(x[ALPHA]);
        }
        let mask = self.mask(model);
        let active: Vec<usize> = (0..FLIGHT_PATH_SIZE).filter(|&i| mask[i] == 1.0).collect();
        let linearised: &[usize] = if columns.is_empty() { &[] } else { &active };
        let directions = Directions::new(model, columns, linearised, false);
        let states = &directions.states;
        let row = |state: usize| states.iter().position(|&i| i == state);
        // S over the active states: the others are measured, independent of θ.
        let mut sensitivity = DMatrix::zeros(states.len(), columns.len());
        for (j, column) in columns.iter().enumerate() {
            if let Column::Initial(i) = *column {
                sensitivity[(row(i).expect("an integrated state"), j)] = 1.0;
            }
            if let (true, Some(chi)) = (chi_from_alpha, row(CHI)) {
                // χ(0) = χ∞(α(0)) moves with α(0) and the stall parameters.
                let target =
                    |model: &FlightModel, alpha: f64| model.aircraft.aero.steady_separation(alpha);
                sensitivity[(chi, j)] = match (*column, directions.sources[j]) {
                    (Column::Initial(ALPHA), _) => {
                        let step = state_step(x[ALPHA]);
                        (target(model, x[ALPHA] + step) - x[CHI]) / step
                    }
                    (_, Source::Direction(d)) => match directions.responses[d] {
                        Response::Model(m) => {
                            let (perturbed, step, _) = &directions.models[m];
                            (target(perturbed, x[ALPHA]) - x[CHI]) / step
                        }
                        Response::Offset(_) => 0.0,
                    },
                    _ => 0.0,
                };
            }
        }
        let shape = || DMatrix::zeros(states.len(), columns.len());
        let mut work = [(); 3].map(|_| shape());
        let (mut middle_a, mut middle_b, mut end_b) =
            (DMatrix::zeros(states.len(), states.len()), shape(), shape());
        // Outputs that are states are x's entries, their sensitivities S's
        // rows (none for a measured state); the others are linearised.
        let mut computed = Vec::new();
        let sources: Vec<OutputSource> = outputs
            .iter()
            .map(|output| match *output {
                Observable::State(index) => OutputSource::State {
                    index,
                    row: row(index),
                },
                other => {
                    computed.push(other);
                    OutputSource::Linearised(computed.len() - 1)
                }
            })
            .collect();
        let mut values = vec![0.0; outputs.len()];
        // (∂y/∂θ)ᵀ: each output's sensitivities contiguous.
        let mut output_sensitivity = DMatrix::zeros(columns.len(), outputs.len());
        let mut computed_sensitivity = DMatrix::zeros(computed.len(), columns.len());
        let mut point = Linearization::new(&directions, computed.len());
        let mut next_point = Linearization::new(&directions, computed.len());
        let exact = linearise == Linearise::Stages && !columns.is_empty();
        let mut stages: Vec<Linearization> = (0..if exact { 3 } else { 0 })
            .map(|_| Linearization::new(&directions, 0))
            .collect();
        let atmosphere = &model.environment.atmosphere;
        let measured_states = std::array::from_fn(|i| mask[i] == 0.0);
        let frozen = self.frozen.for_memo(&self.measured, atmosphere);
        let mut memo = Memo::new(measured_states, frozen);
        point.at(
            model,
            &directions,
            &x,
            &self.controls[0],
            self.pseudo_rates(0),
            &computed,
            &mut memo,
        );
        for k in 0..self.len() {
            check_departure(&x, self.time(k))?;
            if !columns.is_empty() {
                // ∂y/∂θ = ∂g/∂x·S + ∂g/∂θ
                affine(
                    &point.gx,
                    &sensitivity,
                    &point.gtheta,
                    &mut computed_sensitivity,
                );
            }
            let sensitivities = !columns.is_empty();
            for (o, source) in sources.iter().enumerate() {
                let mut into = output_sensitivity.column_mut(o);
                match *source {
                    OutputSource::State { index, row } => {
                        values[o] = x[index];
                        match row {
                            Some(r) if sensitivities => into.tr_copy_from(&sensitivity.row(r)),
                            _ => into.fill(0.0),
                        }
                    }
                    OutputSource::Linearised(c) => {
                        values[o] = point.outputs[c];
                        if sensitivities {
                            into.tr_copy_from(&computed_sensitivity.row(c));
                        }
                    }
                }
            }
            sink(k, &values, &output_sensitivity);
            if k + 1 == self.len() {
                break;
            }
            let end_pseudo = self.pseudo_rates(k + 1);
            let mut stage = 0;
            x = self.step_from(
                &self.stage_inputs(k),
                &x,
                &mask,
                &point.rates,
                &mut memo,
                |merged, controls, pseudo, memo| {
                    if exact {
                        let linearization = &mut stages[stage];
                        stage += 1;
                        linearization.at(model, &directions, merged, controls, pseudo, &[], memo);
                        linearization.rates
                    } else {
                        let (angles, air) = memo.of(merged, atmosphere);
                        derivative(model, merged, &angles, &air, controls, pseudo).0
                    }
                },
            );
            memo.restart();
            memo.at_point(2 * (k + 1));
            next_point.at(
                model,
                &directions,
                &x,
                &self.controls[k + 1],
                end_pseudo,
                &computed,
                &mut memo,
            );
            if exact {
                let stages = [
                    (&point.a, &point.b),
                    (&stages[0].a, &stages[0].b),
                    (&stages[1].a, &stages[1].b),
                    (&stages[2].a, &stages[2].b),
                ];
                rk4_linear_step(&mut sensitivity, self.step, stages, &mut work);
            } else if !columns.is_empty() {
                // The step's last stage sees the controls at θ = 1, which
                // under a hold are the step's start values: the terms'
                // regressors are taken with those (∂f/∂x keeps the grid
                // point's controls: part of the O(h) approximation at a
                // control step that `Linearise::GridPoints` accepts).
                let end_b = if self.holds.iter().all(|h| h.weight(1.0) == 1.0) {
                    &next_point.b
                } else {
                    let controls = self.controls_inside(k, 1.0);
                    next_point.b_with_controls(model, &directions, &controls, &mut end_b);
                    &end_b
                };
                mean(&point.a, &next_point.a, &mut middle_a);
                mean(&point.b, end_b, &mut middle_b);
                let stages = [
                    (&point.a, &point.b),
                    (&middle_a, &middle_b),
                    (&middle_a, &middle_b),
                    (&next_point.a, end_b),
                ];
                rk4_linear_step(&mut sensitivity, self.step, stages, &mut work);
            }
            std::mem::swap(&mut point, &mut next_point);
        }
        Ok(())
    }
}

/// The inputs of step k's later RK4 stages ([`DrivenSimulation::stage_inputs`]):
/// the measured state, controls and pseudo-control rates at its midpoint
/// and at its end.
pub(super) struct StageInputs {
    k: usize,
    middle: (FlightPathState, Controls, PseudoRates),
    end: (FlightPathState, Controls, PseudoRates),
}

/// Plain steps from one grid point for many start states (and models that
/// differ in their parameters only: the sigma points of an unscented
/// filter), with what they share taken once: the stages' inputs and
/// frozen points, and the first stage's angles and air for start states
/// equal to the last one's, with their kinematics and forcing
/// ([`DrivenSimulation::plain_steps`]). Each step
/// is the one a fresh simulation takes from its start state, bit for bit.
pub(super) struct PlainSteps<'a> {
    simulation: &'a DrivenSimulation,
    mask: FlightPathState,
    atmosphere: Atmosphere,
    inputs: StageInputs,
    /// The controls and pseudo-control rates at the grid point.
    start: (Controls, PseudoRates),
    /// A fresh memo at the grid point.
    memo: Memo<'a>,
    /// The last start state, its memo after the first stage and the
    /// angles, kinematics and forcing that stage took.
    first: Option<(FlightPathState, Memo<'a>, Angles, Kinematics, Forcing)>,
}

impl PlainSteps<'_> {
    /// One plain step of `model` from the full flight-path state `x`
    /// ([`DrivenSimulation::step_from`]). `model` has the form the steps
    /// were made for (its atmosphere, the states it integrates).
    pub(super) fn step(&mut self, model: &FlightModel, x: &FlightPathState) -> FlightPathState {
        let (controls, pseudo) = &self.start;
        let (_, memo, angles, kinematics, forcing) = match &self.first {
            Some(first) if first.0 == *x => first,
            _ => {
                let mut memo = self.memo;
                let (angles, air) = memo.of(x, &self.atmosphere);
                let kinematics = kinematics(x, &angles, &air);
                let forcing = model.forcing(&kinematics, controls);
                &*self.first.insert((*x, memo, angles, kinematics, forcing))
            }
        };
        let mut memo = *memo;
        let (first, _) = derivative_at(model, x, angles, kinematics, forcing, *pseudo);
        let atmosphere = &self.atmosphere;
        self.simulation.step_from(
            &self.inputs,
            x,
            &self.mask,
            &first,
            &mut memo,
            |x, controls, pseudo, memo| {
                let (angles, air) = memo.of(x, atmosphere);
                derivative(model, x, &angles, &air, controls, pseudo).0
            },
        )
    }
}

/// Where a simulation's output comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum OutputSource {
    /// A state (index into x): its value, and its sensitivities the row of
    /// S (None: a measured state, independent of θ).
    State { index: usize, row: Option<usize> },
    /// A linearised output (index into the linearisation's outputs).
    Linearised(usize),
}

/// into = (a + b)/2.
fn mean(a: &DMatrix<f64>, b: &DMatrix<f64>, into: &mut DMatrix<f64>) {
    into.as_mut_slice()
        .iter_mut()
        .zip(a.as_slice().iter().zip(b.as_slice()))
        .for_each(|(into, (a, b))| *into = 0.5 * (a + b));
}

fn missing_altitude() -> Error {
    Error::Other(format!(
        "the model needs the measured channel 'altitude' (it is not integrated), or '{}', '{}' or '{}' instead, but the record has none",
        ALTITUDE_SUBSTITUTES[0], ALTITUDE_SUBSTITUTES[1], ALTITUDE_SUBSTITUTES[2]
    ))
}

fn missing(name: &str) -> Error {
    Error::Other(format!(
        "the model needs the measured channel '{name}' (it is not integrated), but the record has none"
    ))
}

pub(super) fn check_departure(x: &FlightPathState, time: f64) -> std::result::Result<(), String> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::{ModelStructure, stall_test_structure};

    /// The derivative tests' models: a wind-axis stall model with χ a
    /// state, τ2 = 0.2 (χ̇ moves with α̇), an Oswald and a CL² drag term; the
    /// body-axis CDRW model; the lateral model with measured airspeed and
    /// sideslip rates.
    fn test_models() -> [(ModelStructure, PseudoRates); 3] {
        [
            (stall_test_structure(0.2), PseudoRates::default()),
            (
                ModelStructure::load("cdrw-longitudinal").unwrap(),
                PseudoRates::default(),
            ),
            (
                ModelStructure::load("attas-lateral").unwrap(),
                PseudoRates {
                    airspeed: Some(0.3),
                    beta: Some(0.02),
                },
            ),
        ]
    }

    /// The record's measured quantities replace the model's own
    /// ([`Ambient`]): given the ISA's density at the altitude and the
    /// propulsion model's thrust as measured, the rates and outputs are the
    /// model's own to rounding (1e-12); a measured density 1 % lower makes
    /// q̄ 1 % lower (1e-12); a measured thrust 1 kN higher moves nx by
    /// exactly the thrust line's x component of 1 kN/(m·g0), and the
    /// throttle then moves nothing.
    #[test]
    fn measured_density_and_thrust_replace_the_models() {
        let structure = ModelStructure::load("attas-longitudinal").unwrap();
        let model = FlightModel::new(structure.aircraft.clone(), Default::default());
        let (x, controls) = test_point();
        let outputs = ["nx", "dynamic_pressure"].map(|name| Observable::parse(name).unwrap());
        let air = model.environment.atmosphere.at(x[ALTITUDE]);
        let propulsion = &model.aircraft.propulsion;
        let thrust = propulsion.thrust(controls[Control::Throttle.index()], air.log_density_ratio);
        assert!(thrust > 1e3);
        let pseudo = PseudoRates::default();
        let at = |ambient: Ambient, controls: &Controls| {
            evaluate(&model, &x, controls, pseudo, ambient, &outputs)
        };
        let (rates, own) = at(Ambient::default(), &controls);
        let measured = Ambient {
            density: Some(air.density),
            thrust: Some(thrust),
            alpha_dot: None,
        };
        let (same_rates, same) = at(measured, &controls);
        assert!((same_rates - rates).amax() <= 1e-12 * rates.amax());
        for (a, b) in same.iter().zip(&own) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
        }
        let thinner = Ambient {
            density: Some(0.99 * air.density),
            ..measured
        };
        let (_, thin) = at(thinner, &controls);
        assert!((thin[1] / own[1] - 0.99).abs() <= 1e-12);
        let stronger = Ambient {
            thrust: Some(thrust + 1e3),
            ..measured
        };
        let (_, strong) = at(stronger, &controls);
        let expected = propulsion.direction.x * 1e3 / (model.aircraft.mass.mass * STANDARD_GRAVITY);
        assert!(
            (strong[0] - own[0] - expected).abs() <= 1e-12,
            "{strong:?} vs {own:?}"
        );
        let mut throttled = controls;
        throttled[Control::Throttle.index()] = 0.9;
        assert_eq!(at(stronger, &throttled), at(stronger, &controls));
    }

    /// [`rotated`] against the library's sine and cosine, over base angles
    /// through all four quadrants and moves up to ±[`NUDGE_LIMIT`]: within
    /// 4·10⁻¹⁶ (two ulp of 1; measured 2.2·10⁻¹⁶), so the simulation's
    /// angles are the library's to rounding wherever it takes them this way.
    #[test]
    fn rotated_angles_match_the_library() {
        let mut worst: f64 = 0.0;
        for base in (-40..=40).map(|k| k as f64 * 0.0873) {
            for h in (-64..=64).map(|k| k as f64 * NUDGE_LIMIT / 64.0) {
                let (sin, cos) = rotated(base.sin_cos(), h);
                let (expected_sin, expected_cos) = (base + h).sin_cos();
                worst = worst.max((sin - expected_sin).abs().max((cos - expected_cos).abs()));
            }
        }
        assert!(worst <= 4e-16, "largest difference {worst:e}");
    }

    /// A state and controls away from trim, every rate and angle non-zero.
    fn test_point() -> (FlightPathState, Controls) {
        (
            FlightPathState::from_column_slice(&[
                60.0, 0.21, 0.03, 0.05, -0.04, 0.02, 0.1, 0.15, 0.3, 1000.0, 0.6,
            ]),
            Controls::from_column_slice(&[-0.05, 0.02, -0.01, 0.0, 0.5]),
        )
    }

    /// ∂f/∂x and ∂g/∂x by dual numbers, along all eleven flight-path
    /// states (three passes of four lanes; altitude included: its air is
    /// held, as the dual evaluation holds it), against central differences
    /// of the f64 evaluation (step 1e-6·max(|x|, 1), error ~1e-9 relative),
    /// on the wind-axis stall model with χ a state (Kirchhoff factor, χ̇),
    /// the body-axis CDRW model and the lateral model with measured airspeed
    /// and sideslip rates; the values are the f64 evaluation's, bit for bit.
    #[test]
    fn dual_derivatives_match_central_differences() {
        let cases = test_models();
        let outputs = [
            "nx", "ny", "nz", "p_dot", "q_dot", "r_dot", "mach", "CX", "CY", "CZ", "CL", "CD",
            "Cl", "Cm", "Cn",
        ]
        .map(|name| Observable::parse(name).unwrap());
        let (x, controls) = test_point();
        for (structure, pseudo) in cases {
            let model = FlightModel::new(structure.aircraft.clone(), Default::default());
            let air = Surroundings::from(model.environment.atmosphere.at(x[ALTITUDE]));
            let evaluate = |x: &FlightPathState| {
                derivative(&model, x, &Angles::of(x), &air, &controls, pseudo)
            };
            let (rates, at) = evaluate(&x);
            for lanes in (0..FLIGHT_PATH_SIZE).collect::<Vec<_>>().chunks(LANES) {
                let (dual_x, dual_rates, dual_at) = dual_derivative(
                    &model,
                    &x,
                    Angles::of(&x),
                    lanes.iter().copied(),
                    &air,
                    &controls,
                    pseudo,
                );
                assert_eq!(dual_rates.map(Dual::value), rates);
                assert_eq!(dual_at.values(), at);
                for (lane, &i) in lanes.iter().enumerate() {
                    let step = 1e-6 * x[i].abs().max(1.0);
                    let moved = |sign: f64| {
                        let mut moved = x;
                        moved[i] += sign * step;
                        evaluate(&moved)
                    };
                    let ((plus, plus_at), (minus, minus_at)) = (moved(1.0), moved(-1.0));
                    let numeric = (plus - minus) / (2.0 * step);
                    let dual = dual_rates.map(|r| r.tangent[lane]);
                    let scale = numeric.amax().max(1.0);
                    assert!(
                        (dual - numeric).amax() <= 1e-7 * scale,
                        "{}: ∂f/∂x{i}: {dual} vs {numeric}",
                        structure.name
                    );
                    for output in outputs {
                        let dual = output.value(&dual_x, &dual_at).tangent[lane];
                        let numeric = (output.value(&x, &plus_at) - output.value(&x, &minus_at))
                            / (2.0 * step);
                        assert!(
                            (dual - numeric).abs() <= 1e-7 * numeric.abs().max(1.0),
                            "{}: ∂{output:?}/∂x{i}: {dual} vs {numeric}",
                            structure.name
                        );
                    }
                }
            }
        }
    }

    /// The exact coefficient responses ([`offset_evaluation`]) against
    /// central differences of models with the coefficient's offset moved by
    /// ±10⁻⁵ (exact for the quadratic CL² drag; rounding ~10⁻¹⁰), for every
    /// coefficient, flight-path rate and output: wind axes with an Oswald
    /// term, a CL² drag term and a stall model whose χ̇ moves with α̇ (τ2);
    /// body axes (CDRW); and the lateral model with measured airspeed and
    /// sideslip rates.
    #[test]
    fn coefficient_responses_match_perturbed_models() {
        let cases = test_models();
        let outputs = [
            "airspeed", "alpha", "beta", "p", "q", "r", "chi", "nx", "ny", "nz", "p_dot", "q_dot",
            "r_dot", "CX", "CY", "CZ", "CL", "CD", "Cl", "Cm", "Cn",
        ]
        .map(|name| Observable::parse(name).unwrap());
        for (structure, pseudo) in cases {
            let model = FlightModel::new(structure.aircraft.clone(), Default::default());
            assert!(!model.aircraft.aero.forces_depend_on_alpha_dot());
            let (x, controls) = test_point();
            let (angles, air) = (
                Angles::of(&x),
                Surroundings::from(model.environment.atmosphere.at(x[ALTITUDE])),
            );
            let (rates, at) = derivative(&model, &x, &angles, &air, &controls, pseudo);
            for coefficient in Coefficient::ALL {
                let offset = offset_response(&model, &at, coefficient);
                let moved = offset_evaluation(&at, &offset);
                let exact = flight_path_rates(&x, &angles, &Motion::of(&moved), pseudo) - rates;
                // The rates' response as the linearisation takes it: the
                // part of the rates linear in the accelerations.
                let direct = motion_rates(
                    &x,
                    &angles,
                    &Motion::of(&at).response(&offset.1, offset.2),
                    pseudo.linear(),
                );
                assert!(
                    (exact - direct).amax() <= 1e-12 * exact.amax().max(1.0),
                    "{}: {coefficient:?}: rates {exact} vs {direct}",
                    structure.name
                );
                let step = 1e-5;
                let shifted = |sign: f64| {
                    let mut perturbed = model.clone();
                    perturbed.aircraft.aero.offsets[coefficient as usize] += sign * step;
                    derivative(&perturbed, &x, &angles, &air, &controls, pseudo)
                };
                let ((plus, plus_eval), (minus, minus_eval)) = (shifted(1.0), shifted(-1.0));
                let numeric = (plus - minus) / (2.0 * step);
                let scale = numeric.amax().max(1.0);
                assert!(
                    (exact - numeric).amax() <= 1e-6 * scale,
                    "{}: {coefficient:?}: rates {exact} vs {numeric}",
                    structure.name
                );
                for output in outputs {
                    let exact = output.value(&x, &moved) - output.value(&x, &at);
                    let numeric = (output.value(&x, &plus_eval) - output.value(&x, &minus_eval))
                        / (2.0 * step);
                    assert!(
                        (exact - numeric).abs() <= 1e-6 * numeric.abs().max(1.0),
                        "{}: {coefficient:?}: {output:?} {exact} vs {numeric}",
                        structure.name
                    );
                }
            }
        }
    }
}
