//! One file per subcommand: each holds the subcommand's arguments (`Args`)
//! and its `run`. Output goes through [`out!`] and [`outln!`], which return
//! a write error instead of panicking, so that a closed pipe
//! (`aeroid estimate … | head -1`) ends the program quietly in `main`.

/// `print!` that returns the write error from the enclosing function.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout(), $($arg)*)?;
    }};
}

/// `println!` that returns the write error from the enclosing function.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($arg)*)?;
    }};
}

pub mod check;
#[cfg(feature = "jsbsim")]
pub mod crosscheck;
pub mod derive;
pub mod estimate;
pub mod export;
#[cfg(feature = "jsbsim")]
pub mod export_jsbsim;
#[cfg(not(feature = "jsbsim"))]
pub mod without_jsbsim;
#[cfg(not(feature = "jsbsim"))]
pub use without_jsbsim::{crosscheck, export_jsbsim};
pub mod gate;
pub mod identifiability;
pub mod import;
pub mod inspect;
pub mod linearise;
pub mod list;
pub mod methods;
pub mod plugin;
pub mod reconstruct;
pub mod record;
pub mod report;
pub mod run;
pub mod simulate;
pub mod study;

/// The error and its causes, each said once: a cause whose text the
/// message already holds is not repeated.
pub fn message(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}

/// Whether an error is a write to a closed pipe (the reader went away).
pub fn is_closed_pipe(error: &anyhow::Error) -> bool {
    error.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
