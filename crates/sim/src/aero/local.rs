//! Local linear derivatives of a model at a flight condition: the truth a
//! linear postulate is scored against when the true model is not linear
//! (DESIGN.md, "Truth when the structures differ"), by central differences
//! with χ at its quasi-steady value.

use super::model::{AeroInput, AeroModel};
use super::terms::{Coefficient, Regressor};
use crate::state::Control;

/// Moves one flight variable of an input by a step (for local derivatives).
type Perturbation = fn(&mut AeroInput, f64);

impl AeroModel {
    /// Local linear derivatives of this model at a flight condition, named
    /// as a linear model's parameters (`CL_alpha`, `Cm_q`, `CL_0`, …): the
    /// truth that a linear postulate is scored against when this (truth)
    /// model is not linear (DESIGN.md, "Truth when the structures differ").
    /// Central differences with steps of 1e-5 in each regressor; χ takes its
    /// quasi-steady value χ∞(α) (α̇ = 0); the constant term is
    /// C(at) − Σ ∂C/∂x·x(at) so that the linear model passes through C(at).
    pub fn local_derivatives(&self, at: &AeroInput) -> Vec<(String, f64)> {
        const STEP: f64 = 1e-5;
        let divisor = self.rate_divisor(at.airspeed);
        let (b, c) = (self.geometry.span, self.geometry.chord);
        let evaluate = |input: &AeroInput| {
            let mut input = *input;
            input.chi = self.separation_target(input.alpha, input.alpha_dot, input.airspeed);
            self.coefficient_values(&self.coefficients(&input))
        };
        let perturbations: [(Regressor, f64, Perturbation); 9] = [
            (Regressor::Alpha, STEP, |i, h| i.alpha += h),
            (Regressor::Beta, STEP, |i, h| i.beta += h),
            (Regressor::RollRate, STEP * divisor / b, |i, h| {
                i.rates.x += h
            }),
            (Regressor::PitchRate, STEP * divisor / c, |i, h| {
                i.rates.y += h
            }),
            (Regressor::YawRate, STEP * divisor / b, |i, h| {
                i.rates.z += h
            }),
            (Regressor::Elevator, STEP, |i, h| {
                i.controls[Control::Elevator.index()] += h
            }),
            (Regressor::Aileron, STEP, |i, h| {
                i.controls[Control::Aileron.index()] += h
            }),
            (Regressor::Rudder, STEP, |i, h| {
                i.controls[Control::Rudder.index()] += h
            }),
            (Regressor::Flap, STEP, |i, h| {
                i.controls[Control::Flap.index()] += h
            }),
        ];
        let regressors = self.regressors(at, 1.0);
        let base = evaluate(at);
        let mut constants = base;
        let mut derivatives = Vec::new();
        for (regressor, h, perturb) in perturbations {
            let (mut plus, mut minus) = (*at, *at);
            perturb(&mut plus, h);
            perturb(&mut minus, -h);
            let (up, down) = (evaluate(&plus), evaluate(&minus));
            for (k, coefficient) in Coefficient::ALL.iter().enumerate() {
                let slope = (up[k] - down[k]) / (2.0 * STEP);
                constants[k] -= slope * regressors[regressor as usize];
                derivatives.push((
                    format!("{}_{}", coefficient.name(self.force_axes), regressor.key()),
                    slope,
                ));
            }
        }
        for (k, coefficient) in Coefficient::ALL.iter().enumerate() {
            derivatives.push((
                format!("{}_0", coefficient.name(self.force_axes)),
                constants[k],
            ));
        }
        derivatives
    }
}
