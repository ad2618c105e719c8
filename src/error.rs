//! The errors of the library side of the root package, which calls into
//! every crate: each crate's error wrapped whole, so that its message reads
//! the same, with accessors for what callers look for inside (a refusal,
//! the problems of a file). The helpers for reading and writing files
//! are core's.

pub use aeroid_core::atomic::write_text;
pub use aeroid_core::error::{FieldError, FieldErrors, parse_toml, read_text, write_error};
use aeroid_core::refusal::Refusal;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or data error (`aeroid_core`).
    #[error(transparent)]
    Core(#[from] aeroid_core::Error),

    /// An error of the numerical kernels (`aeroid_numerics`).
    #[error(transparent)]
    Numerics(#[from] aeroid_numerics::Error),

    /// An error of the simulator (`aeroid_sim`).
    #[error(transparent)]
    Sim(#[from] aeroid_sim::Error),

    /// An error of estimation (`aeroid_estimation`).
    #[error(transparent)]
    Estimation(#[from] aeroid_estimation::Error),

    /// An error of recording or preparing data (`aeroid_record`).
    #[error(transparent)]
    Record(#[from] aeroid_record::error::Error),

    /// An error of the evaluation (`aeroid_eval`).
    #[error(transparent)]
    Eval(#[from] aeroid_eval::Error),

    /// An error of the analysis (`aeroid_analysis`).
    #[error(transparent)]
    Analysis(#[from] aeroid_analysis::Error),

    /// An error of driving JSBSim (`aeroid_jsbsim`).
    #[cfg(feature = "jsbsim")]
    #[error(transparent)]
    Jsbsim(#[from] aeroid_jsbsim::Error),
}

impl Error {
    /// The refusal of an estimator, wherever it was wrapped.
    pub fn refusal(&self) -> Option<&Refusal> {
        match self {
            Error::Estimation(error) => error.refusal(),
            Error::Eval(error) => error.refusal(),
            _ => None,
        }
    }

    /// The problems found in a file that does not validate, wherever the
    /// error was wrapped.
    pub fn field_errors(&self) -> Option<&[FieldError]> {
        match self {
            Error::Core(error) => error.field_errors(),
            Error::Estimation(error) => error.field_errors(),
            Error::Record(error) => error.field_errors(),
            Error::Sim(error) => error.field_errors(),
            Error::Eval(error) => error.field_errors(),
            #[cfg(feature = "jsbsim")]
            Error::Jsbsim(aeroid_jsbsim::Error::Core(error)) => error.field_errors(),
            _ => None,
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
