//! The refusals the methods that simulate or filter a model share: a
//! structure they cannot fit as stated (`unsuitable`), the channels a
//! record lacks (`missing_channels`), nothing free to estimate
//! (`free_parameters`) and fewer data than unknowns (`enough_data`); and
//! the refusal of the methods that regress a linear model one equation at
//! a time of a parameter set in several entries (`one_entry_each`).

use crate::error::{Error, Result};
use crate::estimator::{MissingChannel, Refusal};
use crate::linear_structure::LinearStructure;
use crate::model::driven::ALTITUDE_SUBSTITUTES;
use crate::model::observations::Observations;
use crate::structure::ModelStructure;
use aeroid_record::FlightRecord;

/// Refuses a linear structure with a free parameter that sets several
/// entries (`Z_w` in A and in C): a method that regresses one equation at
/// a time (`method`) estimates each entry on its own and cannot tie them,
/// even within one row. The refusal names every such parameter with its
/// entries and points to the methods that fit the whole model.
pub(crate) fn one_entry_each(method: &str, structure: &LinearStructure) -> Result<()> {
    let shared: Vec<String> = (0..structure.names.len())
        .filter(|&i| structure.free[i] && structure.entries[i].len() > 1)
        .map(|i| {
            let entries: Vec<String> = structure.entries[i].iter().map(|e| e.to_string()).collect();
            format!("'{}' ({})", structure.names[i], entries.join(", "))
        })
        .collect();
    if shared.is_empty() {
        return Ok(());
    }
    Err(Error::Refused(Refusal::UnsuitableModel {
        method: method.to_string(),
        model: structure.name.clone(),
        reason: format!(
            "free parameters that set several entries: {}; {method} regresses one equation at a time and cannot tie a parameter's entries: fit the model with output error (oem) or filter error (fem), or fix the parameter",
            shared.join(", ")
        ),
    }))
}

/// Refuses a structure output error (or another method that simulates or
/// filters it, `method`) cannot fit as stated: no output to compare, or an
/// output that is a flight-path state the model does not integrate (fed
/// in from the record, it would be compared with itself).
pub(crate) fn unsuitable(method: &str, structure: &ModelStructure) -> Result<()> {
    let refuse = |reason: String| {
        Err(Error::Refused(Refusal::UnsuitableModel {
            method: method.to_string(),
            model: structure.name.clone(),
            reason,
        }))
    };
    if structure.outputs.is_empty() {
        return refuse("it names no outputs to compare (`outputs = [...]`)".into());
    }
    let fed_in: Vec<&str> = structure
        .pseudo_controls()
        .into_iter()
        .filter(|state| structure.outputs.iter().any(|o| o == state))
        .collect();
    if !fed_in.is_empty() {
        return refuse(format!(
            "the outputs {} are not integrated (`integrate`): fed in from the record, each would be compared with itself",
            fed_in.join(", ")
        ));
    }
    Ok(())
}

/// The channels a record lacks that output error needs for `structure`:
/// the compared outputs, and the flight-path states it does not integrate
/// (the driven simulation's pseudo-controls; yaw and χ are not needed,
/// the altitude may be a pressure altitude).
pub(crate) fn missing_channels(
    record: &FlightRecord,
    structure: &ModelStructure,
) -> Vec<MissingChannel> {
    let has = |name: &str| record.channel(name).is_ok();
    let mut missing: Vec<MissingChannel> = structure
        .outputs
        .iter()
        .filter(|name| !has(name))
        .map(|name| MissingChannel {
            name: name.clone(),
            purpose: "a compared output".into(),
        })
        .collect();
    for name in structure.pseudo_controls() {
        let absent = match name {
            "yaw" | "chi" => false,
            "altitude" => {
                !has(name)
                    && !ALTITUDE_SUBSTITUTES
                        .iter()
                        .any(|substitute| has(substitute))
            }
            _ => !has(name),
        };
        if absent && !missing.iter().any(|m| m.name == name) {
            missing.push(MissingChannel {
                name: name.to_string(),
                purpose: "a pseudo-control, a state the model does not integrate".into(),
            });
        }
    }
    missing
}

/// The free parameters' indices (`free` per parameter of model `model`),
/// or the refusal of `method`: channels `missing` from the record, or
/// nothing to estimate.
pub(crate) fn free_parameters(
    method: &str,
    record: &FlightRecord,
    missing: Vec<MissingChannel>,
    model: &str,
    free: &[bool],
) -> Result<Vec<usize>> {
    let present = record.channels.iter().map(|c| c.name.clone()).collect();
    if let Some(refusal) = Refusal::missing(method, missing, present) {
        return Err(Error::Refused(refusal));
    }
    let free: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    if free.is_empty() {
        return Err(Error::Refused(Refusal::NothingToEstimate {
            method: method.to_string(),
            model: model.to_string(),
        }));
    }
    Ok(free)
}

/// The refusal of `method` when `observations` (of one record or several)
/// hold fewer data than `unknowns`.
pub(crate) fn enough_data(
    method: &str,
    observations: &[&Observations],
    unknowns: usize,
) -> Result<()> {
    let data: usize = observations
        .iter()
        .map(|o| o.counts().iter().sum::<usize>())
        .sum();
    if data < unknowns {
        return Err(Error::Refused(Refusal::TooFewData {
            method: method.to_string(),
            data,
            unknowns,
        }));
    }
    Ok(())
}
