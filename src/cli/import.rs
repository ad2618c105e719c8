//! `aeroid import`: a CSV of real flight data and a column map become a record.

use anyhow::Result;
use std::path::PathBuf;

/// Bring real flight data in: a CSV and a column map (TOML) become a record folder.
#[derive(clap::Args)]
pub struct Args {
    /// The CSV file with a time column.
    data: PathBuf,
    /// The column map: time column, and per channel its column, unit, scale and offset.
    #[arg(long)]
    map: PathBuf,
    /// The record folder to write.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let Args { data, map, out } = args;
    aeroid::paths::check_output_folder(&out)?;
    let outcome = aeroid::record::import::import(&data, &map)?;
    outcome.record.write(&out)?;
    outln!(
        "{}: {} channels imported into {}",
        data.display(),
        outcome.record.channels.len(),
        out.display()
    );
    if !outcome.unmapped.is_empty() {
        outln!(
            "columns not in the map (not imported): {}",
            outcome.unmapped.join(", ")
        );
    }
    Ok(())
}
