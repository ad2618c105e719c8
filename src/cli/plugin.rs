//! `aeroid plugin`: what a plug-in estimator reads and writes.

use anyhow::Result;

/// Print the JSON Schema of what a plug-in writes back.
///
/// Print the JSON Schema of what a plug-in writes back: `estimate.json`
/// or `refusal.json` (docs/plugins.md describes the whole protocol).
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// The JSON Schema of estimate.json or refusal.json.
    Schema {
        /// `estimate` or `refusal`.
        #[arg(value_parser = ["estimate", "refusal"])]
        file: String,
    },
}

pub fn run(args: Args) -> Result<()> {
    match args.command {
        Command::Schema { file } => {
            let schema = match file.as_str() {
                "estimate" => aeroid::estimation::plugin::ESTIMATE_SCHEMA,
                _ => aeroid::estimation::plugin::REFUSAL_SCHEMA,
            };
            out!("{schema}");
        }
    }
    Ok(())
}
