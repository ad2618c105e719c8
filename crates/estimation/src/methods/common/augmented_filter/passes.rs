//! The residual-correlation passes of an augmented filter: a pass's run
//! and noise, the retuning of the noise by Mehra's method between passes,
//! a pass rejected for making the record less likely, and the report and
//! notes of the noise (the parent module's header, Noise 2).

use super::setup::Setup;
use super::*;

/// What the residual-correlation passes carry from pass to pass.
pub(super) struct Passes {
    /// The states' process noise intensities and θ the next pass runs
    /// with.
    pub(super) process_states: Vec<f64>,
    pub(super) theta: Vec<f64>,
    /// Mehra's lags (0: the zero-lag update).
    pub(super) lags: usize,
    /// What the best pass so far ran with and ended with, for a pass whose
    /// noise makes the record less likely (module header, Noise 2).
    pub(super) best: Option<Best>,
    /// The pass rejected, by its number.
    pub(super) rejected: Option<usize>,
    /// Whether Mehra's method did not serve a pass.
    pub(super) mehra_failed: bool,
    /// Each pass's −ln L, and the report's lines.
    pub(super) costs: Vec<f64>,
    pub(super) report: String,
}

impl Passes {
    /// Mehra's noise made the record less likely than the noise it
    /// replaced (pass `number`, its `outcome`): back to the best pass, the
    /// zero-lag update from it.
    pub(super) fn reject(
        &mut self,
        number: usize,
        outcome: &Result<Pass>,
        setup: &mut Setup,
        settings: &FilterSettings,
    ) {
        let best = self.best.take().expect("a best pass");
        self.costs.push(match outcome {
            Ok(pass) => pass.negative_log_likelihood,
            Err(_) => f64::INFINITY,
        });
        self.report += &format!(
            "{number:>4}  rejected: the record less likely than after pass {}\n",
            best.number
        );
        self.rejected = Some(number);
        self.lags = 0;
        back_to_best(
            &best,
            setup,
            settings,
            &mut self.process_states,
            &mut self.theta,
        );
    }

    /// The noise and θ for the pass after `pass` (number `number`), what
    /// it ran with kept as the best so far while Mehra's method tunes.
    pub(super) fn tune(
        &mut self,
        number: usize,
        pass: &Pass,
        setup: &mut Setup,
        settings: &FilterSettings,
    ) {
        let ran_with = Best {
            number,
            pass: pass.clone(),
            measurement: setup.measurement.clone(),
            process: self.process_states.clone(),
            theta: self.theta.clone(),
        };
        let update = next_noise_and_theta(
            pass,
            setup,
            settings,
            self.lags,
            &mut self.process_states,
            &mut self.theta,
        );
        if update == tuning::Update::ZeroLagFallback {
            self.mehra_failed = true;
        }
        if self.lags > 0 {
            self.best = Some(ran_with);
        }
    }
}

/// One pass of the filter `run` over the record with the parameters
/// `theta` (the free ones among the states) and `noise`: its outcome; an
/// error when the augmented model cannot be made.
pub(super) fn run_pass(
    setup: &Setup,
    theta: &[f64],
    noise: &Noise,
    run: &FilterPass,
) -> Result<Result<Pass>> {
    let augmented = Augmented::new(setup.view.as_ref(), theta, setup.free.clone())?;
    let initial = Gaussian {
        mean: augmented.state(setup.x0.as_slice()),
        covariance: setup.prior.clone(),
    };
    Ok(run(&augmented, initial, noise, &setup.observations))
}

/// Whether a pass's outcome makes the record less likely than the best
/// pass so far (a failed pass does; none is worse without a best pass).
pub(super) fn worse(outcome: &Result<Pass>, best: Option<&Best>) -> bool {
    match (outcome, best) {
        (Ok(pass), Some(best)) => !matches!(
            pass.negative_log_likelihood
                .partial_cmp(&best.pass.negative_log_likelihood),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        ),
        (Err(_), Some(_)) => true,
        (_, None) => false,
    }
}

/// The noise of a pass: the process noise intensities of the states
/// (`process_states`) and the parameters' pseudonoise, the measurement
/// variances.
pub(super) fn pass_noise(setup: &Setup, process_states: &[f64]) -> Noise {
    Noise {
        process: DMatrix::from_diagonal(&DVector::from_iterator(
            setup.x0.len() + setup.free.len(),
            process_states.iter().chain(&setup.pseudonoise).copied(),
        )),
        measurement: DVector::from_column_slice(&setup.measurement),
    }
}

/// After a rejected pass: the noise and θ the best pass ran with, then
/// the zero-lag update from the best pass and θ advanced to where it
/// ended.
fn back_to_best(
    best: &Best,
    setup: &mut Setup,
    settings: &FilterSettings,
    process_states: &mut Vec<f64>,
    theta: &mut Vec<f64>,
) {
    setup.measurement = best.measurement.clone();
    *process_states = best.process.clone();
    *theta = best.theta.clone();
    next_noise_and_theta(&best.pass, setup, settings, 0, process_states, theta);
}

/// The next pass's noise from `pass` by Mehra's method with `lags` lags
/// (0: the zero-lag update), the process noise only if the settings tune
/// it, and θ advanced to where `pass` ended.
fn next_noise_and_theta(
    pass: &Pass,
    setup: &mut Setup,
    settings: &FilterSettings,
    lags: usize,
    process_states: &mut [f64],
    theta: &mut [f64],
) -> tuning::Update {
    let (n, len) = (setup.x0.len(), setup.view.len());
    let step = setup.view.time(1) - setup.view.time(0);
    let update = tuning::update(
        pass,
        len,
        step,
        n,
        lags,
        &mut setup.measurement,
        &setup.floors,
        settings.tune_process_noise.then_some(process_states),
    );
    advance(theta, pass, &setup.free, n, len);
    update
}

/// The report's line of a pass: its −ln L and each output's mean ν²/S.
pub(super) fn report_line(
    number: usize,
    pass: &Pass,
    ratios: &[f64],
    outputs: &[String],
) -> String {
    format!(
        "{number:>4}  {:.1}  {}\n",
        pass.negative_log_likelihood,
        ratios
            .iter()
            .zip(outputs)
            .map(|(r, o)| format!("{o} {r:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The estimate's notes on the final noise, on a rejected pass
/// (`rejected`, its number) and on a pass Mehra's method with the lags
/// `mehra_failed` did not serve.
pub(super) fn noise_notes(
    estimate: &mut Estimate,
    structure: Filtered,
    setup: &Setup,
    noise: &Noise,
    rejected: Option<usize>,
    mehra_failed: Option<usize>,
) {
    let n = setup.x0.len();
    estimate.notes.push(format!(
        "final noise: R σ {}; process noise intensity on {} {}",
        structure
            .outputs()
            .iter()
            .zip(noise.measurement.iter())
            .map(|(o, r)| format!("{o} {:.3e}", r.sqrt()))
            .collect::<Vec<_>>()
            .join(", "),
        setup.state_names.join(", "),
        (0..n)
            .map(|i| format!("{:.3e}", noise.process[(i, i)]))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    if let Some(number) = rejected {
        estimate.notes.push(format!(
            "residual correlation: the noise Mehra's method gave made the record less likely (pass {number}, rejected); the passes from there used the zero-lag update"
        ));
    }
    if let Some(lags) = mehra_failed {
        estimate.notes.push(format!(
            "residual correlation: Mehra's method with {lags} lags did not serve a pass (too few points with every output measured, or no transitions kept); that pass used the zero-lag update"
        ));
    }
}

/// A pass the residual-correlation passes may return to, with the noise
/// and θ it ran with.
pub(super) struct Best {
    number: usize,
    pass: Pass,
    measurement: Vec<f64>,
    process: Vec<f64>,
    theta: Vec<f64>,
}

/// θ for the next pass: the free parameters where `pass` ended.
fn advance(theta: &mut [f64], pass: &Pass, free: &[usize], states: usize, len: usize) {
    let end = pass
        .filtered
        .get(len - 1)
        .expect("a pass keeps every point")
        .mean;
    for (j, &i) in free.iter().enumerate() {
        if end[states + j].is_finite() {
            theta[i] = end[states + j];
        }
    }
}
