//! The simulator's state vector, control vector and attitude conversions.
//!
//! State layout (fixed size, no heap): body-axis inertial velocity u, v, w
//! (m/s); body rates p, q, r (rad/s); attitude quaternion q0..q3 (scalar
//! first, body→NED); NED position north, east, down (m); and the flow
//! separation point χ of the stall model (held constant when unused or
//! algebraic).

use aeroid_numerics::dual::Real;
use nalgebra::{Matrix3, SVector, UnitQuaternion, Vector3};

pub const STATE_SIZE: usize = 14;
/// The simulator's state (the layout in the module docs, indices [`U`] …).
pub type StateVector = SVector<f64, STATE_SIZE>;

pub const U: usize = 0;
pub const V: usize = 1;
pub const W: usize = 2;
pub const P: usize = 3;
pub const Q: usize = 4;
pub const R: usize = 5;
pub const Q0: usize = 6;
pub const NORTH: usize = 10;
pub const EAST: usize = 11;
pub const DOWN: usize = 12;
pub const CHI: usize = 13;

/// Names and units of the state entries, in layout order.
pub const STATE_NAMES: [(&str, &str); STATE_SIZE] = [
    ("u", "m/s"),
    ("v", "m/s"),
    ("w", "m/s"),
    ("p", "rad/s"),
    ("q", "rad/s"),
    ("r", "rad/s"),
    ("q0", "-"),
    ("q1", "-"),
    ("q2", "-"),
    ("q3", "-"),
    ("north", "m"),
    ("east", "m"),
    ("down", "m"),
    ("chi", "-"),
];

/// The controls, each a deflection in rad (throttle: fraction of maximum thrust).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Control {
    Elevator,
    Aileron,
    Rudder,
    Flap,
    Throttle,
}

pub const CONTROL_COUNT: usize = 5;
/// Control deflections and throttle, indexed as [`Control::ALL`].
pub type Controls = SVector<f64, CONTROL_COUNT>;

impl Control {
    pub const ALL: [Control; CONTROL_COUNT] = [
        Control::Elevator,
        Control::Aileron,
        Control::Rudder,
        Control::Flap,
        Control::Throttle,
    ];

    pub fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        match self {
            Control::Elevator => "elevator",
            Control::Aileron => "aileron",
            Control::Rudder => "rudder",
            Control::Flap => "flap",
            Control::Throttle => "throttle",
        }
    }

    /// Unit of the control inside aeroid.
    pub fn unit(self) -> &'static str {
        match self {
            Control::Throttle => "-",
            _ => "rad",
        }
    }

    /// The physical dimension a file value for this control has.
    pub fn dimension(self) -> aeroid_core::units::Dimension {
        match self {
            Control::Throttle => aeroid_core::units::Dimension::Dimensionless,
            _ => aeroid_core::units::Dimension::Angle,
        }
    }
}

/// Euler angles (roll φ, pitch θ, yaw ψ; 3-2-1 sequence) in rad.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EulerAngles {
    pub roll: f64,
    pub pitch: f64,
    pub yaw: f64,
}

/// The attitude quaternion stored in a state vector.
pub fn attitude(x: &StateVector) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
        x[Q0],
        x[Q0 + 1],
        x[Q0 + 2],
        x[Q0 + 3],
    ))
}

pub fn set_attitude(x: &mut StateVector, attitude: &UnitQuaternion<f64>) {
    let q = attitude.quaternion();
    x[Q0] = q.w;
    x[Q0 + 1] = q.i;
    x[Q0 + 2] = q.j;
    x[Q0 + 3] = q.k;
}

pub fn quaternion_from_euler(euler: EulerAngles) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(euler.roll, euler.pitch, euler.yaw)
}

/// Euler angles of the stored quaternion (which need not be exactly unit).
pub fn euler(x: &StateVector) -> EulerAngles {
    let (roll, pitch, yaw) = UnitQuaternion::new_normalize(attitude(x).into_inner()).euler_angles();
    EulerAngles { roll, pitch, yaw }
}

/// Body→NED rotation matrix of a (not necessarily unit) stored quaternion,
/// normalised so that small integration drift does not scale vectors.
pub fn body_to_ned(x: &StateVector) -> Matrix3<f64> {
    let (w, i, j, k) = (x[Q0], x[Q0 + 1], x[Q0 + 2], x[Q0 + 3]);
    let s = 1.0 / (w * w + i * i + j * j + k * k);
    Matrix3::new(
        1.0 - 2.0 * s * (j * j + k * k),
        2.0 * s * (i * j - k * w),
        2.0 * s * (i * k + j * w),
        2.0 * s * (i * j + k * w),
        1.0 - 2.0 * s * (i * i + k * k),
        2.0 * s * (j * k - i * w),
        2.0 * s * (i * k - j * w),
        2.0 * s * (j * k + i * w),
        1.0 - 2.0 * s * (i * i + j * j),
    )
}

pub fn velocity(x: &StateVector) -> Vector3<f64> {
    Vector3::new(x[U], x[V], x[W])
}

pub fn rates(x: &StateVector) -> Vector3<f64> {
    Vector3::new(x[P], x[Q], x[R])
}

/// The sine and cosine of an angle.
pub type SinCos = (f64, f64);

/// NED→body rotation of Euler angles (3-2-1) given by their sines and cosines:
/// rows are the body axes in NED, e.g. the third column is (−sin θ,
/// sin φ·cos θ, cos φ·cos θ), the down axis in body axes.
#[inline(always)]
pub fn ned_to_body<T: Real>(roll: (T, T), pitch: (T, T), yaw: (T, T)) -> Matrix3<T> {
    let ((sin_roll, cos_roll), (sin_pitch, cos_pitch), (sin_yaw, cos_yaw)) = (roll, pitch, yaw);
    Matrix3::new(
        cos_pitch * cos_yaw,
        cos_pitch * sin_yaw,
        -sin_pitch,
        sin_roll * sin_pitch * cos_yaw - cos_roll * sin_yaw,
        sin_roll * sin_pitch * sin_yaw + cos_roll * cos_yaw,
        sin_roll * cos_pitch,
        cos_roll * sin_pitch * cos_yaw + sin_roll * sin_yaw,
        cos_roll * sin_pitch * sin_yaw - sin_roll * cos_yaw,
        cos_roll * cos_pitch,
    )
}

/// Euler-angle rates (φ̇, θ̇, ψ̇) from body rates (p, q, r) at roll φ and pitch θ:
/// φ̇ = p + tan θ·(q sin φ + r cos φ), θ̇ = q cos φ − r sin φ,
/// ψ̇ = (q sin φ + r cos φ)/cos θ.
pub fn euler_rates(roll: f64, pitch: f64, rates: &Vector3<f64>) -> Vector3<f64> {
    euler_rates_of(roll.sin_cos(), pitch.sin_cos(), rates)
}

/// [`euler_rates`] from the sines and cosines of φ and θ.
#[inline(always)]
pub fn euler_rates_of<T: Real>(
    (sin_roll, cos_roll): (T, T),
    (sin_pitch, cos_pitch): (T, T),
    rates: &Vector3<T>,
) -> Vector3<T> {
    let turn = rates.y * sin_roll + rates.z * cos_roll;
    Vector3::new(
        rates.x + sin_pitch / cos_pitch * turn,
        rates.y * cos_roll - rates.z * sin_roll,
        turn / cos_pitch,
    )
}

/// Altitude above the flat earth's reference (m), positive up.
pub fn altitude(x: &StateVector) -> f64 {
    -x[DOWN]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_matches_nalgebra_and_euler_round_trips() {
        let e = EulerAngles {
            roll: 0.3,
            pitch: -0.2,
            yaw: 2.5,
        };
        let q = quaternion_from_euler(e);
        let mut x = StateVector::zeros();
        set_attitude(&mut x, &q);
        let difference = body_to_ned(&x) - q.to_rotation_matrix().into_inner();
        assert!(difference.norm() < 1e-14);
        let direct = ned_to_body(e.roll.sin_cos(), e.pitch.sin_cos(), e.yaw.sin_cos());
        assert!((direct - body_to_ned(&x).transpose()).norm() < 1e-14);
        let back = euler(&x);
        assert!((back.roll - e.roll).abs() < 1e-14);
        assert!((back.pitch - e.pitch).abs() < 1e-14);
        assert!((back.yaw - e.yaw).abs() < 1e-14);
    }
}
