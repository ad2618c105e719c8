//! `aeroid export`: a record folder as one MATLAB or CSV file.

use aeroid::record::FlightRecord;
use aeroid::record::export::{ExportFormat, export};
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

/// Write a record as one MATLAB (.mat) or CSV file.
///
/// Write a record as one file for MATLAB, Octave, SIDPAC or FVSysID: a
/// level-5 MAT-file with a matrix `data` (time, then a column per channel
/// in SI) and character matrices `names` and `units`, or one CSV. The
/// layout of both is in docs/import.md. The record is only read; the
/// output is the one file named, outside the record folder.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder to export.
    record: PathBuf,
    /// The format; by default the output's extension (.mat or .csv).
    #[arg(long, value_enum)]
    format: Option<Format>,
    /// The file to write.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    Mat,
    Csv,
}

pub fn run(args: Args) -> Result<()> {
    let Args {
        record,
        format,
        out,
    } = args;
    let format = match (format, ExportFormat::from_extension(&out)) {
        (Some(Format::Mat), _) => ExportFormat::Mat,
        (Some(Format::Csv), _) => ExportFormat::Csv,
        (None, Some(format)) => format,
        (None, None) => bail!(
            "{}: say the format with --format mat or --format csv (the name does not end in .mat or .csv)",
            out.display()
        ),
    };
    refuse_inside(&record, &out)?;
    aeroid::paths::check_output_file(&out)?;
    let loaded = FlightRecord::read(&record)?;
    let holds = export(&loaded, format, &out)?;
    outln!(
        "{}: {} channels exported to {} ({})",
        record.display(),
        loaded.channels.len(),
        out.display(),
        holds.join("; ")
    );
    Ok(())
}

/// The output may not be inside the record folder: it would overwrite or
/// add to the record it reads.
fn refuse_inside(record: &Path, out: &Path) -> Result<()> {
    let Ok(folder) = record.canonicalize() else {
        // A missing record is said by the read, with its path.
        return Ok(());
    };
    let parent = match out.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let target = match (out.canonicalize(), parent.canonicalize(), out.file_name()) {
        (Ok(existing), _, _) => existing,
        (Err(_), Ok(parent), Some(name)) => parent.join(name),
        _ => return Ok(()),
    };
    if target.starts_with(&folder) {
        bail!(
            "{}: inside the record folder {}, which export only reads; name a file outside it",
            out.display(),
            record.display()
        );
    }
    Ok(())
}
