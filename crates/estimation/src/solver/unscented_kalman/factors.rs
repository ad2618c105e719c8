//! The square-root filter's dense kernels: S·Sᵀ of a triangular factor,
//! triangular products and right solves, the QR triangularisation of a
//! compound matrix, the rank-one Cholesky update and downdate
//! (`cholupdate`, Algorithm 3.1's), the weighted mean and central
//! difference of sigma points, and the process noise's square root.

use super::Weights;
use crate::error::{Error, Result};
use aeroid_numerics::kalman::resize;
use nalgebra::{DMatrix, DVector};

/// P = S·Sᵀ of a lower-triangular S into `p`, formed in its lower
/// triangle and mirrored: column j of the lower triangle (rows j…) is
/// Σ_{k ≤ j} S_jk·(rows j… of S's column k), summed in order of k from
/// zero (the zero factors skipped) in registers, by blocks of 4 and 1 rows
/// (n³/6 multiply-adds, compiled for AVX2 where the CPU has it:
/// [`aeroid_numerics::simd::wide`]). Exactly symmetric, each element of the upper
/// triangle its mirror's.
pub(super) fn covariance_into(factor: &DMatrix<f64>, p: &mut DMatrix<f64>) {
    let n = factor.nrows();
    resize(p, n, n);
    let s = factor.as_slice();
    let data = p.as_mut_slice();
    aeroid_numerics::simd::wide(
        #[inline(always)]
        || {
            for j in 0..n {
                let mut start = j;
                while start + 4 <= n {
                    lower_block::<4>(s, n, j, start, data);
                    start += 4;
                }
                while start < n {
                    lower_block::<1>(s, n, j, start, data);
                    start += 1;
                }
            }
            for j in 0..n {
                for i in j + 1..n {
                    data[i * n + j] = data[j * n + i];
                }
            }
        },
    )
}

/// Rows `start`…`start` + B of column j of S·Sᵀ (S lower triangular, n × n,
/// column-major) into `into` ([`covariance_into`]).
#[inline(always)]
fn lower_block<const B: usize>(s: &[f64], n: usize, j: usize, start: usize, into: &mut [f64]) {
    let mut sum = [0.0; B];
    for k in 0..=j {
        let f = s[k * n + j];
        if f != 0.0 {
            let column: &[f64; B] = s[k * n + start..k * n + start + B]
                .try_into()
                .expect("a block of B rows");
            for (sum, &value) in sum.iter_mut().zip(column) {
                *sum += f * value;
            }
        }
    }
    into[j * n + start..j * n + start + B].copy_from_slice(&sum);
}

/// `into` = L·B for L lower triangular (n × n), B n × m: column j the
/// sum over k of B_kj·L_{·k} in order of k, each over L's rows k… only
/// (the rows above add zeros: the same numbers as the dense product).
pub(super) fn multiply_lower(l: &DMatrix<f64>, b: &DMatrix<f64>, into: &mut DMatrix<f64>) {
    aeroid_numerics::simd::wide(
        #[inline(always)]
        || {
            let n = l.nrows();
            resize(into, n, b.ncols());
            let l = l.as_slice();
            for (column, b) in into
                .as_mut_slice()
                .chunks_exact_mut(n.max(1))
                .zip(b.as_slice().chunks_exact(n.max(1)))
            {
                column.fill(0.0);
                for (k, &factor) in b.iter().enumerate() {
                    for (into, &l) in column[k..].iter_mut().zip(&l[k * n + k..(k + 1) * n]) {
                        *into += factor * l;
                    }
                }
            }
        },
    )
}

/// x = Σ Wᵐ_i·χ'_i of the columns of `moved`.
pub(super) fn weighted_mean(weights: &Weights, moved: &DMatrix<f64>, mean: &mut DVector<f64>) {
    mean.copy_from(&moved.column(0));
    *mean *= weights.mean_zero;
    for j in 1..moved.ncols() {
        mean.axpy(weights.other, &moved.column(j), 1.0);
    }
}

/// (Z_{1…n} − Z_{n+1…2n})/(2c) of the columns of `images` (the sigma
/// points' images Z_i) into `into` (its rows × n): the central difference
/// that is P_{z x}·P⁻¹·S for the covariance P = S·Sᵀ the points were drawn
/// from (`time_update`).
pub(super) fn central_difference_into<S>(
    images: &nalgebra::Matrix<f64, nalgebra::Dyn, nalgebra::Dyn, S>,
    n: usize,
    scale: f64,
    into: &mut DMatrix<f64>,
) where
    S: nalgebra::Storage<f64, nalgebra::Dyn, nalgebra::Dyn>,
{
    let half = 0.5 / scale;
    for i in 0..n {
        for r in 0..images.nrows() {
            into[(r, i)] = half * (images[(r, 1 + i)] - images[(r, 1 + n + i)]);
        }
    }
}

/// X·L = B for X in place of B (column-major), L lower triangular:
/// X_{·j} = (B_{·j} − Σ_{k>j} X_{·k}·L_{kj})/L_{jj} from the last column
/// back, each step an operation on whole contiguous columns (of a length
/// known at compile time for B of up to 8 rows, so that the loops
/// unroll: the same operations in the same order). False when a diagonal
/// element of L is zero.
pub(super) fn solve_right_lower(l: &DMatrix<f64>, b: &mut DMatrix<f64>) -> bool {
    let (l, n) = (l.as_slice(), l.nrows());
    let rows = b.nrows();
    let data = b.as_mut_slice();
    aeroid_numerics::simd::wide(
        #[inline(always)]
        || match rows {
            1 => solve_right_lower_rows::<1>(l, n, data),
            2 => solve_right_lower_rows::<2>(l, n, data),
            3 => solve_right_lower_rows::<3>(l, n, data),
            4 => solve_right_lower_rows::<4>(l, n, data),
            5 => solve_right_lower_rows::<5>(l, n, data),
            6 => solve_right_lower_rows::<6>(l, n, data),
            7 => solve_right_lower_rows::<7>(l, n, data),
            8 => solve_right_lower_rows::<8>(l, n, data),
            _ => solve_right_lower_any(l, n, rows, data),
        },
    )
}

/// [`solve_right_lower`] for B of any number of rows.
pub(super) fn solve_right_lower_any(l: &[f64], n: usize, rows: usize, data: &mut [f64]) -> bool {
    for j in (0..n).rev() {
        let diagonal = l[j * n + j];
        if diagonal == 0.0 {
            return false;
        }
        let (head, tail) = data.split_at_mut((j + 1) * rows);
        let column = &mut head[j * rows..];
        for k in j + 1..n {
            let f = l[j * n + k];
            if f != 0.0 {
                let known = &tail[(k - j - 1) * rows..(k - j) * rows];
                for (c, x) in column.iter_mut().zip(known) {
                    *c -= f * x;
                }
            }
        }
        let inverse = 1.0 / diagonal;
        for c in column.iter_mut() {
            *c *= inverse;
        }
    }
    true
}

/// [`solve_right_lower`] for B of R rows (L n × n, both column-major).
#[inline(always)]
fn solve_right_lower_rows<const R: usize>(l: &[f64], n: usize, data: &mut [f64]) -> bool {
    for j in (0..n).rev() {
        let diagonal = l[j * n + j];
        if diagonal == 0.0 {
            return false;
        }
        let mut column = [0.0; R];
        column.copy_from_slice(&data[j * R..(j + 1) * R]);
        for k in j + 1..n {
            let f = l[j * n + k];
            if f != 0.0 {
                let known = &data[k * R..(k + 1) * R];
                for (c, x) in column.iter_mut().zip(known) {
                    *c -= f * x;
                }
            }
        }
        let inverse = 1.0 / diagonal;
        for c in column.iter_mut() {
            *c *= inverse;
        }
        data[j * R..(j + 1) * R].copy_from_slice(&column);
    }
    true
}

/// The Cholesky factor S (`cols` × `cols`, lower) with S·Sᵀ = Aᵀ·A for A
/// the leading `rows` × `cols` block of `a`, by Householder reflections in
/// place (A is overwritten): the transpose of QR's R with each column's
/// sign chosen so that S's diagonal is non-negative. Column-major, each
/// reflection works on contiguous column slices.
pub(super) fn triangularise(
    a: &mut DMatrix<f64>,
    rows: usize,
    cols: usize,
    factor: &mut DMatrix<f64>,
) {
    aeroid_numerics::simd::wide(
        #[inline(always)]
        || {
            let ld = a.nrows();
            let data = a.as_mut_slice();
            factor.fill(0.0);
            for j in 0..cols.min(rows) {
                let (left, right) = data.split_at_mut((j + 1) * ld);
                let v = &mut left[j * ld + j..j * ld + rows];
                let norm = dot(v, v).sqrt();
                if norm == 0.0 {
                    continue;
                }
                let head = v[0];
                let alpha = if head > 0.0 { -norm } else { norm };
                // v = x − α·e₁ in place; vᵀv = 2α(α − x₀).
                v[0] = head - alpha;
                let scale = 1.0 / (alpha * (alpha - head));
                for c in 0..cols - j - 1 {
                    let column = &mut right[c * ld + j..c * ld + rows];
                    let f = dot(v, column) * scale;
                    for (y, x) in column.iter_mut().zip(v.iter()) {
                        *y -= f * x;
                    }
                }
                v[0] = alpha;
            }
            for j in 0..cols.min(rows) {
                let sign = if data[j * ld + j] < 0.0 { -1.0 } else { 1.0 };
                for c in j..cols {
                    factor[(c, j)] = sign * data[c * ld + j];
                }
            }
        },
    )
}

/// a·b with four running sums (a sum the compiler can keep in vector
/// registers, where one running sum fixes the order of the additions).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [0.0; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a4.zip(b4) {
        for i in 0..4 {
            sums[i] += x[i] * y[i];
        }
    }
    sums[0] + sums[1] + sums[2] + sums[3] + tail
}

/// S·Sᵀ + w·v·vᵀ for the zeroth sigma point's weight w: an update by
/// √w·v when w ≥ 0, a downdate by √(−w)·v when w < 0. `v` is overwritten.
pub(super) fn zeroth_point(factor: &mut DMatrix<f64>, v: &mut [f64], w: f64) -> Result<(), ()> {
    let root = w.abs().sqrt();
    for x in v.iter_mut() {
        *x *= root;
    }
    cholupdate(factor, v, w.signum())
}

/// The rank-one update (`sign` = 1) or downdate (`sign` = −1) of the
/// lower Cholesky factor L in place: L·Lᵀ ± x·xᵀ (`x` is overwritten).
/// An update by Givens rotations; a downdate by hyperbolic rotations in
/// the mixed form (LINPACK's `dchdd`; Golub & Van Loan, "Matrix
/// Computations", 4th ed., §6.5.4), refused (Err) when a new diagonal
/// element would not be positive: the downdated matrix is not positive
/// definite.
pub(super) fn cholupdate(l: &mut DMatrix<f64>, x: &mut [f64], sign: f64) -> Result<(), ()> {
    aeroid_numerics::simd::wide(
        #[inline(always)]
        || {
            let n = x.len();
            for k in 0..n {
                let xk = x[k];
                if xk == 0.0 {
                    continue;
                }
                let column = &mut l.as_mut_slice()[k * n..(k + 1) * n];
                let diagonal = column[k];
                let (top, below) = column.split_at_mut(k + 1);
                let rest = &mut x[k + 1..];
                if sign > 0.0 {
                    let r = diagonal.hypot(xk);
                    let (c, s) = (diagonal / r, xk / r);
                    top[k] = r;
                    for (li, xi) in below.iter_mut().zip(rest.iter_mut()) {
                        let (l0, x0) = (*li, *xi);
                        *li = c * l0 + s * x0;
                        *xi = c * x0 - s * l0;
                    }
                } else {
                    let square = (diagonal - xk) * (diagonal + xk);
                    if !(square > 0.0 && diagonal > 0.0) {
                        return Err(());
                    }
                    let r = square.sqrt();
                    let (c, s) = (r / diagonal, xk / diagonal);
                    let inverse = diagonal / r;
                    top[k] = r;
                    for (li, xi) in below.iter_mut().zip(rest.iter_mut()) {
                        *li = (*li - s * *xi) * inverse;
                        *xi = c * *xi - s * *li;
                    }
                }
            }
            Ok(())
        },
    )
}

/// G with G·Gᵀ = Q_c, without its zero columns: for a diagonal Q_c the
/// square roots of its non-zero diagonal, else from its symmetric
/// eigendecomposition. An error when Q_c has a negative eigenvalue (past
/// rounding).
pub(super) fn process_root(process: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = process.nrows();
    let negative = || Error::Numerical {
        reason: "the process noise is not positive semi-definite".into(),
    };
    let diagonal = (0..n).all(|i| (0..n).all(|j| i == j || process[(i, j)] == 0.0));
    if diagonal {
        if process.diagonal().iter().any(|&q| q.is_nan() || q < 0.0) {
            return Err(negative());
        }
        let kept: Vec<usize> = (0..n).filter(|&i| process[(i, i)] > 0.0).collect();
        let mut root = DMatrix::zeros(n, kept.len());
        for (j, &i) in kept.iter().enumerate() {
            root[(i, j)] = process[(i, i)].sqrt();
        }
        return Ok(root);
    }
    let symmetric = (process + process.transpose()) * 0.5;
    let eigen = symmetric.symmetric_eigen();
    let largest = eigen.eigenvalues.amax();
    if eigen.eigenvalues.iter().any(|&e| e < -1e-12 * largest) {
        return Err(negative());
    }
    let kept: Vec<usize> = (0..n)
        .filter(|&i| eigen.eigenvalues[i] > 1e-15 * largest)
        .collect();
    let mut root = DMatrix::zeros(n, kept.len());
    for (j, &i) in kept.iter().enumerate() {
        root.column_mut(j)
            .copy_from(&(eigen.eigenvectors.column(i) * eigen.eigenvalues[i].sqrt()));
    }
    Ok(root)
}
