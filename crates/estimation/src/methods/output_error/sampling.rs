//! The prediction on the integration grid read at the channels' own instants, and the output weights.

/// Weights 1/σ per output of a diagonal R re-estimated from the residuals,
/// R_ii = mean square residual (Verma & Peyada 2020, Eq. 8), with a floor of 10⁻¹² of the
/// output's RMS so that a noise-free fit stays finite.
pub(crate) fn diagonal_weights(errors: &[Vec<f64>], measured: &[Vec<f64>]) -> Vec<f64> {
    errors
        .iter()
        .zip(measured)
        .map(|(error, values)| {
            let count = error.len().max(1) as f64;
            let variance = error.iter().map(|e| e * e).sum::<f64>() / count;
            let scale = values.iter().map(|z| z * z).sum::<f64>() / count;
            1.0 / variance.max(1e-24 * scale.max(1e-300)).sqrt()
        })
        .collect()
}

/// Linear interpolation of a grid series at time t.
/// `grid[k]` is the value at `start + k·step`; held beyond the ends.
pub(crate) fn interpolate(grid: &[f64], start: f64, step: f64, t: f64) -> f64 {
    if grid.is_empty() {
        return f64::NAN;
    }
    on_grid(grid, grid_bracket(grid.len(), start, step, t))
}

/// The grid interval [k, k + 1] of a grid of `len` points holding t, and
/// t's fraction of it ((0, 0) for a grid of one point).
pub(super) fn grid_bracket(len: usize, start: f64, step: f64, t: f64) -> (usize, f64) {
    if len < 2 {
        return (0, 0.0);
    }
    let position = ((t - start) / step).max(0.0);
    let k = (position.floor() as usize).min(len - 2);
    (k, (position - k as f64).clamp(0.0, 1.0))
}

/// A grid series' value at a [`grid_bracket`].
pub(super) fn on_grid(series: &[f64], at: (usize, f64)) -> f64 {
    at_bracket(at, |k| series[k])
}

/// The value at a [`grid_bracket`] of a series given point by point.
#[inline(always)]
pub(super) fn at_bracket((k, fraction): (usize, f64), series: impl Fn(usize) -> f64) -> f64 {
    if fraction == 0.0 {
        series(k)
    } else {
        let start = series(k);
        start + fraction * (series(k + 1) - start)
    }
}
