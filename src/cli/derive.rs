//! `aeroid derive`: add the geometric angle of attack and sideslip to a record.

use aeroid::prep::flow_angles::{Wind, with_geometric_flow_angles};
use aeroid::units::DEG;
use anyhow::{Context, Result};
use std::path::PathBuf;

/// Add the geometric angle of attack and sideslip (Wang et al. 2012,
/// Eqs. 1–6) from ground speed, track, flight-path angle, attitude and
/// the recorded wind, and write the record with them. A recorded alpha or
/// beta that the quality check finds stuck or stepping is replaced; a
/// usable one is kept and the geometric one added as alpha_geometric,
/// beta_geometric (unless --replace). See docs/cli.md.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder.
    record: PathBuf,
    /// The record folder to write.
    #[arg(long)]
    out: PathBuf,
    /// Relative to the ground: leave the recorded wind out (wind_speed and
    /// wind_direction are then not needed).
    #[arg(long)]
    no_wind_correction: bool,
    /// Replace a usable recorded alpha or beta too.
    #[arg(long)]
    replace: bool,
}

pub fn run(args: Args) -> Result<()> {
    aeroid::paths::check_output_folder(&args.out)?;
    let record = aeroid::record::FlightRecord::read(&args.record)?;
    let wind = match args.no_wind_correction {
        true => Wind::Uncorrected,
        false => Wind::Corrected,
    };
    let derivation = with_geometric_flow_angles(&record, wind, args.replace)
        .with_context(|| args.record.display().to_string())?;
    derivation.record.write(&args.out)?;
    let angles = &derivation.angles;
    outln!(
        "geometric angle of attack and sideslip{}: {} samples at the instants of {}",
        match wind {
            Wind::Corrected => "",
            Wind::Uncorrected => " (without wind correction)",
        },
        angles.alpha.times.len(),
        angles.time_base
    );
    for note in &derivation.notes {
        outln!("  {note}");
    }
    outln!(
        "  error from the channels' resolution (first order, RMS over the record): alpha {:.3} deg, beta {:.3} deg",
        angles.predicted_sigma.0 / DEG,
        angles.predicted_sigma.1 / DEG
    );
    outln!("record written to {}", args.out.display());
    Ok(())
}
