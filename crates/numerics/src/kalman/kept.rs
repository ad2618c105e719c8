//! What a filter pass keeps at its grid points, each quantity in one
//! buffer reserved once per pass: equal-shaped matrices ([`Matrices`]: the
//! transitions), Gaussian estimates ([`Gaussians`]: the predicted and the
//! filtered ones) and the measurement updates ([`Updates`]; as sequences
//! of scalar updates, [`ScalarUpdates`]), read back as views into the
//! buffers. A filter computes a kept matrix in its place in the buffer
//! (`push_for_writing`) rather than copy it there. A
//! pass over any number of grid points makes the same few allocations
//! (tests/no_allocation.rs).
//!
//! The buffers are megabytes (a pass over 1501 points of 22 states keeping
//! everything: 17 MB), which the allocator hands back to the system when a
//! pass ends, so that the next pass would touch every page of them afresh
//! (about 4 300 page faults, half again the pass's own time). A dropped
//! pass's buffers are kept instead for the next pass on the same thread
//! (at most `SPARE_BUFFERS` of them).

use super::sparse::SparseRows;
use super::update::{Gaussian, Measured};
use nalgebra::{DMatrix, DMatrixView, DVector, DVectorView};
use std::borrow::Borrow;
use std::cell::RefCell;

/// How many buffers of dropped passes a thread keeps for its next ones.
pub(crate) const SPARE_BUFFERS: usize = 8;

thread_local! {
    /// The buffers of this thread's dropped passes.
    static SPARE: RefCell<Vec<Vec<f64>>> = const { RefCell::new(Vec::new()) };
}

/// An empty buffer with room for `capacity` values: the smallest spare one
/// that has it, else a new one.
fn buffer(capacity: usize) -> Vec<f64> {
    let spare = SPARE.try_with(|spare| {
        let mut spare = spare.borrow_mut();
        let best = spare
            .iter()
            .enumerate()
            .filter(|(_, b)| b.capacity() >= capacity)
            .min_by_key(|(_, b)| b.capacity())
            .map(|(i, _)| i)?;
        Some(spare.swap_remove(best))
    });
    match spare {
        Ok(Some(mut buffer)) => {
            buffer.clear();
            buffer
        }
        _ => Vec::with_capacity(capacity),
    }
}

/// Keeps `buffer` (emptied) for a next pass on this thread, in place of
/// the smallest spare one when there are [`SPARE_BUFFERS`] already.
fn recycle(buffer: &mut Vec<f64>) {
    let buffer = std::mem::take(buffer);
    if buffer.capacity() == 0 {
        return;
    }
    let _ = SPARE.try_with(|spare| {
        let mut spare = spare.borrow_mut();
        if spare.len() < SPARE_BUFFERS {
            spare.push(buffer);
        } else if let Some(smallest) = spare
            .iter_mut()
            .min_by_key(|b| b.capacity())
            .filter(|b| b.capacity() < buffer.capacity())
        {
            *smallest = buffer;
        }
    });
}

/// Matrices of one shape, one per grid point, one after another in one
/// buffer (column-major each).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Matrices {
    rows: usize,
    columns: usize,
    len: usize,
    /// How many the buffer is reserved for when the first gives the shape.
    capacity: usize,
    values: Vec<f64>,
}

impl Matrices {
    /// None yet; room for `capacity` of them once the first is pushed.
    pub fn with_capacity(capacity: usize) -> Matrices {
        let mut matrices = Matrices::default();
        matrices.capacity = capacity;
        matrices
    }

    /// How many are kept.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether none is kept.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a copy of `matrix`, of the shape of the first one pushed.
    ///
    /// # Panics
    /// On a matrix of another shape (a filter's matrices have one).
    pub fn push(&mut self, matrix: impl Borrow<DMatrix<f64>>) {
        let matrix = matrix.borrow();
        let shape = matrix.shape();
        if self.len == 0 {
            (self.rows, self.columns) = shape;
            self.values.clear();
            self.values
                .reserve_exact(self.capacity.max(1) * matrix.len());
        }
        assert_eq!(
            shape,
            (self.rows, self.columns),
            "kept matrices have one shape"
        );
        self.values.extend_from_slice(matrix.as_slice());
        self.len += 1;
    }

    /// Appends a rows × columns matrix of zeros (the shape of the first
    /// one pushed) and returns its values (column-major) for writing in
    /// place: what a filter computes goes straight into the buffer instead
    /// of through a copy.
    ///
    /// # Panics
    /// On a shape other than the first one's.
    pub fn push_for_writing(&mut self, rows: usize, columns: usize) -> &mut [f64] {
        let size = rows * columns;
        if self.len == 0 {
            (self.rows, self.columns) = (rows, columns);
            self.values.clear();
            self.values.reserve_exact(self.capacity.max(1) * size);
        }
        assert_eq!(
            (rows, columns),
            (self.rows, self.columns),
            "kept matrices have one shape"
        );
        let start = self.values.len();
        self.values.resize(start + size, 0.0);
        self.len += 1;
        &mut self.values[start..]
    }

    /// Matrix k's values (column-major).
    pub fn values(&self, k: usize) -> Option<&[f64]> {
        let size = self.rows * self.columns;
        (k < self.len).then(|| &self.values[k * size..(k + 1) * size])
    }

    /// Matrix k.
    pub fn get(&self, k: usize) -> Option<DMatrixView<'_, f64>> {
        self.values(k)
            .map(|values| DMatrixView::from_slice(values, self.rows, self.columns))
    }

    /// Each matrix in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = DMatrixView<'_, f64>> + '_ {
        (0..self.len).map(|k| self.get(k).expect("k < len"))
    }
}

impl<'a> IntoIterator for &'a Matrices {
    type Item = DMatrixView<'a, f64>;
    type IntoIter = Box<dyn ExactSizeIterator<Item = DMatrixView<'a, f64>> + 'a>;
    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

impl IntoIterator for Matrices {
    type Item = DMatrix<f64>;
    type IntoIter = std::vec::IntoIter<DMatrix<f64>>;
    /// Each matrix as its own.
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
            .map(|m| m.into_owned())
            .collect::<Vec<_>>()
            .into_iter()
    }
}

impl Drop for Matrices {
    fn drop(&mut self) {
        recycle(&mut self.values);
    }
}

/// Sparse matrices, one per grid point, by their entries
/// ([`SparseRows`]): each matrix's values one after another in one buffer,
/// its pattern kept once for all the matrices that share it (a filter's
/// transitions hold one pattern from step to step: a few hundred values a
/// step where the dense matrix has n²).
#[derive(Debug, Clone, Default)]
pub struct SparseMatrices {
    /// How many the buffer is reserved for when the first gives its size.
    capacity: usize,
    /// Per matrix: its pattern in `patterns` and where its values start.
    at: Vec<(usize, usize)>,
    /// The patterns, their values those of the first matrix of each.
    patterns: Vec<SparseRows>,
    values: Vec<f64>,
}

impl SparseMatrices {
    /// None yet; room for `capacity` of them once the first is pushed.
    pub fn with_capacity(capacity: usize) -> SparseMatrices {
        SparseMatrices {
            capacity,
            at: Vec::with_capacity(capacity),
            patterns: Vec::new(),
            values: Vec::new(),
        }
    }

    /// How many are kept.
    pub fn len(&self) -> usize {
        self.at.len()
    }

    /// Whether none is kept.
    pub fn is_empty(&self) -> bool {
        self.at.is_empty()
    }

    /// Appends a copy of `matrix`'s values (and of its pattern, unless the
    /// matrix before held the same: [`SparseRows::pattern`]).
    pub fn push(&mut self, matrix: &SparseRows) {
        let entries = matrix.entries();
        if self.at.is_empty() {
            recycle(&mut self.values);
            self.values = buffer(self.capacity.max(1) * entries.len());
        }
        let same = self
            .patterns
            .last()
            .is_some_and(|last| last.pattern() == matrix.pattern() && matrix.pattern() != 0);
        if !same {
            self.patterns.push(matrix.clone());
        }
        self.at.push((self.patterns.len() - 1, self.values.len()));
        self.values.extend(entries.iter().map(|&(_, value)| value));
    }

    /// Matrix k's pattern and values (one per entry of the pattern, in
    /// [`SparseRows::entries`]' order).
    pub fn get(&self, k: usize) -> Option<(&SparseRows, &[f64])> {
        let &(pattern, start) = self.at.get(k)?;
        let pattern = &self.patterns[pattern];
        Some((
            pattern,
            &self.values[start..start + pattern.entries().len()],
        ))
    }
}

impl PartialEq for SparseMatrices {
    /// The same matrices: each on a pattern of the same entries with the
    /// same values.
    fn eq(&self, other: &SparseMatrices) -> bool {
        let columns = |pattern: &SparseRows, i: usize| {
            pattern.row(i).iter().map(|&(j, _)| j).collect::<Vec<_>>()
        };
        self.len() == other.len()
            && (0..self.len()).all(|k| {
                let ((a, x), (b, y)) = (
                    self.get(k).expect("k < len"),
                    other.get(k).expect("k < len"),
                );
                x == y
                    && a.rows() == b.rows()
                    && a.columns() == b.columns()
                    && (0..a.rows()).all(|i| columns(a, i) == columns(b, i))
            })
    }
}

impl Drop for SparseMatrices {
    fn drop(&mut self) {
        recycle(&mut self.values);
    }
}

/// A kept estimate: views of its mean and covariance (0 × 0 where the
/// covariance was not kept).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussianView<'a> {
    pub mean: DVectorView<'a, f64>,
    pub covariance: DMatrixView<'a, f64>,
}

impl GaussianView<'_> {
    /// The estimate as its own.
    pub fn to_gaussian(&self) -> Gaussian {
        Gaussian {
            mean: self.mean.into_owned(),
            covariance: self.covariance.into_owned(),
        }
    }
}

/// Gaussian estimates of one dimension n, one per grid point: the means
/// in one buffer and the covariances (n × n) in another, every one or only
/// the last one given.
#[derive(Debug, Clone, Default)]
pub struct Gaussians {
    dimension: usize,
    len: usize,
    /// How many the buffers are reserved for when the first gives n.
    capacity: usize,
    /// Every estimate's covariance kept (else only the last one given).
    every_covariance: bool,
    means: Vec<f64>,
    covariances: Vec<f64>,
    /// Without every covariance: the grid point whose covariance is kept.
    kept_covariance: Option<usize>,
    /// The last estimate, taken out of the buffers for writing
    /// ([`Gaussians::last_mut`]); it goes back at the next push.
    taken: Option<Gaussian>,
}

impl Gaussians {
    /// None yet; room for `capacity` estimates once the first is pushed,
    /// with every covariance or only the last one given.
    pub fn with_capacity(capacity: usize, every_covariance: bool) -> Gaussians {
        let mut gaussians = Gaussians::default();
        (gaussians.capacity, gaussians.every_covariance) = (capacity, every_covariance);
        gaussians
    }

    /// How many are kept.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether none is kept.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a copy of `estimate`.
    pub fn push(&mut self, estimate: impl Borrow<Gaussian>) {
        let estimate = estimate.borrow();
        self.push_parts(&estimate.mean, Some(&estimate.covariance));
    }

    /// Appends a copy of the mean and of the covariance if given (n × n or
    /// empty; with every covariance kept, none given is kept as zeros).
    ///
    /// # Panics
    /// On a mean of another dimension than the first one's, or a
    /// covariance of another shape than n × n or 0 × 0.
    pub fn push_parts(&mut self, mean: &DVector<f64>, covariance: Option<&DMatrix<f64>>) {
        let n = mean.len();
        self.begin(n);
        self.means.extend_from_slice(mean.as_slice());
        let covariance = covariance.filter(|c| !c.is_empty());
        if let Some(c) = covariance {
            assert_eq!(c.shape(), (n, n), "a kept covariance is n × n");
        }
        match (self.every_covariance, covariance) {
            (true, Some(c)) => self.covariances.extend_from_slice(c.as_slice()),
            (true, None) => self.covariances.resize(self.covariances.len() + n * n, 0.0),
            (false, Some(c)) => {
                self.covariances.clear();
                self.covariances.extend_from_slice(c.as_slice());
                self.kept_covariance = Some(self.len);
            }
            (false, None) => {}
        }
        self.len += 1;
    }

    /// Before a push of an estimate of dimension n: puts a taken estimate
    /// back, and at the first push reserves the buffers.
    ///
    /// # Panics
    /// On a dimension other than the first estimate's.
    fn begin(&mut self, n: usize) {
        self.settle();
        if self.len == 0 {
            self.dimension = n;
            recycle(&mut self.means);
            self.means = buffer(self.capacity.max(1) * n);
            let covariances = if self.every_covariance {
                self.capacity.max(1)
            } else {
                1
            };
            recycle(&mut self.covariances);
            self.covariances = buffer(covariances * n * n);
            self.kept_covariance = None;
        }
        assert_eq!(n, self.dimension, "kept estimates have one dimension");
    }

    /// Appends an estimate of dimension n, its mean and covariance zeros,
    /// and returns their values (the covariance column-major, n × n) for
    /// writing in place: what a filter computes goes straight into the
    /// buffers instead of through a copy. Without every covariance kept,
    /// the covariance is the one kept (the last given).
    ///
    /// # Panics
    /// On a dimension other than the first estimate's.
    pub fn push_for_writing(&mut self, n: usize) -> (&mut [f64], &mut [f64]) {
        self.begin(n);
        let mean = self.means.len();
        self.means.resize(mean + n, 0.0);
        let covariance = if self.every_covariance {
            self.covariances.len()
        } else {
            self.covariances.clear();
            self.kept_covariance = Some(self.len);
            0
        };
        self.covariances.resize(covariance + n * n, 0.0);
        self.len += 1;
        (&mut self.means[mean..], &mut self.covariances[covariance..])
    }

    /// Estimate k's mean and covariance values (column-major; empty where
    /// its covariance is not kept).
    pub fn values(&self, k: usize) -> Option<(&[f64], &[f64])> {
        if k >= self.len {
            return None;
        }
        if let Some(taken) = self.taken.as_ref().filter(|_| k + 1 == self.len) {
            return Some((taken.mean.as_slice(), taken.covariance.as_slice()));
        }
        let n = self.dimension;
        let mean = &self.means[k * n..(k + 1) * n];
        let covariance: &[f64] = if self.every_covariance {
            &self.covariances[k * n * n..(k + 1) * n * n]
        } else if self.kept_covariance == Some(k) {
            &self.covariances
        } else {
            &[]
        };
        Some((mean, covariance))
    }

    /// Estimate k.
    pub fn get(&self, k: usize) -> Option<GaussianView<'_>> {
        let (mean, covariance) = self.values(k)?;
        let size = if covariance.is_empty() {
            0
        } else {
            self.dimension
        };
        Some(GaussianView {
            mean: DVectorView::from_slice(mean, mean.len()),
            covariance: DMatrixView::from_slice(covariance, size, size),
        })
    }

    /// The first estimate.
    pub fn first(&self) -> Option<GaussianView<'_>> {
        self.get(0)
    }

    /// The last estimate.
    pub fn last(&self) -> Option<GaussianView<'_>> {
        self.get(self.len.checked_sub(1)?)
    }

    /// The last estimate for writing: taken out of the buffers as its own
    /// until the next push puts it back (its covariance n × n, or empty
    /// for none).
    pub fn last_mut(&mut self) -> Option<&mut Gaussian> {
        if self.taken.is_none() {
            let last = self.last()?.to_gaussian();
            self.taken = Some(last);
        }
        self.taken.as_mut()
    }

    /// Each estimate in order, as views into the buffers.
    pub fn views(&self) -> impl ExactSizeIterator<Item = GaussianView<'_>> + '_ {
        (0..self.len).map(|k| self.get(k).expect("k < len"))
    }

    /// Each estimate in order as its own (a copy; [`Gaussians::views`]
    /// copies nothing).
    pub fn iter(&self) -> impl ExactSizeIterator<Item = Gaussian> + '_ {
        self.views().map(|g| g.to_gaussian())
    }

    /// Each estimate as its own.
    pub fn to_vec(&self) -> Vec<Gaussian> {
        self.iter().collect()
    }

    /// Puts an estimate taken out by [`Gaussians::last_mut`] back.
    fn settle(&mut self) {
        let Some(taken) = self.taken.take() else {
            return;
        };
        let (n, k) = (self.dimension, self.len - 1);
        assert_eq!(taken.mean.len(), n, "kept estimates have one dimension");
        self.means[k * n..(k + 1) * n].copy_from_slice(taken.mean.as_slice());
        let covariance = (!taken.covariance.is_empty()).then_some(&taken.covariance);
        if let Some(c) = covariance {
            assert_eq!(c.shape(), (n, n), "a kept covariance is n × n");
        }
        match (self.every_covariance, covariance) {
            (true, Some(c)) => {
                self.covariances[k * n * n..(k + 1) * n * n].copy_from_slice(c.as_slice())
            }
            (true, None) => self.covariances[k * n * n..(k + 1) * n * n].fill(0.0),
            (false, Some(c)) => {
                self.covariances.clear();
                self.covariances.extend_from_slice(c.as_slice());
                self.kept_covariance = Some(k);
            }
            (false, None) => {
                if self.kept_covariance == Some(k) {
                    self.kept_covariance = None;
                }
            }
        }
    }
}

impl Drop for Gaussians {
    fn drop(&mut self) {
        recycle(&mut self.means);
        recycle(&mut self.covariances);
    }
}

impl PartialEq for Gaussians {
    fn eq(&self, other: &Gaussians) -> bool {
        self.len == other.len && self.views().zip(other.views()).all(|(a, b)| a == b)
    }
}

impl<'a> IntoIterator for &'a Gaussians {
    type Item = Gaussian;
    type IntoIter = Box<dyn ExactSizeIterator<Item = Gaussian> + 'a>;
    /// [`Gaussians::iter`].
    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

impl Drop for Updates {
    fn drop(&mut self) {
        recycle(&mut self.values);
    }
}

/// A kept measurement update: H (m × n, the rows of the measured outputs),
/// ν, S, S⁻¹ (m each) and K (n × m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateView<'a> {
    pub observation: DMatrixView<'a, f64>,
    pub innovation: DVectorView<'a, f64>,
    pub innovation_covariance: DMatrixView<'a, f64>,
    pub innovation_inverse: DMatrixView<'a, f64>,
    pub gain: DMatrixView<'a, f64>,
}

/// The measurement updates of a pass, at most one per grid point, one
/// after another in one buffer: H, ν, S, S⁻¹ and K of each.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Updates {
    /// How many grid points and outputs the buffers are reserved for when
    /// the first update gives the number of states.
    capacity: (usize, usize),
    /// Per grid point: where its update starts in `values`, and its number
    /// of measured outputs m (None: no update there).
    at: Vec<Option<(usize, usize)>>,
    states: usize,
    values: Vec<f64>,
}

impl Updates {
    /// None yet; room for `points` grid points with at most `outputs`
    /// measured outputs each.
    pub fn with_capacity(points: usize, outputs: usize) -> Updates {
        let mut updates = Updates::default();
        updates.capacity = (points, outputs);
        updates.at = Vec::with_capacity(points);
        updates
    }

    /// The number of grid points kept (with an update or without).
    pub fn len(&self) -> usize {
        self.at.len()
    }

    /// Whether no grid point is kept.
    pub fn is_empty(&self) -> bool {
        self.at.is_empty()
    }

    /// Appends a grid point's update (None: no measurement there).
    pub fn push(&mut self, measured: Option<Measured>) {
        match measured {
            None => self.at.push(None),
            Some(Measured {
                observation,
                update,
            }) => self.push_update(
                &observation,
                &update.innovation,
                &update.innovation_covariance,
                &update.innovation_inverse,
                &update.gain,
            ),
        }
    }

    /// Appends a grid point's update from its parts: H (m × n), ν, S, S⁻¹
    /// and K (n × m).
    ///
    /// # Panics
    /// When the parts' shapes do not agree, or n differs from the first
    /// update's.
    pub fn push_update(
        &mut self,
        observation: &DMatrix<f64>,
        innovation: &DVector<f64>,
        covariance: &DMatrix<f64>,
        inverse: &DMatrix<f64>,
        gain: &DMatrix<f64>,
    ) {
        let (m, n) = observation.shape();
        if self.values.is_empty() {
            self.states = n;
            let (points, outputs) = self.capacity;
            let outputs = outputs.max(m);
            recycle(&mut self.values);
            self.values = buffer(points.max(1) * Self::size(n, outputs));
        }
        assert!(
            n == self.states
                && innovation.len() == m
                && covariance.shape() == (m, m)
                && inverse.shape() == (m, m)
                && gain.shape() == (n, m),
            "an update's parts agree in shape"
        );
        self.at.push(Some((self.values.len(), m)));
        for part in [
            observation.as_slice(),
            innovation.as_slice(),
            covariance.as_slice(),
            inverse.as_slice(),
            gain.as_slice(),
        ] {
            self.values.extend_from_slice(part);
        }
    }

    /// The values an update of m outputs over n states takes.
    #[inline]
    fn size(n: usize, m: usize) -> usize {
        2 * n * m + m + 2 * m * m
    }

    /// The update at grid point k (None: none there or k past the last).
    pub fn get(&self, k: usize) -> Option<UpdateView<'_>> {
        let (start, m) = (*self.at.get(k)?)?;
        let n = self.states;
        let values = &self.values[start..start + Self::size(n, m)];
        let (observation, rest) = values.split_at(m * n);
        let (innovation, rest) = rest.split_at(m);
        let (covariance, rest) = rest.split_at(m * m);
        let (inverse, gain) = rest.split_at(m * m);
        Some(UpdateView {
            observation: DMatrixView::from_slice(observation, m, n),
            innovation: DVectorView::from_slice(innovation, m),
            innovation_covariance: DMatrixView::from_slice(covariance, m, m),
            innovation_inverse: DMatrixView::from_slice(inverse, m, m),
            gain: DMatrixView::from_slice(gain, n, m),
        })
    }

    /// H's values (column-major) of the update at grid point k.
    pub fn observation_values(&self, k: usize) -> Option<&[f64]> {
        let (start, m) = (*self.at.get(k)?)?;
        Some(&self.values[start..start + m * self.states])
    }

    /// Each grid point's update in order (None where there is none).
    pub fn iter(&self) -> impl ExactSizeIterator<Item = Option<UpdateView<'_>>> + '_ {
        (0..self.at.len()).map(|k| self.get(k))
    }
}

/// One scalar measurement update of a sequence (Bierman 1977, ch. II):
/// the output's row h of H by its non-zeros (their columns and values),
/// the gain k = P·h/s (n), the sequential innovation ν and its variance
/// s = hᵀ·P·h + r.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScalarUpdate<'a> {
    /// The columns of h's non-zeros, in increasing order.
    pub columns: &'a [usize],
    /// h's non-zeros, at `columns`.
    pub observation: &'a [f64],
    pub gain: &'a [f64],
    pub innovation: f64,
    pub variance: f64,
}

impl ScalarUpdate<'_> {
    /// h as a whole row of n values into `into` (zeros off its non-zeros).
    pub fn observation_into(&self, into: &mut [f64]) {
        into.fill(0.0);
        for (&j, &value) in self.columns.iter().zip(self.observation) {
            into[j] = value;
        }
    }
}

/// The measurement updates of a pass processed output by output
/// ([`crate::kalman::sequential_update_with`]), at
/// most one sequence per grid point, one after another in one buffer: per
/// output k, ν, s and h's non-zeros (an observation row has a few: an
/// attitude's one, a load factor's five), their columns in another.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScalarUpdates {
    /// How many grid points and outputs the buffers are reserved for when
    /// the first update gives the number of states.
    capacity: (usize, usize),
    /// Per grid point: where its sequence starts in `at_output` and its
    /// number of scalar updates (None: no update there).
    at: Vec<Option<(usize, usize)>>,
    /// Per scalar update: where it starts in `values` and where its h's
    /// columns start in `columns` (the next update's starts end them).
    at_output: Vec<(usize, usize)>,
    states: usize,
    values: Vec<f64>,
    columns: Vec<usize>,
}

impl Drop for ScalarUpdates {
    fn drop(&mut self) {
        recycle(&mut self.values);
    }
}

impl ScalarUpdates {
    /// None yet; room for `points` grid points with at most `outputs`
    /// measured outputs each.
    pub fn with_capacity(points: usize, outputs: usize) -> ScalarUpdates {
        ScalarUpdates {
            capacity: (points, outputs),
            at: Vec::with_capacity(points),
            at_output: Vec::new(),
            states: 0,
            values: Vec::new(),
            columns: Vec::new(),
        }
    }

    /// The number of grid points kept (with an update or without).
    pub fn len(&self) -> usize {
        self.at.len()
    }

    /// Whether no grid point is kept.
    pub fn is_empty(&self) -> bool {
        self.at.is_empty()
    }

    /// Appends a grid point without a measurement.
    pub fn push_none(&mut self) {
        self.at.push(None);
    }

    /// Appends a grid point's sequence of m scalar updates over n states:
    /// H (m rows over n columns by their entries, [`SparseRows`], its rows
    /// in the order they were processed; an entry that holds a zero is not
    /// kept), the gains (n × m, column i the i-th update's), the
    /// sequential innovations and their variances (m each).
    ///
    /// # Panics
    /// When the parts' shapes do not agree, or n differs from the first
    /// sequence's.
    pub fn push_sequence(
        &mut self,
        observation: &SparseRows,
        gains: &[f64],
        innovations: &[f64],
        variances: &[f64],
    ) {
        let m = observation.rows();
        let n = gains.len().checked_div(m).unwrap_or(self.states);
        if self.values.is_empty() {
            self.states = n;
            let (points, outputs) = self.capacity;
            let outputs = points.max(1) * outputs.max(m);
            recycle(&mut self.values);
            // Room for the gains, ν, s and about five non-zeros of h each.
            self.values = buffer(outputs * (n + 2 + 5));
            self.columns = Vec::with_capacity(outputs * 5);
            self.at_output = Vec::with_capacity(outputs);
        }
        assert!(
            n == self.states
                && gains.len() == n * m
                && innovations.len() == m
                && variances.len() == m,
            "a sequence's parts agree in shape"
        );
        self.at.push(Some((self.at_output.len(), m)));
        for i in 0..m {
            self.at_output.push((self.values.len(), self.columns.len()));
            self.values.extend_from_slice(&gains[i * n..(i + 1) * n]);
            self.values.push(innovations[i]);
            self.values.push(variances[i]);
            for &(j, value) in observation.row(i) {
                if value != 0.0 {
                    self.values.push(value);
                    self.columns.push(j);
                }
            }
        }
    }

    /// The number of scalar updates at grid point k (0: none there or k
    /// past the last).
    pub fn count(&self, k: usize) -> usize {
        self.at.get(k).copied().flatten().map_or(0, |(_, m)| m)
    }

    /// The i-th scalar update at grid point k, in the order processed.
    pub fn get(&self, k: usize, i: usize) -> Option<ScalarUpdate<'_>> {
        let (first, m) = (*self.at.get(k)?)?;
        if i >= m {
            return None;
        }
        let (start, from) = self.at_output[first + i];
        let to = self
            .at_output
            .get(first + i + 1)
            .map_or(self.columns.len(), |&(_, to)| to);
        let n = self.states;
        let values = &self.values[start..start + n + 2 + (to - from)];
        let (gain, rest) = values.split_at(n);
        Some(ScalarUpdate {
            columns: &self.columns[from..to],
            observation: &rest[2..],
            gain,
            innovation: rest[0],
            variance: rest[1],
        })
    }
}

#[cfg(test)]
mod tests;
