//! `aeroid check`: validate one file and explain every problem.

use aeroid::estimation::registry::Registry;
use anyhow::Result;
use std::path::PathBuf;

/// Validate a data file and explain every problem.
///
/// Validate an aircraft, scenario, recorder-profile, model-structure or study
/// file and explain every problem; a scenario is also trimmed.
#[derive(clap::Args)]
pub struct Args {
    /// The file to check.
    file: PathBuf,
}

pub fn run(args: Args, registry: &Registry) -> Result<()> {
    let report = aeroid::check::check_file(registry, &args.file)?;
    outln!("{}: valid {}", args.file.display(), report.kind);
    for line in report.lines {
        outln!("  {line}");
    }
    Ok(())
}
