//! Error types of the library. Every failure a user can cause (a bad file, an
//! unknown name, a trim that does not exist, a departing simulation) is an
//! [`Error`] that names the file, field, line or time; the library never panics
//! on user input and only the CLI prints and exits.

use std::fmt;
use std::path::PathBuf;

/// One problem found while validating a file: the dotted field path and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldError {
    pub field: String,
    pub message: String,
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

/// Collects every problem of a file so that a user sees all of them at once.
#[derive(Debug, Default, Clone)]
pub struct FieldErrors(pub Vec<FieldError>);

impl FieldErrors {
    pub fn push(&mut self, field: impl Into<String>, message: impl fmt::Display) {
        self.0.push(FieldError {
            field: field.into(),
            message: message.to_string(),
        });
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// `Ok(value)` when nothing was found, else an [`Error::Invalid`] naming the file.
    pub fn finish<T>(self, path: &std::path::Path, value: T) -> Result<T, Error> {
        if self.0.is_empty() {
            Ok(value)
        } else {
            Err(Error::Invalid {
                path: path.to_path_buf(),
                problems: self.0,
            })
        }
    }
}

fn list_problems(problems: &[FieldError]) -> String {
    problems
        .iter()
        .map(|p| format!("\n  - {p}"))
        .collect::<String>()
}

/// Every error the aeroid library returns; its message names the file and
/// field at fault where there is one, and says what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },

    /// A file or folder aeroid writes could not be written. The reason is
    /// part of the message, not a separate cause, so that it is said once.
    #[error("cannot write {path}: {reason}")]
    Write { path: PathBuf, reason: String },

    /// A file named inside another file (a record's `record.toml`, a
    /// scenario, a study) that would leave the folder of the file naming it.
    #[error("{path}: {field}: '{reference}' {reason}")]
    Escape {
        path: PathBuf,
        field: String,
        reference: String,
        reason: String,
    },

    #[error("{path}: malformed TOML: {message}")]
    Toml { path: PathBuf, message: String },

    #[error("{path}: {} problem(s):{}", problems.len(), list_problems(problems))]
    Invalid {
        path: PathBuf,
        problems: Vec<FieldError>,
    },

    #[error("unknown {kind} '{name}'; known: {}", known.join(", "))]
    Unknown {
        kind: &'static str,
        name: String,
        known: Vec<String>,
    },

    #[error("{path}: line {line}, column '{column}': {message}")]
    Csv {
        path: PathBuf,
        line: u64,
        column: String,
        message: String,
    },

    /// A unit that is not one of a dimension's (`dimension` as its label).
    #[error("unit '{unit}' is not a unit of {dimension}; accepted: {accepted}")]
    Unit {
        unit: String,
        dimension: &'static str,
        accepted: String,
    },

    /// A quantity's text that does not start with a number.
    #[error("'{text}' does not start with a number")]
    NotANumber { text: String },

    /// A value that is not a finite number (`value` as written).
    #[error("{value} is not a finite number")]
    NotFinite { value: String },

    /// A memory budget variable that does not hold a size.
    #[error(
        "{variable}='{text}' is not a memory size; give bytes or a number with kB, MB, GB, TB, KiB, MiB, GiB or TiB"
    )]
    MemoryBudget {
        variable: &'static str,
        text: String,
    },

    /// `count` items of `item_bytes` each that do not fit the memory budget.
    #[error(
        "{what} would need {} × {item_bytes} bytes = {}, more than the memory budget of {budget}",
        crate::limits::count_text(*count),
        crate::limits::bytes_text(*bytes)
    )]
    Memory {
        what: String,
        count: f64,
        item_bytes: usize,
        bytes: f64,
        budget: crate::limits::Budget,
    },

    /// A file reference, given in a file under `base`, that would leave
    /// that folder (an absolute path, a `..` component, or a symbolic link
    /// that leads out).
    #[error(
        "{kind} '{reference}' {reason}; name a file inside {} by a relative path, or a bundled name",
        base.display()
    )]
    Reference {
        kind: &'static str,
        reference: String,
        reason: String,
        base: PathBuf,
    },
}

impl Error {
    /// The problems found in a file that does not validate.
    pub fn field_errors(&self) -> Option<&[FieldError]> {
        match self {
            Error::Invalid { problems, .. } => Some(problems),
            _ => None,
        }
    }

    /// The error of a write: a failure of the file system reported as a
    /// read ([`Error::Io`]) becomes a [`Error::Write`].
    pub fn as_write(self) -> Error {
        match self {
            Error::Io { path, source } => Error::Write {
                path,
                reason: source.to_string(),
            },
            other => other,
        }
    }
}

/// A result whose error is an aeroid [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Reads a text file, naming it in the error.
pub fn read_text(path: &std::path::Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// A write error naming the path, with the reason said once.
pub fn write_error(path: &std::path::Path, error: impl fmt::Display) -> Error {
    Error::Write {
        path: path.to_path_buf(),
        reason: error.to_string(),
    }
}

/// Parses TOML into `T`, reporting the file, line and column of a syntax or type error.
pub fn parse_toml<T: serde::de::DeserializeOwned>(path: &std::path::Path, text: &str) -> Result<T> {
    toml::from_str(text).map_err(|e| Error::Toml {
        path: path.to_path_buf(),
        message: describe_toml_error(text, &e),
    })
}

fn describe_toml_error(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim().to_string();
    match error.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("line {line}, column {column}: {message}")
        }
        None => message,
    }
}
