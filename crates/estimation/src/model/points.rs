//! Many points (x_j, θ_j) of a state-space model evaluated at one time
//! ([`Points`]: the sigma points of the unscented filter, stepped and
//! measured in one call by
//! [`StateSpaceModel::step_points_into`](super::state_space::StateSpaceModel::step_points_into)),
//! and the buffers a model keeps between calls behind a lock
//! (`Scratch`).

use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
use std::sync::Mutex;

/// Many points (x_j, θ_j), j = 0 … len − 1, of a model evaluated at one
/// time
/// ([`StateSpaceModel::step_points_into`](super::state_space::StateSpaceModel::step_points_into)):
/// x_j the first `rows`
/// values of column j of a column-major array whose columns are `stride`
/// apart, θ_j column j of another (columns `parameter_stride` apart), or
/// one θ for every point.
#[derive(Debug, Clone, Copy)]
pub struct Points<'a> {
    states: &'a [f64],
    rows: usize,
    stride: usize,
    count: usize,
    parameters: &'a [f64],
    parameter_stride: usize,
}

impl<'a> Points<'a> {
    /// One call of `one` per point, each point's value (of `size` entries)
    /// copied into column j of `into` (columns `stride` apart): the default
    /// of the batched calls
    /// ([`StateSpaceModel::step_points_into`](super::state_space::StateSpaceModel::step_points_into)).
    pub(crate) fn each_into(
        &self,
        into: &mut [f64],
        stride: usize,
        size: usize,
        mut one: impl FnMut(usize, &mut DVector<f64>) -> Result<()>,
    ) -> Result<()> {
        self.check_into(into.len(), stride, size)?;
        let mut value = DVector::zeros(0);
        for j in 0..self.len() {
            one(j, &mut value)?;
            into[j * stride..j * stride + value.len()].copy_from_slice(value.as_slice());
        }
        Ok(())
    }

    /// The columns of `states`, each with the parameters `theta`.
    pub fn shared(states: &'a DMatrix<f64>, theta: &'a [f64]) -> Points<'a> {
        Points {
            states: states.as_slice(),
            rows: states.nrows(),
            stride: states.nrows(),
            count: states.ncols(),
            parameters: theta,
            parameter_stride: 0,
        }
    }

    /// The one point (x, θ).
    pub fn one(x: &'a [f64], theta: &'a [f64]) -> Points<'a> {
        Points {
            states: x,
            rows: x.len(),
            stride: x.len(),
            count: 1,
            parameters: theta,
            parameter_stride: 0,
        }
    }

    /// The leading `rows` of each point's state, each point with its own θ:
    /// column j of `parameters` (`count` columns of `parameter_rows`). An
    /// error when there are fewer rows or parameters than that.
    pub fn with_parameters(
        &self,
        rows: usize,
        parameters: &'a [f64],
        parameter_rows: usize,
    ) -> Result<Points<'a>> {
        if rows > self.rows || parameters.len() != parameter_rows * self.count {
            return Err(Error::Shape {
                reason: format!(
                    "{} points of {} states: no {rows} states with {} parameters of {parameter_rows}",
                    self.count,
                    self.rows,
                    parameters.len()
                ),
            });
        }
        Ok(Points {
            rows,
            parameters,
            parameter_stride: parameter_rows,
            ..*self
        })
    }

    /// The number of points.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The number of values in each point's state.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// x_j.
    pub fn state(&self, j: usize) -> &'a [f64] {
        &self.states[j * self.stride..j * self.stride + self.rows]
    }

    /// θ_j.
    pub fn theta(&self, j: usize) -> &'a [f64] {
        if self.parameter_stride == 0 {
            self.parameters
        } else {
            &self.parameters[j * self.parameter_stride..(j + 1) * self.parameter_stride]
        }
    }

    /// Whether every point has the same θ.
    pub fn share_parameters(&self) -> bool {
        self.parameter_stride == 0
    }

    /// An error unless `len` values hold a column of `rows` for each point,
    /// columns `stride` apart.
    pub fn check_into(&self, len: usize, stride: usize, rows: usize) -> Result<()> {
        let needed = self.count.saturating_sub(1) * stride + rows;
        if self.count > 0 && (stride < rows || len < needed) {
            return Err(Error::Shape {
                reason: format!(
                    "{} points: {len} values do not hold columns of {rows} values {stride} apart",
                    self.count
                ),
            });
        }
        Ok(())
    }
}

/// Buffers a model reuses between calls behind a lock (a flight model with
/// θ written in, a linearisation's matrices): a call that finds them in
/// use, by another thread, works on fresh ones. A clone starts empty.
pub(crate) struct Scratch<T>(Mutex<Option<T>>);

impl<T> Default for Scratch<T> {
    fn default() -> Self {
        Scratch(Mutex::new(None))
    }
}

impl<T> Clone for Scratch<T> {
    fn clone(&self) -> Self {
        Scratch::default()
    }
}

impl<T> std::fmt::Debug for Scratch<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Scratch")
    }
}

impl<T> Scratch<T> {
    /// `f` on the buffers (`make` makes them the first time, or when they
    /// are in use).
    pub(crate) fn with<R>(&self, make: impl FnOnce() -> T, f: impl FnOnce(&mut T) -> R) -> R {
        match self.0.try_lock() {
            Ok(mut buffers) => f(buffers.get_or_insert_with(make)),
            Err(_) => f(&mut make()),
        }
    }
}
