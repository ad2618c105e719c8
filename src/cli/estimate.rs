//! `aeroid estimate`: one estimator on one record, or several manoeuvres
//! fitted jointly, and a model structure.

use aeroid::estimation::estimator::MethodTables;
use aeroid::estimation::registry::Registry;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Estimate a model's parameters from one or several records.
///
/// Estimate a postulated model's parameters from a record, or from several
/// manoeuvres fitted jointly (output error: shared aerodynamic parameters,
/// each manoeuvre its own initial state); print the estimates with
/// Cramér–Rao standard errors, scored against the truth when the records
/// came from a scenario (their truth.toml); write estimate.json and
/// estimate.csv.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder, or several: REC1 REC2 … fitted jointly (methods
    /// that fit one record at a time refuse several).
    #[arg(required = true, num_args = 1..)]
    records: Vec<PathBuf>,
    /// The model structure: a bundled name (models/) or a path.
    #[arg(long)]
    model: String,
    /// The estimator (see `aeroid methods`).
    #[arg(long)]
    method: String,
    /// The folder to write estimate.json and estimate.csv into (created).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Proof of match: simulate the estimated model on this other record
    /// (a different manoeuvre) and report how well it reproduces each output.
    #[arg(long)]
    check_on: Option<PathBuf>,
    /// Also write the estimation problem (record, model, settings) as JSON
    /// to this file: what an estimator in another language reads.
    #[arg(long, value_name = "FILE")]
    write_problem: Option<PathBuf>,
    /// A setting of the method, KEY=VALUE with a TOML value, overriding
    /// the model's `[methods.NAME]` table (e.g. `--set start='"model"'`,
    /// `--set step='"0.02 s"'`); repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    settings: Vec<String>,
    /// With `--method ebm`: write the smoothed coefficient histories (CX …
    /// Cn, CL, CD, air data, rates, attitude, altitude and each
    /// coefficient's σ) as CSV to this file, to plot against the truth
    /// trace's coefficients.
    #[arg(long, value_name = "FILE")]
    write_smoothed: Option<PathBuf>,
}

/// `--set KEY=VALUE` arguments as a `[methods.NAME]` table.
fn settings_table(method: &str, settings: &[String]) -> Result<MethodTables> {
    let mut table = toml::Table::new();
    for setting in settings {
        let (key, value) = setting
            .split_once('=')
            .with_context(|| format!("--set {setting}: write KEY=VALUE"))?;
        let parsed: toml::Table =
            toml::from_str(&format!("value = {value}")).with_context(|| {
                format!(
                    "--set {setting}: the value is not TOML (a string needs quotes: {key}='\"…\"')"
                )
            })?;
        table.insert(key.trim().to_string(), parsed["value"].clone());
    }
    Ok([(method.to_string(), table)].into())
}

pub fn run(args: Args, registry: &Registry) -> Result<()> {
    use aeroid::estimation::{
        methods::{self, output_error},
        structure::Structure,
    };
    use aeroid::eval::score;
    let Args {
        records: record_folders,
        model,
        method,
        out,
        check_on,
        write_problem,
        settings,
        write_smoothed,
    } = args;
    if write_smoothed.is_some() && method != methods::smoothed_regression::METHOD {
        anyhow::bail!(
            "--write-smoothed: only the method '{}' smooths coefficient histories, not '{method}'",
            methods::smoothed_regression::METHOD
        );
    }
    if let Some(out) = &out {
        aeroid::paths::check_output_folder(out)?;
    }
    // Every file this command writes is checked before any work, and none
    // may be a file it reads (the model, a record's files).
    let mut inputs: Vec<&std::path::Path> = record_folders.iter().map(PathBuf::as_path).collect();
    inputs.push(std::path::Path::new(&model));
    inputs.extend(check_on.as_deref());
    for output in [&write_problem, &write_smoothed].into_iter().flatten() {
        aeroid::paths::check_output_file(output)?;
        aeroid::paths::check_not_input(output, &inputs, &[])?;
    }
    let records = record_folders
        .iter()
        .map(|folder| aeroid::record::FlightRecord::read(folder))
        .collect::<Result<Vec<_>, _>>()?;
    let other = check_on
        .as_deref()
        .map(aeroid::record::FlightRecord::read)
        .transpose()?;
    let structure = Structure::load(&model)?;
    let overrides = settings_table(&method, &settings)?;
    let problem = registry.problem(&method, records, structure, &[&overrides])?;
    if let Some(path) = &write_problem {
        problem.write_json(path)?;
        outln!("estimation problem written to {}", path.display());
    }
    let estimate = registry.estimate(&problem, None)?;
    if let Some(path) = &write_smoothed {
        write_smoothed_histories(&problem, path)?;
    }
    let structure = &problem.structure;
    out!("{}", estimate.details);
    let truth = shared_truth(&record_folders);
    let scores = score::score(&estimate, truth.as_ref(), structure.score_kind());
    print_estimate(&estimate, &scores)?;
    if let Some(other) = other {
        outln!("proof of match on {} (nothing adjusted):", other.scenario);
        let structure = structure.six_dof("proof of match (--check-on)")?;
        for fit in output_error::proof_of_match(&estimate, structure, &other)? {
            outln!(
                "  {:<12} rms {:.4e}  R² {:.5}  TIC {:.4}",
                fit.channel,
                fit.rms,
                fit.r_squared,
                fit.theil
            );
        }
    }
    if let Some(out) = out {
        std::fs::create_dir_all(&out).map_err(|e| aeroid::error::write_error(&out, e))?;
        estimate.write_json(&out.join("estimate.json"))?;
        score::write_csv(&scores, &out.join("estimate.csv"))?;
        outln!(
            "written: {}/estimate.json, {}/estimate.csv",
            out.display(),
            out.display()
        );
    }
    Ok(())
}

/// The truth the records came from: each record's `truth.toml`, when every
/// record has one and they agree. A truth.toml that aeroid did not write
/// (another tool's) is not a record's truth, and records from different
/// truths have none in common: the estimate is reported unscored, with a
/// warning.
fn shared_truth(folders: &[PathBuf]) -> Option<aeroid::sim::truth::RunTruth> {
    let mut shared: Option<aeroid::sim::truth::RunTruth> = None;
    for folder in folders {
        let path = folder.join(aeroid::sim::truth::TRUTH_FILE);
        if !path.is_file() {
            return None;
        }
        let truth = match aeroid::sim::truth::RunTruth::read(&path) {
            Ok(truth) => truth,
            Err(error) => {
                eprintln!("warning: {error}; the estimate is not scored");
                return None;
            }
        };
        match &shared {
            Some(first)
                if first.kind != truth.kind
                    || first.parameters != truth.parameters
                    || first.local_derivatives != truth.local_derivatives =>
            {
                eprintln!(
                    "warning: {} holds another truth than {}; the estimate is not scored",
                    path.display(),
                    folders[0].join(aeroid::sim::truth::TRUTH_FILE).display()
                );
                return None;
            }
            Some(_) => {}
            None => shared = Some(truth),
        }
    }
    shared
}

/// Writes the smoothed coefficient histories of the problem's record
/// (the method `smoothed-regression`'s) to `path`.
fn write_smoothed_histories(
    problem: &aeroid::estimation::problem::EstimationProblem,
    path: &Path,
) -> Result<()> {
    use aeroid::estimation::methods::smoothed_regression::{
        METHOD, SmoothedRegressionSettings, smooth,
    };
    let settings = SmoothedRegressionSettings::read(&problem.settings)?;
    smooth(
        problem.record(),
        problem.structure.six_dof(METHOD)?,
        &settings,
    )?
    .write_csv(path)?;
    outln!(
        "smoothed coefficient histories written to {}",
        path.display()
    );
    Ok(())
}

/// The estimate: its status, diagnoses, scores, output fits and notes.
fn print_estimate(
    estimate: &aeroid::estimation::estimate::Estimate,
    scores: &[aeroid::eval::score::ParameterScore],
) -> Result<()> {
    outln!(
        "{} on {} with model {}: {} after {} iterations, {:.3} s",
        estimate.method,
        estimate.record,
        estimate.model,
        estimate.status,
        estimate.iterations,
        estimate.wall_time
    );
    for diagnosis in &estimate.diagnoses {
        outln!("diagnosis {diagnosis}");
    }
    out!("{}", aeroid::eval::score::table(scores));
    for fit in &estimate.fits {
        outln!(
            "  fit {:<12} rms {:.4e}  R² {:.5}  TIC {:.4}  ρ₁ {:.3}  outside band {:.0} %  structured {:.4}  quiet share {:.2}",
            fit.channel,
            fit.rms,
            fit.r_squared,
            fit.theil,
            fit.lag_one,
            100.0 * fit.outside_band,
            fit.structured,
            fit.quiet_share
        );
    }
    for note in &estimate.notes {
        outln!("  note: {note}");
    }
    Ok(())
}
