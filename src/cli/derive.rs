//! `aeroid derive`: add the channels a recorder lacks (combined surfaces,
//! geometric angle of attack and sideslip, body rates) to a record.

use aeroid::prep::angular_rates::DEFAULT_DIFFERENTIATOR;
use aeroid::prep::derive::{Options, RatesChoice, derive};
use aeroid::prep::differentiation::Differentiator;
use aeroid::prep::flow_angles::Wind;
use aeroid::prep::thrust::FuelFlowThrust;
use aeroid::units::DEG;
use anyhow::{Context, Result};
use std::path::PathBuf;

/// Add the channels a recorder lacks (flow angles, rates, combined surfaces, thrust).
///
/// Add the channels a recorder lacks and write the record with them:
/// combined aileron, elevator and flap from split left/right channels; the
/// geometric angle of attack and sideslip (Wang et al. 2012, Eqs. 1–6)
/// from ground speed, track, flight-path angle, attitude and the recorded
/// wind; and, when p, q or r is absent, the body rates from the
/// differentiated attitude. A recorded alpha or beta that the quality
/// check finds stuck or stepping is replaced; a usable one is kept and the
/// geometric one added as alpha_geometric, beta_geometric (unless
/// --replace); on request the thrust from the fuel flow. See docs/cli.md.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder.
    record: PathBuf,
    /// The record folder to write.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    options: DeriveFlags,
}

/// The derive step's options, shared by `aeroid derive` and `aeroid run --derive`.
#[derive(clap::Args)]
pub struct DeriveFlags {
    /// Relative to the ground: leave the recorded wind out (wind_speed and
    /// wind_direction are then not needed).
    #[arg(long)]
    no_wind_correction: bool,
    /// Do not derive the angle of attack and sideslip.
    #[arg(long, conflicts_with = "no_wind_correction")]
    no_flow_angles: bool,
    /// Derive the body rates even when p, q and r are recorded (added as
    /// p_kinematic, q_kinematic, r_kinematic unless --replace).
    #[arg(long, conflicts_with = "no_rates")]
    rates: bool,
    /// Do not derive the body rates.
    #[arg(long)]
    no_rates: bool,
    /// Half-width of the attitude differentiator's window, in seconds
    /// (rounded to whole samples, at least enough for the degree).
    #[arg(long, default_value_t = DEFAULT_DIFFERENTIATOR.half_width)]
    rates_half_width: f64,
    /// Degree of the attitude differentiator's local polynomial.
    #[arg(long, default_value_t = DEFAULT_DIFFERENTIATOR.degree)]
    rates_degree: usize,
    /// Replace a usable recorded alpha, beta (and p, q, r with --rates) too.
    #[arg(long)]
    replace: bool,
    /// Add a `thrust` channel (N) from the engines' fuel flow
    /// (`fuel_flow` or `fuel_flow_*`, kg/s) with this thrust-specific fuel
    /// consumption in kg/(N·s): T = Σ (flow − idle)/TSFC. The engine model
    /// is yours; an error in it scales the thrust (docs/cli.md).
    #[arg(long, value_name = "TSFC")]
    thrust_from_fuel_flow: Option<f64>,
    /// Fuel flow at zero thrust, kg/s per engine (with --thrust-from-fuel-flow).
    #[arg(long, default_value_t = 0.0, requires = "thrust_from_fuel_flow")]
    idle_fuel_flow: f64,
}

impl DeriveFlags {
    /// The derive step's options these flags state.
    pub fn options(&self) -> Options {
        Options {
            flow_angles: match (self.no_flow_angles, self.no_wind_correction) {
                (true, _) => None,
                (false, true) => Some(Wind::Uncorrected),
                (false, false) => Some(Wind::Corrected),
            },
            rates: match (self.rates, self.no_rates) {
                (true, _) => RatesChoice::Always,
                (_, true) => RatesChoice::Never,
                _ => RatesChoice::WhenAbsent,
            },
            differentiator: Differentiator {
                half_width: self.rates_half_width,
                degree: self.rates_degree,
            },
            replace: self.replace,
            thrust: self
                .thrust_from_fuel_flow
                .map(|specific_fuel_consumption| FuelFlowThrust {
                    specific_fuel_consumption,
                    idle_fuel_flow: self.idle_fuel_flow,
                }),
        }
    }
}

pub fn run(args: Args) -> Result<()> {
    aeroid::paths::check_output_folder(&args.out)?;
    let record = aeroid::record::FlightRecord::read(&args.record)?;
    let options = args.options.options();
    let derived = derive(&record, &options).with_context(|| args.record.display().to_string())?;
    derived.record.write(&args.out)?;
    print_summary(&derived, &options)?;
    outln!("record written to {}", args.out.display());
    Ok(())
}

/// What the derive step did, one line per derived quantity.
pub fn print_summary(derived: &aeroid::prep::derive::Derived, options: &Options) -> Result<()> {
    if let Some(angles) = &derived.angles {
        outln!(
            "geometric angle of attack and sideslip{}: {} samples at the instants of {}",
            match options.flow_angles {
                Some(Wind::Uncorrected) => " (without wind correction)",
                _ => "",
            },
            angles.alpha.times.len(),
            angles.time_base
        );
        outln!(
            "  error from the channels' resolution (first order, RMS over the record): alpha {:.3} deg, beta {:.3} deg",
            angles.predicted_sigma.0 / DEG,
            angles.predicted_sigma.1 / DEG
        );
    }
    if let Some(rates) = &derived.rates {
        let sigma = rates.resolution_sigma();
        outln!(
            "body rates from the attitude kinematics: {} samples at the instants of {}",
            rates.p.times.len(),
            rates.time_base
        );
        outln!(
            "  {}",
            rates
                .differentiator
                .describe(rates.p.rate)
                .replace("angular accelerations", "attitude derivatives")
        );
        outln!(
            "  error from the attitude's resolution (RMS over the record): p {:.3}, q {:.3}, r {:.3} deg/s",
            sigma[0] / DEG,
            sigma[1] / DEG,
            sigma[2] / DEG
        );
    }
    for note in &derived.notes {
        outln!("  {note}");
    }
    Ok(())
}
