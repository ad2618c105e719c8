//! The measurement update and the estimates a pass keeps.
//!
//! - Gain K = P⁻·Hᵀ·S⁻¹, S = H·P⁻·Hᵀ + R, state x⁺ = x⁻ + K·ν and
//!   covariance in Joseph's form P⁺ = (I − K·H)·P⁻·(I − K·H)ᵀ + K·R·Kᵀ
//!   (Jategaonkar, "Flight Vehicle System Identification", 2nd ed., §5.2,
//!   Eqs. 5.8–5.14; Gelb, "Applied Optimal Estimation", Table 4.2-1). S is
//!   factored by Cholesky, S⁻¹ = L⁻ᵀ·L⁻¹ from its root; one that is not
//!   positive definite is an error.
//! - The same update as a sequence of scalar updates, one per output, for
//!   a diagonal R (Bierman, "Factorization Methods for Discrete Sequential
//!   Estimation", 1977, ch. II; [`sequential_update_with`]): for output i
//!   with row hᵢ of H and variance rᵢ, in turn,
//!   νᵢ = zᵢ − ŷᵢ − hᵢᵀ·(x − x⁻) (the innovation against the estimate so
//!   far, H linearised at x⁻), m = P·hᵢ, sᵢ = hᵢᵀ·m + rᵢ, k = m/sᵢ,
//!   x ← x + k·νᵢ, P ← P − (k·eᵀ + e·kᵀ) with e = m − ½·sᵢ·k (Joseph's form
//!   (I − k·hᵢᵀ)·P·(I − k·hᵢᵀ)ᵀ + k·rᵢ·kᵀ expanded). No matrix inverse, each
//!   O(n²); equal to the vector update in exact arithmetic, and
//!   ln det S = Σ ln sᵢ, νᵀ·S⁻¹·ν = Σ νᵢ²/sᵢ for the sequential
//!   innovations.
//! - [`Gaussian`] and [`Measured`]: an estimate and an update as a pass
//!   keeps them for the smoothers.

use super::dense::{combine_columns, resize};
use super::sparse::SparseRows;
use crate::error::{Error, Result};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use std::cell::Cell;

/// What a measurement update used and produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Update {
    /// ν = z − ŷ.
    pub innovation: DVector<f64>,
    /// S = H·P⁻·Hᵀ + R.
    pub innovation_covariance: DMatrix<f64>,
    /// S⁻¹.
    pub innovation_inverse: DMatrix<f64>,
    /// K = P⁻·Hᵀ·S⁻¹.
    pub gain: DMatrix<f64>,
}

impl Update {
    /// νᵀ·S⁻¹·ν + ln det S, the update's term of −2·ln L (without 2π).
    pub fn log_likelihood_term(&self) -> f64 {
        let log_det = match Cholesky::new(self.innovation_covariance.clone()) {
            Some(c) => log_determinant(&c),
            None => f64::INFINITY,
        };
        self.log_likelihood_term_with(log_det)
    }

    /// [`Update::log_likelihood_term`] given ln det S.
    pub(crate) fn log_likelihood_term_with(&self, log_det: f64) -> f64 {
        let weighted = &self.innovation_inverse * &self.innovation;
        let quadratic = self.innovation.dot(&weighted);
        quadratic + log_det
    }
}

/// ln det S = 2·Σ ln L_ii of S's Cholesky factor L.
fn log_determinant(cholesky: &Cholesky<f64, Dyn>) -> f64 {
    2.0 * cholesky
        .l_dirty()
        .diagonal()
        .iter()
        .map(|d| d.ln())
        .sum::<f64>()
}

/// The measurement update of (x, P) with the innovation ν, its
/// sensitivity H and the noise covariance R, in place (Joseph's form).
/// An error when S is not positive definite.
pub fn update(
    state: &mut DVector<f64>,
    covariance: &mut DMatrix<f64>,
    observation: &DMatrix<f64>,
    noise: &DMatrix<f64>,
    innovation: DVector<f64>,
) -> Result<Update> {
    let mut workspace = UpdateWorkspace::default();
    update_from(
        state,
        None,
        covariance.as_mut_slice(),
        observation,
        noise,
        &innovation,
        &mut workspace,
    )?;
    let UpdateWorkspace {
        innovation_covariance,
        innovation_inverse,
        gain,
        ..
    } = workspace;
    Ok(Update {
        innovation,
        innovation_covariance,
        innovation_inverse,
        gain,
    })
}

/// The buffers of a measurement update ([`update_from`]) and what it
/// produced: S, S⁻¹, K, ln det S.
#[derive(Debug, Clone, Default)]
pub struct UpdateWorkspace {
    observation: SparseRows,
    /// M = P·Hᵀ.
    cross: DMatrix<f64>,
    /// E = M − ½·K·S.
    half: DMatrix<f64>,
    /// K·Eᵀ.
    product: DMatrix<f64>,
    /// L⁻¹ of S's Cholesky factor L (lower triangle).
    root_inverse: DMatrix<f64>,
    /// S = H·P⁻·Hᵀ + R.
    pub innovation_covariance: DMatrix<f64>,
    /// S⁻¹.
    pub innovation_inverse: DMatrix<f64>,
    /// K = P⁻·Hᵀ·S⁻¹.
    pub gain: DMatrix<f64>,
    /// ln det S (its Cholesky factor's).
    pub log_determinant: f64,
}

impl UpdateWorkspace {
    /// νᵀ·S⁻¹·ν + ln det S of the last update with the innovation ν, its
    /// term of −2·ln L (without 2π; [`Update::log_likelihood_term`]).
    pub fn log_likelihood_term(&self, innovation: &DVector<f64>) -> f64 {
        let m = innovation.len();
        let (inverse, nu) = (self.innovation_inverse.as_slice(), innovation.as_slice());
        let mut quadratic = 0.0;
        for (j, column) in inverse.chunks_exact(m.max(1)).enumerate().take(m) {
            quadratic += nu[j] * column.iter().zip(nu).map(|(s, v)| s * v).sum::<f64>();
        }
        quadratic + self.log_determinant
    }
}

/// [`update`] with its buffers and its S, S⁻¹ and K in `workspace`.
/// Joseph's form P⁺ = (I − K·H)·P·(I − K·H)ᵀ + K·R·Kᵀ expanded with
/// M = P·Hᵀ and S = H·M + R: P⁺ = P − K·Mᵀ − M·Kᵀ + K·S·Kᵀ
/// = P − (K·Eᵀ + E·Kᵀ), E = M − ½·K·S, products with H over its
/// non-zeros: O(n²·m) for m outputs instead of O(n³), the same matrix to
/// rounding for any gain. S⁻¹ = L⁻ᵀ·L⁻¹ from S = L·Lᵀ with L⁻¹ formed
/// once (m divisions). Allocates nothing once the buffers have grown.
///
/// P is the covariance `predicted` (n × n, column-major; None: `into`'s
/// own values, the update in place), P⁺ written into `into` (n × n, held
/// elsewhere: a filter's kept filtered covariance).
pub fn update_from(
    state: &mut DVector<f64>,
    predicted: Option<&[f64]>,
    into: &mut [f64],
    observation: &DMatrix<f64>,
    noise: &DMatrix<f64>,
    innovation: &DVector<f64>,
    workspace: &mut UpdateWorkspace,
) -> Result<()> {
    let n = state.len();
    let into = &mut into[..n * n];
    let m = observation.nrows();
    let UpdateWorkspace {
        observation: sparse,
        cross,
        half,
        product,
        root_inverse,
        innovation_covariance: s,
        innovation_inverse: inverse,
        gain,
        log_determinant: log_det,
    } = workspace;
    sparse.set(observation);
    sparse.times_transposed_values(predicted.unwrap_or(into), n, cross);
    innovation_covariance(m, sparse, cross, noise, s);
    *log_det =
        inverse_by_root(s, root_inverse, inverse).ok_or_else(|| Error::NotPositiveDefinite {
            what: "the innovation covariance H·P·Hᵀ + R".into(),
            why: " (a measurement noise variance of zero, or a covariance gone non-finite)",
        })?;
    gain_and_half(n, m, cross, inverse, s, gain, half);
    state.gemv(1.0, gain, innovation, 1.0);
    gain_times_half(n, m, gain, half, product);
    symmetric_difference(predicted, into, product);
    Ok(())
}

/// S = H·M + R (m × m; M = P·Hᵀ = `cross`, H by its rows' entries) into
/// `s`, symmetrised: the mean of each off-diagonal pair.
fn innovation_covariance(
    m: usize,
    sparse: &SparseRows,
    cross: &DMatrix<f64>,
    noise: &DMatrix<f64>,
    s: &mut DMatrix<f64>,
) {
    resize(s, m, m);
    s.copy_from(noise);
    for p in 0..m {
        let column = cross.column(p);
        for o in 0..m {
            s[(o, p)] += sparse
                .row(o)
                .iter()
                .map(|&(j, h)| h * column[j])
                .sum::<f64>();
        }
    }
    for p in 0..m {
        for o in 0..p {
            let mean = 0.5 * (s[(o, p)] + s[(p, o)]);
            s[(o, p)] = mean;
            s[(p, o)] = mean;
        }
    }
}

/// K = M·S⁻¹ into `gain` and E = M − ½·K·S into `half` (both n × m, M =
/// `cross`), column by column.
fn gain_and_half(
    n: usize,
    m: usize,
    cross: &DMatrix<f64>,
    inverse: &DMatrix<f64>,
    s: &DMatrix<f64>,
    gain: &mut DMatrix<f64>,
    half: &mut DMatrix<f64>,
) {
    resize(gain, n, m);
    resize(half, n, m);
    if n > 0 {
        let (m_values, k_values) = (cross.as_slice(), gain.as_mut_slice());
        let (inverse, s) = (inverse.as_slice(), s.as_slice());
        let e_values = half.as_mut_slice();
        crate::simd::wide(
            #[inline(always)]
            || {
                for p in 0..m {
                    let column = &mut k_values[p * n..(p + 1) * n];
                    column.fill(0.0);
                    for o in 0..m {
                        let factor = inverse[o + p * m];
                        for (into, &x) in column.iter_mut().zip(&m_values[o * n..(o + 1) * n]) {
                            *into += factor * x;
                        }
                    }
                }
                e_values.copy_from_slice(m_values);
                for p in 0..m {
                    let column = &mut e_values[p * n..(p + 1) * n];
                    for o in 0..m {
                        let factor = -0.5 * s[o + p * m];
                        for (into, &k) in column.iter_mut().zip(&k_values[o * n..(o + 1) * n]) {
                            *into += factor * k;
                        }
                    }
                }
            },
        );
    }
}

/// K·Eᵀ (K = `gain`, E = `half`, both n × m) into `product`, column by
/// column.
fn gain_times_half(
    n: usize,
    m: usize,
    gain: &DMatrix<f64>,
    half: &DMatrix<f64>,
    product: &mut DMatrix<f64>,
) {
    resize(product, n, n);
    if n > 0 {
        let (gain_values, half_values) = (gain.as_slice(), half.as_slice());
        let product = product.as_mut_slice();
        crate::simd::wide(
            #[inline(always)]
            || {
                for (c, column) in product.chunks_exact_mut(n).enumerate() {
                    column.fill(0.0);
                    for o in 0..m {
                        let factor = half_values[o * n + c];
                        let source = &gain_values[o * n..(o + 1) * n];
                        for (into, &k) in column.iter_mut().zip(source) {
                            *into += factor * k;
                        }
                    }
                }
            },
        );
    }
}

/// S⁻¹ of a symmetric positive definite S into `inverse` by its Cholesky
/// factor S = L·Lᵀ: L⁻¹ into `root_inverse` (lower triangle; one division
/// per row), S⁻¹ = L⁻ᵀ·L⁻¹ (exactly symmetric). Returns ln det S, or None
/// when S is not positive definite (or not finite).
fn inverse_by_root(
    s: &DMatrix<f64>,
    root_inverse: &mut DMatrix<f64>,
    inverse: &mut DMatrix<f64>,
) -> Option<f64> {
    let m = s.nrows();
    // L by columns into the lower triangle of `inverse` (a scratch here),
    // the reciprocals of its diagonal into `root_inverse`'s.
    resize(inverse, m, m);
    resize(root_inverse, m, m);
    let (l, t, s) = (
        inverse.as_mut_slice(),
        root_inverse.as_mut_slice(),
        s.as_slice(),
    );
    let mut log_det = 0.0;
    for j in 0..m {
        let mut d = s[j + j * m];
        for k in 0..j {
            d -= l[j + k * m] * l[j + k * m];
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let root = d.sqrt();
        log_det += root.ln();
        let reciprocal = 1.0 / root;
        l[j + j * m] = root;
        t[j + j * m] = reciprocal;
        for i in j + 1..m {
            let mut v = s[i + j * m];
            for k in 0..j {
                v -= l[i + k * m] * l[j + k * m];
            }
            l[i + j * m] = v * reciprocal;
        }
    }
    // T = L⁻¹ column by column: T_jj = 1/L_jj, T_ij = −(Σ_{j≤k<i} L_ik·T_kj)/L_ii.
    for j in 0..m {
        for i in j + 1..m {
            let mut v = 0.0;
            for k in j..i {
                v += l[i + k * m] * t[k + j * m];
            }
            t[i + j * m] = -v * t[i + i * m];
        }
    }
    // S⁻¹_ij = Σ_{k ≥ max(i, j)} T_ki·T_kj: dot products of T's columns.
    for j in 0..m {
        for i in 0..=j {
            let value = (j..m).map(|k| t[k + i * m] * t[k + j * m]).sum::<f64>();
            l[i + j * m] = value;
            l[j + i * m] = value;
        }
    }
    Some(2.0 * log_det)
}

/// P ← ½·(P + Pᵀ) − (F + Fᵀ), both n × n (F = `product`), P read from
/// `previous` (None: `into`'s own values) and written into `into`.
fn symmetric_difference(previous: Option<&[f64]>, into: &mut [f64], product: &DMatrix<f64>) {
    let n = product.nrows();
    let f = product.as_slice();
    let into = Cell::from_mut(into).as_slice_of_cells();
    #[inline(always)]
    fn entries(n: usize, p: impl Fn(usize) -> f64, f: &[f64], into: &[Cell<f64>]) {
        for j in 0..n {
            for i in 0..=j {
                let value = 0.5 * (p(i + j * n) + p(j + i * n)) - (f[i + j * n] + f[j + i * n]);
                into[i + j * n].set(value);
                into[j + i * n].set(value);
            }
        }
    }
    match previous {
        Some(p) => entries(n, |i| p[i], f, into),
        None => entries(n, |i| into[i].get(), f, into),
    }
}

/// The buffers of a sequential measurement update
/// ([`sequential_update_with`]) and what it produced, per output in the
/// order processed: the innovations νᵢ, their variances sᵢ and the gains.
#[derive(Debug, Clone, Default)]
pub struct SequentialWorkspace {
    observation: SparseRows,
    /// m = P·hᵢ.
    cross: Vec<f64>,
    /// e = m − ½·sᵢ·k.
    half: Vec<f64>,
    /// x − x⁻ so far.
    shift: Vec<f64>,
    /// νᵢ, the innovation against the estimate after the outputs before i.
    pub innovations: Vec<f64>,
    /// sᵢ = hᵢᵀ·P·hᵢ + rᵢ with P after the outputs before i.
    pub variances: Vec<f64>,
    /// kᵢ = P·hᵢ/sᵢ, one after another (n × m, column-major).
    pub gains: Vec<f64>,
}

impl SequentialWorkspace {
    /// The last update's H by its rows' entries, in the order processed
    /// (what [`ScalarUpdates::push_sequence`] keeps).
    ///
    /// [`ScalarUpdates::push_sequence`]: crate::kalman::kept::ScalarUpdates::push_sequence
    pub fn observation(&self) -> &SparseRows {
        &self.observation
    }

    /// Σ (νᵢ²/sᵢ + ln sᵢ) of the last update: νᵀ·S⁻¹·ν + ln det S, its
    /// term of −2·ln L (without 2π).
    pub fn log_likelihood_term(&self) -> f64 {
        self.innovations
            .iter()
            .zip(&self.variances)
            .map(|(nu, s)| nu * nu / s + s.ln())
            .sum()
    }
}

/// The measurement update of (x, P) with ν = z − ŷ, its sensitivity H
/// (m × n) and a diagonal measurement noise (the variances `noise`), as m
/// scalar updates in the order of H's rows (module header; Bierman 1977,
/// ch. II), in place; Joseph's form for each. Each output's ν, s and k
/// into `workspace`. An error when an sᵢ is not positive and finite.
/// Allocates nothing once the buffers have grown.
pub fn sequential_update_with(
    state: &mut DVector<f64>,
    covariance: &mut DMatrix<f64>,
    observation: &DMatrix<f64>,
    noise: &[f64],
    innovation: &DVector<f64>,
    workspace: &mut SequentialWorkspace,
) -> Result<()> {
    let n = state.len();
    let m = observation.nrows();
    debug_assert!(noise.len() == m && innovation.len() == m && covariance.nrows() == n);
    let SequentialWorkspace {
        observation: sparse,
        cross,
        half,
        shift,
        innovations,
        variances,
        gains,
    } = workspace;
    sparse.set(observation);
    for buffer in [&mut *cross, &mut *half, &mut *shift] {
        buffer.clear();
        buffer.resize(n, 0.0);
    }
    innovations.clear();
    variances.clear();
    gains.clear();
    gains.resize(n * m, 0.0);
    let p = covariance.as_mut_slice();
    let x = state.as_mut_slice();
    let positive = crate::simd::wide(
        #[inline(always)]
        || {
            for i in 0..m {
                let row = sparse.row(i);
                let nu = innovation[i] - row.iter().map(|&(j, h)| h * shift[j]).sum::<f64>();
                // m = P·h over h's non-zeros, s = hᵀ·m + r.
                combine_columns(cross, p, row.iter().copied());
                let s = row.iter().map(|&(j, h)| h * cross[j]).sum::<f64>() + noise[i];
                if !(s > 0.0 && s.is_finite()) {
                    return false;
                }
                let gain = &mut gains[i * n..(i + 1) * n];
                for ((k, e), &mi) in gain.iter_mut().zip(half.iter_mut()).zip(cross.iter()) {
                    *k = mi / s;
                    *e = mi - 0.5 * s * *k;
                }
                for ((x, d), &k) in x.iter_mut().zip(shift.iter_mut()).zip(gain.iter()) {
                    *x += k * nu;
                    *d += k * nu;
                }
                // P ← P − (k·eᵀ + e·kᵀ): entries (a, b) and (b, a) take the
                // same products, so a symmetric P stays symmetric.
                let (gain, half) = (&*gain, &*half);
                for (b, column) in p.chunks_exact_mut(n).enumerate() {
                    let (kb, eb) = (gain[b], half[b]);
                    for ((into, &k), &e) in column.iter_mut().zip(gain).zip(half) {
                        *into -= k * eb + e * kb;
                    }
                }
                innovations.push(nu);
                variances.push(s);
            }
            true
        },
    );
    if positive {
        Ok(())
    } else {
        Err(Error::NotPositive {
            what: "an innovation variance hᵀ·P·h + r".into(),
            why: " (a measurement noise variance of zero, or a covariance gone non-finite)",
        })
    }
}

/// A Gaussian estimate: mean and covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct Gaussian {
    pub mean: DVector<f64>,
    pub covariance: DMatrix<f64>,
}

/// What the modified Bryson–Frazier smoother needs of a measurement
/// update: H, S⁻¹, ν and K.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    pub observation: DMatrix<f64>,
    pub update: Update,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The measurement update from a covariance held in one matrix into
    /// another (a filter's kept predicted and filtered covariances) is the
    /// update in place bit for bit: state, covariance, S, S⁻¹ and K.
    #[test]
    fn update_into_another_matrix_is_the_update_in_place_bit_for_bit() {
        let n = 7;
        let value = |i: usize, j: usize| ((i * 3 + j * 11) as f64 * 0.53).cos();
        let root = DMatrix::from_fn(n, n, value);
        let mut covariance = &root * root.transpose() + DMatrix::identity(n, n);
        covariance[(2, 4)] += 1e-9;
        let observation = DMatrix::from_fn(
            2,
            n,
            |i, j| if (i + j) % 3 == 0 { value(i, j) } else { 0.0 },
        );
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 0.02]));
        let innovation = DVector::from_vec(vec![0.4, -1.1]);
        let state = DVector::from_fn(n, |i, _| value(i, 2));
        let (mut in_place, mut state_in_place) = (covariance.clone(), state.clone());
        let mut by_place = UpdateWorkspace::default();
        update_from(
            &mut state_in_place,
            None,
            in_place.as_mut_slice(),
            &observation,
            &noise,
            &innovation,
            &mut by_place,
        )
        .unwrap();
        let (mut into, mut state_into) = (vec![f64::NAN; n * n], state.clone());
        let mut by_copy = UpdateWorkspace::default();
        update_from(
            &mut state_into,
            Some(covariance.as_slice()),
            &mut into,
            &observation,
            &noise,
            &innovation,
            &mut by_copy,
        )
        .unwrap();
        let bits = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        assert!(bits(in_place.as_slice(), &into));
        assert!(bits(state_in_place.as_slice(), state_into.as_slice()));
        for (a, b) in [
            (
                &by_place.innovation_covariance,
                &by_copy.innovation_covariance,
            ),
            (&by_place.innovation_inverse, &by_copy.innovation_inverse),
            (&by_place.gain, &by_copy.gain),
        ] {
            assert!(bits(a.as_slice(), b.as_slice()));
        }
        assert_eq!(
            by_place.log_determinant.to_bits(),
            by_copy.log_determinant.to_bits()
        );
    }

    /// A scalar update whose variance hᵀ·P·h + r is not positive is an
    /// error, not a division by zero.
    #[test]
    fn scalar_update_without_variance_is_refused() {
        let mut x = DVector::zeros(2);
        let mut p = DMatrix::zeros(2, 2);
        let h = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
        let nu = DVector::from_vec(vec![1.0]);
        let mut workspace = SequentialWorkspace::default();
        assert!(sequential_update_with(&mut x, &mut p, &h, &[0.0], &nu, &mut workspace).is_err());
    }
}
