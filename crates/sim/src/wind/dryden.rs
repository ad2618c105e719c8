//! Dryden turbulence: the forms of MIL-F-8785C §3.7.2.2 (one-sided
//! spatial spectra in Ω, rad/m, with `∫₀^∞ Φ(Ω) dΩ = σ²`):
//!
//! ```text
//! Φu(Ω) = σu²·(2Lu/π) / (1 + (Lu·Ω)²)
//! Φv(Ω) = σv²·(Lv/π)·(1 + 3(Lv·Ω)²) / (1 + (Lv·Ω)²)²
//! Φw(Ω) = σw²·(Lw/π)·(1 + 3(Lw·Ω)²) / (1 + (Lw·Ω)²)²
//! ```
//!
//! Frozen turbulence (ω = Ω·V at the trim airspeed V) gives the forming
//! filters, driven by white noise of unit one-sided PSD:
//!
//! ```text
//! Hu(s) = σu·√(2Lu/(πV)) / (1 + Lu·s/V)
//! Hv(s) = σv·√(Lv/(πV))·(1 + √3·Lv·s/V) / (1 + Lv·s/V)²
//! Hw(s) = σw·√(Lw/(πV))·(1 + √3·Lw·s/V) / (1 + Lw·s/V)²
//! ```
//!
//! Their one-sided PSD in Hz is `S(f) = (2π/V)·Φ(2πf/V)`.
//!
//! **Exact discretisation.** Each filter is written in normalised state space
//! whose stationary covariance is the identity, and discretised exactly for
//! the step dt with θ = V·dt/L:
//! * u: `z[k+1] = e^{−θ}·z[k] + √(1 − e^{−2θ})·n[k]`, `u_g = σu·z`;
//! * v, w: `z' = (V/L)·[[0, 1], [−1, −2]]·z + 2√(V/L)·[0, 1]ᵀ·n(t)`,
//!   `y = σ/2·(z₁ + √3·z₂)`, so `Φ = e^{−θ}·[[1+θ, θ], [−θ, 1−θ]]` and
//!   `Qd = ∫₀^dt e^{Aτ}BBᵀe^{Aᵀτ} dτ` in closed form (see
//!   `transverse_process_noise`); the draw is `Φ·z + chol(Qd)·n`. Here z is
//!   the controllable-canonical state of Hv scaled to unit stationary
//!   covariance and n(t) has unit intensity (E[n(t)n(t+τ)] = δ(τ)), which is
//!   the MIL convention's unit one-sided PSD up to the factor √π absorbed in y.
//!
//! Each filter starts from its stationary distribution (a standard normal
//! state), so there is no start-up transient. The sampled sequence has exactly
//! the variance and autocorrelation of the continuous process at the sample
//! times. White noise comes from
//! [`random::stream`](aeroid_core::random::stream)`(seed, TURBULENCE)` in a
//! fixed order: the initial states, then per step u (one draw), v (two), w
//! (two); results are bit-identical for a seed and a sequence of `count`
//! samples is a prefix of any longer one.

use super::turbulence::{FlightConditions, TurbulenceParameters, TurbulenceSpec};
use nalgebra::{Matrix2, RowVector2, Vector2, Vector3};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use rand_distr::StandardNormal;

/// One Dryden forming filter discretised exactly, in normalised coordinates
/// whose stationary covariance is the identity.
#[derive(Debug, Clone)]
struct FormingFilter {
    /// Number of white-noise draws per step (the filter order, 1 or 2).
    order: usize,
    /// State transition Φ over one step.
    transition: Matrix2<f64>,
    /// Lower Cholesky factor of the process-noise covariance Qd over one step.
    noise_factor: Matrix2<f64>,
    /// Output row: turbulence velocity = output·state.
    output: RowVector2<f64>,
    state: Vector2<f64>,
}

impl FormingFilter {
    /// The first-order u filter with θ = V·dt/L.
    fn longitudinal(sigma: f64, theta: f64) -> FormingFilter {
        let correlation = (-theta).exp();
        let innovation = (-(-2.0 * theta).exp_m1()).sqrt();
        FormingFilter {
            order: 1,
            transition: Matrix2::new(correlation, 0.0, 0.0, 0.0),
            noise_factor: Matrix2::new(innovation, 0.0, 0.0, 0.0),
            output: RowVector2::new(sigma, 0.0),
            state: Vector2::zeros(),
        }
    }

    /// The second-order v or w filter with θ = V·dt/L.
    fn transverse(sigma: f64, theta: f64) -> FormingFilter {
        FormingFilter {
            order: 2,
            transition: transverse_transition(theta),
            noise_factor: cholesky_2x2(&transverse_process_noise(theta)),
            output: RowVector2::new(0.5 * sigma, 0.5 * 3f64.sqrt() * sigma),
            state: Vector2::zeros(),
        }
    }

    /// `order` standard normal draws, the rest zero.
    fn draw(&self, rng: &mut ChaCha8Rng) -> Vector2<f64> {
        let mut noise = Vector2::zeros();
        for entry in noise.iter_mut().take(self.order) {
            *entry = rng.sample(StandardNormal);
        }
        noise
    }

    /// Draws the state from the stationary distribution (the identity covariance).
    fn start(&mut self, rng: &mut ChaCha8Rng) {
        self.state = self.draw(rng);
    }

    fn advance(&mut self, rng: &mut ChaCha8Rng) {
        let noise = self.draw(rng);
        self.state = self.transition * self.state + self.noise_factor * noise;
    }

    fn value(&self) -> f64 {
        (self.output * self.state)[0]
    }
}

/// Φ = exp(A·dt) of the normalised v/w filter, A = (V/L)·[[0, 1], [−1, −2]], θ = V·dt/L.
pub(super) fn transverse_transition(theta: f64) -> Matrix2<f64> {
    Matrix2::new(1.0 + theta, theta, -theta, 1.0 - theta) * (-theta).exp()
}

/// Qd = ∫₀^dt e^{Aτ}BBᵀe^{Aᵀτ} dτ of the normalised v/w filter (B = 2√(V/L)·[0, 1]ᵀ),
/// in closed form. With e^{Aτ}B = 2√λ·e^{−λτ}·[λτ, 1 − λτ]ᵀ (λ = V/L) and s = τ/dt:
/// Qd = 4θ·∫₀¹ e^{−2θs}·[[θ²s², θs(1−θs)], [θs(1−θs), (1−θs)²]] ds.
pub(super) fn transverse_process_noise(theta: f64) -> Matrix2<f64> {
    let [g0, g1, g2] = exponential_moments(2.0 * theta);
    let q11 = 4.0 * theta.powi(3) * g2;
    let q12 = 4.0 * theta.powi(2) * (g1 - theta * g2);
    let q22 = 4.0 * theta * (g0 - 2.0 * theta * g1 + theta * theta * g2);
    Matrix2::new(q11, q12, q12, q22)
}

/// gₙ(x) = ∫₀¹ sⁿ·e^{−x·s} ds for n = 0, 1, 2, accurate for every x ≥ 0:
/// the power series below x = 1, the stable upward recurrence
/// gₙ = (n·gₙ₋₁ − e^{−x})/x above.
fn exponential_moments(x: f64) -> [f64; 3] {
    if x < 1.0 {
        let mut moments = [0.0; 3];
        let mut term = 1.0; // (−x)^k / k!
        for k in 0..24 {
            for (n, moment) in moments.iter_mut().enumerate() {
                *moment += term / (n + k + 1) as f64;
            }
            term *= -x / (k + 1) as f64;
        }
        moments
    } else {
        let decay = (-x).exp();
        let g0 = -(-x).exp_m1() / x;
        let g1 = (g0 - decay) / x;
        let g2 = (2.0 * g1 - decay) / x;
        [g0, g1, g2]
    }
}

/// Lower Cholesky factor of a symmetric positive semi-definite 2×2 matrix.
fn cholesky_2x2(matrix: &Matrix2<f64>) -> Matrix2<f64> {
    let l11 = matrix[(0, 0)].max(0.0).sqrt();
    let l21 = if l11 > 0.0 { matrix[(1, 0)] / l11 } else { 0.0 };
    let l22 = (matrix[(1, 1)] - l21 * l21).max(0.0).sqrt();
    Matrix2::new(l11, 0.0, l21, l22)
}

/// The three running forming filters.
pub(super) struct Turbulence {
    filters: [FormingFilter; 3],
}

impl Turbulence {
    /// Builds the filters for the conditions and step and draws their initial states.
    pub(super) fn start(
        spec: &TurbulenceSpec,
        conditions: &FlightConditions,
        step: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Turbulence, crate::error::Error> {
        let FlightConditions { airspeed, altitude } = *conditions;
        if !(airspeed.is_finite() && airspeed > 0.0) {
            return Err(crate::error::Error::TurbulenceConditions {
                reason: format!("airspeed {airspeed} m/s is not positive"),
            });
        }
        if !altitude.is_finite() {
            return Err(crate::error::Error::TurbulenceConditions {
                reason: format!("altitude {altitude} m is not finite"),
            });
        }
        let TurbulenceParameters { sigma, length } = spec.parameters(altitude)?;
        let theta = length.map(|length| airspeed * step / length);
        let mut turbulence = Turbulence {
            filters: [
                FormingFilter::longitudinal(sigma[0], theta[0]),
                FormingFilter::transverse(sigma[1], theta[1]),
                FormingFilter::transverse(sigma[2], theta[2]),
            ],
        };
        turbulence
            .filters
            .iter_mut()
            .for_each(|filter| filter.start(rng));
        Ok(turbulence)
    }

    /// u_g, v_g, w_g in body axes, m/s.
    pub(super) fn velocity(&self) -> Vector3<f64> {
        Vector3::from_fn(|axis, _| self.filters[axis].value())
    }

    /// Moves every filter one step on, drawing noise in the order u, v, w.
    pub(super) fn advance(&mut self, rng: &mut ChaCha8Rng) {
        self.filters
            .iter_mut()
            .for_each(|filter| filter.advance(rng));
    }
}
