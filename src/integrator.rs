//! The one integrator of aeroid: classical fixed-step fourth-order
//! Runge–Kutta, shared by the simulator and every estimator that simulates.
//!
//! Exogenous signals (controls, wind) are known only at the step instants
//! t_k. How they are taken inside a step changes output-error results by
//! several σ at low sample rates, so it is an explicit [`Interpolation`]
//! option: zero-order hold uses u(t_k) for all four stages (exact for
//! piecewise-constant inputs that switch on the step grid, the default);
//! linear uses u(t_k) + θ·(u(t_{k+1}) − u(t_k)) at the stage time t_k + θ·h.

use nalgebra::{DMatrix, SVector};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Interpolation {
    /// Hold the value at the start of the step (default).
    #[default]
    #[serde(rename = "zoh")]
    ZeroOrderHold,
    /// Interpolate linearly between the samples at both ends of the step.
    #[serde(rename = "linear")]
    Linear,
}

impl Interpolation {
    /// Weight of the end-of-step sample at stage fraction θ ∈ [0, 1].
    pub fn weight(self, theta: f64) -> f64 {
        match self {
            Interpolation::ZeroOrderHold => 0.0,
            Interpolation::Linear => theta,
        }
    }

    /// Blends the samples at both ends of a step at stage fraction θ.
    pub fn blend<const N: usize>(
        self,
        start: &SVector<f64, N>,
        end: &SVector<f64, N>,
        theta: f64,
    ) -> SVector<f64, N> {
        let w = self.weight(theta);
        start + (end - start) * w
    }

    /// Rate of the interpolated signal inside a step of length h (zero for a hold).
    pub fn rate<const N: usize>(
        self,
        start: &SVector<f64, N>,
        end: &SVector<f64, N>,
        step: f64,
    ) -> SVector<f64, N> {
        match self {
            Interpolation::ZeroOrderHold => SVector::zeros(),
            Interpolation::Linear => (end - start) / step,
        }
    }
}

/// One RK4 step of length `step` from `x`. `derivative(x, θ)` returns ẋ at the
/// stage whose time is t_k + θ·step (θ = 0, ½, ½, 1).
pub fn rk4_step<const N: usize>(
    x: &SVector<f64, N>,
    step: f64,
    mut derivative: impl FnMut(&SVector<f64, N>, f64) -> SVector<f64, N>,
) -> SVector<f64, N> {
    let k1 = derivative(x, 0.0);
    let k2 = derivative(&(x + k1 * (0.5 * step)), 0.5);
    let k3 = derivative(&(x + k2 * (0.5 * step)), 0.5);
    let k4 = derivative(&(x + k3 * step), 1.0);
    x + (k1 + (k2 + k3) * 2.0 + k4) * (step / 6.0)
}

/// One RK4 step of x and of its sensitivity matrix S = ∂x/∂θ (N × m), the
/// step itself differentiated: with stage states xᵢ = x + cᵢ·h·kᵢ₋₁
/// (c = 0, ½, ½, 1) and stage sensitivities Sᵢ = S + cᵢ·h·Kᵢ₋₁,
/// `Kᵢ = ∂f/∂x(xᵢ)·Sᵢ + ∂f/∂θ(xᵢ)` and `S⁺ = S + h/6·(K₁ + 2K₂ + 2K₃ + K₄)`.
/// S⁺ is then the exact derivative of the discrete step [`rk4_step`] (whose
/// x⁺ this returns bit for bit), not a separately discretised sensitivity
/// equation. `derivative(xᵢ, θ, Sᵢ, Kᵢ)` returns ẋ at the stage and writes Kᵢ.
/// `work` holds three N × m scratch matrices.
pub fn rk4_step_with_sensitivity<const N: usize>(
    x: &SVector<f64, N>,
    sensitivity: &mut DMatrix<f64>,
    step: f64,
    work: &mut [DMatrix<f64>; 3],
    mut derivative: impl FnMut(
        &SVector<f64, N>,
        f64,
        &DMatrix<f64>,
        &mut DMatrix<f64>,
    ) -> SVector<f64, N>,
) -> SVector<f64, N> {
    let [stage, rate, sum] = work;
    stage.copy_from(sensitivity);
    let k1 = derivative(x, 0.0, stage, rate);
    sum.copy_from(rate);
    stage.copy_from(sensitivity);
    add_scaled(stage, 0.5 * step, rate);
    let k2 = derivative(&(x + k1 * (0.5 * step)), 0.5, stage, rate);
    add_scaled(sum, 2.0, rate);
    stage.copy_from(sensitivity);
    add_scaled(stage, 0.5 * step, rate);
    let k3 = derivative(&(x + k2 * (0.5 * step)), 0.5, stage, rate);
    add_scaled(sum, 2.0, rate);
    stage.copy_from(sensitivity);
    add_scaled(stage, step, rate);
    let k4 = derivative(&(x + k3 * step), 1.0, stage, rate);
    add_scaled(sum, 1.0, rate);
    add_scaled(sensitivity, step / 6.0, sum);
    x + (k1 + (k2 + k3) * 2.0 + k4) * (step / 6.0)
}

/// target += factor·source, element-wise.
fn add_scaled(target: &mut DMatrix<f64>, factor: f64, source: &DMatrix<f64>) {
    target
        .as_mut_slice()
        .iter_mut()
        .zip(source.as_slice())
        .for_each(|(t, s)| *t += factor * s);
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    /// Harmonic oscillator: RK4's global error is O(h⁴), so halving h divides it by ~16
    /// (within 1 once h is small enough for the h⁵ term to be negligible).
    #[test]
    fn fourth_order_convergence() {
        let error = |step: f64| {
            let mut x = Vector2::new(1.0, 0.0);
            let steps = (10.0 / step).round() as usize;
            for _ in 0..steps {
                x = rk4_step(&x, step, |x, _| Vector2::new(x[1], -x[0]));
            }
            (x[0] - 10f64.cos()).abs()
        };
        let ratio = error(0.02) / error(0.01);
        assert!((ratio - 16.0).abs() < 1.0, "ratio {ratio}");
    }

    /// ẋ = −a·x² + b·sin x with θ = (a, b): the sensitivity of one step
    /// agrees with central differences of the step to 1e-9 relative, and x⁺
    /// is rk4_step's bit for bit.
    #[test]
    fn sensitivity_step_is_the_derivative_of_the_step() {
        let f = |x: f64, a: f64, b: f64| -a * x * x + b * x.sin();
        let step_of = |x0: f64, a: f64, b: f64| {
            rk4_step(&nalgebra::Vector1::new(x0), 0.3, |x, _| {
                nalgebra::Vector1::new(f(x[0], a, b))
            })[0]
        };
        let (x0, a, b) = (0.8, 1.3, 0.7);
        let mut s = DMatrix::from_row_slice(1, 3, &[0.0, 0.0, 1.0]);
        let mut work = [
            DMatrix::zeros(1, 3),
            DMatrix::zeros(1, 3),
            DMatrix::zeros(1, 3),
        ];
        let next = rk4_step_with_sensitivity(
            &nalgebra::Vector1::new(x0),
            &mut s,
            0.3,
            &mut work,
            |x, _, stage, rate| {
                let jacobian = -2.0 * a * x[0] + b * x[0].cos();
                for j in 0..3 {
                    rate[(0, j)] = jacobian * stage[(0, j)];
                }
                rate[(0, 0)] += -x[0] * x[0];
                rate[(0, 1)] += x[0].sin();
                nalgebra::Vector1::new(f(x[0], a, b))
            },
        );
        assert_eq!(next[0], step_of(x0, a, b));
        let h = 1e-6;
        let expected = [
            (step_of(x0, a + h, b) - step_of(x0, a - h, b)) / (2.0 * h),
            (step_of(x0, a, b + h) - step_of(x0, a, b - h)) / (2.0 * h),
            (step_of(x0 + h, a, b) - step_of(x0 - h, a, b)) / (2.0 * h),
        ];
        for (j, expected) in expected.iter().enumerate() {
            assert!(
                (s[(0, j)] - expected).abs() < 1e-9 * expected.abs().max(1.0),
                "column {j}: {} vs {expected}",
                s[(0, j)]
            );
        }
    }

    /// ẋ = u(t) with u sampled at the step ends: the hold integrates the start
    /// value, linear interpolation integrates the trapezoid.
    #[test]
    fn interpolation_modes_differ_as_documented() {
        let (start, end) = (nalgebra::Vector1::new(1.0), nalgebra::Vector1::new(3.0));
        for (mode, expected) in [
            (Interpolation::ZeroOrderHold, 0.1),
            (Interpolation::Linear, 0.2),
        ] {
            let x = rk4_step(&nalgebra::Vector1::new(0.0), 0.1, |_, theta| {
                mode.blend(&start, &end, theta)
            });
            assert!((x[0] - expected).abs() < 1e-15, "{mode:?}");
        }
    }
}
