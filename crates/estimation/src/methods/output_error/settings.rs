//! What output error is asked to do: its start, stages, integration and bounds (`[methods.oem]`).

use super::*;

/// Settings of an output-error run: the `[methods.oem]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputErrorOptions {
    pub start: Start,
    pub max_iterations: usize,
    /// Integration step (s); None: the fastest compared channel's period,
    /// in equal sub-steps where the model's fastest mode needs them
    /// (`crate::model::state_space::driven_simulation`),
    /// re-chosen at every iteration for the parameters there.
    #[serde(
        deserialize_with = "aeroid_core::units::optional_seconds",
        skip_serializing_if = "Option::is_none"
    )]
    pub step: Option<f64>,
    /// How each input is interpolated inside an integration step
    /// ([`InputInterpolation`]; default: chosen per input from its samples).
    pub interpolation: InputInterpolation,
    /// Initial values of the integrated states as unknowns (per manoeuvre).
    pub estimate_initial_state: bool,
    /// Outputs with a constant bias as an unknown.
    pub output_biases: Vec<String>,
    /// Fit only this time window (s) of every record; default the whole record.
    #[serde(skip)]
    pub window: Option<(f64, f64)>,
    /// Fits from this many starts ([`multi_start`]); 1: one fit.
    pub starts: usize,
    /// The extra starts move each free parameter by up to this fraction of
    /// its magnitude (at least 0.01).
    pub start_spread: f64,
    /// Seed of the extra starts' random stream.
    pub start_seed: u64,
    /// Split each record's fitting window into pieces of about this length
    /// (s), each simulated from its own initial state (multiple shooting);
    /// none: one piece per record.
    #[serde(
        deserialize_with = "aeroid_core::units::optional_seconds",
        skip_serializing_if = "Option::is_none"
    )]
    pub segment: Option<f64>,
    /// Lag (s) to which the residuals' autocorrelation is summed in the
    /// Cramér–Rao bounds (Morelli & Klein 1997); 0: the bounds assume
    /// white residuals.
    #[serde(deserialize_with = "aeroid_core::units::seconds")]
    pub correlation_lag: f64,
    /// The standard deviation of each recorded input's noise, by channel
    /// (e.g. `elevator = "0.01 deg"`): the Cramér–Rao bounds then include
    /// what that noise does to the estimates (`Objective::input_noise_bounds`);
    /// empty: the inputs are taken as exact, as output error's likelihood
    /// takes them.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub input_noise: BTreeMap<String, Quantity>,
    /// Simulated draws of the inputs' noise that measure its share of the
    /// bounds (the share's standard deviations within about 1/√(2·draws)).
    pub input_noise_draws: usize,
    /// Seed of those draws' random stream.
    pub input_noise_seed: u64,
}

/// The most starts a fit takes: a thousand fits of a second each take a
/// quarter of an hour; more is a typo.
pub(crate) const MAX_STARTS: usize = 1000;

/// The widest spread of the extra starts, as a fraction of each
/// parameter's magnitude: tenfold; beyond it a start is no longer near the
/// model file's values.
pub(crate) const MAX_START_SPREAD: f64 = 10.0;

/// The most simulated draws of the inputs' noise: 100 000 put the share's
/// standard deviations within 0.2 %; more only costs time.
pub(crate) const MAX_DRAWS: usize = 100_000;

impl Default for OutputErrorOptions {
    fn default() -> Self {
        OutputErrorOptions {
            start: Start::default(),
            max_iterations: 30,
            step: None,
            interpolation: InputInterpolation::default(),
            estimate_initial_state: false,
            output_biases: Vec::new(),
            window: None,
            starts: 1,
            start_spread: 0.5,
            start_seed: 1,
            segment: None,
            correlation_lag: 0.0,
            input_noise: BTreeMap::new(),
            input_noise_draws: 200,
            input_noise_seed: 1,
        }
    }
}

impl OutputErrorOptions {
    /// The options a model file's `[methods.oem]` table sets.
    pub fn for_structure(structure: &ModelStructure) -> Result<OutputErrorOptions> {
        OutputErrorOptions::read(&merge_settings(METHOD, &[&structure.methods]))
    }

    /// Reads and checks a `[methods.oem]` table.
    pub fn read(settings: &Settings) -> Result<OutputErrorOptions> {
        let options: OutputErrorOptions = parse_settings(METHOD, settings)?;
        options.check()?;
        Ok(options)
    }

    /// Checks the values' ranges and combinations.
    pub fn check(&self) -> Result<()> {
        check_iterations(METHOD, self.step, self.max_iterations)?;
        if !(1..=MAX_STARTS).contains(&self.starts) {
            return Err(Error::Settings {
                method: METHOD.to_string(),
                reason: format!("starts must be from 1 to {MAX_STARTS}, is {}", self.starts),
            });
        }
        if self
            .segment
            .is_some_and(|length| !(length > 0.0 && length.is_finite()))
        {
            return Err(Error::Settings {
                method: METHOD.to_string(),
                reason: "segment must be a positive duration".to_string(),
            });
        }
        if !(self.correlation_lag >= 0.0 && self.correlation_lag.is_finite()) {
            return Err(Error::Settings {
                method: METHOD.to_string(),
                reason: "correlation_lag must be a duration of 0 s or more".to_string(),
            });
        }
        self.input_sigmas()?;
        self.interpolation.check_controls(METHOD)?;
        if !self.input_noise.is_empty() && !(2..=MAX_DRAWS).contains(&self.input_noise_draws) {
            return Err(Error::Settings {
                method: METHOD.to_string(),
                reason: format!(
                    "input_noise_draws must be from 2 to {MAX_DRAWS}, is {}",
                    self.input_noise_draws
                ),
            });
        }
        if !(self.start_spread > 0.0 && self.start_spread <= MAX_START_SPREAD) {
            return Err(Error::Settings {
                method: METHOD.to_string(),
                reason: format!(
                    "start_spread must be a positive fraction of at most {MAX_START_SPREAD}, is {}",
                    self.start_spread
                ),
            });
        }
        Ok(())
    }

    /// `input_noise` in SI units (each channel's own), checked: a known
    /// quantity, a finite standard deviation of 0 or more.
    pub fn input_sigmas(&self) -> Result<Vec<(String, f64)>> {
        self.input_noise
            .iter()
            .map(|(name, noise)| {
                let measurand =
                    aeroid_record::derived::measurand(name).ok_or_else(|| Error::Setting {
                        method: METHOD.to_string(),
                        reason: format!("input_noise: unknown channel '{name}'"),
                    })?;
                let sigma = noise.si(measurand.dimension).map_err(|e| Error::Setting {
                    method: METHOD.to_string(),
                    reason: format!("input_noise.{name}: {e}"),
                })?;
                if sigma < 0.0 {
                    return Err(Error::Setting {
                        method: METHOD.to_string(),
                        reason: format!(
                            "input_noise.{name}: a standard deviation must not be negative"
                        ),
                    });
                }
                Ok((name.clone(), sigma))
            })
            .collect()
    }
}
