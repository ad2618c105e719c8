//! Equation error (least squares) estimation of aerodynamic derivatives —
//! the comparison method of the ELM + Gauss–Newton and reflex-wing UAV papers (reflex-wing UAV paper, §3.1, Eqs. 25–27;
//! Klein & Morelli, "Aircraft System Identification", AIAA 2006, ch. 5).
//! Method `ee`; settings `[methods.ee]`: the differentiator of the angular
//! rates and the lag of the coloured-residual bound ([`EquationErrorSettings`]).
//! The user reference is docs/methods.md, "Equation error".
//!
//! Inputs: a flight record with load factors, angular rates, air data,
//! controls and (when the aircraft has thrust) throttle and altitude; a
//! postulated model structure (its aircraft's mass, inertia, geometry and
//! propulsion; its terms; which parameters are free).
//!
//! 1. The coefficients are reconstructed from the measured accelerations and
//!    angular accelerations (reflex-wing UAV paper, Eqs. 17–24; see
//!    [`crate::reconstruction`]).
//! 2. For each coefficient with a free parameter, one ordinary least-squares
//!    problem `z = X·θ + ε` (Eq. 25): z is the measured coefficient minus the
//!    terms whose parameters are fixed, X holds the regressors of the free
//!    terms from the measured channels ([`aeroid_sim::aero::AeroModel::regressors`]).
//!    With a free Oswald factor e the regressor `CL²/(π·Λ)` is fitted with
//!    parameter 1/e, and σ_e = σ_{1/e}·e². Tied terms, product terms and
//!    moments about a point other than the CG
//!    ([`aeroid_sim::aero::AeroModel::moment_transfer`]) as docs/methods.md says.
//! 3. The cost `½·εᵀε` (Eq. 26) is minimised by `θ̂ = (XᵀX)⁻¹·Xᵀz` (Eq. 27),
//!    computed by SVD ([`aeroid_numerics::regression`]), with the
//!    Cramér–Rao bound `s²·(XᵀX)⁻¹` and the bound corrected for coloured
//!    residuals (Morelli & Klein 1997), which is reported as each
//!    parameter's standard error; both appear in the notes.
//!
//! Outputs: an [`Estimate`] with one fit per coefficient, a block-diagonal
//! covariance (the coefficients are fitted separately), and status
//! Converged, or Diverged with the reason when a regressor matrix is
//! rank-deficient or there are too few samples.
//!
//! Limitations (`tests/estimators/equation_error.rs`): measured regressors
//! attenuate the estimates towards zero (errors in variables, the
//! reflex-wing UAV paper's finding), and the moments need differentiated
//! rates ([`aeroid_record::prep::differentiation`]). The fit lives in
//! `super::common::coefficient_fit`, `super::common::linear_regression`
//! and [`super::common::regression`], shared with the other regression methods.

use crate::error::Result;
use crate::estimate::Estimate;
use crate::estimator::{Capabilities, Description, Method};
use crate::methods::common::coefficient_fit::{
    ANGULAR_ACCELERATIONS_SETTING, CORRELATION_LAG_SETTING, DIFFERENTIATOR_SETTING, check_settings,
};
pub use crate::methods::common::coefficient_fit::{
    EquationErrorOptions, EquationErrorSettings, METHOD, equation_error,
};
pub use crate::methods::common::linear_regression::linear_equation_error;
use crate::problem::EstimationProblem;
use crate::structure::Structure;

/// Equation error as a registered method.
pub struct EquationError;

impl Method for EquationError {
    const NAME: &'static str = METHOD;
    type Settings = EquationErrorSettings;

    fn describe() -> Description {
        Description {
            title: "equation error: least squares on coefficients reconstructed from accelerations and angular accelerations",
            paper: "Klein & Morelli, \"Aircraft System Identification\" (AIAA 2006), ch. 5; \"Longitudinal and lateral aerodynamic characterisation of reflex wing UAV from flight tests using ML, LS and neural Gauss Newton methods\"",
            equations: "coefficients from accelerations (reflex-wing UAV paper, Eqs. 17–24); z = Xθ + ε, θ = (XᵀX)⁻¹Xᵀz (Eqs. 25–27); coloured-residual bounds (Morelli & Klein 1997)",
            needs: "load factors, angular rates, airspeed, α, β, controls, dynamic pressure or altitude, throttle when the aircraft has thrust; a model linear in its parameters; on a linear structure, a channel of every state and input",
            settings: vec![
                DIFFERENTIATOR_SETTING,
                CORRELATION_LAG_SETTING,
                ANGULAR_ACCELERATIONS_SETTING,
            ],
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            tied_parameters: true,
            ..Capabilities::default()
        }
    }

    fn validate(settings: &EquationErrorSettings) -> Result<()> {
        check_settings(METHOD, &settings.differentiator, settings.correlation_lag)
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &EquationErrorSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        match &problem.structure {
            Structure::SixDof(structure) => {
                equation_error(problem.record(), structure, &settings.options())
            }
            Structure::Linear(structure) => linear_equation_error(
                problem.record(),
                structure,
                &settings.differentiator,
                settings.correlation_lag,
            ),
        }
    }
}
