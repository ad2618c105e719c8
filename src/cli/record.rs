//! `aeroid record`: fly a scenario and record it with a recorder profile.

use aeroid::sim::scenario::Scenario;
use anyhow::Result;
use std::path::PathBuf;

/// Fly a scenario and record it with a recorder profile.
///
/// Fly a scenario and record it with a recorder profile: write the flight
/// record (record.toml + CSV per time base) and the run's truth.toml.
#[derive(clap::Args)]
pub struct Args {
    /// A bundled scenario name or a path to a scenario file.
    scenario: String,
    /// A bundled recorder profile (recorders/) or a path; default: the
    /// scenario's `recorder`, else `ideal`.
    #[arg(long)]
    profile: Option<String>,
    /// The record folder to write.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let Args {
        scenario,
        profile,
        out,
    } = args;
    aeroid::paths::check_output_folder(&out)?;
    let scenario = Scenario::load(&scenario)?;
    let profile = aeroid::record::recorder::profile_for(&scenario, profile.as_deref())?;
    let (record, truth) =
        aeroid::eval::linear_flight::record_flight(&scenario, &profile, scenario.seed)?;
    record.write(&out)?;
    truth.write(&out.join(aeroid::sim::truth::TRUTH_FILE))?;
    outln!(
        "{}: recorded with profile {} ({} channels); record and truth written to {}",
        scenario.name,
        profile.name,
        record.channels.len(),
        out.display()
    );
    Ok(())
}
