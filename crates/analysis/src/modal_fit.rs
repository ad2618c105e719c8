//! Continuous-time eigenvalues from a sampled, multi-output free response,
//! by the Eigensystem Realization Algorithm (ERA; Juang & Pappa, "An
//! eigensystem realization algorithm for modal parameter identification and
//! model reduction", J. Guidance 8(5), 1985, 620–627).
//!
//! A free response of a linear system sampled at `t_k = k·Δt` is
//! `y_k = C·A_dᵏ·x_0` with `A_d = e^{A·Δt}`, the same form as the Markov
//! parameters of an impulse response (with `x_0` in the place of B). With
//! `r` block rows and `s` columns, the block Hankel matrices
//!
//! ```text
//!        ┌ y_k      y_{k+1}  …  y_{k+s−1}  ┐
//! H(k) = │ y_{k+1}  y_{k+2}  …  y_{k+s}    │      (r·m × s, m outputs)
//!        │ …                               │
//!        └ y_{k+r−1}        …  y_{k+r+s−2} ┘
//! ```
//!
//! factor as `H(k) = O·A_dᵏ·Q` (observability times "controllability" of
//! x_0). The SVD `H(0) = U·Σ·Vᵀ`, truncated to the model order n
//! (`U₁, Σ₁, V₁`: the n largest singular values), gives the balanced
//! realisation (Juang & Pappa Eqs. 18–22):
//!
//! `A_d = Σ₁^{−1/2}·U₁ᵀ·H(1)·V₁·Σ₁^{−1/2}`, `C = [I_m 0]·U₁·Σ₁^{1/2}`,
//! `x_0 = Σ₁^{1/2}·V₁ᵀ·e_1`,
//!
//! and the continuous-time eigenvalues `λ = ln(z)/Δt` for each eigenvalue z of
//! A_d (principal logarithm: valid while |Im λ|·Δt < π, i.e. below the
//! Nyquist frequency).
//!
//! Each output channel is divided by its RMS value before the Hankel matrices
//! are built (outputs in m/s, rad and m would otherwise weigh by their units),
//! and the scale is put back into C. For each mode the fit reports the
//! modal output amplitude `|ψᵀx_0|·‖C·φ‖/|ψᵀφ|` (φ, ψ the right and left
//! eigenvectors of A_d, channels scaled): a mode whose amplitude is tiny
//! compared with the others is poorly determined by the data.
//!
//! For noise-free data of a linear system of order ≤ n the realisation is
//! exact: the eigenvalues are recovered to round-off.

use crate::error::{Error, Result};
use crate::linearize::{damping_ratio, eigenvectors, natural_frequency};
use nalgebra::{Complex, DMatrix, DVector};

/// ERA settings: the model order and the Hankel matrix size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Era {
    /// Model order n (number of eigenvalues, complex pairs counting twice).
    pub order: usize,
    /// Block rows r of the Hankel matrix; by default the smallest r with
    /// r·m ≥ 10·n, but at most a third of the samples.
    pub block_rows: Option<usize>,
}

/// One fitted mode (complex pairs are listed as both members).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FittedMode {
    /// Discrete-time eigenvalue z.
    pub discrete: Complex<f64>,
    /// Continuous-time eigenvalue λ = ln(z)/Δt.
    pub eigenvalue: Complex<f64>,
    pub natural_frequency: f64,
    pub damping_ratio: f64,
    /// Modal output amplitude, in RMS-scaled output units.
    pub amplitude: f64,
}

/// The result of an ERA fit.
#[derive(Debug, Clone, PartialEq)]
pub struct EraFit {
    /// Fitted modes, ordered by natural frequency, fastest first.
    pub modes: Vec<FittedMode>,
    /// All singular values of H(0), largest first: the gap after the n-th
    /// tells whether the order fits the data.
    pub singular_values: Vec<f64>,
    /// The identified discrete state matrix (balanced coordinates).
    pub a: DMatrix<f64>,
    /// The identified output matrix, in the outputs' own units.
    pub c: DMatrix<f64>,
    /// The identified initial state.
    pub initial_state: DVector<f64>,
}

impl EraFit {
    /// The fitted mode whose continuous eigenvalue is nearest to `lambda`.
    pub fn nearest(&self, lambda: Complex<f64>) -> Option<&FittedMode> {
        self.modes.iter().min_by(|a, b| {
            (a.eigenvalue - lambda)
                .norm()
                .total_cmp(&(b.eigenvalue - lambda).norm())
        })
    }

    /// The continuous eigenvalues, ordered as [`EraFit::modes`].
    pub fn eigenvalues(&self) -> Vec<Complex<f64>> {
        self.modes.iter().map(|m| m.eigenvalue).collect()
    }
}

impl Era {
    pub fn new(order: usize) -> Self {
        Era {
            order,
            block_rows: None,
        }
    }

    pub fn with_block_rows(mut self, rows: usize) -> Self {
        self.block_rows = Some(rows);
        self
    }

    /// The block rows of the Hankel matrices for `samples` (given, else
    /// about 10·order outputs' worth, at most a third of the samples); an
    /// error for an order of 0, no output, a step that is not positive,
    /// samples that are not finite, or too few samples.
    fn block_rows_for(&self, samples: &DMatrix<f64>, step: f64) -> Result<usize> {
        let (count, channels) = samples.shape();
        let n = self.order;
        if n == 0 || channels == 0 {
            return Err(Error::EraInput {
                need: "an order ≥ 1 and at least one output",
            });
        }
        if step.is_nan() || step <= 0.0 || !samples.iter().all(|v| v.is_finite()) {
            return Err(Error::EraInput {
                need: "a positive sample step and finite samples",
            });
        }
        let rows = self
            .block_rows
            .unwrap_or_else(|| (10 * n).div_ceil(channels).min(count / 3))
            .max(1);
        if rows * channels < n || count < rows + n + 1 {
            return Err(Error::EraSamples {
                order: n,
                rows,
                channels,
                samples: count,
            });
        }
        Ok(rows)
    }

    /// Fits the free response `samples` (one row per sample instant, one
    /// column per output channel) taken every `step` seconds.
    pub fn fit(&self, samples: &DMatrix<f64>, step: f64) -> Result<EraFit> {
        let (count, channels) = samples.shape();
        let n = self.order;
        let rows = self.block_rows_for(samples, step)?;
        let columns = count - rows;
        let scales: Vec<f64> = (0..channels)
            .map(|j| {
                let rms = (samples.column(j).norm_squared() / count as f64).sqrt();
                if rms > 0.0 { rms } else { 1.0 }
            })
            .collect();
        let hankel = |shift: usize| {
            DMatrix::from_fn(rows * channels, columns, |i, j| {
                let (block, channel) = (i / channels, i % channels);
                samples[(block + j + shift, channel)] / scales[channel]
            })
        };
        let h0 = hankel(0);
        let h1 = hankel(1);
        let svd = h0.svd(true, true);
        let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
            return Err(Error::Era {
                reason: "the SVD did not converge".into(),
            });
        };
        let singular_values: Vec<f64> = svd.singular_values.iter().copied().collect();
        if singular_values.len() < n
            || singular_values[n - 1].is_nan()
            || singular_values[n - 1] <= 0.0
        {
            return Err(Error::Era {
                reason: format!("the Hankel matrix has rank below the order {n}"),
            });
        }
        let u1 = u.columns(0, n);
        let v1 = v_t.rows(0, n).transpose();
        let root = DVector::from_iterator(n, singular_values[..n].iter().map(|s| s.sqrt()));
        let inverse_root = root.map(|s| 1.0 / s);
        let a = DMatrix::from_diagonal(&inverse_root)
            * (u1.transpose() * &h1 * &v1)
            * DMatrix::from_diagonal(&inverse_root);
        let c_scaled = u1.rows(0, channels) * DMatrix::from_diagonal(&root);
        let initial_state = DMatrix::from_diagonal(&root) * v1.row(0).transpose();
        let c = DMatrix::from_fn(channels, n, |i, j| c_scaled[(i, j)] * scales[i]);
        let mut modes: Vec<FittedMode> = a
            .complex_eigenvalues()
            .iter()
            .map(|&z| fitted_mode(&a, &c_scaled, &initial_state, z, step))
            .collect();
        modes.sort_by(|a, b| {
            b.natural_frequency
                .total_cmp(&a.natural_frequency)
                .then(b.eigenvalue.im.total_cmp(&a.eigenvalue.im))
        });
        Ok(EraFit {
            modes,
            singular_values,
            a,
            c,
            initial_state,
        })
    }
}

/// The mode of the discrete eigenvalue z of the realisation (`a`, the
/// scaled output matrix `c_scaled`, `initial_state`) sampled every
/// `step`: its continuous eigenvalue, frequency, damping and amplitude in
/// the response.
fn fitted_mode(
    a: &DMatrix<f64>,
    c_scaled: &DMatrix<f64>,
    initial_state: &DVector<f64>,
    z: Complex<f64>,
    step: f64,
) -> FittedMode {
    let eigenvalue = z.ln() / step;
    let (right, left) = eigenvectors(a, z);
    let x0 = initial_state.map(Complex::from);
    let projection = left.transpose() * &x0;
    let normal = left.transpose() * &right;
    let shape = c_scaled.map(Complex::from) * &right;
    let amplitude = if normal[0].norm() > 0.0 {
        projection[0].norm() * shape.norm() / normal[0].norm()
    } else {
        f64::NAN
    };
    FittedMode {
        discrete: z,
        eigenvalue,
        natural_frequency: natural_frequency(eigenvalue),
        damping_ratio: damping_ratio(eigenvalue),
        amplitude,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two damped sinusoids and a real exponential, seen by three outputs
    /// with different mixes and units, recovered to 1e-8.
    #[test]
    fn recovers_known_damped_sinusoids_and_exponential() {
        let truth = [
            Complex::new(-0.5, 2.0),
            Complex::new(-0.5, -2.0),
            Complex::new(-0.02, 0.3),
            Complex::new(-0.02, -0.3),
            Complex::new(-0.7, 0.0),
        ];
        let step = 0.05;
        let count = 400;
        let samples = DMatrix::from_fn(count, 3, |k, j| {
            let t = k as f64 * step;
            let fast = (-0.5 * t).exp() * (2.0 * t + 0.3 * j as f64).cos();
            let slow = (-0.02 * t).exp() * (0.3 * t - 1.0 + j as f64).sin();
            let real = (-0.7 * t).exp();
            let weights = [[1.0, 0.5, 2.0], [100.0, -30.0, 5.0], [0.001, 0.004, -0.002]];
            weights[j][0] * fast + weights[j][1] * slow + weights[j][2] * real
        });
        let fit = Era::new(5).fit(&samples, step).unwrap();
        assert_eq!(fit.modes.len(), 5);
        for lambda in truth {
            let found = fit.nearest(lambda).unwrap();
            assert!(
                (found.eigenvalue - lambda).norm() < 1e-8 * lambda.norm(),
                "{lambda} fitted as {}",
                found.eigenvalue
            );
        }
        // A sixth singular value is round-off: the order shows in the data.
        assert!(fit.singular_values[5] < 1e-10 * fit.singular_values[0]);
        // The identified realisation reproduces the samples.
        let mut x = fit.initial_state.clone();
        for k in 0..count {
            let y = &fit.c * &x;
            for j in 0..3 {
                let scale = samples.column(j).amax();
                assert!(
                    (y[j] - samples[(k, j)]).abs() < 1e-9 * scale,
                    "k = {k}, j = {j}"
                );
            }
            x = &fit.a * x;
        }
    }

    #[test]
    fn too_few_samples_is_an_error() {
        let samples = DMatrix::from_element(4, 1, 1.0);
        assert!(Era::new(4).fit(&samples, 0.1).is_err());
    }
}
