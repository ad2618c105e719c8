//! A model with some of its parameters made states (the augmented-state
//! form of the EKF and UKF estimators: Jategaonkar, "Flight Vehicle System
//! Identification", 2nd ed., §7.2, Eq. 7.8; the X-31/F-18 HARV note, seed
//! 003): z = [x; θ_a], ż = [f(x, θ); 0], y = h(x, θ), the parameters θ_a
//! read from z and the others held at their given values. A parameter
//! state is constant over a step (a pseudonoise on it enters only through
//! the filter's process noise).

use super::state_space::{Jacobians, Points, Scratch, StateSpaceModel};
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};

/// `base` with the parameters `augmented` (indices into its θ) as states
/// after its own; the other parameters at `theta`. It has no parameters
/// of its own.
#[derive(Debug, Clone)]
pub struct Augmented<'a, M: StateSpaceModel + ?Sized> {
    base: &'a M,
    theta: Vec<f64>,
    augmented: Vec<usize>,
    /// θ with the parameter states written in, the base model's Jacobians
    /// and its state or outputs, kept between calls.
    scratch: Scratch<Buffers>,
}

/// The buffers of an [`Augmented`] model's calls.
struct Buffers {
    theta: Vec<f64>,
    base: Jacobians,
    /// The full θ of each of many points, one after the other.
    thetas: Vec<f64>,
}

impl Buffers {
    fn new() -> Buffers {
        Buffers {
            theta: Vec::new(),
            base: Jacobians::empty(),
            thetas: Vec::new(),
        }
    }
}

impl<'a, M: StateSpaceModel + ?Sized> Augmented<'a, M> {
    /// An error for an index outside θ, a repeated one, or a θ of the
    /// wrong length.
    pub fn new(base: &'a M, theta: &[f64], augmented: Vec<usize>) -> Result<Augmented<'a, M>> {
        if theta.len() != base.parameter_count() {
            return Err(Error::Shape {
                reason: format!(
                    "θ has {} values; the model has {} parameters",
                    theta.len(),
                    base.parameter_count()
                ),
            });
        }
        for (i, &j) in augmented.iter().enumerate() {
            if j >= theta.len() || augmented[..i].contains(&j) {
                return Err(Error::Shape {
                    reason: format!("parameter index {j} is outside θ or repeated"),
                });
            }
        }
        Ok(Augmented {
            base,
            theta: theta.to_vec(),
            augmented,
            scratch: Scratch::default(),
        })
    }

    /// The augmented state [x; θ_a] of a base state and the held θ.
    pub fn state(&self, x: &[f64]) -> DVector<f64> {
        DVector::from_iterator(
            x.len() + self.augmented.len(),
            x.iter()
                .copied()
                .chain(self.augmented.iter().map(|&j| self.theta[j])),
        )
    }

    /// Splits z into the base state and the full θ.
    fn split<'z>(&self, z: &'z [f64]) -> Result<(&'z [f64], Vec<f64>)> {
        let mut theta = self.theta.clone();
        let x = self.split_into(z, &mut theta)?;
        Ok((x, theta))
    }

    /// The base state of z, with the full θ written into `theta`.
    fn split_into<'z>(&self, z: &'z [f64], theta: &mut Vec<f64>) -> Result<&'z [f64]> {
        let n = self.base.state_count();
        if z.len() != n + self.augmented.len() {
            return Err(Error::Shape {
                reason: format!(
                    "the augmented state has {} values; expected {}",
                    z.len(),
                    n + self.augmented.len()
                ),
            });
        }
        // Only the augmented entries are ever written: the others are
        // the held θ's once copied.
        if theta.len() != self.theta.len() {
            theta.clone_from(&self.theta);
        }
        for (i, &j) in self.augmented.iter().enumerate() {
            theta[j] = z[n + i];
        }
        Ok(&z[..n])
    }

    /// The base model's points of augmented `points`: their base states,
    /// each with its full θ (written into `thetas`, its entries other than
    /// the augmented ones the held θ's once copied).
    fn base_points<'p>(&self, points: Points<'p>, thetas: &'p mut Vec<f64>) -> Result<Points<'p>> {
        let n = self.base.state_count();
        let size = n + self.augmented.len();
        if points.rows() != size {
            return Err(Error::Shape {
                reason: format!(
                    "the augmented state has {} values; expected {size}",
                    points.rows()
                ),
            });
        }
        let p = self.theta.len();
        if thetas.len() != p * points.len() {
            thetas.clear();
            for _ in 0..points.len() {
                thetas.extend_from_slice(&self.theta);
            }
        }
        for (j, theta) in thetas
            .chunks_exact_mut(p.max(1))
            .enumerate()
            .take(points.len())
        {
            let z = points.state(j);
            for (i, &k) in self.augmented.iter().enumerate() {
                theta[k] = z[n + i];
            }
        }
        points.with_parameters(n, thetas, p)
    }

    /// [[∂f/∂x, ∂f/∂θ_a], [0, 0]] of the base's Jacobians into `into`
    /// (`rates_by_parameter` of no columns).
    fn rates_into(&self, base: &Jacobians, into: &mut Jacobians) {
        let n = base.rates_by_state.nrows();
        let size = n + self.augmented.len();
        shape(&mut into.rates_by_state, size, size);
        shape(&mut into.rates_by_parameter, size, 0);
        place(
            &base.rates_by_state,
            &base.rates_by_parameter,
            &self.augmented,
            &mut into.rates_by_state,
        );
    }
}

/// Gives `matrix` the shape r × c (allocating only when it changes).
pub(crate) fn shape(matrix: &mut DMatrix<f64>, r: usize, c: usize) {
    if matrix.shape() != (r, c) {
        *matrix = DMatrix::zeros(r, c);
    }
}

/// [`by_state`, the `columns` of `by_parameter`] into the top rows of
/// `into`, its rows below them zero.
fn place(
    by_state: &DMatrix<f64>,
    by_parameter: &DMatrix<f64>,
    columns: &[usize],
    into: &mut DMatrix<f64>,
) {
    let (rows, n) = by_state.shape();
    let size = into.nrows();
    let sources = by_state.as_slice().chunks_exact(rows.max(1)).take(n).chain(
        columns
            .iter()
            .map(|&j| &by_parameter.as_slice()[j * rows..(j + 1) * rows]),
    );
    for (column, source) in into
        .as_mut_slice()
        .chunks_exact_mut(size.max(1))
        .zip(sources)
    {
        column[..rows].copy_from_slice(source);
        column[rows..].fill(0.0);
    }
}

impl<M: StateSpaceModel + ?Sized> StateSpaceModel for Augmented<'_, M> {
    fn state_count(&self) -> usize {
        self.base.state_count() + self.augmented.len()
    }

    fn output_count(&self) -> usize {
        self.base.output_count()
    }

    fn parameter_count(&self) -> usize {
        0
    }

    fn len(&self) -> usize {
        self.base.len()
    }

    fn time(&self, k: usize) -> f64 {
        self.base.time(k)
    }

    fn rates(&self, t: f64, z: &[f64], _theta: &[f64]) -> Result<DVector<f64>> {
        let (x, theta) = self.split(z)?;
        let rates = self.base.rates(t, x, &theta)?;
        Ok(rates.resize_vertically(z.len(), 0.0))
    }

    /// [[∂f/∂x, ∂f/∂θ_a], [0, 0]] and [∂h/∂x, ∂h/∂θ_a] from the base's
    /// [`StateSpaceModel::jacobians_into`], in kept buffers.
    fn jacobians_into(
        &self,
        t: f64,
        z: &[f64],
        _theta: &[f64],
        into: &mut Jacobians,
        outputs: Option<&mut DVector<f64>>,
    ) -> Result<()> {
        self.scratch.with(Buffers::new, |buffers| {
            let x = self.split_into(z, &mut buffers.theta)?;
            let base = &mut buffers.base;
            self.base
                .jacobians_into(t, x, &buffers.theta, base, outputs)?;
            self.rates_into(base, into);
            let (n, size) = (x.len(), z.len());
            let rows = base.outputs_by_state.nrows();
            shape(&mut into.outputs_by_state, rows, size);
            shape(&mut into.outputs_by_parameter, rows, 0);
            place(
                &base.outputs_by_state,
                &base.outputs_by_parameter,
                &self.augmented,
                &mut into.outputs_by_state,
            );
            debug_assert_eq!(into.outputs_by_state.ncols(), n + self.augmented.len());
            Ok(())
        })
    }

    fn outputs_into(
        &self,
        t: f64,
        z: &[f64],
        _theta: &[f64],
        into: &mut DVector<f64>,
    ) -> Result<()> {
        let m = self.base.output_count();
        if into.len() != m {
            *into = DVector::zeros(m);
        }
        self.outputs_points_into(t, Points::one(z, &[]), into.as_mut_slice(), m)
    }

    /// The base's outputs of every point, in one call with each point's θ.
    fn outputs_points_into(
        &self,
        t: f64,
        points: Points,
        into: &mut [f64],
        stride: usize,
    ) -> Result<()> {
        self.scratch.with(Buffers::new, |buffers| {
            let base = self.base_points(points, &mut buffers.thetas)?;
            self.base.outputs_points_into(t, base, into, stride)
        })
    }

    fn step_into(
        &self,
        k: usize,
        z: &[f64],
        _theta: &[f64],
        into: &mut DVector<f64>,
    ) -> Result<()> {
        if into.len() != z.len() {
            *into = DVector::zeros(z.len());
        }
        self.step_points_into(k, Points::one(z, &[]), into.as_mut_slice(), z.len())
    }

    /// The base's steps of every point, in one call with each point's θ;
    /// the parameter states carried over.
    fn step_points_into(
        &self,
        k: usize,
        points: Points,
        into: &mut [f64],
        stride: usize,
    ) -> Result<()> {
        points.check_into(into.len(), stride, self.state_count())?;
        let n = self.base.state_count();
        self.scratch.with(Buffers::new, |buffers| {
            let base = self.base_points(points, &mut buffers.thetas)?;
            self.base.step_points_into(k, base, into, stride)
        })?;
        for j in 0..points.len() {
            let z = points.state(j);
            into[j * stride + n..j * stride + z.len()].copy_from_slice(&z[n..]);
        }
        Ok(())
    }
}
