//! Filter error (method `fem`): maximum likelihood with a Kalman filter in
//! the loop, for flights with process noise (turbulence) as well as
//! measurement noise (Maine & Iliff, "Identification of dynamic systems",
//! NASA RP-1138, 1985, ch. 9; Jategaonkar, "Flight Vehicle System
//! Identification", 2nd ed., ch. 5). The user's reference, with what was
//! measured, is docs/methods.md, "Filter error".
//!
//! The fit (the filters, their sensitivities, the relaxation of R, the
//! gain constraint, the starts of F and R, the linear model's fit) is
//! `crate::methods::common::filter_fit`, which output error shares on
//! linear structures; here are the registered method, its `[methods.fem]`
//! settings and the fit of a 6-DOF structure from equation error's start.

use crate::error::{Error, Result};
use crate::estimate::Estimate;
use crate::estimator::{
    Capabilities, Description, Method, Settings, merge_settings, parse_settings,
};
use crate::input_timing::InputInterpolation;
use crate::methods::common::coefficient_fit::EQUATION_ERROR;
use crate::methods::common::coefficient_fit::Start;
use crate::methods::common::iterations::check_iterations;
use crate::methods::common::refusals::{
    enough_data, free_parameters, missing_channels, unsuitable,
};
use crate::model::observations::Observations;
use crate::model::state_space::{DrivenStateSpace, StateSpaceModel};
use crate::problem::EstimationProblem;
use crate::structure::{ModelStructure, Structure};
use aeroid_numerics::gauss_newton::Options;
use aeroid_record::FlightRecord;
use nalgebra::DVector;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub use crate::methods::common::filter_fit::*;

/// Method name in estimates.
pub const METHOD: &str = "fem";

mod estimator;
mod settings;

pub use estimator::*;
pub use settings::*;
