//! The errors of the evaluation: a study's journal that cannot be used or
//! merged, a study file or report that cannot be read or drawn, a method
//! that failed in a gate. The crates below it keep their own errors,
//! wrapped here whole so that their messages read the same.

use aeroid_core::refusal::Refusal;
use std::path::PathBuf;

/// Every error of the evaluation (scores, gates, studies, reports): each variant says what went wrong and names the file, field or value.
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

    /// A `--shard` that is not K/N with 1 ≤ K ≤ N.
    #[error("--shard '{text}': expected K/N with 1 ≤ K ≤ N, e.g. 2/8")]
    Shard { text: String },

    /// A journal already in the folder a new study would write.
    #[error(
        "{} holds a study already: resume it with --resume, or write to another folder",
        path.display()
    )]
    JournalExists { path: PathBuf },

    /// A journal another aeroid process is writing (a second `--resume`
    /// on the same folder while the first runs).
    #[error(
        "{}: another aeroid study is writing this journal; wait for it to end, or give this run another folder",
        path.display()
    )]
    JournalBusy { path: PathBuf },

    /// A journal that is of another study or shard, incomplete, or whose
    /// writer failed.
    #[error("{}: {reason}", path.display())]
    Journal { path: PathBuf, reason: String },

    /// A malformed line of a journal (1-based `line`).
    #[error("{}:{line}: {reason}", path.display())]
    JournalLine {
        path: PathBuf,
        line: usize,
        reason: String,
    },

    /// Shards that do not make up one study: none given, one given twice,
    /// cases missing.
    #[error("{reason}")]
    Merge { reason: String },

    /// A JSON file of a study's output (`study.json`, a history) that
    /// cannot be read or written.
    #[error("{}: {reason}", path.display())]
    Json { path: PathBuf, reason: String },

    /// A CSV file of a study's output that cannot be read, at `line` when known.
    #[error("{}{}: {reason}", path.display(), line.map_or(String::new(), |l| format!(":{l}")))]
    Table {
        path: PathBuf,
        line: Option<u64>,
        reason: String,
    },

    /// A plot of a report that cannot be drawn.
    #[error("drawing a plot: {reason}")]
    Plot { reason: String },

    /// A model structure whose files cannot be fingerprinted.
    #[error("model '{name}': {reason}")]
    Model { name: String, reason: String },

    /// A method that failed (not refused) in a gate.
    #[error("{method}: {reason}")]
    Failed { method: String, reason: String },

    /// A worker thread of a study panicked.
    #[error("a study thread panicked")]
    Panicked,
}

impl Error {
    /// The refusal of an estimator, wherever it was wrapped.
    pub fn refusal(&self) -> Option<&Refusal> {
        match self {
            Error::Estimation(error) => error.refusal(),
            _ => None,
        }
    }

    /// The problems found in a file that does not validate, wherever the
    /// error was wrapped.
    pub fn field_errors(&self) -> Option<&[aeroid_core::error::FieldError]> {
        match self {
            Error::Core(error) => error.field_errors(),
            Error::Estimation(error) => error.field_errors(),
            Error::Record(error) => error.field_errors(),
            Error::Sim(error) => error.field_errors(),
            _ => None,
        }
    }
}

/// A result whose error is this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
