//! The record on the restricted model's time base: the measured flight
//! conditions, motion variables and coefficients (the coefficients from the
//! measured accelerations, [`crate::reconstruction`]), the training pairs
//! X(i) → Z(i+1) (the ELM paper's Eqs. 1–2) and their scalings (Eq. 3).

use super::*;

/// The record on the restricted model's time base: measured flight
/// conditions, motion variables and coefficients at each kept instant, the
/// training pairs and the scalings.
pub(super) struct Data {
    pub(super) motion_names: Vec<String>,
    pub(super) coefficients: Vec<Coefficient>,
    pub(super) coefficient_names: Vec<String>,
    pub(super) times: Vec<f64>,
    /// The measured flight condition at each instant (χ set per Θ).
    pub(super) conditions: Vec<AeroInput>,
    /// Motion variables, instant by instant (`motion_names.len()` each).
    pub(super) motion: Vec<f64>,
    /// Measured coefficients, instant by instant.
    pub(super) measured: Vec<f64>,
    /// Instants k whose next instant k+1 is one sample later: the pairs.
    pub(super) pairs: Vec<usize>,
    /// The sample period (s).
    pub(super) period: f64,
    pub(super) input_scaling: Scaling,
    pub(super) output_scaling: Scaling,
    pub(super) coefficient_outputs: bool,
    pub(super) notes: Vec<String>,
}

impl Data {
    pub(super) fn motion_count(&self) -> usize {
        self.motion_names.len()
    }

    pub(super) fn coefficient_count(&self) -> usize {
        self.coefficients.len()
    }

    pub(super) fn output_count(&self) -> usize {
        self.motion_count() + usize::from(self.coefficient_outputs) * self.coefficient_count()
    }

    pub(super) fn input_names(&self) -> Vec<String> {
        let mut names = self.motion_names.clone();
        names.extend(self.coefficient_names.iter().cloned());
        names
    }

    pub(super) fn output_names(&self) -> Vec<String> {
        let mut names = self.motion_names.clone();
        if self.coefficient_outputs {
            names.extend(self.coefficient_names.iter().cloned());
        }
        names
    }

    /// Unscaled network input at instant k with coefficients `coefficients`.
    pub(super) fn raw_input(&self, k: usize, coefficients: &[f64], row: &mut [f64]) {
        let (m, c) = (self.motion_count(), self.coefficient_count());
        row[..m].copy_from_slice(&self.motion[k * m..(k + 1) * m]);
        row[m..m + c].copy_from_slice(&coefficients[k * c..(k + 1) * c]);
    }

    /// Unscaled target at instant k (motion, then measured coefficients).
    pub(super) fn raw_target(&self, k: usize, row: &mut [f64]) {
        let (m, c) = (self.motion_count(), self.coefficient_count());
        row[..m].copy_from_slice(&self.motion[k * m..(k + 1) * m]);
        if self.coefficient_outputs {
            row[m..m + c].copy_from_slice(&self.measured[k * c..(k + 1) * c]);
        }
    }

    /// The scaled training set: pairs (input at k, target at k+1).
    pub(super) fn training_set(&self) -> TrainingSet {
        let inputs_count = self.motion_count() + self.coefficient_count();
        let (inputs, targets) = self
            .pairs
            .iter()
            .map(|&k| {
                let mut x = vec![0.0; inputs_count];
                self.raw_input(k, &self.measured, &mut x);
                self.input_scaling.apply(&mut x);
                let mut z = vec![0.0; self.output_count()];
                self.raw_target(k + 1, &mut z);
                self.output_scaling.apply(&mut z);
                (x, z)
            })
            .unzip();
        TrainingSet {
            inputs,
            targets,
            input_names: self.input_names(),
            output_names: self.output_names(),
        }
    }
}

/// The coefficients with a free parameter among their terms (in
/// evaluation order). A coefficient whose terms are all fixed carries no Θ
/// and may not be computable from the structure alone (CDRW lateral: CD
/// with a CL² term while CL has no terms is a constant the flight never
/// had, outside every training sample).
pub(super) fn model_coefficients(structure: &ModelStructure) -> Vec<Coefficient> {
    let aero = &structure.aircraft.aero;
    Coefficient::ALL
        .into_iter()
        .filter(|&c| {
            aero.terms(c)
                .any(|(_, parameter)| structure.free[parameter])
        })
        .collect()
}

/// Whether the coefficients need α̇ (the stall model's χ, or α̇ terms).
pub(super) fn needs_alpha_dot(aero: &AeroModel) -> bool {
    aero.kind == ModelKind::Stall
        || Coefficient::ALL
            .into_iter()
            .any(|c| aero.terms(c).any(|(r, _)| r.contains(Regressor::AlphaDot)))
}

/// The motion variables: the option's, else the structure's integrated
/// states without χ.
pub(super) fn motion_names(structure: &ModelStructure, options: &RestrictedOptions) -> Vec<String> {
    if !options.motion.is_empty() {
        return options.motion.clone();
    }
    structure
        .integrate
        .iter()
        .map(|&i| FLIGHT_PATH_STATES[i])
        .filter(|&name| name != "chi")
        .map(str::to_string)
        .collect()
}

/// A channel sampled at the instants (None when the record lacks it).
pub(super) fn sampled(
    record: &FlightRecord,
    name: &str,
    times: &[f64],
) -> Result<Option<Vec<f64>>> {
    match record.channel(name) {
        Ok(channel) => Ok(channel.values_at(times).map(Some)?),
        Err(_) => Ok(None),
    }
}

/// Checks that the record has the motion variables and every channel the
/// coefficients need: one refusal naming all that are missing.
pub(super) fn check_motion_and_channels(
    method: &str,
    record: &FlightRecord,
    structure: &ModelStructure,
    request: &Request,
    motion_names: &[String],
) -> Result<()> {
    let mut missing: Vec<MissingChannel> =
        match check_channels(record, &structure.aircraft, request, method) {
            Ok(()) => Vec::new(),
            Err(Error::Refused(Refusal::MissingChannels { channels, .. })) => channels,
            Err(error) => return Err(error),
        };
    for name in motion_names {
        if record.channel(name).is_err() && !missing.iter().any(|c| &c.name == name) {
            missing.push(MissingChannel {
                name: name.clone(),
                purpose: "motion variable of the restricted neural model".into(),
            });
        }
    }
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    match Refusal::missing(method, missing, present) {
        Some(refusal) => Err(Error::Refused(refusal)),
        None => Ok(()),
    }
}

/// Reads the record onto the restricted model's time base.
pub(super) fn prepare(
    method: &str,
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &RestrictedOptions,
) -> Result<Data> {
    let aero = &structure.aircraft.aero;
    let coefficients = model_coefficients(structure);
    let motion_names = motion_names(structure, options);
    if coefficients.is_empty() || motion_names.is_empty() {
        return Err(Error::Refused(Refusal::UnsuitableModel {
            method: method.to_string(),
            model: structure.name.clone(),
            reason: "the restricted neural model needs coefficients with terms and integrated motion variables".into(),
        }));
    }
    let mut request = Request {
        coefficients: coefficients.clone(),
        regressors: Vec::new(),
    };
    for &c in &coefficients {
        request
            .regressors
            .extend(aero.terms(c).flat_map(|(r, _)| r.factors().to_vec()));
    }
    if aero.kind == ModelKind::Stall {
        request.regressors.push(Regressor::Alpha);
    }
    check_motion_and_channels(method, record, structure, &request, &motion_names)?;
    let reconstruction = reconstruct(
        record,
        &structure.aircraft,
        &request,
        &ReconstructionOptions {
            differentiator: Some(options.differentiator),
            step_breaks: StepBreaks::NewValue,
            ..Default::default()
        },
        method,
    )?;
    assemble(
        method,
        record,
        structure,
        options,
        (motion_names, coefficients),
        reconstruction,
    )
}

/// The flight conditions, motion and coefficients at the reconstruction's
/// instants where everything is finite, the pairs and the scalings.
pub(super) fn assemble(
    method: &str,
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &RestrictedOptions,
    (motion_names, coefficients): (Vec<String>, Vec<Coefficient>),
    reconstruction: Reconstruction,
) -> Result<Data> {
    let times = &reconstruction.times;
    let channel = |name: &str| sampled(record, name, times);
    let alpha_dot = alpha_dot(record, structure, options, times)?;
    let motion_series = motion_names
        .iter()
        .map(|name| record.channel(name)?.values_at(times))
        .collect::<aeroid_record::Result<Vec<_>>>()?;
    let [alpha, beta, airspeed, mach, p, q, r] =
        ["alpha", "beta", "airspeed", "mach", "p", "q", "r"].map(channel);
    let (alpha, beta, airspeed, mach) = (alpha?, beta?, airspeed?, mach?);
    let (p, q, r) = (p?, q?, r?);
    let controls = Control::ALL
        .iter()
        .map(|c| channel(c.name()))
        .collect::<Result<Vec<_>>>()?;
    let value = |series: &Option<Vec<f64>>, k: usize| series.as_ref().map_or(f64::NAN, |s| s[k]);
    let mut data = Data::empty(
        structure,
        options,
        (motion_names, coefficients),
        &reconstruction,
    );
    let mut left_out = 0;
    for (k, &time) in times.iter().enumerate() {
        let condition = AeroInput {
            alpha: value(&alpha, k),
            beta: value(&beta, k),
            airspeed: value(&airspeed, k),
            mach: value(&mach, k),
            rates: Vector3::new(value(&p, k), value(&q, k), value(&r, k)),
            alpha_dot: alpha_dot.as_ref().map_or(0.0, |s| s[k]),
            measured_alpha_dot: None,
            controls: Controls::from_fn(|i, _| controls[i].as_ref().map_or(0.0, |s| s[k])),
            chi: 1.0,
        };
        let motion = motion_series.iter().map(|s| s[k]);
        let measured = data
            .coefficients
            .iter()
            .map(|&c| reconstruction.coefficient(c)[k]);
        let finite = motion.clone().chain(measured.clone()).all(f64::is_finite)
            && condition.alpha_dot.is_finite();
        if !finite {
            left_out += 1;
            continue;
        }
        data.times.push(time);
        data.conditions.push(condition);
        data.motion.extend(motion);
        data.measured.extend(measured);
    }
    let tolerance = 0.5 * data.period;
    data.pairs = (0..data.times.len().saturating_sub(1))
        .filter(|&k| (data.times[k + 1] - data.times[k] - data.period).abs() < tolerance)
        .collect();
    if left_out > 0 {
        data.notes.push(format!(
            "{left_out} instants left out where a motion variable or α̇ is not finite"
        ));
    }
    let parameters = structure.free.iter().filter(|&&f| f).count();
    if data.pairs.len() <= parameters.max(10) {
        return Err(Error::Refused(Refusal::TooFewData {
            method: method.to_string(),
            data: data.pairs.len(),
            unknowns: parameters,
        }));
    }
    fit_scalings(&mut data, options.scaling)?;
    Ok(data)
}

/// α̇ on the reconstruction's instants `times` where the model needs it:
/// the α channel differentiated with breaks at the control steps.
fn alpha_dot(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &RestrictedOptions,
    times: &[f64],
) -> Result<Option<Vec<f64>>> {
    if !needs_alpha_dot(&structure.aircraft.aero) {
        return Ok(None);
    }
    let alpha = record.channel("alpha")?;
    let derivative = options
        .differentiator
        .differentiate_with_breaks(alpha, &control_steps(record));
    Ok(Some(derivative.values_at_unbridged(times)))
}

impl Data {
    /// Data of the motion variables and coefficients named, with no
    /// instant yet: the reconstruction's period and notes, scalings still
    /// to fit.
    fn empty(
        structure: &ModelStructure,
        options: &RestrictedOptions,
        (motion_names, coefficients): (Vec<String>, Vec<Coefficient>),
        reconstruction: &Reconstruction,
    ) -> Data {
        let axes = structure.aircraft.aero.force_axes;
        Data {
            coefficient_names: coefficients
                .iter()
                .map(|c| c.name(axes).to_string())
                .collect(),
            motion_names,
            coefficients,
            times: Vec::new(),
            conditions: Vec::new(),
            motion: Vec::new(),
            measured: Vec::new(),
            pairs: Vec::new(),
            period: 1.0 / reconstruction.rate,
            input_scaling: Scaling {
                range: Vec::new(),
                low: 0.0,
                high: 1.0,
            },
            output_scaling: Scaling {
                range: Vec::new(),
                low: 0.0,
                high: 1.0,
            },
            coefficient_outputs: options.coefficient_outputs,
            notes: reconstruction.notes.clone(),
        }
    }
}

/// The input and output scalings from the training pairs (Eq. 3).
pub(super) fn fit_scalings(data: &mut Data, (low, high): (f64, f64)) -> Result<()> {
    let width = data.motion_count() + data.coefficient_count();
    let (inputs, targets): (Vec<Vec<f64>>, Vec<Vec<f64>>) = data
        .pairs
        .iter()
        .map(|&k| {
            let mut x = vec![0.0; width];
            data.raw_input(k, &data.measured, &mut x);
            let mut z = vec![0.0; data.output_count()];
            data.raw_target(k + 1, &mut z);
            (x, z)
        })
        .unzip();
    data.input_scaling = Scaling::fit(&inputs, &data.input_names(), low, high)?;
    data.output_scaling = Scaling::fit(&targets, &data.output_names(), low, high)?;
    Ok(())
}
