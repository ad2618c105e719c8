//! `aeroid reconstruct`: flight path reconstruction of a record.

use anyhow::Result;
use std::path::PathBuf;

/// Flight-path reconstruction: sensor biases and vane calibration.
///
/// Flight path reconstruction / data compatibility check: estimate
/// accelerometer and gyro biases and the flow-vane scale factors and
/// offsets from the kinematics, with their correlations (calibrations the
/// manoeuvre does not separate are diagnosed); with --out, write the
/// corrected record.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder.
    record: PathBuf,
    /// A folder for the corrected record.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    if let Some(out) = &args.out {
        aeroid::paths::check_output_folder(out)?;
    }
    let record = aeroid::record::FlightRecord::read(&args.record)?;
    let result = aeroid::estimation::compatibility::flight_path_reconstruction(&record, 30)?;
    let estimate = &result.estimate;
    outln!(
        "flight path reconstruction of {}: {:?} after {} iterations, {:.3} s",
        estimate.record,
        estimate.status,
        estimate.iterations,
        estimate.wall_time
    );
    for p in &estimate.parameters {
        outln!(
            "  {:<12} {:>14.6e} ± {:.3e}",
            p.name,
            p.value,
            p.standard_error
        );
    }
    print_correlations(estimate)?;
    for diagnosis in &estimate.diagnoses {
        outln!("  diagnosis: {diagnosis}");
    }
    for note in &estimate.notes {
        outln!("  note: {note}");
    }
    for fit in &estimate.fits {
        outln!(
            "  fit {:<10} rms {:.4e}  R² {:.5}  TIC {:.4}",
            fit.channel,
            fit.rms,
            fit.r_squared,
            fit.theil
        );
    }
    if let Some(out) = args.out {
        result.corrected.write(&out)?;
        outln!("corrected record written to {}", out.display());
    }
    Ok(())
}

/// The correlation matrix of the estimated sensor errors (the initial
/// state's left out), one row per error, two decimals.
fn print_correlations(estimate: &aeroid::estimation::estimate::Estimate) -> Result<()> {
    let correlation = estimate.correlation();
    let errors: Vec<usize> = (estimate.parameters.iter().enumerate())
        .filter(|(_, p)| !p.name.starts_with("x0."))
        .map(|(i, _)| i)
        .collect();
    outln!("  correlations of the sensor errors:");
    out!("  {:<12}", "");
    for &j in &errors {
        out!(" {:>6}", abbreviated(&estimate.parameters[j].name));
    }
    outln!();
    for &i in &errors {
        out!("  {:<12}", estimate.parameters[i].name);
        for &j in &errors {
            match correlation.get(i).and_then(|row| row.get(j)) {
                Some(r) if r.is_finite() => out!(" {r:>6.2}"),
                _ => out!(" {:>6}", "-"),
            }
        }
        outln!();
    }
    Ok(())
}

/// A column header of at most six characters.
fn abbreviated(name: &str) -> String {
    name.replace("delta_", "d").chars().take(6).collect()
}
