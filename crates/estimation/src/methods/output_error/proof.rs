//! The proof of match: the estimated model simulated on another record.

use super::*;

/// Proof of match (ELM + Gauss–Newton and reflex-wing UAV papers): the structure with an estimate's
/// aerodynamic values, simulated on another manoeuvre with nothing adjusted
/// (initial state from that record's first samples), and how well it
/// reproduces each output there.
pub fn proof_of_match(
    estimate: &Estimate,
    structure: &ModelStructure,
    record: &FlightRecord,
) -> Result<Vec<OutputFit>> {
    Ok(match_histories(estimate, structure, record)?
        .iter()
        .map(|m| OutputFit::new(&m.channel, &m.measured, &m.predicted))
        .collect())
}

/// One output of a proof of match: the measured samples in the fitting
/// window and the model's prediction at their instants.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchedOutput {
    pub channel: String,
    pub times: Vec<f64>,
    pub measured: Vec<f64>,
    pub predicted: Vec<f64>,
}

/// The histories behind [`proof_of_match`]: per output of the structure,
/// the measured and predicted values at the record's samples.
pub fn match_histories(
    estimate: &Estimate,
    structure: &ModelStructure,
    record: &FlightRecord,
) -> Result<Vec<MatchedOutput>> {
    let mut aircraft = structure.aircraft.clone();
    for p in &estimate.parameters {
        if aircraft.aero.parameters.index(&p.name).is_some() {
            aircraft.aero.parameters.set(&p.name, p.value)?;
        }
    }
    let options = OutputErrorOptions::for_structure(structure)?;
    let segment = segment(record, structure, &options)?;
    let model = FlightModel::new(aircraft, Default::default());
    let observables = observables(structure)?;
    let mut problem = Objective::from_segments(
        model,
        vec![segment],
        Vec::new(),
        observables,
        structure,
        &options,
    );
    // The grid for the estimate's values, not the model file's.
    let nothing = DVector::zeros(0);
    problem
        .resolve_steps(&nothing)
        .and_then(|_| problem.predict(&nothing))
        .map_err(|reason| Error::Method {
            reason: format!("proof of match on '{}': {reason}", record.scenario),
        })?;
    let predicted = &problem.predictions()[0];
    Ok(problem.segments[0]
        .outputs
        .iter()
        .zip(predicted)
        .zip(&problem.outputs)
        .map(|((measured, predicted), channel)| MatchedOutput {
            channel: channel.clone(),
            times: measured.times.clone(),
            measured: measured.values.clone(),
            predicted: predicted.clone(),
        })
        .collect())
}
