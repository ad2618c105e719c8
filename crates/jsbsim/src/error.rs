//! The errors of driving JSBSim: a call that failed (a C++ exception or a
//! failure status, turned into an error at the FFI boundary) and an
//! aircraft JSBSim does not have. The errors of aeroid's files and
//! simulator are wrapped whole, so that their messages read the same.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or data error (`aeroid_core`).
    #[error(transparent)]
    Core(#[from] aeroid_core::Error),

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
    /// The error as an `aeroid_core` error, for the simulator layer that
    /// flies JSBSim's aircraft through [`aeroid_sim::source::ForeignSimulator`].
    pub(crate) fn into_core(self) -> aeroid_core::Error {
        match self {
            Error::Core(error) => error,
            Error::Jsbsim { context, message } => aeroid_core::Error::Jsbsim { context, message },
            other => aeroid_core::Error::Jsbsim {
                context: "aircraft".into(),
                message: other.to_string(),
            },
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
