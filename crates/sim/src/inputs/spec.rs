//! The `[[inputs]]` entries of a scenario file as written ([`InputSpec`]):
//! step, doublet, 3-2-1-1, multistep, multisine, ramp and CSV replay, each
//! selected by `kind`, with the control's dimension for amplitudes and
//! levels (angle; throttle: fraction). The syntax is in docs/files.md.

use crate::state::Control;
use aeroid_core::units::Quantity;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

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
