//! The dense helpers the kernels share: a matrix or vector given a shape in
//! its own storage ([`resize`], [`resize_vector`]), the symmetric part
//! (M + Mᵀ)/2 in place or into another matrix, the product a·b column by
//! column (unrolled for n ≤ 8), and the column sums Σ f·x_{·j} and
//! Σ_a x_ia·y_ia held in registers by blocks of 16 and 4 rows. Each keeps
//! the sums of the plain loop in its order: the same numbers.

use nalgebra::{DMatrix, DVector};
use std::cell::Cell;

/// Replaces a square matrix by its symmetric part, (M + Mᵀ)/2, in place.
pub fn symmetrise(matrix: &mut DMatrix<f64>) {
    let n = matrix.nrows();
    symmetrise_values(matrix.as_mut_slice(), n);
}

/// [`symmetrise`] of an n × n matrix's values (column-major).
pub(super) fn symmetrise_values(m: &mut [f64], n: usize) {
    let m = Cell::from_mut(m).as_slice_of_cells();
    symmetric_part(n, |i| m[i].get(), m);
}

/// The symmetric part of the n × n matrix `from` into `into` (both
/// column-major): the numbers of [`symmetrise`] in place.
pub(super) fn symmetrised_into(from: &[f64], into: &mut [f64], n: usize) {
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
pub(super) fn sum_of_products(into: &mut [f64], x: &[f64], y: &[f64]) {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
