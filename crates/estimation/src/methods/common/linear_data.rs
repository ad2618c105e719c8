//! A linear structure on a record's grid, as the fits of a linear model
//! (output and filter error, multiple shooting) take it: the free
//! parameters (or the refusal naming missing channels or nothing to
//! estimate), the exact discrete model driven by the record's inputs
//! ([`crate::model::linear`]), its initial state, its step and the
//! observations of the compared outputs on its grid.

use super::refusals::free_parameters;
use crate::error::Result;
use crate::linear_structure::LinearStructure;
use crate::model::linear::LinearStateSpace;
use crate::model::observations::Observations;
use crate::model::state_space::StateSpaceModel;
use aeroid_record::FlightRecord;
use nalgebra::DVector;

/// What [`linear_data`] gives a fit.
pub(crate) struct LinearData {
    /// Indices of the free parameters.
    pub free: Vec<usize>,
    pub model: LinearStateSpace,
    /// x₀: the file's `initial_state`, else the record's value of each
    /// state named like a channel, else 0.
    pub initial: DVector<f64>,
    /// The grid step (s).
    pub step: f64,
    pub observations: Observations,
}

/// `structure` on `record`'s grid of `step` (None: the fastest output's
/// period) over `window`; the refusal of `method` when the record lacks a
/// channel or nothing is free.
pub(crate) fn linear_data(
    method: &str,
    record: &FlightRecord,
    structure: &LinearStructure,
    step: Option<f64>,
    window: Option<(f64, f64)>,
) -> Result<LinearData> {
    let free = free_parameters(
        method,
        record,
        structure.missing_channels(record),
        &structure.name,
        &structure.free,
    )?;
    let (model, initial) = structure.for_record(record, step, window)?;
    let step = model.time(1) - model.time(0);
    let observations =
        Observations::from_record(record, &structure.outputs, model.time(0), step, model.len())?;
    Ok(LinearData {
        free,
        model,
        initial,
        step,
        observations,
    })
}
