//! Linear time-invariant models as the frequency-domain estimators see
//! them: matrices A(θ), B(θ), C(θ), D(θ) of
//!
//!   δẋ = A·δx + B·δu,   δy = C·δx + D·δu,
//!
//! in perturbations from a reference point, whose transfer function
//! C·(jωI − A)⁻¹·B + D is fitted to measured Fourier transforms
//! (Klein & Morelli, "Aircraft System Identification", AIAA 2006, §7.4).
//!
//! Two sources: a [`LinearStateSpace`] (dimensional derivatives as entries),
//! and a nonlinear postulated model linearised about one grid point of its
//! record-driven view (`LinearisedFlight`): the integrated flight-path
//! states are δx; the controls and the measured pseudo-controls (the
//! flight-path states the model does not integrate, e.g. V, α, q, θ under a
//! lateral model) and the record's measured density and thrust where they
//! replace the model's own are δu; the Jacobians come from central differences of
//! the same flight-path rates and outputs the time-domain methods integrate
//! ([`super::driven`]), with the pseudo-controls' own rates at zero (a
//! steady reference). With a linear aerodynamic model, A…D are affine in
//! the coefficients; the bias terms (the constant regressor) only move the
//! reference's rates, which a transform at the Fourier frequencies k/T does
//! not see.

use super::driven::{self, Ambient, FlightPathState, PseudoRates};
use super::linear::LinearStateSpace;
use super::state_space::DrivenStateSpace;
use crate::error::{Error, Result};
use crate::structure::FLIGHT_PATH_STATES;
use aeroid_sim::state::{Control, Controls};
use nalgebra::DMatrix;

/// A linear model with parameters θ.
pub trait TransferModel {
    fn parameter_count(&self) -> usize;
    /// A, B, C, D at θ.
    fn matrices(&self, theta: &[f64]) -> Result<[DMatrix<f64>; 4]>;
}

impl TransferModel for LinearStateSpace {
    fn parameter_count(&self) -> usize {
        self.parameters.len()
    }

    /// The bias terms are constants: no transform at ω = 2πk/T. A rate
    /// output (ẋ_i) is row i of [A B].
    fn matrices(&self, theta: &[f64]) -> Result<[DMatrix<f64>; 4]> {
        let m = self.at(theta)?;
        let rows = |direct: &DMatrix<f64>, rates: &DMatrix<f64>| {
            let mut stacked =
                DMatrix::zeros(direct.nrows() + self.rate_outputs.len(), direct.ncols());
            stacked.rows_mut(0, direct.nrows()).copy_from(direct);
            for (k, &i) in self.rate_outputs.iter().enumerate() {
                stacked.row_mut(direct.nrows() + k).copy_from(&rates.row(i));
            }
            stacked
        };
        let (c, d) = (rows(&m.c, &m.a), rows(&m.d, &m.b));
        Ok([m.a, m.b, c, d])
    }
}

/// One input of a linearised flight.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input {
    Control(Control),
    /// A measured flight-path state (index into `FLIGHT_PATH_STATES`).
    Measured(usize),
    /// The record's measured air density, where it replaces the ISA's.
    Density,
    /// The record's measured thrust, where it replaces the throttle model.
    Thrust,
}

impl Input {
    pub fn name(&self) -> &'static str {
        match self {
            Input::Control(control) => control.name(),
            Input::Measured(i) => FLIGHT_PATH_STATES[*i],
            Input::Density => "density",
            Input::Thrust => "thrust",
        }
    }
}

/// A record-driven postulated model linearised about grid point `k`.
#[derive(Debug, Clone)]
pub(crate) struct LinearisedFlight<'a> {
    view: &'a DrivenStateSpace,
    reference: FlightPathState,
    controls: Controls,
    /// The record's measured density and thrust at the reference point.
    ambient: Ambient,
    inputs: Vec<Input>,
}

impl<'a> LinearisedFlight<'a> {
    /// The view linearised about its grid point `k` with the integrated
    /// states at `x` (the others, and the controls, as measured there).
    pub fn new(view: &'a DrivenStateSpace, k: usize, x: &[f64]) -> Result<LinearisedFlight<'a>> {
        let simulation = view.simulation();
        if k >= simulation.len() {
            return Err(Error::Grid {
                reason: format!(
                    "no grid point {k} to linearise about: the grid has {}",
                    simulation.len()
                ),
            });
        }
        let mut reference = simulation.measured()[k];
        if x.len() != view.states().len() {
            return Err(Error::Shape {
                reason: format!(
                    "x has {} values; the model has {} states",
                    x.len(),
                    view.states().len()
                ),
            });
        }
        for (&i, &value) in view.states().iter().zip(x) {
            reference[i] = value;
        }
        let mut inputs: Vec<Input> = Control::ALL.into_iter().map(Input::Control).collect();
        inputs.extend(
            (0..FLIGHT_PATH_STATES.len())
                .filter(|i| !simulation.integrate[*i])
                .map(Input::Measured),
        );
        let ambient = simulation.ambient(k);
        inputs.extend(ambient.density.map(|_| Input::Density));
        inputs.extend(ambient.thrust.map(|_| Input::Thrust));
        Ok(LinearisedFlight {
            view,
            reference,
            controls: simulation.controls[k],
            ambient,
            inputs,
        })
    }

    pub fn inputs(&self) -> &[Input] {
        &self.inputs
    }

    /// δu at every grid point: controls and measured states minus the reference's.
    pub fn input_perturbations(&self) -> DMatrix<f64> {
        let simulation = self.view.simulation();
        DMatrix::from_fn(simulation.len(), self.inputs.len(), |k, i| {
            match self.inputs[i] {
                Input::Control(c) => simulation.controls[k][c.index()] - self.controls[c.index()],
                Input::Measured(j) => simulation.measured()[k][j] - self.reference[j],
                Input::Density => difference(simulation.ambient(k).density, self.ambient.density),
                Input::Thrust => difference(simulation.ambient(k).thrust, self.ambient.thrust),
            }
        })
    }

    /// The integrated states' reference values.
    pub fn reference_state(&self) -> Vec<f64> {
        self.view
            .states()
            .iter()
            .map(|&i| self.reference[i])
            .collect()
    }

    /// Rates of the integrated states and outputs at a perturbed point.
    fn evaluate(
        &self,
        model: &aeroid_sim::dynamics::FlightModel,
        state: &FlightPathState,
        controls: &Controls,
        ambient: Ambient,
    ) -> (Vec<f64>, Vec<f64>) {
        let pseudo = PseudoRates {
            airspeed: (!self.view.simulation().integrate[driven::AIRSPEED]).then_some(0.0),
            beta: (!self.view.simulation().integrate[driven::BETA]).then_some(0.0),
        };
        let (rates, outputs) = driven::evaluate(
            model,
            state,
            controls,
            pseudo,
            ambient,
            self.view.observables(),
        );
        (
            self.view.states().iter().map(|&i| rates[i]).collect(),
            outputs,
        )
    }
}

/// A measured quantity's perturbation from the reference's (both present
/// when it is an input).
fn difference(value: Option<f64>, reference: Option<f64>) -> f64 {
    value.zip(reference).map_or(0.0, |(v, r)| v - r)
}

/// Central-difference step along a flight-path state, control or
/// measured quantity.
fn nudge(value: f64) -> f64 {
    1e-6 * value.abs().max(1.0)
}

impl TransferModel for LinearisedFlight<'_> {
    fn parameter_count(&self) -> usize {
        self.view.parameters().len()
    }

    fn matrices(&self, theta: &[f64]) -> Result<[DMatrix<f64>; 4]> {
        let model = self.view.model_at(theta)?;
        let states = self.view.states();
        let (n, m, l) = (
            states.len(),
            self.inputs.len(),
            self.view.observables().len(),
        );
        let mut matrices = [
            DMatrix::zeros(n, n),
            DMatrix::zeros(n, m),
            DMatrix::zeros(l, n),
            DMatrix::zeros(l, m),
        ];
        let columns = states
            .iter()
            .map(|&i| (Input::Measured(i), true))
            .chain(self.inputs.iter().map(|&input| (input, false)));
        for (column, (input, is_state)) in columns.enumerate() {
            let mut sides = [(Vec::new(), Vec::new()), (Vec::new(), Vec::new())];
            let mut step = 0.0;
            for (side, sign) in sides.iter_mut().zip([1.0, -1.0]) {
                let (mut state, mut controls, mut ambient) =
                    (self.reference, self.controls, self.ambient);
                let value = match input {
                    Input::Control(c) => &mut controls[c.index()],
                    Input::Measured(j) => &mut state[j],
                    Input::Density => ambient.density.get_or_insert(0.0),
                    Input::Thrust => ambient.thrust.get_or_insert(0.0),
                };
                step = nudge(*value);
                *value += sign * step;
                *side = self.evaluate(&model, &state, &controls, ambient);
            }
            let [(rates_up, outputs_up), (rates_down, outputs_down)] = &sides;
            let (f, h, j) = if is_state {
                (0, 2, column)
            } else {
                (1, 3, column - n)
            };
            for r in 0..n {
                matrices[f][(r, j)] = (rates_up[r] - rates_down[r]) / (2.0 * step);
            }
            for r in 0..l {
                matrices[h][(r, j)] = (outputs_up[r] - outputs_down[r]) / (2.0 * step);
            }
        }
        if matrices.iter().any(|m| m.iter().any(|v| !v.is_finite())) {
            return Err(Error::Numerical {
                reason: "the linearised model is not finite at the reference point".into(),
            });
        }
        Ok(matrices)
    }
}
