//! `aeroid linearise`: a scenario's aircraft linearised at its trim point,
//! written as a linear model file.

use aeroid::analysis::linear_model::{Axes, linearise_scenario, to_toml};
use anyhow::Result;
use std::path::PathBuf;

/// Write a scenario's linearisation as a linear model file.
///
/// Trim a scenario's aircraft and write its linearisation as a linear model
/// file (`kind = "linear"`): states V, α, β, p, q, r, φ, θ as record
/// channels, dimensional derivatives as named parameters whose values are
/// the truth of a flight of the file (a scenario's `[linear]` table).
#[derive(clap::Args)]
pub struct Args {
    /// A bundled scenario name or a path.
    scenario: String,
    /// The model file to write.
    #[arg(long)]
    model_out: PathBuf,
    /// The states kept: longitudinal, short-period, lateral or all.
    #[arg(long, value_enum, default_value = "all")]
    axes: Axes,
    /// The model's name (default: SCENARIO-linear-AXES).
    #[arg(long)]
    name: Option<String>,
}

pub fn run(args: Args) -> Result<()> {
    let Args {
        scenario,
        model_out,
        axes,
        name,
    } = args;
    aeroid::paths::check_output_file(&model_out)?;
    aeroid::paths::check_not_input(&model_out, &[std::path::Path::new(&scenario)], &[])?;
    let scenario = aeroid::sim::scenario::Scenario::load(&scenario)?;
    let mut file = linearise_scenario(&scenario, axes)?;
    if let Some(name) = name {
        file.name = name;
    }
    aeroid::error::write_text(&model_out, &to_toml(&file)?)?;
    outln!(
        "{}: states {}, inputs {}, {} parameters; written to {}",
        file.name,
        file.states.join(", "),
        file.inputs.join(", "),
        file.parameters.len(),
        model_out.display()
    );
    Ok(())
}
