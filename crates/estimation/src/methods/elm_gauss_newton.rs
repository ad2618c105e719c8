//! ELM + Gauss–Newton (ELM-GN): an extreme learning machine trained on the
//! record as the restricted flight-dynamic model, then Gauss–Newton on
//! det(R) over the postulated model's parameters propagated through it.
//! Method `elm-gn`; settings `[methods.elm-gn]` ([`ElmSettings`]).
//!
//! Paper: "Parameter estimation of aircraft using extreme learning machine
//! and Gauss-Newton algorithm" (the ELM paper), Eqs. 1–22.
//! - The network ([`crate::neural::elm`]): random normal input
//!   weights and biases from the seed, log-sigmoid hidden layer (Eq. 4),
//!   output weights by the Moore–Penrose pseudo-inverse (Eq. 8, by SVD),
//!   the hidden-layer size by the residual criterion (Eq. 6) on held-out
//!   samples, MSE and R² (Eqs. 9–10).
//! - The restricted model and the estimation
//!   ([`crate::neural::restricted`]): input the motion
//!   variables and coefficients at i, output the motion variables at i+1
//!   (Eqs. 1–2); training coefficients from the measured accelerations,
//!   inputs scaled by Eq. 3; in estimation the model's coefficients at Θ
//!   through the network (Eq. 11), det(R) by Gauss–Newton (Eqs. 12–20) with
//!   forward-difference response gradients (Eq. 19), Cramér–Rao bounds
//!   (Eqs. 21–22).
//! - Start values (`start`): by default equation error's estimates when the
//!   structure allows equation error (the paper starts "closer to the
//!   results of EEM"), else the model file's values; an estimate passed in
//!   (`aeroid run` passes equation error's) is used first.

use crate::error::Result;
use crate::estimate::Estimate;
use crate::estimator::{Capabilities, Description, Method};
use crate::methods::common::coefficient_fit::EQUATION_ERROR;
pub use crate::methods::common::elm_fit::{ElmSettings, Start};
use crate::methods::common::elm_fit::{SHARED_SETTINGS, estimate_with};
use crate::problem::EstimationProblem;

/// Method name in estimates.
pub const METHOD: &str = "elm-gn";

/// ELM-GN as a registered method.
pub(crate) struct ElmGaussNewton;

impl Method for ElmGaussNewton {
    const NAME: &'static str = METHOD;
    type Settings = ElmSettings;

    fn describe() -> Description {
        Description {
            title: "ELM + Gauss–Newton: an extreme learning machine trained on the record as the restricted flight-dynamic model, Gauss–Newton on det(R) through it",
            paper: "\"Parameter estimation of aircraft using extreme learning machine and Gauss-Newton algorithm\" (the ELM paper); Huang, Zhu & Siew, \"Extreme learning machine: theory and applications\", Neurocomputing 70 (2006)",
            equations: "X(i) → Z(i+1) (Eqs. 1–2), scaling (Eq. 3), log-sigmoid hidden layer (Eq. 4), W = H⁺Z by SVD (Eqs. 7–8), hidden size by held-out residual (Eq. 6), MSE and R² (Eqs. 9–10), Y(i+1) = f(X(i), Θ) (Eq. 11), det(R) Gauss–Newton with forward-difference gradients (Eqs. 12–20), Cramér–Rao bounds (Eqs. 21–22)",
            needs: "the structure's integrated motion variables, load factors, angular rates, airspeed, α, β, controls, dynamic pressure or altitude (the coefficients from accelerations); a 6-DOF structure",
            settings: SHARED_SETTINGS.to_vec(),
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            starts_from: Some(EQUATION_ERROR),
            ..Capabilities::default()
        }
    }

    fn validate(settings: &ElmSettings) -> Result<()> {
        settings.check(METHOD)
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &ElmSettings,
        start: Option<&Estimate>,
    ) -> Result<Estimate> {
        estimate_with(METHOD, "elm", problem, settings, start)
    }
}
