//! The setup of an augmented filter's passes: the checks of the record,
//! structure and settings, the state-space view, the start values, the
//! measurement noise from the outputs' spectra, the prior covariance and
//! the parameters' pseudonoise (the parent module's header).

use super::*;

/// What every pass shares: the model view, the start, the prior, the
/// observations and the noise floors.
pub(super) struct Setup {
    pub(super) view: Box<dyn StateSpaceModel>,
    pub(super) state_names: Vec<String>,
    pub(super) x0: DVector<f64>,
    /// Every aerodynamic parameter, the free ones at their start.
    pub(super) theta: Vec<f64>,
    /// Indices of the free parameters in θ.
    pub(super) free: Vec<usize>,
    pub(super) names: Vec<String>,
    pub(super) observations: Observations,
    pub(super) prior: DMatrix<f64>,
    /// Pseudonoise intensity per free parameter.
    pub(super) pseudonoise: Vec<f64>,
    /// Fourier R per output and its floor.
    pub(super) measurement: Vec<f64>,
    pub(super) floors: Vec<f64>,
    pub(super) notes: Vec<String>,
}

/// Refuses what no augmented filter can run on.
fn check(method: &str, record: &FlightRecord, structure: Filtered) -> Result<()> {
    let missing = match structure {
        Filtered::SixDof(s) => missing_channels(record, s),
        Filtered::Linear(s) => s.missing_channels(record),
    };
    let free = structure.parameters().free;
    free_parameters(method, record, missing, structure.name(), free)?;
    if let Filtered::SixDof(s) = structure {
        unsuitable(method, s)?;
    }
    Ok(())
}

/// The start θ and a note saying which: equation error's estimate
/// (`start = "ee"`) when that method serves the structure. The EKF is
/// linearised about its running estimate, and a start near the optimum
/// keeps the early transient, where a wide prior makes large gains act on
/// a poor linearisation, short; regression costs a fraction of a pass. The
/// prior σ of each parameter state is `initial_uncertainty` times
/// max(|θ₀|, 0.1), wide enough that the data, not the start, decide.
fn start_values(
    record: &FlightRecord,
    structure: Filtered,
    settings: &FilterSettings,
    given: Option<&Estimate>,
) -> (Vec<f64>, String) {
    let Parameters {
        names,
        values,
        free,
        bounds,
    } = structure.parameters();
    let mut theta = values.to_vec();
    if settings.start == Start::Model {
        return (theta, "θ started from the model file's values".into());
    }
    match structure.equation_error_start(record, given) {
        Ok(estimate) => {
            for (i, name) in names.iter().enumerate() {
                if let (true, Some(p)) = (free[i], estimate.parameter(name))
                    && p.value.is_finite()
                {
                    theta[i] = p.value.clamp(bounds[i].0, bounds[i].1);
                }
            }
            (theta, "θ started from equation error's estimate".into())
        }
        Err(reason) => (
            theta,
            format!("θ started from the model file's values: {reason}"),
        ),
    }
}

/// An error when `pseudonoise_for` names a parameter that is not free.
fn check_pseudonoise(method: &str, structure: Filtered, settings: &FilterSettings) -> Result<()> {
    match settings
        .pseudonoise_for
        .keys()
        .find(|name| !structure.free_names().contains(name))
    {
        Some(name) => Err(Error::Setting {
            method: method.to_string(),
            reason: format!(
                "pseudonoise_for: '{name}' is not a free parameter of model '{}'",
                structure.name()
            ),
        }),
        None => Ok(()),
    }
}

/// Each output's measurement noise variance from its spectrum above the
/// motion's band, with its floor, and a note per output (σ, and the
/// Fourier estimate's).
fn measurement_noise(
    record: &FlightRecord,
    outputs: &[String],
    settings: &FilterSettings,
) -> Result<(Vec<f64>, Vec<f64>, Vec<String>)> {
    let window = fitting_window(record, outputs, None)?;
    let mut measurement = Vec::new();
    let mut floors = Vec::new();
    let mut notes = Vec::new();
    for name in outputs {
        let channel = record.channel(name)?;
        let (variance, fourier, floor) = channel_noise(channel, window, settings.motion_bandwidth);
        measurement.push(variance);
        floors.push(floor);
        notes.push(format!(
            "{name} {:.3e} (Fourier {:.3e})",
            variance.sqrt(),
            fourier.sqrt()
        ));
    }
    Ok((measurement, floors, notes))
}

impl Setup {
    pub(super) fn new(
        method: &str,
        record: &FlightRecord,
        structure: Filtered,
        settings: &FilterSettings,
        start: Option<&Estimate>,
    ) -> Result<Setup> {
        check(method, record, structure)?;
        let parameters = structure.parameters();
        let (names_all, free_flags) = (parameters.names, parameters.free);
        let outputs = structure.outputs();
        check_pseudonoise(method, structure, settings)?;
        let View {
            model: view,
            x0,
            state_names,
            notes: view_notes,
        } = structure.view(record, settings)?;
        if view.len() < 2 {
            return Err(Error::Refused(Refusal::TooFewData {
                method: method.to_string(),
                data: view.len(),
                unknowns: 2,
            }));
        }
        let (theta, start_note) = start_values(record, structure, settings, start);
        let free: Vec<usize> = (0..theta.len()).filter(|&i| free_flags[i]).collect();
        let names: Vec<String> = free.iter().map(|&i| names_all[i].clone()).collect();
        let step = view.time(1) - view.time(0);
        let observations =
            Observations::from_record(record, outputs, view.time(0), step, view.len())?;
        enough_data(method, &[&observations], free.len())?;
        let (measurement, floors, noise_notes) = measurement_noise(record, outputs, settings)?;
        let mut notes = vec![
            start_note,
            format!(
                "measurement noise σ from the spectrum above {} Hz: {}",
                settings.motion_bandwidth,
                noise_notes.join(", ")
            ),
        ];
        notes.extend(observations.note(step));
        notes.extend(view_notes);
        let setup = Setup {
            view,
            state_names,
            x0,
            theta,
            free,
            names,
            observations,
            prior: DMatrix::zeros(0, 0),
            pseudonoise: Vec::new(),
            measurement,
            floors,
            notes,
        };
        Ok(setup.with_prior(outputs, settings))
    }

    /// The setup with its prior covariance (a state's measurement variance
    /// where it is an output, else 0.01; a free parameter's initial
    /// uncertainty relative to its start) and each free parameter's
    /// pseudonoise.
    fn with_prior(mut self, outputs: &[String], settings: &FilterSettings) -> Setup {
        let (free, theta) = (&self.free, &self.theta);
        let scale = |v: f64| v.abs().max(PARAMETER_SCALE);
        let n = self.x0.len();
        let mut prior = DMatrix::zeros(n + free.len(), n + free.len());
        for (i, state) in self.state_names.iter().enumerate() {
            prior[(i, i)] = outputs
                .iter()
                .position(|o| o == state)
                .map_or(0.01, |o| self.measurement[o]);
        }
        for (j, &i) in free.iter().enumerate() {
            prior[(n + j, n + j)] = (settings.initial_uncertainty * scale(theta[i])).powi(2);
        }
        let pseudonoise: Vec<f64> = free
            .iter()
            .zip(&self.names)
            .map(|(&i, name)| {
                let relative = settings
                    .pseudonoise_for
                    .get(name)
                    .copied()
                    .unwrap_or(settings.pseudonoise);
                (relative * scale(theta[i])).powi(2)
            })
            .collect();
        self.prior = prior;
        self.pseudonoise = pseudonoise;
        self
    }
}
