//! `aeroid report`: the HTML report of a study's output folder.

use anyhow::Result;
use std::path::PathBuf;

/// Write a study's HTML report.
///
/// Write one self-contained HTML page for a study's output folder (the
/// --out of `aeroid study` or `aeroid study merge`): the summary and how
/// the fits ended as tables, SVG plots (each derivative's error against
/// the sweep with its Cramér–Rao band, per method; every estimate by
/// case), the study file, aeroid's version, the seed and the fingerprint.
/// It opens in a browser with no server.
#[derive(clap::Args)]
pub struct Args {
    /// The study's output folder (holds study.json and runs.csv).
    folder: PathBuf,
    /// The page to write; default FOLDER/report.html.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    if let Some(out) = &args.out {
        aeroid::paths::check_output_file(out)?;
        aeroid::paths::check_not_input(out, &[&args.folder], &[".html"])?;
    }
    let path = aeroid::eval::report::write_report(&args.folder, args.out.as_deref())?;
    outln!("written: {}", path.display());
    Ok(())
}
