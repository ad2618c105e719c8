//! `aeroid study`: a Monte Carlo study.

use anyhow::{Context, Result};
use std::path::PathBuf;

/// Run a Monte Carlo study (studies/*.toml): many seeded runs of
/// simulate, record, estimate and score over the study's sweep points;
/// print per point, model, method and parameter the bias, the spread
/// against the Cramér–Rao bound and the 95 % coverage. The numbers
/// depend only on the study seed, whatever the thread count.
#[derive(clap::Args)]
pub struct Args {
    /// A bundled study name (studies/) or a path to a study file.
    study: String,
    /// Runs per sweep point, instead of the file's `runs` (the first runs
    /// are the same either way).
    #[arg(long)]
    runs: Option<usize>,
    /// Worker threads; default one per core.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// A folder for runs.csv (every run's rows), summary.csv and study.json.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let Args {
        study: reference,
        runs,
        threads,
        out,
    } = args;
    if let Some(out) = &out {
        aeroid::paths::check_output_folder(out)?;
    }
    let mut study = aeroid::eval::study::Study::load(&reference)?;
    if let Some(runs) = runs {
        study.set_runs(runs, "--runs")?;
    }
    let cases = study.cases().len();
    outln!(
        "study {}: {} sweep point(s) × {} runs = {} cases; models {}; methods {}; seed {}",
        study.name,
        study.points.len(),
        study.runs,
        cases,
        study
            .models
            .iter()
            .map(|m| m.name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        study.methods.join(", "),
        study.seed
    );
    let bar = indicatif::ProgressBar::new(cases as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} cases, {elapsed} (eta {eta})",
        )
        .context("progress bar template")?,
    );
    let started = std::time::Instant::now();
    let result = study.run(threads, &|| bar.inc(1))?;
    bar.finish_and_clear();
    outln!(
        "{} cases in {:.1} s",
        cases,
        started.elapsed().as_secs_f64()
    );
    out!("{}", result.table());
    // Every fit that is not converged is counted by what it is, with the
    // first one's reason.
    let endings = result.endings();
    outln!(
        "fits: {}",
        endings
            .iter()
            .map(|(status, count, _)| format!("{count} {status}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for (status, count, first) in endings
        .iter()
        .filter(|(status, _, _)| status != aeroid::eval::study::CONVERGED)
    {
        outln!(
            "{count} {status}; the first (point {}, run {}, {} {}): {}",
            first.point,
            first.run,
            first.model,
            first.method,
            first.reason
        );
    }
    if let Some(out) = out {
        result.write(&out)?;
        outln!(
            "written: {0}/runs.csv, {0}/summary.csv, {0}/study.json",
            out.display()
        );
    }
    Ok(())
}
