//! Settings of a filter-error run (the `[methods.fem]` table): the start,
//! the gain, the form of R, the states driven by process noise, P0.

use super::*;

/// Settings of a filter-error run: the `[methods.fem]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FilterErrorOptions {
    pub start: Start,
    pub max_iterations: usize,
    /// Integration step (s); None: the fastest compared channel's period.
    #[serde(
        deserialize_with = "aeroid_core::units::optional_seconds",
        skip_serializing_if = "Option::is_none"
    )]
    pub step: Option<f64>,
    /// How each input is interpolated inside an integration step
    /// ([`InputInterpolation`]; default: chosen per input from its samples).
    pub interpolation: InputInterpolation,
    /// The integrated states driven by process noise (one F entry each);
    /// None: every integrated state but roll, pitch, yaw, altitude and χ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub process_noise: Option<Vec<String>>,
    /// The filter in the loop: the steady-state gain of the system
    /// linearised at the first point, or the time-varying extended filter.
    pub gain: Gain,
    /// With the time-varying gain: the variance of the initial state's
    /// error, per integrated state (P0 diagonal; a state not named starts
    /// known, variance 0).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub initial_variance: BTreeMap<String, f64>,
    /// The steady gain's innovation covariance R: diagonal, or full where
    /// every output shares one time base ([`InnovationCovariance`]); not
    /// set: full with the steady gain ([`FilterErrorOptions::innovation_form`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub innovation_covariance: Option<InnovationForm>,
    /// Fit only this time window (s) of the record; default the whole record.
    #[serde(skip)]
    pub window: Option<(f64, f64)>,
}

impl Default for FilterErrorOptions {
    fn default() -> Self {
        FilterErrorOptions {
            start: Start::default(),
            max_iterations: 30,
            step: None,
            interpolation: InputInterpolation::default(),
            process_noise: None,
            gain: Gain::default(),
            initial_variance: BTreeMap::new(),
            innovation_covariance: None,
            window: None,
        }
    }
}

impl FilterErrorOptions {
    /// Reads and checks a `[methods.fem]` table.
    pub fn read(settings: &Settings) -> Result<FilterErrorOptions> {
        let options: FilterErrorOptions = parse_settings(METHOD, settings)?;
        options.check()?;
        Ok(options)
    }

    /// Checks the values' ranges and combinations.
    pub fn check(&self) -> Result<()> {
        check_iterations(METHOD, self.step, self.max_iterations)?;
        check_initial_variance(METHOD, self.gain, &self.initial_variance)?;
        self.interpolation.check_controls(METHOD)?;
        if self.gain == Gain::TimeVarying
            && self.innovation_covariance == Some(InnovationForm::Full)
        {
            return Err(Error::Setting { method: METHOD.to_string(), reason: "innovation_covariance = \"full\" needs gain = \"steady\": the time-varying filter's innovation covariance C·P̃·Cᵀ + G·Gᵀ is full already".to_string() });
        }
        Ok(())
    }

    /// The form of R: as set, else full with the steady gain (the
    /// time-varying gain's innovation covariance is full already).
    pub fn innovation_form(&self) -> InnovationForm {
        self.innovation_covariance.unwrap_or(match self.gain {
            Gain::Steady => InnovationForm::Full,
            Gain::TimeVarying => InnovationForm::Diagonal,
        })
    }

    /// The options a model file's `[methods.fem]` table sets.
    pub fn for_structure(structure: &ModelStructure) -> Result<FilterErrorOptions> {
        FilterErrorOptions::read(&merge_settings(METHOD, &[&structure.methods]))
    }
}
