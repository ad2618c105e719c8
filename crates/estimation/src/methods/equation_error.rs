//! Equation error (least squares) estimation of aerodynamic derivatives —
//! the comparison method of the ELM + Gauss–Newton and reflex-wing UAV papers (reflex-wing UAV paper, §3.1, Eqs. 25–27;
//! Klein & Morelli, "Aircraft System Identification", AIAA 2006, ch. 5).
//! Method `ee`; settings `[methods.ee]`: the differentiator of the angular
//! rates and the lag of the coloured-residual bound ([`EquationErrorSettings`]).
//!
//! Inputs: a flight record with load factors, angular rates, air data,
//! controls and (when the aircraft has thrust) throttle and altitude; a
//! postulated model structure (its aircraft's mass, inertia, geometry and
//! propulsion; its terms; which parameters are free).
//!
//! 1. The coefficients are reconstructed from the measured accelerations and
//!    angular accelerations (reflex-wing UAV paper, Eqs. 17–24; see
//!    [`crate::reconstruction`] for the equations, the thrust,
//!    q̄, the differentiator and the common time base).
//! 2. For each coefficient with a free parameter, one ordinary least-squares
//!    problem `z = X·θ + ε` (Eq. 25): z is the measured coefficient minus the
//!    terms whose parameters are fixed, X holds the regressors of the free
//!    terms from the measured channels ([`aeroid_sim::aero::AeroModel::regressors`]:
//!    α, β, normalised rates, controls, …). Drag in wind axes with an Oswald
//!    factor e: the induced drag `CL²/(e·π·Λ)` uses the measured CL; with e
//!    free the regressor `CL²/(π·Λ)` is fitted with parameter 1/e and e is
//!    reported with the delta-method variance `σ_e = σ_{1/e}·e²`.
//!    A product term's regressor is the product of its measured factors
//!    (`alpha^2` → α²). A term tied to a parameter (θ = c·θ_master + d)
//!    adds c times its regressor to the master's column when the master is
//!    in the same regression, and is a known term otherwise, the master's
//!    coefficient fitted first (ties in a cycle between coefficients are
//!    refused). Moments taken about a point other than the CG are moved
//!    there from the measured moments about the CG with the measured
//!    forces, M_ref = M_cg − r × F ([`aeroid_sim::aero::AeroModel::moment_transfer`]).
//! 3. The cost `½·εᵀε` (Eq. 26) is minimised by `θ̂ = (XᵀX)⁻¹·Xᵀz` (Eq. 27),
//!    computed by SVD ([`aeroid_numerics::regression`]), with the
//!    Cramér–Rao bound `s²·(XᵀX)⁻¹` and the bound corrected for coloured
//!    residuals (Morelli & Klein 1997). The CORRECTED bound is reported as
//!    each parameter's standard error; both appear in the notes.
//!
//! Outputs: an [`Estimate`] with method "ee", one fit per coefficient
//! (measured against modelled coefficient), a block-diagonal covariance
//! (the coefficients are fitted separately), and status Converged, or
//! Diverged with the reason when a regressor matrix is rank-deficient or
//! there are too few samples. A missing channel is an error naming it.
//!
//! Limitations, measured in `tests/estimators/equation_error.rs` (ATTAS multisine):
//! - the reflex-wing UAV paper's finding: least squares assumes noise-free regressors;
//!   measured α, β, rates and controls carry noise, so the estimates are
//!   attenuated towards zero (errors in variables). On the 25 Hz
//!   flight-test profile: CLα −5.6 %, Cmq −12.6 %, Clp −1.5 %, each as the
//!   errors-in-variables limit (M_xx + M_nn)⁻¹·M_xx·θ predicts, and several
//!   times larger than the reported standard errors;
//! - the moments need differentiated rates. A simulated step input makes
//!   the angular accelerations jump; the differentiator leaves out the
//!   samples whose window would cross a step found in a control channel
//!   ([`aeroid_record::prep::differentiation`]), so on noise-free data the
//!   moment derivatives are within 1e-3 on step inputs too, and within the
//!   differentiator's gain error (1.2e-3 on a 1.5 Hz multisine) otherwise.
//!   Forces and moments are reconstructed separately, so the force
//!   regressions keep the samples next to the steps.
//!
//! The fit lives in the common modules [`super::common::coefficient_fit`]
//! (6-DOF), [`super::common::linear_regression`] (linear structures) and
//! [`super::common::regression`] (the least-squares step), which the other
//! regression methods and the starts of the iterative methods share.

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
