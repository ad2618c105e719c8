//! Forward-mode automatic differentiation: dual numbers carrying the
//! derivatives along [`LANES`] directions at once (Griewank & Walther,
//! "Evaluating Derivatives", 2nd ed., ch. 3: the tangent of every
//! intermediate quantity is propagated by the chain rule alongside its
//! value). The equations of motion are written once over the [`Real`]
//! scalar: with `f64` they are the simulator's, with [`Dual`] the same
//! code gives ∂f/∂x along the seeded directions, exact to rounding (no
//! difference step; see `estimation::driven`, whose linearisations use it).

use num_traits::{One, Zero};
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// The number of directions a [`Dual`] carries: four, the integrated states
/// of a decoupled longitudinal or lateral model (more are taken in turns).
pub const LANES: usize = 4;

/// The scalar the equations of motion are written over: `f64`, or a
/// [`Dual`] that carries derivatives too. Mixed operations take the
/// constant on the right (`x * 2.0`, `x - 1.0`); a constant on the left is
/// `T::constant(c)`.
pub trait Real:
    nalgebra::Scalar
    + Copy
    + Zero
    + One
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A constant (zero derivatives).
    fn constant(value: f64) -> Self;
    /// The value, without derivatives.
    fn value(self) -> f64;
    fn sqrt(self) -> Self;
    fn tanh(self) -> Self;
    fn sin_cos(self) -> (Self, Self);
    /// max(self, floor) by value (the derivative is the larger one's).
    fn max_value(self, floor: f64) -> Self;
}

impl Real for f64 {
    #[inline(always)]
    fn constant(value: f64) -> f64 {
        value
    }
    #[inline(always)]
    fn value(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn tanh(self) -> f64 {
        f64::tanh(self)
    }
    #[inline(always)]
    fn sin_cos(self) -> (f64, f64) {
        f64::sin_cos(self)
    }
    #[inline(always)]
    fn max_value(self, floor: f64) -> f64 {
        self.max(floor)
    }
}

/// A value with its derivatives along [`LANES`] directions.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dual {
    pub value: f64,
    pub tangent: [f64; LANES],
}

impl Dual {
    /// A value with derivatives `tangent`.
    #[inline(always)]
    pub fn new(value: f64, tangent: [f64; LANES]) -> Dual {
        Dual { value, tangent }
    }

    /// The independent variable of direction `lane` (derivative 1 there).
    pub fn variable(value: f64, lane: usize) -> Dual {
        let mut tangent = [0.0; LANES];
        tangent[lane] = 1.0;
        Dual { value, tangent }
    }

    /// A function of this value with value `value` and derivative `slope`
    /// (the chain rule).
    #[inline(always)]
    fn chain(self, value: f64, slope: f64) -> Dual {
        Dual {
            value,
            tangent: self.tangent.map(|d| d * slope),
        }
    }
}

impl Real for Dual {
    #[inline(always)]
    fn constant(value: f64) -> Dual {
        Dual {
            value,
            tangent: [0.0; LANES],
        }
    }
    #[inline(always)]
    fn value(self) -> f64 {
        self.value
    }
    #[inline(always)]
    fn sqrt(self) -> Dual {
        let root = self.value.sqrt();
        self.chain(root, 0.5 / root)
    }
    #[inline(always)]
    fn tanh(self) -> Dual {
        let t = self.value.tanh();
        self.chain(t, 1.0 - t * t)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Dual, Dual) {
        let (sin, cos) = self.value.sin_cos();
        (self.chain(sin, cos), self.chain(cos, -sin))
    }
    #[inline(always)]
    fn max_value(self, floor: f64) -> Dual {
        if self.value >= floor {
            self
        } else {
            Dual::constant(floor)
        }
    }
}

/// Element-wise combination of two tangents.
#[inline(always)]
fn zip(a: [f64; LANES], b: [f64; LANES], f: impl Fn(f64, f64) -> f64) -> [f64; LANES] {
    std::array::from_fn(|i| f(a[i], b[i]))
}

impl Add for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, other: Dual) -> Dual {
        Dual::new(
            self.value + other.value,
            zip(self.tangent, other.tangent, |a, b| a + b),
        )
    }
}

impl Sub for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, other: Dual) -> Dual {
        Dual::new(
            self.value - other.value,
            zip(self.tangent, other.tangent, |a, b| a - b),
        )
    }
}

impl Mul for Dual {
    type Output = Dual;
    /// (u·v)' = u'·v + u·v'.
    #[allow(clippy::suspicious_arithmetic_impl)]
    #[inline(always)]
    fn mul(self, other: Dual) -> Dual {
        let (u, v) = (self.value, other.value);
        Dual::new(
            u * v,
            zip(self.tangent, other.tangent, |a, b| a * v + u * b),
        )
    }
}

impl Div for Dual {
    type Output = Dual;
    /// (u/v)' = (u' − (u/v)·v')/v, the division once (the value is u/v
    /// itself, as in f64).
    #[inline(always)]
    fn div(self, other: Dual) -> Dual {
        let (quotient, reciprocal) = (self.value / other.value, 1.0 / other.value);
        Dual::new(
            quotient,
            zip(self.tangent, other.tangent, |a, b| {
                (a - quotient * b) * reciprocal
            }),
        )
    }
}

impl Neg for Dual {
    type Output = Dual;
    #[inline(always)]
    fn neg(self) -> Dual {
        Dual::new(-self.value, self.tangent.map(|d| -d))
    }
}

impl Add<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, c: f64) -> Dual {
        Dual::new(self.value + c, self.tangent)
    }
}

impl Sub<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, c: f64) -> Dual {
        Dual::new(self.value - c, self.tangent)
    }
}

impl Mul<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn mul(self, c: f64) -> Dual {
        Dual::new(self.value * c, self.tangent.map(|d| d * c))
    }
}

impl Div<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn div(self, c: f64) -> Dual {
        let reciprocal = 1.0 / c;
        Dual::new(self.value / c, self.tangent.map(|d| d * reciprocal))
    }
}

macro_rules! assign {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for Dual {
            #[inline(always)]
            fn $method(&mut self, other: Dual) {
                *self = *self $op other;
            }
        }
    };
}
assign!(AddAssign, add_assign, +);
assign!(SubAssign, sub_assign, -);
assign!(MulAssign, mul_assign, *);
assign!(DivAssign, div_assign, /);

impl Zero for Dual {
    fn zero() -> Dual {
        Dual::constant(0.0)
    }
    fn is_zero(&self) -> bool {
        self.value == 0.0 && self.tangent.iter().all(|d| *d == 0.0)
    }
}

impl One for Dual {
    fn one() -> Dual {
        Dual::constant(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The derivatives of a function using every operation against central
    /// differences (step 1e-6: error ~1e-10), along two directions at once.
    #[test]
    fn derivatives_match_central_differences() {
        fn f<T: Real>(x: T, y: T) -> T {
            let (s, c) = (x * y).sin_cos();
            let mut value = (x * x + y * y * 3.0 + 1.0).sqrt() / (y - 2.0) + s * c.tanh();
            value -= T::constant(1.5) / (x + 4.0);
            value *= -x + 7.0;
            value += (y * 0.5).max_value(0.1);
            value / 3.0
        }
        let (x, y) = (0.7, -0.4);
        let dual = f(Dual::variable(x, 0), Dual::variable(y, 1));
        assert_eq!(dual.value, f(x, y));
        let h = 1e-6;
        let dx = (f(x + h, y) - f(x - h, y)) / (2.0 * h);
        let dy = (f(x, y + h) - f(x, y - h)) / (2.0 * h);
        assert!(
            (dual.tangent[0] - dx).abs() < 1e-8,
            "{} {dx}",
            dual.tangent[0]
        );
        assert!(
            (dual.tangent[1] - dy).abs() < 1e-8,
            "{} {dy}",
            dual.tangent[1]
        );
        assert_eq!(dual.tangent[2..], [0.0, 0.0]);
    }
}
