//! The settings every iterative method takes alike, checked by one routine.

use crate::error::{Error, Result};

/// Checks an iterative method's `step` (positive when set) and
/// `max_iterations` (at least 1); `method` names its settings table.
pub(crate) fn check_iterations(
    method: &str,
    step: Option<f64>,
    max_iterations: usize,
) -> Result<()> {
    if step.is_some_and(|step| !(step > 0.0 && step.is_finite())) {
        return Err(Error::Settings {
            method: method.to_string(),
            reason: "step must be positive".to_string(),
        });
    }
    if max_iterations == 0 {
        return Err(Error::Settings {
            method: method.to_string(),
            reason: "max_iterations must be at least 1".to_string(),
        });
    }
    Ok(())
}
