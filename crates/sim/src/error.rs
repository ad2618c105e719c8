//! The errors of the simulator: a trim that does not exist, a flight that
//! departed, a wind that cannot be generated, a parameter that cannot be
//! tied, changed or defined, a foreign simulator's failure. File and data
//! errors are `aeroid_core`'s, wrapped whole so that their messages read
//! the same.

use aeroid_core::error::FieldError;
use aeroid_core::limits;

fn joined(problems: &[FieldError]) -> String {
    problems
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("; ")
}

/// Every error of the simulator: each variant says what went wrong and names the file, field or value.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or data error (`aeroid_core`).
    #[error(transparent)]
    Core(#[from] aeroid_core::Error),

    /// No trim at the flight condition; the reason says which condition.
    #[error("no trim: {0}")]
    Trim(String),

    /// The flight left its limits; whoever flew it keeps the trace up to
    /// the departure (`aeroid_sim::Flight`).
    #[error("simulation departed at t = {time:.3} s: {reason}")]
    Departed { time: f64, reason: String },

    /// A truth that cannot be written as TOML.
    #[error("{reason}")]
    Serialize { reason: String },

    /// The problems of a wind table, said on one line.
    #[error("{}", joined(problems))]
    WindProblems { problems: Vec<FieldError> },

    /// A wind generated on a step that is not a positive number.
    #[error("wind: step {step} s is not a positive number")]
    WindStep { step: f64 },

    /// A name of the wind table that is not one of its kind's (a gust
    /// direction, a turbulence intensity).
    #[error("unknown {kind} '{name}'")]
    WindName { kind: &'static str, name: String },

    /// A turbulence scale or intensity given neither explicitly nor by a rule.
    #[error("wind.turbulence.{name} is missing")]
    TurbulenceMissing { name: &'static str },

    /// Flight conditions turbulence cannot be started in.
    #[error("wind.turbulence: {reason}")]
    TurbulenceConditions { reason: String },

    /// A parameter change outside the run (0 < time < duration).
    #[error(
        "{} s is outside the run: a change happens after 0 s and before the duration, {} s",
        limits::number(*time),
        limits::number(*duration)
    )]
    ChangeOutsideRun { time: f64, duration: f64 },

    /// A parameter change between integration steps.
    #[error(
        "{} s is not a multiple of the step {} s: a change happens at an integration step",
        limits::number(*time),
        limits::number(*step)
    )]
    ChangeOffStep { time: f64, step: f64 },

    /// A value that may not replace a parameter in flight.
    #[error("{reason}, got {value}")]
    Replacement { reason: &'static str, value: f64 },

    /// A tie between parameters that cannot be made.
    #[error("{reason}")]
    Tie { reason: String },

    /// A moment reference table that does not give one offset.
    #[error("{reason}")]
    MomentReference { reason: &'static str },

    /// A failure of a simulator other than aeroid's (JSBSim), as that
    /// simulator's own error.
    #[error(transparent)]
    Foreign(Box<dyn std::error::Error + Send + Sync>),

    /// A parameter name given twice.
    #[error("parameter '{name}' is defined twice")]
    DefinedTwice { name: String },
}

impl Error {
    /// The problems found in a file that does not validate.
    pub fn field_errors(&self) -> Option<&[FieldError]> {
        match self {
            Error::Core(error) => error.field_errors(),
            _ => None,
        }
    }

    /// The time and reason of a flight that departed, when this is one.
    pub fn departure(&self) -> Option<(f64, &str)> {
        match self {
            Error::Departed { time, reason } => Some((*time, reason)),
            _ => None,
        }
    }
}

/// A result whose error is this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
