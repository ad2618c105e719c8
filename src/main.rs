//! The `aeroid` command line. Only this file prints and exits.

use aeroid::catalog;
use aeroid::scenario::Scenario;
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
    /// List the bundled aircraft and scenarios.
    List,
    /// Validate an aircraft or scenario file and explain every problem; a
    /// scenario is also trimmed.
    Check {
        /// The file to check.
        file: PathBuf,
    },
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
            for folder in [catalog::AIRCRAFT_FOLDER, catalog::SCENARIO_FOLDER] {
                println!("{folder}:");
                for name in catalog::bundled(folder) {
                    println!("  {name}");
                }
            }
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
