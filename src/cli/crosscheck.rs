//! `aeroid crosscheck` (feature `jsbsim`): aeroid's simulator against JSBSim.

use aeroid::sim::scenario::Scenario;
use anyhow::Result;

/// Fly a scenario in aeroid's simulator and in JSBSim and compare them.
///
/// Fly a scenario in aeroid's simulator and in JSBSim (the exported
/// aircraft, same trim, same inputs, no wind) and print the largest
/// difference per state and both simulators' steps per second (needs the
/// `jsbsim` feature).
#[derive(clap::Args)]
pub struct Args {
    /// A bundled scenario name or a path to a scenario file.
    scenario: String,
    /// Flight time, e.g. "60 s"; default: the scenario's duration.
    #[arg(long)]
    duration: Option<String>,
    /// Keep JSBSim's standard atmosphere instead of aeroid's ISA.
    #[arg(long)]
    jsbsim_atmosphere: bool,
    /// JSBSim steps per aeroid step: its Adams-Bashforth integrators
    /// smear each input step over the derivative history.
    #[arg(long, default_value_t = aeroid::jsbsim::crosscheck::DEFAULT_SUBSTEPS)]
    substeps: usize,
}

pub fn run(args: Args) -> Result<()> {
    use aeroid::jsbsim::crosscheck::{CrossCheckOptions, crosscheck};
    let Args {
        scenario: reference,
        duration,
        jsbsim_atmosphere,
        substeps,
    } = args;
    let scenario = Scenario::load(&reference)?;
    let duration = duration
        .map(|text| {
            aeroid::units::Quantity::Text(text.clone())
                .si(aeroid::units::Dimension::Time)
                .map_err(|message| anyhow::anyhow!("--duration '{text}': {message}"))
        })
        .transpose()?;
    let options = CrossCheckOptions {
        duration,
        jsbsim_atmosphere,
        substeps,
    };
    let check = crosscheck(&scenario, &options)?;
    outln!(
        "{}: {} s, {} steps of {} s, aeroid (RK4) vs JSBSim {} (Adams-Bashforth 3, {} substeps), no wind",
        check.scenario,
        check.duration,
        check.steps,
        check.step,
        aeroid::jsbsim::VERSION,
        check.substeps
    );
    outln!(
        "{:<9} {:>14} {:>10} {:>14} {:>10}",
        "state",
        "max |diff|",
        "at t (s)",
        "excursion",
        "diff/exc"
    );
    for d in &check.differences {
        let relative = d
            .relative
            .map_or_else(|| "-".to_string(), |r| format!("{:.3} %", 100.0 * r));
        outln!(
            "{:<9} {:>14} {:>10.2} {:>14} {:>10}",
            d.name,
            format!("{:.3e} {}", d.max_difference, d.unit),
            d.time_of_max,
            format!("{:.3e} {}", d.excursion, d.unit),
            relative
        );
    }
    outln!(
        "steps per second: aeroid {:.0}, JSBSim {:.0}",
        check.aeroid_steps_per_second,
        check.jsbsim_steps_per_second
    );
    Ok(())
}
