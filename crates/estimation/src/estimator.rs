//! The estimator interface. Every method is one type implementing
//! [`Estimator`] in its own file under `methods/`, listed by one line in
//! [`crate::methods::built_in`]; the command line, `run`, `gate`, `study`
//! and the reports find methods only through a [`crate::registry::Registry`].
//!
//! A method reads one [`EstimationProblem`] (the record or records, the
//! model structure with its free parameters, start values and bounds, and
//! its own settings, the resolved `[methods.NAME]` table) and returns an
//! [`Estimate`], or refuses with a [`Refusal`] that says, as data, what the
//! record or the model lacks. Settings are plain tables: a method declares
//! each key with its default and meaning ([`MethodInfo::settings`]) and
//! parses the table into its own settings type ([`parse_settings`]).

use crate::estimate::Estimate;
use crate::problem::EstimationProblem;
use aeroid_core::error::{Error, Result};

pub use crate::settings::{
    MethodTables, SettingInfo, Settings, merge_settings, parse_settings, setting_infos,
};

pub use aeroid_core::refusal::{MissingChannel, Refusal, RefusalKind};

/// What `aeroid methods` shows of an estimator.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodInfo {
    /// What the method is, in a few words.
    pub title: &'static str,
    /// The papers and books it follows (author, title).
    pub paper: &'static str,
    /// The equations it implements, with their numbers in the papers.
    pub equations: &'static str,
    /// The channels and model structures it needs.
    pub needs: &'static str,
    /// Every setting of its `[methods.NAME]` table.
    pub settings: Vec<SettingInfo>,
}

/// An estimation method.
pub trait Estimator: Send + Sync {
    /// The name used on the command line and in files (`ee`, `oem`, …).
    fn name(&self) -> &'static str;

    /// Title, paper, equations, needs and settings.
    fn info(&self) -> MethodInfo;

    /// Checks a settings table: every key known, every value well formed.
    fn check_settings(&self, settings: &Settings) -> Result<()>;

    /// The method whose estimate this one can take as its start (output
    /// error: equation error's). A caller that has that estimate for the
    /// same problem passes it to [`Estimator::estimate`].
    fn starts_from(&self) -> Option<&'static str> {
        None
    }

    /// Whether the method fits a model with parameters tied to others
    /// (`[parameters.NAME] tie`): its model is evaluated through
    /// [`aeroid_sim::aero::AeroModel`], which gives a tied term its value
    /// from its master, and its unknowns are the masters. A model with ties
    /// is refused by a method that does not.
    fn fits_tied_parameters(&self) -> bool {
        false
    }

    /// Whether the method fits a model whose moments are taken about a
    /// point other than the CG (`[aero.moment_reference]`); refused otherwise.
    fn fits_moment_reference(&self) -> bool {
        true
    }

    /// Estimates the problem's parameters, or refuses it
    /// ([`Error::Refused`]) when the record or the model cannot serve.
    fn estimate(&self, problem: &EstimationProblem, start: Option<&Estimate>) -> Result<Estimate>;
}

/// A refusal unless the problem has exactly one record, for methods
/// that fit one record at a time.
pub fn one_record(method: &str, problem: &EstimationProblem) -> Result<()> {
    match problem.records.len() {
        1 => Ok(()),
        records => Err(Error::Refused(Refusal::OneRecordOnly {
            method: method.to_string(),
            records,
        })),
    }
}

/// An error naming every key of `settings` among `unsupported` (key,
/// why) that a linear structure `model` does not take, so that a setting
/// is refused, never silently unused; Ok when there is none. `start =
/// "model"` is what a linear fit does, and is accepted.
pub fn refuse_for_linear(
    method: &str,
    settings: &Settings,
    model: &str,
    unsupported: &[(&str, &str)],
) -> Result<()> {
    let refused: Vec<String> = unsupported
        .iter()
        .filter(|(key, _)| {
            settings
                .get(*key)
                .is_some_and(|value| !(*key == "start" && value.as_str() == Some("model")))
        })
        .map(|(key, why)| format!("{key} ({why})"))
        .collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(Error::Other(format!(
        "[methods.{method}]: not for the linear model '{model}': {}",
        refused.join("; ")
    )))
}
