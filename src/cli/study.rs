//! `aeroid study`: a Monte Carlo study.

use aeroid::estimation::registry::Registry;
use aeroid::eval::journal::Shard;
use aeroid::eval::row::RowStatus;
use aeroid::eval::study::Study;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Run a Monte Carlo study, on one machine or in shards.
///
/// Run a Monte Carlo study (studies/*.toml): many seeded runs of
/// simulate, record, estimate and score over the study's sweep points;
/// print per point, model, method and parameter the bias, the spread
/// against the Cramér–Rao bound and the 95 % coverage. The numbers
/// depend only on the study seed, whatever the thread count, shard split
/// or interruption. With --out every case is journaled as it finishes
/// (OUT/cases.jsonl), so --resume continues an interrupted study;
/// --shard K/N runs one share of the cases, and `aeroid study merge
/// --out DIR SHARD_DIR…` joins the shards into the result one machine
/// would have written (docs/cli.md, "study").
#[derive(clap::Args)]
pub struct Args {
    /// A bundled study name (studies/) or a path to a study file; or
    /// `merge` followed by the shards' output folders.
    study: String,
    /// With `merge`: the shards' output folders.
    shards: Vec<PathBuf>,
    /// Runs per sweep point, instead of the file's `runs` (the first runs
    /// are the same either way).
    #[arg(long)]
    runs: Option<usize>,
    /// Worker threads; default one per core.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// A folder for cases.jsonl (the journal), runs.csv (every run's
    /// rows), summary.csv and study.json.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the interrupted study journaled in --out.
    #[arg(long, requires = "out")]
    resume: bool,
    /// Run only shard K of N (cases i with i mod N = K − 1); needs --out.
    #[arg(long, value_name = "K/N", requires = "out")]
    shard: Option<String>,
    /// Also write the HTML report (OUT/report.html, as `aeroid report
    /// OUT`) once the study is complete (a shard's is the merge's).
    #[arg(long, requires = "out")]
    report: bool,
}

pub fn run(args: Args, registry: &Registry) -> Result<()> {
    if args.study == "merge" {
        return merge(args);
    }
    if !args.shards.is_empty() {
        anyhow::bail!(
            "unexpected arguments after the study name: {} (only `aeroid study merge` takes folders)",
            args.shards
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    let Args {
        study: reference,
        runs,
        threads,
        out,
        resume,
        shard,
        report: write_html,
        ..
    } = args;
    let shard = shard
        .as_deref()
        .map(aeroid::eval::journal::Shard::parse)
        .transpose()?
        .unwrap_or_default();
    if let Some(out) = &out {
        aeroid::paths::check_output_folder(out)?;
    }
    let mut study = aeroid::eval::study::Study::load(registry, &reference)?;
    if let Some(runs) = runs {
        study.set_runs(runs, "--runs")?;
    }
    let cases = study.cases().len();
    describe(&study, cases)?;
    let started = std::time::Instant::now();
    let Some(out) = out else {
        let progress = Progress::new(cases)?;
        let result = study.run(threads, &|rows| progress.case(rows))?;
        progress.finish();
        outln!("{cases} cases in {:.1} s", started.elapsed().as_secs_f64());
        return report(&result, None, false);
    };
    let progress = Progress::new(remaining_cases(&study, &out, shard, resume)?)?;
    let journaled = study.run_journaled(&out, shard, resume, threads, &|rows| progress.case(rows));
    progress.finish();
    let journaled = journaled?;
    outln!(
        "{} cases in {:.1} s{}{}",
        journaled.ran,
        started.elapsed().as_secs_f64(),
        if journaled.resumed > 0 {
            format!(" ({} more from the journal)", journaled.resumed)
        } else {
            String::new()
        },
        if shard.count > 1 {
            format!(", shard {shard}")
        } else {
            String::new()
        }
    );
    keep_study_file(&study.path, &out)?;
    if shard.count > 1 {
        return shard_done(shard, &out, write_html);
    }
    let result = aeroid::eval::study::assemble(std::slice::from_ref(&out), &out)?;
    report(&result, Some(&out), write_html)
}

/// The study's first line: its sweep points, runs, cases, models,
/// methods and seed.
fn describe(study: &Study, cases: usize) -> Result<()> {
    outln!(
        "study {}: {} sweep point(s) × {} runs = {} cases; models {}; methods {}; seed {}",
        study.name,
        study.points.len(),
        study.runs,
        cases,
        study
            .models
            .iter()
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", "),
        study.methods.join(", "),
        study.seed
    );
    Ok(())
}

/// The cases of `shard` still to run: all of them, or with --resume
/// those the journal in `out` (of the same study and shard) lacks.
fn remaining_cases(study: &Study, out: &Path, shard: Shard, resume: bool) -> Result<usize> {
    let header = study.journal_header(shard)?;
    let finished = if resume {
        aeroid::eval::journal::read(out)
            .ok()
            .filter(|(found, _)| *found == header)
            .map(|(_, f)| f)
            .unwrap_or_default()
    } else {
        Default::default()
    };
    Ok(study.remaining(shard, &finished).len())
}

/// A shard's last lines: where it is journaled, and that the merge
/// writes the report.
fn shard_done(shard: Shard, out: &Path, write_html: bool) -> Result<()> {
    outln!(
        "shard {shard} journaled in {}; when every shard is done: aeroid study merge --out DIR SHARD_DIR…",
        out.join(aeroid::eval::journal::JOURNAL_FILE).display()
    );
    if write_html {
        outln!(
            "the report is written by the merge: aeroid study merge --report --out DIR SHARD_DIR…"
        );
    }
    Ok(())
}

/// Copies the study file into its output folder (`study.toml`, which the
/// report shows).
fn keep_study_file(study: &std::path::Path, out: &std::path::Path) -> Result<()> {
    let copy = out.join(aeroid::eval::report::STUDY_COPY);
    if std::fs::canonicalize(study).ok() != std::fs::canonicalize(&copy).ok() {
        std::fs::copy(study, &copy)
            .with_context(|| format!("copying {} to {}", study.display(), copy.display()))?;
    }
    Ok(())
}

/// `aeroid study merge --out DIR SHARD_DIR…`.
fn merge(args: Args) -> Result<()> {
    let Some(out) = args.out else {
        anyhow::bail!("aeroid study merge needs --out DIR for the merged result");
    };
    if args.shards.is_empty() {
        anyhow::bail!("aeroid study merge needs the shards' output folders");
    }
    aeroid::paths::check_output_folder(&out)?;
    let result = aeroid::eval::study::assemble(&args.shards, &out)?;
    let first_copy = args.shards[0].join(aeroid::eval::report::STUDY_COPY);
    if first_copy.exists() {
        keep_study_file(&first_copy, &out)?;
    }
    outln!(
        "study {}: {} shard folder(s) merged, {} cases, {} rows",
        result.study,
        args.shards.len(),
        result.cases,
        result.rows
    );
    report(&result, Some(&out), args.report)
}

/// Prints the summary and the endings, and where they were written; with
/// `html`, writes the report page into `out`.
fn report(
    result: &aeroid::eval::study::StudyResult,
    out: Option<&PathBuf>,
    html: bool,
) -> Result<()> {
    out!("{}", result.table());
    // Every fit that is not converged is counted by what it is, with the
    // first one's reason.
    outln!(
        "fits: {}",
        result
            .endings
            .iter()
            .map(|e| format!("{} {}", e.count, e.status))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for ending in result
        .endings
        .iter()
        .filter(|e| e.status != RowStatus::Converged)
    {
        let first = &ending.first;
        outln!(
            "{} {}; the first (point {}, run {}, {} {}): {}",
            ending.count,
            ending.status,
            first.point,
            first.run,
            first.model,
            first.method,
            first.reason
        );
    }
    // Diagnosed fits are counted in the statistics above; what they carried.
    for line in result.diagnosed() {
        outln!("{line}");
    }
    if let Some(out) = out {
        outln!(
            "written: {0}/runs.csv, {0}/summary.csv, {0}/study.json",
            out.display()
        );
        if html {
            let page = aeroid::eval::report::write_report(out, None)?;
            outln!("written: {}", page.display());
        }
    }
    Ok(())
}

/// Progress of a study: a bar on a terminal; elsewhere (CI, a batch
/// job's log) a line every few seconds. Both count cases done, cases with
/// a failed or refused fit, the rate and the time left.
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    total: usize,
    state: std::sync::Mutex<(usize, usize, std::time::Instant)>,
    started: std::time::Instant,
}

/// Seconds between progress lines on a non-terminal.
const LINE_INTERVAL: f64 = 5.0;

impl Progress {
    fn new(total: usize) -> Result<Progress> {
        use std::io::IsTerminal;
        let bar = if std::io::stderr().is_terminal() {
            Some(
                indicatif::ProgressBar::new(total as u64).with_style(
                    indicatif::ProgressStyle::with_template(
                        "{bar:40} {pos}/{len} cases, {msg}, {per_sec}, {elapsed} (eta {eta})",
                    )
                    .context("progress bar template")?,
                ),
            )
        } else {
            None
        };
        let now = std::time::Instant::now();
        Ok(Progress {
            bar,
            total,
            state: std::sync::Mutex::new((0, 0, now)),
            started: now,
        })
    }

    fn case(&self, rows: &[aeroid::eval::study::Row]) {
        let failed = rows
            .iter()
            .any(|r| matches!(r.status, RowStatus::Failed | RowStatus::Refused));
        let Ok(mut state) = self.state.lock() else {
            return;
        };
        state.0 += 1;
        state.1 += usize::from(failed);
        let (done, failures) = (state.0, state.1);
        match &self.bar {
            Some(bar) => {
                bar.set_message(format!("{failures} with a failed or refused fit"));
                bar.inc(1);
            }
            None => {
                let now = std::time::Instant::now();
                if now.duration_since(state.2).as_secs_f64() >= LINE_INTERVAL || done == self.total
                {
                    state.2 = now;
                    let elapsed = now.duration_since(self.started).as_secs_f64();
                    let rate = done as f64 / elapsed.max(1e-9);
                    eprintln!(
                        "{done}/{} cases, {failures} with a failed or refused fit, {rate:.1} cases/s, {elapsed:.0} s elapsed, eta {:.0} s",
                        self.total,
                        (self.total - done) as f64 / rate.max(1e-9)
                    );
                }
            }
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
