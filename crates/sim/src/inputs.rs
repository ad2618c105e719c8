//! Control input signals that a scenario superposes on the trim controls.
//!
//! A scenario's `[[inputs]]` array holds one [`InputSpec`] per entry; each is
//! one signal on one control (a multisine drives several). The specs are
//! validated and pre-computed once into an [`InputSchedule`], whose
//! [`InputSchedule::deviation`] sums all signals at a time without allocating.
//!
//! References:
//! - 3-2-1-1: R. Koehler and K. Wilhelm, "Auslegung von Eingangssignalen für
//!   die Kennwertermittlung", DFVLR-IB 154-77/40, 1977 (see also
//!   R. V. Jategaonkar, *Flight Vehicle System Identification*, AIAA, ch. 2).
//! - Multisine: E. A. Morelli, "Multiple input design for real-time parameter
//!   estimation in the frequency domain", 13th IFAC Symposium on System
//!   Identification, 2003: harmonics of one fundamental interleaved over the
//!   inputs so that their spectra are disjoint, Schroeder phases
//!   φ_k = φ_1 − π k²/M for a low peak factor, each input shifted to start at
//!   zero. Morelli's further optimisation of the phases (relative peak factor
//!   ≈ 1.0–1.1) is not done: plain Schroeder phases give about 1.25–1.4.

use crate::state::{Control, Controls};
use aeroid_core::csv_table::CsvTable;
use aeroid_core::error::{Error, Problems};
use aeroid_core::units::{Dimension, Quantity, unit_factor};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

/// One `[[inputs]]` entry as written in a scenario file, selected by `kind`.
/// Amplitudes and levels have the control's dimension (angle; throttle:
/// fraction); times are times; `start` defaults to 0.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum InputSpec {
    Step(StepSpec),
    Doublet(DoubletSpec),
    #[serde(rename = "3211")]
    ThreeTwoOneOne(ThreeTwoOneOneSpec),
    Multistep(MultistepSpec),
    Multisine(MultisineSpec),
    Ramp(RampSpec),
    Csv(CsvSpec),
}

/// `kind = "step"`: `amplitude` from `start` on, held to the end of the run.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StepSpec {
    pub control: Control,
    #[serde(default)]
    pub start: Quantity,
    pub amplitude: Quantity,
    /// Time each change takes, as a linear ramp from its switch time (a
    /// surface moved by an actuator); 0, the default, is a step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transition: Option<Quantity>,
}

/// `kind = "doublet"`: +amplitude for `pulse_width`, −amplitude for `pulse_width`, then 0.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DoubletSpec {
    pub control: Control,
    #[serde(default)]
    pub start: Quantity,
    pub pulse_width: Quantity,
    pub amplitude: Quantity,
    /// Time each change takes, as a linear ramp from its switch time (a
    /// surface moved by an actuator); 0, the default, is a step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transition: Option<Quantity>,
}

/// `kind = "3211"`: +A for 3Δt, −A for 2Δt, +A for Δt, −A for Δt, then 0
/// (Δt = `unit_time`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ThreeTwoOneOneSpec {
    pub control: Control,
    #[serde(default)]
    pub start: Quantity,
    pub unit_time: Quantity,
    pub amplitude: Quantity,
    /// Time each change takes, as a linear ramp from its switch time (a
    /// surface moved by an actuator); 0, the default, is a step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transition: Option<Quantity>,
}

/// `kind = "multistep"`: each of `levels` held for `step_time`, then 0.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MultistepSpec {
    pub control: Control,
    #[serde(default)]
    pub start: Quantity,
    pub step_time: Quantity,
    pub levels: Vec<Quantity>,
    /// Time each change takes, as a linear ramp from its switch time (a
    /// surface moved by an actuator); 0, the default, is a step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transition: Option<Quantity>,
}

/// `kind = "multisine"`: Schroeder-phased multisine on several controls
/// (Morelli 2003), lasting `cycles` periods, then 0. `harmonics` lists the
/// harmonic numbers k (frequency k/period) to use, which must lie inside the
/// band if one is given; without it, every harmonic inside
/// [`frequency_min`, `frequency_max`] is used. Harmonic j (in ascending
/// order) goes to control j mod n; each control peaks at its amplitude.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MultisineSpec {
    pub controls: Vec<Control>,
    pub amplitudes: Vec<Quantity>,
    #[serde(default)]
    pub start: Quantity,
    pub period: Quantity,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub harmonics: Option<Vec<u32>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frequency_min: Option<Quantity>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frequency_max: Option<Quantity>,
    #[serde(default = "one_cycle")]
    pub cycles: u32,
}

/// `kind = "ramp"`: linear 0 → amplitude over `ramp_time`, held for
/// `hold_time`, then back to 0 over `return_time` if given (else held to the
/// end of the run); the quasi-steady stall manoeuvre.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RampSpec {
    pub control: Control,
    #[serde(default)]
    pub start: Quantity,
    pub ramp_time: Quantity,
    pub amplitude: Quantity,
    #[serde(default)]
    pub hold_time: Quantity,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub return_time: Option<Quantity>,
}

/// `kind = "csv"`: replays `column` of a CSV file with a header line (path
/// relative to the scenario file), interpolated linearly in `time_column`
/// (s, default "time") shifted by `start`; 0 before the first and after the
/// last sample. `unit` is the column's unit (default SI: rad; throttle: fraction).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CsvSpec {
    pub control: Control,
    pub file: PathBuf,
    #[serde(default = "default_time_column")]
    pub time_column: String,
    pub column: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    #[serde(default)]
    pub start: Quantity,
}

fn one_cycle() -> u32 {
    1
}

fn default_time_column() -> String {
    "time".to_string()
}

/// Signals built from the specs, evaluated at any time.
#[derive(Debug, Clone)]
pub struct InputSchedule {
    signals: Vec<Signal>,
    /// Every deviation times this (1 as the file gives it).
    scale: f64,
}

impl Default for InputSchedule {
    /// No inputs.
    fn default() -> Self {
        InputSchedule {
            signals: Vec::new(),
            scale: 1.0,
        }
    }
}

impl InputSchedule {
    /// Validates every spec, collecting ALL problems (field paths like
    /// `inputs[2].amplitude`), reading CSV files relative to `base_dir`.
    /// `scenario_path` is the scenario file named in errors. CSV files are read
    /// only once the specs themselves are free of problems.
    pub fn build(
        specs: &[InputSpec],
        base_dir: &Path,
        scenario_path: &Path,
    ) -> aeroid_core::Result<InputSchedule> {
        let mut problems = Problems::default();
        let pending: Vec<Pending> = specs
            .iter()
            .enumerate()
            .filter_map(|(index, spec)| {
                let mut checker = Checker {
                    problems: &mut problems,
                    prefix: format!("inputs[{index}]"),
                };
                resolve(spec, &mut checker)
            })
            .collect();
        problems.finish(scenario_path, ())?;
        let signals = pending
            .into_iter()
            .map(|item| item.load(base_dir, scenario_path))
            .collect::<aeroid_core::Result<Vec<Signal>>>()?;
        Ok(InputSchedule {
            signals,
            scale: 1.0,
        })
    }

    /// Sum of all signals at time `time` (s): deviation from trim, SI/rad
    /// (throttle: fraction). Does not allocate.
    pub fn deviation(&self, time: f64) -> Controls {
        let mut deviation = Controls::zeros();
        for signal in &self.signals {
            signal.add_to(time, &mut deviation);
        }
        if self.scale != 1.0 {
            deviation *= self.scale;
        }
        deviation
    }

    /// True when the scenario has no input signals.
    pub fn is_empty(&self) -> bool {
        self.signals.is_empty()
    }

    /// The same inputs with every deviation from trim times `factor`
    /// (a study's input-amplitude axis).
    pub fn scaled(&self, factor: f64) -> InputSchedule {
        InputSchedule {
            signals: self.signals.clone(),
            scale: self.scale * factor,
        }
    }
}

// ---------------------------------------------------------------------------
// Pre-computed signals

#[derive(Debug, Clone)]
enum Signal {
    Steps(Steps),
    Polyline(Polyline),
    Multisine(Multisine),
}

impl Signal {
    fn add_to(&self, time: f64, deviation: &mut Controls) {
        match self {
            Signal::Steps(steps) => deviation[steps.control] += steps.value(time),
            Signal::Polyline(line) => deviation[line.control] += line.value(time),
            Signal::Multisine(sine) => sine.add_to(time, deviation),
        }
    }
}

/// Tolerance (s) of a step input's switch times against rounding.
const SWITCH_TOLERANCE: f64 = 1e-10;

/// Piecewise constant: 0 before `times[0]`, `levels[i]` on
/// [`times[i]`, `times[i+1]`), `after` from the last time on; each change
/// a linear ramp over `transition` from its switch time (0: a step).
#[derive(Debug, Clone)]
struct Steps {
    control: usize,
    times: Vec<f64>,
    levels: Vec<f64>,
    after: f64,
    transition: f64,
}

impl Steps {
    /// Levels starting at `start`, each held `duration`, then `after`.
    fn new(control: Control, start: f64, duration: f64, levels: Vec<f64>, after: f64) -> Steps {
        let times = (0..=levels.len())
            .map(|i| start + i as f64 * duration)
            .collect();
        Steps {
            control: control.index(),
            times,
            levels,
            after,
            transition: 0.0,
        }
    }

    /// The same levels, each change a ramp over `transition`.
    fn ramped(self, transition: f64) -> Steps {
        Steps { transition, ..self }
    }

    /// A switch within [`SWITCH_TOLERANCE`] (0.1 ns) after `time` counts as reached:
    /// switch times are sums such as 3 + 3·1.6 = 7.800000000000001, and a
    /// switch meant to fall on a sample instant must not slip a whole step.
    fn value(&self, time: f64) -> f64 {
        let time = time + SWITCH_TOLERANCE;
        if time.is_nan() || time < self.times[0] {
            return 0.0;
        }
        let passed = self.times.partition_point(|&t| t <= time);
        let level = self.levels.get(passed - 1).copied().unwrap_or(self.after);
        let since = time - self.times[passed - 1];
        if since >= self.transition {
            return level;
        }
        let previous = match passed {
            1 => 0.0,
            _ => self.levels[passed - 2],
        };
        previous + (level - previous) * since / self.transition
    }
}

/// Piecewise linear through (`times`, `values`): 0 before the first point,
/// `after` after the last.
#[derive(Debug, Clone)]
struct Polyline {
    control: usize,
    times: Vec<f64>,
    values: Vec<f64>,
    after: f64,
}

impl Polyline {
    fn value(&self, time: f64) -> f64 {
        let last = self.times.len() - 1;
        if time.is_nan() || time < self.times[0] {
            return 0.0;
        }
        if time >= self.times[last] {
            return if time == self.times[last] {
                self.values[last]
            } else {
                self.after
            };
        }
        let next = self.times.partition_point(|&t| t <= time);
        let (t0, t1) = (self.times[next - 1], self.times[next]);
        let (v0, v1) = (self.values[next - 1], self.values[next]);
        v0 + (v1 - v0) * (time - t0) / (t1 - t0)
    }
}

/// One sinusoid `amplitude · cos(frequency · τ + phase)` of a multisine, τ
/// the time since the multisine's start.
#[derive(Debug, Clone, Copy)]
struct Harmonic {
    control: usize,
    amplitude: f64,
    /// Angular frequency (rad/s).
    frequency: f64,
    phase: f64,
}

#[derive(Debug, Clone)]
struct Multisine {
    start: f64,
    end: f64,
    harmonics: Vec<Harmonic>,
}

impl Multisine {
    fn add_to(&self, time: f64, deviation: &mut Controls) {
        if time >= self.start && time < self.end {
            let elapsed = time - self.start;
            for harmonic in &self.harmonics {
                deviation[harmonic.control] +=
                    harmonic.amplitude * (harmonic.frequency * elapsed + harmonic.phase).cos();
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Validation

/// Reads a spec's quantities, pushing a problem under `prefix.field` for each bad one.
struct Checker<'a> {
    problems: &'a mut Problems,
    prefix: String,
}

impl Checker<'_> {
    fn push(&mut self, field: &str, message: impl Into<String>) {
        self.problems
            .push(format!("{}.{field}", self.prefix), message);
    }

    fn quantity(&mut self, field: &str, quantity: &Quantity, dimension: Dimension) -> Option<f64> {
        quantity
            .si(dimension)
            .map_err(|message| self.push(field, message))
            .ok()
    }

    /// A value of the control's dimension (amplitude, level), within the
    /// control's range ([`aeroid_core::limits::MAX_DEFLECTION`], [`aeroid_core::limits::MAX_THROTTLE`]).
    fn amplitude(&mut self, field: &str, quantity: &Quantity, control: Control) -> Option<f64> {
        let value = self.quantity(field, quantity, control.dimension())?;
        self.within_range(field, quantity, value, control)
    }

    fn within_range(
        &mut self,
        field: &str,
        quantity: &Quantity,
        value: f64,
        control: Control,
    ) -> Option<f64> {
        let (limit, text) = match control {
            Control::Throttle => (
                aeroid_core::limits::MAX_THROTTLE,
                format!(
                    "{}, the whole range of thrust",
                    aeroid_core::limits::MAX_THROTTLE
                ),
            ),
            _ => (
                aeroid_core::limits::MAX_DEFLECTION,
                format!(
                    "{} deg (no control surface deflects further)",
                    aeroid_core::limits::MAX_DEFLECTION.to_degrees()
                ),
            ),
        };
        if value.abs() <= limit {
            Some(value)
        } else {
            self.push(
                field,
                format!(
                    "{} is beyond the {} input's largest magnitude {text}",
                    quantity.to_string().trim_matches('"'),
                    control.name()
                ),
            );
            None
        }
    }

    /// An input's start: not before the flight begins at 0 s.
    fn time(&mut self, field: &str, quantity: &Quantity) -> Option<f64> {
        let value = self.quantity(field, quantity, Dimension::Time)?;
        if value >= 0.0 {
            Some(value)
        } else {
            self.push(
                field,
                format!(
                    "{} is before the flight begins at 0 s; an input starts at 0 s or later",
                    quantity.to_string().trim_matches('"')
                ),
            );
            None
        }
    }

    /// A strictly positive value (widths, periods, durations).
    fn positive(&mut self, field: &str, quantity: &Quantity, dimension: Dimension) -> Option<f64> {
        let value = self.quantity(field, quantity, dimension)?;
        if value > 0.0 {
            Some(value)
        } else {
            self.push(field, format!("must be positive, got {quantity}"));
            None
        }
    }

    /// A step input's `transition`: 0 when absent, else not negative and
    /// at most `hold` (each level is held that long, so one change ends
    /// before the next begins).
    fn transition(&mut self, quantity: Option<&Quantity>, hold: f64) -> Option<f64> {
        let Some(quantity) = quantity else {
            return Some(0.0);
        };
        let value = self.non_negative("transition", quantity, Dimension::Time)?;
        if value > hold {
            self.push(
                "transition",
                format!("{quantity} is longer than a level is held ({hold} s)"),
            );
            return None;
        }
        Some(value)
    }

    fn non_negative(
        &mut self,
        field: &str,
        quantity: &Quantity,
        dimension: Dimension,
    ) -> Option<f64> {
        let value = self.quantity(field, quantity, dimension)?;
        if value >= 0.0 {
            Some(value)
        } else {
            self.push(field, format!("must not be negative, got {quantity}"));
            None
        }
    }
}

/// A validated spec: a finished signal, or a CSV file still to read.
enum Pending {
    Ready(Signal),
    Csv(CsvRequest),
}

impl Pending {
    fn load(self, base_dir: &Path, scenario_path: &Path) -> aeroid_core::Result<Signal> {
        match self {
            Pending::Ready(signal) => Ok(signal),
            Pending::Csv(request) => request.load(base_dir, scenario_path),
        }
    }
}

/// Validates one spec; `None` when it has problems (already pushed).
fn resolve(spec: &InputSpec, checker: &mut Checker) -> Option<Pending> {
    let signal = match spec {
        InputSpec::Step(step) => step.resolve(checker),
        InputSpec::Doublet(doublet) => doublet.resolve(checker),
        InputSpec::ThreeTwoOneOne(three_two_one_one) => three_two_one_one.resolve(checker),
        InputSpec::Multistep(multistep) => multistep.resolve(checker),
        InputSpec::Multisine(multisine) => multisine.resolve(checker),
        InputSpec::Ramp(ramp) => ramp.resolve(checker),
        InputSpec::Csv(csv) => return csv.resolve(checker).map(Pending::Csv),
    };
    signal.map(Pending::Ready)
}

impl StepSpec {
    fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let start = checker.time("start", &self.start);
        let amplitude = checker.amplitude("amplitude", &self.amplitude, self.control);
        let transition = checker.transition(self.transition.as_ref(), f64::INFINITY);
        Some(Signal::Steps(
            Steps::new(self.control, start?, 0.0, vec![], amplitude?).ramped(transition?),
        ))
    }
}

impl DoubletSpec {
    fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
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
    fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
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
    fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
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
    fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
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

/// An optional field that failed validation is `None`; one absent or valid is `Some`.
fn transpose(value: Option<Option<f64>>) -> Option<Option<f64>> {
    match value {
        Some(None) => None,
        Some(Some(value)) => Some(Some(value)),
        None => Some(None),
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

// ---------------------------------------------------------------------------
// Multisine (Morelli 2003)

/// A multisine's validated numbers, before the harmonics are laid out.
struct MultisinePlan {
    controls: Vec<Control>,
    amplitudes: Vec<f64>,
    start: f64,
    period: f64,
    harmonic_numbers: Vec<u32>,
    cycles: u32,
}

/// Most harmonics one multisine may use: beyond this, the band or the period is a typo.
const MAXIMUM_HARMONICS: usize = 10_000;

impl MultisineSpec {
    fn resolve(&self, checker: &mut Checker) -> Option<Signal> {
        let plan = self.plan(checker)?;
        let control_count = plan.controls.len();
        let mut harmonics = Vec::with_capacity(plan.harmonic_numbers.len());
        let mut valid = true;
        for (slot, (&control, &amplitude)) in plan.controls.iter().zip(&plan.amplitudes).enumerate()
        {
            let numbers: Vec<u32> = (plan.harmonic_numbers.iter().copied())
                .skip(slot)
                .step_by(control_count)
                .collect();
            if numbers.len() < 2 {
                let message = format!(
                    "control '{}' gets {} harmonic(s) but needs at least 2: widen the band, lengthen the period or list more harmonics",
                    control.name(),
                    numbers.len()
                );
                checker.push("harmonics", message);
                valid = false;
                continue;
            }
            harmonics.extend(control_harmonics(control, amplitude, plan.period, &numbers));
        }
        valid.then_some(())?;
        Some(Signal::Multisine(Multisine {
            start: plan.start,
            end: plan.start + f64::from(plan.cycles) * plan.period,
            harmonics,
        }))
    }

    fn plan(&self, checker: &mut Checker) -> Option<MultisinePlan> {
        let controls_valid = check_multisine_controls(checker, &self.controls);
        let amplitudes = multisine_amplitudes(checker, &self.controls, &self.amplitudes);
        let start = checker.time("start", &self.start);
        let period = checker.positive("period", &self.period, Dimension::Time);
        if self.cycles == 0 {
            checker.push("cycles", "must be at least 1");
        }
        let band = frequency_band(
            checker,
            self.frequency_min.as_ref(),
            self.frequency_max.as_ref(),
        );
        let harmonic_numbers = harmonic_numbers(checker, self.harmonics.as_deref(), band?, period?);
        (controls_valid && self.cycles > 0).then_some(())?;
        Some(MultisinePlan {
            controls: self.controls.clone(),
            amplitudes: amplitudes?,
            start: start?,
            period: period?,
            harmonic_numbers: harmonic_numbers?,
            cycles: self.cycles,
        })
    }
}

/// At least one control, none twice.
fn check_multisine_controls(checker: &mut Checker, controls: &[Control]) -> bool {
    if controls.is_empty() {
        checker.push("controls", "must list at least one control");
        return false;
    }
    let mut valid = true;
    for (i, control) in controls.iter().enumerate() {
        if controls[..i].contains(control) {
            let message = format!(
                "'{}' appears twice; each control needs its own harmonics",
                control.name()
            );
            checker.push("controls", message);
            valid = false;
        }
    }
    valid
}

/// One positive amplitude per control, in that control's dimension.
fn multisine_amplitudes(
    checker: &mut Checker,
    controls: &[Control],
    amplitudes: &[Quantity],
) -> Option<Vec<f64>> {
    if amplitudes.len() != controls.len() {
        let message = format!(
            "{} controls but {} amplitudes",
            controls.len(),
            amplitudes.len()
        );
        checker.push("amplitudes", message);
        return None;
    }
    let values: Vec<Option<f64>> = controls
        .iter()
        .zip(amplitudes)
        .enumerate()
        .map(|(i, (&control, amplitude))| {
            let field = format!("amplitudes[{i}]");
            let value = checker.positive(&field, amplitude, control.dimension())?;
            checker.within_range(&field, amplitude, value, control)
        })
        .collect();
    values.into_iter().collect()
}

/// The optional band [frequency_min, frequency_max] in Hz; `None` when invalid.
fn frequency_band(
    checker: &mut Checker,
    minimum: Option<&Quantity>,
    maximum: Option<&Quantity>,
) -> Option<(Option<f64>, Option<f64>)> {
    let low = minimum.map(|q| checker.non_negative("frequency_min", q, Dimension::Frequency));
    let high = maximum.map(|q| checker.positive("frequency_max", q, Dimension::Frequency));
    let (low, high) = (transpose(low)?, transpose(high)?);
    if let (Some(low), Some(high)) = (low, high)
        && low >= high
    {
        checker.push(
            "frequency_min",
            format!("must be below frequency_max ({low} Hz ≥ {high} Hz)"),
        );
        return None;
    }
    Some((low, high))
}

/// The sorted harmonic numbers k (frequency k/period): the listed ones, which
/// must lie inside the band if one is given, or every one inside the band.
fn harmonic_numbers(
    checker: &mut Checker,
    listed: Option<&[u32]>,
    band: (Option<f64>, Option<f64>),
    period: f64,
) -> Option<Vec<u32>> {
    let numbers = match (listed, band) {
        (Some(listed), _) => check_listed_harmonics(checker, listed, band, period)?,
        (None, (Some(_), Some(high)))
            if (high * period).is_nan() || high * period >= u32::MAX as f64 =>
        {
            let message = format!(
                "{period} s at frequency_max {high} Hz puts the harmonic numbers beyond {}: check the band and period",
                u32::MAX
            );
            checker.push("period", message);
            return None;
        }
        (None, (Some(low), Some(high))) => harmonics_in_band(low, high, period),
        (None, _) => {
            let message = "frequency_min and frequency_max are required unless harmonics is given";
            checker.push("harmonics", message);
            return None;
        }
    };
    if numbers.len() > MAXIMUM_HARMONICS {
        let message = format!(
            "{} harmonics (more than {MAXIMUM_HARMONICS}): check the band and period",
            numbers.len()
        );
        checker.push("harmonics", message);
        return None;
    }
    Some(numbers)
}

/// Tolerance when comparing a harmonic's frequency with the band edges, so
/// that e.g. 0.1 Hz · 10 s counts as harmonic 1 despite rounding.
const BAND_TOLERANCE: f64 = 1e-9;

fn harmonics_in_band(low: f64, high: f64, period: f64) -> Vec<u32> {
    let first = (low * period - BAND_TOLERANCE).ceil().max(1.0);
    let last = (high * period + BAND_TOLERANCE).floor();
    let count = (last - first + 1.0).clamp(0.0, (MAXIMUM_HARMONICS + 1) as f64) as u32;
    (0..count).map(|i| first as u32 + i).collect()
}

fn check_listed_harmonics(
    checker: &mut Checker,
    listed: &[u32],
    band: (Option<f64>, Option<f64>),
    period: f64,
) -> Option<Vec<u32>> {
    let mut numbers = listed.to_vec();
    numbers.sort_unstable();
    let length = numbers.len();
    numbers.dedup();
    let mut valid = true;
    if numbers.len() != length {
        checker.push("harmonics", "lists a harmonic twice");
        valid = false;
    }
    if numbers.first() == Some(&0) {
        checker.push(
            "harmonics",
            "harmonic 0 is a constant, not a sinusoid; harmonics start at 1",
        );
        valid = false;
    }
    let low = band.0.unwrap_or(0.0) * period - BAND_TOLERANCE;
    let high = band
        .1
        .map_or(f64::INFINITY, |high| high * period + BAND_TOLERANCE);
    if let Some(outside) = numbers
        .iter()
        .find(|&&k| f64::from(k) < low || f64::from(k) > high)
    {
        let message = format!(
            "harmonic {outside} ({} Hz) lies outside the frequency band",
            f64::from(*outside) / period
        );
        checker.push("harmonics", message);
        valid = false;
    }
    valid.then_some(numbers)
}

/// One control's harmonics: equal amplitudes, Schroeder phases
/// φ_k = φ_1 − π k²/M (k = 1..M over this control's own harmonics, φ_1 = 0),
/// shifted in time to start at a zero crossing, scaled to peak `amplitude`.
fn control_harmonics(
    control: Control,
    amplitude: f64,
    period: f64,
    numbers: &[u32],
) -> Vec<Harmonic> {
    let count = numbers.len() as f64;
    let mut harmonics: Vec<Harmonic> = numbers
        .iter()
        .enumerate()
        .map(|(i, &number)| Harmonic {
            control: control.index(),
            amplitude: 1.0,
            frequency: TAU * f64::from(number) / period,
            phase: -PI * ((i + 1) as f64).powi(2) / count,
        })
        .collect();
    let shift = zero_crossing_nearest_origin(&harmonics, period);
    for harmonic in &mut harmonics {
        harmonic.phase = (harmonic.phase + harmonic.frequency * shift).rem_euclid(TAU);
    }
    let peak = peak_magnitude(&harmonics, period);
    for harmonic in &mut harmonics {
        harmonic.amplitude = amplitude / peak;
    }
    harmonics
}

fn sum_of(harmonics: &[Harmonic], time: f64) -> f64 {
    harmonics
        .iter()
        .map(|h| h.amplitude * (h.frequency * time + h.phase).cos())
        .sum()
}

fn slope_of(harmonics: &[Harmonic], time: f64) -> f64 {
    harmonics
        .iter()
        .map(|h| -h.amplitude * h.frequency * (h.frequency * time + h.phase).sin())
        .sum()
}

/// Grid spacing for searches: 64 points per cycle of the highest harmonic.
fn search_step(harmonics: &[Harmonic]) -> f64 {
    let highest = harmonics.iter().map(|h| h.frequency).fold(0.0, f64::max);
    TAU / highest / 64.0
}

/// The zero of the sum nearest t = 0: a grid search outwards from 0 in both
/// directions, then bisection of the first bracket found.
fn zero_crossing_nearest_origin(harmonics: &[Harmonic], period: f64) -> f64 {
    let step = search_step(harmonics);
    let value = |time: f64| sum_of(harmonics, time);
    let steps = (0.5 * period / step).ceil() as usize;
    for i in 0..steps {
        let near = i as f64 * step;
        for (a, b) in [(near, near + step), (-near, -near - step)] {
            if value(a) == 0.0 {
                return a;
            }
            if value(a) * value(b) < 0.0 {
                return bisect(value, a, b);
            }
        }
    }
    0.0 // unreachable for a zero-mean sum: it crosses zero within every period
}

/// A root of `function` in [a, b] where it changes sign, to machine precision.
fn bisect(function: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let positive_at_a = function(a) > 0.0;
    for _ in 0..200 {
        let middle = 0.5 * (a + b);
        if middle == a || middle == b {
            break;
        }
        if (function(middle) > 0.0) == positive_at_a {
            a = middle;
        } else {
            b = middle;
        }
    }
    0.5 * (a + b)
}

/// max |sum| over one period: the grid's local maxima near the top, each
/// refined by bisecting the slope between its neighbours.
fn peak_magnitude(harmonics: &[Harmonic], period: f64) -> f64 {
    let count = (period / search_step(harmonics)).ceil() as usize;
    let step = period / count as f64;
    let samples: Vec<f64> = (0..count)
        .map(|i| sum_of(harmonics, i as f64 * step).abs())
        .collect();
    let grid_peak = samples.iter().copied().fold(0.0, f64::max);
    let mut peak = grid_peak;
    for i in 0..count {
        let (before, after) = (samples[(i + count - 1) % count], samples[(i + 1) % count]);
        if samples[i] >= 0.8 * grid_peak && samples[i] >= before && samples[i] >= after {
            let centre = i as f64 * step;
            let sign = sum_of(harmonics, centre).signum();
            let outward_slope = |time: f64| sign * slope_of(harmonics, time);
            let top = bisect(outward_slope, centre - step, centre + step);
            peak = peak.max(sum_of(harmonics, top).abs());
        }
    }
    peak
}

// ---------------------------------------------------------------------------
// CSV replay

/// A validated `csv` spec whose file is still to be read.
struct CsvRequest {
    control: usize,
    file: PathBuf,
    /// The spec's field naming the file (`inputs[2].file`), for errors.
    field: String,
    time_column: String,
    column: String,
    /// Factor from the column's unit to SI.
    factor: f64,
    /// Added to the file's times.
    shift: f64,
}

impl CsvSpec {
    /// Checks the unit and shift; the file is read later by [`CsvRequest::load`].
    fn resolve(&self, checker: &mut Checker) -> Option<CsvRequest> {
        // A shift, not a start: a negative one moves a file whose clock
        // starts late back to the flight's 0 s.
        let shift = checker.quantity("start", &self.start, Dimension::Time);
        let factor = (self.unit.as_deref())
            .map_or(Ok(1.0), |unit| unit_factor(unit, self.control.dimension()));
        let factor = factor.map_err(|message| checker.push("unit", message)).ok();
        let file = self.file.to_string_lossy();
        if !aeroid_core::paths::stays_inside(&file) {
            checker.push(
                "file",
                format!(
                    "'{file}' leaves the scenario's folder; name a CSV file inside it by a relative path without '..'"
                ),
            );
            return None;
        }
        Some(CsvRequest {
            control: self.control.index(),
            file: self.file.clone(),
            field: format!("{}.file", checker.prefix),
            time_column: self.time_column.clone(),
            column: self.column.clone(),
            factor: factor?,
            shift: shift?,
        })
    }
}

impl CsvRequest {
    fn load(self, base_dir: &Path, scenario_path: &Path) -> aeroid_core::Result<Signal> {
        let path = aeroid_core::paths::inside(
            base_dir,
            &self.file.to_string_lossy(),
            scenario_path,
            &self.field,
        )?;
        let (times, values) = read_csv_columns(&path, &self.time_column, &self.column)?;
        Ok(Signal::Polyline(Polyline {
            control: self.control,
            times: times.into_iter().map(|time| time + self.shift).collect(),
            values: values
                .into_iter()
                .map(|value| value * self.factor)
                .collect(),
            after: 0.0,
        }))
    }
}

/// The time column (finite, strictly increasing) and value column (finite)
/// of a CSV file with a header line; errors name the line (1-based, as in the
/// file) and column.
fn read_csv_columns(
    path: &Path,
    time_column: &str,
    column: &str,
) -> aeroid_core::Result<(Vec<f64>, Vec<f64>)> {
    let table = CsvTable::read(path)?;
    let time_index = table.column_index(time_column)?;
    let value_index = table.column_index(column)?;
    let times = table.time_column(time_index)?;
    let values = table.finite_numbers(value_index)?;
    if times.len() < 2 {
        return Err(Error::Csv {
            path: path.to_path_buf(),
            line: times.len() as u64 + 1,
            column: time_column.to_string(),
            message: "needs at least 2 samples".into(),
        });
    }
    Ok((times, values))
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_core::units::DEG;

    #[derive(Deserialize)]
    struct Scenario {
        inputs: Vec<InputSpec>,
    }

    fn parse(text: &str) -> Vec<InputSpec> {
        toml::from_str::<Scenario>(text).expect("valid TOML").inputs
    }

    fn schedule(text: &str) -> InputSchedule {
        InputSchedule::build(&parse(text), Path::new("."), Path::new("test.toml"))
            .expect("valid inputs")
    }

    fn problems(text: &str) -> Vec<aeroid_core::error::Problem> {
        match InputSchedule::build(&parse(text), Path::new("."), Path::new("test.toml")) {
            Err(Error::Invalid { problems, .. }) => problems,
            other => panic!("expected Error::Invalid, got {other:?}"),
        }
    }

    const TINY: f64 = 1e-9;

    fn elevator(schedule: &InputSchedule, time: f64) -> f64 {
        schedule.deviation(time)[Control::Elevator.index()]
    }

    #[test]
    fn step_holds_amplitude_from_start_on() {
        let s = schedule(
            "[[inputs]]\nkind = \"step\"\ncontrol = \"throttle\"\nstart = \"500 ms\"\namplitude = \"10 %\"",
        );
        let throttle = |t: f64| s.deviation(t)[Control::Throttle.index()];
        assert_eq!(throttle(0.5 - TINY), 0.0);
        assert!((throttle(0.5 + TINY) - 0.1).abs() < 1e-15);
        assert!((throttle(1e4) - 0.1).abs() < 1e-15);
        assert_eq!(s.deviation(1.0)[Control::Elevator.index()], 0.0);
    }

    /// Switch times are sums that round: 3 + 3·1.6 = 7.800000000000001. A
    /// switch meant for the sample instant 7.8 s must happen there, not one
    /// simulator step (or recorder sample) later.
    #[test]
    fn a_rounded_switch_time_lands_on_its_instant() {
        let s = schedule(
            "[[inputs]]\nkind = \"3211\"\ncontrol = \"elevator\"\nstart = 3\nunit_time = 1.6\namplitude = 0.03",
        );
        let switch = std::hint::black_box(3.0) + 3.0 * std::hint::black_box(1.6);
        assert!(switch > 7.8, "the rounding this test is about");
        assert_eq!(elevator(&s, 7.8), -0.03);
        assert_eq!(elevator(&s, 780.0 * 0.01), -0.03);
        assert_eq!(elevator(&s, 195.0 * 0.04), -0.03);
    }

    /// With a `transition`, each change of a step input is a linear ramp
    /// from its switch time: halfway through it the value is halfway, and
    /// after it the level holds; a transition longer than a level is held,
    /// or negative, is refused.
    #[test]
    fn transitions_ramp_each_change() {
        let s = schedule(
            "[[inputs]]\nkind = \"doublet\"\ncontrol = \"elevator\"\nstart = 1\npulse_width = 0.5\namplitude = 0.02\ntransition = \"0.04 s\"",
        );
        for (time, expected) in [
            (0.99, 0.0),
            (1.02, 0.01),
            (1.2, 0.02),
            (1.51, 0.01),
            (1.52, 0.0),
            (1.8, -0.02),
            (2.02, -0.01),
            (2.5, 0.0),
        ] {
            assert!(
                (elevator(&s, time) - expected).abs() < 1e-9,
                "{time}: {}",
                elevator(&s, time)
            );
        }
        let step = schedule(
            "[[inputs]]\nkind = \"step\"\ncontrol = \"elevator\"\nstart = 1\namplitude = 0.02\ntransition = \"2 s\"",
        );
        assert!((elevator(&step, 2.5) - 0.015).abs() < 1e-9);
        let long = problems(
            "[[inputs]]\nkind = \"3211\"\ncontrol = \"elevator\"\nunit_time = 0.5\namplitude = 0.02\ntransition = \"0.6 s\"\n\n[[inputs]]\nkind = \"multistep\"\ncontrol = \"rudder\"\nstep_time = 1\nlevels = [0.01]\ntransition = -1",
        );
        let fields: Vec<&str> = long.iter().map(|p| p.field.as_str()).collect();
        assert_eq!(fields, ["inputs[0].transition", "inputs[1].transition"]);
    }

    #[test]
    fn doublet_switches_at_each_pulse_edge() {
        let s = schedule(
            "[[inputs]]\nkind = \"doublet\"\ncontrol = \"elevator\"\nstart = 1\npulse_width = 0.5\namplitude = \"2 deg\"",
        );
        let a = 2.0 * DEG;
        for (time, expected) in [(1.0, 0.0), (1.5, a), (2.0, -a)] {
            assert_eq!(elevator(&s, time - TINY), expected, "just before {time}");
        }
        for (time, expected) in [(1.0, a), (1.5, -a), (2.0, 0.0)] {
            assert_eq!(elevator(&s, time + TINY), expected, "just after {time}");
        }
    }

    #[test]
    fn three_two_one_one_switches_and_integrates_to_amplitude_times_unit_time() {
        let s = schedule(
            "[[inputs]]\nkind = \"3211\"\ncontrol = \"elevator\"\nstart = 2\nunit_time = 0.4\namplitude = 0.03",
        );
        let a = 0.03;
        let edges = [
            (2.0, 0.0, a),
            (3.2, a, -a),
            (4.0, -a, a),
            (4.4, a, -a),
            (4.8, -a, 0.0),
        ];
        for (time, before, after) in edges {
            assert_eq!(elevator(&s, time - TINY), before, "just before {time}");
            assert_eq!(elevator(&s, time + TINY), after, "just after {time}");
        }
        let step = 1e-4;
        let integral: f64 = (0..60_000)
            .map(|i| elevator(&s, (i as f64 + 0.5) * step) * step)
            .sum();
        assert!((integral - a * 0.4).abs() < 1e-9, "integral {integral}");
    }

    #[test]
    fn multistep_holds_each_level_then_returns_to_zero() {
        let s = schedule(
            "[[inputs]]\nkind = \"multistep\"\ncontrol = \"rudder\"\nstep_time = 0.25\nlevels = [1, \"-2 deg\", 0.5]",
        );
        let rudder = |t: f64| s.deviation(t)[Control::Rudder.index()];
        for (time, expected) in [
            (0.1, 1.0),
            (0.249, 1.0),
            (0.26, -2.0 * DEG),
            (0.6, 0.5),
            (0.76, 0.0),
        ] {
            assert_eq!(rudder(time), expected, "at {time}");
        }
        assert_eq!(rudder(-0.01), 0.0);
    }

    #[test]
    fn ramp_rises_holds_and_returns() {
        let text = "[[inputs]]\nkind = \"ramp\"\ncontrol = \"elevator\"\nstart = 1\nramp_time = 10\namplitude = \"-10 deg\"\nhold_time = 2\nreturn_time = 4";
        let s = schedule(text);
        let a = -10.0 * DEG;
        assert_eq!(elevator(&s, 1.0 - TINY), 0.0);
        assert!((elevator(&s, 3.5) - 0.25 * a).abs() < 1e-15);
        let slope = (elevator(&s, 7.0) - elevator(&s, 6.0)) / 1.0;
        assert!((slope - a / 10.0).abs() < 1e-12);
        assert!((elevator(&s, 12.0) - a).abs() < 1e-15);
        assert!((elevator(&s, 14.0) - 0.75 * a).abs() < 1e-12);
        assert_eq!(elevator(&s, 17.0 + TINY), 0.0);
        let without_return = schedule(
            "[[inputs]]\nkind = \"ramp\"\ncontrol = \"elevator\"\nramp_time = 2\namplitude = 0.1",
        );
        assert!((elevator(&without_return, 1.0) - 0.05).abs() < 1e-15);
        assert_eq!(elevator(&without_return, 100.0), 0.1);
    }

    const MULTISINE: &str = "[[inputs]]\nkind = \"multisine\"\ncontrols = [\"elevator\", \"aileron\", \"rudder\"]\namplitudes = [\"2 deg\", \"3 deg\", 0.02]\nstart = 1.5\nperiod = 10\nfrequency_min = \"0.1 Hz\"\nfrequency_max = \"3 Hz\"";

    /// One period of each control's signal, `count` samples from the start.
    fn one_period(s: &InputSchedule, control: Control, count: usize) -> Vec<f64> {
        (0..count)
            .map(|i| s.deviation(1.5 + 10.0 * i as f64 / count as f64)[control.index()])
            .collect()
    }

    /// |X_k| of a plain DFT, normalised so a unit cosine gives 0.5.
    fn dft_magnitudes(samples: &[f64]) -> Vec<f64> {
        let n = samples.len() as f64;
        (0..samples.len() / 2)
            .map(|k| {
                let (re, im) = samples
                    .iter()
                    .enumerate()
                    .fold((0.0, 0.0), |(re, im), (i, x)| {
                        let angle = TAU * k as f64 * i as f64 / n;
                        (re + x * angle.cos(), im - x * angle.sin())
                    });
                (re * re + im * im).sqrt() / n
            })
            .collect()
    }

    /// max |value| found by a grid search then golden-section refinement.
    fn refined_peak(value: impl Fn(f64) -> f64, from: f64, to: f64) -> f64 {
        let step = (to - from) / 100_000.0;
        let best = (0..100_000)
            .map(|i| from + i as f64 * step)
            .fold(from, |best, t| {
                if value(t).abs() > value(best).abs() {
                    t
                } else {
                    best
                }
            });
        let (mut a, mut b) = (best - step, best + step);
        let ratio = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..100 {
            let (c, d) = (b - ratio * (b - a), a + ratio * (b - a));
            if value(c).abs() > value(d).abs() {
                b = d
            } else {
                a = c
            }
        }
        value(0.5 * (a + b)).abs().max(value(best).abs())
    }

    #[test]
    fn multisine_controls_have_disjoint_harmonics_zero_start_and_exact_peak() {
        let s = schedule(MULTISINE);
        let amplitudes = [2.0 * DEG, 3.0 * DEG, 0.02];
        // Harmonics 1..=30 of 0.1 Hz, interleaved: control j gets j+1, j+4, ...
        for (slot, control) in [Control::Elevator, Control::Aileron, Control::Rudder]
            .into_iter()
            .enumerate()
        {
            let spectrum = dft_magnitudes(&one_period(&s, control, 256));
            for (k, magnitude) in spectrum.iter().enumerate() {
                let own = (1..=30).contains(&k) && (k - 1) % 3 == slot;
                if own {
                    assert!(
                        *magnitude > 1e-3 * amplitudes[slot],
                        "{control:?} harmonic {k}: {magnitude}"
                    );
                } else {
                    assert!(
                        *magnitude < 1e-12,
                        "{control:?} has energy {magnitude} at foreign harmonic {k}"
                    );
                }
            }
            let value = |t: f64| s.deviation(t)[control.index()];
            assert!(
                value(1.5).abs() < 1e-9,
                "{control:?} starts at {}",
                value(1.5)
            );
            let peak = refined_peak(value, 1.5, 11.5);
            assert!(
                (peak - amplitudes[slot]).abs() < 1e-9,
                "{control:?} peak {peak}"
            );
        }
        assert_eq!(elevator(&s, 1.5 - TINY), 0.0);
        assert_eq!(elevator(&s, 11.5 + TINY), 0.0);
    }

    fn relative_peak_factor(samples: &[f64]) -> f64 {
        let peak = samples.iter().fold(0.0_f64, |peak, x| peak.max(x.abs()));
        let rms = (samples.iter().map(|x| x * x).sum::<f64>() / samples.len() as f64).sqrt();
        peak / (2f64.sqrt() * rms)
    }

    /// Plain Schroeder phases φ_k = −π k²/M give a relative peak factor of
    /// about 1.35 for these 10 interleaved harmonics (1.36, 1.35, 1.35; an
    /// independent script agrees); Morelli's 1.0–1.1 needs his further phase
    /// optimisation. Zero phases give √M ≈ 3.16.
    #[test]
    fn schroeder_phases_give_a_low_peak_factor_unlike_zero_phases() {
        let s = schedule(MULTISINE);
        for control in [Control::Elevator, Control::Aileron, Control::Rudder] {
            let factor = relative_peak_factor(&one_period(&s, control, 20_000));
            assert!(factor < 1.4, "{control:?}: relative peak factor {factor}");
        }
        let zero_phase: Vec<f64> = (0..20_000)
            .map(|i| {
                (1..=10)
                    .map(|k| (TAU * (3 * k - 2) as f64 * i as f64 / 20_000.0).cos())
                    .sum()
            })
            .collect();
        let factor = relative_peak_factor(&zero_phase);
        assert!(factor > 3.0, "zero-phase relative peak factor {factor}");
    }

    #[test]
    fn multisine_lasts_the_given_cycles_and_accepts_listed_harmonics() {
        let text = "[[inputs]]\nkind = \"multisine\"\ncontrols = [\"aileron\", \"rudder\"]\namplitudes = [0.05, 0.04]\nperiod = 8\nharmonics = [2, 3, 4, 5, 6, 7]\ncycles = 2";
        let s = schedule(text);
        let aileron = |t: f64| s.deviation(t)[Control::Aileron.index()];
        assert!((aileron(3.3) - aileron(11.3)).abs() < 1e-12);
        assert!(aileron(3.3).abs() > 0.0);
        assert_eq!(aileron(16.0 + TINY), 0.0);
    }

    #[test]
    fn multisine_rejects_shared_controls_and_too_few_harmonics() {
        let text = "[[inputs]]\nkind = \"multisine\"\ncontrols = [\"elevator\", \"elevator\", \"rudder\"]\namplitudes = [0.1, 0.1, 0.1]\nperiod = 10\nfrequency_min = 0.1\nfrequency_max = 0.5";
        let found = problems(text);
        let fields: Vec<&str> = found.iter().map(|p| p.field.as_str()).collect();
        assert!(fields.contains(&"inputs[0].controls"), "{found:?}");
        let text = "[[inputs]]\nkind = \"multisine\"\ncontrols = [\"elevator\", \"rudder\"]\namplitudes = [0.1, 0.1]\nperiod = 10\nfrequency_min = 0.1\nfrequency_max = 0.3";
        let found = problems(text);
        assert!(
            found
                .iter()
                .any(|p| p.field == "inputs[0].harmonics" && p.message.contains("rudder")),
            "{found:?}"
        );
        let text = "[[inputs]]\nkind = \"multisine\"\ncontrols = [\"elevator\"]\namplitudes = [0.1]\nperiod = 10\nfrequency_min = 2\nfrequency_max = 1";
        assert_eq!(problems(text)[0].field, "inputs[0].frequency_min");
    }

    #[test]
    fn every_problem_of_every_spec_is_reported() {
        let text = "[[inputs]]\nkind = \"step\"\ncontrol = \"elevator\"\namplitude = 0.1\n\n[[inputs]]\nkind = \"step\"\ncontrol = \"elevator\"\namplitude = 0.1\n\n[[inputs]]\nkind = \"doublet\"\ncontrol = \"elevator\"\npulse_width = -1\namplitude = \"5 kt\"\n\n[[inputs]]\nkind = \"multistep\"\ncontrol = \"flap\"\nstep_time = 1\nlevels = []";
        let found = problems(text);
        let fields: Vec<&str> = found.iter().map(|p| p.field.as_str()).collect();
        assert_eq!(
            fields,
            [
                "inputs[2].pulse_width",
                "inputs[2].amplitude",
                "inputs[3].levels"
            ],
            "{found:?}"
        );
        assert!(found[1].message.contains("'kt'"));
    }

    #[test]
    fn unknown_fields_and_kinds_are_rejected_by_the_parser() {
        let typo = "[[inputs]]\nkind = \"doublet\"\ncontrol = \"elevator\"\npulse_widht = 1\namplitude = 0.1";
        let error = toml::from_str::<Scenario>(typo)
            .err()
            .expect("a typo is an error");
        assert!(error.to_string().contains("pulse_widht"), "{error}");
        let unknown_kind = "[[inputs]]\nkind = \"chirp\"\ncontrol = \"elevator\"";
        assert!(toml::from_str::<Scenario>(unknown_kind).is_err());
    }

    /// A CSV file in the temporary directory, removed when dropped.
    struct TemporaryCsv(PathBuf);

    impl TemporaryCsv {
        fn new(name: &str, contents: &str) -> TemporaryCsv {
            let unique = format!("aeroid-inputs-{}-{name}.csv", std::process::id());
            let path = std::env::temp_dir().join(unique);
            std::fs::write(&path, contents).expect("temporary directory is writable");
            TemporaryCsv(path)
        }

        fn build(&self, column: &str) -> aeroid_core::Result<InputSchedule> {
            let spec = InputSpec::Csv(CsvSpec {
                control: Control::Aileron,
                file: PathBuf::from(self.0.file_name().expect("a file name")),
                time_column: "t".to_string(),
                column: column.to_string(),
                unit: Some("deg".to_string()),
                start: Quantity::Number(1.0),
            });
            InputSchedule::build(&[spec], &std::env::temp_dir(), Path::new("test.toml"))
        }
    }

    impl Drop for TemporaryCsv {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    fn csv_line_and_column(result: aeroid_core::Result<InputSchedule>) -> (u64, String, String) {
        match result {
            Err(Error::Csv {
                line,
                column,
                message,
                ..
            }) => (line, column, message),
            other => panic!("expected Error::Csv, got {other:?}"),
        }
    }

    #[test]
    fn csv_replay_converts_units_and_interpolates() {
        let file = TemporaryCsv::new(
            "replay",
            "t, aileron_deg, other\n0, 0, x\n1, 10, y\n3, -10, z\n",
        );
        let s = file.build("aileron_deg").expect("valid CSV");
        let aileron = |t: f64| s.deviation(t)[Control::Aileron.index()];
        assert_eq!(aileron(1.0 - TINY), 0.0);
        assert!((aileron(1.5) - 5.0 * DEG).abs() < 1e-15);
        assert!((aileron(3.0) - 0.0).abs() < 1e-15);
        assert!((aileron(3.5) + 5.0 * DEG).abs() < 1e-15);
        assert!((aileron(4.0) + 10.0 * DEG).abs() < 1e-15);
        assert_eq!(aileron(4.0 + TINY), 0.0);
    }

    #[test]
    fn csv_errors_name_line_and_column() {
        let file = TemporaryCsv::new("bad-cell", "t,a\n0,1\n1,abc\n2,3\n");
        let (line, column, message) = csv_line_and_column(file.build("a"));
        assert_eq!((line, column.as_str()), (3, "a"), "{message}");
        assert!(message.contains("abc"));
        let file = TemporaryCsv::new("not-a-number", "t,a\n0,1\n1,NaN\n");
        assert_eq!(csv_line_and_column(file.build("a")).0, 3);
        let file = TemporaryCsv::new("backwards", "t,a\n0,1\n1,2\n1,3\n");
        let (line, column, _) = csv_line_and_column(file.build("a"));
        assert_eq!((line, column.as_str()), (4, "t"));
        let file = TemporaryCsv::new("missing", "t,a\n0,1\n1,2\n");
        let (line, column, message) = csv_line_and_column(file.build("b"));
        assert_eq!((line, column.as_str()), (1, "b"));
        assert!(message.contains("t, a"), "{message}");
    }

    /// Replayed inputs are read by the same CSV reader as records and
    /// imports, so a header that names a column twice is refused here too
    /// (which of the two is meant is unknowable), at line 1 with the name.
    #[test]
    fn csv_replay_shares_the_record_reader() {
        let file = TemporaryCsv::new("repeated", "t,a,a\n0,1,2\n1,2,3\n");
        let (line, column, message) = csv_line_and_column(file.build("a"));
        assert_eq!((line, column.as_str()), (1, "a"), "{message}");
        assert!(message.contains("appears twice"), "{message}");
    }

    #[test]
    fn schedule_without_inputs_is_empty_and_zero() {
        let s = InputSchedule::build(&[], Path::new("."), Path::new("test.toml"))
            .expect("no inputs is valid");
        assert!(s.is_empty());
        assert_eq!(s.deviation(3.0), Controls::zeros());
    }
}
