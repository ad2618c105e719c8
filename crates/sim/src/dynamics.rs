//! Rigid-body six-degree-of-freedom equations of motion over a flat,
//! non-rotating earth, in body axes with quaternion attitude (the standard
//! form, e.g. Stevens, Lewis & Johnson, "Aircraft Control and Simulation",
//! 3rd ed., §1.7, and the reflex-wing UAV paper, Eqs. 1–8, in their decoupled form):
//!
//! `m·(V̇ + ω × V) = F_aero + F_thrust + m·C_bn·g`,
//! `I·ω̇ + ω × (I·ω) = M_aero + r_T × F_thrust`,
//! `q̇ = ½·q ⊗ (0, ω)`, `ṗ_NED = C_nb·V`, `τ1·χ̇ = χ∞(α − τ2·α̇) − χ`.
//!
//! V is the inertial velocity in body axes; air data (V, α, β, q̄, Mach) are
//! taken relative to the air mass moving with the wind. α̇ comes from the
//! state derivative (never from differencing outputs); when the forces depend
//! on α̇ (α̇ terms, or χ algebraic with τ2 ≠ 0) the equations are solved for α̇
//! by secant iteration.
//!
//! [`FlightModel::evaluate`] is usable outside the integrator, state by state,
//! as the filter estimators need.

use crate::aero::{AeroCoefficients, AeroInput};
use crate::aircraft::Aircraft;
use crate::atmosphere::{Air, Atmosphere};
use crate::integrator::Interpolation;
use crate::state::{
    self, CHI, CONTROL_COUNT, Control, Controls, DOWN, NORTH, P, Q0, STATE_SIZE, StateVector, U,
};
use crate::wind::WindSample;
use aeroid_numerics::dual::Real;
use nalgebra::{Matrix3, SVector, Vector3};

/// The environment the aircraft flies in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Environment {
    pub atmosphere: Atmosphere,
    /// Gravitational acceleration (m/s²); 0 switches gravity off.
    pub gravity: f64,
}

impl Default for Environment {
    fn default() -> Self {
        Environment {
            atmosphere: Atmosphere::default(),
            gravity: aeroid_core::units::STANDARD_GRAVITY,
        }
    }
}

/// Everything from outside the state at one instant: controls and wind, and
/// their rates within the step (zero under a zero-order hold).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Exogenous {
    pub controls: Controls,
    pub wind: WindSample,
    pub wind_rate: WindSample,
}

/// Exogenous signals packed as one vector for interpolation: controls, wind NED, turbulence body.
pub(crate) const EXOGENOUS_SIZE: usize = CONTROL_COUNT + 6;
/// An [`Exogenous`] packed as one vector (see [`EXOGENOUS_SIZE`]).
pub(crate) type ExogenousVector = SVector<f64, EXOGENOUS_SIZE>;

impl Exogenous {
    pub fn pack(controls: &Controls, wind: &WindSample) -> ExogenousVector {
        let mut v = ExogenousVector::zeros();
        v.fixed_rows_mut::<CONTROL_COUNT>(0).copy_from(controls);
        v.fixed_rows_mut::<3>(CONTROL_COUNT).copy_from(&wind.ned);
        v.fixed_rows_mut::<3>(CONTROL_COUNT + 3)
            .copy_from(&wind.body);
        v
    }

    /// The exogenous signals at stage fraction θ of a step between two packed samples.
    pub fn at_stage(
        start: &ExogenousVector,
        end: &ExogenousVector,
        theta: f64,
        interpolation: Interpolation,
        step: f64,
    ) -> Exogenous {
        let value = interpolation.blend(start, end, theta);
        let rate = interpolation.rate(start, end, step);
        Exogenous {
            controls: value.fixed_rows::<CONTROL_COUNT>(0).into(),
            wind: unpack_wind(&value),
            wind_rate: unpack_wind(&rate),
        }
    }
}

fn unpack_wind(v: &ExogenousVector) -> WindSample {
    WindSample {
        ned: v.fixed_rows::<3>(CONTROL_COUNT).into(),
        body: v.fixed_rows::<3>(CONTROL_COUNT + 3).into(),
    }
}

/// Air data relative to the moving air mass (over a [`Real`] scalar, like
/// everything the equations of motion compute).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AirData<T: Real = f64> {
    pub airspeed: T,
    pub alpha: T,
    /// sin α, cos α (the wind-axis forces need them at every evaluation).
    pub alpha_sin_cos: (T, T),
    pub beta: T,
    pub mach: T,
    pub dynamic_pressure: T,
    /// Air-relative velocity in body axes.
    pub velocity: Vector3<T>,
}

impl AirData {
    /// Air data of an air-relative velocity (body axes) whose α and β are known.
    pub fn new(velocity: Vector3<f64>, alpha: f64, beta: f64, air: &Air) -> AirData {
        AirData::with_alpha_sin_cos(velocity, alpha, alpha.sin_cos(), beta, air)
    }
}

impl<T: Real> AirData<T> {
    /// The values, without derivatives.
    pub fn values(&self) -> AirData {
        AirData {
            airspeed: self.airspeed.value(),
            alpha: self.alpha.value(),
            alpha_sin_cos: (self.alpha_sin_cos.0.value(), self.alpha_sin_cos.1.value()),
            beta: self.beta.value(),
            mach: self.mach.value(),
            dynamic_pressure: self.dynamic_pressure.value(),
            velocity: self.velocity.map(T::value),
        }
    }

    /// As [`AirData::new`], with α's sine and cosine already computed.
    #[inline(always)]
    pub fn with_alpha_sin_cos(
        velocity: Vector3<T>,
        alpha: T,
        alpha_sin_cos: (T, T),
        beta: T,
        air: &Air,
    ) -> AirData<T> {
        // |v| as nalgebra's norm computes it, √(v·v).
        let airspeed = velocity.dot(&velocity).sqrt();
        AirData {
            airspeed,
            alpha,
            alpha_sin_cos,
            beta,
            mach: match air.mach {
                Some(mach) => T::constant(mach),
                None => airspeed / air.speed_of_sound,
            },
            dynamic_pressure: airspeed * (0.5 * air.density) * airspeed,
            velocity,
        }
    }
}

/// The state derivative together with every intermediate quantity a truth
/// trace or a recorder needs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Evaluation<T: Real = f64> {
    pub derivative: SVector<T, STATE_SIZE>,
    pub air: Air,
    pub air_data: AirData<T>,
    pub alpha_dot: T,
    pub beta_dot: T,
    /// χ the forces used (state, algebraic value, or 1).
    pub chi: T,
    pub coefficients: AeroCoefficients<T>,
    /// The flight variables the aerodynamic model was evaluated at.
    pub aero_input: AeroInput<T>,
    /// Controls after saturation.
    pub controls: Controls,
    pub thrust: f64,
    /// Specific force (what an accelerometer at the CG reads), body axes, m/s².
    pub specific_force: Vector3<T>,
    pub angular_acceleration: Vector3<T>,
}

impl<T: Real> Evaluation<T> {
    /// The evaluation's values, without derivatives (over a
    /// [`aeroid_numerics::dual::Dual`], the same numbers as the f64 evaluation).
    pub fn values(&self) -> Evaluation {
        Evaluation {
            derivative: self.derivative.map(T::value),
            air: self.air,
            air_data: self.air_data.values(),
            alpha_dot: self.alpha_dot.value(),
            beta_dot: self.beta_dot.value(),
            chi: self.chi.value(),
            coefficients: self.coefficients.values(),
            aero_input: self.aero_input.values(),
            controls: self.controls,
            thrust: self.thrust,
            specific_force: self.specific_force.map(T::value),
            angular_acceleration: self.angular_acceleration.map(T::value),
        }
    }
}

/// What an evaluation of the equations of motion takes besides the
/// kinematics and the aerodynamic model ([`FlightModel::forcing`]): the
/// controls after saturation, the thrust, and in body axes gravity and the
/// thrust force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Forcing<T: Real = f64> {
    pub controls: Controls,
    pub thrust: f64,
    gravity_body: Vector3<T>,
    thrust_force: Vector3<f64>,
}

/// What the equations of motion need of the state and the wind at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinematics<T: Real = f64> {
    /// Inertial velocity, body axes.
    pub velocity: Vector3<T>,
    /// Body rates p, q, r.
    pub omega: Vector3<T>,
    /// NED→body rotation.
    pub ned_to_body: Matrix3<T>,
    pub air: Air,
    pub air_data: AirData<T>,
    /// The separation point state χ.
    pub chi: T,
    /// Rate of the wind, body axes, as seen from the rotating body.
    pub wind_rate_body: Vector3<T>,
    /// A measured thrust (N, along the thrust line) that replaces the
    /// propulsion model's δT·Tmax·(ρ/ρ0)ⁿ; None: the propulsion model.
    pub thrust: Option<f64>,
    /// The derivative of the measured α (rad/s), for a stall model whose
    /// separation takes it (`alpha_dot = "measured"`); None: the state's α̇.
    pub measured_alpha_dot: Option<f64>,
}

/// An aircraft in an environment: the right-hand side of the equations of motion.
#[derive(Debug, Clone, PartialEq)]
pub struct FlightModel {
    pub aircraft: Aircraft,
    pub environment: Environment,
}

/// Forces of one α̇ guess.
struct Translational<T: Real> {
    coefficients: AeroCoefficients<T>,
    input: AeroInput<T>,
    chi: T,
    accelerations: Accelerations<T>,
}

/// What the aerodynamic coefficients give at one instant: affine in the
/// coefficients (see [`FlightModel::acceleration_response`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Accelerations<T: Real = f64> {
    /// Specific force, body axes, m/s².
    pub specific_force: Vector3<T>,
    /// u̇, v̇, ẇ.
    pub velocity_rate: Vector3<T>,
    pub alpha_dot: T,
    pub beta_dot: T,
    /// ṗ, q̇, ṙ.
    pub angular_acceleration: Vector3<T>,
}

impl FlightModel {
    pub fn new(aircraft: Aircraft, environment: Environment) -> Self {
        FlightModel {
            aircraft,
            environment,
        }
    }

    /// Air data for a state and wind, given the state's NED→body rotation.
    pub fn air_data(
        x: &StateVector,
        ned_to_body: &Matrix3<f64>,
        wind: &WindSample,
        air: &Air,
    ) -> AirData {
        let velocity = state::velocity(x) - ned_to_body * wind.ned - wind.body;
        let airspeed = velocity.norm();
        AirData::new(
            velocity,
            velocity.z.atan2(velocity.x),
            (velocity.y / airspeed).clamp(-1.0, 1.0).asin(),
            air,
        )
    }

    /// ẋ = f(x, u). Allocation-free.
    #[inline]
    pub fn derivative(&self, x: &StateVector, exogenous: &Exogenous) -> StateVector {
        self.evaluate(x, exogenous).derivative
    }

    /// The state derivative and all intermediate quantities at one state.
    #[inline(always)]
    pub fn evaluate(&self, x: &StateVector, exogenous: &Exogenous) -> Evaluation {
        let air = self.environment.atmosphere.at(state::altitude(x));
        let ned_to_body = state::body_to_ned(x).transpose();
        let air_data = Self::air_data(x, &ned_to_body, &exogenous.wind, &air);
        let omega = state::rates(x);
        let wind_rate_body = ned_to_body * exogenous.wind_rate.ned
            - omega.cross(&(ned_to_body * exogenous.wind.ned))
            + exogenous.wind_rate.body;
        let mut evaluation = self.evaluate_kinematics(
            &Kinematics {
                velocity: state::velocity(x),
                omega,
                ned_to_body,
                air,
                air_data,
                chi: x[CHI],
                wind_rate_body,
                thrust: None,
                measured_alpha_dot: None,
            },
            &exogenous.controls,
        );
        evaluation
            .derivative
            .fixed_rows_mut::<4>(Q0)
            .copy_from(&quaternion_rate(x, &omega));
        evaluation
    }

    /// The equations of motion from the kinematic quantities they need (the
    /// attitude enters only through `ned_to_body`). The quaternion rate is
    /// left 0: it is the caller's, who knows the attitude's parametrisation.
    #[inline(always)]
    pub fn evaluate_kinematics<T: Real>(
        &self,
        kinematics: &Kinematics<T>,
        controls: &Controls,
    ) -> Evaluation<T> {
        self.evaluate_forced(kinematics, &self.forcing(kinematics, controls))
    }

    /// What an evaluation at `kinematics` with `controls` takes besides the
    /// aerodynamic model ([`Forcing`]): the same for models that differ in
    /// their aerodynamic parameters only.
    #[inline(always)]
    pub fn forcing<T: Real>(&self, kinematics: &Kinematics<T>, controls: &Controls) -> Forcing<T> {
        let aircraft = &self.aircraft;
        let mut controls = *controls;
        aircraft.saturate(&mut controls);
        let thrust = kinematics.thrust.unwrap_or_else(|| {
            aircraft.propulsion.thrust(
                controls[Control::Throttle.index()],
                kinematics.air.log_density_ratio,
            )
        });
        Forcing {
            controls,
            thrust,
            gravity_body: kinematics
                .ned_to_body
                .column(2)
                .map(|e| e * self.environment.gravity),
            thrust_force: aircraft.propulsion.direction * thrust,
        }
    }

    /// [`FlightModel::evaluate_kinematics`] with its [`Forcing`] given (this
    /// model's, or that of one that differs in its aerodynamic parameters
    /// only).
    #[inline(always)]
    pub fn evaluate_forced<T: Real>(
        &self,
        kinematics: &Kinematics<T>,
        forcing: &Forcing<T>,
    ) -> Evaluation<T> {
        let aircraft = &self.aircraft;
        let Kinematics {
            velocity,
            ned_to_body,
            air,
            air_data,
            ..
        } = kinematics;
        let (controls, thrust) = (forcing.controls, forcing.thrust);
        let context = TranslationalContext {
            kinematics,
            controls: &controls,
            gravity_body: forcing.gravity_body,
            thrust_force: forcing.thrust_force,
        };
        let measured_alpha_dot = kinematics.measured_alpha_dot.is_some();
        let translational = if aircraft
            .aero
            .forces_depend_on_state_alpha_dot(measured_alpha_dot)
        {
            self.solve_alpha_dot(&context)
        } else {
            self.translational(&context, T::zero())
        };
        let Accelerations {
            specific_force,
            velocity_rate,
            alpha_dot,
            beta_dot,
            angular_acceleration,
        } = translational.accelerations;
        let mut derivative = SVector::<T, STATE_SIZE>::zeros();
        derivative.fixed_rows_mut::<3>(U).copy_from(&velocity_rate);
        derivative
            .fixed_rows_mut::<3>(P)
            .copy_from(&angular_acceleration);
        derivative
            .fixed_rows_mut::<3>(NORTH)
            .copy_from(&ned_to_body.tr_mul(velocity));
        derivative[CHI] = aircraft.aero.separation_rate(
            air_data.alpha,
            aircraft
                .aero
                .separation_alpha_dot(alpha_dot, kinematics.measured_alpha_dot),
            kinematics.chi,
            air_data.airspeed,
        );
        debug_assert_eq!(DOWN, NORTH + 2);
        Evaluation {
            derivative,
            air: *air,
            air_data: *air_data,
            alpha_dot,
            beta_dot,
            chi: translational.chi,
            coefficients: translational.coefficients,
            aero_input: translational.input,
            controls,
            thrust,
            specific_force,
            angular_acceleration,
        }
    }

    /// How the accelerations change when the aerodynamic coefficients move
    /// by `direction` (other things equal), at air data `air_data`: exact,
    /// `FlightModel::accelerations` being affine in the coefficients, and
    /// computed as its linear part alone (the aerodynamic force and moment
    /// of `direction`, with no gravity, thrust or gyroscopic terms). Valid
    /// when the forces do not depend on α̇ (else the coefficients move with
    /// α̇ too).
    pub fn acceleration_response(
        &self,
        air_data: &AirData,
        direction: &AeroCoefficients,
    ) -> Accelerations {
        let aircraft = &self.aircraft;
        let scale = air_data.dynamic_pressure * aircraft.wing_area;
        let specific_force = direction.force * scale / aircraft.mass.mass;
        // A moment coefficient moves no force, and so neither flow angle.
        let (alpha_dot, beta_dot) = if direction.force == Vector3::zeros() {
            (0.0, 0.0)
        } else {
            flow_angle_rates(air_data, &specific_force)
        };
        Accelerations {
            specific_force,
            velocity_rate: specific_force,
            alpha_dot,
            beta_dot,
            angular_acceleration: aircraft.mass.inertia_inverse
                * self.aero_moment(&direction.moment, scale),
        }
    }

    /// The aerodynamic moment of moment coefficients (Cl, Cm, Cn) at
    /// q̄·S = `scale`: (Cl·b, Cm·c̄, Cn·b)·q̄S.
    #[inline(always)]
    fn aero_moment<T: Real>(&self, c: &Vector3<T>, scale: T) -> Vector3<T> {
        let geometry = &self.aircraft.geometry;
        Vector3::new(
            c.x * geometry.span,
            c.y * geometry.chord,
            c.z * geometry.span,
        ) * scale
    }

    /// Translational acceleration for a guess of α̇ (used by the aero model),
    /// returning the α̇ that acceleration implies.
    #[inline(always)]
    fn translational<T: Real>(
        &self,
        context: &TranslationalContext<T>,
        alpha_dot_guess: T,
    ) -> Translational<T> {
        let aircraft = &self.aircraft;
        let air_data = &context.kinematics.air_data;
        let input = AeroInput {
            alpha: air_data.alpha,
            beta: air_data.beta,
            airspeed: air_data.airspeed,
            mach: air_data.mach,
            rates: context.kinematics.omega,
            alpha_dot: alpha_dot_guess,
            measured_alpha_dot: context.kinematics.measured_alpha_dot,
            controls: *context.controls,
            chi: context.kinematics.chi,
        };
        let coefficients = aircraft
            .aero
            .coefficients_at(&input, air_data.alpha_sin_cos);
        Translational {
            accelerations: self.accelerations(context, &coefficients),
            coefficients,
            input,
            chi: aircraft.aero.effective_chi(&input),
        }
    }

    /// The accelerations aerodynamic coefficients give: the translational
    /// equation (specific force, u̇ v̇ ẇ, and the α̇, β̇ of the air-relative
    /// velocity) and the rotational one, ω̇ = I⁻¹·(M − ω × I·ω).
    #[inline(always)]
    fn accelerations<T: Real>(
        &self,
        context: &TranslationalContext<T>,
        coefficients: &AeroCoefficients<T>,
    ) -> Accelerations<T> {
        let aircraft = &self.aircraft;
        let kinematics = context.kinematics;
        let air_data = &kinematics.air_data;
        let scale = air_data.dynamic_pressure * aircraft.wing_area;
        let aero_force = coefficients.force * scale;
        let specific_force =
            (aero_force + context.thrust_force.map(T::constant)).map(|e| e / aircraft.mass.mass);
        let velocity_rate =
            specific_force + context.gravity_body - kinematics.omega.cross(&kinematics.velocity);
        let air_rate = velocity_rate - kinematics.wind_rate_body;
        let (alpha_dot, beta_dot) = flow_angle_rates(air_data, &air_rate);
        let moment = self.aero_moment(&coefficients.moment, scale)
            + aircraft
                .propulsion
                .position
                .cross(&context.thrust_force)
                .map(T::constant);
        let omega = &kinematics.omega;
        let inertia = &aircraft.mass.inertia;
        Accelerations {
            specific_force,
            velocity_rate,
            alpha_dot,
            beta_dot,
            angular_acceleration: constant_times(
                &aircraft.mass.inertia_inverse,
                &(moment - omega.cross(&constant_times(inertia, omega))),
            ),
        }
    }

    /// Solves α̇ = g(α̇) by the secant method: the forces depend on α̇ and α̇ on the forces.
    /// Over a [`aeroid_numerics::dual::Dual`] the iterates' derivatives are not the
    /// implicit function's: differentiate such models by differences.
    fn solve_alpha_dot<T: Real>(&self, context: &TranslationalContext<T>) -> Translational<T> {
        const TOLERANCE: f64 = 1e-13;
        let mut guess = T::zero();
        let mut result = self.translational(context, guess);
        let mut previous: Option<(T, T)> = None;
        for _ in 0..50 {
            let residual = result.accelerations.alpha_dot - guess;
            if residual.value().abs() <= TOLERANCE * (1.0 + guess.value().abs()) {
                break;
            }
            let next = match previous {
                Some((old_guess, old_residual)) if residual.value() != old_residual.value() => {
                    guess - residual * (guess - old_guess) / (residual - old_residual)
                }
                _ => result.accelerations.alpha_dot,
            };
            previous = Some((guess, residual));
            guess = next;
            result = self.translational(context, guess);
        }
        result
    }
}

/// α̇ and β̇ of the air-relative velocity (body axes, `air_data`) changing
/// at `air_rate`: α̇ = (u·ẇ − w·u̇)/(u² + w²),
/// β̇ = (v̇·V − v·V̇)/(V·√(u² + w²)) with V̇ = V·V̇/V; linear in the rate.
#[inline(always)]
fn flow_angle_rates<T: Real>(air_data: &AirData<T>, air_rate: &Vector3<T>) -> (T, T) {
    let (u, v, w) = (
        air_data.velocity.x,
        air_data.velocity.y,
        air_data.velocity.z,
    );
    let alpha_dot = (u * air_rate.z - w * air_rate.x) / (u * u + w * w);
    let speed_rate = air_data.velocity.dot(air_rate) / air_data.airspeed;
    let beta_dot = (air_rate.y * air_data.airspeed - v * speed_rate)
        / (air_data.airspeed * (u * u + w * w).sqrt());
    (alpha_dot, beta_dot)
}

/// m·v for a constant matrix m, summed as nalgebra's product sums it
/// (column after column), without lifting m to the scalar `T`.
#[inline(always)]
fn constant_times<T: Real>(m: &Matrix3<f64>, v: &Vector3<T>) -> Vector3<T> {
    Vector3::from_fn(|i, _| v.x * m[(i, 0)] + v.y * m[(i, 1)] + v.z * m[(i, 2)])
}

struct TranslationalContext<'a, T: Real> {
    kinematics: &'a Kinematics<T>,
    controls: &'a Controls,
    gravity_body: Vector3<T>,
    thrust_force: Vector3<f64>,
}

/// q̇ = ½·q ⊗ (0, ω), scalar-first quaternion.
fn quaternion_rate(x: &StateVector, omega: &Vector3<f64>) -> nalgebra::Vector4<f64> {
    let (q0, q1, q2, q3) = (x[Q0], x[Q0 + 1], x[Q0 + 2], x[Q0 + 3]);
    let (p, q, r) = (omega.x, omega.y, omega.z);
    0.5 * nalgebra::Vector4::new(
        -q1 * p - q2 * q - q3 * r,
        q0 * p + q2 * r - q3 * q,
        q0 * q + q3 * p - q1 * r,
        q0 * r + q1 * q - q2 * p,
    )
}
