//! Flights of a linear model (a scenario with a `[linear]` table): the
//! model file's ẋ = A·x + B·u + b + F·w, y = [C·x + D·u + c; (ẋ)_R] flown
//! on the scenario's step with the model's own exact discretisation
//! ([`LinearStateSpace::step`]), its parameters at the file's values (the
//! run's truth, exact), recorded by the recorder profile like any flight.
//!
//! - Inputs: a model input named like a control (`elevator`, `aileron`,
//!   `rudder`, `flap`, `throttle`) is the scenario's `[[inputs]]` signal on
//!   that control (the deviation from trim), any other input 0.
//! - Initial state: the model file's `initial_state` when it states one,
//!   else the equilibrium of the inputs at t = 0, A·x₀ = −(B·u₀ + b)
//!   (x₀ = 0 when A is singular).
//! - Process noise: white, F = diag(`process_noise`) over the named
//!   states; per step w_k ~ N(0, Q_d), Q_d = ∫₀ʰ e^{A·s}·F·Fᵀ·e^{Aᵀ·s} ds
//!   (Van Loan, [`aeroid_numerics::kalman::discretise`]), drawn
//!   from [`random::streams::PROCESS_NOISE`] of the scenario's seed: the
//!   discrete process of exactly the continuous model that the filter
//!   error method postulates.
//! - Gusts (`gusts`): Dryden turbulence ([`aeroid_sim::wind`], its
//!   forming filters discretised exactly, seeded by the scenario's seed on
//!   the turbulence stream, at the trim airspeed and altitude) entering as
//!   inputs through G: ẋ = A·x + B·u + b + G·(u_g, v_g, w_g), held or
//!   interpolated over each step as the model's inputs are, so the step
//!   stays exact and the truth the model's parameters.
//! - Feedback (`feedback`): a stability augmentation moving one model
//!   input by K·x on top of the pilot's signal, x read at the start of
//!   each frame and the command held over the frame (a flight-control
//!   computer; the model's inputs must then be held, `interpolation =
//!   "zoh"`); the recorded input is the total. The flight then starts at
//!   the closed loop's equilibrium, (A + B_c·K)·x₀ = −(B·u₀ + b), B_c the
//!   moved input's column.
//! - Record: the profile's channels whose quantity is a state, input or
//!   output of the model, named as in the file ([`Profile::record_signals`]).

use crate::error::{Error, Result};
use aeroid_core::random::{self, streams};
use aeroid_estimation::linear_structure::LinearStructure;
use aeroid_estimation::model::linear::LinearStateSpace;
use aeroid_estimation::model::state_space::StateSpaceModel;
use aeroid_numerics::kalman;
use aeroid_record::FlightRecord;
use aeroid_record::recorder::Profile;
use aeroid_sim::aero::ModelKind;
use aeroid_sim::feedback::Feedback;
use aeroid_sim::scenario::{LinearFlight, LinearGusts, Scenario};
use aeroid_sim::state::Control;
use aeroid_sim::trace::TruthTrace;
use aeroid_sim::truth::RunTruth;
use aeroid_sim::wind::{FlightConditions, WindSpec};
use nalgebra::{DMatrix, DVector};
use rand::RngExt;
use rand_distr::StandardNormal;

/// A linear model's flight: the grid, every signal by name, and its truth.
#[derive(Debug, Clone)]
pub struct LinearTrace {
    pub times: Vec<f64>,
    /// States, inputs and outputs, each on the grid.
    pub signals: Vec<(String, Vec<f64>)>,
    /// The Dryden gusts (u_g, v_g, w_g, m/s) at each grid point; empty
    /// without `[linear] gusts`.
    pub gusts: Vec<[f64; 3]>,
    pub truth: RunTruth,
}

/// Records a scenario's flight: a linear model's when it has a `[linear]`
/// table, else the simulator's ([`aeroid_record::recorder::record_scenario_seeded`]).
pub fn record_flight(
    scenario: &Scenario,
    profile: &Profile,
    recorder_seed: u64,
) -> Result<(FlightRecord, RunTruth)> {
    record_flight_traced(scenario, profile, recorder_seed).map(|(record, truth, _)| (record, truth))
}

/// [`record_flight`], and the simulator's truth trace when the simulator
/// flew (none for a linear model's flight).
pub(crate) fn record_flight_traced(
    scenario: &Scenario,
    profile: &Profile,
    recorder_seed: u64,
) -> Result<(FlightRecord, RunTruth, Option<TruthTrace>)> {
    let Some(linear) = &scenario.linear else {
        let (trace, truth) = aeroid_sim::fly(scenario)?;
        let record = profile.record(&trace, &scenario.aircraft, recorder_seed)?;
        return Ok((record, truth, Some(trace)));
    };
    let trace = fly(scenario, linear)?;
    let step = scenario.step;
    let record = profile.record_signals(
        &scenario.name,
        &trace.times,
        step,
        &trace.signals,
        recorder_seed,
    )?;
    Ok((record, trace.truth, None))
}

/// Flies the linear model of a scenario's `[linear]` table.
// The model's setup, then one simulation pass: state, process noise, feedback command and outputs advance together step by step.
pub fn fly(scenario: &Scenario, linear: &LinearFlight) -> Result<LinearTrace> {
    let structure = LinearStructure::load(&linear.model_path.to_string_lossy())?;
    let count = scenario.step_count() + 1;
    let times: Vec<f64> = (0..count).map(|k| k as f64 * scenario.step).collect();
    let (distribution, gusts) = match &linear.gusts {
        Some(spec) => {
            let (g, gusts) = gust_inputs(scenario, spec, &structure, count)?;
            (Some(g), gusts)
        }
        None => (None, Vec::new()),
    };
    let mut inputs = scheduled_inputs(scenario, &structure, &times, &gusts);
    let mut model =
        structure.model_disturbed(0.0, scenario.step, inputs.clone(), distribution.as_ref())?;
    let augmentation = linear
        .feedback
        .as_ref()
        .map(|feedback| augmentation(scenario, feedback, &structure))
        .transpose()?;
    let theta = structure.parameter_values();
    let distribution = process_noise(&structure, linear, scenario)?;
    let noise = noise_factor(&model, &distribution)?;
    let matrices = model.at(theta.as_slice())?;
    // The equilibrium of the control inputs alone: the gusts start from
    // their stationary distribution, the motion from trim.
    let controls_at_start = inputs[0].rows(0, structure.inputs.len());
    let mut closed = matrices.a.clone();
    if let Some((column, gains, _)) = &augmentation {
        closed += matrices.b.column(*column) * gains.transpose();
    }
    let mut x = structure.initial_state.clone().unwrap_or_else(|| {
        equilibrium(
            &closed,
            &(matrices.b.columns(0, structure.inputs.len()) * controls_at_start
                + &matrices.state_bias),
        )
    });
    let mut command = 0.0;
    let mut rng = random::stream(scenario.seed, streams::PROCESS_NOISE);
    let n = structure.states.len();
    let mut states = vec![Vec::with_capacity(count); n];
    let mut outputs = vec![Vec::with_capacity(count); structure.outputs.len()];
    for (k, &t) in times.iter().enumerate() {
        if k > 0 {
            x = model.step(k - 1, x.as_slice(), theta.as_slice())?;
            if let Some(factor) = &noise {
                let draws = DVector::from_fn(n, |_, _| rng.sample::<f64, _>(StandardNormal));
                x += factor * draws;
            }
            if !x.iter().all(|v| v.is_finite()) {
                return Err(aeroid_sim::Error::Departed {
                    time: t,
                    reason: format!("the linear model '{}' diverged", structure.name),
                }
                .into());
            }
        }
        if let Some((column, gains, frame)) = &augmentation {
            if k % frame == 0 {
                command = gains.dot(&x);
            }
            inputs[k][*column] += command;
            model.inputs[k][*column] = inputs[k][*column];
        }
        let y = model.outputs(t, x.as_slice(), theta.as_slice())?;
        for i in 0..n {
            states[i].push(x[i]);
        }
        for (o, column) in outputs.iter_mut().enumerate() {
            column.push(y[o]);
        }
    }
    let mut signals: Vec<(String, Vec<f64>)> =
        structure.states.iter().cloned().zip(states).collect();
    for (j, name) in structure.inputs.iter().enumerate() {
        signals.push((name.clone(), inputs.iter().map(|u| u[j]).collect()));
    }
    signals.extend(structure.outputs.iter().cloned().zip(outputs));
    Ok(LinearTrace {
        times,
        signals,
        gusts,
        truth: truth(scenario, &structure),
    })
}

/// The model's inputs at `times`: each control input's deviation from
/// trim in the scenario's schedule (0 for an input that is no control),
/// then the gust inputs `gusts` (per time, if any).
fn scheduled_inputs(
    scenario: &Scenario,
    structure: &LinearStructure,
    times: &[f64],
    gusts: &[[f64; 3]],
) -> Vec<DVector<f64>> {
    let controls: Vec<Option<usize>> = structure
        .inputs
        .iter()
        .map(|name| Control::ALL.iter().position(|c| c.name() == name))
        .collect();
    times
        .iter()
        .enumerate()
        .map(|(k, &t)| {
            let deviation = scenario.inputs.deviation(t);
            let gust = gusts.get(k).map_or(&[][..], |g| &g[..]);
            DVector::from_iterator(
                controls.len() + gust.len(),
                controls
                    .iter()
                    .map(|c| c.map_or(0.0, |i| deviation[i]))
                    .chain(gust.iter().copied()),
            )
        })
        .collect()
}

/// The moved input's index, the gains over the model's states and the
/// frame in steps of a `[linear.feedback]` table, checked against the
/// model: a named input and states, held inputs.
fn augmentation(
    scenario: &Scenario,
    feedback: &Feedback,
    structure: &LinearStructure,
) -> Result<(usize, DVector<f64>, usize)> {
    let invalid = |field: String, message: String| -> Error {
        aeroid_core::Error::Invalid {
            path: scenario.path.clone(),
            problems: vec![aeroid_core::error::FieldError { field, message }],
        }
        .into()
    };
    let Some(column) = structure.inputs.iter().position(|i| *i == feedback.control) else {
        return Err(invalid(
            "linear.feedback.control".into(),
            format!(
                "'{}' is not an input of '{}' ({})",
                feedback.control,
                structure.name,
                structure.inputs.join(", ")
            ),
        ));
    };
    if structure.interpolation != aeroid_sim::integrator::Interpolation::ZeroOrderHold.into() {
        return Err(invalid(
            "linear.feedback".into(),
            format!(
                "the augmentation holds its command over a frame: the model '{}' must hold its inputs (interpolation = \"zoh\")",
                structure.name
            ),
        ));
    }
    let mut gains = DVector::zeros(structure.states.len());
    for (state, &gain) in &feedback.gains {
        let Some(i) = structure.states.iter().position(|s| s == state) else {
            return Err(invalid(
                format!("linear.feedback.gains.{state}"),
                format!(
                    "not a state of '{}' ({})",
                    structure.name,
                    structure.states.join(", ")
                ),
            ));
        };
        gains[i] = gain;
    }
    Ok((column, gains, feedback.frame_steps))
}

/// G of `[linear] gusts` (its rows checked against the model's states) and
/// the Dryden gusts (u_g, v_g, w_g) at every grid point
/// ([`WindSpec::generate`]: the scenario's seed, the turbulence stream; at
/// the trim airspeed and altitude).
fn gust_inputs(
    scenario: &Scenario,
    spec: &LinearGusts,
    structure: &LinearStructure,
    count: usize,
) -> Result<(DMatrix<f64>, Vec<[f64; 3]>)> {
    let invalid = |field: &str, message: String| -> Error {
        aeroid_core::Error::Invalid {
            path: scenario.path.clone(),
            problems: vec![aeroid_core::error::FieldError {
                field: field.to_string(),
                message,
            }],
        }
        .into()
    };
    let n = structure.states.len();
    if spec.matrix.len() != n || spec.matrix.iter().any(|row| row.len() != 3) {
        return Err(invalid(
            "linear.gusts.matrix",
            format!(
                "must have one row of 3 entries per state of '{}' ({}: {n} rows)",
                structure.name,
                structure.states.join(", ")
            ),
        ));
    }
    let g = DMatrix::from_fn(n, 3, |i, j| spec.matrix[i][j]);
    let wind = WindSpec {
        turbulence: Some(spec.turbulence.clone()),
        ..WindSpec::default()
    };
    let conditions = FlightConditions {
        airspeed: scenario.trim.airspeed,
        altitude: scenario.trim.altitude,
    };
    let samples = wind
        .generate(&conditions, scenario.step, count, scenario.seed)
        .map_err(|message| invalid("linear.gusts", message.to_string()))?;
    Ok((
        g,
        samples
            .iter()
            .map(|s| [s.body[0], s.body[1], s.body[2]])
            .collect(),
    ))
}

/// F's diagonal from `[linear] process_noise`, named states checked.
fn process_noise(
    structure: &LinearStructure,
    linear: &LinearFlight,
    scenario: &Scenario,
) -> Result<DVector<f64>> {
    let mut distribution = DVector::zeros(structure.states.len());
    for (state, &value) in &linear.process_noise {
        let Some(i) = structure.states.iter().position(|s| s == state) else {
            return Err(aeroid_core::Error::Invalid {
                path: scenario.path.clone(),
                problems: vec![aeroid_core::error::FieldError {
                    field: format!("linear.process_noise.{state}"),
                    message: format!(
                        "not a state of '{}' ({})",
                        structure.name,
                        structure.states.join(", ")
                    ),
                }],
            }
            .into());
        };
        distribution[i] = value;
    }
    Ok(distribution)
}

/// A factor L with L·Lᵀ = Q_d of one step, or None without process noise.
fn noise_factor(
    model: &LinearStateSpace,
    distribution: &DVector<f64>,
) -> Result<Option<DMatrix<f64>>> {
    if distribution.iter().all(|f| *f == 0.0) {
        return Ok(None);
    }
    let theta = model.parameter_values();
    let a = model.at(theta.as_slice())?.a;
    let n = a.nrows();
    let spectral = DMatrix::from_diagonal(&distribution.map(|f| f * f));
    let q =
        kalman::discretise(&a, &DMatrix::zeros(n, 0), Some(&spectral), model.step).process_noise;
    // Q_d is only positive semi-definite when some states have no noise:
    // its symmetric eigen-decomposition gives a factor either way.
    let eigen = q.symmetric_eigen();
    let roots = eigen.eigenvalues.map(|v| v.max(0.0).sqrt());
    Ok(Some(&eigen.eigenvectors * DMatrix::from_diagonal(&roots)))
}

/// x with A·x = −rate, or 0 when A is singular.
fn equilibrium(a: &DMatrix<f64>, rate: &DVector<f64>) -> DVector<f64> {
    a.clone()
        .lu()
        .solve(&-rate)
        .filter(|x| x.iter().all(|v| v.is_finite()))
        .unwrap_or_else(|| DVector::zeros(a.nrows()))
}

/// The exact truth of a linear flight: the model's parameter values.
fn truth(scenario: &Scenario, structure: &LinearStructure) -> RunTruth {
    RunTruth::exact_parameters(
        scenario,
        (0.0, 0.0, 0.0, Default::default()),
        ModelKind::Linear,
        structure
            .names
            .iter()
            .cloned()
            .zip(structure.starts.iter().copied())
            .collect(),
    )
}
