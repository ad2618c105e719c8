//! Innovation statistics: Mehra's residual-correlation estimates of the
//! noise covariances from a constant-gain filter's innovations (Mehra, "On
//! the identification of variances and adaptive Kalman filtering", IEEE
//! TAC 15(2), 1970, §IV; [`residual_correlation`]) and the whiteness test
//! of a series' autocorrelations (Box & Jenkins; Jategaonkar, "Flight
//! Vehicle System Identification", 2nd ed., §6.5.1; [`whiteness`]).

use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};

/// What Mehra's residual-correlation method estimates ([`residual_correlation`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualCorrelation {
    /// R̂ = Ĉ₀ − H·(M·Hᵀ)^ (Mehra Eq. 30).
    pub measurement: DMatrix<f64>,
    /// The diagonal of the discrete process noise Q_d, zero where not
    /// estimated; entries the least squares put below zero are zero.
    pub process: DVector<f64>,
    /// (M·Hᵀ)^ (Mehra Eq. 29).
    pub cross: DMatrix<f64>,
}

/// Mehra's residual-correlation estimates of the noise of a time-invariant
/// system x_{k+1} = Φ·x_k + w_k (E[w·wᵀ] = Q_d), z_k = H·x_k + v_k
/// (E[v·vᵀ] = R) from the innovations ν_k of a filter with the constant,
/// not necessarily optimal, gain K (Mehra, "On the identification of
/// variances and adaptive Kalman filtering", IEEE TAC 15(2), 1970, §IV):
/// 1. the sample autocorrelations Ĉ_j = (1/N)·Σ_{i≥j} ν_i·ν_{i−j}ᵀ,
///    j = 0 … `lags` (Eq. 13);
/// 2. with C_j = H·Ψ^{j−1}·Φ·(M·Hᵀ − K·C₀), Ψ = Φ·(I − K·H), M the
///    filter's predicted error covariance (Eq. 21), M·Hᵀ = K·Ĉ₀ + A⁺·Ĉ by
///    least squares over the lags, A = [H·Φ; H·Ψ·Φ; …; H·Ψ^{lags−1}·Φ],
///    Ĉ = [Ĉ₁; …; Ĉ_lags] (Eq. 29; unique when `lags` ≥ the states and the
///    system is observable);
/// 3. R̂ = Ĉ₀ − H·M·Hᵀ (Eq. 30);
/// 4. Q_d from M = Φ·M·Φᵀ + Ω + Q_d, Ω = Φ·(K·C₀·Kᵀ − K·H·M − M·Hᵀ·Kᵀ)·Φᵀ,
///    which gives for j = 1 … `lags`
///    Σ_{l<j} H·Φˡ·Q_d·Φ^{(l−j)ᵀ}·Hᵀ = H·M·Φ^{−jᵀ}·Hᵀ − H·Φʲ·M·Hᵀ
///    − Σ_{l<j} H·Φˡ·Ω·Φ^{(l−j)ᵀ}·Hᵀ (Eq. 33), whose right side needs only
///    M·Hᵀ; with Q_d diagonal on the states `noisy`, linear in its
///    entries, solved by least squares over every entry of every lag.
///
/// An error when there are not more innovations than lags, no lag is
/// asked for, or Φ is singular.
pub fn residual_correlation(
    transition: &DMatrix<f64>,
    observation: &DMatrix<f64>,
    gain: &DMatrix<f64>,
    innovations: &[DVector<f64>],
    lags: usize,
    noisy: &[usize],
) -> Result<ResidualCorrelation> {
    let (n, m, count) = (transition.nrows(), observation.nrows(), innovations.len());
    if lags == 0 || count <= lags {
        return Err(Error::Input {
            reason: format!(
                "the residual-correlation method needs at least one lag and more innovations than lags ({count} innovations, {lags} lags)"
            ),
        });
    }
    let autocorrelation = |j: usize| {
        let mut sum = DMatrix::zeros(m, m);
        for i in j..count {
            sum += &innovations[i] * innovations[i - j].transpose();
        }
        sum / count as f64
    };
    let correlations: Vec<DMatrix<f64>> = (0..=lags).map(autocorrelation).collect();
    let zero = &correlations[0];
    let closed = transition * (DMatrix::identity(n, n) - gain * observation);
    let mut stacked = DMatrix::zeros(lags * m, n);
    let mut measured = DMatrix::zeros(lags * m, m);
    let mut power = transition.clone();
    for j in 0..lags {
        stacked
            .rows_mut(j * m, m)
            .copy_from(&(observation * &power));
        measured.rows_mut(j * m, m).copy_from(&correlations[j + 1]);
        power = &closed * power;
    }
    let solved = stacked
        .svd(true, true)
        .solve(&measured, 1e-12)
        .map_err(|e| Error::LeastSquares {
            what: "the residual-correlation least squares",
            reason: e.to_string(),
        })?;
    let cross = gain * zero + solved;
    let measurement = zero - observation * &cross;
    let measurement = (&measurement + measurement.transpose()) * 0.5;
    let process = process_noise_diagonal(transition, observation, gain, zero, &cross, lags, noisy)?;
    Ok(ResidualCorrelation {
        measurement,
        process,
        cross,
    })
}

/// Q_d's diagonal on the states `noisy` from Mehra's Eq. 33 over the lags
/// 1 … `lags` by least squares ([`residual_correlation`], step 4), given
/// Ĉ₀ = `zero` and M·Hᵀ = `cross`; entries below zero are zero. An error
/// when Φ is singular.
fn process_noise_diagonal(
    transition: &DMatrix<f64>,
    observation: &DMatrix<f64>,
    gain: &DMatrix<f64>,
    zero: &DMatrix<f64>,
    cross: &DMatrix<f64>,
    lags: usize,
    noisy: &[usize],
) -> Result<DVector<f64>> {
    let (n, m) = (transition.nrows(), observation.nrows());
    let inverse = transition
        .clone()
        .try_inverse()
        .ok_or_else(|| Error::Singular {
            reason: "the residual-correlation method needs an invertible transition".into(),
        })?;
    let omega = transition
        * (gain * zero * gain.transpose() - gain * cross.transpose() - cross * gain.transpose())
        * transition.transpose();
    // Φˡ·Hᵀ's transposes H·Φˡ for l = 0 … lags and H·Φ^{−l} for l = 1 … lags.
    let mut forward = vec![observation.clone()];
    let mut backward = vec![observation.clone()];
    for _ in 0..lags {
        let last = forward.last().cloned().unwrap_or_default();
        forward.push(last * transition);
        let last = backward.last().cloned().unwrap_or_default();
        backward.push(last * &inverse);
    }
    let mut design = DMatrix::zeros(lags * m * m, noisy.len());
    let mut right = DVector::zeros(lags * m * m);
    for j in 1..=lags {
        // H·M·Φ^{−jᵀ}·Hᵀ = (Φ^{−j}·M·Hᵀ)ᵀ·Hᵀ, and M·Hᵀ = `cross`.
        let inverse_power = (0..j).fold(DMatrix::identity(n, n), |p, _| p * &inverse);
        let mut side = (inverse_power * cross).transpose() * observation.transpose()
            - &forward[j].clone() * cross;
        for l in 0..j {
            side -= &forward[l] * &omega * backward[j - l].transpose();
        }
        for (c, &i) in noisy.iter().enumerate() {
            let mut term = DMatrix::<f64>::zeros(m, m);
            for l in 0..j {
                term += forward[l].column(i) * backward[j - l].column(i).transpose();
            }
            for (e, value) in term.iter().enumerate() {
                design[((j - 1) * m * m + e, c)] = *value;
            }
        }
        for (e, value) in side.iter().enumerate() {
            right[(j - 1) * m * m + e] = *value;
        }
    }
    let entries = design
        .svd(true, true)
        .solve(&right, 1e-12)
        .map_err(|e| Error::LeastSquares {
            what: "the residual-correlation least squares",
            reason: e.to_string(),
        })?;
    let mut process = DVector::zeros(n);
    for (c, &i) in noisy.iter().enumerate() {
        process[i] = entries[c].max(0.0);
    }
    Ok(process)
}

/// The fraction of lags 1 … `lags` at which the normalised autocorrelation
/// of `series` (mean removed) lies inside ±1.96/√N, the 95 % band of
/// white noise (Box & Jenkins; Jategaonkar §6.5.1): a whiteness test of
/// innovations. NaN for a constant or too short series.
pub fn whiteness(series: &[f64], lags: usize) -> f64 {
    let n = series.len();
    if n < 2 || lags == 0 || lags >= n {
        return f64::NAN;
    }
    let mean = series.iter().sum::<f64>() / n as f64;
    let centred: Vec<f64> = series.iter().map(|v| v - mean).collect();
    let zero: f64 = centred.iter().map(|v| v * v).sum();
    if zero <= 0.0 {
        return f64::NAN;
    }
    let band = 1.96 / (n as f64).sqrt();
    let inside = (1..=lags)
        .filter(|&lag| {
            let r: f64 = (lag..n).map(|i| centred[i] * centred[i - lag]).sum::<f64>() / zero;
            r.abs() <= band
        })
        .count();
    inside as f64 / lags as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whiteness_separates_white_from_coloured_series() {
        use rand::rngs::ChaCha8Rng;
        use rand::{RngExt, SeedableRng};
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let white: Vec<f64> = (0..4000)
            .map(|_| rng.sample::<f64, _>(rand_distr::StandardNormal))
            .collect();
        assert!(whiteness(&white, 50) >= 0.9);
        let mut coloured = vec![0.0; white.len()];
        for i in 1..white.len() {
            coloured[i] = 0.9 * coloured[i - 1] + white[i];
        }
        // ρ(k) = 0.9ᵏ ≥ 0.35 to lag 10, far above the band 1.96/√4000 = 0.031
        // (the estimate's own scatter there is ≈ 0.07).
        assert!(whiteness(&coloured, 10) == 0.0);
    }
}
