//! The estimator interface. Every method is one type implementing the
//! typed [`Method`] in its own file under `methods/`, listed by one line in
//! [`crate::methods::built_in`]; one generic implementation makes every
//! `Method` an object-safe [`Estimator`] (plug-ins implement that
//! directly); the command line, `run`, `gate`, `study` and the reports find
//! methods only through a [`crate::registry::Registry`].
//!
//! A method reads one [`EstimationProblem`] (the record or records, the
//! model structure with its free parameters, start values and bounds, and
//! its own settings, the resolved `[methods.NAME]` table) and returns an
//! [`Estimate`], or refuses with a [`Refusal`] that says, as data, what the
//! record or the model lacks. Settings are plain tables: a method declares
//! each key with its default and meaning ([`MethodInfo::settings`]); the
//! table is parsed once into the method's own settings type
//! ([`Method::Settings`], [`parse_settings`]) and checked
//! ([`Method::validate`]). What a method fits is data ([`Capabilities`]):
//! a problem outside it is refused before the method runs
//! (`check_capabilities`).

use crate::error::{Error, Result};
use crate::estimate::Estimate;
use crate::problem::EstimationProblem;
use crate::structure::{ModelStructure, Structure};
use serde::Serialize;
use serde::de::DeserializeOwned;

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

/// What a method fits, as data: the command line shows it, `run` reads
/// [`Capabilities::starts_from`], and a problem outside it is refused
/// before the method runs (`check_capabilities`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capabilities {
    /// Fits 6-DOF structures (non-dimensional coefficients).
    pub six_dof: bool,
    /// Fits linear state-space structures.
    pub linear: bool,
    /// Fits several records jointly (else one at a time).
    pub several_records: bool,
    /// Fits a model with parameters tied to others (`[parameters.NAME]
    /// tie`): its model is evaluated through
    /// [`aeroid_sim::aero::AeroModel`], which gives a tied term its value
    /// from its master, and its unknowns are the masters.
    pub tied_parameters: bool,
    /// Fits a model whose moments are taken about a point other than the
    /// CG (`[aero.moment_reference]`).
    pub moment_reference: bool,
    /// The method whose estimate this one can take as its start (output
    /// error: equation error's). A caller that has that estimate for the
    /// same problem passes it to [`Estimator::estimate`].
    pub starts_from: Option<&'static str>,
}

impl Default for Capabilities {
    /// A 6-DOF method fitting one record, without ties, with any moment
    /// reference, starting from nothing.
    fn default() -> Capabilities {
        Capabilities {
            six_dof: true,
            linear: false,
            several_records: false,
            tied_parameters: false,
            moment_reference: true,
            starts_from: None,
        }
    }
}

/// An estimation method behind the object-safe interface the registry
/// holds. The built-in methods implement the typed [`Method`] instead and
/// get this through the one generic implementation below; plug-ins
/// implement it directly.
pub trait Estimator: Send + Sync {
    /// The name used on the command line and in files (`ee`, `oem`, …).
    fn name(&self) -> &'static str;

    /// Title, paper, equations, needs and settings.
    fn info(&self) -> MethodInfo;

    /// Checks a settings table: every key known, every value well formed.
    fn check_settings(&self, settings: &Settings) -> Result<()>;

    /// What the method fits and where it starts from.
    fn capabilities(&self) -> Capabilities;

    /// Estimates the problem's parameters, or refuses it
    /// ([`Error::Refused`]) when the record or the model cannot serve.
    fn estimate(&self, problem: &EstimationProblem, start: Option<&Estimate>) -> Result<Estimate>;
}

/// What `aeroid methods` shows of a [`Method`], but its settings' defaults,
/// which come from [`Method::Settings`]' default.
#[derive(Debug, Clone, PartialEq)]
pub struct Description {
    /// What the method is, in a few words.
    pub title: &'static str,
    /// The papers and books it follows (author, title).
    pub paper: &'static str,
    /// The equations it implements, with their numbers in the papers.
    pub equations: &'static str,
    /// The channels and model structures it needs.
    pub needs: &'static str,
    /// Every key of its `[methods.NAME]` table, with its meaning.
    pub settings: Vec<(&'static str, &'static str)>,
}

/// An estimation method, typed: its settings are its own type, parsed and
/// checked once, and what it fits is data ([`Capabilities`]), checked
/// before [`Method::fit`] runs. Every `Method` is an [`Estimator`].
///
/// # Example
///
/// A program adds its own method to its registry with
/// [`Registry::add`](crate::registry::Registry::add); everything that runs
/// methods by name (`estimate`, `run`, gates, studies) then finds it. This
/// one returns the model file's start values with a standard error
/// of its `sigma` setting (the `[methods.start-values]` table of a model,
/// scenario, study or gate case):
///
/// ```
/// use aeroid_estimation::Result;
/// use aeroid_estimation::estimate::{Estimate, ParameterEstimate, Status};
/// use aeroid_estimation::estimator::{Capabilities, Description, Method, MethodTables};
/// use aeroid_estimation::{problem::EstimationProblem, registry::Registry, structure::Structure};
/// use aeroid_record::recorder::{Profile, record_scenario};
/// use aeroid_sim::scenario::Scenario;
/// use std::sync::Arc;
///
/// struct StartValues;
///
/// #[derive(serde::Serialize, serde::Deserialize)]
/// #[serde(deny_unknown_fields, default)]
/// struct StartSettings {
///     sigma: f64,
/// }
///
/// impl Default for StartSettings {
///     fn default() -> Self {
///         StartSettings { sigma: 1.0 }
///     }
/// }
///
/// impl Method for StartValues {
///     const NAME: &'static str = "start-values";
///     type Settings = StartSettings;
///
///     fn describe() -> Description {
///         Description {
///             title: "the model file's start values",
///             paper: "none",
///             equations: "θ = θ₀",
///             needs: "a 6-DOF model structure",
///             settings: vec![("sigma", "the standard error reported")],
///         }
///     }
///
///     fn capabilities() -> Capabilities {
///         Capabilities::default() // 6-DOF structures, one record
///     }
///
///     fn fit(
///         &self,
///         problem: &EstimationProblem,
///         settings: &StartSettings,
///         _start: Option<&Estimate>,
///     ) -> Result<Estimate> {
///         let structure = problem.structure.six_dof(Self::NAME)?;
///         let parameters = &structure.aircraft.aero.parameters;
///         let free: Vec<ParameterEstimate> = parameters
///             .names()
///             .iter()
///             .zip(parameters.values())
///             .zip(&structure.free)
///             .filter(|(_, free)| **free)
///             .map(|((name, &start), _)| ParameterEstimate {
///                 name: name.clone(),
///                 value: start,
///                 standard_error: settings.sigma,
///                 start,
///             })
///             .collect();
///         let n = free.len();
///         let variance = settings.sigma.powi(2);
///         let covariance = (0..n)
///             .map(|i| (0..n).map(|j| if i == j { variance } else { 0.0 }).collect())
///             .collect();
///         let record = problem.record().name();
///         Ok(Estimate {
///             parameters: free,
///             covariance,
///             ..Estimate::empty(Self::NAME, &structure.name, record, Status::Converged)
///         })
///     }
/// }
///
/// let mut registry = Registry::built_in();
/// registry.add(Arc::new(StartValues))?;
///
/// let scenario = Scenario::load("attas-elevator-3211")?;
/// let (record, _truth) = record_scenario(&scenario, &Profile::load("ideal", None)?)?;
/// let settings: MethodTables = toml::from_str("[start-values]\nsigma = 0.5")?;
/// let structure = Structure::load("attas-longitudinal")?;
/// let problem = registry.problem("start-values", vec![record], structure, &[&settings])?;
/// let estimate = registry.estimate(&problem, None)?;
///
/// assert_eq!(estimate.status, Status::Converged);
/// assert!(estimate.parameters.iter().all(|p| p.value == p.start && p.standard_error == 0.5));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub trait Method: Send + Sync + 'static {
    /// The name used on the command line and in files (`ee`, `oem`, …).
    const NAME: &'static str;

    /// The `[methods.NAME]` table, parsed ([`parse_settings`]: an unknown
    /// key or a malformed value is an error naming the method and the key).
    type Settings: Serialize + DeserializeOwned + Default;

    /// Title, paper, equations, needs and the settings' meanings.
    fn describe() -> Description;

    /// What the method fits and where it starts from.
    fn capabilities() -> Capabilities;

    /// Checks the parsed settings' values (ranges, combinations).
    fn validate(_settings: &Self::Settings) -> Result<()> {
        Ok(())
    }

    /// Estimates the problem's parameters with the settings parsed and
    /// validated, the problem within [`Method::capabilities`]; refuses
    /// ([`Error::Refused`]) what the record or the model lacks beyond that.
    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &Self::Settings,
        start: Option<&Estimate>,
    ) -> Result<Estimate>;
}

/// Parses and validates a [`Method`]'s settings.
fn read_settings<M: Method>(settings: &Settings) -> Result<M::Settings> {
    let parsed: M::Settings = parse_settings(M::NAME, settings)?;
    M::validate(&parsed)?;
    Ok(parsed)
}

impl<M: Method> Estimator for M {
    fn name(&self) -> &'static str {
        M::NAME
    }

    fn info(&self) -> MethodInfo {
        let description = M::describe();
        MethodInfo {
            title: description.title,
            paper: description.paper,
            equations: description.equations,
            needs: description.needs,
            settings: setting_infos(&M::Settings::default(), &description.settings),
        }
    }

    fn check_settings(&self, settings: &Settings) -> Result<()> {
        read_settings::<M>(settings).map(|_| ())
    }

    fn capabilities(&self) -> Capabilities {
        M::capabilities()
    }

    fn estimate(&self, problem: &EstimationProblem, start: Option<&Estimate>) -> Result<Estimate> {
        let settings = read_settings::<M>(&problem.settings)?;
        check_capabilities(M::NAME, &M::capabilities(), problem)?;
        self.fit(problem, &settings, start)
    }
}

/// A refusal of a problem outside a method's capabilities: a model feature
/// it does not fit ([`check_model_features`]), several records to a method
/// of one, a structure kind it does not fit.
pub(crate) fn check_capabilities(
    method: &str,
    capabilities: &Capabilities,
    problem: &EstimationProblem,
) -> Result<()> {
    if let Structure::SixDof(structure) = &problem.structure {
        check_model_features(method, capabilities, structure)?;
    }
    if !capabilities.several_records {
        one_record(method, problem)?;
    }
    match &problem.structure {
        Structure::Linear(_) if !capabilities.linear => {
            problem.structure.six_dof(method).map(|_| ())
        }
        Structure::SixDof(structure) if !capabilities.six_dof => {
            Err(Error::Refused(Refusal::StructureKind {
                method: method.to_string(),
                model: structure.name.clone(),
                structure: "6-DOF".into(),
                needs: "a linear state-space structure".into(),
            }))
        }
        _ => Ok(()),
    }
}

/// Refuses a model that uses a feature the method does not fit (tied
/// parameters, a moment reference point off the CG).
pub(crate) fn check_model_features(
    method: &str,
    capabilities: &Capabilities,
    structure: &ModelStructure,
) -> Result<()> {
    let aero = &structure.aircraft.aero;
    let reason = if aero.has_ties() && !capabilities.tied_parameters {
        "it has tied parameters ([parameters.NAME] tie), which this method does not fit"
    } else if aero.moment_reference != nalgebra::Vector3::zeros() && !capabilities.moment_reference
    {
        "its moments are taken about a point other than the CG ([aero.moment_reference]), which this method does not fit"
    } else {
        return Ok(());
    };
    Err(Error::Refused(Refusal::UnsuitableModel {
        method: method.to_string(),
        model: structure.name.clone(),
        reason: reason.into(),
    }))
}

/// A refusal unless the problem has exactly one record, for methods
/// that fit one record at a time.
pub fn one_record(method: &str, problem: &EstimationProblem) -> Result<()> {
    match problem.records.len() {
        1 => Ok(()),
        records => Err(Error::Refused(Refusal::OneRecordOnly {
            method: method.to_string(),
            records,
            gaps: (!problem.gap_notes.is_empty()).then(|| problem.gap_notes.join("; ")),
        })),
    }
}

/// An error naming every key of `settings` among `unsupported` (key,
/// why) that a linear structure `model` does not take, so that a setting
/// is refused, never silently unused; Ok when there is none. `start =
/// "model"` is what a linear fit does, and is accepted.
pub(crate) fn refuse_for_linear(
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
    Err(Error::Settings {
        method: method.to_string(),
        reason: format!("not for the linear model '{model}': {}", refused.join("; ")),
    })
}
