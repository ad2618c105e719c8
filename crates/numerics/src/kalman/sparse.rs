//! A matrix by its non-zero entries row by row ([`SparseRows`]), so that
//! the products of a filter's step skip the zeros of its transition, its
//! Jacobians and its observation matrix: x·Aᵀ in O(nnz(A)·n) instead of
//! O(n³), the sums of each entry in the dense product's order. Read on a
//! held pattern without allocating.

use super::dense::{combine_columns, resize};
use nalgebra::DMatrix;

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
    pub(super) leading: usize,
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
    /// rows of constant states,
    /// [`Exponential::of_scaled`](crate::kalman::Exponential::of_scaled)).
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
