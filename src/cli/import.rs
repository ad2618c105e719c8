//! `aeroid import`: a data file of real flight data and a column map become a record.

use anyhow::Result;
use std::path::PathBuf;

/// Bring real flight data in as a record folder.
///
/// Bring real flight data in: a data file and a column map (TOML) become a record folder.
///
/// The data file is a CSV with a header row, headerless ASCII
/// (whitespace- or comma-separated) whose columns the map names by number,
/// or a MATLAB level-5 MAT-file (a matrix's columns by number, vector
/// variables by name; v7.3 files are refused); comment lines (`#`, `%`),
/// CRLF line ends and a UTF-8 byte-order mark are accepted. The map names each channel's column (or columns, summed,
/// averaged or half-differenced), unit, scale, offset and, for altitude, its
/// convention. The map format, every channel name with its unit and
/// meaning, and every accepted unit are in docs/import.md.
#[derive(clap::Args)]
pub struct Args {
    /// The data file: headed CSV, headerless ASCII or a level-5 MAT-file
    /// (see docs/import.md).
    data: PathBuf,
    /// The column map: time column, and per channel its column(s), unit,
    /// scale and offset (format in docs/import.md).
    #[arg(long)]
    map: PathBuf,
    /// The record folder to write.
    #[arg(long)]
    out: PathBuf,
    /// Let estimators interpolate across the record's gaps (stretches
    /// without any sample, longer than ten sample periods) instead of
    /// fitting the pieces between them as separate manoeuvres.
    #[arg(long)]
    bridge_gaps: bool,
}

pub fn run(args: Args) -> Result<()> {
    let Args {
        data,
        map,
        out,
        bridge_gaps,
    } = args;
    aeroid::paths::check_output_folder(&out)?;
    let mut outcome =
        aeroid::record::import::import(&data, &map, aeroid::estimation::CHANNELS_READ)?;
    outcome.record.bridge_gaps = bridge_gaps;
    outcome.record.write(&out)?;
    let gaps = outcome.record.time_gaps();
    if !gaps.is_empty() {
        outln!(
            "{} gap(s) without any sample: estimators {}",
            gaps.len(),
            if bridge_gaps {
                "interpolate across them (--bridge-gaps)"
            } else {
                "fit the pieces between them as separate manoeuvres (--bridge-gaps to interpolate)"
            }
        );
    }
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
    for note in &outcome.notes {
        outln!("note: {note}");
    }
    for warning in &outcome.warnings {
        eprintln!("warning: {warning}");
    }
    Ok(())
}
