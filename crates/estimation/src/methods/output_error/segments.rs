//! Multiple shooting and the integration grid: the pieces of a record and their RK4 sub-steps.

use super::*;

/// The fitting window of `record` cut into pieces of equal length, as
/// close to `length` as a whole number of them allows, each half-open (a
/// sample on a boundary belongs to the later piece); an error when a piece
/// would hold fewer than two samples of an output.
pub(super) fn pieces(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    length: f64,
) -> Result<Vec<(f64, f64)>> {
    let (start, end) = fitting_window(record, &structure.outputs, options.window)?;
    let count = ((end - start) / length).round().max(1.0) as usize;
    let piece = (end - start) / count as f64;
    let windows: Vec<(f64, f64)> = (0..count)
        .map(|k| {
            let from = start + k as f64 * piece;
            let to = if k + 1 == count {
                end
            } else {
                start + (k + 1) as f64 * piece - 1e-9 * piece
            };
            (from, to)
        })
        .collect();
    for name in &structure.outputs {
        let channel = record.channel(name)?;
        for &(from, to) in &windows {
            let samples = channel
                .times
                .iter()
                .filter(|t| **t >= from && **t <= to)
                .count();
            if samples < 2 {
                return Err(Error::Setting {
                    method: METHOD.to_string(),
                    reason: format!(
                        "segment = {length} s: the piece {from:.3}–{to:.3} s of '{}' holds {samples} sample(s) of '{name}'; give a longer segment",
                        record.scenario
                    ),
                });
            }
        }
    }
    Ok(windows)
}

/// One record's (or piece's) segment over its fitting window, on
/// [`driven_simulation`]'s grid.
pub(super) fn segment<'a>(
    record: &'a FlightRecord,
    structure: &ModelStructure,
    options: &OutputErrorOptions,
) -> Result<Segment<'a>> {
    let window = fitting_window(record, &structure.outputs, options.window)?;
    let (mut simulation, notes) = driven_simulation(
        record,
        structure,
        &options.interpolation,
        options.step,
        window,
    )?;
    let inputs = driving_channels(structure);
    let period = observation_step(record, &structure.outputs, &inputs, options.step, window.0)?;
    let substeps = options
        .step
        .is_none()
        .then(|| (period, (period / simulation.step).round().max(1.0) as usize));
    let grid_notes = notes
        .iter()
        .filter(|note| note.starts_with("grid step"))
        .cloned()
        .collect();
    simulation.notes.extend(notes);
    let end = simulation.time(simulation.len() - 1);
    let initial = recorded_initial_state(record, structure, &simulation, window.0);
    let outputs = structure
        .outputs
        .iter()
        .map(|name| {
            let channel = record.channel(name)?;
            let (times, values): (Vec<f64>, Vec<f64>) = channel
                .times
                .iter()
                .zip(&channel.values)
                .filter(|(t, v)| **t >= window.0 && **t <= end && v.is_finite())
                .map(|(t, v)| (*t, *v))
                .unzip();
            Ok(Measured {
                times,
                values,
                brackets: Vec::new(),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let mut segment = Segment {
        simulation,
        initial,
        outputs,
        record,
        window,
        substeps,
        grid_notes,
        rechosen: 0,
        fastest: f64::NAN,
    };
    segment.locate_samples();
    Ok(segment)
}

/// The factor by which the RK4 steps of a re-chosen grid are finer than
/// h·|λ| ≤ [`RK4_STEP_LIMIT`] asks (h·|λ| ≤ 0.4), and the factor by which
/// the mode must then slow before the steps are coarsened again (h·|λ| <
/// 0.2).
pub(super) const RECHOSEN_MARGIN: f64 = 1.25;

/// How far beyond [`RK4_STEP_LIMIT`] the fastest mode may move before the
/// grid is re-chosen finer (h·|λ| > 1, RK4's error per step then 0.8 %):
/// a new grid changes the cost the fit descends, and on the 1.25 Hz
/// HANSA-3 record a grid re-chosen for h·|λ| = 0.69 at the estimate moved
/// it by 0.1σ from the fit on that grid throughout, the scatter of its
/// path; a fit whose modes move a little keeps the grid it started on.
pub(super) const REFINE_BEYOND: f64 = 2.0;

impl Segment<'_> {
    /// Where each output sample lies on the simulation's grid.
    pub(super) fn locate_samples(&mut self) {
        let simulation = &self.simulation;
        for measured in &mut self.outputs {
            measured.brackets = measured
                .times
                .iter()
                .map(|&t| grid_bracket(simulation.len(), simulation.start, simulation.step, t))
                .collect();
        }
    }

    /// Re-chooses the RK4 steps of each grid interval for `model`'s
    /// fastest mode at the segment's initial state ([`fastest_mode`]),
    /// where the user gave no step: finer when h·|λ| exceeds 1
    /// ([`REFINE_BEYOND`]), coarser when it has fallen below 0.2
    /// ([`RECHOSEN_MARGIN`]); a new step takes h·|λ| ≤ 0.4. Returns whether
    /// the grid changed (the simulation is then rebuilt).
    pub(super) fn resolve(
        &mut self,
        model: &FlightModel,
        integrate: &[usize],
        interpolation: &InputInterpolation,
        alpha_dot: bool,
    ) -> crate::Result<bool> {
        let Some((period, current)) = self.substeps else {
            return Ok(false);
        };
        let fastest = fastest_mode(&self.simulation, model, &self.initial)?;
        let needed = period * fastest / RK4_STEP_LIMIT;
        if !needed.is_finite()
            || (needed <= REFINE_BEYOND * current as f64
                && 2.0 * RECHOSEN_MARGIN * needed >= current as f64)
        {
            return Ok(false);
        }
        let substeps = rk4_substeps(period, RECHOSEN_MARGIN * fastest).min(MAX_SUBSTEPS);
        if substeps == current {
            return Ok(false);
        }
        let mut simulation = DrivenSimulation::from_record(
            self.record,
            integrate,
            interpolation,
            period / substeps as f64,
            self.window,
            alpha_dot,
        )?;
        simulation.notes.extend(self.grid_notes.iter().cloned());
        self.simulation = simulation;
        self.substeps = Some((period, substeps));
        self.rechosen += 1;
        self.fastest = fastest;
        self.locate_samples();
        Ok(true)
    }

    /// An error when `model`'s fastest mode at the segment's initial state
    /// is beyond what the grid's RK4 steps integrate ([`RK4_STEP_REACH`]).
    pub(super) fn check_reach(&self, model: &FlightModel) -> crate::Result<()> {
        let Some((period, substeps)) = self.substeps else {
            return Ok(());
        };
        let fastest = fastest_mode(&self.simulation, model, &self.initial)?;
        check_step_reach(period, substeps, fastest)
    }

    /// The note on a grid whose sub-steps were re-chosen.
    pub(super) fn rechosen_note(&self) -> Option<String> {
        let (period, substeps) = self.substeps?;
        (self.rechosen > 0).then(|| {
            format!(
                "{}; re-chosen {} time(s) as the parameters moved, for the fastest mode at the parameters of the last choice (at the initial state){}",
                substep_note(period, substeps, self.fastest, "there"),
                self.rechosen,
                if substeps >= MAX_SUBSTEPS {
                    format!(
                        ": the finest a fit takes ({MAX_SUBSTEPS} per grid interval); a step that speeds the mode beyond h·|λ| = {RK4_STEP_REACH} is not simulated, so a fit that stops here stopped at that edge, not at a minimum (a time constant driven toward 0, the stall model's τ1: fit its limit, τ1 = 0)"
                    )
                } else {
                    String::new()
                }
            )
        })
    }
}
