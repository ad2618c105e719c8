//! Step-type inputs resolved into signals: step, doublet, 3-2-1-1 and
//! multistep (levels held for a time each, then 0), and the ramp of the
//! quasi-steady stall manoeuvre.
//!
//! 3-2-1-1: R. Koehler and K. Wilhelm, "Auslegung von Eingangssignalen für
//! die Kennwertermittlung", DFVLR-IB 154-77/40, 1977 (see also
//! R. V. Jategaonkar, *Flight Vehicle System Identification*, AIAA, ch. 2):
//! +A for 3Δt, −A for 2Δt, +A for Δt, −A for Δt.

use super::checker::{Checker, transpose};
use super::signal::{Polyline, Signal, Steps};
use super::spec::{DoubletSpec, MultistepSpec, RampSpec, StepSpec, ThreeTwoOneOneSpec};
use crate::state::Control;
use aeroid_core::units::Dimension;

impl StepSpec {
    pub(super) fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let start = checker.time("start", &self.start);
        let amplitude = checker.amplitude("amplitude", &self.amplitude, self.control);
        let transition = checker.transition(self.transition.as_ref(), f64::INFINITY);
        Some(Signal::Steps(
            Steps::new(self.control, start?, 0.0, vec![], amplitude?).ramped(transition?),
        ))
    }
}

impl DoubletSpec {
    pub(super) fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let start = checker.time("start", &self.start);
        let width = checker.positive("pulse_width", &self.pulse_width, Dimension::Time);
        let a = checker.amplitude("amplitude", &self.amplitude, self.control);
        let levels = vec![a?, -a?];
        let transition = checker.transition(self.transition.as_ref(), width?);
        Some(Signal::Steps(
            Steps::new(self.control, start?, width?, levels, 0.0).ramped(transition?),
        ))
    }
}

impl ThreeTwoOneOneSpec {
    /// The 3-2-1-1 as seven steps of one unit time: +A +A +A −A −A +A −A.
    pub(super) fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let start = checker.time("start", &self.start);
        let unit_time = checker.positive("unit_time", &self.unit_time, Dimension::Time);
        let a = checker.amplitude("amplitude", &self.amplitude, self.control);
        let a = a?;
        let levels = vec![a, a, a, -a, -a, a, -a];
        let transition = checker.transition(self.transition.as_ref(), unit_time?);
        Some(Signal::Steps(
            Steps::new(self.control, start?, unit_time?, levels, 0.0).ramped(transition?),
        ))
    }
}

impl MultistepSpec {
    pub(super) fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let start = checker.time("start", &self.start);
        let step_time = checker.positive("step_time", &self.step_time, Dimension::Time);
        if self.levels.is_empty() {
            checker.push("levels", "must list at least one level");
        }
        let levels: Vec<Option<f64>> = (self.levels.iter().enumerate())
            .map(|(i, level)| checker.amplitude(&format!("levels[{i}]"), level, self.control))
            .collect();
        let levels = levels.into_iter().collect::<Option<Vec<f64>>>()?;
        if levels.is_empty() {
            return None;
        }
        let transition = checker.transition(self.transition.as_ref(), step_time?);
        Some(Signal::Steps(
            Steps::new(self.control, start?, step_time?, levels, 0.0).ramped(transition?),
        ))
    }
}

impl RampSpec {
    pub(super) fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let start = checker.time("start", &self.start);
        let ramp_time = checker.positive("ramp_time", &self.ramp_time, Dimension::Time);
        let amplitude = checker.amplitude("amplitude", &self.amplitude, self.control);
        let hold_time = checker.non_negative("hold_time", &self.hold_time, Dimension::Time);
        let return_time = (self.return_time.as_ref())
            .map(|time| checker.positive("return_time", time, Dimension::Time));
        let return_time = transpose(return_time)?;
        let line = ramp(
            self.control,
            start?,
            ramp_time?,
            amplitude?,
            hold_time?,
            return_time,
        );
        Some(Signal::Polyline(line))
    }
}

fn ramp(
    control: Control,
    start: f64,
    ramp_time: f64,
    amplitude: f64,
    hold: f64,
    back: Option<f64>,
) -> Polyline {
    let top = start + ramp_time;
    let mut times = vec![start, top];
    let mut values = vec![0.0, amplitude];
    if hold > 0.0 {
        times.push(top + hold);
        values.push(amplitude);
    }
    if let Some(back) = back {
        times.push(top + hold + back);
        values.push(0.0);
    }
    Polyline {
        control: control.index(),
        times,
        values,
        after: if back.is_some() { 0.0 } else { amplitude },
    }
}
