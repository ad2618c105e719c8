//! Local derivatives of JSBSim's own aerodynamics at a flight condition, by
//! central differences through JSBSim: α, β, p̂, q̂, r̂ (normalised by 2V,
//! DESIGN.md "Conventions") and the elevator, aileron and rudder are
//! perturbed one at a time, each state is set up with `RunIC` (which
//! evaluates every model without advancing time), and the aerodynamic
//! coefficients are read back from JSBSim's forces and moments. The names
//! follow aeroid's linear models (`CL_alpha`, `Cm_q`, `Cn_dr`, `CL_0`, …), so
//! that a JSBSim aircraft's derivatives stand as the truth an estimate is
//! scored against (DESIGN.md, "Truth when the structures differ").
//!
//! What the numbers mean when the aircraft has a flight-control system:
//! - Surfaces are perturbed through the property the caller names: the
//!   surface position itself for an aircraft without a flight-control system
//!   (an exported aeroid aircraft), the pilot command for one with it (the
//!   737's FCS rewrites `fcs/*-pos-rad` in every `RunIC`). The derivative is
//!   the change in coefficient over the change in the surface position read
//!   back, which must move (else an error names both properties) and must be
//!   the only surface that moves.
//! - The rate and flow-angle derivatives are taken at fixed surfaces: where
//!   the FCS moves a surface with the state (the 737's yaw damper feeds r to
//!   the rudder), the surface's share is removed by the chain rule,
//!   `∂C/∂x = dC/dx − Σ ∂C/∂δ·dδ/dx`. An estimator sees the surface positions
//!   as measured inputs, so this is the derivative it estimates.
//! - Terms in α̇ (the 737's Cmα̇) are evaluated at JSBSim's own α̇ of the
//!   perturbed state: `RunIC` runs the models twice, so α̇ comes from the
//!   accelerations of that state. The derivatives are then those of a model
//!   without an α̇ term along the aircraft's own motion, e.g.
//!   `Cm_q = Cmq + Cmα̇·∂α̇/∂q`, which is what a linear postulate in α, q̂, δe
//!   can identify.
//! - The constant terms make the linear model pass through the coefficients
//!   at the condition, `C_0 = C(at) − Σ ∂C/∂x·x(at)`, as
//!   [`aeroid_sim::aero::AeroModel::local_derivatives`] does.

use super::{Exec, InitialConditions, InitialSpeed};
use crate::error::{Error, Result};

/// Perturbation of each variable: 1e-4 rad, 1e-4 of a normalised rate, or
/// 1e-4 of a surface's command.
pub const STEP: f64 = 1e-4;

/// The coefficient names in the order [`coefficients`] returns them.
pub const COEFFICIENTS: [&str; 6] = ["CL", "CY", "CD", "Cl", "Cm", "Cn"];

/// The perturbed variables' keys in derivative names, in perturbation order.
pub const VARIABLES: [&str; 8] = ["alpha", "beta", "p", "q", "r", "de", "da", "dr"];

/// The aerodynamic coefficients JSBSim computed at its current state: CL
/// and CD in stability axes, CY along body y, and the body-axis moments
/// about the centre of gravity (the same axes as aeroid's wind-axis models).
pub fn coefficients(exec: &Exec) -> Result<[f64; 6]> {
    let qs = exec.get("aero/qbar-psf")? * exec.get("metrics/Sw-sqft")?;
    if qs <= 0.0 {
        return Err(Error::Jsbsim {
            context: "aerodynamic coefficients".into(),
            message: format!(
                "the dynamic pressure times wing area is {qs} lbf; is the aircraft moving?"
            ),
        });
    }
    let (span, chord) = (exec.get("metrics/bw-ft")?, exec.get("metrics/cbarw-ft")?);
    Ok([
        exec.get("forces/fsz-aero-lbs")? / qs,
        exec.get("forces/fsy-aero-lbs")? / qs,
        exec.get("forces/fsx-aero-lbs")? / qs,
        exec.get("moments/l-aero-lbsft")? / (qs * span),
        exec.get("moments/m-aero-lbsft")? / (qs * chord),
        exec.get("moments/n-aero-lbsft")? / (qs * span),
    ])
}

/// How one of aeroid's control surfaces is moved and read in a JSBSim aircraft.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceBinding {
    /// The property that is perturbed: the surface position itself, or the
    /// pilot command a flight-control system turns into it.
    pub command: String,
    /// The command's value at the flight condition.
    pub command_value: f64,
    /// JSBSim's surface position (rad), read back after every evaluation.
    pub position: String,
    /// aeroid's deflection is `sign × position` (DESIGN.md: positive elevator
    /// gives Cmδe < 0, positive aileron Clδa < 0, positive rudder Cnδr < 0).
    pub sign: f64,
}

impl SurfaceBinding {
    /// A surface written directly (no flight-control system), in aeroid's sign.
    pub fn direct(property: &str, value: f64) -> SurfaceBinding {
        SurfaceBinding {
            command: property.to_owned(),
            command_value: value,
            position: property.to_owned(),
            sign: 1.0,
        }
    }
}

/// The elevator, aileron and rudder of an aircraft, in that order.
pub type ControlSurfaces = [SurfaceBinding; 3];

/// The result of [`local_derivatives`].
#[derive(Debug, Clone, PartialEq)]
pub struct LocalDerivatives {
    /// `{coefficient}_{alpha|beta|p|q|r|de|da|dr}`, then `{coefficient}_0`.
    pub values: Vec<(String, f64)>,
    /// Change of each surface's deflection (aeroid's sign, rad) per unit
    /// change of its command, at the condition.
    pub deflection_per_command: [f64; 3],
    /// The surface deflections (aeroid's sign, rad) at the condition.
    pub deflections: [f64; 3],
}

impl LocalDerivatives {
    /// A value by name.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.values.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }
}

/// One evaluation: the coefficients and the surface deflections (aeroid's sign).
type Evaluation = ([f64; 6], [f64; 3]);

/// Central-difference derivatives of every coefficient with respect to
/// α, β, p̂, q̂, r̂, δe, δa, δr at `at` (given with its true airspeed), with
/// the surfaces moved through `controls` (see the module documentation for
/// flight-control systems). The executive is left at the unperturbed condition.
pub fn local_derivatives(
    exec: &mut Exec,
    at: &InitialConditions,
    controls: &ControlSurfaces,
) -> Result<LocalDerivatives> {
    let InitialSpeed::TrueAirspeed { speed, alpha, beta } = at.speed else {
        return Err(Error::Jsbsim {
            context: "local derivatives".into(),
            message: "the flight condition must give the true airspeed with α and β".into(),
        });
    };
    let span = exec.get("metrics/bw-ft")? * super::FT;
    let chord = exec.get("metrics/cbarw-ft")? * super::FT;
    let rate_scale = [span, chord, span].map(|length| 2.0 * speed / length);
    // Sets the condition with (variable, offset) applied and evaluates it.
    let mut evaluate = |variable: usize, offset: f64| -> Result<Evaluation> {
        let mut ic = *at;
        let (mut a, mut b) = (alpha, beta);
        match variable {
            0 => a += offset,
            1 => b += offset,
            2..=4 => ic.rates[variable - 2] += offset * rate_scale[variable - 2],
            _ => {}
        }
        ic.speed = InitialSpeed::TrueAirspeed {
            speed,
            alpha: a,
            beta: b,
        };
        for (k, surface) in controls.iter().enumerate() {
            let delta = if variable == 5 + k { offset } else { 0.0 };
            exec.set(&surface.command, surface.command_value + delta)?;
        }
        exec.set_initial_conditions(&ic)?;
        exec.run_ic()?;
        let mut deflections = [0.0; 3];
        for (deflection, surface) in deflections.iter_mut().zip(controls) {
            *deflection = surface.sign * exec.get(&surface.position)?;
        }
        Ok((coefficients(exec)?, deflections))
    };
    // d(coefficients, deflections)/d(variable) by central differences.
    let mut slopes = Vec::with_capacity(VARIABLES.len());
    for variable in 0..VARIABLES.len() {
        let (c_up, s_up) = evaluate(variable, STEP)?;
        let (c_down, s_down) = evaluate(variable, -STEP)?;
        let dc: [f64; 6] = std::array::from_fn(|i| (c_up[i] - c_down[i]) / (2.0 * STEP));
        let ds: [f64; 3] = std::array::from_fn(|i| (s_up[i] - s_down[i]) / (2.0 * STEP));
        slopes.push((dc, ds));
    }
    let (base, deflections) = evaluate(usize::MAX, 0.0)?;

    // ∂C/∂δ_k: the change per command over the change in the surface it moved.
    let mut per_surface = [[0.0; 6]; 3];
    let mut deflection_per_command = [0.0; 3];
    for (k, surface) in controls.iter().enumerate() {
        let (dc, ds) = &slopes[5 + k];
        let moved = ds[k];
        if moved.abs() < 1e-9 {
            return Err(Error::Jsbsim {
                context: format!("local derivatives, {}", VARIABLES[5 + k]),
                message: format!(
                    "changing '{}' does not move '{}' (a flight-control system holds it?): name the command that moves the surface",
                    surface.command, surface.position
                ),
            });
        }
        for (m, other) in controls.iter().enumerate() {
            if m != k && ds[m].abs() > 1e-6 * moved.abs() {
                return Err(Error::Jsbsim {
                    context: format!("local derivatives, {}", VARIABLES[5 + k]),
                    message: format!(
                        "changing '{}' also moves '{}'",
                        surface.command, other.position
                    ),
                });
            }
        }
        per_surface[k] = dc.map(|d| d / moved);
        deflection_per_command[k] = moved;
    }
    // ∂C/∂x at fixed surfaces: remove what the FCS moved with the state.
    let state_at = [alpha, beta, at.rates[0], at.rates[1], at.rates[2]];
    let mut values = Vec::with_capacity(COEFFICIENTS.len() * (VARIABLES.len() + 1));
    let mut constants = base;
    for (variable, key) in VARIABLES.iter().enumerate() {
        let (dc, ds) = &slopes[variable];
        for (i, name) in COEFFICIENTS.iter().enumerate() {
            let derivative = if variable < 5 {
                dc[i] - (0..3).map(|k| per_surface[k][i] * ds[k]).sum::<f64>()
            } else {
                per_surface[variable - 5][i]
            };
            let value_at = if variable < 2 {
                state_at[variable]
            } else if variable < 5 {
                state_at[variable] / rate_scale[variable - 2]
            } else {
                deflections[variable - 5]
            };
            constants[i] -= derivative * value_at;
            values.push((format!("{name}_{key}"), derivative));
        }
    }
    for (name, constant) in COEFFICIENTS.iter().zip(constants) {
        values.push((format!("{name}_0"), constant));
    }
    Ok(LocalDerivatives {
        values,
        deflection_per_command,
        deflections,
    })
}
