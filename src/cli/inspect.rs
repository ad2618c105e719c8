//! `aeroid inspect`: describe a record's channels.

use anyhow::Result;
use std::path::PathBuf;

/// Print a record's channels, or its data-quality report.
///
/// Print a record's channels with rates, units, ranges, dropouts and gaps;
/// with --quality, the data-quality report instead.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder.
    record: PathBuf,
    /// Check every channel for stuck values, quantization, dropouts and
    /// implausible steps (see docs/cli.md).
    #[arg(long)]
    quality: bool,
}

pub fn run(args: Args) -> Result<()> {
    let record = aeroid::record::FlightRecord::read(&args.record)?;
    match args.quality {
        true => out!("{}", aeroid::record::quality::assess(&record).table()),
        false => out!("{}", record.describe()),
    }
    Ok(())
}
