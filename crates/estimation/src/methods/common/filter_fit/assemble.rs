//! The estimate of a fit: the aerodynamic parameters with their block of
//! the Cramér–Rao covariance; F, G and R in the notes and details.

use super::*;
use crate::estimate::ParameterEstimate;

/// The names of the noise unknowns: F's entries of the `noisy` states and,
/// with the time-varying gain, G's of the `outputs`.
pub(crate) fn noise_names<'a>(
    noisy: impl Iterator<Item = &'a str>,
    outputs: &[String],
    gain: Gain,
) -> Vec<String> {
    let measurement = outputs.iter().take(if gain == Gain::TimeVarying {
        outputs.len()
    } else {
        0
    });
    noisy
        .map(|name| format!("F.{name}"))
        .chain(measurement.map(|name| format!("G.{name}")))
        .collect()
}

/// The names of a fit's unknowns: the free parameters, then F's entries
/// (and G's, time-varying gain).
pub(crate) struct Names {
    pub(crate) parameters: Vec<String>,
    pub(crate) noise: Vec<String>,
    /// The model's integrated states, in x's order.
    pub(crate) states: Vec<String>,
}

impl Names {
    /// Every unknown's name in θ's order.
    pub(crate) fn unknowns(&self) -> Vec<String> {
        self.parameters.iter().chain(&self.noise).cloned().collect()
    }
}

/// The estimate of a fit by `method` of model `name` with `outputs`: the
/// model's parameters with their block of the Cramér–Rao covariance; F and
/// R in the notes and details.
pub(crate) fn assemble<M: StateSpaceModel + ?Sized>(
    (method, name, outputs): (&str, &str, &[String]),
    record: &FlightRecord,
    fit: &FilterErrorFit<'_, M>,
    result: &FitResult,
    names: &Names,
    mut notes: Vec<String>,
    wall_time: f64,
) -> Estimate {
    let all: Vec<String> = names
        .parameters
        .iter()
        .chain(&names.noise)
        .cloned()
        .collect();
    let full = Estimate::from_solution(
        (method, name.to_string(), record.scenario.clone()),
        &all,
        &result.start,
        &result.solution,
    );
    let aero = names.parameters.len();
    let noise = &full.parameters[aero..];
    let details = details(fit.gain, result, noise, outputs);
    noise_notes(fit, result, names, noise, outputs, &mut notes);
    let fits = output_fits(fit, result, outputs);
    Estimate {
        parameters: full.parameters[..aero].to_vec(),
        covariance: full.covariance[..aero]
            .iter()
            .map(|row| row[..aero].to_vec())
            .collect(),
        fits,
        wall_time,
        notes,
        details,
        ..full
    }
}

/// The estimate's details: F (and G) with their Cramér–Rao σ, R or G·Gᵀ's
/// diagonal, and a full R's correlations.
fn details(
    gain: Gain,
    result: &FitResult,
    noise: &[ParameterEstimate],
    outputs: &[String],
) -> String {
    let mut details = String::new();
    if !noise.is_empty() {
        details.push_str(match gain {
            Gain::Steady => "process-noise distribution F (diagonal), Cramér–Rao σ:\n",
            Gain::TimeVarying => {
                "process-noise distribution F and measurement-noise G (diagonal), Cramér–Rao σ:\n"
            }
        });
    }
    for p in noise {
        details.push_str(&format!(
            "  {} = {:.6e} ± {:.3e} (start {:.3e})\n",
            p.name,
            p.value.abs(),
            p.standard_error,
            p.start
        ));
    }
    details.push_str(match (gain, &result.full) {
        (Gain::Steady, None) => "innovation covariance R (diagonal):\n",
        (Gain::Steady, Some(_)) => {
            "innovation covariance R (full, one time base): variances, then correlations:\n"
        }
        (Gain::TimeVarying, _) => "measurement noise G·Gᵀ (diagonal):\n",
    });
    for (name, r) in outputs.iter().zip(result.variances.iter()) {
        details.push_str(&format!("  {name}: {r:.6e}\n"));
    }
    if let Some(full) = result.full.as_ref().map(InnovationCovariance::matrix) {
        for a in 0..full.nrows() {
            for b in 0..a {
                let correlation = full[(a, b)] / (full[(a, a)] * full[(b, b)]).sqrt();
                details.push_str(&format!(
                    "  {} · {}: {correlation:+.3}\n",
                    outputs[a], outputs[b]
                ));
            }
        }
    }
    details
}

/// The notes on the noise: F (and G) estimated, the gain constraint where
/// it is active, the form of R and its determinant, the outputs fitted to
/// rounding.
fn noise_notes<M: StateSpaceModel + ?Sized>(
    fit: &FilterErrorFit<'_, M>,
    result: &FitResult,
    names: &Names,
    noise: &[ParameterEstimate],
    outputs: &[String],
    notes: &mut Vec<String>,
) {
    if !noise.is_empty() {
        notes.push(format!(
            "{} {}; F started at {} × F_ref",
            match fit.gain {
                Gain::Steady => "process noise",
                Gain::TimeVarying => "process and measurement noise",
            },
            noise
                .iter()
                .map(|p| format!(
                    "{} = {:.4e} ± {:.2e}",
                    p.name,
                    p.value.abs(),
                    p.standard_error
                ))
                .collect::<Vec<_>>()
                .join(", "),
            result.start_factor
        ));
    }
    if let (true, Some(FilterPass::Steady(pass))) = (result.constrained, &result.pass) {
        let products = (&pass.steady.gain * &pass.output_matrix).diagonal();
        let largest = products
            .iter()
            .zip(&names.states)
            .max_by(|a, b| a.0.total_cmp(b.0))
            .map(|(p, name)| format!("{name} ({p:.6})"))
            .unwrap_or_default();
        notes.push(format!(
            "the constraint diag(K·C) ≤ 1 (Jategaonkar §5.3) is active at the solution: the last Gauss–Newton step was the quadratic program constrained by it; largest entry after the last R update and F compensation {largest}"
        ));
    }
    if let Some(reason) = &result.full_refused {
        notes.push(format!("R is diagonal, not full: {reason}"));
    } else if result.full.is_some() {
        notes.push("R full, fitted from the estimate with a diagonal R".into());
    }
    let determinant = match &result.full {
        Some(full) => full.matrix().determinant(),
        None => result.variances.iter().product::<f64>(),
    };
    notes.push(match (fit.gain, &result.full) {
        (Gain::Steady, None) => format!(
            "R (innovation covariance) is diagonal; det(R) = {determinant:.4e} at the solution"
        ),
        (Gain::Steady, Some(_)) => format!(
            "R (innovation covariance) is full (every output on one time base; its correlations in the details); det(R) = {determinant:.4e} at the solution"
        ),
        (Gain::TimeVarying, _) => format!(
            "time-varying gain (extended Kalman filter in the loop); G·Gᵀ (measurement noise) is diagonal, det(G·Gᵀ) = {determinant:.4e} at the solution; P0 diagonal {}",
            fit.initial_covariance
                .diagonal()
                .iter()
                .map(|v| format!("{v:.3e}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    });
    let exact = fit.noise_at_rounding(&result.solution.theta);
    if !exact.is_empty() {
        notes.push(format!(
            "fitted to rounding: G·Gᵀ of {} at its rounding floor ({NOISE_ROUNDING:e} of the output's variance), measurements without noise; G held there, its bound infinite",
            exact
                .iter()
                .map(|&o| outputs[o].as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
}

/// Each output's measured and predicted values at the solution's pass.
fn output_fits<M: StateSpaceModel + ?Sized>(
    fit: &FilterErrorFit<'_, M>,
    result: &FitResult,
    outputs: &[String],
) -> Vec<OutputFit> {
    result
        .pass
        .as_ref()
        .map(|pass| {
            (0..outputs.len())
                .map(|o| {
                    let (measured, predicted): (Vec<f64>, Vec<f64>) = fit
                        .outputs
                        .iter()
                        .zip(fit.measured.iter().zip(pass.predicted()))
                        .filter(|(output, _)| **output == o)
                        .map(|(_, (z, y))| (*z, *y))
                        .unzip();
                    OutputFit::new(&outputs[o], &measured, &predicted)
                })
                .collect()
        })
        .unwrap_or_default()
}
