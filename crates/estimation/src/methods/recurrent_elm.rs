//! Recurrent ELM + Gauss–Newton (RELM-GN): a Jordan-type recurrent extreme
//! learning machine trained on the record, then Gauss–Newton on det(R) over
//! the postulated model's parameters propagated through it — the method of
//! the quasi-steady stall model's estimation. Method `relm-gn`; settings
//! `[methods.relm-gn]` (those of `elm-gn`,
//! [`crate::methods::common::elm_fit::ElmSettings`]).
//!
//! Paper: Verma & Peyada, "Estimation of aerodynamic parameters near stall
//! using maximum likelihood and extreme learning machine-based methods",
//! Aeronautical J. 2020, Eqs. 11–26; the stall model Eqs. 2–4.
//! - The Jordan structure (Eq. 17): the network's inputs at sample i are
//!   the aerodynamic coefficients at i and the outputs y(i) fed back; its
//!   outputs are the motion variables at i+1. In training the fed-back
//!   outputs are the measured motion (teacher forcing) and the coefficients
//!   come from the measured accelerations (Eqs. 12–15); scaling Eq. 16;
//!   random input weights, log-sigmoid hidden layer and pseudo-inverse
//!   output weights (Eqs. 17–20, [`crate::neural::elm`]); MSE
//!   and R² (Eqs. 21–22).
//! - The estimation (Eqs. 23–26,
//!   [`crate::neural::restricted`]): the postulated model's
//!   coefficients at Θ through the network, Y(i+1) = f(X(i), Y(i), Θ)
//!   (Eq. 23), with Y(i) the training observations (`feedback =
//!   "measured"`, the paper's form and the default) or the network's own
//!   previous prediction (`feedback = "predicted"`, a free-running
//!   simulation from the measured first sample); forward-difference
//!   response gradients (Eq. 24), Gauss–Newton on det(R) (Eqs. 5–10),
//!   Cramér–Rao bounds (Eqs. 25–26).
//! - The stall model's coefficients depend on the separation point χ: for
//!   τ1 = 0 (the quasi-steady form, Eq. 3) χ = χ∞(α, α̇) at each sample with
//!   α measured and α̇ differentiated from it; for τ1 > 0 Eq. 2 is
//!   integrated along the record by the project's RK4 — both with the
//!   model's own separation equations ([`aeroid_sim::aero::AeroModel`]).
//!
//! With measured feedback the network's inputs are those of the ELM
//! paper's Eq. 1 (motion and coefficients at i), so RELM-GN and ELM-GN
//! train the same network; they differ in the paper they follow, the
//! report's kind and the stall model they are applied to here.

use crate::error::Result;
use crate::estimate::Estimate;
use crate::estimator::{Capabilities, Description, Method};
use crate::methods::common::coefficient_fit::EQUATION_ERROR;
use crate::methods::common::elm_fit::{ElmSettings, SHARED_SETTINGS, estimate_with};
use crate::problem::EstimationProblem;

/// Method name in estimates.
pub const METHOD: &str = "relm-gn";

/// RELM-GN as a registered method.
pub(crate) struct RecurrentElm;

impl Method for RecurrentElm {
    const NAME: &'static str = METHOD;
    type Settings = ElmSettings;

    fn describe() -> Description {
        Description {
            title: "recurrent ELM + Gauss–Newton: a Jordan-type recurrent extreme learning machine as the restricted flight-dynamic model, Gauss–Newton on det(R) through it",
            paper: "Verma & Peyada, \"Estimation of aerodynamic parameters near stall using maximum likelihood and extreme learning machine-based methods\", Aeronautical J. 2020",
            equations: "coefficients from accelerations (Eqs. 12–15), scaling (Eq. 16), Jordan ELM with output feedback (Eqs. 17–20), MSE and R² (Eqs. 21–22), Y(i+1) = f(X(i), Y(i), Θ) (Eq. 23), forward-difference gradients (Eq. 24), det(R) Gauss–Newton (Eqs. 5–10), Cramér–Rao bounds (Eqs. 25–26); stall model χ (Eqs. 2–4)",
            needs: "the structure's integrated motion variables, load factors, angular rates, airspeed, α, β, controls, dynamic pressure or altitude; α for χ of a stall model; a 6-DOF structure",
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
        estimate_with(METHOD, "recurrent-elm", problem, settings, start)
    }
}
