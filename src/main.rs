//! The `aeroid` command line: parse, dispatch to one subcommand (`cli/`),
//! exit. Only the command line prints and exits.

mod cli;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "aeroid",
    version,
    about = "Simulate aircraft manoeuvres, record them like a flight recorder, and check whether estimators recover the aerodynamic parameters",
    after_help = "Bundled files (aircraft/, scenarios/, recorders/, models/, studies/, golden/) are found by name in the data folder: the folder named by the environment variable AEROID_DATA, else the current folder if it holds aircraft/ or scenarios/, else the source tree aeroid was built from. `aeroid list` shows it."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Simulate(cli::simulate::Args),
    List(cli::list::Args),
    Methods(cli::methods::Args),
    Check(cli::check::Args),
    Record(cli::record::Args),
    Import(cli::import::Args),
    Export(cli::export::Args),
    Inspect(cli::inspect::Args),
    Derive(cli::derive::Args),
    Run(cli::run::Args),
    Reconstruct(cli::reconstruct::Args),
    Identifiability(cli::identifiability::Args),
    Linearise(cli::linearise::Args),
    Gate(cli::gate::Args),
    Study(cli::study::Args),
    Report(cli::report::Args),
    Plugin(cli::plugin::Args),
    Estimate(cli::estimate::Args),
    ExportJsbsim(cli::export_jsbsim::Args),
    Crosscheck(cli::crosscheck::Args),
}

fn main() -> ExitCode {
    #[cfg(feature = "jsbsim")]
    aeroid::jsbsim::register();
    let command = Cli::parse().command;
    // The estimators: the built-in ones, then the plug-ins of the plug-in
    // folders, found once for whichever command runs a method.
    let registry = || aeroid::estimation::registry::Registry::with_plugins();
    let result = match command {
        Command::Simulate(args) => cli::simulate::run(args),
        Command::List(args) => cli::list::run(args),
        Command::Methods(args) => cli::methods::run(args, &registry()),
        Command::Check(args) => cli::check::run(args, &registry()),
        Command::Record(args) => cli::record::run(args),
        Command::Import(args) => cli::import::run(args),
        Command::Export(args) => cli::export::run(args),
        Command::Inspect(args) => cli::inspect::run(args),
        Command::Derive(args) => cli::derive::run(args),
        Command::Run(args) => cli::run::run(args, &registry()),
        Command::Reconstruct(args) => cli::reconstruct::run(args),
        Command::Identifiability(args) => cli::identifiability::run(args),
        Command::Linearise(args) => cli::linearise::run(args),
        Command::Gate(args) => cli::gate::run(args, &registry()),
        Command::Study(args) => cli::study::run(args, &registry()),
        Command::Report(args) => cli::report::run(args),
        Command::Plugin(args) => cli::plugin::run(args),
        Command::Estimate(args) => cli::estimate::run(args, &registry()),
        Command::ExportJsbsim(args) => cli::export_jsbsim::run(args),
        Command::Crosscheck(args) => cli::crosscheck::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of the output went away (`| head`): nothing left to say.
        Err(error) if cli::is_closed_pipe(&error) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {}", cli::message(&error));
            ExitCode::FAILURE
        }
    }
}
