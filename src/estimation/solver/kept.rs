//! What a filter pass keeps at its grid points, each quantity in one
//! buffer reserved once per pass: equal-shaped matrices ([`Matrices`]: the
//! transitions), Gaussian estimates ([`Gaussians`]: the predicted and the
//! filtered ones) and the measurement updates ([`Updates`]), read back as
//! views into the buffers. A pass over any number of grid points makes the
//! same few allocations (tests/no_allocation.rs).

use crate::estimation::solver::kalman::{Gaussian, Measured};
use nalgebra::{DMatrix, DMatrixView, DVector, DVectorView};
use std::borrow::Borrow;

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
        Matrices {
            capacity,
            ..Matrices::default()
        }
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
        Gaussians {
            capacity,
            every_covariance,
            ..Gaussians::default()
        }
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
        self.settle();
        let n = mean.len();
        if self.len == 0 {
            self.dimension = n;
            self.means.clear();
            self.means.reserve_exact(self.capacity.max(1) * n);
            self.covariances.clear();
            let covariances = if self.every_covariance {
                self.capacity.max(1)
            } else {
                1
            };
            self.covariances.reserve_exact(covariances * n * n);
            self.kept_covariance = None;
        }
        assert_eq!(n, self.dimension, "kept estimates have one dimension");
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
        Updates {
            capacity: (points, outputs),
            at: Vec::with_capacity(points),
            ..Updates::default()
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
            self.values
                .reserve_exact(points.max(1) * Self::size(n, outputs));
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
