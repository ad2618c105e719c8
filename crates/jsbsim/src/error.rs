//! The errors of driving JSBSim: a call that failed (a C++ exception or a
//! failure status, turned into an error at the FFI boundary) and an
//! aircraft JSBSim does not have. The errors of aeroid's files and
//! simulator are wrapped whole, so that their messages read the same.

use std::path::PathBuf;

/// Every error of the JSBSim bridge: each variant says what went wrong and names the file, field or value.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or data error (`aeroid_core`).
    #[error(transparent)]
    Core(#[from] aeroid_core::Error),

    /// An error of the simulator (`aeroid_sim`).
    #[error(transparent)]
    Sim(#[from] aeroid_sim::Error),

    /// A JSBSim call failed. `context` names the aircraft, property or
    /// operation; `message` is JSBSim's own.
    #[error("JSBSim: {context}: {message}")]
    Jsbsim { context: String, message: String },

    /// An aircraft JSBSim's root does not have: the file looked for and
    /// the aircraft there are.
    #[error(
        "JSBSim has no aircraft '{model}' (no file {}); its aircraft: {}",
        file.display(),
        known.join(", ")
    )]
    NoAircraft {
        model: String,
        file: PathBuf,
        known: Vec<String>,
    },
}

impl Error {
    /// The error as the simulator layer's, which flies JSBSim's aircraft
    /// through [`aeroid_sim::source::ForeignSimulator`]: its own errors as
    /// they are, JSBSim's as a foreign simulator's.
    pub(crate) fn into_sim(self) -> aeroid_sim::Error {
        match self {
            Error::Sim(error) => error,
            Error::Core(error) => error.into(),
            other => aeroid_sim::Error::Foreign(Box::new(other)),
        }
    }
}

/// A result whose error is this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
