//! The augmented filters' noise tuning between passes (the `ekf`/`ukf`
//! module header, Noise 2): R per output and the integrated states'
//! process noise from a pass's innovations over the second half of the
//! record, past the parameters' transient.
//!
//! **Mehra's residual-correlation method** (the default; Mehra, "On the
//! identification of variances and adaptive Kalman filtering", IEEE TAC
//! 15(2), 1970, §IV; [`kalman::residual_correlation`]): the innovations'
//! sample autocorrelations Ĉ_j at lags j = 0 … k (Eq. 13), at the grid
//! points where every output is measured, give M·Hᵀ by least squares
//! (Eq. 29), R = Ĉ₀ − H·M·Hᵀ (Eq. 30) and the diagonal of the states'
//! discrete process noise Q_d by least squares over the lags' equations
//! (Eq. 33), the intensity Q_c = Q_d/h replacing the previous one. The
//! lags default to the number of integrated states n: Eq. 29 determines
//! M·Hᵀ uniquely when k ≥ n and the system is observable. The method holds
//! for any constant gain, not only the optimal one, so the first pass's
//! (no process noise) already serves. It assumes a time-invariant system
//! and gain: the kinematic block of the transition and of H at the
//! window's middle and of the gain at its end stand for them (the
//! parameter states, nearly settled there, are left out), exact for a
//! linear model with settled parameters.
//!
//! **Zero-lag covariance matching** (`correlation_lags = 0`; Mehra's R
//! step with the filter's own P⁻, and the Myers–Tapley form of the Q
//! step): R = C₀ − H·P⁻·Hᵀ per output and Q_d += K·(C₀ − S)·Kᵀ (diagonal,
//! the kinematic states, not below zero). Its Q step scales with the gain
//! the last pass had: with no process noise the gain on the states is
//! small, so a few passes raise Q far too little (on the linear short
//! period with known process noise, `tests/estimators/linear_models.rs`: three to
//! four orders of magnitude low, where Mehra's mean over 10 seeds is
//! within 15 %; on the ATTAS lateral flight in turbulence it leaves the
//! gust on β, p and r to the parameter states, docs/findings.md).

use crate::solver::extended_kalman::Pass;
use aeroid_numerics::kalman;
use aeroid_numerics::kept::UpdateView;
use nalgebra::DVector;

/// Which update a pass's tuning used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Update {
    /// Mehra's method.
    Mehra,
    /// The zero-lag covariance matching, asked for (`correlation_lags = 0`).
    ZeroLag,
    /// The zero-lag matching where Mehra's method did not serve the pass
    /// (too few points with every output measured, or no transitions).
    ZeroLagFallback,
}

/// Re-estimates R (`measurement`, per output, not below `floors`) and,
/// when `process` is given, the states' process-noise intensities from
/// `pass` over the second half of its `len` grid points of `step`
/// seconds: Mehra's method with `lags` lags, the zero-lag matching for 0
/// lags or where Mehra's does not serve.
#[allow(clippy::too_many_arguments)]
pub fn update(
    pass: &Pass,
    len: usize,
    step: f64,
    states: usize,
    lags: usize,
    measurement: &mut [f64],
    floors: &[f64],
    mut process: Option<&mut [f64]>,
) -> Update {
    if lags > 0
        && mehra_update(
            pass,
            len,
            step,
            states,
            lags,
            measurement,
            floors,
            process.as_deref_mut(),
        )
        .is_some()
    {
        return Update::Mehra;
    }
    correlation_update(pass, len, step, states, measurement, floors, process);
    if lags > 0 {
        Update::ZeroLagFallback
    } else {
        Update::ZeroLag
    }
}

/// Per output: the mean normalised squared innovation ν²/S over the second
/// half of the record.
pub(crate) fn normalised_innovations(pass: &Pass, len: usize) -> Vec<f64> {
    pass.innovations
        .iter()
        .map(|innovations| {
            let late: Vec<f64> = innovations
                .iter()
                .filter(|i| i.k >= len / 2)
                .map(|i| i.value * i.value / i.variance)
                .collect();
            late.iter().sum::<f64>() / late.len().max(1) as f64
        })
        .collect()
}

/// The residual-correlation update of R (per output) and the states'
/// process noise (module header, Noise 2), from a pass's innovations over
/// the second half of the record.
fn correlation_update(
    pass: &Pass,
    len: usize,
    step: f64,
    states: usize,
    measurement: &mut [f64],
    floors: &[f64],
    process: Option<&mut [f64]>,
) {
    for (o, innovations) in pass.innovations.iter().enumerate() {
        let late: Vec<_> = innovations.iter().filter(|i| i.k >= len / 2).collect();
        if late.is_empty() {
            continue;
        }
        let count = late.len() as f64;
        let square = late.iter().map(|i| i.value * i.value).sum::<f64>() / count;
        let predicted = late.iter().map(|i| i.variance).sum::<f64>() / count - measurement[o];
        measurement[o] = (square - predicted).max(floors[o]);
    }
    let Some(process) = process else {
        return;
    };
    let mut change = vec![0.0; states];
    let mut count = 0usize;
    for update in pass.measured.iter().skip(len / 2).flatten() {
        let gain = update.gain.rows(0, states);
        let excess =
            update.innovation * update.innovation.transpose() - update.innovation_covariance;
        let delta = gain * excess * gain.transpose();
        for (i, c) in change.iter_mut().enumerate() {
            *c += delta[(i, i)];
        }
        count += 1;
    }
    if count == 0 {
        return;
    }
    for (q, c) in process.iter_mut().zip(change) {
        // Q_d per step as a continuous intensity: Q_c ≈ Q_d/h.
        *q = (*q + c / count as f64 / step).max(0.0);
    }
}

/// Mehra's residual-correlation update (module header, Noise 2, k ≥ 1
/// lags; [`kalman::residual_correlation`]) of R (per output) and the
/// states' process noise from a pass's innovations over the second half of
/// the record, at the grid points where every output is measured: the
/// kinematic block of the transition at the window's middle, of H there,
/// and of the gain at its end stand for the time-invariant system Mehra's
/// method assumes (the parameter states, nearly settled there, are left
/// out). Q_c = Q_d/h. None, with nothing changed, where the pass does not
/// serve (too few such points, no transitions kept, a singular step).
#[allow(clippy::too_many_arguments)]
fn mehra_update(
    pass: &Pass,
    len: usize,
    step: f64,
    states: usize,
    lags: usize,
    measurement: &mut [f64],
    floors: &[f64],
    process: Option<&mut [f64]>,
) -> Option<()> {
    let outputs = measurement.len();
    let window: Vec<(usize, UpdateView)> = pass
        .measured
        .iter()
        .enumerate()
        .skip(len / 2)
        .filter_map(|(k, m)| m.map(|m| (k, m)))
        // A grid point's measurements are in the outputs' order.
        .filter(|(_, m)| m.innovation.len() == outputs)
        .collect();
    let &(middle, at_middle) = window.get(window.len() / 2)?;
    let (_, last) = window.last()?;
    let transition = pass
        .transitions
        .get(middle)?
        .view((0, 0), (states, states))
        .into_owned();
    let observation = at_middle.observation.columns(0, states).into_owned();
    let gain = last.gain.rows(0, states).into_owned();
    let innovations: Vec<DVector<f64>> = window
        .iter()
        .map(|(_, m)| m.innovation.into_owned())
        .collect();
    let noisy: Vec<usize> = (0..states).collect();
    let tuned =
        kalman::residual_correlation(&transition, &observation, &gain, &innovations, lags, &noisy)
            .ok()?;
    for (o, value) in measurement.iter_mut().enumerate() {
        *value = tuned.measurement[(o, o)].max(floors[o]);
    }
    if let Some(process) = process {
        for (q, d) in process.iter_mut().zip(tuned.process.iter()) {
            *q = d / step;
        }
    }
    Some(())
}
