//! `aeroid identifiability`: a-priori Cramér–Rao bounds of a scenario.

use anyhow::Result;

/// A-priori identifiability: each parameter's Cramér–Rao bound.
///
/// A-priori identifiability: the Cramér–Rao bound of every aerodynamic
/// parameter of the scenario's aircraft that the profile's channels allow
/// (sensitivities by central differences through the simulator and the
/// recorder, measurement error from the profile's noise and resolution),
/// and whether its relative bound is below the threshold.
#[derive(clap::Args)]
pub struct Args {
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
}

pub fn run(args: Args) -> Result<()> {
    let Args {
        scenario,
        profile,
        threshold,
        parameters,
        channels,
        segment,
    } = args;
    let segment = segment
        .map(|text| {
            let seconds = aeroid::units::Quantity::Text(text.clone())
                .si(aeroid::units::Dimension::Time)
                .map_err(|e| anyhow::anyhow!("--segment: {e}"))?;
            anyhow::ensure!(
                seconds > 0.0,
                "--segment: \"{text}\" must be a positive length of time (e.g. \"20 s\"); leave it out to analyse the whole flight as one segment"
            );
            Ok(seconds)
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
    out!("{}", result.table());
    Ok(())
}
