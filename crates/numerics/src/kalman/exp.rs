//! The matrix exponential e^M by scaling and squaring with a Taylor series
//! (Moler & Van Loan, "Nineteen dubious ways to compute the exponential of
//! a matrix, twenty-five years later", SIAM Rev. 45, 2003, method 3): the
//! matrix scaled by 2⁻ˢ to norm ≤ ½, at most 18 terms (truncation below
//! 10⁻¹⁸ relative), fewer where the terms fall below 2⁻⁶⁰ sooner, then s
//! squarings. When M's trailing rows are zero, M = [[X, Y], [0, 0]] (a
//! discretisation's input block, an augmented model's parameter rows),
//! e^M = [[e^X, φ₁(X)·Y], [0, I]], φ₁(X) = Σ Xʲ/(j + 1)!, is computed on
//! the k × k blocks ([`Exponential`]).

use super::dense::resize;
use nalgebra::DMatrix;

/// Taylor terms of the scaled exponential.
const TAYLOR_TERMS: usize = 18;

/// e^M by scaling and squaring (see the module header). When M's last r
/// rows are zero, M = [[X, Y], [0, 0]] (a discretisation's input block, an
/// augmented model's parameter rows), e^M = [[e^X, φ₁(X)·Y], [0, I]] is
/// computed on the blocks ([`Exponential::of`]): the series and squarings
/// of e^X and φ₁(X) on k × k matrices, then one product with Y, instead
/// of O((k + r)³) products.
pub fn exponential(matrix: &DMatrix<f64>) -> DMatrix<f64> {
    let mut result = DMatrix::zeros(0, 0);
    Exponential::default().of(matrix, &mut result);
    result
}

/// The buffers of [`exponential`], kept between calls so that a filter's
/// step takes the exponential without allocating.
#[derive(Debug, Clone, Default)]
pub struct Exponential {
    x: DMatrix<f64>,
    top_left: DMatrix<f64>,
    /// φ₁ of the scaled X, squared along with e^X.
    phi: DMatrix<f64>,
    term: DMatrix<f64>,
    product: DMatrix<f64>,
}

impl Exponential {
    /// e^`matrix` into `into` ([`exponential`]). With M = [[X, Y], [0, 0]]
    /// (r trailing zero rows) the series and the squarings run on k × k
    /// matrices only: the top-right block is linear in Y,
    /// [[E, Φ₁·Y], [0, I]]² = [[E², (E·Φ₁ + Φ₁)·Y], [0, I]], so
    /// φ₁(X) = Σ Xʲ/(j + 1)! is squared along with e^X and multiplies Y
    /// once at the end; the scaling is X's alone (Y does not enter the
    /// series' convergence).
    pub fn of(&mut self, matrix: &DMatrix<f64>, into: &mut DMatrix<f64>) {
        self.of_scaled(matrix, 1.0, into);
    }

    /// e^{`matrix`·h} into `into` (the same numbers as [`Exponential::of`]
    /// of the matrix times h, without forming it). Returns k, the rows of
    /// the matrix up to its last non-zero one: the rows of `into` from k on
    /// are the identity's.
    pub fn of_scaled(&mut self, matrix: &DMatrix<f64>, h: f64, into: &mut DMatrix<f64>) -> usize {
        let n = matrix.nrows();
        resize(into, n, n);
        self.of_scaled_into(matrix, h, into.as_mut_slice())
    }

    /// [`Exponential::of_scaled`] into the values (column-major, n × n) of
    /// a matrix held elsewhere (a filter's kept transition).
    pub fn of_scaled_into(&mut self, matrix: &DMatrix<f64>, h: f64, into: &mut [f64]) -> usize {
        let n = matrix.nrows();
        let values = matrix.as_slice();
        // The rows below the last non-zero entry of any column are zero
        // (each column read from its end down to the rows known non-zero).
        let mut k = 0;
        for column in values.chunks_exact(n.max(1)) {
            if let Some(i) = column[k..].iter().rposition(|&v| v != 0.0) {
                k += i + 1;
            }
        }
        let mut largest = 0.0f64;
        for column in values.chunks_exact(n.max(1)).take(k) {
            for &v in &column[..k] {
                largest = largest.max((v * h).abs());
            }
        }
        let squarings = squarings_for(largest * k as f64);
        // The same sums with k known at compile time for the small leading
        // blocks (an augmented model's kinematic states), so that the
        // series' products and sums unroll, compiled for AVX2 where the CPU
        // has it ([`crate::simd::wide`]: the same numbers).
        macro_rules! leading {
            ($($size:literal)*) => {
                match k {
                    $($size => self.leading_block($size, n, squarings, values, h, into),)*
                    _ => self.leading_block(k, n, squarings, values, h, into),
                }
            };
        }
        crate::simd::wide(
            #[inline(always)]
            || leading!(1 2 3 4 5 6 7 8),
        );
        k
    }

    /// [`Exponential::of_scaled`] past finding k, the rows of `values`
    /// (column-major, n × n) up to their last non-zero one, and the squarings:
    /// the series and squarings of the k × k block and the rest of `into`.
    #[inline(always)]
    fn leading_block(
        &mut self,
        k: usize,
        n: usize,
        squarings: i32,
        values: &[f64],
        h: f64,
        result: &mut [f64],
    ) {
        let scale = 2f64.powi(-squarings);
        resize(&mut self.x, k, k);
        for (into, column) in self
            .x
            .as_mut_slice()
            .chunks_exact_mut(k.max(1))
            .zip(values.chunks_exact(n.max(1)))
        {
            for (into, &v) in into.iter_mut().zip(&column[..k]) {
                *into = (v * h) * scale;
            }
        }
        resize(&mut self.top_left, k, k);
        resize(&mut self.phi, k, k);
        resize(&mut self.term, k, k);
        resize(&mut self.product, k, k);
        let x = &self.x.as_slice()[..k * k];
        let mut top_left = &mut self.top_left.as_mut_slice()[..k * k];
        let phi = &mut self.phi.as_mut_slice()[..k * k];
        let term = &mut self.term.as_mut_slice()[..k * k];
        let mut product = &mut self.product.as_mut_slice()[..k * k];
        taylor_series(k, x, top_left, phi, term, product);
        // [[E, Φ₁], [0, I]]² = [[E², E·Φ₁ + Φ₁], [0, I]].
        for _ in 0..squarings {
            square_product(k, top_left, phi, product);
            for (into, &p) in phi.iter_mut().zip(product.iter()) {
                *into += p;
            }
            square_product(k, top_left, top_left, product);
            std::mem::swap(&mut top_left, &mut product);
        }
        let result = &mut result[..n * n];
        result.fill(0.0);
        for (c, column) in result.chunks_exact_mut(n.max(1)).enumerate() {
            if c < k {
                column[..k].copy_from_slice(&top_left[c * k..(c + 1) * k]);
            } else {
                column[c] = 1.0;
            }
        }
        // The top-right block: Φ₁·(Y·h·2⁻ˢ), column by column.
        if k > 0 {
            for c in k..n {
                let source = &values[c * n..c * n + k];
                let column = &mut result[c * n..c * n + k];
                for (&y, phi) in source.iter().zip(phi.chunks_exact(k)) {
                    let y = (y * h) * scale;
                    for (into, &phi) in column.iter_mut().zip(phi) {
                        *into += phi * y;
                    }
                }
            }
        }
    }
}

/// The Taylor series of the scaled k × k block X (column-major):
/// E = Σ_{j ≤ J} Xʲ/j! into `top_left`, Φ₁ = Σ_{j < J} Xʲ/(j + 1)! into
/// `phi`, J ≤ 18, ended early where a term's bound k·max|Xʲ/j!| is below
/// 2⁻⁶⁰ (‖X‖∞ ≤ ½, so the rest of either series is smaller still: below
/// the rounding of E's unit diagonal); `term` and `product` are scratch.
#[inline(always)]
fn taylor_series(
    k: usize,
    x: &[f64],
    top_left: &mut [f64],
    phi: &mut [f64],
    term: &mut [f64],
    product: &mut [f64],
) {
    identity(k, top_left);
    phi.fill(0.0);
    identity(k, term);
    let negligible = 2f64.powi(-60) / k.max(1) as f64;
    for j in 1..=TAYLOR_TERMS {
        let j = j as f64;
        for (phi, &term) in phi.iter_mut().zip(term.iter()) {
            *phi += term / j;
        }
        square_product(k, term, x, product);
        // The quotients, sums and largest entry in loops of their own,
        // so that the divisions run as vector instructions.
        for (term, &p) in term.iter_mut().zip(product.iter()) {
            *term = p / j;
        }
        for (left, &term) in top_left.iter_mut().zip(term.iter()) {
            *left += term;
        }
        let size = term.iter().fold(0.0f64, |size, term| size.max(term.abs()));
        if size < negligible {
            // Φ₁'s next term, Xʲ/(j + 1)!, is this one over j + 1.
            for (phi, &term) in phi.iter_mut().zip(term.iter()) {
                *phi += term / (j + 1.0);
            }
            break;
        }
    }
}

/// The squarings that bring a matrix of norm bound `norm` (n times its
/// largest entry) to ½ or below, where the Taylor series of
/// [`Exponential`] and [`ProcessNoise`] converge fast.
pub(super) fn squarings_for(norm: f64) -> i32 {
    if norm > 0.5 {
        (norm / 0.5).log2().ceil() as i32
    } else {
        0
    }
}

/// a·b of two k × k matrices (column-major slices) into `into`: the sums
/// of [`multiply`] in the same order, inlined so that a k known where it
/// is called unrolls them.
#[inline(always)]
fn square_product(k: usize, a: &[f64], b: &[f64], into: &mut [f64]) {
    if k == 0 {
        return;
    }
    let (a, b) = (&a[..k * k], &b[..k * k]);
    for (column, b) in into[..k * k].chunks_exact_mut(k).zip(b.chunks_exact(k)) {
        column.fill(0.0);
        for (&factor, a) in b.iter().zip(a.chunks_exact(k)) {
            for (sum, &a) in column.iter_mut().zip(a) {
                *sum += factor * a;
            }
        }
    }
}

/// The k × k identity into a column-major slice.
#[inline(always)]
fn identity(k: usize, into: &mut [f64]) {
    into[..k * k].fill(0.0);
    for i in 0..k {
        into[i + i * k] = 1.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::testing::{assert_close, system};
    use nalgebra::DVector;

    #[test]
    fn exponential_of_a_diagonalisable_matrix_matches_its_eigen_form() {
        // A rotation generator: e^{[[0, w], [−w, 0]]·t} = [[cos, sin], [−sin, cos]].
        let w: f64 = 7.3;
        let m = DMatrix::from_row_slice(2, 2, &[0.0, w, -w, 0.0]);
        let exact = DMatrix::from_row_slice(2, 2, &[w.cos(), w.sin(), -w.sin(), w.cos()]);
        assert_close(&exponential(&m), &exact, 1e-13, "rotation");
        // Diagonal: e^d elementwise, across scales.
        let d = DMatrix::from_diagonal(&DVector::from_vec(vec![-30.0, 0.001, 4.0]));
        let exact = DMatrix::from_diagonal(&DVector::from_vec(vec![
            (-30.0f64).exp(),
            0.001f64.exp(),
            4.0f64.exp(),
        ]));
        assert_close(&exponential(&d), &exact, 1e-13, "diagonal");
    }

    /// A matrix with zero trailing rows (a system with its input block)
    /// against the same exponential with those rows perturbed by 10⁻³⁰⁰
    /// (the dense path, the same scaling): equal to rounding, with the
    /// zero rows' block exactly [0, I].
    #[test]
    fn exponential_of_a_block_with_zero_rows_is_the_dense_one() {
        let (a, b) = system();
        let h = 0.3;
        let mut block = DMatrix::zeros(4, 4);
        block.view_mut((0, 0), (3, 3)).copy_from(&(&a * h));
        block.view_mut((0, 3), (3, 1)).copy_from(&(&b * h));
        let structured = exponential(&block);
        let mut dense = block.clone();
        dense[(3, 0)] = 1e-300;
        let dense = exponential(&dense);
        assert_close(&structured, &dense, 1e-14, "blocks");
        assert_eq!(structured[(3, 3)], 1.0);
        assert_eq!(structured[(3, 0)], 0.0);
    }

    /// e^{A·h} of a matrix whose last rows are zero (an augmented model's
    /// A: k rows of states, zero rows of constant parameters) with k the
    /// block sizes taken at compile time (1–8) and one past them (9): the
    /// AVX2 build's numbers are the baseline's bit for bit (both exact
    /// IEEE sums and quotients in the same order), and e^{A·h}·e^{−A·h}
    /// is the identity to rounding (1e-13 for ‖A·h‖ ≈ 1).
    #[test]
    fn leading_block_exponential_is_the_same_on_every_path() {
        let n = 14;
        for k in [0, 1, 4, 8, 9] {
            let a = DMatrix::from_fn(n, n, |i, j| {
                if i < k {
                    ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.45
                } else {
                    0.0
                }
            });
            let exponential = |a: &DMatrix<f64>| {
                let mut into = DMatrix::zeros(0, 0);
                let leading = Exponential::default().of_scaled(a, 0.3, &mut into);
                assert!(leading <= k);
                into
            };
            let wide = exponential(&a);
            let baseline = crate::simd::baseline(|| exponential(&a));
            assert_eq!(wide, baseline, "k = {k}");
            let inverse = exponential(&-&a);
            let error = (&wide * &inverse - DMatrix::identity(n, n)).amax();
            assert!(error < 1e-13, "k = {k}: {error}");
        }
    }
}
