//! `export-jsbsim` and `crosscheck` in a build without the `jsbsim`
//! feature: declared, so that they are listed and explain what they need.

/// The error of a command that needs the `jsbsim` feature.
fn needs_jsbsim() -> anyhow::Error {
    anyhow::anyhow!(
        "this command needs the jsbsim feature: build with `cargo build --release --features jsbsim`"
    )
}

pub mod export_jsbsim {
    /// Write an aircraft as a JSBSim aircraft (needs the `jsbsim` feature).
    ///
    /// Write an aircraft as a JSBSim aircraft (needs the `jsbsim` feature,
    /// which this build lacks: build with `cargo build --release --features jsbsim`).
    #[derive(clap::Args)]
    pub struct Args {
        #[arg(hide = true, trailing_var_arg = true, allow_hyphen_values = true)]
        arguments: Vec<String>,
    }

    pub fn run(_: Args) -> anyhow::Result<()> {
        Err(super::needs_jsbsim())
    }
}

pub mod crosscheck {
    /// Fly a scenario in aeroid's simulator and in JSBSim (needs the `jsbsim` feature).
    ///
    /// Fly a scenario in aeroid's simulator and in JSBSim and compare them
    /// (needs the `jsbsim` feature, which this build lacks: build with
    /// `cargo build --release --features jsbsim`).
    #[derive(clap::Args)]
    pub struct Args {
        #[arg(hide = true, trailing_var_arg = true, allow_hyphen_values = true)]
        arguments: Vec<String>,
    }

    pub fn run(_: Args) -> anyhow::Result<()> {
        Err(super::needs_jsbsim())
    }
}
