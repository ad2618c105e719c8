//! `aeroid list`: the bundled files of the data folder.

use aeroid::catalog;
use anyhow::Result;

/// List the data folder's aircraft, scenarios, profiles, models and studies.
///
/// List the data folder's aircraft, scenarios, recorder profiles, model
/// structures and studies (the names every other subcommand accepts).
#[derive(clap::Args)]
pub struct Args {}

pub fn run(_: Args) -> Result<()> {
    outln!("data folder: {}", catalog::data_folder().display());
    for folder in catalog::LISTED_FOLDERS {
        outln!("{folder}:");
        for name in catalog::bundled(folder) {
            outln!("  {name}");
        }
    }
    Ok(())
}
