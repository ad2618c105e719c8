//! The fixed-interval smoothers over a filter's pass.
//!
//! - Rauch–Tung–Striebel (Rauch, Tung & Striebel, AIAA J. 3(8), 1965):
//!   x_{k|N} = x_{k|k} + C_k·(x_{k+1|N} − x_{k+1|k}),
//!   C_k = P_{k|k}·Φ_kᵀ·P_{k+1|k}⁻¹.
//! - Modified Bryson–Frazier (Bierman, "Fixed interval smoothing with
//!   discrete measurements", Int. J. Control 18(1), 1973; the form of
//!   Wang et al. 2012, Eqs. 21–24): backwards from λ̂_N = 0, Λ̂_N = 0, at a
//!   measurement λ̃_k = −Hᵀ·S⁻¹·ν + (I − K·H)ᵀ·λ̂_k,
//!   Λ̃_k = Hᵀ·S⁻¹·H + (I − K·H)ᵀ·Λ̂_k·(I − K·H) (else λ̃ = λ̂, Λ̃ = Λ̂);
//!   x_{k|N} = x_{k|k−1} − P_{k|k−1}·λ̃_k,
//!   P_{k|N} = P_{k|k−1} − P_{k|k−1}·Λ̃_k·P_{k|k−1};
//!   λ̂_{k−1} = Φᵀ·λ̃_k, Λ̂_{k−1} = Φᵀ·Λ̃_k·Φ (Φ from k − 1 to k). It needs
//!   no inverse of a covariance, unlike RTS. After a sequence of scalar
//!   updates the measurement step goes through each of them in reverse
//!   (Bierman, "Sequential square root filtering and smoothing of discrete
//!   linear systems", Automatica 10(2), 1974; "Factorization Methods for
//!   Discrete Sequential Estimation", 1977, ch. X): with the kept hᵢ, kᵢ,
//!   νᵢ and sᵢ, from the last output to the first,
//!   λ ← (I − kᵢ·hᵢᵀ)ᵀ·λ − hᵢ·νᵢ/sᵢ and
//!   Λ ← (I − kᵢ·hᵢᵀ)ᵀ·Λ·(I − kᵢ·hᵢᵀ) + hᵢ·hᵢᵀ/sᵢ; expanded with g = Λ·kᵢ,
//!   c = kᵢᵀ·g and e = g − ½·(c + 1/sᵢ)·hᵢ as Λ ← Λ − (e·hᵢᵀ + hᵢ·eᵀ), which
//!   touches only the rows and columns of hᵢ's non-zeros ([`ScalarUpdates`]).

use super::dense::{combine_columns, resize, resize_vector, sum_of_products, symmetrise};
use super::kept::{
    GaussianView, Gaussians, Matrices, ScalarUpdates, SparseMatrices, UpdateView, Updates,
};
use super::sparse::SparseRows;
use super::update::Gaussian;
use crate::error::{Error, Result};
use nalgebra::{Cholesky, DMatrix, DVector};

/// The RTS smoother over a filter's pass: `filtered[k]` = (x, P)_{k|k}
/// (every covariance kept), `predicted[k]` = (x, P)_{k|k−1} (`predicted[0]`
/// unused), `transitions[k]` = Φ from k to k + 1. Returns (x, P)_{k|N}.
pub fn rts_smooth(
    filtered: &Gaussians,
    predicted: &Gaussians,
    transitions: &Matrices,
) -> Result<Vec<Gaussian>> {
    let n = filtered.len();
    if n == 0 {
        return Ok(Vec::new());
    }
    let mut smoothed = filtered.to_vec();
    let dimension = smoothed[0].mean.len();
    let complete = predicted.len() >= n
        && transitions.len() + 1 >= n
        && smoothed.iter().all(|g| g.covariance.nrows() == dimension)
        && (1..n).all(|k| {
            predicted
                .get(k)
                .is_some_and(|g| g.covariance.nrows() == dimension)
        });
    if !complete {
        return Err(Error::Input { reason: "the RTS smoother needs every filtered and predicted covariance and every transition"
                .into() });
    }
    for k in (0..n - 1).rev() {
        let prior = predicted.get(k + 1).expect("checked above");
        let inverse = Cholesky::new(prior.covariance.into_owned())
            .ok_or_else(|| Error::NotPositiveDefinite {
                what: format!(
                    "the RTS smoother: the predicted covariance at step {}",
                    k + 1
                ),
                why: "",
            })?
            .inverse();
        let phi = transitions.get(k).expect("checked above");
        let gain = &smoothed[k].covariance * phi.transpose() * inverse;
        let mean = &smoothed[k].mean + &gain * (&smoothed[k + 1].mean - prior.mean);
        let covariance = &smoothed[k].covariance
            + &gain * (&smoothed[k + 1].covariance - prior.covariance) * gain.transpose();
        smoothed[k] = Gaussian {
            mean,
            covariance: (&covariance + covariance.transpose()) * 0.5,
        };
    }
    Ok(smoothed)
}

/// The modified Bryson–Frazier smoother (module header) over a filter's
/// pass: `predicted[k]` = (x, P)_{k|k−1} (at k = 0 the initial estimate),
/// `measured[k]` the update at k if there was one, `transitions[k]` = Φ
/// from k to k + 1. Returns (x, P)_{k|N}.
///
/// The products skip the zeros of Φ and H, and the measurement's term
/// (I − K·H)ᵀ·Λ·(I − K·H) is expanded with G = Λ·K, C = Kᵀ·G and
/// E = G − ½·Hᵀ·C as Λ − (E·H + Hᵀ·Eᵀ) (O(n²·m) for m outputs); only
/// P·Λ·P is a product of two dense n × n matrices.
pub fn mbf_smooth<U: SmootherUpdates + ?Sized, T: Transitions + ?Sized>(
    predicted: &Gaussians,
    measured: &U,
    transitions: &T,
) -> Vec<Gaussian> {
    let mut smoothed = predicted.to_vec();
    mbf_backward(
        predicted,
        measured,
        transitions,
        |k, prior, p, adjoint, information, work| {
            let n = adjoint.len();
            let into = &mut smoothed[k];
            let (x, lambda) = (prior.mean.as_slice(), adjoint.as_slice());
            let mean = into.mean.as_mut_slice();
            crate::simd::wide(
                #[inline(always)]
                || smoothed_mean(mean, x, p, lambda),
            );
            let [product, outer] = work;
            product.gemm(1.0, information, &prior.covariance, 0.0);
            outer.gemm(1.0, &prior.covariance, product, 0.0);
            let (p, q, smoothed) = (p, outer.as_slice(), into.covariance.as_mut_slice());
            for j in 0..n {
                for i in 0..=j {
                    let (ij, ji) = (i + j * n, j + i * n);
                    let value = 0.5 * ((p[ij] - q[ij]) + (p[ji] - q[ji]));
                    smoothed[ij] = value;
                    smoothed[ji] = value;
                }
            }
        },
    );
    smoothed
}

/// [`mbf_smooth`]'s means x_{k|N} and variances, the diagonal of P_{k|N}
/// (as a column): with P = P_{k|k−1} and Λ symmetric, Λ = U + Uᵀ with U
/// Λ's upper triangle and half its diagonal, the diagonal of P·Λ·P is
/// 2·Σ_a P_ia·W_ia with W = P·U (Σ_a Σ_b P_ia·P_ib·U_ba is the same sum for
/// U and Uᵀ when P is symmetric), so the variance is
/// P_ii − 2·Σ_a P_ia·W_ia: W's column j combines P's columns 0..=j in
/// registers (`combine_columns`), half the multiply-adds of the dense
/// product P·Λ, each sum taken along P's and W's columns a for all i at
/// once.
pub fn mbf_smooth_variances<U: SmootherUpdates + ?Sized, T: Transitions + ?Sized>(
    predicted: &Gaussians,
    measured: &U,
    transitions: &T,
) -> Vec<(DVector<f64>, DVector<f64>)> {
    let mut smoothed = vec![(DVector::zeros(0), DVector::zeros(0)); predicted.len()];
    mbf_backward(
        predicted,
        measured,
        transitions,
        |k, prior, p, adjoint, information, work| {
            let n = adjoint.len();
            let [product, _] = work;
            resize(product, n, n);
            let (mut mean, mut variances) = (DVector::zeros(n), DVector::zeros(n));
            let (w, x, lambda, information) = (
                product.as_mut_slice(),
                prior.mean.as_slice(),
                adjoint.as_slice(),
                information.as_slice(),
            );
            let (mean_values, sums) = (mean.as_mut_slice(), variances.as_mut_slice());
            crate::simd::wide(
                #[inline(always)]
                || {
                    for (j, column) in w.chunks_exact_mut(n).enumerate() {
                        let upper = &information[j * n..j * n + j + 1];
                        let terms = upper[..j]
                            .iter()
                            .copied()
                            .enumerate()
                            .chain(std::iter::once((j, 0.5 * upper[j])));
                        combine_columns(column, p, terms);
                    }
                    smoothed_mean(mean_values, x, p, lambda);
                    sum_of_products(sums, p, w);
                    for (i, sum) in sums.iter_mut().enumerate() {
                        *sum = p[i + i * n] - 2.0 * *sum;
                    }
                },
            );
            smoothed[k] = (mean, variances);
        },
    );
    smoothed
}

/// The smoothed mean x − P·λ into `into` (P column-major, the columns
/// combined in registers: [`combine_columns`]); both smoothers' means.
#[inline(always)]
fn smoothed_mean(into: &mut [f64], x: &[f64], p: &[f64], lambda: &[f64]) {
    combine_columns(into, p, lambda.iter().copied().enumerate());
    for (into, &x) in into.iter_mut().zip(x) {
        *into = x - *into;
    }
}

/// A pass's measurement updates as the modified Bryson–Frazier smoother
/// goes back through them (module header): vector updates ([`Updates`])
/// or sequences of scalar updates ([`ScalarUpdates`]).
pub trait SmootherUpdates {
    /// λ and Λ back through the update at grid point k (unchanged where
    /// there is none); `scratch` and `work` are the sweep's buffers.
    fn back_through(
        &self,
        k: usize,
        adjoint: &mut DVector<f64>,
        information: &mut DMatrix<f64>,
        scratch: &mut SmootherScratch,
        work: &mut [DMatrix<f64>; 2],
    );
}

/// The buffers of a smoother's measurement steps.
#[derive(Debug, Clone, Default)]
pub struct SmootherScratch {
    transposed: SparseRows,
    weighted: DMatrix<f64>,
    by_gain: DMatrix<f64>,
    half: DMatrix<f64>,
    reduced: DVector<f64>,
    /// Λ·kᵢ, then e.
    vector: Vec<f64>,
    /// hᵢ as a whole row.
    row: Vec<f64>,
}

impl SmootherUpdates for Updates {
    fn back_through(
        &self,
        k: usize,
        adjoint: &mut DVector<f64>,
        information: &mut DMatrix<f64>,
        scratch: &mut SmootherScratch,
        work: &mut [DMatrix<f64>; 2],
    ) {
        if let Some(update) = self.get(k) {
            mbf_measurement(
                &update,
                self.observation_values(k).expect("an update at k"),
                adjoint,
                information,
                scratch,
                work,
            );
        }
    }
}

impl SmootherUpdates for ScalarUpdates {
    /// Each scalar update from the last to the first (module header):
    /// λ ← λ − hᵢ·(kᵢᵀ·λ + νᵢ/sᵢ), Λ ← Λ − (e·hᵢᵀ + hᵢ·eᵀ) with
    /// e = Λ·kᵢ − ½·(kᵢᵀ·Λ·kᵢ + 1/sᵢ)·hᵢ, Λ made symmetric first. Entries
    /// (a, b) and (b, a) take the same products, so Λ stays symmetric.
    fn back_through(
        &self,
        k: usize,
        adjoint: &mut DVector<f64>,
        information: &mut DMatrix<f64>,
        scratch: &mut SmootherScratch,
        _: &mut [DMatrix<f64>; 2],
    ) {
        let count = self.count(k);
        if count == 0 {
            return;
        }
        let n = adjoint.len();
        symmetrise(information);
        let lambda = information.as_mut_slice();
        let SmootherScratch {
            vector: e, row: h, ..
        } = scratch;
        e.clear();
        e.resize(n, 0.0);
        h.clear();
        h.resize(n, 0.0);
        let adjoint = adjoint.as_mut_slice();
        crate::simd::wide(
            #[inline(always)]
            || {
                for i in (0..count).rev() {
                    let update = self.get(k, i).expect("i < count");
                    let gain = update.gain;
                    // h's non-zeros and h as a whole row.
                    let support = update
                        .columns
                        .iter()
                        .copied()
                        .zip(update.observation.iter().copied());
                    update.observation_into(h);
                    let weight = gain.iter().zip(&*adjoint).map(|(k, l)| k * l).sum::<f64>()
                        + update.innovation / update.variance;
                    for (j, value) in support.clone() {
                        adjoint[j] -= value * weight;
                    }
                    // g = Λ·k, c = kᵀ·g, e = g − ½·(c + 1/s)·h.
                    combine_columns(e, lambda, gain.iter().copied().enumerate());
                    let c = gain.iter().zip(e.iter()).map(|(k, g)| k * g).sum::<f64>();
                    let half = 0.5 * (c + 1.0 / update.variance);
                    for (j, value) in support.clone() {
                        e[j] -= half * value;
                    }
                    // Λ_ab −= e_a·h_b + h_a·e_b: whole columns b of h's
                    // non-zeros, elsewhere only the rows a of h's non-zeros
                    // (e_a·0 + x = x).
                    for (b, column) in lambda.chunks_exact_mut(n).enumerate() {
                        let (hb, eb) = (h[b], e[b]);
                        if hb != 0.0 {
                            for ((into, &ea), &ha) in column.iter_mut().zip(e.iter()).zip(h.iter())
                            {
                                *into -= ea * hb + ha * eb;
                            }
                        } else {
                            for (a, ha) in support.clone() {
                                column[a] -= ha * eb;
                            }
                        }
                    }
                }
            },
        );
    }
}

/// A pass's transitions as the smoothers read them: dense ([`Matrices`])
/// or by their entries ([`SparseMatrices`]).
pub trait Transitions {
    /// Φ from grid point k to k + 1 (n × n) read as its transpose into
    /// `into` (its rows Φ's columns, [`SparseRows::set_transposed_values`]);
    /// `scratch` holds what a reading keeps from one call to the next.
    fn transposed_into(&self, k: usize, n: usize, scratch: &mut SparseRows, into: &mut SparseRows);
}

impl Transitions for Matrices {
    fn transposed_into(&self, k: usize, n: usize, _: &mut SparseRows, into: &mut SparseRows) {
        into.set_transposed_values(self.values(k).expect("a transition between points"), n);
    }
}

impl Transitions for SparseMatrices {
    fn transposed_into(&self, k: usize, _: usize, scratch: &mut SparseRows, into: &mut SparseRows) {
        let (pattern, values) = self.get(k).expect("a transition between points");
        scratch.set_from(pattern, values);
        into.set_transposed_rows(scratch);
    }
}

/// The smoother's backward sweep (module header): at each grid point k,
/// from the last down, `at`(k, (x, P)_{k|k−1}, P_{k|k−1}'s values, λ̃_k,
/// Λ̃_k, two n × n work matrices).
fn mbf_backward<U: SmootherUpdates + ?Sized, T: Transitions + ?Sized>(
    predicted: &Gaussians,
    measured: &U,
    transitions: &T,
    mut at: impl FnMut(
        usize,
        GaussianView,
        &[f64],
        &DVector<f64>,
        &DMatrix<f64>,
        &mut [DMatrix<f64>; 2],
    ),
) {
    let len = predicted.len();
    let Some(first) = predicted.first() else {
        return;
    };
    let n = first.mean.len();
    let (mut adjoint, mut transposed_adjoint) = (DVector::zeros(n), DVector::zeros(n));
    let mut information = DMatrix::zeros(n, n);
    let (mut transition, mut rows) = (SparseRows::default(), SparseRows::default());
    let mut work = [DMatrix::zeros(n, n), DMatrix::zeros(n, n)];
    let mut scratch = SmootherScratch::default();
    for k in (0..len).rev() {
        measured.back_through(k, &mut adjoint, &mut information, &mut scratch, &mut work);
        let prior = predicted.get(k).expect("k < len");
        let (_, covariance) = predicted.values(k).expect("k < len");
        at(k, prior, covariance, &adjoint, &information, &mut work);
        if k > 0 {
            // λ ← Φᵀ·λ, Λ ← Φᵀ·Λ·Φ = (Zᵀ·Φ)ᵀ with Z = Λ·Φ, by Φ's columns.
            let [product, outer] = &mut work;
            transitions.transposed_into(k - 1, n, &mut rows, &mut transition);
            for (i, into) in transposed_adjoint.iter_mut().enumerate() {
                *into = transition
                    .row(i)
                    .iter()
                    .map(|&(j, value)| value * adjoint[j])
                    .sum();
            }
            std::mem::swap(&mut adjoint, &mut transposed_adjoint);
            transition.times_transposed(&information, product);
            product.transpose_to(outer);
            transition.times_transposed(outer, &mut information);
        }
    }
}

/// The modified Bryson–Frazier smoother's step at a measurement (H's
/// values `observation`, column-major):
/// λ ← −Hᵀ·S⁻¹·ν + λ − Hᵀ·(Kᵀ·λ) and
/// Λ ← Hᵀ·S⁻¹·H + Λ − (E·H + Hᵀ·Eᵀ) ([`mbf_smooth`]).
fn mbf_measurement(
    update: &UpdateView,
    observation: &[f64],
    adjoint: &mut DVector<f64>,
    information: &mut DMatrix<f64>,
    scratch: &mut SmootherScratch,
    work: &mut [DMatrix<f64>; 2],
) {
    let SmootherScratch {
        transposed,
        weighted,
        by_gain,
        half,
        reduced,
        ..
    } = scratch;
    let n = adjoint.len();
    let h = &update.observation;
    let m = h.nrows();
    let gain = &update.gain;
    transposed.set_transposed_values(observation, m);
    // Hᵀ·v for an m-vector v, over H's non-zeros.
    let h_transposed_times = |v: &[f64], into: &mut [f64]| {
        for (i, into) in into.iter_mut().enumerate() {
            *into = transposed
                .row(i)
                .iter()
                .map(|&(o, value)| value * v[o])
                .sum();
        }
    };
    // W = Hᵀ·S⁻¹ (S⁻¹ symmetric: column p is Hᵀ·(column p of S⁻¹)).
    resize(weighted, n, m);
    for p in 0..m {
        let column = update.innovation_inverse.column(p);
        let mut into = weighted.column_mut(p);
        h_transposed_times(column.as_slice(), into.as_mut_slice());
    }
    // λ ← −W·ν + λ − Hᵀ·(Kᵀ·λ).
    let gain_adjoint = gain.tr_mul(adjoint);
    resize_vector(reduced, n);
    h_transposed_times(gain_adjoint.as_slice(), reduced.as_mut_slice());
    *adjoint -= &*reduced;
    adjoint.gemv(-1.0, weighted, &update.innovation, 1.0);
    // G = Λ·K, C = Kᵀ·G, E = G − ½·Hᵀ·C.
    resize(by_gain, n, m);
    by_gain.gemm(1.0, information, gain, 0.0);
    let c = gain.tr_mul(by_gain);
    resize(half, n, m);
    half.copy_from(by_gain);
    resize_vector(reduced, n);
    for p in 0..m {
        let column = c.column(p);
        h_transposed_times(column.as_slice(), reduced.as_mut_slice());
        half.column_mut(p).axpy(-0.5, &*reduced, 1.0);
    }
    // Λ ← W·H + Λ − (E·H + (E·H)ᵀ).
    let [product, outer] = work;
    transposed.times_transposed(half, product);
    transposed.times_transposed(weighted, outer);
    let (f, w, lambda) = (
        product.as_slice(),
        outer.as_slice(),
        information.as_mut_slice(),
    );
    for j in 0..n {
        for i in 0..=j {
            let (ij, ji) = (i + j * n, j + i * n);
            let value = 0.5 * (w[ij] + w[ji]) + 0.5 * (lambda[ij] + lambda[ji]) - (f[ij] + f[ji]);
            lambda[ij] = value;
            lambda[ji] = value;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::discretise::discretise;
    use crate::kalman::predict::predict_covariance;
    use crate::kalman::testing::{assert_close, system};
    use crate::kalman::update::{Measured, SequentialWorkspace, sequential_update_with, update};

    #[test]
    fn mbf_and_rts_smoothers_agree() {
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let d = discretise(&a, &b, Some(&noise), 0.05);
        let h = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 1.0]);
        let r = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-3, 4e-3]));
        let mut x = DVector::from_vec(vec![0.1, -0.2, 0.05]);
        let mut p = DMatrix::identity(3, 3) * 0.5;
        let (mut filtered, mut predicted, mut measured, mut transitions) = (
            Gaussians::with_capacity(80, true),
            Gaussians::with_capacity(80, true),
            Updates::with_capacity(80, 2),
            Matrices::with_capacity(80),
        );
        for k in 0..80 {
            if k > 0 {
                x = &d.transition * &x;
                p = predict_covariance(&p, &d.transition, &d.process_noise);
                transitions.push(d.transition.clone());
            }
            predicted.push(Gaussian {
                mean: x.clone(),
                covariance: p.clone(),
            });
            // Every third step without a measurement.
            if k % 3 == 2 {
                measured.push(None);
            } else {
                let z = DVector::from_vec(vec![(k as f64 * 0.3).sin(), (k as f64 * 0.11).cos()]);
                let nu = z - &h * &x;
                let u = update(&mut x, &mut p, &h, &r, nu).unwrap();
                measured.push(Some(Measured {
                    observation: h.clone(),
                    update: u,
                }));
            }
            filtered.push(Gaussian {
                mean: x.clone(),
                covariance: p.clone(),
            });
        }
        transitions.push(d.transition.clone());
        let rts = rts_smooth(&filtered, &predicted, &transitions).unwrap();
        let mbf = mbf_smooth(&predicted, &measured, &transitions);
        for (k, (a, b)) in rts.iter().zip(&mbf).enumerate() {
            let da = (&a.mean - &b.mean).norm() / a.mean.norm().max(1e-3);
            assert!(da < 1e-9, "mean at {k}: {da:e}");
            assert_close(&b.covariance, &a.covariance, 1e-9, "covariance");
        }
    }

    /// The measurement update as scalar updates is the vector update:
    /// sequential and batch forms are equal in exact arithmetic, so over 80
    /// steps of a 3-state system with 3 outputs (a row with zeros, a row
    /// with none, a unit row; every third step without a measurement) the
    /// filtered means and covariances, the likelihood, and the smoother's
    /// means and covariances through the scalar updates in reverse agree
    /// with the vector forms to rounding (1e-12 relative to their norms:
    /// the condition number of these covariances is about 10³).
    #[test]
    fn scalar_updates_are_the_vector_update_and_smooth_alike() {
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let d = discretise(&a, &b, Some(&noise), 0.05);
        let h = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.5, 0.2, -1.0, 1.0, 0.0, 1.0, 0.0]);
        let variances = [1e-3, 4e-3, 2e-2];
        let r = DMatrix::from_diagonal(&DVector::from_column_slice(&variances));
        let (mut x, mut xs) = (DVector::from_vec(vec![0.1, -0.2, 0.05]), DVector::zeros(3));
        xs.copy_from(&x);
        let (mut p, mut ps) = (DMatrix::identity(3, 3) * 0.5, DMatrix::identity(3, 3) * 0.5);
        let mut sparse_transitions = SparseMatrices::with_capacity(80);
        let (mut predicted, mut predicted_s, mut measured, mut scalar, mut transitions) = (
            Gaussians::with_capacity(80, true),
            Gaussians::with_capacity(80, true),
            Updates::with_capacity(80, 3),
            ScalarUpdates::with_capacity(80, 3),
            Matrices::with_capacity(80),
        );
        let mut workspace = SequentialWorkspace::default();
        for k in 0..80 {
            if k > 0 {
                x = &d.transition * &x;
                xs = &d.transition * &xs;
                p = predict_covariance(&p, &d.transition, &d.process_noise);
                ps = predict_covariance(&ps, &d.transition, &d.process_noise);
                transitions.push(d.transition.clone());
                sparse_transitions.push(&SparseRows::of(&d.transition));
            }
            predicted.push(Gaussian {
                mean: x.clone(),
                covariance: p.clone(),
            });
            predicted_s.push(Gaussian {
                mean: xs.clone(),
                covariance: ps.clone(),
            });
            if k % 3 == 2 {
                measured.push(None);
                scalar.push_none();
            } else {
                let z = DVector::from_vec(vec![
                    (k as f64 * 0.3).sin(),
                    (k as f64 * 0.11).cos(),
                    0.1 * k as f64,
                ]);
                let nu = &z - &h * &x;
                let u = update(&mut x, &mut p, &h, &r, nu).unwrap();
                let nu_s = &z - &h * &xs;
                sequential_update_with(&mut xs, &mut ps, &h, &variances, &nu_s, &mut workspace)
                    .unwrap();
                assert_eq!(ps, ps.transpose(), "the covariance stays symmetric");
                let (batch, sequential) =
                    (u.log_likelihood_term(), workspace.log_likelihood_term());
                assert!(
                    (batch - sequential).abs() < 1e-12 * batch.abs().max(1.0),
                    "likelihood at {k}: {batch} against {sequential}"
                );
                scalar.push_sequence(
                    workspace.observation(),
                    &workspace.gains,
                    &workspace.innovations,
                    &workspace.variances,
                );
                measured.push(Some(Measured {
                    observation: h.clone(),
                    update: u,
                }));
            }
            let dx = (&x - &xs).norm() / x.norm();
            assert!(dx < 1e-12, "filtered mean at {k}: {dx:e}");
            let dp = relative(&p, &ps);
            assert!(dp < 1e-12, "filtered covariance at {k}: {dp:e}");
        }
        transitions.push(d.transition.clone());
        let vector = mbf_smooth(&predicted, &measured, &transitions);
        assert_smooth_alike(
            &vector,
            &predicted_s,
            &scalar,
            &transitions,
            &sparse_transitions,
        );
    }

    /// ‖a − b‖/‖a‖ (Frobenius).
    fn relative(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
        (a - b).norm() / a.norm().max(1e-300)
    }

    /// The smoother through the scalar updates in reverse against the
    /// vector form's `vector` ([`scalar_updates_are_the_vector_update_and_smooth_alike`]):
    /// means and covariances to rounding, the variances' means the same
    /// and the transitions by their entries the dense ones' bit for bit.
    fn assert_smooth_alike(
        vector: &[Gaussian],
        predicted_s: &Gaussians,
        scalar: &ScalarUpdates,
        transitions: &Matrices,
        sparse_transitions: &SparseMatrices,
    ) {
        let sequential = mbf_smooth(predicted_s, scalar, transitions);
        let variances = mbf_smooth_variances(predicted_s, scalar, transitions);
        assert!(
            mbf_smooth_variances(predicted_s, scalar, sparse_transitions) == variances,
            "the transitions by their entries smooth as the dense ones, bit for bit"
        );
        for (k, ((a, b), (mean, diagonal))) in
            vector.iter().zip(&sequential).zip(&variances).enumerate()
        {
            let dx = (&a.mean - &b.mean).norm() / a.mean.norm().max(1e-3);
            assert!(dx < 1e-12, "smoothed mean at {k}: {dx:e}");
            let dp = relative(&a.covariance, &b.covariance);
            assert!(dp < 1e-12, "smoothed covariance at {k}: {dp:e}");
            assert_eq!(mean, &b.mean);
            let dd = (diagonal - b.covariance.diagonal()).amax() / diagonal.amax();
            assert!(dd < 1e-12, "smoothed variances at {k}: {dd:e}");
        }
    }
}
