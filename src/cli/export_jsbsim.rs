//! `aeroid export-jsbsim` (feature `jsbsim`): an aircraft as a JSBSim aircraft.

use aeroid::catalog;
use anyhow::Result;
use std::path::PathBuf;

/// Write an aircraft as a JSBSim aircraft.
///
/// Write an aircraft as a JSBSim aircraft (DIR/NAME/NAME.xml): the same
/// mass, inertia, geometry, thrust and linear aerodynamics, the
/// aerodynamics as JSBSim functions (needs the `jsbsim` feature).
#[derive(clap::Args)]
pub struct Args {
    /// A bundled aircraft name (see `aeroid list`) or a path to an aircraft file.
    aircraft: String,
    /// The folder to write the JSBSim aircraft folder into.
    #[arg(long)]
    out: PathBuf,
    /// Keep JSBSim's standard atmosphere (geopotential altitude) instead of
    /// overriding it with aeroid's ISA.
    #[arg(long)]
    jsbsim_atmosphere: bool,
}

pub fn run(args: Args) -> Result<()> {
    use aeroid::jsbsim::export::{ExportOptions, export};
    let Args {
        aircraft: reference,
        out,
        jsbsim_atmosphere,
    } = args;
    aeroid::paths::check_output_folder(&out)?;
    let path = catalog::resolve(&reference, catalog::AIRCRAFT_FOLDER, None)?;
    let aircraft = aeroid::sim::aircraft::Aircraft::load(&path)?;
    let options = ExportOptions {
        aeroid_atmosphere: !jsbsim_atmosphere,
        ..ExportOptions::default()
    };
    let file = export(&aircraft, &options, &out)?;
    outln!(
        "{}: JSBSim aircraft written to {} (load it with aircraft path {})",
        aircraft.name,
        file.display(),
        out.display()
    );
    Ok(())
}
