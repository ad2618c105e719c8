//! How an estimation ended: the one status every optimiser and filter
//! reports, judged in one place by each method and scored as a success only
//! when converged.

use serde::{Deserialize, Serialize};

/// How an estimation ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "status", content = "reason")]
pub enum Status {
    /// Stopped at an optimum, every parameter determined.
    Converged,
    /// The iteration limit came first.
    IterationLimit,
    /// The model could not be evaluated (a departing simulation, a NaN).
    Diverged(String),
    /// No step lowers the cost while the Gauss–Newton step still predicts
    /// a decrease beyond the convergence tolerance (from the start, or after
    /// some iterations: the fit stalled short of a minimum).
    NoProgress,
    /// These parameters have a non-finite standard error: the data do not
    /// determine them.
    Unidentified(Vec<String>),
    /// The covariance is missing or not finite though every standard error is.
    Degenerate(String),
    /// A recursive estimator's parameter estimates had not settled by the
    /// end of the record: the reason.
    Unsettled(String),
}

impl Status {
    /// Only a converged estimate counts as a success in scores, gates and studies.
    pub fn is_success(&self) -> bool {
        matches!(self, Status::Converged)
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Status::Converged => f.write_str("converged"),
            Status::IterationLimit => f.write_str("iteration limit"),
            Status::Diverged(reason) => write!(f, "diverged: {reason}"),
            Status::NoProgress => {
                f.write_str("no progress: no step lowers the cost short of the minimum")
            }
            Status::Unidentified(names) => write!(f, "unidentified: {}", names.join(", ")),
            Status::Degenerate(reason) => write!(f, "degenerate: {reason}"),
            Status::Unsettled(reason) => write!(f, "not settled: {reason}"),
        }
    }
}
