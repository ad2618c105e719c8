//! The training data of the RBF networks: per coefficient, the
//! reconstructed (or smoothed) coefficient and the motion and control
//! inputs that vary on the record, at the reconstruction's instants (the
//! parent module's header, steps 1 and 2).

use super::*;

/// One network's training data.
pub(super) struct TrainingData {
    pub(super) coefficient: Coefficient,
    /// The coefficient's name in the structure's axes.
    pub(super) name: &'static str,
    pub(super) times: Vec<f64>,
    /// The inputs kept (varying on the record).
    pub(super) inputs: Vec<Regressor>,
    /// One row of input values per sample (regressor units).
    pub(super) rows: Vec<Vec<f64>>,
    pub(super) targets: Vec<f64>,
}

/// A refusal of the smoother's names this method.
fn as_own(error: Error) -> Error {
    match error {
        Error::Refused(mut refusal) => {
            match &mut refusal {
                Refusal::MissingChannels { method, .. }
                | Refusal::TooFewData { method, .. }
                | Refusal::UnsuitableModel { method, .. }
                | Refusal::NotLinearInParameters { method, .. }
                | Refusal::NothingToEstimate { method, .. }
                | Refusal::StructureKind { method, .. }
                | Refusal::OneRecordOnly { method, .. } => *method = METHOD.to_string(),
            }
            Error::Refused(refusal)
        }
        other => other,
    }
}

/// Whether the record has what reconstructing the plans' coefficients
/// needs (accelerations, α, β, rates, dynamic pressure, thrust).
fn can_reconstruct(record: &FlightRecord, structure: &ModelStructure, plans: &[Plan]) -> bool {
    let measured_rates = ["p", "q", "r"].iter().all(|name| {
        record
            .channel(name)
            .is_ok_and(|c| !aeroid_record::prep::derive::is_derived(&c.source))
    });
    if !measured_rates {
        return false;
    }
    let mut request = Request {
        coefficients: plans.iter().map(|p| p.coefficient).collect(),
        regressors: vec![Regressor::Alpha, Regressor::Beta],
    };
    for plan in plans {
        for rate in [
            Regressor::PitchRate,
            Regressor::RollRate,
            Regressor::YawRate,
        ] {
            if inputs_of(plan.coefficient).contains(&rate) {
                request.regressors.push(rate);
            }
        }
    }
    missing_channels(record, &structure.aircraft, &request, &Default::default()).is_empty()
}

/// The inputs of `coefficient` whose channels the record has.
fn recorded_inputs(
    record: &FlightRecord,
    structure: &ModelStructure,
    coefficient: Coefficient,
) -> Vec<Regressor> {
    inputs_of(coefficient)
        .iter()
        .copied()
        .filter(|&r| {
            let request = Request {
                coefficients: Vec::new(),
                regressors: vec![r],
            };
            missing_channels(record, &structure.aircraft, &request, &Default::default()).is_empty()
        })
        .collect()
}

/// The coefficient data of every plan, with notes on the source.
pub(super) fn coefficient_data(
    record: &FlightRecord,
    structure: &ModelStructure,
    plans: &[Plan],
    settings: &RbfDeltaSettings,
    notes: &mut Vec<String>,
) -> Result<Vec<TrainingData>> {
    let reconstructed = match settings.coefficients {
        CoefficientSource::Reconstructed => true,
        CoefficientSource::Smoothed => false,
        CoefficientSource::Auto => can_reconstruct(record, structure, plans),
    };
    let mut data = Vec::new();
    if reconstructed {
        notes.push(
            "coefficients reconstructed from the measured accelerations and angular accelerations"
                .into(),
        );
        // Forces and moments apart, as equation error: only the moments
        // need differentiated rates, whose windows skip control steps.
        let (forces, moments): (Vec<&Plan>, Vec<&Plan>) =
            plans.iter().partition(|p| p.coefficient.is_force());
        for group in [forces, moments].into_iter().filter(|g| !g.is_empty()) {
            let mut request = Request::default();
            for plan in &group {
                request.coefficients.push(plan.coefficient);
                for r in recorded_inputs(record, structure, plan.coefficient) {
                    if !request.regressors.contains(&r) {
                        request.regressors.push(r);
                    }
                }
            }
            let reconstruction = reconstruct(
                record,
                &structure.aircraft,
                &request,
                &ReconstructionOptions::default(),
                METHOD,
            )?;
            for plan in &group {
                let inputs = recorded_inputs(record, structure, plan.coefficient);
                data.push(training_data(
                    named(structure, plan.coefficient),
                    &inputs,
                    &reconstruction,
                    notes,
                ));
            }
            extend_unique(notes, &reconstruction.notes);
        }
    } else {
        notes.push("coefficients from the EKF + modified Bryson–Frazier smoother (Wang et al. 2012, Eqs. 7–24)".into());
        let smoothed = smoothing::smooth(record, structure, &settings.smoother).map_err(as_own)?;
        let reconstruction = smoothing::regression_data(
            record,
            structure,
            &smoothed,
            plans,
            settings.smoother.step_margin,
        )?;
        extend_unique(notes, &smoothed.notes);
        extend_unique(notes, &reconstruction.notes);
        for plan in plans {
            let inputs = inputs_of(plan.coefficient).to_vec();
            data.push(training_data(
                named(structure, plan.coefficient),
                &inputs,
                &reconstruction,
                notes,
            ));
        }
    }
    Ok(data)
}

/// A coefficient with its name in the structure's axes.
fn named(structure: &ModelStructure, coefficient: Coefficient) -> (Coefficient, &'static str) {
    (
        coefficient,
        coefficient.name(structure.aircraft.aero.force_axes),
    )
}

fn extend_unique(notes: &mut Vec<String>, more: &[String]) {
    for note in more {
        if !notes.contains(note) {
            notes.push(note.clone());
        }
    }
}

/// One coefficient's rows: the samples where the target and every input
/// are finite; inputs constant on them are left out with a note.
fn training_data(
    (coefficient, name): (Coefficient, &'static str),
    inputs: &[Regressor],
    reconstruction: &Reconstruction,
    notes: &mut Vec<String>,
) -> TrainingData {
    let targets_all = reconstruction.coefficient(coefficient);
    let mut times = Vec::new();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut targets = Vec::new();
    for (k, regressors) in reconstruction.regressors.iter().enumerate() {
        let row: Vec<f64> = inputs.iter().map(|&r| regressors[r as usize]).collect();
        let target = targets_all.get(k).copied().unwrap_or(f64::NAN);
        if target.is_finite() && row.iter().all(|v| v.is_finite()) {
            times.push(reconstruction.times[k]);
            rows.push(row);
            targets.push(target);
        }
    }
    let varying: Vec<bool> = (0..inputs.len())
        .map(|j| {
            let first = rows.first().map_or(0.0, |r| r[j]);
            rows.iter().any(|r| r[j] != first)
        })
        .collect();
    let dropped: Vec<&str> = inputs
        .iter()
        .zip(&varying)
        .filter(|(_, v)| !**v)
        .map(|(r, _)| r.key())
        .collect();
    let missing: Vec<&str> = inputs_of(coefficient)
        .iter()
        .filter(|r| !inputs.contains(r))
        .map(|r| r.key())
        .collect();
    if !dropped.is_empty() || !missing.is_empty() {
        notes.push(format!(
            "{name} network: inputs left out (constant on the record: {}; no channel: {})",
            list_or_none(&dropped),
            list_or_none(&missing)
        ));
    }
    for row in &mut rows {
        let mut j = 0;
        row.retain(|_| {
            j += 1;
            varying[j - 1]
        });
    }
    TrainingData {
        coefficient,
        name,
        times,
        inputs: inputs
            .iter()
            .zip(&varying)
            .filter(|(_, v)| **v)
            .map(|(r, _)| *r)
            .collect(),
        rows,
        targets,
    }
}

fn list_or_none(items: &[&str]) -> String {
    if items.is_empty() {
        "none".into()
    } else {
        items.join(", ")
    }
}
