//! `aeroid methods`: the registered estimators.

use aeroid::estimation::registry::Registry;
use anyhow::Result;

/// List the estimators with their papers and settings.
///
/// List every estimator with its paper, the equations it implements, what
/// it needs and its settings (`[methods.NAME]` keys with their defaults);
/// with a name, show that one.
#[derive(clap::Args)]
pub struct Args {
    /// One method's name.
    name: Option<String>,
}

pub fn run(args: Args, registry: &Registry) -> Result<()> {
    for problem in registry.plugin_problems() {
        eprintln!("warning: {problem}");
    }
    let estimators = match &args.name {
        Some(name) => vec![registry.find(name)?],
        None => registry.all().iter().collect(),
    };
    for estimator in estimators {
        let (name, info) = (estimator.name(), estimator.info());
        outln!("{name}: {}", info.title);
        outln!("  paper:     {}", info.paper);
        outln!("  equations: {}", info.equations);
        outln!("  needs:     {}", info.needs);
        if let Some(from) = estimator.capabilities().starts_from {
            outln!("  starts from {from}'s estimate where it has one");
        }
        outln!("  settings ([methods.{name}]):");
        for setting in &info.settings {
            outln!(
                "    {} = {}   # {}",
                setting.name,
                setting.default,
                setting.meaning
            );
        }
        outln!();
    }
    Ok(())
}
