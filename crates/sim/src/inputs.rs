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
//!
//! The parts, each importing only those listed before it: `spec` (the file
//! entries), `signal` (the pre-computed signals), `checker` (reading a
//! spec's quantities), then one per kind: `steps` (step, doublet, 3-2-1-1,
//! multistep, ramp), `multisine`, `replay` (CSV).

mod checker;
mod multisine;
mod replay;
mod signal;
mod spec;
mod steps;

#[cfg(test)]
mod tests;

pub use spec::{
    CsvSpec, DoubletSpec, InputSpec, MultisineSpec, MultistepSpec, RampSpec, StepSpec,
    ThreeTwoOneOneSpec,
};

use crate::state::Controls;
use aeroid_core::error::FieldErrors;
use checker::Checker;
use replay::CsvRequest;
use signal::Signal;
use std::path::Path;

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
        let mut problems = FieldErrors::default();
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
