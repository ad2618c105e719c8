//! The errors of the analysis: an ERA fit that cannot be made, an
//! identifiability analysis that cannot be run, a linear model that cannot
//! be written. The crates below it keep their own errors, wrapped here
//! whole so that their messages read the same.

use std::path::PathBuf;

/// Every error of the analysis: each variant says what went wrong and names the file, field or value.
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

    /// Samples or an order that ERA cannot fit.
    #[error("ERA needs {need}")]
    EraInput { need: &'static str },

    /// Too few samples for ERA of this order and block rows.
    #[error(
        "ERA of order {order} with {rows} block rows of {channels} outputs needs more than {samples} samples"
    )]
    EraSamples {
        order: usize,
        rows: usize,
        channels: usize,
        samples: usize,
    },

    /// A failure of ERA's decomposition of the Hankel matrix.
    #[error("ERA: {reason}")]
    Era { reason: String },

    /// A segment length shorter than the scenario's integration step.
    #[error(
        "segment length {length} s: a segment must be at least one integration step ({step} s of {}) long",
        scenario.display()
    )]
    Segment {
        length: f64,
        step: f64,
        scenario: PathBuf,
    },

    /// A scenario whose parameters change during the flight.
    #[error(
        "identifiability of '{scenario}' ({}): its parameters change during the flight ([[parameter_changes]]); the analysis is of constant parameters",
        path.display()
    )]
    ChangingParameters { scenario: String, path: PathBuf },

    /// A sensitivity that cannot be had: a parameter that cannot be moved,
    /// a perturbed flight that failed.
    #[error("identifiability of '{scenario}': {reason}")]
    Identifiability { scenario: String, reason: String },

    /// A recorder profile with no channel to analyse.
    #[error("profile '{profile}': no channel with a finite error model to analyse")]
    NoChannels { profile: String },

    /// A file that cannot be written in its format (`what` as TOML).
    #[error("{what} as TOML: {reason}")]
    Format { what: &'static str, reason: String },
}

/// A result whose error is this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
