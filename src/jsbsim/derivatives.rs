//! Local derivatives of JSBSim's own aerodynamics at a flight condition, by
//! central differences through JSBSim: α, β, p̂, q̂, r̂ (normalised by 2V) and
//! the elevator, aileron and rudder deflections are perturbed one at a time,
//! each state is set up with `RunIC` (which evaluates every model without
//! advancing time), and the aerodynamic coefficients are read back from
//! JSBSim's forces and moments. The names follow aeroid's linear models
//! (`CL_alpha`, `Cm_q`, `Cn_dr`, …), so that a JSBSim aircraft's derivatives
//! can stand as the truth an estimate is scored against (issue 5, use 2).

use super::{Exec, InitialConditions, InitialSpeed};
use crate::error::{Error, Result};

/// Perturbation of each variable: 1e-4 rad, or 1e-4 of a normalised rate.
pub const STEP: f64 = 1e-4;

/// The coefficient names in the order [`coefficients`] returns them.
pub const COEFFICIENTS: [&str; 6] = ["CL", "CY", "CD", "Cl", "Cm", "Cn"];

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

/// The properties of the elevator, aileron and rudder deflections (rad) to
/// perturb, and their values at the flight condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlSurfaces<'a> {
    pub elevator: (&'a str, f64),
    pub aileron: (&'a str, f64),
    pub rudder: (&'a str, f64),
}

/// Central-difference derivatives of every coefficient with respect to
/// α, β, p̂, q̂, r̂, δe, δa, δr at `at` (given with its true airspeed), named
/// `{coefficient}_{alpha|beta|p|q|r|de|da|dr}`. The executive is left at the
/// unperturbed condition.
pub fn local_derivatives(
    exec: &mut Exec,
    at: &InitialConditions,
    controls: &ControlSurfaces,
) -> Result<Vec<(String, f64)>> {
    let InitialSpeed::TrueAirspeed { speed, alpha, beta } = at.speed else {
        return Err(Error::Jsbsim {
            context: "local derivatives".into(),
            message: "the flight condition must give the true airspeed with α and β".into(),
        });
    };
    let span = exec.get("metrics/bw-ft")? * super::FT;
    let chord = exec.get("metrics/cbarw-ft")? * super::FT;
    let surfaces = [controls.elevator, controls.aileron, controls.rudder];
    // Sets the condition with (variable, offset) applied and evaluates it.
    let mut evaluate = |variable: usize, offset: f64| -> Result<[f64; 6]> {
        let mut ic = *at;
        let (mut a, mut b) = (alpha, beta);
        match variable {
            0 => a += offset,
            1 => b += offset,
            2 => ic.rates[0] += offset * 2.0 * speed / span,
            3 => ic.rates[1] += offset * 2.0 * speed / chord,
            4 => ic.rates[2] += offset * 2.0 * speed / span,
            _ => {}
        }
        ic.speed = InitialSpeed::TrueAirspeed {
            speed,
            alpha: a,
            beta: b,
        };
        for (k, (property, value)) in surfaces.iter().enumerate() {
            let delta = if variable == 5 + k { offset } else { 0.0 };
            exec.set(property, value + delta)?;
        }
        exec.set_initial_conditions(&ic)?;
        exec.run_ic()?;
        coefficients(exec)
    };
    const KEYS: [&str; 8] = ["alpha", "beta", "p", "q", "r", "de", "da", "dr"];
    let mut derivatives = Vec::with_capacity(KEYS.len() * COEFFICIENTS.len());
    for (variable, key) in KEYS.iter().enumerate() {
        let up = evaluate(variable, STEP)?;
        let down = evaluate(variable, -STEP)?;
        for (k, name) in COEFFICIENTS.iter().enumerate() {
            derivatives.push((format!("{name}_{key}"), (up[k] - down[k]) / (2.0 * STEP)));
        }
    }
    evaluate(usize::MAX, 0.0)?;
    Ok(derivatives)
}
