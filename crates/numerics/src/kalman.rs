//! The Kalman-filtering core every filter method shares: discretisation,
//! time and measurement updates, the steady-state gain, the
//! Rauch–Tung–Striebel and modified Bryson–Frazier smoothers, and sigma
//! points. Methods hold the model ([`aeroid_estimation::model`]); this
//! module holds only the linear algebra.
//!
//! - Discretisation (Van Loan, "Computing integrals involving the matrix
//!   exponential", IEEE TAC 23(3), 1978, §4): with ẋ = A·x + B·u + G·w,
//!   E[w·wᵀ] = Q_c, the step h transition Φ = e^{A·h}, the input matrix
//!   Γ = ∫₀ʰ e^{A·s} ds·B and the discrete process noise
//!   Q_d = ∫₀ʰ e^{A·s}·G·Q_c·Gᵀ·e^{Aᵀ·s} ds come from the exponentials of
//!   the block matrices [[A, B], [0, 0]]·h and [[−A, GQ_cGᵀ], [0, Aᵀ]]·h;
//!   Q_d, the second's top-right block times Φ, is summed as that block's
//!   series on n × n matrices with doubling ([`ProcessNoise`]).
//!   The exponential is by scaling and squaring with a Taylor series
//!   (Moler & Van Loan, "Nineteen dubious ways…", SIAM Rev. 45, 2003,
//!   method 3): the matrix scaled to norm ≤ ½, at most 18 terms (truncation
//!   below 10⁻¹⁸ relative), fewer where the terms fall below 2⁻⁶⁰ sooner;
//!   on its blocks when its trailing rows are zero.
//! - Time update P⁻ = Φ·P⁺·Φᵀ + Q_d; measurement update with gain
//!   K = P⁻·Hᵀ·S⁻¹, S = H·P⁻·Hᵀ + R, state x⁺ = x⁻ + K·ν and covariance in
//!   Joseph's form P⁺ = (I − K·H)·P⁻·(I − K·H)ᵀ + K·R·Kᵀ (Jategaonkar,
//!   "Flight Vehicle System Identification", 2nd ed., §5.2, Eqs. 5.8–5.14;
//!   Gelb, "Applied Optimal Estimation", Table 4.2-1). S is factored by
//!   Cholesky; one that is not positive definite is an error.
//! - The same measurement update as a sequence of scalar updates, one per
//!   output, for a diagonal R (Bierman, "Factorization Methods for
//!   Discrete Sequential Estimation", 1977, ch. II; [`sequential_update_with`]):
//!   for output i with row hᵢ of H and variance rᵢ, in turn,
//!   νᵢ = zᵢ − ŷᵢ − hᵢᵀ·(x − x⁻) (the innovation against the estimate so
//!   far, H linearised at x⁻), m = P·hᵢ, sᵢ = hᵢᵀ·m + rᵢ, k = m/sᵢ,
//!   x ← x + k·νᵢ, P ← P − (k·eᵀ + e·kᵀ) with e = m − ½·sᵢ·k (Joseph's form
//!   (I − k·hᵢᵀ)·P·(I − k·hᵢᵀ)ᵀ + k·rᵢ·kᵀ expanded). No matrix inverse, each
//!   O(n²); equal to the vector update in exact arithmetic, and
//!   ln det S = Σ ln sᵢ, νᵀ·S⁻¹·ν = Σ νᵢ²/sᵢ for the sequential
//!   innovations.
//! - The steady-state gain of a time-invariant system (the filter error
//!   method's, Jategaonkar §5.3, Eq. 5.23): the predicted covariance P
//!   solving the discrete algebraic Riccati equation
//!   P = Φ·(P − P·Hᵀ·(H·P·Hᵀ + R)⁻¹·H·P)·Φᵀ + Q_d, by the structured
//!   doubling algorithm (Chu, Fan & Lin, "A structure-preserving doubling
//!   algorithm for discrete-time algebraic Riccati equations", Linear
//!   Algebra Appl. 396, 2005, Eq. 2.5), quadratically convergent.
//! - Rauch–Tung–Striebel smoother (Rauch, Tung & Striebel, AIAA J. 3(8),
//!   1965): x_{k|N} = x_{k|k} + C_k·(x_{k+1|N} − x_{k+1|k}),
//!   C_k = P_{k|k}·Φ_kᵀ·P_{k+1|k}⁻¹.
//! - Modified Bryson–Frazier smoother (Bierman, "Fixed interval smoothing
//!   with discrete measurements", Int. J. Control 18(1), 1973; the form of
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
//! - Mehra's residual-correlation estimates of the noise covariances from a
//!   constant-gain filter's innovations ([`residual_correlation`]).
//! - Sigma points of the scaled unscented transform (Wan & van der Merwe,
//!   "The unscented Kalman filter for nonlinear estimation", IEEE AS-SPCC
//!   2000, Eq. 15): χ₀ = x̄, χ_{±i} = x̄ ± (√((n + λ)·P))_i,
//!   λ = α²·(n + κ) − n, weights W₀ᵐ = λ/(n + λ),
//!   W₀ᶜ = W₀ᵐ + 1 − α² + β, Wᵢ = 1/(2(n + λ)).

use crate::kept::{
    GaussianView, Gaussians, Matrices, ScalarUpdates, SparseMatrices, UpdateView, Updates,
};
use aeroid_core::error::{Error, Result};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use std::cell::Cell;

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
        // Taylor series: E = Σ_{j ≤ J} Xʲ/j!, Φ₁ = Σ_{j < J} Xʲ/(j + 1)!,
        // J ≤ 18, ended early where a term's bound k·max|Xʲ/j!| is below
        // 2⁻⁶⁰ (‖X‖∞ ≤ ½, so the rest of either series is smaller still:
        // below the rounding of E's unit diagonal).
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

/// The most terms of [`ProcessNoise`]'s series.
const NOISE_TERMS: usize = 24;

/// The discrete process noise Q_d = ∫₀ʰ e^{A·s}·Q_c·e^{Aᵀ·s} ds of
/// ẋ = A·x + w, E[w·wᵀ] = Q_c·δ, by its Taylor series and doubling: the
/// integrand's derivatives at 0 are L_j = A·L_{j−1} + L_{j−1}·Aᵀ, L_0 = Q_c,
/// so Q_d(τ) = Σ_j τ^{j+1}/(j + 1)!·L_j, taken for τ = h·2⁻ˢ with A·τ
/// scaled as [`Exponential`] scales it (‖A·τ‖ ≤ ½: the j-th term below
/// ‖Q_c‖·τ/(j + 1)!; ended where n times a term's largest entry falls
/// below 2⁻⁶⁰ of Q_c's, at most 24 terms); then s doublings
/// Q_d(2τ) = Q_d(τ) + Φ(τ)·Q_d(τ)·Φ(τ)ᵀ,
/// Φ(2τ) = Φ(τ)². The same matrix as Van Loan's block exponential (module
/// header) to rounding, from products of n × n matrices over A's non-zeros
/// instead of the series of a 2n × 2n one. The buffers are kept between
/// calls, so that a filter's step takes it without allocating.
#[derive(Debug, Clone, Default)]
pub struct ProcessNoise {
    scaled: DMatrix<f64>,
    sparse: SparseRows,
    term: DMatrix<f64>,
    product: DMatrix<f64>,
    transition: DMatrix<f64>,
    exponential: Exponential,
    work: [DMatrix<f64>; 2],
}

impl ProcessNoise {
    /// Q_d of A = `a`, Q_c = `noise` (symmetric) over a step h into `into`,
    /// symmetric.
    pub fn of(&mut self, a: &DMatrix<f64>, noise: &DMatrix<f64>, h: f64, into: &mut DMatrix<f64>) {
        let n = a.nrows();
        let squarings =
            squarings_for(a.iter().map(|v| (v * h).abs()).fold(0.0, f64::max) * n as f64);
        let tau = h * 2f64.powi(-squarings);
        resize(&mut self.scaled, n, n);
        for (into, &a) in self.scaled.iter_mut().zip(a.iter()) {
            *into = a * tau;
        }
        self.sparse.set(&self.scaled);
        // The sum Σ_j L_j·τʲ/(j + 1)! (times τ at the end), its term
        // M_j = L_j·τʲ = X·M_{j−1} + (X·M_{j−1})ᵀ, X·M = (M·Xᵀ)ᵀ (M symmetric).
        resize(into, n, n);
        into.copy_from(noise);
        resize(&mut self.term, n, n);
        self.term.copy_from(noise);
        let largest = noise.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut factor = 1.0;
        for j in 1..=NOISE_TERMS {
            self.sparse.times_transposed(&self.term, &mut self.product);
            factor /= (j + 1) as f64;
            let (term, product, sum) = (
                self.term.as_mut_slice(),
                self.product.as_slice(),
                into.as_mut_slice(),
            );
            let mut size = 0.0f64;
            for c in 0..n {
                for r in 0..n {
                    let value = product[r + c * n] + product[c + r * n];
                    term[r + c * n] = value;
                    sum[r + c * n] += factor * value;
                    size = size.max(value.abs());
                }
            }
            if size * factor * n as f64 <= 2f64.powi(-60) * largest {
                break;
            }
        }
        *into *= tau;
        if squarings > 0 {
            self.exponential.of(&self.scaled, &mut self.transition);
            let [product, outer] = &mut self.work;
            for _ in 0..squarings {
                // Q ← Q + Φ·Q·Φᵀ, Φ ← Φ².
                resize(product, n, n);
                product.gemm(1.0, into, &self.transition.transpose(), 0.0);
                resize(outer, n, n);
                outer.gemm(1.0, &self.transition, product, 0.0);
                *into += &*outer;
                multiply(&self.transition, &self.transition, product);
                std::mem::swap(&mut self.transition, product);
            }
        }
        symmetrise(into);
    }
}

/// The squarings that bring a matrix of norm bound `norm` (n times its
/// largest entry) to ½ or below, where the Taylor series of
/// [`Exponential`] and [`ProcessNoise`] converge fast.
fn squarings_for(norm: f64) -> i32 {
    if norm > 0.5 {
        (norm / 0.5).log2().ceil() as i32
    } else {
        0
    }
}

/// Replaces a square matrix by its symmetric part, (M + Mᵀ)/2, in place.
pub fn symmetrise(matrix: &mut DMatrix<f64>) {
    let n = matrix.nrows();
    symmetrise_values(matrix.as_mut_slice(), n);
}

/// [`symmetrise`] of an n × n matrix's values (column-major).
fn symmetrise_values(m: &mut [f64], n: usize) {
    let m = Cell::from_mut(m).as_slice_of_cells();
    symmetric_part(n, |i| m[i].get(), m);
}

/// The symmetric part of the n × n matrix `from` into `into` (both
/// column-major): the numbers of [`symmetrise`] in place.
fn symmetrised_into(from: &[f64], into: &mut [f64], n: usize) {
    let into = Cell::from_mut(into).as_slice_of_cells();
    symmetric_part(n, |i| from[i], into);
}

/// The symmetric part of the n × n matrix whose entries `from` reads
/// (column-major positions) written into `into` (the same cells: in
/// place): the mean of each off-diagonal pair, the diagonal as it is.
#[inline(always)]
fn symmetric_part(n: usize, from: impl Fn(usize) -> f64, into: &[Cell<f64>]) {
    for j in 0..n {
        for i in 0..j {
            let mean = (from(i + j * n) + from(j + i * n)) * 0.5;
            into[i + j * n].set(mean);
            into[j + i * n].set(mean);
        }
        into[j + j * n].set(from(j + j * n));
    }
}

/// Gives `matrix` the shape rows × columns, zeros when it changes, in its
/// own storage (allocating only when it needs more room than it had).
pub fn resize(matrix: &mut DMatrix<f64>, rows: usize, columns: usize) {
    if matrix.shape() != (rows, columns) {
        let mut values: Vec<f64> = std::mem::replace(matrix, DMatrix::zeros(0, 0)).data.into();
        values.clear();
        values.resize(rows * columns, 0.0);
        *matrix = DMatrix::from_vec(rows, columns, values);
    }
}

/// `into` = a·b, in place, column by column (for small matrices: the
/// exponential's series, the UKF's measurement update).
pub fn multiply(a: &DMatrix<f64>, b: &DMatrix<f64>, into: &mut DMatrix<f64>) {
    let rows = a.nrows();
    resize(into, rows, b.ncols());
    if rows == 0 {
        return;
    }
    if a.is_square() && b.shape() == a.shape() {
        let (a, b, into) = (a.as_slice(), b.as_slice(), into.as_mut_slice());
        match rows {
            2 => return multiply_square::<2>(a, b, into),
            3 => return multiply_square::<3>(a, b, into),
            4 => return multiply_square::<4>(a, b, into),
            5 => return multiply_square::<5>(a, b, into),
            6 => return multiply_square::<6>(a, b, into),
            7 => return multiply_square::<7>(a, b, into),
            8 => return multiply_square::<8>(a, b, into),
            _ => {}
        }
    }
    let a = a.as_slice();
    for (column, b) in into
        .as_mut_slice()
        .chunks_exact_mut(rows)
        .zip(b.as_slice().chunks_exact(b.nrows().max(1)))
    {
        column.fill(0.0);
        for (&factor, a) in b.iter().zip(a.chunks_exact(rows)) {
            for (into, &a) in column.iter_mut().zip(a) {
                *into += factor * a;
            }
        }
    }
}

/// [`multiply`] of two N × N matrices (column-major slices) with N known
/// at compile time, so that the loops unroll: the same sums in the same
/// order.
#[inline(always)]
fn multiply_square<const N: usize>(a: &[f64], b: &[f64], into: &mut [f64]) {
    let (a, b) = (&a[..N * N], &b[..N * N]);
    for (c, into) in into[..N * N].chunks_exact_mut(N).enumerate() {
        let mut column = [0.0; N];
        for l in 0..N {
            let factor = b[l + c * N];
            for (sum, &a) in column.iter_mut().zip(&a[l * N..(l + 1) * N]) {
                *sum += factor * a;
            }
        }
        into.copy_from_slice(&column);
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

/// A linear system over one step: x_{k+1} = Φ·x_k + Γ·u_k + w_k,
/// E[w·wᵀ] = Q_d.
#[derive(Debug, Clone, PartialEq)]
pub struct Discrete {
    /// Φ = e^{A·h}.
    pub transition: DMatrix<f64>,
    /// Γ = ∫₀ʰ e^{A·s} ds·B (a held input).
    pub input: DMatrix<f64>,
    /// Q_d (zero without process noise).
    pub process_noise: DMatrix<f64>,
}

/// Φ, Γ and Q_d of ẋ = A·x + B·u + G·w over a step h, with `noise` the
/// continuous spectral density G·Q_c·Gᵀ (None: no process noise). Van
/// Loan's method (module header).
pub fn discretise(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    noise: Option<&DMatrix<f64>>,
    h: f64,
) -> Discrete {
    let n = a.nrows();
    let m = b.ncols();
    let mut block = DMatrix::zeros(n + m, n + m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    block.view_mut((0, n), (n, m)).copy_from(&(b * h));
    let exp = exponential(&block);
    let transition = exp.view((0, 0), (n, n)).into_owned();
    let input = exp.view((0, n), (n, m)).into_owned();
    let process_noise = match noise {
        None => DMatrix::zeros(n, n),
        Some(noise) => {
            let mut process_noise = DMatrix::zeros(n, n);
            ProcessNoise::default().of(a, noise, h, &mut process_noise);
            process_noise
        }
    };
    Discrete {
        transition,
        input,
        process_noise,
    }
}

/// The input matrices of one step under a first-order hold, u linear from
/// u_k to u_{k+1} over the step: x_{k+1} = Φ·x_k + Γ₀·u_k + Γ₁·(u_{k+1} − u_k)
/// with Γ₀ = ∫₀ʰ e^{A·s} ds·B (the zero-order hold's Γ) and
/// Γ₁ = ∫₀ʰ e^{A·(h−s)}·B·s/h ds, both from one exponential of the block
/// matrix [[A·h, B·h, 0], [0, 0, I], [0, 0, 0]] (Van Loan; Franklin, Powell
/// & Workman, "Digital Control of Dynamic Systems", §6.3.2). Returns
/// (Φ, Γ₀, Γ₁).
pub fn discretise_first_order_hold(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    h: f64,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (a.nrows(), b.ncols());
    let mut block = DMatrix::zeros(n + 2 * m, n + 2 * m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    block.view_mut((0, n), (n, m)).copy_from(&(b * h));
    block
        .view_mut((n, n + m), (m, m))
        .copy_from(&DMatrix::identity(m, m));
    let exp = exponential(&block);
    (
        exp.view((0, 0), (n, n)).into_owned(),
        exp.view((0, n), (n, m)).into_owned(),
        exp.view((0, n + m), (n, m)).into_owned(),
    )
}

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
    predict_covariance_in_place(
        &mut predicted,
        &SparseRows::of(transition),
        noise,
        &mut Default::default(),
    );
    predicted
}

/// A matrix's non-zero entries row by row, so that products with it skip
/// its zeros: an augmented model's transition (its parameter rows are rows
/// of the identity), the Gauss–Markov chains' rows, an observation's unit
/// rows. Rebuilt in place ([`SparseRows::set`]) without allocating once
/// its storage has grown. A filter reads matrices of one sparsity pattern
/// at every step (a model's Jacobian, its transition, the observation
/// matrix): when every non-zero of the matrix read lies on the pattern
/// already held, only the values are gathered on it (an entry of the
/// pattern may then hold a zero, which a product adds as 0·x).
#[derive(Debug, Clone, Default)]
pub struct SparseRows {
    /// The pattern's id: a number drawn once for each pattern built in the
    /// process (kept by its copies; 0 for none), so that a pattern held
    /// elsewhere is recognised without comparing it.
    pattern: u64,
    /// For a transpose read from another pattern
    /// ([`SparseRows::set_transposed_rows`]): that pattern's id and, per
    /// entry, the entry of it the value comes from.
    source: (u64, Vec<usize>),
    /// Read as the transpose ([`SparseRows::set_transposed_values`]).
    transposed: bool,
    columns: usize,
    /// The rows from this one on are the identity's
    /// ([`SparseRows::set_leading`]; all rows where none are known to be).
    leading: usize,
    /// Row i's entries (column, value) are `entries[starts[i]..starts[i + 1]]`
    /// (`entries` may hold more, unused).
    starts: Vec<usize>,
    entries: Vec<(usize, f64)>,
}

impl SparseRows {
    /// The non-zeros of `matrix`.
    pub fn of(matrix: &DMatrix<f64>) -> SparseRows {
        let mut sparse = SparseRows::default();
        sparse.set(matrix);
        sparse
    }

    /// Reads the non-zeros of `matrix`.
    pub fn set(&mut self, matrix: &DMatrix<f64>) {
        self.set_leading(matrix, matrix.nrows());
    }

    /// Reads the non-zeros of the first `leading` rows of `matrix`; its
    /// rows from `leading` on are taken as the identity's (a transition's
    /// rows of constant states, [`Exponential::of_scaled`]).
    pub fn set_leading(&mut self, matrix: &DMatrix<f64>, leading: usize) {
        let (rows, columns) = matrix.shape();
        self.set_leading_values(matrix.as_slice(), rows, columns, leading);
    }

    /// [`SparseRows::set_leading`] of the rows × columns matrix whose
    /// values (column-major) are `values`.
    pub fn set_leading_values(
        &mut self,
        values: &[f64],
        rows: usize,
        columns: usize,
        leading: usize,
    ) {
        let leading = leading.min(rows);
        if self.values_on_pattern(false, values, rows, columns, leading) {
            return;
        }
        self.transposed = false;
        self.begin(columns);
        self.leading = leading;
        // Every entry is written and only a non-zero one kept (no branch):
        // `entries` holds room for all of them.
        if self.entries.len() < values.len() {
            self.entries.resize(values.len(), (0, 0.0));
        }
        let entries = self.entries.as_mut_slice();
        let mut count = 0;
        for i in 0..leading.min(rows) {
            for (j, &value) in values[i..].iter().step_by(rows).enumerate() {
                entries[count] = (j, value);
                count += usize::from(value != 0.0);
            }
            self.starts.push(count);
        }
        for i in leading.min(rows)..rows {
            entries[count] = (i, 1.0);
            count += 1;
            self.starts.push(count);
        }
    }

    /// The non-zeros of `other` times `factor`, on `other`'s pattern
    /// (those of a matrix and of its multiple: A and A·h).
    pub fn scaled_from(&mut self, other: &SparseRows, factor: f64) {
        (self.pattern, self.transposed, self.columns, self.leading) = (
            other.pattern,
            other.transposed,
            other.columns,
            other.leading,
        );
        self.starts.clone_from(&other.starts);
        self.entries.clear();
        let used = &other.entries[..other.starts.last().copied().unwrap_or(0)];
        self.entries
            .extend(used.iter().map(|&(j, value)| (j, value * factor)));
    }

    /// Reads the non-zeros of `matrix`ᵀ (the rows are its columns).
    pub fn set_transposed(&mut self, matrix: &DMatrix<f64>) {
        self.set_transposed_values(matrix.as_slice(), matrix.nrows());
    }

    /// [`SparseRows::set_transposed`] of the matrix of `rows` rows whose
    /// values (column-major) are `values`.
    pub fn set_transposed_values(&mut self, values: &[f64], rows: usize) {
        let columns = values.len().checked_div(rows).unwrap_or(0);
        if self.values_on_pattern(true, values, rows, columns, rows) {
            return;
        }
        self.transposed = true;
        self.begin(rows);
        self.leading = columns;
        // Every entry is written and only a non-zero one kept (no branch):
        // `entries` holds room for all of them.
        if self.entries.len() < values.len() {
            self.entries.resize(values.len(), (0, 0.0));
        }
        let entries = self.entries.as_mut_slice();
        let mut count = 0;
        for column in values.chunks_exact(rows.max(1)) {
            for (i, &value) in column.iter().enumerate() {
                entries[count] = (i, value);
                count += usize::from(value != 0.0);
            }
            self.starts.push(count);
        }
    }

    /// Gathers the values of the matrix (`rows` × `columns`, column-major
    /// `values`; read as its transpose if `transposed`, its rows from
    /// `leading` on as the identity's otherwise) on the pattern held, and
    /// says whether the pattern holds the matrix: the same shape and
    /// orientation, and as many non-zeros gathered as the matrix has.
    /// False leaves the held values to be rebuilt.
    fn values_on_pattern(
        &mut self,
        transposed: bool,
        values: &[f64],
        rows: usize,
        columns: usize,
        leading: usize,
    ) -> bool {
        let (held_rows, kept) = if transposed {
            (columns, columns)
        } else {
            (rows, leading)
        };
        let same_shape = self.transposed == transposed
            && self.columns == if transposed { rows } else { columns }
            && self.starts.len() == held_rows + 1
            && self.leading == kept
            && values.len() == rows * columns;
        if !same_shape || rows == 0 {
            return false;
        }
        let held = self.starts[kept];
        let counted: usize = if transposed || leading == rows {
            values.iter().map(|&v| usize::from(v != 0.0)).sum()
        } else {
            values
                .chunks_exact(rows)
                .map(|column| {
                    column[..leading]
                        .iter()
                        .map(|&v| usize::from(v != 0.0))
                        .sum::<usize>()
                })
                .sum()
        };
        if counted > held {
            return false;
        }
        let mut gathered = 0;
        for i in 0..kept {
            let (from, to) = (self.starts[i], self.starts[i + 1]);
            for entry in &mut self.entries[from..to] {
                let value = if transposed {
                    values[entry.0 + i * rows]
                } else {
                    values[i + entry.0 * rows]
                };
                entry.1 = value;
                gathered += usize::from(value != 0.0);
            }
        }
        gathered == counted
    }

    fn begin(&mut self, columns: usize) {
        static PATTERNS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        self.pattern = PATTERNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.source.0 = 0;
        self.columns = columns;
        self.starts.clear();
        self.starts.push(0);
    }

    /// The number of columns.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// The id of the pattern held (0: none built).
    pub fn pattern(&self) -> u64 {
        self.pattern
    }

    /// Holds the pattern whose row i has the entries at the columns
    /// `rows[i]` (in the order given) over `columns` columns, their values
    /// zero.
    pub fn set_pattern<R, I>(&mut self, columns: usize, rows: R)
    where
        R: IntoIterator<Item = I>,
        I: IntoIterator<Item = usize>,
    {
        self.transposed = false;
        self.begin(columns);
        self.entries.clear();
        for row in rows {
            self.entries.extend(row.into_iter().map(|j| (j, 0.0)));
            self.starts.push(self.entries.len());
        }
        self.leading = self.rows();
    }

    /// The entries of every row, one row after another.
    pub fn entries(&self) -> &[(usize, f64)] {
        &self.entries[..self.starts.last().copied().unwrap_or(0)]
    }

    /// [`SparseRows::entries`] for writing their values.
    pub fn entries_mut(&mut self) -> &mut [(usize, f64)] {
        let used = self.starts.last().copied().unwrap_or(0);
        &mut self.entries[..used]
    }

    /// The pattern of `pattern` (its copy, unless held already) with the
    /// values `values`, one per entry in [`SparseRows::entries`]' order.
    pub fn set_from(&mut self, pattern: &SparseRows, values: &[f64]) {
        if self.pattern != pattern.pattern || self.pattern == 0 {
            self.clone_from(pattern);
        }
        for (entry, &value) in self.entries_mut().iter_mut().zip(values) {
            entry.1 = value;
        }
    }

    /// Reads `matrix`ᵀ from its entries (the rows of the result are the
    /// columns of `matrix`, each row's entries in increasing column, as
    /// [`SparseRows::set_transposed_values`] reads them from a dense
    /// matrix); the transposed pattern is built once for each pattern of
    /// `matrix` and its values gathered on it.
    pub fn set_transposed_rows(&mut self, matrix: &SparseRows) {
        if self.source.0 != matrix.pattern || matrix.pattern == 0 || self.rows() != matrix.columns {
            let mut counts = vec![0; matrix.columns + 1];
            for &(j, _) in matrix.entries() {
                counts[j + 1] += 1;
            }
            for j in 0..matrix.columns {
                counts[j + 1] += counts[j];
            }
            let used = matrix.entries().len();
            let mut from = vec![0; used];
            let mut entries = vec![(0, 0.0); used];
            let mut next = counts.clone();
            for i in 0..matrix.rows() {
                for position in matrix.starts[i]..matrix.starts[i + 1] {
                    let j = matrix.entries[position].0;
                    entries[next[j]] = (i, 0.0);
                    from[next[j]] = position;
                    next[j] += 1;
                }
            }
            self.transposed = true;
            self.begin(matrix.rows());
            self.starts.clear();
            self.starts.extend_from_slice(&counts);
            self.entries = entries;
            self.leading = matrix.columns;
            self.source = (matrix.pattern, from);
        }
        let values = matrix.entries();
        for (entry, &from) in self.entries.iter_mut().zip(&self.source.1) {
            entry.1 = values[from].1;
        }
    }

    /// The number of rows.
    pub fn rows(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// Row i's non-zeros (column, value).
    pub fn row(&self, i: usize) -> &[(usize, f64)] {
        &self.entries[self.starts[i]..self.starts[i + 1]]
    }

    /// `into` = x·Sᵀ (x with as many columns as S, `into` x's rows × S's
    /// rows): column i of `into` is Σ_j S_ij·(column j of x), a sum over
    /// row i's non-zeros only.
    pub fn times_transposed(&self, x: &DMatrix<f64>, into: &mut DMatrix<f64>) {
        debug_assert_eq!(x.ncols(), self.columns);
        self.times_transposed_values(x.as_slice(), x.nrows(), into);
    }

    /// [`SparseRows::times_transposed`] of the matrix x of `rows` rows
    /// whose values (column-major) are `x`.
    pub fn times_transposed_values(&self, x: &[f64], rows: usize, into: &mut DMatrix<f64>) {
        resize(into, rows, self.rows());
        if rows == 0 {
            return;
        }
        let into = into.as_mut_slice();
        crate::simd::wide(
            #[inline(always)]
            || {
                for (i, column) in into.chunks_exact_mut(rows).enumerate() {
                    combine_columns(column, x, self.row(i).iter().copied());
                }
            },
        )
    }
}

/// `into` = Σ f·(column j of `x`) over the terms (j, f) in order, x
/// column-major with `into.len()` rows: each entry summed from zero in the
/// terms' order (the numbers of a loop that adds each term's column into
/// `into` in turn), by blocks of 16 and 4 rows held in registers across
/// the terms instead of read and written back for each term. Inlined into
/// the caller's [`crate::simd::wide`] kernel.
#[inline(always)]
pub(crate) fn combine_columns<I>(into: &mut [f64], x: &[f64], terms: I)
where
    I: Iterator<Item = (usize, f64)> + Clone,
{
    #[inline(always)]
    fn block<const B: usize, I: Iterator<Item = (usize, f64)>>(
        into: &mut [f64],
        x: &[f64],
        rows: usize,
        start: usize,
        terms: I,
    ) {
        let mut sum = [0.0; B];
        for (j, factor) in terms {
            let source: &[f64; B] = x[j * rows + start..j * rows + start + B]
                .try_into()
                .expect("a block of B rows");
            for (sum, &value) in sum.iter_mut().zip(source) {
                *sum += factor * value;
            }
        }
        into[start..start + B].copy_from_slice(&sum);
    }
    let rows = into.len();
    let mut start = 0;
    while start + 16 <= rows {
        block::<16, _>(into, x, rows, start, terms.clone());
        start += 16;
    }
    while start + 4 <= rows {
        block::<4, _>(into, x, rows, start, terms.clone());
        start += 4;
    }
    while start < rows {
        block::<1, _>(into, x, rows, start, terms.clone());
        start += 1;
    }
}

/// `into`_i = Σ_a x_ia·y_ia over the columns a of x and y (column-major,
/// `into.len()` rows each), summed in the columns' order by blocks of 16
/// and 4 rows held in registers ([`combine_columns`]).
#[inline(always)]
fn sum_of_products(into: &mut [f64], x: &[f64], y: &[f64]) {
    #[inline(always)]
    fn block<const B: usize>(into: &mut [f64], x: &[f64], y: &[f64], rows: usize, start: usize) {
        let mut sum = [0.0; B];
        for (x, y) in x.chunks_exact(rows).zip(y.chunks_exact(rows)) {
            let x: &[f64; B] = x[start..start + B].try_into().expect("B rows");
            let y: &[f64; B] = y[start..start + B].try_into().expect("B rows");
            for ((sum, &x), &y) in sum.iter_mut().zip(x).zip(y) {
                *sum += x * y;
            }
        }
        into[start..start + B].copy_from_slice(&sum);
    }
    let rows = into.len();
    if rows == 0 {
        return;
    }
    let mut start = 0;
    while start + 16 <= rows {
        block::<16>(into, x, y, rows, start);
        start += 16;
    }
    while start + 4 <= rows {
        block::<4>(into, x, y, rows, start);
        start += 4;
    }
    while start < rows {
        block::<1>(into, x, y, rows, start);
        start += 1;
    }
}

/// P ← Φ·P·Φᵀ + Q_d (`process_noise`; None: zero) in place, Φ by its
/// non-zeros: U = P·Φᵀ and Φ·U = (Uᵀ·Φᵀ)ᵀ, each O(nnz(Φ)·n) instead of
/// O(n³), symmetrised; `work` holds U and Uᵀ. Where Φ's rows from k on are
/// the identity's ([`SparseRows::set_leading`]: an augmented model's
/// constant parameters), Φ = \[\[Φ₁₁, Φ₁₂\], \[0, I\]\] = \[\[Φ₁\], \[0, I\]\] and
/// the blocks are P₁₁ ← Φ₁·P·Φ₁ᵀ, P₁₂ ← Φ₁₁·P₁₂ + Φ₁₂·P₂₂ (the rows of
/// W = P·Φ₁ᵀ, n × k, past k, transposed), P₂₂ unchanged: the same numbers
/// as the dense form's for a symmetric P, without its products over the
/// identity's rows.
pub fn predict_covariance_in_place(
    covariance: &mut DMatrix<f64>,
    transition: &SparseRows,
    process_noise: Option<&DMatrix<f64>>,
    work: &mut [DMatrix<f64>; 2],
) {
    let n = transition.rows();
    resize(covariance, n, n);
    predict_covariance_from(
        None,
        covariance.as_mut_slice(),
        transition,
        process_noise,
        work,
    );
}

/// [`predict_covariance_in_place`] of the covariance `previous` (n × n,
/// column-major; None: `into`'s own values) into `into` (n × n, held
/// elsewhere: a filter's kept predicted covariance), n the rows of Φ: the
/// same numbers, without a copy of the result.
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
/// are the identity's ([`predict_covariance_in_place`]). With W = P·Φ₁ᵀ
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
    update_with(
        state,
        covariance,
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

/// The buffers of a measurement update ([`update_with`]) and what it
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
pub fn update_with(
    state: &mut DVector<f64>,
    covariance: &mut DMatrix<f64>,
    observation: &DMatrix<f64>,
    noise: &DMatrix<f64>,
    innovation: &DVector<f64>,
    workspace: &mut UpdateWorkspace,
) -> Result<()> {
    update_from(
        state,
        None,
        covariance.as_mut_slice(),
        observation,
        noise,
        innovation,
        workspace,
    )
}

/// [`update_with`] of the covariance `predicted` (n × n, column-major;
/// None: `into`'s own values) into `into` (n × n, held elsewhere: a
/// filter's kept filtered covariance): the same numbers, without a copy of
/// the result.
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
    *log_det = inverse_by_root(s, root_inverse, inverse).ok_or_else(|| {
        Error::Other(
            "the innovation covariance H·P·Hᵀ + R is not positive definite (a measurement noise variance of zero, or a covariance gone non-finite)".into(),
        )
    })?;
    // K = M·S⁻¹ and E = M − ½·K·S, column by column.
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
    state.gemv(1.0, gain, innovation, 1.0);
    // K·Eᵀ, column by column.
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
    symmetric_difference(predicted, into, product);
    Ok(())
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
        Err(Error::Other(
            "an innovation variance hᵀ·P·h + r is not positive (a measurement noise variance of zero, or a covariance gone non-finite)".into(),
        ))
    }
}

/// The steady state of a time-invariant filter.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyState {
    /// The predicted covariance P solving the Riccati equation.
    pub covariance: DMatrix<f64>,
    /// K = P·Hᵀ·S⁻¹.
    pub gain: DMatrix<f64>,
    /// S = H·P·Hᵀ + R.
    pub innovation_covariance: DMatrix<f64>,
}

/// Doubling iterations before the Riccati solution is declared not found.
const DOUBLING_LIMIT: usize = 60;

/// The steady-state predicted covariance and gain of
/// x_{k+1} = Φ·x_k + w (Q_d), z = H·x + v (R), by the structured doubling
/// algorithm (module header). An error when it does not converge (Φ not
/// detectable through H, or a singular step).
pub fn steady_state(
    transition: &DMatrix<f64>,
    observation: &DMatrix<f64>,
    process_noise: &DMatrix<f64>,
    noise: &DMatrix<f64>,
) -> Result<SteadyState> {
    let n = transition.nrows();
    let noise_inverse = Cholesky::new(noise.clone())
        .ok_or_else(|| {
            Error::Other("the measurement noise covariance R is not positive definite".into())
        })?
        .inverse();
    let identity = DMatrix::<f64>::identity(n, n);
    // The DARE X = AᵀXA − AᵀXB(R + BᵀXB)⁻¹BᵀXA + Q with A = Φᵀ, B = Hᵀ.
    let mut a = transition.transpose();
    let mut g = observation.transpose() * &noise_inverse * observation;
    let mut x = process_noise.clone();
    for _ in 0..DOUBLING_LIMIT {
        let w = &identity + &g * &x;
        let lu = w.lu();
        let solve = |m: &DMatrix<f64>| lu.solve(m);
        let (Some(wa), Some(wg)) = (solve(&a), solve(&g)) else {
            return Err(Error::Other(
                "the Riccati equation's doubling met a singular matrix".into(),
            ));
        };
        let next_x = &x + a.transpose() * &x * &wa;
        let next_g = &g + &a * wg * a.transpose();
        let next_a = &a * wa;
        let change = (&next_x - &x).norm();
        x = (&next_x + next_x.transpose()) * 0.5;
        g = (&next_g + next_g.transpose()) * 0.5;
        a = next_a;
        if !x.iter().all(|v| v.is_finite()) {
            break;
        }
        if change <= 1e-14 * x.norm().max(f64::MIN_POSITIVE) {
            let s = observation * &x * observation.transpose() + noise;
            let s_inverse = Cholesky::new(s.clone())
                .ok_or_else(|| {
                    Error::Other(
                        "the steady-state innovation covariance is not positive definite".into(),
                    )
                })?
                .inverse();
            let gain = &x * observation.transpose() * s_inverse;
            let closed_loop = transition * (&identity - &gain * observation);
            if !is_stable(closed_loop) {
                break;
            }
            return Ok(SteadyState {
                covariance: x,
                gain,
                innovation_covariance: s,
            });
        }
    }
    Err(Error::Other(
        "the steady-state Riccati equation has no solution: the system is not detectable through the outputs, or not stabilisable by the process noise".into(),
    ))
}

/// Newton iterations of [`steady_state_for_innovation`] before it gives up.
const NEWTON_LIMIT: usize = 50;

/// The steady state of a time-invariant filter whose innovation
/// covariance is given (the filter error method's R, Jategaonkar §5.3,
/// where R is estimated from the innovations and the measurement noise is
/// what is left of it, G·Gᵀ = R − H·P·Hᵀ, Eq. 5.13): the predicted
/// covariance P solving P = Φ·(P − P·Hᵀ·S⁻¹·H·P)·Φᵀ + Q_d, the gain
/// K = P·Hᵀ·S⁻¹, and the measurement noise V = S − H·P·Hᵀ it implies.
/// This P is the steady state of the ordinary filter ([`steady_state`])
/// with measurement noise V, whose innovation covariance is then S.
///
/// Solved by Newton's method on the matrix equation, from the steady state
/// with measurement noise S (whose P bounds the solution from above): the
/// derivative in the direction X is Φ·(L·X·Lᵀ − M·X·Mᵀ)·Φᵀ − X with
/// M = K·H and L = I − M, solved as an n²-dimensional linear system
/// (Kronecker form), until the equation's residual is below 10⁻¹³ of P.
/// An error when no such steady state exists: the iteration does not
/// converge, the filter is not stable, or V is not positive definite (an
/// eigenvalue of K·H at or above 1: process noise too large for S).
pub fn steady_state_for_innovation(
    transition: &DMatrix<f64>,
    observation: &DMatrix<f64>,
    process_noise: &DMatrix<f64>,
    innovation: &DMatrix<f64>,
) -> Result<(SteadyState, DMatrix<f64>)> {
    let n = transition.nrows();
    let innovation_inverse = Cholesky::new(innovation.clone())
        .ok_or_else(|| Error::Other("the innovation covariance R is not positive definite".into()))?
        .inverse();
    let weight = observation.transpose() * &innovation_inverse * observation;
    let identity = DMatrix::<f64>::identity(n, n);
    let residual_of = |p: &DMatrix<f64>| {
        transition * (p - p * &weight * p) * transition.transpose() + process_noise - p
    };
    let mut p = steady_state(transition, observation, process_noise, innovation)?.covariance;
    let mut residual = residual_of(&p);
    let mut converged = false;
    for _ in 0..NEWTON_LIMIT {
        if residual.norm() <= 1e-13 * p.norm().max(f64::MIN_POSITIVE) {
            converged = true;
            break;
        }
        let m = &p * &weight;
        let left = transition * (&identity - &m);
        let right = transition * &m;
        let jacobian = left.kronecker(&left)
            - right.kronecker(&right)
            - DMatrix::<f64>::identity(n * n, n * n);
        let rhs = DVector::from_column_slice((-&residual).as_slice());
        let Some(step) = jacobian.lu().solve(&rhs) else {
            break;
        };
        let step = DMatrix::from_column_slice(n, n, step.as_slice());
        let next = &p + (&step + step.transpose()) * 0.5;
        if !next.iter().all(|v| v.is_finite()) {
            break;
        }
        p = next;
        residual = residual_of(&p);
    }
    let refuse = |why: &str| {
        Err(Error::Other(format!(
            "no steady-state filter has this innovation covariance: {why}"
        )))
    };
    if !converged {
        return refuse("the Riccati equation's Newton iteration did not converge");
    }
    let gain = &p * observation.transpose() * &innovation_inverse;
    let noise = innovation - observation * &p * observation.transpose();
    let noise = (&noise + noise.transpose()) * 0.5;
    if Cholesky::new(noise.clone()).is_none() {
        return refuse(
            "the measurement noise R − H·P·Hᵀ is not positive definite (K·H has an eigenvalue at or above 1)",
        );
    }
    if !is_stable(transition * (&identity - &gain * observation)) {
        return refuse("the filter it defines is not stable");
    }
    Ok((
        SteadyState {
            covariance: p,
            gain,
            innovation_covariance: innovation.clone(),
        },
        noise,
    ))
}

/// Whether every eigenvalue of a transition matrix lies inside the unit
/// circle: its 2³⁰th power (by squaring) vanishes.
fn is_stable(mut matrix: DMatrix<f64>) -> bool {
    for _ in 0..30 {
        matrix = &matrix * &matrix;
        let norm = matrix.norm();
        if !norm.is_finite() || norm > 1e100 {
            return false;
        }
    }
    matrix.norm() < 1e-6
}

/// A Gaussian estimate: mean and covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct Gaussian {
    pub mean: DVector<f64>,
    pub covariance: DMatrix<f64>,
}

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
        return Err(Error::Other(
            "the RTS smoother needs every filtered and predicted covariance and every transition"
                .into(),
        ));
    }
    for k in (0..n - 1).rev() {
        let prior = predicted.get(k + 1).expect("checked above");
        let inverse = Cholesky::new(prior.covariance.into_owned())
            .ok_or_else(|| {
                Error::Other(format!(
                    "the RTS smoother: the predicted covariance at step {} is not positive definite",
                    k + 1
                ))
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

/// What the modified Bryson–Frazier smoother needs of a measurement
/// update: H, S⁻¹, ν and K.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    pub observation: DMatrix<f64>,
    pub update: Update,
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

/// Gives `vector` the length `len`, zeros when it changes, in its own
/// storage (allocating only when it needs more room than it had).
pub fn resize_vector(vector: &mut DVector<f64>, len: usize) {
    if vector.len() != len {
        let mut values: Vec<f64> = std::mem::replace(vector, DVector::zeros(0)).data.into();
        values.clear();
        values.resize(len, 0.0);
        *vector = DVector::from_vec(values);
    }
}

/// The scaled unscented transform's parameters (Wan & van der Merwe 2000).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unscented {
    /// Spread of the points about the mean (10⁻³ … 1).
    pub alpha: f64,
    /// Prior knowledge of the distribution (2 for a Gaussian).
    pub beta: f64,
    /// Secondary scaling (0, or 3 − n).
    pub kappa: f64,
}

impl Default for Unscented {
    fn default() -> Self {
        Unscented {
            alpha: 1.0,
            beta: 2.0,
            kappa: 0.0,
        }
    }
}

/// 2n + 1 sigma points with their mean and covariance weights.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaPoints {
    pub points: Vec<DVector<f64>>,
    pub mean_weights: Vec<f64>,
    pub covariance_weights: Vec<f64>,
}

impl Unscented {
    /// The sigma points of (x̄, P); an error when P is not positive definite.
    pub fn points(&self, mean: &DVector<f64>, covariance: &DMatrix<f64>) -> Result<SigmaPoints> {
        let n = mean.len();
        let lambda = self.alpha * self.alpha * (n as f64 + self.kappa) - n as f64;
        let scale = n as f64 + lambda;
        let root = Cholesky::<f64, Dyn>::new(covariance * scale)
            .ok_or_else(|| {
                Error::Other("the UKF's state covariance is not positive definite".into())
            })?
            .unpack();
        let mut points = Vec::with_capacity(2 * n + 1);
        points.push(mean.clone());
        for i in 0..n {
            points.push(mean + root.column(i));
        }
        for i in 0..n {
            points.push(mean - root.column(i));
        }
        let weight = 1.0 / (2.0 * scale);
        let mut mean_weights = vec![weight; 2 * n + 1];
        let mut covariance_weights = mean_weights.clone();
        mean_weights[0] = lambda / scale;
        covariance_weights[0] = lambda / scale + 1.0 - self.alpha * self.alpha + self.beta;
        Ok(SigmaPoints {
            points,
            mean_weights,
            covariance_weights,
        })
    }
}

impl SigmaPoints {
    /// The weighted mean of transformed points.
    pub fn mean_of(&self, transformed: &[DVector<f64>]) -> DVector<f64> {
        let mut mean = DVector::zeros(transformed[0].len());
        for (point, &w) in transformed.iter().zip(&self.mean_weights) {
            mean.axpy(w, point, 1.0);
        }
        mean
    }

    /// The weighted cross-covariance Σ W_i·(a_i − ā)(b_i − b̄)ᵀ.
    pub fn cross_covariance(
        &self,
        a: &[DVector<f64>],
        a_mean: &DVector<f64>,
        b: &[DVector<f64>],
        b_mean: &DVector<f64>,
    ) -> DMatrix<f64> {
        let mut result = DMatrix::zeros(a_mean.len(), b_mean.len());
        for ((a, b), &w) in a.iter().zip(b).zip(&self.covariance_weights) {
            let da = a - a_mean;
            let db = b - b_mean;
            result.ger(w, &da, &db, 1.0);
        }
        result
    }
}

/// What Mehra's residual-correlation method estimates ([`residual_correlation`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualCorrelation {
    /// R̂ = Ĉ₀ − H·(M·Hᵀ)^ (Mehra Eq. 30).
    pub measurement: DMatrix<f64>,
    /// The diagonal of the discrete process noise Q_d, zero where not
    /// estimated; entries the least squares put below zero are zero.
    pub process: DVector<f64>,
    /// (M·Hᵀ)^ (Mehra Eq. 29).
    pub cross: DMatrix<f64>,
}

/// Mehra's residual-correlation estimates of the noise of a time-invariant
/// system x_{k+1} = Φ·x_k + w_k (E[w·wᵀ] = Q_d), z_k = H·x_k + v_k
/// (E[v·vᵀ] = R) from the innovations ν_k of a filter with the constant,
/// not necessarily optimal, gain K (Mehra, "On the identification of
/// variances and adaptive Kalman filtering", IEEE TAC 15(2), 1970, §IV):
/// 1. the sample autocorrelations Ĉ_j = (1/N)·Σ_{i≥j} ν_i·ν_{i−j}ᵀ,
///    j = 0 … `lags` (Eq. 13);
/// 2. with C_j = H·Ψ^{j−1}·Φ·(M·Hᵀ − K·C₀), Ψ = Φ·(I − K·H), M the
///    filter's predicted error covariance (Eq. 21), M·Hᵀ = K·Ĉ₀ + A⁺·Ĉ by
///    least squares over the lags, A = [H·Φ; H·Ψ·Φ; …; H·Ψ^{lags−1}·Φ],
///    Ĉ = [Ĉ₁; …; Ĉ_lags] (Eq. 29; unique when `lags` ≥ the states and the
///    system is observable);
/// 3. R̂ = Ĉ₀ − H·M·Hᵀ (Eq. 30);
/// 4. Q_d from M = Φ·M·Φᵀ + Ω + Q_d, Ω = Φ·(K·C₀·Kᵀ − K·H·M − M·Hᵀ·Kᵀ)·Φᵀ,
///    which gives for j = 1 … `lags`
///    Σ_{l<j} H·Φˡ·Q_d·Φ^{(l−j)ᵀ}·Hᵀ = H·M·Φ^{−jᵀ}·Hᵀ − H·Φʲ·M·Hᵀ
///    − Σ_{l<j} H·Φˡ·Ω·Φ^{(l−j)ᵀ}·Hᵀ (Eq. 33), whose right side needs only
///    M·Hᵀ; with Q_d diagonal on the states `noisy`, linear in its
///    entries, solved by least squares over every entry of every lag.
///
/// An error when there are not more innovations than lags, no lag is
/// asked for, or Φ is singular.
pub fn residual_correlation(
    transition: &DMatrix<f64>,
    observation: &DMatrix<f64>,
    gain: &DMatrix<f64>,
    innovations: &[DVector<f64>],
    lags: usize,
    noisy: &[usize],
) -> Result<ResidualCorrelation> {
    let (n, m, count) = (transition.nrows(), observation.nrows(), innovations.len());
    if lags == 0 || count <= lags {
        return Err(Error::Other(format!(
            "the residual-correlation method needs at least one lag and more innovations than lags ({count} innovations, {lags} lags)"
        )));
    }
    let autocorrelation = |j: usize| {
        let mut sum = DMatrix::zeros(m, m);
        for i in j..count {
            sum += &innovations[i] * innovations[i - j].transpose();
        }
        sum / count as f64
    };
    let correlations: Vec<DMatrix<f64>> = (0..=lags).map(autocorrelation).collect();
    let zero = &correlations[0];
    let closed = transition * (DMatrix::identity(n, n) - gain * observation);
    let mut stacked = DMatrix::zeros(lags * m, n);
    let mut measured = DMatrix::zeros(lags * m, m);
    let mut power = transition.clone();
    for j in 0..lags {
        stacked
            .rows_mut(j * m, m)
            .copy_from(&(observation * &power));
        measured.rows_mut(j * m, m).copy_from(&correlations[j + 1]);
        power = &closed * power;
    }
    let solved = stacked
        .svd(true, true)
        .solve(&measured, 1e-12)
        .map_err(|e| Error::Other(format!("the residual-correlation least squares: {e}")))?;
    let cross = gain * zero + solved;
    let measurement = zero - observation * &cross;
    let measurement = (&measurement + measurement.transpose()) * 0.5;
    let inverse = transition.clone().try_inverse().ok_or_else(|| {
        Error::Other("the residual-correlation method needs an invertible transition".into())
    })?;
    let omega = transition
        * (gain * zero * gain.transpose() - gain * cross.transpose() - &cross * gain.transpose())
        * transition.transpose();
    // Φˡ·Hᵀ's transposes H·Φˡ for l = 0 … lags and H·Φ^{−l} for l = 1 … lags.
    let mut forward = vec![observation.clone()];
    let mut backward = vec![observation.clone()];
    for _ in 0..lags {
        let last = forward.last().cloned().unwrap_or_default();
        forward.push(last * transition);
        let last = backward.last().cloned().unwrap_or_default();
        backward.push(last * &inverse);
    }
    let mut design = DMatrix::zeros(lags * m * m, noisy.len());
    let mut right = DVector::zeros(lags * m * m);
    for j in 1..=lags {
        // H·M·Φ^{−jᵀ}·Hᵀ = (Φ^{−j}·M·Hᵀ)ᵀ·Hᵀ, and M·Hᵀ = `cross`.
        let inverse_power = (0..j).fold(DMatrix::identity(n, n), |p, _| p * &inverse);
        let mut side = (inverse_power * &cross).transpose() * observation.transpose()
            - &forward[j].clone() * &cross;
        for l in 0..j {
            side -= &forward[l] * &omega * backward[j - l].transpose();
        }
        for (c, &i) in noisy.iter().enumerate() {
            let mut term = DMatrix::<f64>::zeros(m, m);
            for l in 0..j {
                term += forward[l].column(i) * backward[j - l].column(i).transpose();
            }
            for (e, value) in term.iter().enumerate() {
                design[((j - 1) * m * m + e, c)] = *value;
            }
        }
        for (e, value) in side.iter().enumerate() {
            right[(j - 1) * m * m + e] = *value;
        }
    }
    let entries = design
        .svd(true, true)
        .solve(&right, 1e-12)
        .map_err(|e| Error::Other(format!("the residual-correlation least squares: {e}")))?;
    let mut process = DVector::zeros(n);
    for (c, &i) in noisy.iter().enumerate() {
        process[i] = entries[c].max(0.0);
    }
    Ok(ResidualCorrelation {
        measurement,
        process,
        cross,
    })
}

/// The fraction of lags 1 … `lags` at which the normalised autocorrelation
/// of `series` (mean removed) lies inside ±1.96/√N, the 95 % band of
/// white noise (Box & Jenkins; Jategaonkar §6.5.1): a whiteness test of
/// innovations. NaN for a constant or too short series.
pub fn whiteness(series: &[f64], lags: usize) -> f64 {
    let n = series.len();
    if n < 2 || lags == 0 || lags >= n {
        return f64::NAN;
    }
    let mean = series.iter().sum::<f64>() / n as f64;
    let centred: Vec<f64> = series.iter().map(|v| v - mean).collect();
    let zero: f64 = centred.iter().map(|v| v * v).sum();
    if zero <= 0.0 {
        return f64::NAN;
    }
    let band = 1.96 / (n as f64).sqrt();
    let inside = (1..=lags)
        .filter(|&lag| {
            let r: f64 = (lag..n).map(|i| centred[i] * centred[i - lag]).sum::<f64>() / zero;
            r.abs() <= band
        })
        .count();
    inside as f64 / lags as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_close(a: &DMatrix<f64>, b: &DMatrix<f64>, tolerance: f64, what: &str) {
        let scale = b.norm().max(1e-300);
        let error = (a - b).norm() / scale;
        assert!(
            error <= tolerance,
            "{what}: relative error {error:e}\n{a}\n{b}"
        );
    }

    /// A damped oscillator (short period like) and a slow real mode.
    fn system() -> (DMatrix<f64>, DMatrix<f64>) {
        let a = DMatrix::from_row_slice(3, 3, &[-1.2, 1.0, 0.0, -8.0, -2.1, 0.3, 0.0, 0.5, -0.05]);
        let b = DMatrix::from_row_slice(3, 1, &[-0.1, -9.0, 0.0]);
        (a, b)
    }

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
            predict_covariance_in_place(&mut by_blocks, &blocks, process, &mut work);
            predict_covariance_in_place(&mut by_dense, &dense, process, &mut work);
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
                    predict_covariance_in_place(&mut in_place, transition, process, &mut work);
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
        update_with(
            &mut state_in_place,
            &mut in_place,
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

    /// The unrolled product of small square matrices is the general loop's,
    /// bit for bit.
    #[test]
    fn small_square_products_are_the_general_ones() {
        for n in 2..=9 {
            let a = DMatrix::from_fn(n, n, |i, j| ((i * 5 + j * 3) as f64 * 0.71).cos() / 3.0);
            let b = DMatrix::from_fn(n, n, |i, j| ((i * 2 + j * 11) as f64 * 0.29).sin() * 1e3);
            let mut fast = DMatrix::zeros(0, 0);
            multiply(&a, &b, &mut fast);
            let mut general = DMatrix::<f64>::zeros(n, n);
            for c in 0..n {
                for l in 0..n {
                    for r in 0..n {
                        general[(r, c)] += b[(l, c)] * a[(r, l)];
                    }
                }
            }
            assert!(
                fast.iter()
                    .zip(general.iter())
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "n = {n}"
            );
        }
    }

    /// Reading a matrix into a SparseRows that holds another's pattern
    /// gives a fresh read's non-zeros whether the pattern is the same or
    /// holds entries the matrix has as zeros (values gathered on it,
    /// the zeros kept as entries), or the matrix has a non-zero off the
    /// pattern (read afresh), as rows and as the transpose, with trailing
    /// identity rows or without.
    #[test]
    fn sparse_rows_read_on_a_held_pattern_are_a_fresh_read() {
        let base = DMatrix::from_fn(7, 7, |i, j| {
            if (i * 3 + j * 5) % 4 == 0 {
                ((i * 7 + j) as f64 * 0.37).sin() + 2.0
            } else {
                0.0
            }
        });
        let mut scaled = base.clone() * -1.5;
        let mut more = base.clone();
        more[(1, 2)] = 0.5;
        let mut fewer = base.clone();
        fewer[(0, 0)] = 0.0;
        let mut moved = fewer.clone();
        moved[(1, 2)] = 0.25;
        scaled[(6, 6)] = 3.0;
        let rows_of = |s: &SparseRows| -> Vec<Vec<(usize, f64)>> {
            (0..s.rows())
                .map(|i| s.row(i).iter().copied().filter(|e| e.1 != 0.0).collect())
                .collect()
        };
        for leading in [7, 4] {
            let (mut held, mut transposed) = (SparseRows::default(), SparseRows::default());
            for matrix in [&base, &base, &scaled, &more, &fewer, &moved, &base] {
                held.set_leading(matrix, leading);
                if std::ptr::eq(matrix, &fewer) {
                    // Read on the pattern of `more`, which holds (0, 0).
                    assert_eq!(held.row(0).first(), Some(&(0, 0.0)));
                }
                let mut fresh = SparseRows::default();
                fresh.set_leading(matrix, leading);
                assert_eq!(rows_of(&held), rows_of(&fresh), "leading {leading}");
                transposed.set_transposed(matrix);
                let mut fresh = SparseRows::default();
                fresh.set_transposed(matrix);
                assert_eq!(rows_of(&transposed), rows_of(&fresh));
                assert_eq!(
                    rows_of(&fresh),
                    rows_of(&SparseRows::of(&matrix.transpose()))
                );
            }
        }
    }

    /// A transpose read from a matrix's entries
    /// (`SparseRows::set_transposed_rows`) is the one read from the dense
    /// matrix: the same rows, each in increasing column, on a pattern
    /// built and on the same pattern with new values (a zero held).
    #[test]
    fn sparse_rows_transposed_from_rows_are_the_dense_transpose() {
        let first = DMatrix::from_row_slice(
            3,
            4,
            &[1.0, 0.0, 2.0, 0.0, 0.0, 3.0, 4.0, 0.0, 5.0, 0.0, 0.0, 6.0],
        );
        let mut second = first.clone() * -2.0;
        second[(1, 2)] = 0.0;
        let (mut rows, mut transposed) = (SparseRows::default(), SparseRows::default());
        let mut pattern = 0;
        for matrix in [&first, &second] {
            rows.set(matrix);
            transposed.set_transposed_rows(&rows);
            let mut dense = SparseRows::default();
            dense.set_transposed_values(matrix.as_slice(), matrix.nrows());
            assert_eq!((transposed.rows(), transposed.columns()), (4, 3));
            for i in 0..4 {
                let nonzero = |s: &SparseRows| -> Vec<(usize, f64)> {
                    s.row(i).iter().copied().filter(|e| e.1 != 0.0).collect()
                };
                assert_eq!(nonzero(&transposed), nonzero(&dense));
                assert!(transposed.row(i).windows(2).all(|w| w[0].0 < w[1].0));
            }
            if pattern != 0 {
                assert_eq!(pattern, transposed.pattern(), "the transposed pattern held");
            }
            pattern = transposed.pattern();
        }
        assert_eq!(transposed.row(2), &[(0, -4.0), (1, 0.0)]);
    }

    /// The columns combined in registers are the loop that adds each
    /// term's column in turn, bit for bit, for row counts around the
    /// blocks of 16 and 4.
    #[test]
    fn combined_columns_are_the_plain_loop() {
        for rows in [1, 3, 4, 5, 16, 17, 20, 28, 33] {
            let x: Vec<f64> = (0..rows * 9)
                .map(|i| (i as f64 * 0.77).sin() * 1e2)
                .collect();
            let terms: Vec<(usize, f64)> = [(0, 0.3), (4, -1.7), (2, 1e-3), (8, 2.5), (4, 0.1)]
                .into_iter()
                .collect();
            let mut fast = vec![f64::NAN; rows];
            combine_columns(&mut fast, &x, terms.iter().copied());
            let mut plain = vec![0.0; rows];
            for &(j, factor) in &terms {
                for (into, &value) in plain.iter_mut().zip(&x[j * rows..(j + 1) * rows]) {
                    *into += factor * value;
                }
            }
            assert!(
                fast.iter()
                    .zip(&plain)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "rows {rows}"
            );
        }
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

    #[test]
    fn van_loan_matches_fine_quadrature() {
        // Γ and Q_d against the integrals by the trapezoidal rule over 20 000
        // sub-steps of e^{A·s} (error ~h²/12·max|f″| ≈ 1e-10 relative).
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let h = 0.2;
        let discrete = discretise(&a, &b, Some(&noise), h);
        let steps = 20_000;
        let ds = h / steps as f64;
        let (mut gamma, mut q) = (DMatrix::zeros(3, 1), DMatrix::zeros(3, 3));
        for i in 0..=steps {
            let w = if i == 0 || i == steps { 0.5 } else { 1.0 };
            let e = exponential(&(&a * (i as f64 * ds)));
            gamma += &e * &b * (w * ds);
            q += &e * &noise * e.transpose() * (w * ds);
        }
        assert_close(&discrete.transition, &exponential(&(&a * h)), 1e-14, "Φ");
        assert_close(&discrete.input, &gamma, 1e-9, "Γ");
        assert_close(&discrete.process_noise, &q, 1e-9, "Q_d");
    }

    /// The series with doubling against Van Loan's block exponential
    /// itself, Q_d = Φ·F with e^{[[−A, Q_c], [0, Aᵀ]]·h} = [[·, F], [0, ·]]:
    /// within 10⁻¹⁴ relative (Frobenius norm) for a step inside the series'
    /// radius (no doubling), one of 5 doublings, and an augmented model's A
    /// (trailing zero rows, noise on a constant state too); exactly
    /// symmetric.
    #[test]
    fn process_noise_series_is_van_loans_block_exponential() {
        let van_loan = |a: &DMatrix<f64>, noise: &DMatrix<f64>, h: f64| {
            let n = a.nrows();
            let mut block = DMatrix::zeros(2 * n, 2 * n);
            block.view_mut((0, 0), (n, n)).copy_from(&(-a * h));
            block.view_mut((0, n), (n, n)).copy_from(&(noise * h));
            block
                .view_mut((n, n), (n, n))
                .copy_from(&(a.transpose() * h));
            exponential(&(a * h)) * exponential(&block).view((0, n), (n, n))
        };
        let (a, b) = system();
        let mut augmented = DMatrix::zeros(4, 4);
        augmented.view_mut((0, 0), (3, 3)).copy_from(&a);
        augmented.view_mut((0, 3), (3, 1)).copy_from(&b);
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let augmented_noise =
            DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01, 1e-4]));
        let mut series = ProcessNoise::default();
        for (a, noise, h) in [
            (&a, &noise, 0.01),
            (&a, &noise, 0.5),
            (&augmented, &augmented_noise, 0.04),
        ] {
            let mut q = DMatrix::zeros(0, 0);
            series.of(a, noise, h, &mut q);
            let expected = van_loan(a, noise, h);
            assert_close(&q, &expected, 1e-14, &format!("h = {h}"));
            assert_eq!(q, q.transpose());
        }
    }

    #[test]
    fn steady_state_solves_the_riccati_equation_and_is_the_filters_limit() {
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let d = discretise(&a, &b, Some(&noise), 0.04);
        let h = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let r = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-4, 4e-4]));
        let s = steady_state(&d.transition, &h, &d.process_noise, &r).unwrap();
        let p = &s.covariance;
        let gain_term = p * h.transpose() * (&h * p * h.transpose() + &r).try_inverse().unwrap();
        let residual = &d.transition * (p - &gain_term * &h * p) * d.transition.transpose()
            + &d.process_noise
            - p;
        assert!(residual.norm() <= 1e-12 * p.norm(), "{residual}");
        // The time-varying filter's covariance converges to it.
        let mut state = DVector::zeros(3);
        let mut covariance = DMatrix::identity(3, 3);
        for _ in 0..3000 {
            covariance = predict_covariance(&covariance, &d.transition, &d.process_noise);
            let predicted = covariance.clone();
            update(&mut state, &mut covariance, &h, &r, DVector::zeros(2)).unwrap();
            if (&predicted - p).norm() < 1e-13 * p.norm() {
                break;
            }
        }
        let predicted = predict_covariance(&covariance, &d.transition, &d.process_noise);
        assert_close(&predicted, p, 1e-10, "limit of the filter");
    }

    /// The steady state with a given innovation covariance S: P solves
    /// its Riccati equation, and it is the ordinary steady state with the
    /// measurement noise it implies, whose innovation covariance is S (to
    /// 1e-10: the two solvers' tolerances, 1e-13 and 1e-14 of P, after
    /// rounding). An S smaller than the process noise allows is refused.
    #[test]
    fn steady_state_for_an_innovation_covariance_is_the_ordinary_one_with_its_noise() {
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let d = discretise(&a, &b, Some(&noise), 0.04);
        let h = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let s = DMatrix::from_diagonal(&DVector::from_vec(vec![0.02, 4e-3]));
        let (steady, v) =
            steady_state_for_innovation(&d.transition, &h, &d.process_noise, &s).unwrap();
        let p = &steady.covariance;
        let weight = h.transpose() * s.clone().try_inverse().unwrap() * &h;
        let residual =
            &d.transition * (p - p * &weight * p) * d.transition.transpose() + &d.process_noise - p;
        assert!(residual.norm() <= 1e-12 * p.norm(), "{residual}");
        let ordinary = steady_state(&d.transition, &h, &d.process_noise, &v).unwrap();
        assert_close(&ordinary.covariance, p, 1e-10, "P");
        assert_close(&ordinary.innovation_covariance, &s, 1e-10, "S");
        assert_close(&ordinary.gain, &steady.gain, 1e-10, "K");
        let small = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-6, 1e-7]));
        assert!(steady_state_for_innovation(&d.transition, &h, &d.process_noise, &small).is_err());
    }

    #[test]
    fn steady_state_of_an_undetectable_system_is_refused() {
        // A growing mode that no output sees.
        let phi = DMatrix::from_row_slice(2, 2, &[1.1, 0.0, 0.0, 0.5]);
        let h = DMatrix::from_row_slice(1, 2, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2) * 0.1;
        let r = DMatrix::identity(1, 1) * 0.01;
        assert!(steady_state(&phi, &h, &q, &r).is_err());
    }

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
        let close = |a: &DMatrix<f64>, b: &DMatrix<f64>| (a - b).norm() / a.norm().max(1e-300);
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
            let dp = close(&p, &ps);
            assert!(dp < 1e-12, "filtered covariance at {k}: {dp:e}");
        }
        transitions.push(d.transition.clone());
        let vector = mbf_smooth(&predicted, &measured, &transitions);
        let sequential = mbf_smooth(&predicted_s, &scalar, &transitions);
        let variances = mbf_smooth_variances(&predicted_s, &scalar, &transitions);
        assert!(
            mbf_smooth_variances(&predicted_s, &scalar, &sparse_transitions) == variances,
            "the transitions by their entries smooth as the dense ones, bit for bit"
        );
        for (k, ((a, b), (mean, diagonal))) in
            vector.iter().zip(&sequential).zip(&variances).enumerate()
        {
            let dx = (&a.mean - &b.mean).norm() / a.mean.norm().max(1e-3);
            assert!(dx < 1e-12, "smoothed mean at {k}: {dx:e}");
            let dp = close(&a.covariance, &b.covariance);
            assert!(dp < 1e-12, "smoothed covariance at {k}: {dp:e}");
            assert_eq!(mean, &b.mean);
            let dd = (diagonal - b.covariance.diagonal()).amax() / diagonal.amax();
            assert!(dd < 1e-12, "smoothed variances at {k}: {dd:e}");
        }
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

    #[test]
    fn sigma_points_reproduce_mean_and_covariance() {
        let mean = DVector::from_vec(vec![1.0, -2.0, 0.5]);
        let covariance =
            DMatrix::from_row_slice(3, 3, &[2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 0.5]);
        for unscented in [
            Unscented::default(),
            Unscented {
                alpha: 1e-3,
                beta: 2.0,
                kappa: 0.0,
            },
        ] {
            let sigma = unscented.points(&mean, &covariance).unwrap();
            // W₀ᵐ = 1 − n/(α²·(n + κ)): −3·10⁶ at α = 10⁻³, so the mean
            // keeps about 16 − 6.5 digits.
            let m = sigma.mean_of(&sigma.points);
            assert!((&m - &mean).norm() < 1e-8, "{m}");
            let c = sigma.cross_covariance(&sigma.points, &m, &sigma.points, &m);
            assert_close(&c, &covariance, 1e-9, "covariance");
        }
    }

    #[test]
    fn whiteness_separates_white_from_coloured_series() {
        use rand::rngs::ChaCha8Rng;
        use rand::{RngExt, SeedableRng};
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let white: Vec<f64> = (0..4000)
            .map(|_| rng.sample::<f64, _>(rand_distr::StandardNormal))
            .collect();
        assert!(whiteness(&white, 50) >= 0.9);
        let mut coloured = vec![0.0; white.len()];
        for i in 1..white.len() {
            coloured[i] = 0.9 * coloured[i - 1] + white[i];
        }
        // ρ(k) = 0.9ᵏ ≥ 0.35 to lag 10, far above the band 1.96/√4000 = 0.031
        // (the estimate's own scatter there is ≈ 0.07).
        assert!(whiteness(&coloured, 10) == 0.0);
    }
}
