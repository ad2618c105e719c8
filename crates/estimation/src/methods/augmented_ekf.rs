//! The extended Kalman filter with the aerodynamic parameters as augmented
//! states (the X-31/F-18 HARV EKF note, seed 003; Jategaonkar, "Flight
//! Vehicle System Identification", 2nd ed., ch. 7, Eqs. 7.8, 7.11–7.19).
//! Method `ekf`; settings `[methods.ekf]` ([`FilterSettings`]). The
//! augmented model, the starts, the noise tuning (Mehra 1970), the status
//! and the estimate are [`crate::methods::common::augmented_filter`],
//! which the unscented filter shares; here are the registered method and
//! its filter pass, the continuous–discrete EKF with exact discretisation
//! ([`extended_kalman::filter_with`]).

use crate::error::Result;
use crate::estimate::Estimate;
use crate::estimator::{Capabilities, Description, Method};
pub use crate::methods::common::augmented_filter::*;
use crate::methods::common::coefficient_fit::EQUATION_ERROR;
use crate::model::observations::Observations;
use crate::model::state_space::StateSpaceModel;
use crate::problem::EstimationProblem;
use crate::solver::extended_kalman::{self, Discretisation, Keep, Noise, Pass};
use aeroid_numerics::kalman::Gaussian;

/// Method name in estimates.
pub const METHOD: &str = "ekf";

/// The augmented-state EKF as a registered method.
pub(crate) struct AugmentedEkf;

impl Method for AugmentedEkf {
    const NAME: &'static str = METHOD;
    type Settings = FilterSettings;

    fn describe() -> Description {
        Description {
            title: "extended Kalman filter with the parameters as augmented states, pseudonoise, Fourier R and residual-correlation tuning",
            paper: "EKF parameter estimation for the X-31 drop model and the F-18 HARV (J. Guidance, Engineering Note); Jategaonkar, \"Flight Vehicle System Identification\", 2nd ed., ch. 7; Mehra, IEEE TAC 15(2), 1970",
            equations: "state and output models with process noise and parameter pseudonoise (note Eqs. 1–3); augmented state (Jategaonkar Eq. 7.8); continuous–discrete EKF (Jategaonkar Eqs. 7.11–7.19); R from the spectrum above the motion's bandwidth; R and the states' process noise from the innovations' autocorrelations (Mehra 1970, Eqs. 13, 29, 30, 33)",
            needs: "the compared outputs, the controls, and every flight-path state the model does not integrate (pseudo-controls); on a linear structure, its input and output channels",
            settings: FILTER_SETTINGS.to_vec(),
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            tied_parameters: true,
            starts_from: Some(EQUATION_ERROR),
            ..Capabilities::default()
        }
    }

    fn validate(settings: &FilterSettings) -> Result<()> {
        settings.check(METHOD)
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &FilterSettings,
        start: Option<&Estimate>,
    ) -> Result<Estimate> {
        refuse_for_linear(METHOD, problem)?;
        let run = augmented_estimate(
            METHOD,
            problem.record(),
            &problem.structure,
            settings,
            start,
            &|model, initial, noise, observations| {
                extended_pass(settings, model, initial, noise, observations)
            },
        )?;
        if let Some(path) = &settings.history {
            run.history.write_csv(path)?;
        }
        Ok(run.estimate)
    }
}

/// The `ekf` method's filter pass ([`extended_kalman::filter_with`], exact
/// discretisation), keeping what the method reads: the filtered
/// covariances (the parameter histories' σ) and, for Mehra's method
/// (`correlation_lags` not 0), the transitions; not the predicted estimates.
pub fn extended_pass<M: StateSpaceModel + ?Sized>(
    settings: &FilterSettings,
    model: &M,
    initial: Gaussian,
    noise: &Noise,
    observations: &Observations,
) -> Result<Pass> {
    let keep = Keep {
        predicted: false,
        transitions: settings.correlation_lags != Some(0),
        sparse_transitions: false,
        filtered_covariances: true,
        sequential: false,
    };
    extended_kalman::filter_with(
        model,
        &[],
        initial,
        noise,
        observations,
        Discretisation::Exact,
        keep,
    )
}
