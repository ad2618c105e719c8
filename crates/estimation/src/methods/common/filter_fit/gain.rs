//! The filter in the loop (`gain`), the form of the steady gain's R
//! (`innovation_covariance`) and P0 (`initial_variance`), with their checks.

use super::*;

/// The steady gain's innovation covariance R (`innovation_covariance`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InnovationForm {
    /// One variance per output.
    Diagonal,
    /// R = (1/N)·Σ ν·νᵀ whole, where every grid point with a measurement
    /// measures every output (else diagonal, with a note).
    Full,
}

/// The filter in the filter error method's loop (docs/methods.md, Filter error).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Gain {
    /// The steady-state gain of the model linearised at the first grid
    /// point, the innovation covariance R estimated by relaxation.
    #[default]
    Steady,
    /// The extended Kalman filter, its covariance propagated with the model
    /// linearised at each point, the measurement noise G·Gᵀ estimated by
    /// relaxation.
    TimeVarying,
}

/// Checks an `initial_variance` table: finite variances not below zero,
/// and only with the time-varying gain (the steady-state filter has no
/// initial covariance).
pub(crate) fn check_initial_variance(
    method: &str,
    gain: Gain,
    initial_variance: &BTreeMap<String, f64>,
) -> Result<()> {
    if gain == Gain::Steady && !initial_variance.is_empty() {
        return Err(Error::Setting { method: method.to_string(), reason: "initial_variance needs gain = \"time_varying\": the steady-state filter has no initial covariance".to_string() });
    }
    match initial_variance
        .iter()
        .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
    {
        Some((name, v)) => Err(Error::Setting {
            method: method.to_string(),
            reason: format!(
                "initial_variance.{name} = {v}: a variance must be finite and not below zero"
            ),
        }),
        None => Ok(()),
    }
}

/// P0 = diag of `initial_variance` over the states `names`; an error
/// naming a key that is not a state.
pub(crate) fn initial_covariance(
    method: &str,
    names: &[&str],
    initial_variance: &BTreeMap<String, f64>,
) -> Result<DMatrix<f64>> {
    let mut covariance = DMatrix::zeros(names.len(), names.len());
    for (name, &variance) in initial_variance {
        let i = names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| Error::Setting {
                method: method.to_string(),
                reason: format!(
                    "initial_variance: '{name}' is not an integrated state of the model ({})",
                    names.join(", ")
                ),
            })?;
        covariance[(i, i)] = variance;
    }
    Ok(covariance)
}
