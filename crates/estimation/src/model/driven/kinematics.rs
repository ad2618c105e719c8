//! The flight-path rates of a postulated model at one state, over f64 and
//! over dual numbers ([`aeroid_numerics::dual`]): the kinematics with no
//! wind (body velocity V·(cos α cos β, sin β, sin α cos β), the Euler
//! angles' rotation, air data from V, α, β), the simulator's evaluation
//! ([`FlightModel::evaluate_forced`]) and its conversion to
//! x = [V, α, β, p, q, r, φ, θ, ψ, h, χ]:
//! `V̇ = V·V̇_b/V`, `φ̇ = p + tan θ·(q sin φ + r cos φ)`,
//! `θ̇ = q cos φ − r sin φ`, `ḣ = −ḋ`; where a measured state's rate enters
//! an integrated state's equation (the decoupled models of the reflex-wing
//! UAV paper, Eqs. 5–8) the measured rate is used ([`PseudoRates`]).
//! Also a coefficient's exact response (f is affine in C when the forces
//! do not depend on α̇), and the sines and cosines of an angle moved by a
//! small step by the addition theorems ([`rotated`]).

use super::measured::Surroundings;
use super::{
    AIRSPEED, ALPHA, ALTITUDE, BETA, CHI, FLIGHT_PATH_SIZE, FlightPathState, P, PITCH, ROLL,
};
use aeroid_numerics::dual::{Dual, Real};
use aeroid_sim::aero::{AeroCoefficients, Coefficient};
use aeroid_sim::dynamics::{Accelerations, AirData, Evaluation, FlightModel, Forcing, Kinematics};
use aeroid_sim::state::{self, Controls, SinCos};
use nalgebra::{SVector, Vector3};

/// The largest move of an angle (rad) whose sine and cosine
/// [`Angles::moved_from`] takes by [`rotated`]: a simulation's integrated
/// angles move by a few hundredths of a radian within a step.
pub(super) const NUDGE_LIMIT: f64 = 1.0 / 32.0;

/// The sine and cosine of an angle moved by h (|h| ≤ [`NUDGE_LIMIT`]) from
/// one whose sine and cosine are `(sin, cos)`: by the addition theorems,
/// with sin h and cos h from their Taylor series to h⁷ and h⁸ (the first
/// terms left out, h⁹/9! and h¹⁰/10!, are below 10⁻¹⁹ there), within an
/// ulp or two of the library's sine and cosine.
pub(super) fn rotated((sin, cos): SinCos, h: f64) -> SinCos {
    let h2 = h * h;
    let sin_h = h * (1.0 + h2 * (-1.0 / 6.0 + h2 * (1.0 / 120.0 + h2 * (-1.0 / 5040.0))));
    let cos_h = 1.0 + h2 * (-0.5 + h2 * (1.0 / 24.0 + h2 * (-1.0 / 720.0 + h2 * (1.0 / 40320.0))));
    (sin * cos_h + cos * sin_h, cos * cos_h - sin * sin_h)
}

/// Sines and cosines of a flight-path state's angles α, β, φ, θ. The
/// heading ψ enters none of the flight-path rates (gravity in body axes and
/// the climb rate do not depend on it), so it is not needed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Angles<T: Real = f64> {
    pub(super) alpha: (T, T),
    pub(super) beta: (T, T),
    roll: (T, T),
    pitch: (T, T),
}

impl<T: Real> Angles<T> {
    /// The sine and cosine of state `i`, if it is one of the angles.
    pub(super) fn slot(&mut self, i: usize) -> Option<&mut (T, T)> {
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
    pub(super) const ZERO: Angles = Angles {
        alpha: (0.0, 1.0),
        beta: (0.0, 1.0),
        roll: (0.0, 1.0),
        pitch: (0.0, 1.0),
    };

    pub(super) fn of(x: &FlightPathState) -> Angles {
        Angles {
            alpha: x[ALPHA].sin_cos(),
            beta: x[BETA].sin_cos(),
            roll: x[ROLL].sin_cos(),
            pitch: x[PITCH].sin_cos(),
        }
    }

    /// The sine and cosine of state `i`, if it is one of the angles.
    pub(super) fn get(mut self, i: usize) -> Option<SinCos> {
        self.slot(i).copied()
    }

    /// The angles after state `i` moved by a difference step `h` (|h| ≲
    /// 10⁻⁶): no sine or cosine evaluated ([`rotated`]).
    pub(super) fn nudged(mut self, i: usize, h: f64) -> Angles {
        if let Some(slot) = self.slot(i) {
            *slot = rotated(*slot, h);
        }
        self
    }

    /// The angles after state `i` moved to `value` (only that one recomputed).
    pub(super) fn moved(mut self, i: usize, value: f64) -> Angles {
        if let Some(slot) = self.slot(i) {
            *slot = value.sin_cos();
        }
        self
    }

    /// The angles with state `i` at `value`, its sine and cosine those of
    /// `anchor` (an angle and its sine and cosine) [`rotated`] by the move,
    /// if it is at most [`NUDGE_LIMIT`], else the library's. Returns
    /// whether the library was used.
    pub(super) fn moved_from(
        &mut self,
        i: usize,
        (angle, sin_cos): (f64, SinCos),
        value: f64,
    ) -> bool {
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

/// The kinematics of a flight-path state with no wind: body velocity
/// V·(cos α cos β, sin β, sin α cos β), the Euler angles' rotation (ψ = 0:
/// see [`Angles`]), air data straight from V, α, β.
#[inline(always)]
pub(super) fn kinematics<T: Real>(
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
    pub(super) fn linear(self) -> PseudoRates {
        PseudoRates {
            airspeed: self.airspeed.map(|_| 0.0),
            beta: self.beta.map(|_| 0.0),
        }
    }

    /// The rates a fraction θ into a step from `self` to `end`.
    pub(super) fn blend(self, end: PseudoRates, theta: f64) -> PseudoRates {
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
/// `angles` and `air` are x's (computed once per evaluation;
/// [`Linearization::at`](super::linearise::Linearization::at) reuses them
/// for every perturbed model).
#[inline(always)]
pub(super) fn derivative<T: Real>(
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
pub(super) fn derivative_at<T: Real>(
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
pub(super) fn dual_derivative(
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
pub(super) struct Motion<T: Real = f64> {
    velocity: Vector3<T>,
    pub(super) airspeed: T,
    /// u̇, v̇, ẇ.
    velocity_rate: Vector3<T>,
    pub(super) alpha_dot: T,
    beta_dot: T,
    pub(super) angular_acceleration: Vector3<T>,
    down_rate: T,
    chi_rate: T,
}

impl<T: Real> Motion<T> {
    pub(super) fn of(evaluation: &Evaluation<T>) -> Motion<T> {
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
    pub(super) fn response(self, response: &Accelerations, chi_rate: f64) -> Motion {
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
pub(super) fn flight_path_rates<T: Real>(
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
pub(super) fn motion_rates<T: Real>(
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
pub(super) fn offset_response(
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
pub(super) fn offset_evaluation(
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
