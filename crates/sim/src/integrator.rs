//! The one integrator of aeroid: classical fixed-step fourth-order
//! Runge–Kutta, shared by the simulator and every estimator that simulates.
//!
//! Exogenous signals (controls, wind) are known only at the step instants
//! t_k. How they are taken inside a step changes output-error results by
//! several σ at low sample rates, so it is an explicit [`Interpolation`]
//! option: zero-order hold uses u(t_k) for all four stages (exact for
//! piecewise-constant inputs that switch on the step grid, the default);
//! linear uses u(t_k) + θ·(u(t_{k+1}) − u(t_k)) at the stage time t_k + θ·h.
//! This is the simulator's (the scenario's) option for all its inputs; an
//! estimator chooses one per recorded input
//! (`aeroid_estimation::model::input_timing`) and blends each with its own
//! [`Interpolation::weight`].

use nalgebra::{DMatrix, SVector};
use serde::{Deserialize, Serialize};

/// How a signal known at the step instants is taken inside an RK4 step:
/// held or interpolated linearly (see the module docs).
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

/// One RK4 step of the linear time-varying matrix equation
/// `Ṡ = A·S + B` over a step of length h, given A and B at the four stages
/// (c = 0, ½, ½, 1): `Kᵢ = Aᵢ·(S + cᵢ·h·Kᵢ₋₁) + Bᵢ`,
/// `S⁺ = S + h/6·(K₁ + 2K₂ + 2K₃ + K₄)`. This is how the sensitivity
/// equations Ṡ = (∂f/∂x)·S + ∂f/∂θ are integrated. With the linearisations
/// at the state's own RK4 stage states (xᵢ = x + cᵢ·h·kᵢ₋₁), S⁺ is the exact
/// derivative of the discrete step [`rk4_step`], not a separately
/// discretised sensitivity equation; with the grid points' linearisations
/// (A₀, their mean twice, A₁) it is exact for coefficients varying linearly
/// inside the step and otherwise within O(h²) of it. `work` holds three
/// scratch matrices of S's shape.
pub fn rk4_linear_step(
    sensitivity: &mut DMatrix<f64>,
    step: f64,
    stages: [(&DMatrix<f64>, &DMatrix<f64>); 4],
    work: &mut [DMatrix<f64>; 3],
) {
    aeroid_numerics::simd::wide(
        #[inline(always)]
        || {
            let rows = sensitivity.nrows();
            if (1..=12).contains(&rows) && stages.iter().all(|(a, _)| a.shape() == (rows, rows)) {
                let slices = stages.map(|(a, b)| (a.as_slice(), b.as_slice()));
                aeroid_numerics::simd::fixed_rows!(
                    rows,
                    rk4_linear_fixed,
                    |_: &mut [f64], _, _| unreachable!("1 to 12 rows"),
                    (sensitivity.as_mut_slice(), step, slices)
                );
                return;
            }
            let [stage, rate, sum] = work;
            affine(stages[0].0, sensitivity, stages[0].1, rate);
            sum.copy_from(rate);
            for ((a, b), (c, weight)) in
                stages[1..].iter().zip([(0.5, 2.0), (0.5, 2.0), (1.0, 1.0)])
            {
                stage.copy_from(sensitivity);
                add_scaled(stage, c * step, rate);
                affine(a, stage, b, rate);
                add_scaled(sum, weight, rate);
            }
            add_scaled(sensitivity, step / 6.0, sum);
        },
    )
}

/// [`rk4_linear_step`] with R states, one column of S at a time through
/// all four stages (held in registers): the same operations in the same
/// order as the general path, so the same numbers.
#[inline(always)]
fn rk4_linear_fixed<const R: usize>(
    sensitivity: &mut [f64],
    step: f64,
    stages: [(&[f64], &[f64]); 4],
) {
    let a: [&[[f64; R]]; 4] = stages.map(|(a, _)| a.as_chunks::<R>().0);
    let b: [&[[f64; R]]; 4] = stages.map(|(_, b)| b.as_chunks::<R>().0);
    let affine = |a: &[[f64; R]], s: &[f64; R], b: &[f64; R]| {
        let mut column = *b;
        for (a, &s) in a.iter().zip(s) {
            for (value, a) in column.iter_mut().zip(a) {
                *value += a * s;
            }
        }
        column
    };
    for (j, s) in sensitivity.as_chunks_mut::<R>().0.iter_mut().enumerate() {
        let mut rate = affine(a[0], s, &b[0][j]);
        let mut sum = rate;
        for (i, (c, weight)) in [(1, (0.5, 2.0)), (2, (0.5, 2.0)), (3, (1.0, 1.0))] {
            let factor = c * step;
            let mut stage = *s;
            for (stage, rate) in stage.iter_mut().zip(&rate) {
                *stage += factor * rate;
            }
            rate = affine(a[i], &stage, &b[i][j]);
            for (sum, rate) in sum.iter_mut().zip(&rate) {
                *sum += weight * rate;
            }
        }
        let factor = step / 6.0;
        for (s, sum) in s.iter_mut().zip(&sum) {
            *s += factor * sum;
        }
    }
}

/// into = a·s + b, for the small matrices of the sensitivity equations
/// (a is r × n, s is n × m, b is r × m). Up to 12 rows go through a kernel
/// with r known at compile time, whose column loops the compiler unrolls
/// and vectorises.
pub fn affine(a: &DMatrix<f64>, s: &DMatrix<f64>, b: &DMatrix<f64>, into: &mut DMatrix<f64>) {
    aeroid_numerics::simd::wide(
        #[inline(always)]
        || {
            let (rows, inner) = (a.nrows(), s.nrows());
            let (a, s, b) = (a.as_slice(), s.as_slice(), b.as_slice());
            let into = into.as_mut_slice();
            if rows == 0 {
                return;
            }
            if inner == 0 {
                into.copy_from_slice(b);
                return;
            }
            aeroid_numerics::simd::fixed_rows!(
                rows,
                affine_kernel,
                |inner, a, s, b, into| affine_columns(rows, inner, a, s, b, into),
                (inner, a, s, b, into)
            )
        },
    )
}

#[inline(always)]
fn affine_kernel<const R: usize>(inner: usize, a: &[f64], s: &[f64], b: &[f64], into: &mut [f64]) {
    let a: &[[f64; R]] = a.as_chunks::<R>().0;
    let columns = into
        .as_chunks_mut::<R>()
        .0
        .iter_mut()
        .zip(b.as_chunks::<R>().0)
        .zip(s.chunks_exact(inner));
    for ((into, b), s) in columns {
        let mut column = *b;
        for (a, &s) in a.iter().zip(s) {
            for (value, a) in column.iter_mut().zip(a) {
                *value += a * s;
            }
        }
        *into = column;
    }
}

#[inline(always)]
fn affine_columns(rows: usize, inner: usize, a: &[f64], s: &[f64], b: &[f64], into: &mut [f64]) {
    for ((into, b), s) in into
        .chunks_exact_mut(rows)
        .zip(b.chunks_exact(rows))
        .zip(s.chunks_exact(inner))
    {
        into.copy_from_slice(b);
        for (a, &s) in a.chunks_exact(rows).zip(s) {
            for (into, a) in into.iter_mut().zip(a) {
                *into += a * s;
            }
        }
    }
}

/// target += factor·source, element-wise.
#[inline(always)]
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

    /// S (1 × 3, columns θ₁, θ₂, x₀) against central differences of
    /// `step_of(x₀, θ₁, θ₂)` at `[x₀, θ₁, θ₂]`, to 1e-9 relative.
    fn assert_is_derivative(
        s: &DMatrix<f64>,
        step_of: impl Fn(f64, f64, f64) -> f64,
        at: [f64; 3],
    ) {
        let [x0, t1, t2] = at;
        let d = 1e-6;
        let expected = [
            (step_of(x0, t1 + d, t2) - step_of(x0, t1 - d, t2)) / (2.0 * d),
            (step_of(x0, t1, t2 + d) - step_of(x0, t1, t2 - d)) / (2.0 * d),
            (step_of(x0 + d, t1, t2) - step_of(x0 - d, t1, t2)) / (2.0 * d),
        ];
        for (j, expected) in expected.iter().enumerate() {
            assert!(
                (s[(0, j)] - expected).abs() < 1e-9 * expected.abs().max(1.0),
                "column {j}: {} vs {expected}",
                s[(0, j)]
            );
        }
    }

    /// ẋ = −a·x² + b·sin x with θ = (a, b, x₀): with the linearisations
    /// at the stage states the sensitivity step is the derivative of the
    /// discrete step, so it agrees with central differences of [`rk4_step`]
    /// to 1e-9 relative.
    #[test]
    fn stage_linearised_step_is_the_derivative_of_the_step() {
        let h = 0.3;
        let f = |x: f64, a: f64, b: f64| -a * x * x + b * x.sin();
        let step_of = |x0: f64, a: f64, b: f64| {
            rk4_step(&nalgebra::Vector1::new(x0), h, |x, _| {
                nalgebra::Vector1::new(f(x[0], a, b))
            })[0]
        };
        let (x0, a, b) = (0.8, 1.3, 0.7);
        let mut linearisations = Vec::new();
        rk4_step(&nalgebra::Vector1::new(x0), h, |x, _| {
            linearisations.push((
                DMatrix::from_element(1, 1, -2.0 * a * x[0] + b * x[0].cos()),
                DMatrix::from_row_slice(1, 3, &[-x[0] * x[0], x[0].sin(), 0.0]),
            ));
            nalgebra::Vector1::new(f(x[0], a, b))
        });
        let stages = [0, 1, 2, 3].map(|i| (&linearisations[i].0, &linearisations[i].1));
        let mut s = DMatrix::from_row_slice(1, 3, &[0.0, 0.0, 1.0]);
        let mut work = [(); 3].map(|_| DMatrix::zeros(1, 3));
        rk4_linear_step(&mut s, h, stages, &mut work);
        assert_is_derivative(&s, step_of, [x0, a, b]);
    }

    /// ẋ = a(t)·x + b(t)·θ₁ + θ₂ with a, b linear in t inside the step and
    /// θ = (θ₁, θ₂, x₀): with only the step ends' linearisations (their mean
    /// at the middle stages) the step is still the exact derivative, to 1e-9.
    #[test]
    fn end_linearised_step_is_exact_for_linearly_varying_coefficients() {
        let h = 0.3;
        let a = |tau: f64| -1.2 + 0.8 * tau;
        let b = |tau: f64| 0.5 - 0.9 * tau;
        let step_of = |x0: f64, t1: f64, t2: f64| {
            rk4_step(&nalgebra::Vector1::new(x0), h, |x, tau| {
                nalgebra::Vector1::new(a(tau) * x[0] + b(tau) * t1 + t2)
            })[0]
        };
        let (x0, t1, t2) = (0.8, 1.3, 0.7);
        let at = |tau: f64| {
            (
                DMatrix::from_element(1, 1, a(tau)),
                DMatrix::from_row_slice(1, 3, &[b(tau), 1.0, 0.0]),
            )
        };
        let (start, middle, end) = (at(0.0), at(0.5), at(1.0));
        let mut s = DMatrix::from_row_slice(1, 3, &[0.0, 0.0, 1.0]);
        let mut work = [(); 3].map(|_| DMatrix::zeros(1, 3));
        let stages = [
            (&start.0, &start.1),
            (&middle.0, &middle.1),
            (&middle.0, &middle.1),
            (&end.0, &end.1),
        ];
        rk4_linear_step(&mut s, h, stages, &mut work);
        assert_is_derivative(&s, step_of, [x0, t1, t2]);
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
