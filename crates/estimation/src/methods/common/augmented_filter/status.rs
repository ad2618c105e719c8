//! How an augmented-filter fit ended: settled, identified and consistent (the module documentation's "Status").

use super::*;

/// Settled and identified (module header, Status), and the innovations'
/// consistency as a diagnosis.
pub(super) fn status(
    setup: &Setup,
    history: &History,
    ratios: &[f64],
    outputs: &[String],
) -> (Status, Vec<Diagnosis>) {
    status_of(
        &setup.prior,
        setup.x0.len(),
        &setup.names,
        history,
        ratios,
        outputs,
    )
}

/// [`status`] from the prior covariance (n kinematic states, then the
/// parameters `names`).
pub(super) fn status_of(
    prior: &DMatrix<f64>,
    n: usize,
    names: &[String],
    history: &History,
    ratios: &[f64],
    outputs: &[String],
) -> (Status, Vec<Diagnosis>) {
    let inconsistent: Vec<(&String, f64)> = outputs
        .iter()
        .zip(ratios)
        .filter(|(_, r)| r.is_nan() || (**r - 1.0).abs() > CONSISTENT)
        .map(|(o, r)| (o, *r))
        .collect();
    let diagnoses = if inconsistent.is_empty() {
        Vec::new()
    } else {
        vec![Diagnosis {
            kind: DiagnosisKind::InconsistentInnovations,
            about: inconsistent.iter().map(|(o, _)| o.to_string()).collect(),
            measures: inconsistent.iter().map(|(_, r)| *r).collect(),
            advice: format!(
                "mean ν²/S beyond 1 ± {CONSISTENT}: the noise covariances Q and R do not describe the record, so the bounds do not either"
            ),
        }]
    };
    (settled(prior, n, names, history), diagnoses)
}

/// Identified and settled: each parameter's σ below its prior's /√2, and
/// its estimate within 2σ over the last [`SETTLING_FRACTION`] of the record.
pub(super) fn settled(
    prior: &DMatrix<f64>,
    n: usize,
    names: &[String],
    history: &History,
) -> Status {
    let len = history.times.len();
    let last = len - 1;
    let from = ((1.0 - SETTLING_FRACTION) * last as f64).floor() as usize;
    let unidentified: Vec<String> = (0..names.len())
        .filter(|&j| {
            let prior = prior[(n + j, n + j)].sqrt();
            history.sigmas[last][j].is_nan()
                || history.sigmas[last][j] >= prior / std::f64::consts::SQRT_2
        })
        .map(|j| names[j].clone())
        .collect();
    if !unidentified.is_empty() {
        return Status::Unidentified(unidentified);
    }
    let unsettled: Vec<String> = (0..names.len())
        .filter(|&j| {
            let moved = (from..=last)
                .map(|k| (history.values[k][j] - history.values[last][j]).abs())
                .fold(0.0, f64::max);
            moved.is_nan() || moved > 2.0 * history.sigmas[from][j]
        })
        .map(|j| names[j].clone())
        .collect();
    if !unsettled.is_empty() {
        return Status::Unsettled(format!(
            "moved by more than 2σ over the last {:.0} % of the record: {}",
            100.0 * SETTLING_FRACTION,
            unsettled.join(", ")
        ));
    }
    Status::Converged
}
