//! What a model structure and a record must give output error, refused by name otherwise.

use super::*;

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
