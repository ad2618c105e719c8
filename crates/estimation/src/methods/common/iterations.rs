//! The settings every iterative method takes alike, checked by one routine.

use crate::error::{Error, Result};

/// The shortest integration `step` a method takes, in seconds: 100 kHz,
/// faster than any flight recorder samples; a 60 s record then has six
/// million grid points. A step of 1e-9 s would ask for more memory than
/// any machine has.
pub(crate) const MIN_STEP: f64 = 1e-5;

/// Whether an integration `step` is within what a method takes: a finite
/// number of at least [`MIN_STEP`] seconds.
pub(crate) fn step_in_range(step: f64) -> bool {
    (MIN_STEP..f64::INFINITY).contains(&step)
}

/// Checks an iterative method's `step` (at least [`MIN_STEP`] when set)
/// and `max_iterations` (at least 1); `method` names its settings table.
pub(crate) fn check_iterations(
    method: &str,
    step: Option<f64>,
    max_iterations: usize,
) -> Result<()> {
    if let Some(step) = step.filter(|&step| !step_in_range(step)) {
        return Err(Error::Settings {
            method: method.to_string(),
            reason: format!("step must be at least {MIN_STEP} s, is {step} s"),
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
