//! `aeroid gate`: the accuracy gates.

use aeroid::estimation::registry::Registry;
use anyhow::Result;
use std::path::PathBuf;

/// Run the accuracy gates and fail on any regression.
///
/// Run the accuracy gates (golden/gates.toml in the data folder): fly,
/// record and estimate every case, check each parameter against the truth
/// within its tolerance, print what failed, and exit non-zero on any failure.
#[derive(clap::Args)]
pub struct Args {
    /// The gate file [default: golden/gates.toml in the data folder]
    #[arg(long)]
    file: Option<PathBuf>,
    /// Print every parameter's row (estimate, σ, truth, error, allowed), not only failures.
    #[arg(long)]
    verbose: bool,
    /// Run only the cases whose name contains this text.
    #[arg(long)]
    only: Option<String>,
}

pub fn run(args: Args, registry: &Registry) -> Result<()> {
    let Args {
        file,
        verbose,
        only,
    } = args;
    let file = file.unwrap_or_else(aeroid::catalog::gate_file);
    let mut gates = aeroid::eval::gate::load(registry, &file)?;
    if let Some(text) = &only {
        let names: Vec<String> = gates.cases.iter().map(|case| case.name.clone()).collect();
        gates.cases.retain(|case| case.name.contains(text.as_str()));
        if gates.cases.is_empty() {
            anyhow::bail!(
                "--only '{text}' matches no case of {}; cases: {}",
                file.display(),
                names.join(", ")
            );
        }
    }
    let mut failed = Vec::new();
    for case in &gates.cases {
        match aeroid::eval::gate::run_case(registry, case) {
            Ok(result) if result.passed() => {
                match &result.refusal {
                    Some(refusal) => {
                        outln!("pass  {:<34} refused as expected: {refusal}", case.name)
                    }
                    None => {
                        let (ok, unidentifiable, known) = result.counts();
                        outln!(
                            "pass  {:<34} {ok} of {} terms ok (worst at {:.0} % of its tolerance), {unidentifiable} not identifiable, {known} known failures",
                            case.name,
                            result.rows.len(),
                            100.0 * result.worst()
                        )
                    }
                }
                if verbose && result.refusal.is_none() {
                    outln!("{}", result.table(false));
                }
            }
            Ok(result) => {
                outln!("FAIL  {}\n{}", case.name, result.table(!verbose));
                failed.push(case.name.clone());
            }
            Err(error) => {
                outln!("FAIL  {}: {error}", case.name);
                failed.push(case.name.clone());
            }
        }
    }
    if failed.is_empty() {
        outln!("all {} gates pass", gates.cases.len());
        Ok(())
    } else {
        anyhow::bail!(
            "{} of {} gates failed: {}",
            failed.len(),
            gates.cases.len(),
            failed.join(", ")
        )
    }
}
