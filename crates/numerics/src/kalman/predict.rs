//! The time update P⁻ = Φ·P⁺·Φᵀ + Q_d (Jategaonkar, "Flight Vehicle
//! System Identification", 2nd ed., §5.2; Gelb, "Applied Optimal
//! Estimation", Table 4.2-1), Φ by its non-zeros ([`SparseRows`]) and,
//! where Φ's trailing rows are the identity's (an augmented model's
//! constant parameters), on its blocks; symmetrised.

use super::dense::{combine_columns, resize, symmetrise_values, symmetrised_into};
use super::sparse::SparseRows;
use nalgebra::DMatrix;

/// P⁻ = Φ·P·Φᵀ + Q_d.
pub fn predict_covariance(
    covariance: &DMatrix<f64>,
    transition: &DMatrix<f64>,
    process_noise: &DMatrix<f64>,
) -> DMatrix<f64> {
    let mut predicted = covariance.clone();
    let noise = process_noise
        .iter()
        .any(|&v| v != 0.0)
        .then_some(process_noise);
    let transition = SparseRows::of(transition);
    let n = transition.rows();
    resize(&mut predicted, n, n);
    predict_covariance_from(
        None,
        predicted.as_mut_slice(),
        &transition,
        noise,
        &mut Default::default(),
    );
    predicted
}

/// P ← Φ·P·Φᵀ + Q_d (`process_noise`; None: zero) into `into`, Φ by its
/// non-zeros: U = P·Φᵀ and Φ·U = (Uᵀ·Φᵀ)ᵀ, each O(nnz(Φ)·n) instead of
/// O(n³), symmetrised; `work` holds U and Uᵀ. Where Φ's rows from k on are
/// the identity's ([`SparseRows::set_leading`]: an augmented model's
/// constant parameters), Φ = \[\[Φ₁₁, Φ₁₂\], \[0, I\]\] = \[\[Φ₁\], \[0, I\]\] and
/// the blocks are P₁₁ ← Φ₁·P·Φ₁ᵀ, P₁₂ ← Φ₁₁·P₁₂ + Φ₁₂·P₂₂ (the rows of
/// W = P·Φ₁ᵀ, n × k, past k, transposed), P₂₂ unchanged: the same numbers
/// as the dense form's for a symmetric P, without its products over the
/// identity's rows.
///
/// P is the covariance `previous` (n × n, column-major; None: `into`'s own
/// values, the prediction in place), n the rows of Φ; `into` holds at
/// least n × n values (a filter's kept predicted covariance).
pub fn predict_covariance_from(
    previous: Option<&[f64]>,
    into: &mut [f64],
    transition: &SparseRows,
    process_noise: Option<&DMatrix<f64>>,
    work: &mut [DMatrix<f64>; 2],
) {
    let n = transition.rows();
    let into = &mut into[..n * n];
    if transition.leading < n {
        predict_constant_rows(previous, into, transition, &mut work[0]);
    } else {
        let [product, transposed] = work;
        transition.times_transposed_values(previous.unwrap_or(into), n, product);
        resize(transposed, product.ncols(), product.nrows());
        product.transpose_to(transposed);
        transition.times_transposed(transposed, product);
        let (p, f) = (&mut *into, product.as_slice());
        for j in 0..n {
            for i in 0..=j {
                let value = 0.5 * (f[i + j * n] + f[j + i * n]);
                p[i + j * n] = value;
                p[j + i * n] = value;
            }
        }
    }
    if let Some(noise) = process_noise {
        for (p, &q) in into.iter_mut().zip(noise.as_slice()) {
            *p += q;
        }
    }
}

/// Φ·P·Φᵀ in place for a Φ whose rows from k = `transition.leading` on
/// are the identity's ([`predict_covariance_from`]). With W = P·Φ₁ᵀ
/// (column r: Σ_j Φ_rj·P_{·j} over row r's non-zeros, as the dense form's
/// first product): (Φ·P·Φᵀ)_rc = Σ_j Φ_cj·W_jr for r, c < k, W_cr for
/// c ≥ k, P_rc for both ≥ k; symmetrised as the dense form symmetrises
/// (P is first made symmetric, which leaves a symmetric one as it is),
/// from `previous` (None: `p`'s own values) into `p`.
fn predict_constant_rows(
    previous: Option<&[f64]>,
    p: &mut [f64],
    transition: &SparseRows,
    w: &mut DMatrix<f64>,
) {
    let n = transition.rows();
    let k = transition.leading;
    match previous {
        Some(previous) => symmetrised_into(previous, p, n),
        None => symmetrise_values(p, n),
    }
    resize(w, n, k);
    {
        let w = w.as_mut_slice();
        let p = &*p;
        crate::simd::wide(
            #[inline(always)]
            || {
                for (r, column) in w.chunks_exact_mut(n).enumerate() {
                    combine_columns(column, p, transition.row(r).iter().copied());
                }
            },
        );
    }
    let w = w.as_slice();
    // The leading block: F_rc = Σ_j Φ_cj·W_jr, P_rc = ½·(F_rc + F_cr).
    let product = |r: usize, c: usize| {
        let column = &w[r * n..(r + 1) * n];
        let mut sum = 0.0;
        for &(j, value) in transition.row(c) {
            sum += value * column[j];
        }
        sum
    };
    for c in 0..k {
        for r in 0..=c {
            let value = 0.5 * (product(r, c) + product(c, r));
            p[r + c * n] = value;
            p[c + r * n] = value;
        }
    }
    // The cross blocks: P_rc = P_cr = W_cr (r < k ≤ c).
    for r in 0..k {
        for c in k..n {
            let value = w[c + r * n];
            p[r + c * n] = value;
            p[c + r * n] = value;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The prediction by blocks for a transition whose trailing rows are
    /// the identity's (an augmented model's constant parameters) gives the
    /// dense prediction's numbers bit for bit, with and without process
    /// noise, and leaves the constant block as it was.
    #[test]
    fn prediction_with_constant_rows_is_the_dense_one_bit_for_bit() {
        let (n, k) = (9, 3);
        let value = |i: usize, j: usize| ((i * 7 + j * 13) as f64 * 0.37).sin();
        let mut transition = DMatrix::identity(n, n);
        for i in 0..k {
            for j in 0..n {
                // Zeros in the leading rows too, where a model's are.
                if (i + j) % 4 != 1 {
                    transition[(i, j)] = 0.1 * value(i, j) + if i == j { 1.0 } else { 0.0 };
                }
            }
        }
        let root = DMatrix::from_fn(n, n, value);
        let covariance = &root * root.transpose() + DMatrix::identity(n, n);
        let noise = DMatrix::from_fn(n, n, |i, j| 1e-3 * value(i.min(j), i.max(j)));
        let mut blocks = SparseRows::default();
        blocks.set_leading(&transition, k);
        let dense = SparseRows::of(&transition);
        assert_eq!((blocks.leading, dense.leading), (k, n));
        for process in [None, Some(&noise)] {
            let (mut by_blocks, mut by_dense) = (covariance.clone(), covariance.clone());
            let mut work = Default::default();
            predict_covariance_from(None, by_blocks.as_mut_slice(), &blocks, process, &mut work);
            predict_covariance_from(None, by_dense.as_mut_slice(), &dense, process, &mut work);
            assert!(
                by_blocks
                    .iter()
                    .zip(by_dense.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{by_blocks}\n{by_dense}"
            );
            if process.is_none() {
                assert_eq!(
                    by_blocks.view((k, k), (n - k, n - k)),
                    covariance.view((k, k), (n - k, n - k))
                );
            }
        }
        // From another matrix into a third (a filter's kept covariances),
        // on both paths, for a symmetric P and one that is not (made
        // symmetric first): the numbers in place, bit for bit.
        let mut skewed = covariance.clone();
        skewed[(1, 5)] += 1e-9;
        skewed[(7, 0)] -= 3e-10;
        for start in [&covariance, &skewed] {
            for transition in [&blocks, &dense] {
                for process in [None, Some(&noise)] {
                    let mut in_place = start.clone();
                    let mut work = Default::default();
                    predict_covariance_from(
                        None,
                        in_place.as_mut_slice(),
                        transition,
                        process,
                        &mut work,
                    );
                    let mut into = vec![f64::NAN; n * n];
                    predict_covariance_from(
                        Some(start.as_slice()),
                        &mut into,
                        transition,
                        process,
                        &mut work,
                    );
                    assert!(
                        in_place
                            .iter()
                            .zip(&into)
                            .all(|(a, b)| a.to_bits() == b.to_bits())
                    );
                }
            }
        }
    }
}
