//! Estimation before modelling (`ebm`): the aerodynamic coefficients as
//! Gauss–Markov states of an extended Kalman filter, smoothed by the
//! modified Bryson–Frazier smoother, then regressed on the model
//! structure's terms (Wang et al. 2012, "Aerodynamic modeling and
//! parameter estimation from QAR data of an airplane approaching a
//! high-altitude airport", Chinese J. Aeronautics 25, §3.2, Eqs. 7–24; the
//! regression of the smoothed histories is equation error's, Klein &
//! Morelli 2006, ch. 5, where Wang et al. fit an RBF network and use the
//! Delta method, Eqs. 25–33).
//!
//! 1. Model (Eqs. 7–8, [`crate::model::coefficient_states`]): the 6-DOF
//!    motion with CX, CY, CZ, Cl, Cm, Cn each a third-order Gauss–Markov
//!    process, observed through the load factors, attitude, V and h, and
//!    α, β, p, q, r where the record has them.
//! 2. Forward pass (Eqs. 10–16): the continuous–discrete EKF, the state
//!    propagated by RK4 (Eq. 12), the covariance by
//!    Φ = I + F·Δt + ½(F·Δt)² (Eq. 11b), the measurement update a sequence
//!    of scalar updates (Bierman 1977, ch. II), no matrix inverse.
//! 3. Backward pass (Eqs. 17–24): the modified Bryson–Frazier smoother
//!    back through each scalar update (Bierman 1974; 1977, ch. X). The
//!    equations of both passes are in `smoother`'s header.
//! 4. Coefficients (Eq. 9): the smoothed CX, CY, CZ, Cl, Cm, Cn; CL and CD
//!    from CX, CZ and the smoothed α for a wind-axis structure.
//! 5. Modelling: for each coefficient with a free parameter, least squares
//!    of the smoothed coefficient on the structure's terms, the regressors
//!    from the smoothed states (α, β, V, p̂, q̂, r̂, α̇, Mach) and the recorded
//!    controls — the regression equation error runs
//!    (`crate::methods::common::regression::regress`), with its coloured-residual
//!    Cramér–Rao bounds.
//!
//! Outputs: an [`Estimate`] of the structure's free parameters, and on
//! request the smoothed histories ([`smooth`], [`Smoothed::write_csv`]).
//!
//! Limitations: still air is assumed (a wind or turbulence puts its
//! accelerations into the coefficients); the Gauss–Markov model smooths a
//! coefficient's steps over its bandwidth, so a step in a control shows as
//! a ramp; the moments are observed through the second derivative of the
//! attitude when the record has no rates.
//!
//! The smoother and the regression of its histories are the common module
//! [`crate::methods::common::smoothing`], which the RBF Δ-method shares.

use crate::error::Result;
use crate::estimate::Estimate;
use crate::estimator::{Capabilities, Description, Method};
use crate::methods::common::smoothing::SETTINGS;
pub use crate::methods::common::smoothing::{
    GaussMarkov, METHOD, Smoothed, SmoothedRegressionSettings, SmootherSetup, smooth,
    smooth_and_regress,
};
use crate::problem::EstimationProblem;

/// Estimation before modelling as a registered method.
pub(crate) struct SmoothedRegression;

impl Method for SmoothedRegression {
    const NAME: &'static str = METHOD;
    type Settings = SmoothedRegressionSettings;

    fn describe() -> Description {
        Description {
            title: "estimation before modelling: coefficients as Gauss–Markov states of an EKF, smoothed by the modified Bryson–Frazier smoother, regressed on the model's terms",
            paper: "Wang et al., \"Aerodynamic modeling and parameter estimation from QAR data of an airplane approaching a high-altitude airport\", Chinese J. Aeronautics 25 (2012); Bierman, \"Fixed interval smoothing with discrete measurements\" (1973); Klein & Morelli (2006), ch. 5",
            equations: "6-DOF kinematics with third-order Gauss–Markov coefficients (Eq. 7), observations (Eq. 8), coefficients (Eq. 9), EKF (Eqs. 10–16), modified Bryson–Frazier smoother (Eqs. 17–24); least squares on the smoothed coefficients (Eqs. 25–27 of the reflex-wing UAV paper)",
            needs: "load factors, attitude angles, airspeed, altitude or pressure altitude (α, β, p, q, r used when present), the controls of the model's terms, thrust or throttle when the aircraft has thrust; a model linear in its parameters",
            settings: SETTINGS.to_vec(),
        }
    }

    /// Its moment equations are about the CG, in its own form.
    fn capabilities() -> Capabilities {
        Capabilities {
            moment_reference: false,
            ..Capabilities::default()
        }
    }

    fn validate(settings: &SmoothedRegressionSettings) -> Result<()> {
        settings.check()
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &SmoothedRegressionSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let started = std::time::Instant::now();
        let (smoothed, mut estimate) = smooth_and_regress(
            problem.record(),
            problem.structure.six_dof(METHOD)?,
            settings,
        )?;
        estimate.notes.extend(smoothed.notes.iter().cloned());
        estimate.notes.push(determined_note(&estimate));
        estimate.histories = smoothed.coefficient_histories();
        estimate.wall_time = started.elapsed().as_secs_f64();
        Ok(estimate)
    }
}

/// Which parameters the record determined: those with a standard error
/// below 10 % of their value (a ±2σ interval of ±20 %), and the others.
pub(crate) fn determined_note(estimate: &Estimate) -> String {
    let (determined, not): (Vec<_>, Vec<_>) = estimate
        .parameters
        .iter()
        .partition(|p| p.standard_error < 0.1 * p.value.abs());
    let names = |list: Vec<&crate::estimate::ParameterEstimate>| {
        if list.is_empty() {
            "none".to_string()
        } else {
            list.iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    format!(
        "determined to 10 % (σ < 0.1·|value|): {}; not: {}",
        names(determined),
        names(not)
    )
}
