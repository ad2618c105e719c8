//! The errors of the numerical kernels: a matrix that must be positive
//! definite or invertible and is not, a Riccati equation without a
//! solution, a square-root filter's downdate that would lose positive
//! definiteness, a smoother or a Fourier transform given data it cannot
//! use.

/// Every error of the numerical kernels: each variant says what went wrong and names the file, field or value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A matrix that must be positive definite and is not; `why` says
    /// what usually causes it, when known (in parentheses after a space).
    #[error("{what} is not positive definite{why}")]
    NotPositiveDefinite { what: String, why: &'static str },

    /// A variance that must be positive and is not.
    #[error("{what} is not positive{why}")]
    NotPositive { what: String, why: &'static str },

    /// A matrix that must be invertible and is not.
    #[error("{reason}")]
    Singular { reason: String },

    /// A steady-state Riccati equation or filter that has no solution.
    #[error("{reason}")]
    NoSolution { reason: String },

    /// A square-root filter's Cholesky downdate that would leave its
    /// covariance factor without a positive diagonal: the covariance it
    /// stands for would no longer be positive definite. `step` names the
    /// filter step.
    #[error(
        "at t = {time} s: the {step} would leave the covariance not positive definite (a Cholesky downdate)"
    )]
    Downdate { time: f64, step: &'static str },

    /// Data a kernel cannot use: too few samples or lags, sizes that do
    /// not agree, a step or frequency that is not valid.
    #[error("{reason}")]
    Input { reason: String },

    /// Residuals that are not all finite at the estimate being evaluated.
    #[error("the residuals are not finite")]
    NonFiniteResiduals,

    /// Sensitivities that are not finite, named by their unknowns (a model
    /// evaluated where it has no derivative).
    #[error("the sensitivities to {} are not finite", unknowns.join(", "))]
    NonFiniteSensitivities { unknowns: Vec<String> },

    /// A least-squares solve inside a kernel that failed.
    #[error("{what}: {reason}")]
    LeastSquares { what: &'static str, reason: String },
}

/// A result whose error is this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
