//! The modes of a fitted model and the instability they show
//! ([`DiagnosisKind::Unstable`]): for a linear structure the eigenvalues
//! of A at the estimate, for a 6-DOF structure those of ∂f/∂x at the
//! record's start (`super::state_space::mode_eigenvalues`, the Jacobian
//! the integration step is chosen by).
//!
//! A mode λ with Re λ > 0 grows as e^{Re λ·t}: it doubles in
//! T₂ = ln 2 / Re λ. Where T₂ is shorter than the time one simulation runs
//! (the record, or a piece of it with `segment`), output error simulates
//! the model through that growth: any error of the initial state or of the
//! recorded inputs grows with it, the cost stops being near quadratic in
//! the parameters, and the fit ends at a wrong model, at the iteration
//! limit or with a diverging simulation (Jategaonkar, "Flight Vehicle
//! System Identification", 2nd ed., ch. 9). The diagnosis names each such
//! mode by its eigenvalue (a complex pair once; "short period" where the
//! model's states are that pair, α or w with q) with its T₂ as the
//! measure, fastest growing first, and advises stabilised output error:
//! multiple shooting over pieces shorter than T₂ (`segment`).

use crate::estimate::{Diagnosis, DiagnosisKind, Estimate};
use crate::linear_structure::LinearStructure;
use crate::model::linear::Matrix;
use nalgebra::Complex;

/// Each mode among `eigenvalues` that doubles within `horizon` s (a
/// complex pair once), named, with its time to double; fastest first.
pub fn growing(
    eigenvalues: &[Complex<f64>],
    horizon: f64,
    states: &[String],
) -> Vec<(String, f64)> {
    let short_period = states.len() == 2
        && states.iter().any(|s| s == "q")
        && states.iter().any(|s| s == "alpha" || s == "w");
    let mut modes: Vec<(String, f64)> = eigenvalues
        .iter()
        .filter(|lambda| lambda.re > 0.0 && lambda.im >= 0.0)
        .map(|lambda| {
            (
                name(*lambda, short_period),
                std::f64::consts::LN_2 / lambda.re,
            )
        })
        .filter(|(_, doubling)| doubling.is_finite() && *doubling < horizon)
        .collect();
    modes.sort_by(|a, b| a.1.total_cmp(&b.1));
    modes
}

/// A mode's name: its eigenvalue (a pair as re ± im·i), after "short
/// period" where the states are that pair.
fn name(lambda: Complex<f64>, short_period: bool) -> String {
    let value = if lambda.im > 1e-9 * lambda.norm() {
        format!("λ = {:+.3} ± {:.3}i /s", lambda.re, lambda.im)
    } else {
        format!("λ = {:+.3}/s", lambda.re)
    };
    if short_period {
        format!("short period {value}")
    } else {
        format!("mode {value}")
    }
}

/// Diagnoses `estimate` [`DiagnosisKind::Unstable`] when a mode among
/// `eigenvalues` doubles within `horizon` s, the length of one simulation
/// (`segmented`: a piece of `segment`, else the record).
pub(crate) fn diagnose(
    estimate: &mut Estimate,
    eigenvalues: &[Complex<f64>],
    states: &[String],
    horizon: f64,
    segmented: bool,
) {
    let modes = growing(eigenvalues, horizon, states);
    let Some(fastest) = modes.first().map(|m| m.1) else {
        return;
    };
    let within = if segmented {
        format!("each simulated piece ({horizon:.3} s, `segment`)")
    } else {
        format!("the simulated record ({horizon:.3} s)")
    };
    let advice = format!(
        "the fitted model is unstable and its mode doubles within {within}: a simulation \
         diverges from the flight with any error of its initial state or inputs, so the \
         output-error fit may end at a wrong model; use stabilised output error, multiple \
         shooting over pieces shorter than the time to double, e.g. segment = \"{} s\" \
         (Jategaonkar ch. 9), or the filter error method",
        aeroid_record::significant(shorter(fastest), 1)
    );
    let (about, measures) = modes.into_iter().unzip();
    estimate.diagnose(Diagnosis {
        kind: DiagnosisKind::Unstable,
        about,
        measures,
        advice,
    });
}

/// `value` rounded down to one significant digit (a piece length below
/// the time to double).
fn shorter(value: f64) -> f64 {
    let magnitude = 10f64.powf(value.log10().floor());
    (value / magnitude).floor() * magnitude
}

/// The eigenvalues of A of `structure` with the estimate's values of its
/// parameters (the file's for those it does not hold).
pub(crate) fn linear_eigenvalues(
    structure: &LinearStructure,
    estimate: &Estimate,
) -> Vec<Complex<f64>> {
    let mut a = structure.matrices.a.clone();
    for (i, set) in structure.entries.iter().enumerate() {
        let value = estimate
            .parameter(&structure.names[i])
            .map_or(structure.starts[i], |p| p.value);
        for entry in set.iter().filter(|e| e.matrix == Matrix::A) {
            a[(entry.row, entry.column)] = value;
        }
    }
    if !a.iter().all(|v| v.is_finite()) {
        return Vec::new();
    }
    a.complex_eigenvalues().iter().copied().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_divergence_faster_than_the_record_is_named_with_its_time_to_double() {
        let states = vec!["alpha".to_string(), "q".to_string()];
        let eigenvalues = [Complex::new(0.5, 0.0), Complex::new(-1.5, 0.0)];
        let modes = growing(&eigenvalues, 20.0, &states);
        assert_eq!(modes.len(), 1);
        assert_eq!(modes[0].0, "short period λ = +0.500/s");
        assert!((modes[0].1 - std::f64::consts::LN_2 / 0.5).abs() < 1e-12);
        // Slower than a 1-s piece: nothing to say.
        assert!(growing(&eigenvalues, 1.0, &states).is_empty());
        // A pair is named once, as a mode where the states are not the short period's.
        let pair = [Complex::new(0.2, 1.0), Complex::new(0.2, -1.0)];
        let modes = growing(&pair, 20.0, &["beta".into(), "r".into(), "p".into()]);
        assert_eq!(modes.len(), 1);
        assert_eq!(modes[0].0, "mode λ = +0.200 ± 1.000i /s");
    }
}
