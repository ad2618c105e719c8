//! The `aeroid` command line. Only this file prints and exits.

use aeroid::catalog;
use aeroid::sim::scenario::Scenario;
use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "aeroid",
    version,
    about = "Simulate aircraft manoeuvres, record them like a flight recorder, and check whether estimators recover the aerodynamic parameters"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Trim and fly a scenario; write the truth trace (every state, air data,
    /// control and aerodynamic coefficient at every integration step) as CSV.
    Simulate {
        /// A bundled scenario name (see `aeroid list`) or a path to a scenario file.
        scenario: String,
        /// The CSV file to write; its header names every column and its unit.
        #[arg(long)]
        out: PathBuf,
    },
    /// List the bundled aircraft, scenarios, recorder profiles and studies.
    List,
    /// Validate an aircraft, scenario, recorder-profile or study file and explain
    /// every problem; a scenario is also trimmed.
    Check {
        /// The file to check.
        file: PathBuf,
    },
    /// Fly a scenario and record it with a recorder profile: write the flight
    /// record (record.toml + CSV per time base) and the run's truth.toml.
    Record {
        /// A bundled scenario name or a path to a scenario file.
        scenario: String,
        /// A bundled recorder profile (recorders/) or a path; default: the
        /// scenario's `recorder`, else `ideal`.
        #[arg(long)]
        profile: Option<String>,
        /// The record folder to write.
        #[arg(long)]
        out: PathBuf,
    },
    /// Bring real flight data in: a CSV and a column map (TOML) become a record folder.
    Import {
        /// The CSV file with a time column.
        data: PathBuf,
        /// The column map: time column, and per channel its column, unit, scale and offset.
        #[arg(long)]
        map: PathBuf,
        /// The record folder to write.
        #[arg(long)]
        out: PathBuf,
    },
    /// Print a record's channels with rates, units, ranges, dropouts and gaps.
    Inspect {
        /// The record folder.
        record: PathBuf,
    },
    /// The whole harness on one scenario: simulate, record (the scenario's
    /// recorder profile unless --profile), run every classical estimator (ee,
    /// swr, oem) on every model structure the scenario names, and score each
    /// against the truth. With --out, writes the record, truth and estimates.
    Run {
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
    },
    /// Flight path reconstruction / data compatibility check (reflex-wing UAV paper): estimate
    /// accelerometer and gyro biases and the flow-vane scale factors and
    /// offsets from the kinematics; with --out, write the corrected record.
    Reconstruct {
        /// The record folder.
        record: PathBuf,
        /// A folder for the corrected record.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// A-priori identifiability: the Cramér–Rao bound of every aerodynamic
    /// parameter of the scenario's aircraft that the profile's channels allow
    /// (sensitivities by central differences through the simulator and the
    /// recorder, measurement error from the profile's noise and resolution),
    /// and whether its relative bound is below the threshold.
    Identifiability {
        /// A bundled scenario name or a path.
        scenario: String,
        /// The recorder profile (default: the scenario's).
        #[arg(long)]
        profile: Option<String>,
        /// Identifiable when σ/|truth| is below this.
        #[arg(long, default_value_t = 0.1)]
        threshold: f64,
        /// Only these parameters (comma-separated).
        #[arg(long, value_delimiter = ',')]
        parameters: Option<Vec<String>>,
        /// Only these channels (comma-separated).
        #[arg(long, value_delimiter = ',')]
        channels: Option<Vec<String>>,
        /// Split the flight into segments of this length (e.g. "20 s"), each
        /// with its own unknown initial state.
        #[arg(long)]
        segment: Option<String>,
    },
    /// Run the accuracy gates (golden/gates.toml): fly, record and estimate
    /// every case, check each parameter against the truth within its
    /// tolerance, print what failed, and exit non-zero on any failure.
    Gate {
        /// The gate file.
        #[arg(long, default_value = aeroid::eval::gate::GATE_FILE)]
        file: PathBuf,
        /// Print every parameter's row (estimate, σ, truth, error, allowed), not only failures.
        #[arg(long)]
        verbose: bool,
        /// Run only the cases whose name contains this text.
        #[arg(long)]
        only: Option<String>,
    },
    /// Run a Monte Carlo study (studies/*.toml): many seeded runs of
    /// simulate, record, estimate and score over the study's sweep points;
    /// print per point, model, method and parameter the bias, the spread
    /// against the Cramér–Rao bound and the 95 % coverage. The numbers
    /// depend only on the study seed, whatever the thread count.
    Study {
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
    },
    /// Estimate a postulated model's parameters from a record; print the
    /// estimates with Cramér–Rao standard errors, scored against the truth
    /// when the record came from a scenario (its truth.toml); write
    /// estimate.json and estimate.csv.
    Estimate {
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
        #[arg(long, value_enum, default_value_t = aeroid::estimation::methods::output_error::Start::EquationError)]
        start: aeroid::estimation::methods::output_error::Start,
    },
    /// Write an aircraft as a JSBSim aircraft (DIR/NAME/NAME.xml): the same
    /// mass, inertia, geometry, thrust and linear aerodynamics, the
    /// aerodynamics as JSBSim functions (needs the `jsbsim` feature).
    #[cfg(feature = "jsbsim")]
    ExportJsbsim {
        /// A bundled aircraft name (see `aeroid list`) or a path to an aircraft file.
        aircraft: String,
        /// The folder to write the JSBSim aircraft folder into.
        #[arg(long)]
        out: PathBuf,
        /// Keep JSBSim's standard atmosphere (geopotential altitude) instead of
        /// overriding it with aeroid's ISA.
        #[arg(long)]
        jsbsim_atmosphere: bool,
    },
    /// Fly a scenario in aeroid's simulator and in JSBSim (the exported
    /// aircraft, same trim, same inputs, no wind) and print the largest
    /// difference per state and both simulators' steps per second (needs the
    /// `jsbsim` feature).
    #[cfg(feature = "jsbsim")]
    Crosscheck {
        /// A bundled scenario name or a path to a scenario file.
        scenario: String,
        /// Flight time, e.g. "60 s"; default: the scenario's duration.
        #[arg(long)]
        duration: Option<String>,
        /// Keep JSBSim's standard atmosphere instead of aeroid's ISA.
        #[arg(long)]
        jsbsim_atmosphere: bool,
        /// JSBSim steps per aeroid step: its Adams-Bashforth integrators
        /// smear each input step over the derivative history.
        #[arg(long, default_value_t = aeroid::jsbsim::crosscheck::DEFAULT_SUBSTEPS)]
        substeps: usize,
    },
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

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Simulate { scenario, out } => simulate(&scenario, &out),
        Command::List => {
            println!("data folder: {}", catalog::data_folder().display());
            for folder in [
                catalog::AIRCRAFT_FOLDER,
                catalog::SCENARIO_FOLDER,
                catalog::RECORDER_FOLDER,
                catalog::STUDY_FOLDER,
            ] {
                println!("{folder}:");
                for name in catalog::bundled(folder) {
                    println!("  {name}");
                }
            }
            Ok(())
        }
        Command::Record {
            scenario,
            profile,
            out,
        } => record(&scenario, profile.as_deref(), &out),
        Command::Import { data, map, out } => import(&data, &map, &out),
        Command::Run {
            scenario,
            profile,
            verbose,
            out,
        } => run_all(&scenario, profile.as_deref(), verbose, out.as_deref()),
        Command::Gate {
            file,
            verbose,
            only,
        } => gate(&file, verbose, only.as_deref()),
        Command::Study {
            study,
            runs,
            threads,
            out,
        } => run_study(&study, runs, threads, out.as_deref()),
        #[cfg(feature = "jsbsim")]
        Command::ExportJsbsim {
            aircraft,
            out,
            jsbsim_atmosphere,
        } => export_jsbsim(&aircraft, &out, jsbsim_atmosphere),
        #[cfg(feature = "jsbsim")]
        Command::Crosscheck {
            scenario,
            duration,
            jsbsim_atmosphere,
            substeps,
        } => crosscheck(&scenario, duration.as_deref(), jsbsim_atmosphere, substeps),
        Command::Reconstruct { record, out } => reconstruct(&record, out.as_deref()),
        Command::Identifiability {
            scenario,
            profile,
            threshold,
            parameters,
            channels,
            segment,
        } => {
            let segment = segment
                .map(|text| {
                    aeroid::units::Quantity::Text(text)
                        .si(aeroid::units::Dimension::Time)
                        .map_err(|e| anyhow::anyhow!("--segment: {e}"))
                })
                .transpose()?;
            let scenario = aeroid::sim::scenario::Scenario::load(&scenario)?;
            let profile = aeroid::record::recorder::profile_for(&scenario, profile.as_deref())?;
            if threshold.is_nan() || threshold <= 0.0 {
                anyhow::bail!("--threshold must be positive, is {threshold}");
            }
            let options = aeroid::analysis::identifiability::IdentifiabilityOptions {
                threshold,
                parameters,
                channels,
                segment,
                ..Default::default()
            };
            let result = aeroid::analysis::identifiability::analyse(&scenario, &profile, &options)?;
            print!("{}", result.table());
            Ok(())
        }
        Command::Estimate {
            record,
            model,
            method,
            out,
            check_on,
            start,
        } => estimate(
            &record,
            &model,
            method,
            out.as_deref(),
            check_on.as_deref(),
            start,
        ),
        Command::Inspect { record } => {
            print!(
                "{}",
                aeroid::record::FlightRecord::read(&record)?.describe()
            );
            Ok(())
        }
        Command::Check { file } => {
            let report = aeroid::check::check_file(&file)?;
            println!("{}: valid {}", file.display(), report.kind);
            for line in report.lines {
                println!("  {line}");
            }
            Ok(())
        }
    }
}

fn simulate(reference: &str, out: &std::path::Path) -> Result<()> {
    let scenario = Scenario::load(reference)?;
    let started = std::time::Instant::now();
    match aeroid::sim::simulate(&scenario) {
        Ok(trace) => {
            trace.write_csv(out)?;
            println!(
                "{}: {} samples over {} s in {:.3} s; truth trace written to {}",
                scenario.name,
                trace.samples.len(),
                trace.duration(),
                started.elapsed().as_secs_f64(),
                out.display()
            );
            Ok(())
        }
        Err(aeroid::Error::Departed {
            time,
            reason,
            partial,
        }) => {
            partial
                .write_csv(out)
                .context("writing the partial trace")?;
            anyhow::bail!(
                "simulation departed at t = {time:.3} s: {reason}; the {} samples before departure are in {}",
                partial.samples.len(),
                out.display()
            )
        }
        Err(error) => Err(error.into()),
    }
}

fn record(reference: &str, profile: Option<&str>, out: &std::path::Path) -> Result<()> {
    let scenario = Scenario::load(reference)?;
    let profile = aeroid::record::recorder::profile_for(&scenario, profile)?;
    let (record, truth) = aeroid::record::recorder::record_scenario(&scenario, &profile)?;
    record.write(out)?;
    truth.write(&out.join(aeroid::sim::truth::TRUTH_FILE))?;
    println!(
        "{}: recorded with profile {} ({} channels); record and truth written to {}",
        scenario.name,
        profile.name,
        record.channels.len(),
        out.display()
    );
    Ok(())
}

fn import(data: &std::path::Path, map: &std::path::Path, out: &std::path::Path) -> Result<()> {
    let outcome = aeroid::record::import::import(data, map)?;
    outcome.record.write(out)?;
    println!(
        "{}: {} channels imported into {}",
        data.display(),
        outcome.record.channels.len(),
        out.display()
    );
    if !outcome.unmapped.is_empty() {
        println!(
            "columns not in the map (not imported): {}",
            outcome.unmapped.join(", ")
        );
    }
    Ok(())
}

fn estimate(
    record_folder: &std::path::Path,
    model: &str,
    method: Method,
    out: Option<&std::path::Path>,
    check_on: Option<&std::path::Path>,
    start: aeroid::estimation::methods::output_error::Start,
) -> Result<()> {
    use aeroid::estimation::{methods::output_error, structure::ModelStructure};
    use aeroid::eval::score;
    let record = aeroid::record::FlightRecord::read(record_folder)?;
    let structure = ModelStructure::load(model)?;
    let estimate = match method {
        Method::Ee => aeroid::estimation::methods::equation_error::equation_error(
            &record,
            &structure,
            &Default::default(),
        )?,
        Method::Swr => {
            let (reports, estimate) =
                aeroid::estimation::methods::stepwise::stepwise_all(&record, &structure)?;
            reports.iter().for_each(|report| println!("{report}"));
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
    println!(
        "{} on {} with model {}: {:?} after {} iterations, {:.3} s",
        estimate.method,
        estimate.record,
        estimate.model,
        estimate.status,
        estimate.iterations,
        estimate.wall_time
    );
    print!("{}", score::table(&scores));
    for fit in &estimate.fits {
        println!(
            "  fit {:<12} rms {:.4e}  R² {:.5}  TIC {:.4}",
            fit.channel, fit.rms, fit.r_squared, fit.theil
        );
    }
    for note in &estimate.notes {
        println!("  note: {note}");
    }
    if let Some(other) = check_on {
        let other = aeroid::record::FlightRecord::read(other)?;
        println!("proof of match on {} (nothing adjusted):", other.scenario);
        for fit in output_error::proof_of_match(&estimate, &structure, &other)? {
            println!(
                "  {:<12} rms {:.4e}  R² {:.5}  TIC {:.4}",
                fit.channel, fit.rms, fit.r_squared, fit.theil
            );
        }
    }
    if let Some(out) = out {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
        estimate.write_json(&out.join("estimate.json"))?;
        score::write_csv(&scores, &out.join("estimate.csv"))?;
        println!(
            "written: {}/estimate.json, {}/estimate.csv",
            out.display(),
            out.display()
        );
    }
    Ok(())
}

fn run_all(
    reference: &str,
    profile: Option<&str>,
    verbose: bool,
    out: Option<&std::path::Path>,
) -> Result<()> {
    let scenario = Scenario::load(reference)?;
    let profile = aeroid::record::recorder::profile_for(&scenario, profile)?;
    let report = aeroid::eval::run::run(&scenario, &profile)?;
    let truth = match report.truth.kind {
        aeroid::sim::truth::TruthKind::Exact => format!("{:?} model", report.truth.model),
        aeroid::sim::truth::TruthKind::LocalDerivative => {
            format!("local derivatives of {} at trim", report.truth.aircraft)
        }
    };
    println!(
        "{}: recorded with {} ({} channels); truth: {truth}",
        report.scenario,
        report.profile,
        report.record.channels.len(),
    );
    if scenario.models.is_empty() {
        println!("the scenario names no model structures (`models = [...]`): nothing to estimate");
    }
    println!(
        "{:<22} {:<5} {:<16} {:>6} {:>9} {:>13} {:>10}",
        "model", "method", "status", "iter", "time [s]", "inside 95 %", "max|e/σ|"
    );
    for run in &report.runs {
        match &run.outcome {
            Ok((estimate, scores)) => {
                let (inside, scored, worst) = run.coverage().unwrap_or((0, 0, f64::NAN));
                let status = format!("{:?}", estimate.status)
                    .chars()
                    .take(16)
                    .collect::<String>();
                println!(
                    "{:<22} {:<5} {:<16} {:>6} {:>9.3} {:>13} {:>10.2}",
                    run.model,
                    run.method,
                    status,
                    estimate.iterations,
                    estimate.wall_time,
                    format!("{inside}/{scored}"),
                    worst
                );
                if verbose {
                    print!("{}", aeroid::eval::score::table(scores));
                }
            }
            Err(reason) => println!("{:<22} {:<5} not run: {reason}", run.model, run.method),
        }
    }
    if let Some(out) = out {
        report.record.write(out)?;
        report
            .truth
            .write(&out.join(aeroid::sim::truth::TRUTH_FILE))?;
        for run in &report.runs {
            if let Ok((estimate, scores)) = &run.outcome {
                let stem = format!("{}-{}", run.model.replace(['/', '.'], "_"), run.method);
                estimate.write_json(&out.join(format!("{stem}.json")))?;
                aeroid::eval::score::write_csv(scores, &out.join(format!("{stem}.csv")))?;
            }
        }
        println!("record, truth and estimates written to {}", out.display());
    }
    Ok(())
}

fn reconstruct(record_folder: &std::path::Path, out: Option<&std::path::Path>) -> Result<()> {
    let record = aeroid::record::FlightRecord::read(record_folder)?;
    let result = aeroid::prep::compatibility::flight_path_reconstruction(&record, 30)?;
    let estimate = &result.estimate;
    println!(
        "flight path reconstruction of {}: {:?} after {} iterations, {:.3} s",
        estimate.record, estimate.status, estimate.iterations, estimate.wall_time
    );
    for p in &estimate.parameters {
        println!(
            "  {:<12} {:>14.6e} ± {:.3e}",
            p.name, p.value, p.standard_error
        );
    }
    for fit in &estimate.fits {
        println!(
            "  fit {:<10} rms {:.4e}  R² {:.5}  TIC {:.4}",
            fit.channel, fit.rms, fit.r_squared, fit.theil
        );
    }
    if let Some(out) = out {
        result.corrected.write(out)?;
        println!("corrected record written to {}", out.display());
    }
    Ok(())
}

fn gate(file: &std::path::Path, verbose: bool, only: Option<&str>) -> Result<()> {
    let mut gates = aeroid::eval::gate::load(file)?;
    gates
        .cases
        .retain(|case| only.is_none_or(|text| case.name.contains(text)));
    let mut failed = Vec::new();
    for case in &gates.cases {
        match aeroid::eval::gate::run_case(case) {
            Ok(result) if result.passed() => {
                match &result.refusal {
                    Some(refusal) => {
                        println!("pass  {:<34} refused as expected: {refusal}", case.name)
                    }
                    None => println!(
                        "pass  {:<34} {} parameters, worst at {:.0} % of its tolerance",
                        case.name,
                        result.rows.len(),
                        100.0 * result.worst()
                    ),
                }
                if verbose && result.refusal.is_none() {
                    println!("{}", result.table(false));
                }
            }
            Ok(result) => {
                println!("FAIL  {}\n{}", case.name, result.table(!verbose));
                failed.push(case.name.clone());
            }
            Err(error) => {
                println!("FAIL  {}: {error}", case.name);
                failed.push(case.name.clone());
            }
        }
    }
    if failed.is_empty() {
        println!("all {} gates pass", gates.cases.len());
        Ok(())
    } else {
        anyhow::bail!(
            "{} of {} gates failed: {}",
            failed.len(),
            gates.cases.len(),
            failed.join(", ")
        )
    }
}

fn run_study(
    reference: &str,
    runs: Option<usize>,
    threads: usize,
    out: Option<&std::path::Path>,
) -> Result<()> {
    let mut study = aeroid::eval::study::Study::load(reference)?;
    if let Some(runs) = runs {
        anyhow::ensure!(runs >= 1, "--runs must be at least 1");
        study.runs = runs;
    }
    let cases = study.cases().len();
    println!(
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
    println!(
        "{} cases in {:.1} s",
        cases,
        started.elapsed().as_secs_f64()
    );
    print!("{}", result.table());
    let failures: Vec<&aeroid::eval::study::Row> = result
        .rows
        .iter()
        .filter(|r| r.status == aeroid::eval::study::FAILED)
        .collect();
    if let Some(first) = failures.first() {
        println!(
            "{} fit(s) failed; the first (point {}, run {}, {} {}): {}",
            failures.len(),
            first.point,
            first.run,
            first.model,
            first.method,
            first.reason
        );
    }
    if let Some(out) = out {
        result.write(out)?;
        println!(
            "written: {0}/runs.csv, {0}/summary.csv, {0}/study.json",
            out.display()
        );
    }
    Ok(())
}

#[cfg(feature = "jsbsim")]
fn export_jsbsim(reference: &str, out: &std::path::Path, jsbsim_atmosphere: bool) -> Result<()> {
    use aeroid::jsbsim::export::{ExportOptions, export};
    let path = catalog::resolve(reference, catalog::AIRCRAFT_FOLDER, None)?;
    let aircraft = aeroid::sim::aircraft::Aircraft::load(&path)?;
    let options = ExportOptions {
        aeroid_atmosphere: !jsbsim_atmosphere,
        ..ExportOptions::default()
    };
    let file = export(&aircraft, &options, out)?;
    println!(
        "{}: JSBSim aircraft written to {} (load it with aircraft path {})",
        aircraft.name,
        file.display(),
        out.display()
    );
    Ok(())
}

#[cfg(feature = "jsbsim")]
fn crosscheck(
    reference: &str,
    duration: Option<&str>,
    jsbsim_atmosphere: bool,
    substeps: usize,
) -> Result<()> {
    use aeroid::jsbsim::crosscheck::{CrossCheckOptions, crosscheck};
    let scenario = Scenario::load(reference)?;
    let duration = duration
        .map(|text| {
            aeroid::units::Quantity::Text(text.to_string())
                .si(aeroid::units::Dimension::Time)
                .map_err(|message| anyhow::anyhow!("--duration '{text}': {message}"))
        })
        .transpose()?;
    let options = CrossCheckOptions {
        duration,
        jsbsim_atmosphere,
        substeps,
    };
    let check = crosscheck(&scenario, &options)?;
    println!(
        "{}: {} s, {} steps of {} s, aeroid (RK4) vs JSBSim {} (Adams-Bashforth 3, {} substeps), no wind",
        check.scenario,
        check.duration,
        check.steps,
        check.step,
        aeroid::jsbsim::VERSION,
        check.substeps
    );
    println!(
        "{:<9} {:>14} {:>10} {:>14} {:>10}",
        "state", "max |diff|", "at t (s)", "excursion", "diff/exc"
    );
    for d in &check.differences {
        let relative = d
            .relative
            .map_or_else(|| "-".to_string(), |r| format!("{:.3} %", 100.0 * r));
        println!(
            "{:<9} {:>14} {:>10.2} {:>14} {:>10}",
            d.name,
            format!("{:.3e} {}", d.max_difference, d.unit),
            d.time_of_max,
            format!("{:.3e} {}", d.excursion, d.unit),
            relative
        );
    }
    println!(
        "steps per second: aeroid {:.0}, JSBSim {:.0}",
        check.aeroid_steps_per_second, check.jsbsim_steps_per_second
    );
    Ok(())
}
