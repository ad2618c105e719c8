//! The registry of estimators: a value built once — the built-in methods
//! ([`crate::methods::built_in`]), then the plug-ins of the plug-in folders
//! (`crate::plugin::discover`), then those a program adds — and passed to
//! whatever runs a method (the command line, `run`, `gate`, `study`).
//!
//! It turns a method name into an [`Estimator`], builds the
//! [`EstimationProblem`] of a method (its settings merged and checked once)
//! and runs it, judging every estimate the same way ([`Estimate::assess`]):
//! an estimate with unidentified parameters, a degenerate covariance, no
//! progress or a fit worse than the mean is not "converged", whichever
//! method made it.

use crate::error::{Error, Result};
use crate::estimate::Estimate;
use crate::estimator::{Estimator, check_model_features};
use crate::problem::EstimationProblem;
use crate::settings::{MethodTables, Settings, overlay};
use crate::structure::{ModelStructure, Structure};
use aeroid_core::error::FieldErrors;
use aeroid_record::FlightRecord;
use std::path::PathBuf;
use std::sync::Arc;

/// The estimators a program can run, in the order `aeroid run` runs them.
///
/// # Example
///
/// A program runs a method through the registry: it builds the method's
/// problem (a record, a model structure from `models/` and the method's
/// settings) and judges the estimate. Equation error on a noise-free record
/// (the `ideal` recorder profile) recovers the truth:
///
/// ```
/// use aeroid_estimation::{estimate::Status, registry::Registry, structure::Structure};
/// use aeroid_record::recorder::{Profile, record_scenario};
/// use aeroid_sim::scenario::Scenario;
///
/// let scenario = Scenario::load("attas-elevator-3211")?;
/// let (record, truth) = record_scenario(&scenario, &Profile::load("ideal", None)?)?;
///
/// let registry = Registry::built_in();
/// let structure = Structure::load("attas-longitudinal")?;
/// let problem = registry.problem("ee", vec![record], structure, &[])?;
/// let estimate = registry.estimate(&problem, None)?;
///
/// assert_eq!(estimate.status, Status::Converged);
/// for parameter in &estimate.parameters {
///     let truth = truth.parameters[&parameter.name];
///     assert!((parameter.value - truth).abs() <= 1e-3 * truth.abs(), "{}", parameter.name);
/// }
/// # Ok::<(), aeroid_estimation::Error>(())
/// ```
#[derive(Clone)]
pub struct Registry {
    estimators: Vec<Arc<dyn Estimator>>,
    /// Plug-in files that could not be loaded or were left out: each
    /// file's path and the message that says why.
    plugin_problems: Vec<(PathBuf, String)>,
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry")
            .field("methods", &self.names())
            .field("plugin_problems", &self.plugin_problems)
            .finish()
    }
}

impl Registry {
    /// The built-in estimators alone.
    pub fn built_in() -> Registry {
        Registry {
            estimators: crate::methods::built_in(),
            plugin_problems: Vec::new(),
        }
    }

    /// The built-in estimators, then the plug-ins of the plug-in folders
    /// (the data folder's `estimators/` and those of `AEROID_ESTIMATORS`).
    /// A plug-in named like a built-in method, and every plug-in whose
    /// name another plug-in file also has, is left out with a problem that
    /// `aeroid methods` lists and [`Registry::find`] gives for that name.
    pub fn with_plugins() -> Registry {
        let mut registry = Registry::built_in();
        let (plugins, problems) = crate::plugin::discover();
        registry.plugin_problems = problems
            .into_iter()
            .map(|(path, error)| (path, error.to_string()))
            .collect();
        for plugin in &plugins {
            let name = Estimator::name(plugin);
            let file = plugin.path().to_path_buf();
            let path = file.display();
            let namesakes: Vec<String> = plugins
                .iter()
                .filter(|other| Estimator::name(*other) == name && other.path() != plugin.path())
                .map(|other| other.path().display().to_string())
                .collect();
            let reason = if registry.estimators.iter().any(|e| e.name() == name) {
                format!(
                    "{path}: '{name}' is a built-in method; the plug-in is left out (rename its file)"
                )
            } else if !namesakes.is_empty() {
                format!(
                    "{path}: the plug-in name '{name}' is also {}; both are left out (rename one)",
                    namesakes.join(", ")
                )
            } else {
                continue;
            };
            registry.plugin_problems.push((file, reason));
        }
        for plugin in plugins {
            let file = plugin.path().to_path_buf();
            let left_out = registry
                .plugin_problems
                .iter()
                .any(|(path, _)| *path == file);
            if !left_out && let Err(error) = registry.add(Arc::new(plugin)) {
                let reason = format!("{}: {error}", file.display());
                registry.plugin_problems.push((file, reason));
            }
        }
        registry
    }

    /// Adds an estimator; its name must be new.
    pub fn add(&mut self, estimator: Arc<dyn Estimator>) -> Result<()> {
        let name = estimator.name();
        if self.estimators.iter().any(|e| e.name() == name) {
            return Err(Error::Method {
                reason: format!("a method named '{name}' exists already"),
            });
        }
        self.estimators.push(estimator);
        Ok(())
    }

    /// Every estimator, in registry order.
    pub fn all(&self) -> &[Arc<dyn Estimator>] {
        &self.estimators
    }

    /// Every estimator's name, in registry order.
    pub fn names(&self) -> Vec<String> {
        self.estimators
            .iter()
            .map(|e| e.name().to_string())
            .collect()
    }

    /// The plug-in files left out of the registry, and why.
    pub fn plugin_problems(&self) -> impl Iterator<Item = &str> {
        self.plugin_problems
            .iter()
            .map(|(_, reason)| reason.as_str())
    }

    /// The estimator named `name`.
    pub fn find(&self, name: &str) -> Result<&Arc<dyn Estimator>> {
        if let Some(found) = self.estimators.iter().find(|e| e.name() == name) {
            return Ok(found);
        }
        // A plug-in file of that name that did not load: its reason, not
        // only "unknown method".
        if let Some((_, reason)) = self
            .plugin_problems
            .iter()
            .find(|(path, _)| path.file_stem().is_some_and(|stem| stem == name))
        {
            return Err(Error::PluginNotLoaded {
                name: name.to_string(),
                reason: reason.clone(),
            });
        }
        Err(aeroid_core::Error::Unknown {
            kind: "method",
            name: name.to_string(),
            known: self.names(),
        }
        .into())
    }

    /// Checks a file's `[methods.NAME]` tables: each names a registered
    /// method and holds settings that method accepts. Problems are named
    /// `methods.NAME`.
    pub fn check_tables(&self, tables: &MethodTables, problems: &mut FieldErrors) {
        for (name, table) in tables {
            let field = format!("methods.{name}");
            match self.find(name) {
                Ok(estimator) => {
                    let mut settings = Settings::new();
                    overlay(&mut settings, table);
                    if let Err(error) = estimator.check_settings(&settings) {
                        let message = error.to_string();
                        let prefix = format!("[{field}]: ");
                        problems.push(field, message.trim_start_matches(&prefix).to_string());
                    }
                }
                Err(error) => problems.push(field, error.to_string()),
            }
        }
    }

    /// [`Registry::check_tables`] for a file read elsewhere (a scenario, a
    /// model): an error naming `path` and each table's problem.
    pub fn validate_tables(&self, tables: &MethodTables, path: &std::path::Path) -> Result<()> {
        let mut problems = FieldErrors::default();
        self.check_tables(tables, &mut problems);
        Ok(problems.finish(path, ())?)
    }

    /// The problem of `method` on `records` ([`EstimationProblem::new`]).
    pub fn problem(
        &self,
        method: &str,
        records: Vec<FlightRecord>,
        structure: impl Into<Structure>,
        layers: &[&MethodTables],
    ) -> Result<EstimationProblem> {
        let structure = structure.into();
        self.validate_tables(structure.methods(), structure.path())?;
        let estimator = self.find(method)?;
        let problem = EstimationProblem::new(method, records, structure, layers)?;
        estimator.check_settings(&problem.settings)?;
        Ok(problem)
    }

    /// Runs the problem's method and judges its result.
    pub fn estimate(
        &self,
        problem: &EstimationProblem,
        start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let estimator = self.find(&problem.method)?;
        estimator.check_settings(&problem.settings)?;
        if let Structure::SixDof(structure) = &problem.structure {
            check_model_features(estimator.name(), &estimator.capabilities(), structure)?;
        }
        let mut estimate = estimator.estimate(problem, start)?;
        if let Structure::SixDof(structure) = &problem.structure {
            estimate.notes.extend(tied_notes(structure, &estimate));
        }
        for note in problem.notes() {
            if !estimate.notes.contains(&note) {
                estimate.notes.push(note);
            }
        }
        Ok(estimate.assess())
    }
}

/// A note per tied parameter: its relation, and its value and standard
/// error from its master's estimate (σ = |c|·σ_master). A tied parameter
/// is not in the estimate's parameters, so it is not scored as if it had
/// been estimated independently (as a fixed one is not).
pub(crate) fn tied_notes(structure: &ModelStructure, estimate: &Estimate) -> Vec<String> {
    let aero = &structure.aircraft.aero;
    let names = aero.parameters.names();
    (0..names.len())
        .filter_map(|i| aero.tie_of(i).map(|tie| (i, tie)))
        .map(|(i, tie)| {
            let master = &names[tie.master];
            let relation = format!(
                "{} is tied: {} = {}·{master} + {}",
                names[i], names[i], tie.factor, tie.offset
            );
            match estimate.parameter(master) {
                Some(p) => format!(
                    "{relation} = {:.6e} ± {:.3e} (from {master}'s estimate; not estimated independently)",
                    tie.factor * p.value + tie.offset,
                    tie.factor.abs() * p.standard_error
                ),
                None => format!(
                    "{relation} = {:.6e} ({master} not estimated)",
                    aero.parameters.values()[i]
                ),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimator::Settings;

    /// Every registered method is described (paper, equations, needs),
    /// every setting it describes is accepted at its stated default, and a
    /// key it does not have is refused with the key named.
    #[test]
    fn every_method_describes_its_settings_truthfully() {
        let registry = Registry::built_in();
        let names = registry.names();
        for estimator in registry.all() {
            let (name, info) = (estimator.name(), estimator.info());
            assert_eq!(names.iter().filter(|n| **n == name).count(), 1);
            assert!(!info.paper.is_empty() && !info.equations.is_empty() && !info.needs.is_empty());
            let mut defaults = Settings::new();
            for setting in info.settings.iter().filter(|s| s.default != "(none)") {
                let table: toml::Table = toml::from_str(&format!("value = {}", setting.default))
                    .unwrap_or_else(|e| panic!("{name} {}: {e}", setting.name));
                defaults.insert(
                    setting.name.to_string(),
                    serde_json::to_value(&table["value"]).unwrap(),
                );
            }
            estimator
                .check_settings(&defaults)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let mut unknown = Settings::new();
            unknown.insert("no_such_setting".into(), serde_json::Value::from(1));
            let error = estimator.check_settings(&unknown).unwrap_err().to_string();
            assert!(error.contains("no_such_setting"), "{name}: {error}");
        }
    }

    /// The registry resolves names and refuses an unknown one with the list.
    #[test]
    fn unknown_method_names_the_known_ones() {
        let error = Registry::built_in()
            .find("no-such-method")
            .err()
            .unwrap()
            .to_string();
        assert!(error.contains("ee") && error.contains("oem"), "{error}");
    }
}
