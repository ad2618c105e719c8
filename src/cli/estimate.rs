//! `aeroid estimate`: one estimator on one record and model structure.

use aeroid::estimation::methods::output_error::Start;
use anyhow::{Context, Result};
use std::path::PathBuf;

/// Estimate a postulated model's parameters from a record; print the
/// estimates with Cramér–Rao standard errors, scored against the truth
/// when the record came from a scenario (its truth.toml); write
/// estimate.json and estimate.csv.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder.
    record: PathBuf,
    /// The model structure: a bundled name (models/) or a path.
    #[arg(long)]
    model: String,
    /// The estimator.
    #[arg(long, value_enum)]
    method: Method,
    /// The folder to write estimate.json and estimate.csv into (created).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Proof of match: simulate the estimated model on this other record
    /// (a different manoeuvre) and report how well it reproduces each output.
    #[arg(long)]
    check_on: Option<PathBuf>,
    /// Output error's start values: equation error's estimates when they
    /// fit better than the model file's (ee), or the model file's (model).
    #[arg(long, value_enum, default_value_t = Start::EquationError)]
    start: Start,
}

/// Estimators the CLI can run.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum Method {
    /// Equation error: least squares on coefficients reconstructed from
    /// accelerations and angular accelerations, coloured-residual bounds.
    Ee,
    /// Stepwise regression (F-to-enter/F-to-remove, PRESS) on every
    /// coefficient the model has, printing which terms it selects.
    Swr,
    /// Output error, maximum likelihood (Gauss–Newton on det R).
    Oem,
}

pub fn run(args: Args) -> Result<()> {
    use aeroid::estimation::{methods::output_error, structure::ModelStructure};
    use aeroid::eval::score;
    let Args {
        record: record_folder,
        model,
        method,
        out,
        check_on,
        start,
    } = args;
    let record = aeroid::record::FlightRecord::read(&record_folder)?;
    let structure = ModelStructure::load(&model)?;
    let estimate = match method {
        Method::Ee => aeroid::estimation::methods::equation_error::equation_error(
            &record,
            &structure,
            &Default::default(),
        )?,
        Method::Swr => {
            let (reports, estimate) =
                aeroid::estimation::methods::stepwise::stepwise_all(&record, &structure)?;
            for report in &reports {
                outln!("{report}");
            }
            estimate
        }
        Method::Oem => {
            let options = output_error::OutputErrorOptions {
                start,
                ..Default::default()
            };
            output_error::output_error(&[&record], &structure, &options)?
        }
    };
    let truth_path = record_folder.join(aeroid::sim::truth::TRUTH_FILE);
    let truth = truth_path
        .is_file()
        .then(|| aeroid::sim::truth::RunTruth::read(&truth_path))
        .transpose()?;
    let scores = score::score(&estimate, truth.as_ref(), structure.aircraft.aero.kind);
    outln!(
        "{} on {} with model {}: {:?} after {} iterations, {:.3} s",
        estimate.method,
        estimate.record,
        estimate.model,
        estimate.status,
        estimate.iterations,
        estimate.wall_time
    );
    out!("{}", score::table(&scores));
    for fit in &estimate.fits {
        outln!(
            "  fit {:<12} rms {:.4e}  R² {:.5}  TIC {:.4}",
            fit.channel,
            fit.rms,
            fit.r_squared,
            fit.theil
        );
    }
    for note in &estimate.notes {
        outln!("  note: {note}");
    }
    if let Some(other) = check_on {
        let other = aeroid::record::FlightRecord::read(&other)?;
        outln!("proof of match on {} (nothing adjusted):", other.scenario);
        for fit in output_error::proof_of_match(&estimate, &structure, &other)? {
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
        std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
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
