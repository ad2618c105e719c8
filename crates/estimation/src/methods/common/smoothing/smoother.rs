//! Steps 1–3 of estimation before modelling: the coefficient-state model
//! on its grid, its initial estimate and Gauss–Markov noise
//! ([`GaussMarkov`]: each chain lowered to the change bounds over one
//! sample period), the forward EKF and the backward smoother.
//!
//! 1. Model (Eqs. 7–8, [`crate::model::coefficient_states`]):
//!    u, v, w, p, q, r, φ, θ, ψ, h and CX, CY, CZ, Cl, Cm, Cn each a
//!    third-order Gauss–Markov process (value, first and second derivative;
//!    the third derivative white noise of spectral density
//!    `force_noise` / `moment_noise`); observed through nx, ny, nz, φ, θ, ψ,
//!    V, h (`observations`) and α, β, p, q, r where the record has them
//!    (`optional_observations`). No angular rate is needed. Without an
//!    `altitude` channel the pressure altitude observes h; the thrust is
//!    the record's `thrust` channel when it has one (a QAR's, derived from
//!    the fuel flow), else the throttle through the engine model.
//! 2. Forward pass (Eqs. 10–16): the continuous–discrete EKF
//!    ([`extended_kalman::filter_with`]) with the state propagated by RK4
//!    (Eq. 12) and the covariance by Φ = I + F·Δt + ½(F·Δt)² (Eq. 11b).
//!    R is diagonal (each output's noise variance), so the measurement
//!    update is a sequence of scalar updates, one per measured output
//!    (Bierman, "Factorization Methods for Discrete Sequential
//!    Estimation", 1977, ch. II; [`kalman::sequential_update_with`]):
//!    sᵢ = hᵢᵀ·P·hᵢ + rᵢ, kᵢ = P·hᵢ/sᵢ, x ← x + kᵢ·νᵢ,
//!    P ← (I − kᵢ·hᵢᵀ)·P·(I − kᵢ·hᵢᵀ)ᵀ + kᵢ·rᵢ·kᵢᵀ, no matrix inverse;
//!    equal to the vector update of Eqs. 13–16 in exact arithmetic.
//! 3. Backward pass (Eqs. 17–24): the modified Bryson–Frazier smoother
//!    ([`kalman::mbf_smooth_variances`]; adjoint λ, Λ from zero after the
//!    last measurement, updated at each measurement, propagated by Φᵀ;
//!    x_{k|N} = x_{k|k−1} − P_{k|k−1}·λ_k, P_{k|N} = P − P·Λ·P). The
//!    transcript's Eqs. 17–22 are damaged; Bierman's (1973) textbook form
//!    is used, which they transcribe, in its form for scalar updates
//!    (Bierman, "Sequential square root filtering and smoothing of
//!    discrete linear systems", Automatica 10, 1974; 1977, ch. X): through
//!    each scalar update in reverse, λ ← (I − kᵢ·hᵢᵀ)ᵀ·λ − hᵢ·νᵢ/sᵢ,
//!    Λ ← (I − kᵢ·hᵢᵀ)ᵀ·Λ·(I − kᵢ·hᵢᵀ) + hᵢ·hᵢᵀ/sᵢ, with νᵢ, sᵢ and kᵢ
//!    kept per output per point.

use super::METHOD;
use super::inputs::{
    observations_and_inputs, thrust_input, unwrapped_yaw, value_or, with_altitude,
};
use super::settings::SmoothedRegressionSettings;
use super::smoothed::Smoothed;
use crate::error::{Error, Result};
use crate::estimator::Refusal;
use crate::methods::common::regression::{self, Plan};
use crate::model::coefficient_states::{
    self, COEFFICIENT_NAMES, CoefficientStates, H, P, PHI, PSI, STATE_COUNT, THETA, U,
};
use crate::model::observations::Observations;
use crate::model::state_space::{StateSpaceModel, fitting_window};
use crate::solver::extended_kalman::{self, Discretisation, Keep, Noise};
use crate::structure::ModelStructure;
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::kalman::{self, Gaussian};
use aeroid_record::FlightRecord;
use aeroid_sim::atmosphere::Atmosphere;
use nalgebra::{DMatrix, DVector, Vector3};

/// The initial estimate at the window's start: the recorded air data,
/// attitude, altitude and rates (α from the pitch angle and β = 0 when not
/// recorded; rates 0), the force coefficients from the load factors (Eq. 8
/// inverted), the moment coefficients those of no angular acceleration
/// (M_aero = ω × I·ω − r_T × T), derivatives 0.
fn initial_estimate(
    record: &FlightRecord,
    model: &CoefficientStates,
    settings: &SmoothedRegressionSettings,
    start: f64,
    period: f64,
) -> (Gaussian, GaussMarkov) {
    let aircraft = model.aircraft();
    let pitch = value_or(record, "pitch", start, 0.0);
    let airspeed = value_or(record, "airspeed", start, 100.0);
    let alpha = value_or(record, "alpha", start, pitch);
    let beta = value_or(record, "beta", start, 0.0);
    let rates = Vector3::new(
        value_or(record, "p", start, 0.0),
        value_or(record, "q", start, 0.0),
        value_or(record, "r", start, 0.0),
    );
    let mut x = DVector::zeros(STATE_COUNT);
    x[U] = airspeed * alpha.cos() * beta.cos();
    x[U + 1] = airspeed * beta.sin();
    x[U + 2] = airspeed * alpha.sin() * beta.cos();
    for i in 0..3 {
        x[P + i] = rates[i];
    }
    x[PHI] = value_or(record, "roll", start, 0.0);
    x[THETA] = pitch;
    x[PSI] = value_or(record, "yaw", start, 0.0);
    x[H] = value_or(record, "altitude", start, 0.0);
    let air = Atmosphere::default().at(x[H]);
    let scale = 0.5 * air.density * airspeed * airspeed * aircraft.wing_area;
    let throttle = value_or(record, "throttle", start, 0.0);
    let propulsion = &aircraft.propulsion;
    let measured = value_or(record, "thrust", start, f64::NAN);
    let thrust = if measured.is_finite() {
        propulsion.direction * measured
    } else if propulsion.max_thrust > 0.0 {
        propulsion.direction * propulsion.thrust(throttle, air.log_density_ratio)
    } else {
        Vector3::zeros()
    };
    let weight = aircraft.mass.mass * STANDARD_GRAVITY;
    let load = Vector3::new(
        value_or(record, "nx", start, 0.0),
        value_or(record, "ny", start, 0.0),
        -value_or(record, "nz", start, 1.0),
    );
    let inertia = aircraft.mass.inertia;
    let moment = rates.cross(&(inertia * rates)) - propulsion.position.cross(&thrust);
    let geometry = &aircraft.geometry;
    let arms = Vector3::new(geometry.span, geometry.chord, geometry.span);
    for i in 0..3 {
        x[coefficient_states::coefficient(i)] = (load[i] * weight - thrust[i]) / scale;
        x[coefficient_states::coefficient(3 + i)] = moment[i] / (scale * arms[i]);
    }
    let mut gains = [0.0; 6];
    for i in 0..3 {
        gains[i] = scale / aircraft.mass.mass;
        gains[3 + i] = aircraft.mass.inertia_inverse[(i, i)] * arms[i] * scale;
    }
    let markov = GaussMarkov::for_period(settings, &gains, period);
    let mut deviations = vec![1.0, 1.0, 1.0, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 5.0];
    for initial in &markov.initial {
        deviations.extend(initial);
    }
    let covariance = DMatrix::from_diagonal(&DVector::from_iterator(
        STATE_COUNT,
        deviations.iter().map(|s| s * s),
    ));
    (
        Gaussian {
            mean: x,
            covariance,
        },
        markov,
    )
}

/// The Gauss–Markov model of each coefficient (CX, CY, CZ, Cl, Cm, Cn) for
/// observations sampled every T: the spectral density of its third
/// derivative and the initial standard deviations of the coefficient and
/// its two derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussMarkov {
    pub density: [f64; 6],
    pub initial: [[f64; 3]; 6],
    /// For a lowered coefficient, the white process noise density its axis
    /// takes instead (on u̇, v̇, ẇ for CX, CY, CZ in m²/s³; on ṗ, q̇, ṙ for
    /// Cl, Cm, Cn in rad²/s³): bound²·T, the bound's spread over one
    /// sample period as white noise; 0 where the chain is not lowered.
    pub white: [f64; 6],
    /// Coefficients whose density or initial deviations the bound lowered.
    pub bounded: Vec<&'static str>,
}

impl GaussMarkov {
    /// The settings' densities and deviations, each lowered where over one
    /// sample period T of the observations it would spread the
    /// coefficient's specific force or angular acceleration by more than
    /// `force_change_bound` or `moment_change_bound` (`gains`: the
    /// acceleration per unit coefficient, q̄S/m for a force,
    /// I⁻¹_ii·L_i·q̄S for a moment, L the span or chord). With σ_C =
    /// bound/gain the coefficient's largest spread over T: a white third
    /// derivative of density q spreads it by q·T⁵/20 (variance), so
    /// q ≤ 20·σ_C²/T⁵; the initial first and second derivatives by σ′·T and
    /// σ″·T²/2, so σ′ ≤ σ_C/T and σ″ ≤ 2·σ_C/T². A lowered coefficient's
    /// axis takes white process noise of density bound²·T instead
    /// ([`GaussMarkov::white`]).
    ///
    /// Why: between two samples nothing restores the motion (the model has
    /// no aerodynamic stiffness or damping). At 25 Hz a sample follows
    /// within 0.04 s; on a 1 Hz QAR the default moment chains spread each
    /// moment coefficient by σ = 7 in one second, the predicted σ of p
    /// reaches about 200 rad/s (103 rad/s² per unit Cl times
    /// √(q·T⁷/252)) and the body velocity departs after 3 s. Lowered
    /// chains without the white noise are overconfident instead: the
    /// turbulence moves the coefficients faster than they may follow, the
    /// extrapolated slope and curvature make the predicted yaw rate and
    /// sideslip overshoot from sample to sample (the ψ, β and r
    /// innovations alternate in sign, growing from 5σ to 10σ; airspeed
    /// innovations of 10–40σ), and the filter departs after 15–55 s. The
    /// white noise gives the same spread over one sample without an
    /// extrapolated slope.
    ///
    /// For a transport at 25 Hz the default bounds lie above the default
    /// densities (the tightest, Cl at q̄ = 10 kPa, allows about 1100 1/s⁵ against
    /// the 1000 set) and change nothing; at 10 Hz they lower Cl and Cn.
    pub fn for_period(
        settings: &SmoothedRegressionSettings,
        gains: &[f64; 6],
        period: f64,
    ) -> GaussMarkov {
        let mut markov = GaussMarkov {
            density: [0.0; 6],
            initial: [[0.0; 3]; 6],
            white: [0.0; 6],
            bounded: Vec::new(),
        };
        for (i, gain) in gains.iter().enumerate() {
            let (density, initial, bound) = if i < 3 {
                (
                    settings.force_noise,
                    settings.initial_force_std,
                    settings.force_change_bound,
                )
            } else {
                (
                    settings.moment_noise,
                    settings.initial_moment_std,
                    settings.moment_change_bound,
                )
            };
            let spread = if *gain > 0.0 && gain.is_finite() {
                bound / gain
            } else {
                f64::INFINITY
            };
            let lowered = [
                density.min(20.0 * spread * spread / period.powi(5)),
                initial[1].min(spread / period),
                initial[2].min(2.0 * spread / (period * period)),
            ];
            if lowered != [density, initial[1], initial[2]] {
                markov.bounded.push(COEFFICIENT_NAMES[i]);
                markov.white[i] = bound * bound * period;
            }
            markov.density[i] = lowered[0];
            markov.initial[i] = [initial[0], lowered[1], lowered[2]];
        }
        markov
    }
}

/// The process noise spectral density (diagonal): velocities, rates, the
/// coefficients' third derivatives.
pub(super) fn process_noise(
    settings: &SmoothedRegressionSettings,
    markov: &GaussMarkov,
) -> DMatrix<f64> {
    let mut density = DVector::zeros(STATE_COUNT);
    for i in 0..3 {
        density[U + i] = settings.velocity_noise.max(markov.white[i]);
        density[P + i] = settings.rate_noise.max(markov.white[3 + i]);
    }
    for (i, value) in markov.density.iter().enumerate() {
        density[coefficient_states::coefficient(i) + 2] = *value;
    }
    DMatrix::from_diagonal(&density)
}

/// Runs the EKF and the modified Bryson–Frazier smoother over the record
/// (steps 1–3 of this module's header); the grid is the fastest observation's
/// sample period over the window where every needed observation has
/// samples.
pub fn smooth(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
) -> Result<Smoothed> {
    let plans = regression::plans(structure, METHOD).unwrap_or_default();
    smooth_with(
        record,
        structure,
        settings,
        &plans,
        Keep::SEQUENTIAL_SMOOTHER,
    )
}

/// The `ebm` pass set up on a record, as [`smooth`] runs it: the
/// coefficient-state model on its grid (the fastest observation's sample
/// period, cut to `max_step`), the filter's initial estimate and noise,
/// and the observations on the grid.
pub struct SmootherSetup {
    pub model: CoefficientStates,
    pub initial: Gaussian,
    pub noise: Noise,
    pub observations: Observations,
    /// The grid's times, first time and step.
    pub(super) times: Vec<f64>,
    start: f64,
    pub(super) step: f64,
    /// Grid points to a sample period.
    pub(super) parts: usize,
    pub(super) period: f64,
    pub(super) names: Vec<String>,
    pub(super) absent: Vec<String>,
    derived: Vec<String>,
    pub(super) markov: GaussMarkov,
    altitude_note: Option<String>,
    pub(super) thrust_measured: bool,
}

impl SmootherSetup {
    /// The set-up of [`smooth`] on `record`.
    pub fn new(
        record: &FlightRecord,
        structure: &ModelStructure,
        settings: &SmoothedRegressionSettings,
    ) -> Result<SmootherSetup> {
        let plans = regression::plans(structure, METHOD).unwrap_or_default();
        SmootherSetup::with_plans(record, structure, settings, &plans)
    }

    fn with_plans(
        record: &FlightRecord,
        structure: &ModelStructure,
        settings: &SmoothedRegressionSettings,
        plans: &[Plan],
    ) -> Result<SmootherSetup> {
        let (outputs, absent) = observations_and_inputs(record, structure, settings, plans)?;
        let (record, altitude_note) = with_altitude(record);
        let record = record.as_ref();
        let names: Vec<String> = outputs.iter().map(|o| o.channel().to_string()).collect();
        let Grid {
            start,
            step,
            len,
            parts,
            period,
        } = Grid::of(record, &names, settings)?;
        let times: Vec<f64> = (0..len).map(|k| start + k as f64 * step).collect();
        let (thrust, thrust_measured) = thrust_input(record, structure, &times)?;
        let record = unwrapped_yaw(record);
        let mut model = CoefficientStates::new(
            structure.aircraft.clone(),
            start,
            step,
            thrust,
            outputs.clone(),
        )?;
        if thrust_measured {
            model = model.with_measured_thrust();
        }
        let observations = Observations::from_record(&record, &names, start, step, len)?;
        let (measurement, derived) = measurement_noise(&record, &names, settings);
        let (initial, markov) = initial_estimate(&record, &model, settings, start, period);
        let noise = Noise {
            process: process_noise(settings, &markov),
            measurement,
        };
        Ok(SmootherSetup {
            model,
            initial,
            noise,
            observations,
            times,
            start,
            step,
            parts,
            period,
            names,
            absent,
            derived,
            markov,
            altitude_note,
            thrust_measured,
        })
    }

    /// The forward EKF over the grid (its covariance's transition by the
    /// second-order series, [`Discretisation::SecondOrder`]), keeping what
    /// `keep` says.
    pub fn filter(&self, keep: Keep) -> Result<extended_kalman::Pass> {
        extended_kalman::filter_with(
            &self.model,
            &[],
            self.initial.clone(),
            &self.noise,
            &self.observations,
            Discretisation::SecondOrder,
            keep,
        )
    }

    /// The modified Bryson–Frazier smoother back through `pass` (a
    /// [`SmootherSetup::filter`] that kept what `keep` says: the smoother
    /// goes back through the scalar updates ([`Keep::sequential`]) or the
    /// vector updates): the smoothed mean and variances at every grid
    /// point, all the histories read of it.
    pub fn smooth(pass: &extended_kalman::Pass, keep: Keep) -> Vec<(DVector<f64>, DVector<f64>)> {
        let updates: &dyn kalman::SmootherUpdates = if keep.sequential {
            &pass.scalar_updates
        } else {
            &pass.measured
        };
        if keep.sparse_transitions {
            kalman::mbf_smooth_variances(&pass.predicted, updates, &pass.sparse_transitions)
        } else {
            kalman::mbf_smooth_variances(&pass.predicted, updates, &pass.transitions)
        }
    }
}

/// The filter's grid: the fastest observation's sample period cut into
/// `parts` equal steps no longer than `max_step`, over the window where
/// every needed observation has samples.
struct Grid {
    start: f64,
    step: f64,
    len: usize,
    /// Grid points to a sample period, and the period.
    parts: usize,
    period: f64,
}

impl Grid {
    /// The grid of the observations `names` of `record`; refused with
    /// fewer than three sample periods.
    fn of(
        record: &FlightRecord,
        names: &[String],
        settings: &SmoothedRegressionSettings,
    ) -> Result<Grid> {
        let (start, end) = fitting_window(record, &settings.observations, None)?;
        let mut fastest: f64 = 0.0;
        for name in names {
            fastest = fastest.max(record.channel(name)?.rate);
        }
        if !(fastest > 0.0 && fastest.is_finite()) {
            return Err(Error::Data {
                reason: "ebm: the observations have no sample rate".into(),
            });
        }
        let period = 1.0 / fastest;
        let parts = ((period / settings.max_step) - 1e-9).ceil().max(1.0) as usize;
        let step = period / parts as f64;
        let len = ((end - start) / step + 1e-9).floor() as usize + 1;
        if len < 3 * parts {
            return Err(Error::Refused(Refusal::TooFewData {
                method: METHOD.to_string(),
                data: len / parts,
                unknowns: 3,
            }));
        }
        Ok(Grid {
            start,
            step,
            len,
            parts,
            period,
        })
    }
}

/// The measurement noise variance of each observation `names`: its
/// setting's σ² (a derived channel's from `derived_measurement_noise`)
/// plus its quantization, LSB²/12 (at least 10⁻¹⁶); and the derived
/// channels so weighted.
fn measurement_noise(
    record: &FlightRecord,
    names: &[String],
    settings: &SmoothedRegressionSettings,
) -> (DVector<f64>, Vec<String>) {
    let defaults = SmoothedRegressionSettings::default().measurement_noise;
    let mut derived = Vec::new();
    let measurement = DVector::from_iterator(
        names.len(),
        names.iter().map(|name| {
            let computed = record
                .channel(name)
                .is_ok_and(|c| aeroid_record::prep::derive::is_derived(&c.source))
                && settings.derived_measurement_noise.contains_key(name);
            if computed {
                derived.push(name.clone());
            }
            let sigma = if computed {
                settings.derived_measurement_noise[name]
            } else {
                settings
                    .measurement_noise
                    .get(name)
                    .or_else(|| defaults.get(name))
                    .copied()
                    .unwrap_or(0.0)
            };
            let resolution = record
                .channel(name)
                .ok()
                .and_then(|c| c.resolution)
                .unwrap_or(0.0);
            (sigma * sigma + resolution * resolution / 12.0).max(1e-16)
        }),
    );
    (measurement, derived)
}

/// [`smooth`] with the filter keeping what `keep` says
/// ([`SmootherSetup::smooth`]).
pub(super) fn smooth_with(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
    plans: &[Plan],
    keep: Keep,
) -> Result<Smoothed> {
    let setup = SmootherSetup::with_plans(record, structure, settings, plans)?;
    let pass = setup.filter(keep)?;
    // The histories at the sample instants: every `parts`-th grid point.
    let mut smoothed = SmootherSetup::smooth(&pass, keep);
    drop(pass);
    let mut notes = setup.notes();
    let SmootherSetup {
        times,
        parts,
        names,
        ..
    } = setup;
    let mut times = times;
    if parts > 1 {
        smoothed = smoothed.into_iter().step_by(parts).collect();
        times = times.into_iter().step_by(parts).collect();
    }
    // The standard deviations in the variances' own vectors.
    let (states, deviations): (Vec<DVector<f64>>, Vec<DVector<f64>>) = smoothed
        .into_iter()
        .map(|(mean, mut variances)| {
            variances.apply(|v| *v = v.max(0.0).sqrt());
            (mean, variances)
        })
        .unzip();
    notes.push(determination_note(&states, &deviations));
    Ok(Smoothed {
        times,
        states,
        deviations,
        observations: names,
        notes,
    })
}

impl SmootherSetup {
    /// What the pass notes before its histories: the grid and the
    /// observations, how they are sampled, the derived channels' noise,
    /// the lowered Gauss–Markov models, the altitude and the thrust.
    fn notes(&self) -> Vec<String> {
        let SmootherSetup {
            model,
            observations,
            start,
            step,
            parts,
            period,
            names,
            absent,
            derived,
            markov,
            altitude_note,
            thrust_measured,
            ..
        } = self;
        let (start, step, parts, period) = (*start, *step, *parts, *period);
        let len = model.len();
        let mut notes = vec![format!(
            "EKF + modified Bryson–Frazier smoother over {len} points of {} s from {start:.3} s{}, observing {}{}",
            aeroid_record::rounded(step),
            if parts > 1 {
                format!(
                    " ({parts} to the sample period; the histories at the {} s samples)",
                    aeroid_record::rounded(period)
                )
            } else {
                String::new()
            },
            names.join(", "),
            if absent.is_empty() {
                String::new()
            } else {
                format!("; not in the record: {}", absent.join(", "))
            }
        )];
        notes.extend(observations.note(step));
        if !derived.is_empty() {
            notes.push(format!(
                "derived channels weighted by derived_measurement_noise: {}",
                derived.join(", ")
            ));
        }
        if !markov.bounded.is_empty() {
            notes.push(format!(
                "the Gauss–Markov models of {} lowered to the change bounds over the {} s sample period (third-derivative densities {})",
                markov.bounded.join(", "),
                aeroid_record::rounded(period),
                markov
                    .density
                    .iter()
                    .zip(COEFFICIENT_NAMES)
                    .map(|(q, name)| format!("{name} {q:.2e}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        notes.extend(altitude_note.iter().cloned());
        if *thrust_measured {
            notes.push(
                "thrust: the record's 'thrust' channel, along the aircraft's thrust line, not the throttle and engine model".into(),
            );
        }
        notes
    }
}

/// How well each coefficient history is determined: its smoothed standard
/// deviation (RMS over the record) against its variation (standard
/// deviation about its mean).
fn determination_note(smoothed: &[DVector<f64>], deviations: &[DVector<f64>]) -> String {
    let items: Vec<String> = COEFFICIENT_NAMES
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let c = coefficient_states::coefficient(i);
            let n = smoothed.len() as f64;
            let mean = smoothed.iter().map(|x| x[c]).sum::<f64>() / n;
            let variation =
                (smoothed.iter().map(|x| (x[c] - mean).powi(2)).sum::<f64>() / n).sqrt();
            let sigma = (deviations.iter().map(|d| d[c] * d[c]).sum::<f64>() / n).sqrt();
            format!("{name} σ {sigma:.2e} (variation {variation:.2e})")
        })
        .collect();
    format!(
        "smoothed coefficient histories, RMS standard deviation against the history's own variation: {}",
        items.join(", ")
    )
}
