//! Parameter estimation: the postulated model structure, the estimation
//! problem, the state-space view of the model, the shared solvers, the
//! estimators (one file each under `methods/`) and what they return.
//!
//! The regression estimators (equation error, stepwise regression) share the
//! coefficient reconstruction (`reconstruction`) and the least-squares
//! solution with its error bounds (`solver::regression`).
//!
//! # Estimating
//!
//! A program runs a method through the [`registry::Registry`]: it builds the
//! method's problem (a record, a model structure from `models/` and the
//! method's settings) and judges the estimate. Equation error on a
//! noise-free record (the `ideal` recorder profile) recovers the truth:
//!
//! ```
//! use aeroid_estimation::{estimate::Status, registry::Registry, structure::Structure};
//! use aeroid_record::recorder::{Profile, record_scenario};
//! use aeroid_sim::scenario::Scenario;
//!
//! let scenario = Scenario::load("attas-elevator-3211")?;
//! let (record, truth) = record_scenario(&scenario, &Profile::load("ideal", None)?)?;
//!
//! let registry = Registry::built_in();
//! let structure = Structure::load("attas-longitudinal")?;
//! let problem = registry.problem("ee", vec![record], structure, &[])?;
//! let estimate = registry.estimate(&problem, None)?;
//!
//! assert_eq!(estimate.status, Status::Converged);
//! for parameter in &estimate.parameters {
//!     let truth = truth.parameters[&parameter.name];
//!     assert!((parameter.value - truth).abs() <= 1e-3 * truth.abs(), "{}", parameter.name);
//! }
//! # Ok::<(), aeroid_core::Error>(())
//! ```
//!
//! # Adding a method
//!
//! A method is a type implementing [`estimator::Method`]; a program adds it
//! to its registry with [`registry::Registry::add`], and everything that
//! runs methods by name (`estimate`, `run`, gates, studies) then finds it.
//! This one returns the model file's start values with a standard error
//! of its `sigma` setting (the `[methods.start-values]` table of a model,
//! scenario, study or gate case):
//!
//! ```
//! use aeroid_core::Result;
//! use aeroid_estimation::estimate::{Estimate, ParameterEstimate, Status};
//! use aeroid_estimation::estimator::{Capabilities, Description, Method, MethodTables};
//! use aeroid_estimation::{problem::EstimationProblem, registry::Registry, structure::Structure};
//! use aeroid_record::recorder::{Profile, record_scenario};
//! use aeroid_sim::scenario::Scenario;
//! use std::sync::Arc;
//!
//! struct StartValues;
//!
//! #[derive(serde::Serialize, serde::Deserialize)]
//! #[serde(deny_unknown_fields, default)]
//! struct StartSettings {
//!     sigma: f64,
//! }
//!
//! impl Default for StartSettings {
//!     fn default() -> Self {
//!         StartSettings { sigma: 1.0 }
//!     }
//! }
//!
//! impl Method for StartValues {
//!     const NAME: &'static str = "start-values";
//!     type Settings = StartSettings;
//!
//!     fn describe() -> Description {
//!         Description {
//!             title: "the model file's start values",
//!             paper: "none",
//!             equations: "θ = θ₀",
//!             needs: "a 6-DOF model structure",
//!             settings: vec![("sigma", "the standard error reported")],
//!         }
//!     }
//!
//!     fn capabilities() -> Capabilities {
//!         Capabilities::default() // 6-DOF structures, one record
//!     }
//!
//!     fn fit(
//!         &self,
//!         problem: &EstimationProblem,
//!         settings: &StartSettings,
//!         _start: Option<&Estimate>,
//!     ) -> Result<Estimate> {
//!         let structure = problem.structure.six_dof(Self::NAME)?;
//!         let parameters = &structure.aircraft.aero.parameters;
//!         let free: Vec<ParameterEstimate> = parameters
//!             .names()
//!             .iter()
//!             .zip(parameters.values())
//!             .zip(&structure.free)
//!             .filter(|(_, free)| **free)
//!             .map(|((name, &start), _)| ParameterEstimate {
//!                 name: name.clone(),
//!                 value: start,
//!                 standard_error: settings.sigma,
//!                 start,
//!             })
//!             .collect();
//!         let n = free.len();
//!         let variance = settings.sigma.powi(2);
//!         let covariance = (0..n)
//!             .map(|i| (0..n).map(|j| if i == j { variance } else { 0.0 }).collect())
//!             .collect();
//!         let record = problem.record().name();
//!         Ok(Estimate {
//!             parameters: free,
//!             covariance,
//!             ..Estimate::empty(Self::NAME, &structure.name, record, Status::Converged)
//!         })
//!     }
//! }
//!
//! let mut registry = Registry::built_in();
//! registry.add(Arc::new(StartValues))?;
//!
//! let scenario = Scenario::load("attas-elevator-3211")?;
//! let (record, _truth) = record_scenario(&scenario, &Profile::load("ideal", None)?)?;
//! let settings: MethodTables = toml::from_str("[start-values]\nsigma = 0.5")?;
//! let structure = Structure::load("attas-longitudinal")?;
//! let problem = registry.problem("start-values", vec![record], structure, &[&settings])?;
//! let estimate = registry.estimate(&problem, None)?;
//!
//! assert_eq!(estimate.status, Status::Converged);
//! assert!(estimate.parameters.iter().all(|p| p.value == p.start && p.standard_error == 0.5));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod compatibility;
pub mod diagnosis;
pub mod estimate;
pub mod estimator;
pub mod fit_quality;
pub mod input_timing;
pub mod linear_structure;
pub mod methods;
pub mod model;
pub mod neural;
pub mod plugin;
pub mod problem;
pub mod reconstruction;
pub mod registry;
pub mod sandbox;
pub mod settings;
pub mod solver;
pub mod structure;

/// Every channel some estimator or the flight-path reconstruction reads
/// (see docs/import.md, "What each estimator reads"). An imported channel
/// not in this list is kept in the record, and the import warns that no
/// estimator uses it.
pub const CHANNELS_READ: &[&str] = &[
    "airspeed",
    "alpha",
    "beta",
    "mach",
    "dynamic_pressure",
    "p",
    "q",
    "r",
    "roll",
    "pitch",
    "yaw",
    "nx",
    "ny",
    "nz",
    "altitude",
    "pressure_altitude",
    "elevator",
    "aileron",
    "rudder",
    "flap",
    "throttle",
    "thrust",
    "density",
    "chi",
];
