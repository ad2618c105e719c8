//! `aeroid inspect`: describe a record's channels.

use anyhow::Result;
use std::path::PathBuf;

/// Print a record's channels with rates, units, ranges, dropouts and gaps.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder.
    record: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    out!(
        "{}",
        aeroid::record::FlightRecord::read(&args.record)?.describe()
    );
    Ok(())
}
