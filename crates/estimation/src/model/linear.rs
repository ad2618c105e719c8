//! A linear time-invariant model as a state-space model:
//!
//!   ẋ = A·x + B·u + b,   y = [C·x + D·u + c; (ẋ)_R],
//!
//! b a constant term per state, c one per output, and (ẋ)_R the rates of
//! the states R that are outputs themselves (ṗ, ṙ as measured angular
//! accelerations). Each θ_j sets one or more entries of A, B, C, D, b
//! and c (dimensional derivatives such as Z_w, M_q, M_δe, and biases; Z_w
//! both in A and in the a_z row of C), so ∂f/∂θ_j and ∂y/∂θ_j sum over
//! its entries. The
//! inputs u are given at the grid points, each held over a step
//! (zero-order hold) or interpolated linearly between them (first-order
//! hold), as [`crate::input_timing`] chooses per input: W the diagonal
//! of their weights (1 linear, 0 held). The step is exact:
//! x_{k+1} = Φ·x_k + Γ₀·(u_k, 1) + Γ₁·W·(u_{k+1} − u_k), with Φ = e^{A·h},
//! Γ₀ = ∫₀ʰ e^{A·s} ds·[B b] and Γ₁ the first-order hold's ramp matrix
//! (Van Loan, [`aeroid_numerics::kalman`]),
//! so a filter on it is a linear Kalman filter: the oracle the filters are
//! checked against. The discrete matrices of the last θ are kept, so a
//! pass over the grid computes them once.

use super::jacobians::check_sensitivity_shape;
use super::state_space::{Jacobians, StateSpaceModel};
use super::state_space::{fitting_window, observation_step};
use crate::error::{Error, Result};
use crate::input_timing::Chosen;
use crate::linear_structure::LinearStructure;
pub use crate::linear_structure::{Entry, Matrices, Matrix};
use aeroid_numerics::kalman::{discretise, discretise_first_order_hold};
use aeroid_record::FlightRecord;
use aeroid_sim::integrator::Interpolation;
use nalgebra::{DMatrix, DVector};
use std::sync::{Arc, Mutex};

/// The discrete step of one θ: Φ, Γ₀ of [B b], and Γ₁·W of B for the
/// inputs under the first-order hold (none when every input is held).
#[derive(Debug, Clone, PartialEq)]
struct Discrete {
    transition: DMatrix<f64>,
    input: DMatrix<f64>,
    ramp: Option<DMatrix<f64>>,
}

mod sensitivity;

/// What was computed for the last θ (the discrete matrices, their
/// derivatives), so that a pass over the grid computes it once.
#[derive(Debug)]
struct Cache<T>(Mutex<Option<(Vec<f64>, Arc<T>)>>);

impl<T> Default for Cache<T> {
    fn default() -> Self {
        Cache(Mutex::new(None))
    }
}

impl<T> Clone for Cache<T> {
    fn clone(&self) -> Self {
        Cache::default()
    }
}

impl<T> PartialEq for Cache<T> {
    /// A cache says nothing about the model.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl<T> Cache<T> {
    /// The value kept for θ, if θ is the last one's.
    fn get(&self, theta: &[f64]) -> Option<Arc<T>> {
        let cache = self.0.lock().unwrap_or_else(|p| p.into_inner());
        cache
            .as_ref()
            .filter(|(last, _)| last.as_slice() == theta)
            .map(|(_, value)| value.clone())
    }

    /// Keeps `value` for θ and returns it.
    fn put(&self, theta: &[f64], value: T) -> Arc<T> {
        let value = Arc::new(value);
        let mut cache = self.0.lock().unwrap_or_else(|p| p.into_inner());
        *cache = Some((theta.to_vec(), value.clone()));
        value
    }
}

/// ẋ = A·x + B·u + b, y = [C·x + D·u + c; (ẋ)_R] on the grid start + k·step, u_k given.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearStateSpace {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
    /// b (zero unless set by [`LinearStateSpace::with_biases`]).
    pub state_bias: DVector<f64>,
    /// c (zero unless set by [`LinearStateSpace::with_biases`]).
    pub output_bias: DVector<f64>,
    /// The states whose rates follow C·x + D·u + c among the outputs.
    pub rate_outputs: Vec<usize>,
    /// How each input of u is taken inside a step.
    pub holds: Vec<Interpolation>,
    /// The inputs' names, interpolations and why (empty unless set by
    /// [`LinearStateSpace::with_input_timing`]).
    pub input_timing: Vec<Chosen>,
    /// θ: the entries each θ_j sets (it overrides every one of them).
    pub parameters: Vec<Vec<Entry>>,
    pub start: f64,
    pub step: f64,
    /// u at each grid point.
    pub inputs: Vec<DVector<f64>>,
    cache: Cache<Discrete>,
    derivatives: sensitivity::DerivativeCache,
    written: Cache<Matrices>,
}

impl LinearStateSpace {
    /// A model with no biases, no rate outputs and held inputs; an error
    /// when the shapes do not agree, a parameter sets no entry or one
    /// outside its matrix, or the grid has fewer than two points.
    pub fn new(
        [a, b, c, d]: [DMatrix<f64>; 4],
        parameters: Vec<Vec<Entry>>,
        start: f64,
        step: f64,
        inputs: Vec<DVector<f64>>,
    ) -> Result<LinearStateSpace> {
        let (n, l, m) = (a.nrows(), c.nrows(), b.ncols());
        LinearStateSpace {
            a,
            b,
            c,
            d,
            state_bias: DVector::zeros(n),
            output_bias: DVector::zeros(l),
            rate_outputs: Vec::new(),
            holds: vec![Interpolation::ZeroOrderHold; m],
            input_timing: Vec::new(),
            parameters,
            start,
            step,
            inputs,
            cache: Cache::default(),
            derivatives: Cache::default(),
            written: Cache::default(),
        }
        .checked()
    }

    /// The model with constant terms b (per state) and c (per output of C).
    pub fn with_biases(
        mut self,
        state_bias: DVector<f64>,
        output_bias: DVector<f64>,
    ) -> Result<LinearStateSpace> {
        self.state_bias = state_bias;
        self.output_bias = output_bias;
        self.checked()
    }

    /// The model with the rates of `states` appended to its outputs.
    pub fn with_rate_outputs(mut self, states: Vec<usize>) -> Result<LinearStateSpace> {
        self.rate_outputs = states;
        self.checked()
    }

    /// The model with every input taken inside a step by `hold`.
    pub fn with_hold(mut self, hold: Interpolation) -> LinearStateSpace {
        self.holds = vec![hold; self.b.ncols()];
        self
    }

    /// The model with input j taken inside a step as `chosen[j]` says; an
    /// error when there is not one per input.
    pub fn with_input_timing(mut self, chosen: Vec<Chosen>) -> Result<LinearStateSpace> {
        self.holds = chosen.iter().map(|c| c.interpolation).collect();
        self.input_timing = chosen;
        self.checked()
    }

    /// The inputs' weights inside a step at fraction θ (θ linear, 0 held).
    fn weights(&self, fraction: f64) -> DVector<f64> {
        DVector::from_iterator(
            self.holds.len(),
            self.holds.iter().map(|h| h.weight(fraction)),
        )
    }

    fn checked(self) -> Result<LinearStateSpace> {
        let (a, b, c, d) = (&self.a, &self.b, &self.c, &self.d);
        let (n, m, l) = (a.nrows(), b.ncols(), c.nrows());
        let shapes_agree = a.ncols() == n
            && b.nrows() == n
            && c.ncols() == n
            && d.nrows() == l
            && d.ncols() == m
            && self.state_bias.len() == n
            && self.output_bias.len() == l
            && self.rate_outputs.iter().all(|&i| i < n)
            && self.holds.len() == m
            && self.inputs.iter().all(|u| u.len() == m);
        if !shapes_agree {
            return Err(Error::Shape {
                reason: format!(
                    "a linear model's matrices do not agree: A {}×{}, B {}×{}, C {}×{}, D {}×{}, b of {}, c of {}, inputs of {m}",
                    a.nrows(),
                    a.ncols(),
                    b.nrows(),
                    b.ncols(),
                    c.nrows(),
                    c.ncols(),
                    d.nrows(),
                    d.ncols(),
                    self.state_bias.len(),
                    self.output_bias.len(),
                ),
            });
        }
        if self.inputs.len() < 2 || !(self.step > 0.0 && self.step.is_finite()) {
            return Err(Error::Grid {
                reason: "a linear model needs at least two grid points and a positive step".into(),
            });
        }
        for (j, set) in self.parameters.iter().enumerate() {
            if set.is_empty() {
                return Err(Error::Method {
                    reason: format!("parameter {j} of the linear model sets no entry"),
                });
            }
            for entry in set {
                let (rows, columns) = self.shape(entry.matrix);
                if entry.row >= rows || entry.column >= columns {
                    return Err(Error::Method {
                        reason: format!(
                            "parameter entry {entry} lies outside {:?} ({rows}×{columns})",
                            entry.matrix,
                        ),
                    });
                }
            }
        }
        Ok(self)
    }

    fn shape(&self, which: Matrix) -> (usize, usize) {
        match which {
            Matrix::A => self.a.shape(),
            Matrix::B => self.b.shape(),
            Matrix::C => self.c.shape(),
            Matrix::D => self.d.shape(),
            Matrix::StateBias => (self.state_bias.len(), 1),
            Matrix::OutputBias => (self.output_bias.len(), 1),
        }
    }

    fn value(&self, entry: &Entry) -> f64 {
        match entry.matrix {
            Matrix::A => self.a[(entry.row, entry.column)],
            Matrix::B => self.b[(entry.row, entry.column)],
            Matrix::C => self.c[(entry.row, entry.column)],
            Matrix::D => self.d[(entry.row, entry.column)],
            Matrix::StateBias => self.state_bias[entry.row],
            Matrix::OutputBias => self.output_bias[entry.row],
        }
    }

    /// θ as the matrices hold it (each θ_j from its first entry).
    pub fn parameter_values(&self) -> DVector<f64> {
        DVector::from_iterator(
            self.parameters.len(),
            self.parameters.iter().map(|set| self.value(&set[0])),
        )
    }

    /// The matrices with θ written in.
    pub fn at(&self, theta: &[f64]) -> Result<Matrices> {
        if theta.len() != self.parameters.len() {
            return Err(Error::Shape {
                reason: format!(
                    "θ has {} values; the linear model has {} parameters",
                    theta.len(),
                    self.parameters.len()
                ),
            });
        }
        let mut matrices = Matrices {
            a: self.a.clone(),
            b: self.b.clone(),
            c: self.c.clone(),
            d: self.d.clone(),
            state_bias: self.state_bias.clone(),
            output_bias: self.output_bias.clone(),
        };
        for (set, &value) in self.parameters.iter().zip(theta) {
            for entry in set {
                *matrices.entry_mut(entry) = value;
            }
        }
        Ok(matrices)
    }

    /// [`LinearStateSpace::at`], from the cache when θ is the last one's.
    fn matrices(&self, theta: &[f64]) -> Result<Arc<Matrices>> {
        match self.written.get(theta) {
            Some(matrices) => Ok(matrices),
            None => Ok(self.written.put(theta, self.at(theta)?)),
        }
    }

    /// u at t: each input its held grid sample or the linear interpolation
    /// between the two grid points around t.
    fn input_at(&self, t: f64) -> Result<DVector<f64>> {
        let position = (t - self.start) / self.step;
        let last = self.inputs.len() - 1;
        if !position.is_finite() || position < -1e-9 || position > last as f64 + 1e-9 {
            return Err(Error::Grid {
                reason: format!("t = {t} s is outside the linear model's grid"),
            });
        }
        let k = ((position + 1e-9).floor().max(0.0) as usize).min(last);
        let fraction = (position - k as f64).clamp(0.0, 1.0);
        Ok(if k < last && fraction > 1e-9 {
            &self.inputs[k]
                + (&self.inputs[k + 1] - &self.inputs[k]).component_mul(&self.weights(fraction))
        } else {
            self.inputs[k].clone()
        })
    }

    fn check_state(&self, x: &[f64]) -> Result<()> {
        if x.len() != self.a.nrows() {
            return Err(Error::Shape {
                reason: format!(
                    "x has {} values; the linear model has {} states",
                    x.len(),
                    self.a.nrows()
                ),
            });
        }
        Ok(())
    }

    /// The discrete step of θ, from the cache when θ is the last one's.
    fn discrete(&self, theta: &[f64]) -> Result<Arc<Discrete>> {
        if let Some(discrete) = self.cache.get(theta) {
            return Ok(discrete);
        }
        let matrices = self.matrices(theta)?;
        let (n, m) = matrices.b.shape();
        let mut driven = DMatrix::zeros(n, m + 1);
        driven.view_mut((0, 0), (n, m)).copy_from(&matrices.b);
        driven.set_column(m, &matrices.state_bias);
        let held = discretise(&matrices.a, &driven, None, self.step);
        let ramp = self.holds.contains(&Interpolation::Linear).then(|| {
            discretise_first_order_hold(&matrices.a, &matrices.b, self.step).2
                * DMatrix::from_diagonal(&self.weights(1.0))
        });
        Ok(self.cache.put(
            theta,
            Discrete {
                transition: held.transition,
                input: held.input,
                ramp,
            },
        ))
    }
}

impl StateSpaceModel for LinearStateSpace {
    fn state_count(&self) -> usize {
        self.a.nrows()
    }

    fn output_count(&self) -> usize {
        self.c.nrows() + self.rate_outputs.len()
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
        let matrices = self.matrices(theta)?;
        Ok(matrices.rates(&DVector::from_column_slice(x), &self.input_at(t)?))
    }

    fn outputs_into(
        &self,
        t: f64,
        x: &[f64],
        theta: &[f64],
        into: &mut DVector<f64>,
    ) -> Result<()> {
        self.check_state(x)?;
        let matrices = self.matrices(theta)?;
        let u = self.input_at(t)?;
        let x = nalgebra::DVectorView::from_slice(x, x.len());
        let direct = matrices.c.nrows();
        if into.len() != self.output_count() {
            *into = DVector::zeros(self.output_count());
        }
        let mut head = into.rows_mut(0, direct);
        head.copy_from(&matrices.output_bias);
        head.gemv(1.0, &matrices.c, &x, 1.0);
        head.gemv(1.0, &matrices.d, &u, 1.0);
        for (o, &state) in self.rate_outputs.iter().enumerate() {
            into[direct + o] = matrices.a.row(state).dot(&x.transpose())
                + matrices.b.row(state).dot(&u.transpose())
                + matrices.state_bias[state];
        }
        Ok(())
    }

    fn jacobians_into(
        &self,
        t: f64,
        x: &[f64],
        theta: &[f64],
        into: &mut Jacobians,
        outputs: Option<&mut DVector<f64>>,
    ) -> Result<()> {
        if let Some(outputs) = outputs {
            self.outputs_into(t, x, theta, outputs)?;
        }
        self.check_state(x)?;
        let matrices = self.matrices(theta)?;
        let u = self.input_at(t)?;
        let (n, l, p) = (matrices.a.nrows(), self.output_count(), theta.len());
        let direct = matrices.c.nrows();
        let fit = |matrix: &mut DMatrix<f64>, rows: usize, columns: usize| {
            if matrix.shape() == (rows, columns) {
                matrix.fill(0.0);
            } else {
                *matrix = DMatrix::zeros(rows, columns);
            }
        };
        fit(&mut into.rates_by_parameter, n, p);
        fit(&mut into.outputs_by_parameter, l, p);
        fit(&mut into.outputs_by_state, l, n);
        for (j, entry) in self
            .parameters
            .iter()
            .enumerate()
            .flat_map(|(j, set)| set.iter().map(move |entry| (j, entry)))
        {
            let factor = match entry.matrix {
                Matrix::A | Matrix::C => x[entry.column],
                Matrix::B | Matrix::D => u[entry.column],
                Matrix::StateBias | Matrix::OutputBias => 1.0,
            };
            match entry.matrix {
                Matrix::A | Matrix::B | Matrix::StateBias => {
                    into.rates_by_parameter[(entry.row, j)] += factor;
                    for (o, &state) in self.rate_outputs.iter().enumerate() {
                        if state == entry.row {
                            into.outputs_by_parameter[(direct + o, j)] += factor;
                        }
                    }
                }
                Matrix::C | Matrix::D | Matrix::OutputBias => {
                    into.outputs_by_parameter[(entry.row, j)] += factor
                }
            }
        }
        into.outputs_by_state
            .view_mut((0, 0), (direct, n))
            .copy_from(&matrices.c);
        for (o, &state) in self.rate_outputs.iter().enumerate() {
            into.outputs_by_state
                .row_mut(direct + o)
                .copy_from(&matrices.a.row(state));
        }
        if into.rates_by_state.shape() == (n, n) {
            into.rates_by_state.copy_from(&matrices.a);
        } else {
            into.rates_by_state = matrices.a.clone();
        }
        Ok(())
    }

    /// The exact step: x_{k+1} = Φ·x_k + Γ₀·(u_k, 1) + Γ₁·W·(u_{k+1} − u_k),
    /// the last term for the inputs taken linearly.
    fn step_into(&self, k: usize, x: &[f64], theta: &[f64], into: &mut DVector<f64>) -> Result<()> {
        self.check_state(x)?;
        if k + 1 >= self.inputs.len() {
            return Err(Error::Grid {
                reason: format!(
                    "no step from grid point {k}: the grid has {} points",
                    self.inputs.len()
                ),
            });
        }
        let discrete = self.discrete(theta)?;
        let u = &self.inputs[k];
        let driven = DVector::from_iterator(u.len() + 1, u.iter().copied().chain([1.0]));
        let mut next =
            &discrete.transition * DVector::from_column_slice(x) + &discrete.input * driven;
        if let Some(ramp) = &discrete.ramp {
            next += ramp * (&self.inputs[k + 1] - u);
        }
        *into = next;
        Ok(())
    }

    /// The exact step with its exact sensitivities (module `sensitivity`).
    fn step_sensitivity(
        &self,
        k: usize,
        x: &[f64],
        theta: &[f64],
        columns: &[Option<usize>],
        sensitivity: &mut DMatrix<f64>,
    ) -> Result<Option<DVector<f64>>> {
        let mut next = DVector::zeros(self.state_count());
        self.step_into(k, x, theta, &mut next)?;
        check_sensitivity_shape(sensitivity, self.state_count(), columns, theta.len())?;
        self.propagate_sensitivity(k, x, theta, columns, sensitivity)?;
        Ok(Some(next))
    }
}

/// The linear model a structure describes, on a time grid.
impl LinearStructure {
    /// The model on the grid start + k·step with inputs u_k.
    pub fn model(
        &self,
        start: f64,
        step: f64,
        inputs: Vec<DVector<f64>>,
    ) -> Result<LinearStateSpace> {
        self.model_disturbed(start, step, inputs, None)
    }

    /// [`LinearStructure::model`] with more inputs after the model's own,
    /// entering the states through `disturbance` (states × extra inputs,
    /// columns after B's) and no output directly: each u_k holds the
    /// model's inputs, then the disturbances. Each input is taken inside a
    /// step as the file's `interpolation` chooses for it, "auto" from its
    /// values on the grid.
    pub fn model_disturbed(
        &self,
        start: f64,
        step: f64,
        inputs: Vec<DVector<f64>>,
        disturbance: Option<&DMatrix<f64>>,
    ) -> Result<LinearStateSpace> {
        let columns = inputs.first().map_or(0, |u| u.len());
        let chosen = (0..columns)
            .map(|j| {
                let name = self
                    .inputs
                    .get(j)
                    .cloned()
                    .unwrap_or_else(|| format!("disturbance {}", j + 1 - self.inputs.len()));
                let values: Vec<f64> = inputs.iter().map(|u| u[j]).collect();
                self.interpolation.choose(&name, &values)
            })
            .collect();
        self.build(start, step, inputs, disturbance, chosen)
    }

    /// The model with each input taken inside a step as `chosen` says.
    fn build(
        &self,
        start: f64,
        step: f64,
        inputs: Vec<DVector<f64>>,
        disturbance: Option<&DMatrix<f64>>,
        chosen: Vec<Chosen>,
    ) -> Result<LinearStateSpace> {
        let m = &self.matrices;
        let (mut b, mut d) = (m.b.clone(), m.d.clone());
        if let Some(g) = disturbance {
            let columns = b.ncols();
            b = b.insert_columns(columns, g.ncols(), 0.0);
            b.columns_mut(columns, g.ncols()).copy_from(g);
            d = d.insert_columns(columns, g.ncols(), 0.0);
        }
        LinearStateSpace::new(
            [m.a.clone(), b, m.c.clone(), d],
            self.entries.clone(),
            start,
            step,
            inputs,
        )?
        .with_biases(m.state_bias.clone(), m.output_bias.clone())?
        .with_rate_outputs(self.rate_states.clone())?
        .with_input_timing(chosen)
    }

    /// The model driven by `record`: over the window where every output has
    /// samples (inside `limit`), on a grid of `step` (else
    /// [`observation_step`]'s), its inputs the input channels at the grid points
    /// (linear between samples), x₀ the file's `initial_state`, else
    /// [`LinearStructure::recorded_state`] at the window's start.
    pub fn for_record(
        &self,
        record: &FlightRecord,
        step: Option<f64>,
        limit: Option<(f64, f64)>,
    ) -> Result<(LinearStateSpace, DVector<f64>)> {
        let window = fitting_window(record, &self.outputs, limit)?;
        let inputs: Vec<&str> = self.inputs.iter().map(String::as_str).collect();
        let step = observation_step(record, &self.outputs, &inputs, step, window.0)?;
        let count = ((window.1 - window.0) / step + 1e-9).floor() as usize + 1;
        let times: Vec<f64> = (0..count).map(|k| window.0 + k as f64 * step).collect();
        let mut inputs = vec![DVector::zeros(self.inputs.len()); count];
        let mut chosen = Vec::new();
        for (j, name) in self.inputs.iter().enumerate() {
            let channel = record.channel(name)?;
            let choice = self.interpolation.choose(name, &channel.values);
            let values = channel.sampled_at(&times, choice.interpolation)?;
            for (u, value) in inputs.iter_mut().zip(values) {
                u[j] = value;
            }
            chosen.push(choice);
        }
        let initial = self
            .initial_state
            .clone()
            .unwrap_or_else(|| self.recorded_state(record, window.0));
        Ok((self.build(window.0, step, inputs, None, chosen)?, initial))
    }

    /// The state at `t` as the record gives it: each state named like a
    /// channel that channel's value, any other 0.
    pub fn recorded_state(&self, record: &FlightRecord, t: f64) -> DVector<f64> {
        DVector::from_iterator(
            self.states.len(),
            self.states.iter().map(|name| {
                record
                    .channel(name)
                    .ok()
                    .and_then(|c| c.value_at(t))
                    .unwrap_or(0.0)
            }),
        )
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
            vec![Entry {
                matrix: Matrix::A,
                row: 1,
                column: 1,
            }],
            vec![Entry {
                matrix: Matrix::B,
                row: 1,
                column: 0,
            }],
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

    /// The step's sensitivities are its derivatives: against central
    /// differences of whole steps (step 1e-6, truncation ~1e-12·‖∂³‖,
    /// rounding ~1e-16/1e-6), within 1e-8 for every unknown — a parameter
    /// in A and C together, one in B, a state bias, an output-only one and
    /// an unknown that is no parameter — with the input held and taken
    /// linearly.
    #[test]
    fn step_sensitivities_are_the_steps_derivatives() {
        let entry = |matrix, row, column| Entry {
            matrix,
            row,
            column,
        };
        for linear in [false, true] {
            let mut model = model();
            model.parameters = vec![
                vec![entry(Matrix::A, 1, 1), entry(Matrix::C, 0, 1)],
                vec![entry(Matrix::B, 1, 0)],
                vec![entry(Matrix::StateBias, 0, 0)],
                vec![entry(Matrix::OutputBias, 1, 0)],
            ];
            if linear {
                model.holds = vec![Interpolation::Linear];
            }
            let theta = model.parameter_values();
            let columns = [Some(0), Some(1), Some(2), Some(3), None];
            let x = [0.02, -0.1];
            // Start from a non-zero S so that Φ·S is checked too.
            let start = DMatrix::from_fn(2, 5, |i, j| 0.1 * (i + 1) as f64 - 0.03 * j as f64);
            let mut sensitivity = start.clone();
            // The step into the input's rise: u changes over it.
            let k = 9;
            model
                .step_sensitivity(k, &x, theta.as_slice(), &columns, &mut sensitivity)
                .unwrap()
                .unwrap();
            let step = |x: &[f64], theta: &[f64]| model.step(k, x, theta).unwrap();
            let phi = DMatrix::from_fn(2, 2, |i, c| {
                let (mut plus, mut minus) = (x, x);
                plus[c] += 1e-6;
                minus[c] -= 1e-6;
                (step(&plus, theta.as_slice())[i] - step(&minus, theta.as_slice())[i]) / 2e-6
            });
            for (j, column) in columns.iter().enumerate() {
                let mut expected = &phi * start.column(j);
                if let Some(p) = *column {
                    let (mut plus, mut minus) = (theta.clone(), theta.clone());
                    plus[p] += 1e-6;
                    minus[p] -= 1e-6;
                    expected += (step(&x, plus.as_slice()) - step(&x, minus.as_slice())) / 2e-6;
                }
                let error = (sensitivity.column(j) - &expected).norm();
                assert!(error < 1e-8, "linear {linear}, unknown {j}: {error:e}");
            }
        }
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

    /// Z_w in A and in a_z's row of C, Z_δe in B and in D (the textbook
    /// short period), and q̇ a rate output: ∂f/∂θ and ∂y/∂θ are the sums
    /// over each parameter's entries, as central differences give them
    /// (f and y are linear in θ: the differences are exact to rounding).
    #[test]
    fn a_parameter_in_several_entries_has_the_summed_jacobian() {
        let entry = |matrix, row, column| Entry {
            matrix,
            row,
            column,
        };
        let a = DMatrix::from_row_slice(2, 2, &[-1.2, 1.0, -8.0, -2.1]);
        let b = DMatrix::from_row_slice(2, 1, &[-0.1, -9.0]);
        let c = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, -1.2, 0.0]);
        let d = DMatrix::from_row_slice(3, 1, &[0.0, 0.0, -0.1]);
        let parameters = vec![
            vec![entry(Matrix::A, 0, 0), entry(Matrix::C, 2, 0)],
            vec![entry(Matrix::B, 0, 0), entry(Matrix::D, 2, 0)],
            vec![entry(Matrix::A, 1, 1)],
        ];
        let inputs = vec![DVector::from_element(1, 0.03); 10];
        let model = LinearStateSpace::new([a, b, c, d], parameters, 0.0, 0.04, inputs)
            .unwrap()
            .with_rate_outputs(vec![1])
            .unwrap();
        let theta = [-1.5, -0.2, -2.5];
        let x = [0.02, -0.1];
        let t = model.time(3);
        let j = model.jacobians(t, &x, &theta).unwrap();
        assert_eq!(model.at(&theta).unwrap().c[(2, 0)], -1.5);
        assert_eq!(model.at(&theta).unwrap().d[(2, 0)], -0.2);
        for p in 0..theta.len() {
            let (mut up, mut down) = (theta, theta);
            up[p] += 1e-6;
            down[p] -= 1e-6;
            let rates =
                (model.rates(t, &x, &up).unwrap() - model.rates(t, &x, &down).unwrap()) / 2e-6;
            let outputs =
                (model.outputs(t, &x, &up).unwrap() - model.outputs(t, &x, &down).unwrap()) / 2e-6;
            assert!(
                (rates - j.rates_by_parameter.column(p)).amax() < 1e-9,
                "{p}"
            );
            assert!(
                (outputs - j.outputs_by_parameter.column(p)).amax() < 1e-9,
                "{p}"
            );
        }
        assert_eq!(j.outputs_by_parameter[(2, 0)], 0.02);
        assert_eq!(j.rates_by_parameter[(0, 0)], 0.02);
    }

    #[test]
    fn bad_shapes_and_entries_are_refused() {
        let m = model();
        let mut parameters = m.parameters.clone();
        parameters.push(vec![Entry {
            matrix: Matrix::D,
            row: 5,
            column: 0,
        }]);
        let matrices = [m.a.clone(), m.b.clone(), m.c.clone(), m.d.clone()];
        assert!(LinearStateSpace::new(matrices, parameters, 0.0, 0.04, m.inputs.clone()).is_err());
        let matrices = [m.a.clone(), m.b.clone(), m.c.clone(), DMatrix::zeros(1, 1)];
        assert!(LinearStateSpace::new(matrices, vec![], 0.0, 0.04, m.inputs.clone()).is_err());
    }
}
