//! The errors of estimation: a method that refuses a record or model (a
//! [`Refusal`], as data), settings a method does not take, a record that
//! lacks what a model needs, sizes or grids that do not agree, a numerical
//! failure of a filter or fit, a network that cannot be trained, a plug-in
//! that fails, an estimation problem file that does not read. The errors
//! of the crates below are wrapped whole, so that their messages read the
//! same.

use aeroid_core::refusal::Refusal;

/// Every error of the estimation: each variant says what went wrong and names the file, field or value.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or data error (`aeroid_core`).
    #[error(transparent)]
    Core(#[from] aeroid_core::Error),

    /// An error of the numerical kernels (`aeroid_numerics`).
    #[error(transparent)]
    Numerics(#[from] aeroid_numerics::Error),

    /// An error of the simulator's own (`aeroid_sim`).
    #[error(transparent)]
    Sim(#[from] aeroid_sim::error::Error),

    /// An error of recording or preparing data (`aeroid_record`).
    #[error(transparent)]
    Record(#[from] aeroid_record::error::Error),

    /// An estimator cannot run on this record or model; the refusal says
    /// what is missing, as data.
    #[error("{0}")]
    Refused(Refusal),

    /// A method's settings that it does not take (`[methods.NAME]: …`).
    #[error("[methods.{method}]: {reason}")]
    Settings { method: String, reason: String },

    /// One setting of a method that it does not take (`[methods.NAME] key…`).
    #[error("[methods.{method}] {reason}")]
    Setting { method: String, reason: String },

    /// Sizes that do not agree: parameters, states, outputs, matrices.
    #[error("{reason}")]
    Shape { reason: String },

    /// A time grid too short, or a time outside it.
    #[error("{reason}")]
    Grid { reason: String },

    /// A record that lacks a channel or samples a model or method needs.
    #[error("{reason}")]
    Data { reason: String },

    /// A numerical failure: a covariance not positive definite, a singular
    /// matrix, a state gone non-finite, a model that departed.
    #[error("{reason}")]
    Numerical { reason: String },

    /// The model being fitted departed while simulated at an estimate
    /// (non-finite, |α| or |β| beyond 90°, airspeed not positive).
    #[error("the postulated model departed at t = {time:.3} s")]
    ModelDeparted { time: f64 },

    /// Equation error could not give a start for a fit.
    #[error("no equation-error start ({0})")]
    NoStart(Box<Error>),

    /// Equation error's estimate, as a start for a fit, did not converge.
    #[error("equation error ended {0}")]
    StartNotConverged(aeroid_numerics::Status),

    /// A piece of a multiple-shooting fit whose simulation departed.
    #[error("the simulation of piece {piece} departed at t = {time:.3} s")]
    PieceDeparted { piece: usize, time: f64 },

    /// A stall model's τ1 that crossed 0 during a fit (χ is a state only
    /// while τ1 > 0, so the model's state vector would change).
    #[error("τ1 must stay on the side of 0 it starts on (χ is a state only while τ1 > 0)")]
    Tau1Sign,

    /// A model whose fastest mode is beyond what the fit's RK4 steps
    /// integrate (h·|λ| above `reach`); `finest`: the finest sub-division
    /// a fit takes, when the steps are already at it.
    #[error(
        "the model's fastest mode (|λ| = {}/s) is beyond RK4 steps of {step:.5} s (h·|λ| = {} > {reach}){}",
        readable(*fastest, 1),
        readable(step * fastest, 2),
        finest.map(|n| format!(", the finest a fit takes ({n} per grid interval)")).unwrap_or_default()
    )]
    BeyondStepReach {
        fastest: f64,
        step: f64,
        reach: f64,
        finest: Option<usize>,
    },

    /// The flight path that flight-path reconstruction integrates went
    /// non-finite or to a non-positive airspeed.
    #[error("the reconstructed flight path diverged at t = {time:.2} s")]
    PathDiverged { time: f64 },

    /// Values of the model that are not finite at the estimate being
    /// evaluated (`what`: "the model's coefficients").
    #[error("{what} are not finite at this Θ")]
    NotFinite { what: &'static str },

    /// A neural network that cannot be built or trained.
    #[error("{reason}")]
    Network { reason: String },

    /// A plug-in estimator that cannot be run or fails.
    #[error("{reason}")]
    Plugin { reason: String },

    /// A method asked for by name whose plug-in file did not load.
    #[error("method '{name}' is not available: its plug-in file did not load: {reason}")]
    PluginNotLoaded { name: String, reason: String },

    /// An estimation problem or estimate file that cannot be read or written.
    #[error("{reason}")]
    File { reason: String },

    /// A method that cannot be set up on this problem: a start, a plan, a
    /// registration.
    #[error("{reason}")]
    Method { reason: String },
}

impl Error {
    /// The refusal of an estimator, when this is one.
    pub fn refusal(&self) -> Option<&Refusal> {
        match self {
            Error::Refused(refusal) => Some(refusal),
            _ => None,
        }
    }

    /// The problems found in a file that does not validate.
    pub fn field_errors(&self) -> Option<&[aeroid_core::error::FieldError]> {
        match self {
            Error::Core(error) => error.field_errors(),
            Error::Record(error) => error.field_errors(),
            Error::Sim(error) => error.field_errors(),
            _ => None,
        }
    }

    /// The time and reason of a simulation that departed, when this is one.
    pub fn departure(&self) -> Option<(f64, &str)> {
        match self {
            Error::Sim(error) => error.departure(),
            Error::ModelDeparted { time } => Some((*time, "the postulated model departed")),
            _ => None,
        }
    }
}

/// `value` with `decimals` decimals, or in exponent form beyond a million
/// (a mode of 1e30/s reads as one).
fn readable(value: f64, decimals: usize) -> String {
    if value.abs() < 1e6 {
        format!("{value:.decimals$}")
    } else {
        format!("{value:.3e}")
    }
}

/// A result whose error is this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
