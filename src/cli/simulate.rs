//! `aeroid simulate`: trim and fly a scenario, write its truth trace.

use aeroid::sim::scenario::Scenario;
use anyhow::{Context, Result};
use std::path::PathBuf;

/// Fly a scenario and write its truth trace.
///
/// Trim and fly a scenario; write the truth trace (every state, air data,
/// control and aerodynamic coefficient at every integration step) as CSV.
/// A flight that departs writes the trace up to its departure and fails.
#[derive(clap::Args)]
pub struct Args {
    /// A bundled scenario name (see `aeroid list`) or a path to a scenario file.
    scenario: String,
    /// The CSV file to write; its header names every column and its unit.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let Args { scenario, out } = args;
    aeroid::paths::check_output_file(&out)?;
    aeroid::paths::check_not_input(&out, &[std::path::Path::new(&scenario)], &[])?;
    let scenario = Scenario::load(&scenario)?;
    let started = std::time::Instant::now();
    let flight = aeroid::sim::simulate(&scenario)?;
    let trace = &flight.trace;
    match &flight.departure {
        None => {
            trace.write_csv(&out)?;
            outln!(
                "{}: {} samples over {} s in {:.3} s; truth trace written to {}",
                scenario.name,
                trace.samples.len(),
                trace.duration(),
                started.elapsed().as_secs_f64(),
                out.display()
            );
            Ok(())
        }
        Some(departure) => {
            trace.write_csv(&out).context("writing the partial trace")?;
            anyhow::bail!(
                "simulation departed at t = {:.3} s: {}; the {} samples before departure are in {}",
                departure.time,
                departure.reason,
                trace.samples.len(),
                out.display()
            )
        }
    }
}
