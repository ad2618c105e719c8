//! A linear time-invariant model as a state-space model:
//!
//!   ẋ = A·x + B·u,   y = C·x + D·u,
//!
//! u held constant over each step of the grid (zero-order hold), θ a list
//! of entries of A, B, C and D (dimensional derivatives such as Z_w, M_q,
//! M_δe). Its step is exact, x_{k+1} = Φ·x_k + Γ·u_k with Φ = e^{A·h} and
//! Γ = ∫₀ʰ e^{A·s} ds·B (Van Loan, [`crate::estimation::solver::kalman`]),
//! so a filter on it is a linear Kalman filter: the oracle the filters are
//! checked against.

use super::state_space::{Jacobians, StateSpaceModel};
use crate::error::{Error, Result};
use crate::estimation::solver::kalman::discretise;
use nalgebra::{DMatrix, DVector};

/// Which matrix a parameter is an entry of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Matrix {
    A,
    B,
    C,
    D,
}

/// A parameter: entry (row, column) of one of the matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    pub matrix: Matrix,
    pub row: usize,
    pub column: usize,
}

/// ẋ = A·x + B·u, y = C·x + D·u on the grid start + k·step, u_k given.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearStateSpace {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
    /// θ: the entries it sets (θ_j overrides entry j).
    pub parameters: Vec<Entry>,
    pub start: f64,
    pub step: f64,
    /// u at each grid point, held over the step that follows.
    pub inputs: Vec<DVector<f64>>,
}

impl LinearStateSpace {
    /// A model; an error when the shapes do not agree, an entry lies
    /// outside its matrix, or the grid has fewer than two points.
    pub fn new(
        [a, b, c, d]: [DMatrix<f64>; 4],
        parameters: Vec<Entry>,
        start: f64,
        step: f64,
        inputs: Vec<DVector<f64>>,
    ) -> Result<LinearStateSpace> {
        let (n, m, l) = (a.nrows(), b.ncols(), c.nrows());
        let shapes_agree = a.ncols() == n
            && b.nrows() == n
            && c.ncols() == n
            && d.nrows() == l
            && d.ncols() == m
            && inputs.iter().all(|u| u.len() == m);
        if !shapes_agree {
            return Err(Error::Other(format!(
                "a linear model's matrices do not agree: A {}×{}, B {}×{}, C {}×{}, D {}×{}, inputs of {m}",
                a.nrows(),
                a.ncols(),
                b.nrows(),
                b.ncols(),
                c.nrows(),
                c.ncols(),
                d.nrows(),
                d.ncols()
            )));
        }
        if inputs.len() < 2 || !(step > 0.0 && step.is_finite()) {
            return Err(Error::Other(
                "a linear model needs at least two grid points and a positive step".into(),
            ));
        }
        let model = LinearStateSpace {
            a,
            b,
            c,
            d,
            parameters,
            start,
            step,
            inputs,
        };
        for entry in &model.parameters {
            let matrix = model.matrix(entry.matrix);
            if entry.row >= matrix.nrows() || entry.column >= matrix.ncols() {
                return Err(Error::Other(format!(
                    "parameter entry ({}, {}) lies outside {:?} ({}×{})",
                    entry.row,
                    entry.column,
                    entry.matrix,
                    matrix.nrows(),
                    matrix.ncols()
                )));
            }
        }
        Ok(model)
    }

    fn matrix(&self, which: Matrix) -> &DMatrix<f64> {
        match which {
            Matrix::A => &self.a,
            Matrix::B => &self.b,
            Matrix::C => &self.c,
            Matrix::D => &self.d,
        }
    }

    /// θ as the matrices hold it.
    pub fn parameter_values(&self) -> DVector<f64> {
        DVector::from_iterator(
            self.parameters.len(),
            self.parameters
                .iter()
                .map(|e| self.matrix(e.matrix)[(e.row, e.column)]),
        )
    }

    /// The matrices with θ written in.
    pub(crate) fn at(&self, theta: &[f64]) -> Result<[DMatrix<f64>; 4]> {
        if theta.len() != self.parameters.len() {
            return Err(Error::Other(format!(
                "θ has {} values; the linear model has {} parameters",
                theta.len(),
                self.parameters.len()
            )));
        }
        let mut matrices = [
            self.a.clone(),
            self.b.clone(),
            self.c.clone(),
            self.d.clone(),
        ];
        for (entry, &value) in self.parameters.iter().zip(theta) {
            let index = entry.matrix as usize;
            matrices[index][(entry.row, entry.column)] = value;
        }
        Ok(matrices)
    }

    /// The grid point whose step contains t (the last point: itself).
    fn input_at(&self, t: f64) -> Result<&DVector<f64>> {
        let position = (t - self.start) / self.step;
        let last = self.inputs.len() - 1;
        if !position.is_finite() || position < -1e-9 || position > last as f64 + 1e-9 {
            return Err(Error::Other(format!(
                "t = {t} s is outside the linear model's grid"
            )));
        }
        let k = ((position + 1e-9).floor().max(0.0) as usize).min(last);
        Ok(&self.inputs[k])
    }

    fn check_state(&self, x: &[f64]) -> Result<()> {
        if x.len() != self.a.nrows() {
            return Err(Error::Other(format!(
                "x has {} values; the linear model has {} states",
                x.len(),
                self.a.nrows()
            )));
        }
        Ok(())
    }
}

impl StateSpaceModel for LinearStateSpace {
    fn state_count(&self) -> usize {
        self.a.nrows()
    }

    fn output_count(&self) -> usize {
        self.c.nrows()
    }

    fn parameter_count(&self) -> usize {
        self.parameters.len()
    }

    fn len(&self) -> usize {
        self.inputs.len()
    }

    fn time(&self, k: usize) -> f64 {
        self.start + k as f64 * self.step
    }

    fn rates(&self, t: f64, x: &[f64], theta: &[f64]) -> Result<DVector<f64>> {
        self.check_state(x)?;
        let [a, b, _, _] = self.at(theta)?;
        Ok(a * DVector::from_column_slice(x) + b * self.input_at(t)?)
    }

    fn outputs(&self, t: f64, x: &[f64], theta: &[f64]) -> Result<DVector<f64>> {
        self.check_state(x)?;
        let [_, _, c, d] = self.at(theta)?;
        Ok(c * DVector::from_column_slice(x) + d * self.input_at(t)?)
    }

    fn jacobians(&self, t: f64, x: &[f64], theta: &[f64]) -> Result<Jacobians> {
        self.check_state(x)?;
        let [a, _, c, _] = self.at(theta)?;
        let u = self.input_at(t)?;
        let (n, l, p) = (a.nrows(), c.nrows(), theta.len());
        let mut rates_by_parameter = DMatrix::zeros(n, p);
        let mut outputs_by_parameter = DMatrix::zeros(l, p);
        for (j, entry) in self.parameters.iter().enumerate() {
            let factor = match entry.matrix {
                Matrix::A | Matrix::C => x[entry.column],
                Matrix::B | Matrix::D => u[entry.column],
            };
            match entry.matrix {
                Matrix::A | Matrix::B => rates_by_parameter[(entry.row, j)] += factor,
                Matrix::C | Matrix::D => outputs_by_parameter[(entry.row, j)] += factor,
            }
        }
        Ok(Jacobians {
            rates_by_state: a,
            rates_by_parameter,
            outputs_by_state: c,
            outputs_by_parameter,
        })
    }

    /// The exact step under a held input: x_{k+1} = Φ·x_k + Γ·u_k.
    fn step(&self, k: usize, x: &[f64], theta: &[f64]) -> Result<DVector<f64>> {
        self.check_state(x)?;
        if k + 1 >= self.inputs.len() {
            return Err(Error::Other(format!(
                "no step from grid point {k}: the grid has {} points",
                self.inputs.len()
            )));
        }
        let [a, b, _, _] = self.at(theta)?;
        let discrete = discretise(&a, &b, None, self.step);
        Ok(discrete.transition * DVector::from_column_slice(x) + discrete.input * &self.inputs[k])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A short-period-like pair with one input.
    fn model() -> LinearStateSpace {
        let a = DMatrix::from_row_slice(2, 2, &[-1.2, 1.0, -8.0, -2.1]);
        let b = DMatrix::from_row_slice(2, 1, &[-0.1, -9.0]);
        let c = DMatrix::identity(2, 2);
        let d = DMatrix::zeros(2, 1);
        let inputs = (0..50)
            .map(|k| DVector::from_element(1, if (10..20).contains(&k) { 0.05 } else { 0.0 }))
            .collect();
        let parameters = vec![
            Entry {
                matrix: Matrix::A,
                row: 1,
                column: 1,
            },
            Entry {
                matrix: Matrix::B,
                row: 1,
                column: 0,
            },
        ];
        LinearStateSpace::new([a, b, c, d], parameters, 0.0, 0.04, inputs).unwrap()
    }

    #[test]
    fn step_is_the_exact_solution_under_a_held_input() {
        // Against RK4 with 400 sub-steps (error ~h⁴ = 1e-16·‖A‖⁴).
        let model = model();
        let theta = model.parameter_values();
        let x = [0.02, -0.1];
        let next = model.step(12, &x, theta.as_slice()).unwrap();
        let mut state = DVector::from_column_slice(&x);
        let h = model.step / 400.0;
        let t = model.time(12);
        let f = |s: &DVector<f64>| model.rates(t, s.as_slice(), theta.as_slice()).unwrap();
        for _ in 0..400 {
            let k1 = f(&state);
            let k2 = f(&(&state + &k1 * (h / 2.0)));
            let k3 = f(&(&state + &k2 * (h / 2.0)));
            let k4 = f(&(&state + &k3 * h));
            state += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
        }
        assert!((next - state).norm() < 1e-13);
    }

    #[test]
    fn parameter_jacobian_is_the_entrys_factor() {
        let model = model();
        let theta = model.parameter_values();
        let x = [0.02, -0.1];
        let t = model.time(15);
        let j = model.jacobians(t, &x, theta.as_slice()).unwrap();
        assert_eq!(j.rates_by_parameter[(1, 0)], -0.1);
        assert_eq!(j.rates_by_parameter[(1, 1)], 0.05);
        assert_eq!(j.rates_by_parameter[(0, 0)], 0.0);
    }

    #[test]
    fn bad_shapes_and_entries_are_refused() {
        let m = model();
        let mut parameters = m.parameters.clone();
        parameters.push(Entry {
            matrix: Matrix::D,
            row: 5,
            column: 0,
        });
        let matrices = [m.a.clone(), m.b.clone(), m.c.clone(), m.d.clone()];
        assert!(LinearStateSpace::new(matrices, parameters, 0.0, 0.04, m.inputs.clone()).is_err());
        let matrices = [m.a.clone(), m.b.clone(), m.c.clone(), DMatrix::zeros(1, 1)];
        assert!(LinearStateSpace::new(matrices, vec![], 0.0, 0.04, m.inputs.clone()).is_err());
    }
}
