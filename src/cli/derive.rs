//! `aeroid derive`: add the channels a recorder lacks (combined surfaces,
//! geometric angle of attack and sideslip, body rates) to a record, and on
//! request the aerodynamic coefficients from the measured accelerations.

use aeroid::estimation::coefficient_channels::coefficient_channels;
use aeroid::estimation::reconstruction::{AngularAccelerations, ReconstructionOptions};
use aeroid::prep::angular_rates::DEFAULT_DIFFERENTIATOR;
use aeroid::prep::derive::{Options, RatesChoice, derive};
use aeroid::prep::differentiation::Differentiator;
use aeroid::prep::flow_angles::Wind;
use aeroid::prep::thrust::FuelFlowThrust;
use aeroid::units::DEG;
use anyhow::{Context, Result, bail};
use nalgebra::Vector3;
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
/// --replace); on request the thrust from the fuel flow, and with
/// --coefficients the aerodynamic coefficients CX, CY, CZ, CL, CD, Cl, Cm,
/// Cn from the measured accelerations. See docs/cli.md.
#[derive(clap::Args)]
pub struct Args {
    /// The record folder.
    record: PathBuf,
    /// The record folder to write.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    options: DeriveFlags,
    #[command(flatten)]
    coefficients: CoefficientFlags,
}

/// The options of the coefficients from the measured accelerations.
#[derive(clap::Args)]
pub struct CoefficientFlags {
    /// Add the aerodynamic coefficients CX, CY, CZ, CL, CD, Cl, Cm, Cn
    /// computed from the measured accelerations with this aircraft's mass,
    /// inertia, geometry and engine (a bundled name or a file).
    #[arg(long, value_name = "AIRCRAFT")]
    coefficients: Option<String>,
    /// The accelerometers' position relative to the centre of gravity,
    /// body axes, in metres ("x,y,z"; x forward, y right, z down): the
    /// load factors are carried to the CG. Default: at the CG.
    #[arg(
        long,
        value_name = "X,Y,Z",
        requires = "coefficients",
        allow_hyphen_values = true
    )]
    accelerometer_position: Option<String>,
    /// Where the angular accelerations of the moments come from:
    /// `differentiated` (the rates, by the smoothing differentiator),
    /// `measured` (the record's q_dot for Cm, p_dot and r_dot for Cl and
    /// Cn, all three with an accelerometer position) or `auto` (measured
    /// when the record has them).
    #[arg(
        long,
        value_name = "SOURCE",
        default_value = "differentiated",
        requires = "coefficients"
    )]
    angular_accelerations: String,
    /// Half-width of the rates' differentiator window, in seconds.
    #[arg(long, value_name = "S", requires = "coefficients")]
    acceleration_half_width: Option<f64>,
    /// Degree of the rates' differentiator's local polynomial.
    #[arg(long, value_name = "D", requires = "coefficients")]
    acceleration_degree: Option<usize>,
}

impl CoefficientFlags {
    /// The reconstruction's options these flags state.
    fn options(&self) -> Result<ReconstructionOptions> {
        let angular_accelerations = match self.angular_accelerations.as_str() {
            "differentiated" => AngularAccelerations::Differentiated,
            "measured" => AngularAccelerations::Measured,
            "auto" => AngularAccelerations::Auto,
            other => bail!(
                "--angular-accelerations {other:?}: expected differentiated, measured or auto"
            ),
        };
        let accelerometer_position = match &self.accelerometer_position {
            None => Vector3::zeros(),
            Some(text) => parse_position(text)?,
        };
        let mut differentiator = Differentiator::default();
        if let Some(half_width) = self.acceleration_half_width {
            differentiator.half_width = half_width;
        }
        if let Some(degree) = self.acceleration_degree {
            differentiator.degree = degree;
        }
        if let Some(problem) = differentiator.check() {
            bail!("--acceleration-half-width / --acceleration-degree: {problem}");
        }
        Ok(ReconstructionOptions {
            differentiator: Some(differentiator),
            angular_accelerations,
            accelerometer_position,
            ..ReconstructionOptions::default()
        })
    }
}

/// "x,y,z" in metres, each finite.
fn parse_position(text: &str) -> Result<Vector3<f64>> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let numbers: Vec<f64> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match numbers[..] {
        [x, y, z]
            if parts.len() == 3 && numbers.iter().all(|v| v.is_finite() && v.abs() <= 1e3) =>
        {
            Ok(Vector3::new(x, y, z))
        }
        _ => bail!(
            "--accelerometer-position {text:?}: expected three distances in metres, \"x,y,z\", each within ±1000 m"
        ),
    }
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
    let coefficient_options = args.coefficients.options()?;
    let aircraft = match &args.coefficients.coefficients {
        Some(reference) => {
            let path = aeroid::catalog::resolve(reference, aeroid::catalog::AIRCRAFT_FOLDER, None)?;
            Some(aeroid::sim::aircraft::Aircraft::load(&path)?)
        }
        None => None,
    };
    let record = aeroid::record::FlightRecord::read(&args.record)?;
    let options = args.options.options();
    let mut derived =
        derive(&record, &options).with_context(|| args.record.display().to_string())?;
    print_summary(&derived, &options)?;
    if let Some(aircraft) = &aircraft {
        let computed = coefficient_channels(&derived.record, aircraft, &coefficient_options)
            .with_context(|| args.record.display().to_string())?;
        print_coefficients(&computed, &aircraft.name)?;
        if computed.channels.is_empty() {
            bail!(
                "{}: no coefficient can be computed from this record (the channels each lacks are listed above)",
                args.record.display()
            );
        }
        for line in computed.add_to(&mut derived.record, options.replace) {
            outln!("  {line}");
        }
    }
    derived.record.write(&args.out)?;
    outln!("record written to {}", args.out.display());
    Ok(())
}

/// What the coefficient step computed, from what, and what it left out.
fn print_coefficients(
    computed: &aeroid::estimation::coefficient_channels::CoefficientChannels,
    aircraft: &str,
) -> Result<()> {
    let names: Vec<&str> = computed.channels.iter().map(|c| c.name.as_str()).collect();
    outln!(
        "aerodynamic coefficients from the measured accelerations ({aircraft}'s mass, inertia and geometry): {}",
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    );
    for note in &computed.notes {
        outln!("  {note}");
    }
    for (name, missing) in &computed.left_out {
        outln!(
            "  {name}: left out, the record has no {}",
            missing.join(", ")
        );
    }
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
