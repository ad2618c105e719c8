//! `aeroid run`: the whole harness on one scenario.

use aeroid::estimation::registry::Registry;
use aeroid::eval::run::{Outcome, RunReport};
use aeroid::prep::derive::Options as DeriveOptions;
use aeroid::sim::scenario::Scenario;
use anyhow::Result;
use std::path::{Path, PathBuf};

/// The widest status the summary table shows in full.
const STATUS_WIDTH: usize = 40;

/// The whole harness on one scenario: fly, record, estimate, score.
///
/// The whole harness on one scenario: simulate, record (the scenario's
/// recorder profile unless --profile), run every registered estimator
/// (`aeroid methods`) on every model structure the scenario names, and
/// score each against the truth. With --out, writes the record, truth and estimates.
#[derive(clap::Args)]
pub struct Args {
    /// A bundled scenario name or a path to a scenario file.
    scenario: String,
    /// A recorder profile (recorders/) or a path.
    #[arg(long)]
    profile: Option<String>,
    /// Print every parameter's score, not just the summary per estimator.
    #[arg(long)]
    verbose: bool,
    /// A folder for the record, truth.toml and one estimate per model and method.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run the derive step on the record before the estimators, as
    /// `aeroid derive` does, with the flags below (a recorder without
    /// angular rates, true airspeed or combined surfaces, such as the QAR).
    #[arg(long)]
    derive: bool,
    #[command(flatten)]
    derive_flags: crate::cli::derive::DeriveFlags,
}

pub fn run(args: Args, registry: &Registry) -> Result<()> {
    let Args {
        scenario,
        profile,
        verbose,
        out,
        derive,
        derive_flags,
    } = args;
    if let Some(out) = &out {
        aeroid::paths::check_output_folder(out)?;
    }
    let derive_options = derive_flags.options();
    if !derive && derive_options != aeroid::prep::derive::Options::default() {
        anyhow::bail!("the derive step's flags need --derive");
    }
    let scenario = Scenario::load(&scenario)?;
    let profile = aeroid::record::recorder::profile_for(&scenario, profile.as_deref())?;
    let report = aeroid::eval::run::run(
        registry,
        &scenario,
        &profile,
        derive.then_some(&derive_options),
    )?;
    print_header(&report, &derive_options)?;
    print_table(&report, &scenario, verbose)?;
    if let Some(out) = out {
        write_out(&report, &out)?;
    }
    Ok(())
}

/// The run's first lines: the scenario, the recorder and the truth, the
/// derive step's summary and the parameter changes scored against their
/// start values.
fn print_header(report: &RunReport, derive_options: &DeriveOptions) -> Result<()> {
    let truth = match report.truth.kind {
        aeroid::sim::truth::TruthKind::Exact => format!(
            "exact, the parameters {} flew ({})",
            report.truth.aircraft,
            match report.truth.model {
                aeroid::sim::aero::ModelKind::Linear => "linear aerodynamics",
                aeroid::sim::aero::ModelKind::Stall => "quasi-steady stall aerodynamics",
            }
        ),
        aeroid::sim::truth::TruthKind::LocalDerivative => {
            format!("local derivatives of {} at trim", report.truth.aircraft)
        }
    };
    outln!(
        "{}: recorded with {} ({} channels{}); truth: {truth}",
        report.scenario,
        report.profile,
        report.record.channels.len(),
        if report.derived.is_some() {
            " after the derive step"
        } else {
            ""
        },
    );
    if let Some(derived) = &report.derived {
        outln!("the derive step:");
        crate::cli::derive::print_summary(derived, derive_options)?;
    }
    for change in &report.truth.parameter_changes {
        outln!(
            "{} changes to {} at {} s: scored against its value at the start, {}",
            change.parameter,
            change.value,
            change.time,
            report
                .truth
                .parameters
                .get(&change.parameter)
                .map_or(f64::NAN, |v| *v),
        );
    }
    Ok(())
}

/// The table of the estimators' runs, a line each (with --verbose each
/// parameter's score beneath).
fn print_table(report: &RunReport, scenario: &Scenario, verbose: bool) -> Result<()> {
    let (model_width, method_width, status_width) = column_widths(report);
    if scenario.models.is_empty() {
        outln!("the scenario names no model structures (`models = [...]`): nothing to estimate");
    } else {
        outln!(
            "{:<model_width$} {:<method_width$} {:<status_width$} {:>6} {:>9} {:>13} {:>10}  diagnoses",
            "model",
            "method",
            "status",
            "iter",
            "time [s]",
            "inside 95 %",
            "max|e/σ|"
        );
    }
    for run in &report.runs {
        match &run.outcome {
            Outcome::Estimated { estimate, scores } => {
                let (inside, scored, worst) = run.coverage().unwrap_or((0, 0, f64::NAN));
                let status = status_of(estimate.status.to_string());
                let diagnoses: Vec<String> = estimate
                    .diagnoses
                    .iter()
                    .map(|d| format!("{} ({})", d.kind, d.about.join(", ")))
                    .collect();
                let line = format!(
                    "{:<model_width$} {:<method_width$} {:<status_width$} {:>6} {:>9.3} {:>13} {:>10.2}  {}",
                    run.model,
                    run.method,
                    status,
                    estimate.iterations,
                    estimate.wall_time,
                    format!("{inside}/{scored}"),
                    worst,
                    diagnoses.join("; ")
                );
                outln!("{}", line.trim_end());
                if verbose {
                    for diagnosis in &estimate.diagnoses {
                        outln!("  diagnosis {diagnosis}");
                    }
                    out!("{}", aeroid::eval::score::table(scores));
                }
            }
            Outcome::Refused(refusal) => outln!(
                "{:<model_width$} {:<method_width$} refused ({}): {refusal}",
                run.model,
                run.method,
                refusal.kind()
            ),
            Outcome::Failed(reason) => {
                outln!(
                    "{:<model_width$} {:<method_width$} failed: {reason}",
                    run.model,
                    run.method
                )
            }
        }
    }
    Ok(())
}

/// The widths of the model, method and status columns: as wide as their
/// longest entry ([`status_of`]'s for the status).
fn column_widths(report: &RunReport) -> (usize, usize, usize) {
    let model_width = report
        .runs
        .iter()
        .map(|r| r.model.chars().count())
        .fold(22, usize::max);
    let method_width = report
        .runs
        .iter()
        .map(|r| r.method.chars().count())
        .fold(6, usize::max);
    let status_width = report
        .runs
        .iter()
        .filter_map(|r| match &r.outcome {
            Outcome::Estimated { estimate, .. } => {
                Some(status_of(estimate.status.to_string()).chars().count())
            }
            _ => None,
        })
        .fold(16, usize::max);
    (model_width, method_width, status_width)
}

/// A status as the table shows it: one longer than STATUS_WIDTH is cut
/// with an ellipsis (the estimate files keep it).
fn status_of(status: String) -> String {
    if status.chars().count() > STATUS_WIDTH {
        status.chars().take(STATUS_WIDTH - 1).chain(['…']).collect()
    } else {
        status
    }
}

/// Writes the record, the truth and each estimate with its scores into
/// the folder `out`.
fn write_out(report: &RunReport, out: &Path) -> Result<()> {
    report.record.write(out)?;
    report
        .truth
        .write(&out.join(aeroid::sim::truth::TRUTH_FILE))?;
    for run in &report.runs {
        if let Outcome::Estimated { estimate, scores } = &run.outcome {
            let stem = format!("{}-{}", run.model.replace(['/', '.'], "_"), run.method);
            estimate.write_json(&out.join(format!("{stem}.json")))?;
            aeroid::eval::score::write_csv(scores, &out.join(format!("{stem}.csv")))?;
        }
    }
    outln!("record, truth and estimates written to {}", out.display());
    Ok(())
}
