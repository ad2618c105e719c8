//! A-priori identifiability of an aircraft's aerodynamic parameters from a
//! recorder: the Cramér–Rao bounds that the recorded channels allow, before
//! any estimator runs (`aeroid identifiability`; the user's reference is
//! docs/methods.md, "A-priori identifiability").
//!
//! **Bounds.** The output sensitivities S_c(t_i) = ∂y_c(t_i)/∂θ_j of every
//! recorded channel at its own instants come from central differences: the
//! scenario flown again with θ_j ± h_j (h_j = 10⁻⁴·max(|θ_j|, 10⁻²)), the
//! same trim, controls and wind, recorded by the profile's deterministic
//! parts (rates, skew, delay, lag, filter, bias, scale, saturation) without
//! noise or quantization. With R_c = σ_noise² + LSB²/12 the information is
//! M = Σ_c Σ_i S_cᵀ S_c / R_c and σ_j = √(M⁻¹)_jj (Verma & Peyada 2020,
//! Eq. 10; the reflex-wing UAV paper, Eq. 15); the null space of M gets
//! σ = ∞. Segments (multiple shooting) add each segment's initial state as
//! nuisance unknowns, marginalised by the inversion.
//!
//! **Model errors the bound does not know** (Jategaonkar, "Flight Vehicle
//! System Identification", 2nd ed., §4.17: to first order a maximum
//! likelihood estimate moves by δθ = M⁻¹·Σ Sᵀ·R⁻¹·r, r the output error at
//! the truth): δθ_inputs, the flight flown with the inputs as recorded
//! (sampled, quantized, interpolated), and δθ_wind, the flight without its
//! gusts and turbulence.
//!
//! **Verdict.** Identifiable when σ_j/|θ_j| < threshold (10 %: the ±20 %
//! of a 95 % interval, the accuracy of a-priori handbook values) and
//! |δθ_inputs| < 2·threshold·|θ_j|; δθ_wind is reported beside it. For a
//! gusty flight the calm flight's bound is computed too: a parameter
//! identifiable only in the gusty one is identifiable *through the gusts*.
//! The bounds know the wind, so "identifiable" is necessary, not
//! sufficient; a record without usable flow angles, whose estimators take
//! the geometric ones, gets a note ([`aeroid_record::prep::flow_angles`]).
//!
//! **The sampling rule** (Wang et al. 2012, §2, item 3: sample "at least 25
//! times" the frequency of the modes): each parameter's mode is the one
//! whose eigenvalue it moves furthest, |∂λ/∂ln θ_j| from central
//! differences of the trimmed linearisation ([`crate::linearize`]),
//! when its elasticity is at least 0.1; a parameter whose mode's 25·|λ|/2π
//! exceeds the channels' fastest rate is marked "below the rule" (advice,
//! not part of the verdict).

use crate::error::{Error, Result};
use crate::linearize::{ModeKind, find, linearize};
use aeroid_numerics::gauss_newton::{pseudo_inverse_or_infinite, unit_diagonal_scale};
use aeroid_record::FlightRecord;
use aeroid_record::recorder::Profile;
use aeroid_sim::Simulation;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::state::{self, CONTROL_COUNT, Control, StateVector};
use aeroid_sim::wind::WindSample;
use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};

/// Settings of an identifiability analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifiabilityOptions {
    /// Relative-σ threshold below which a parameter counts as identifiable.
    pub threshold: f64,
    /// Parameters to analyse; default every aerodynamic parameter of the aircraft.
    pub parameters: Option<Vec<String>>,
    /// Channels to use; default every usable channel of the profile.
    pub channels: Option<Vec<String>>,
    /// Relative central-difference step.
    pub relative_step: f64,
    /// Split the flight into segments of this length (s), each restarted
    /// from its own unknown initial state (multiple shooting); default one
    /// segment, the whole flight.
    pub segment: Option<f64>,
}

impl IdentifiabilityOptions {
    /// The central-difference step of a parameter whose value is `truth`:
    /// h = relative_step·max(|θ|, 10⁻²).
    fn parameter_step(&self, truth: f64) -> f64 {
        self.relative_step * truth.abs().max(1e-2)
    }
}

impl Default for IdentifiabilityOptions {
    fn default() -> Self {
        IdentifiabilityOptions {
            threshold: 0.1,
            parameters: None,
            channels: None,
            relative_step: 1e-4,
            segment: None,
        }
    }
}

/// A channel that contributed information.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelUse {
    pub name: String,
    /// √R_c: noise and quantization error together.
    pub sigma: f64,
    pub samples: usize,
}

/// The factor of the sampling rule: a mode wants at least this many
/// samples a period (module documentation, "The sampling rule").
pub const RULE_FACTOR: f64 = 25.0;

/// The least elasticity for a mode to count as a parameter's.
pub const GOVERNING_ELASTICITY: f64 = 0.1;

/// The mode a parameter moves furthest (module documentation, "The
/// sampling rule").
#[derive(Debug, Clone, PartialEq)]
pub struct GoverningMode {
    pub kind: ModeKind,
    /// |λ|/2π at the trim (Hz).
    pub frequency: f64,
    /// |∂λ/∂θ|·|θ|/|λ|.
    pub elasticity: f64,
}

impl GoverningMode {
    /// The sample rate the rule asks for: 25 times the mode's frequency.
    pub fn rule_rate(&self) -> f64 {
        RULE_FACTOR * self.frequency
    }
}

/// One parameter's bound.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifiabilityRow {
    pub parameter: String,
    pub truth: f64,
    pub sigma: f64,
    /// First-order error from the inputs as recorded (module documentation).
    pub input_error: f64,
    /// First-order error of a fit that ignores the gusts and turbulence.
    pub wind_error: f64,
    /// The bound and the recorded inputs' error of the same flight without
    /// its gusts and turbulence (the controls' excitation alone); None for
    /// a flight without them.
    pub calm: Option<(f64, f64)>,
    pub identifiable: bool,
    /// The mode the parameter moves furthest, when by
    /// [`GOVERNING_ELASTICITY`] or more; None otherwise (control
    /// derivatives).
    pub mode: Option<GoverningMode>,
}

impl IdentifiabilityRow {
    /// σ/|truth| (∞ for a zero truth with a non-zero bound).
    pub fn relative_sigma(&self) -> f64 {
        self.sigma / self.truth.abs()
    }

    /// Identifiable only through the gusts and turbulence: the flight
    /// without them fails the verdict (its bound at or above the threshold,
    /// or its recorded inputs' error beyond twice it). An estimator must
    /// then know the wind, or draw the information from the turbulent
    /// motion as a filter does, to reach the bound.
    pub fn through_gusts(&self, threshold: f64) -> bool {
        let limit = threshold * self.truth.abs();
        self.identifiable
            && self
                .calm
                .is_some_and(|(sigma, error)| !(sigma < limit && error.abs() < 2.0 * limit))
    }

    /// Its mode wants a faster sample rate than `rate` by the rule.
    pub fn below_rule(&self, rate: f64) -> bool {
        self.mode.as_ref().is_some_and(|m| m.rule_rate() > rate)
    }
}

/// The result of an analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct Identifiability {
    pub scenario: String,
    pub profile: String,
    pub threshold: f64,
    /// Segment length (s): each segment's initial state is an unknown.
    pub segment: f64,
    pub channels: Vec<ChannelUse>,
    /// The fastest sample rate of the channels used (Hz).
    pub rate: f64,
    /// Parameters left out, with the reason: those the central differences
    /// cannot move both ways without changing the model's structure
    /// (τ1 = 0, χ algebraic).
    pub parameters_left_out: Vec<(String, String)>,
    /// Channels left out, with the reason.
    pub excluded: Vec<(String, String)>,
    /// What the bounds cannot show about this flight and record (module
    /// documentation, "The geometric flow angles").
    pub notes: Vec<String>,
    pub rows: Vec<IdentifiabilityRow>,
}

impl Identifiability {
    /// The table: parameter, truth, σ, σ/|truth|, verdict; then the channels.
    pub fn table(&self) -> String {
        let mut text = format!(
            "{} recorded by {}: Cramér–Rao bounds at the truth, {} s segments with unknown initial states; identifiable when σ/|truth| < {}\n",
            self.scenario, self.profile, self.segment, self.threshold
        );
        text += "error from inputs: the first-order error of an estimator that takes the recorded inputs (at the record's rate and resolution, reconstructed by the scenario's interpolation) as exact; error from wind: of one that ignores the gusts and turbulence (not in the verdict); calm σ: the bound of the flight without its gusts and turbulence (identifiable \"through the gusts\" when that flight fails the verdict: its bound or its inputs' error); mode: the mode the parameter moves furthest at the trim and the rate the sampling rule asks for (25 times its frequency; advice, not in the verdict)\n";
        text += &format!(
            "{:<14} {:>12} {:>11} {:>10} {:>12} {:>12} {:>12}  {:<24} {}\n",
            "parameter",
            "truth",
            "σ",
            "σ/|truth|",
            "inputs/|θ|",
            "wind/|θ|",
            "calm σ/|θ|",
            "mode, 25×f",
            "verdict"
        );
        for row in &self.rows {
            text += &format!(
                "{:<14} {:>12.6} {:>11.3e} {:>10.3e} {:>12.2e} {:>12.2e} {:>12}  {:<24} {}{}\n",
                row.parameter,
                row.truth,
                row.sigma,
                row.relative_sigma(),
                row.input_error / row.truth.abs(),
                row.wind_error / row.truth.abs(),
                row.calm.map_or("-".to_string(), |(s, _)| format!(
                    "{:.3e}",
                    s / row.truth.abs()
                )),
                row.mode.as_ref().map_or("-".to_string(), |m| format!(
                    "{}, {:.2} Hz",
                    m.kind.name(),
                    m.rule_rate()
                )),
                verdict(row, self.threshold),
                if row.below_rule(self.rate) {
                    ", below the rule"
                } else {
                    ""
                }
            );
        }
        let count = self.rows.iter().filter(|r| r.identifiable).count();
        let gusts = self
            .rows
            .iter()
            .filter(|r| r.through_gusts(self.threshold))
            .count();
        text += &format!(
            "{count} of {} identifiable ({gusts} through the gusts)\n",
            self.rows.len()
        );
        let below: Vec<&str> = self
            .rows
            .iter()
            .filter(|r| r.identifiable && r.below_rule(self.rate))
            .map(|r| r.parameter.as_str())
            .collect();
        text += &format!(
            "sampling rule (Wang et al. 2012: at least 25 times the mode's frequency): the channels used are sampled at up to {} Hz; {}\n",
            aeroid_record::significant(self.rate, 3),
            if below.is_empty() {
                "every identifiable parameter's mode within it".to_string()
            } else {
                format!(
                    "{} of the identifiable below it: {}",
                    below.len(),
                    below.join(", ")
                )
            }
        );
        text += &format!(
            "channels used: {}\n",
            self.channels
                .iter()
                .map(|c| format!("{} (σ {:.3e}, {} samples)", c.name, c.sigma, c.samples))
                .collect::<Vec<_>>()
                .join(", ")
        );
        for note in &self.notes {
            text += &format!("note: {note}\n");
        }
        for (name, reason) in &self.parameters_left_out {
            text += &format!("parameter left out: {name}: {reason}\n");
        }
        for (name, reason) in &self.excluded {
            text += &format!("left out: {name}: {reason}\n");
        }
        text
    }

    /// Rounded relative bounds and verdicts, one per line, for snapshots.
    pub fn snapshot(&self) -> String {
        let mut text = format!(
            "{} / {}: {} s segments, threshold {}, channels at up to {} Hz\n",
            self.scenario,
            self.profile,
            self.segment,
            self.threshold,
            aeroid_record::significant(self.rate, 3)
        );
        for row in &self.rows {
            let calm = row.calm.map_or(String::new(), |(s, error)| {
                format!(
                    "  calm {} inputs {}",
                    aeroid_record::significant(s / row.truth.abs(), 2),
                    aeroid_record::significant(error / row.truth.abs(), 2)
                )
            });
            let mode = row.mode.as_ref().map_or(String::new(), |m| {
                format!(
                    "  {} {} Hz{}",
                    m.kind.name(),
                    aeroid_record::significant(m.frequency, 2),
                    if row.below_rule(self.rate) {
                        " (below the rule)"
                    } else {
                        ""
                    }
                )
            });
            text += &format!(
                "{} σ/|truth| = {}  inputs {}  wind {}{calm}{mode}  {}\n",
                row.parameter,
                aeroid_record::significant(row.relative_sigma(), 2),
                aeroid_record::significant(row.input_error / row.truth.abs(), 2),
                aeroid_record::significant(row.wind_error / row.truth.abs(), 2),
                verdict(row, self.threshold)
            );
        }
        text += &format!(
            "channels: {}\n",
            self.channels
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
        text
    }
}

fn verdict(row: &IdentifiabilityRow, threshold: f64) -> &'static str {
    if row.through_gusts(threshold) {
        "identifiable (through the gusts)"
    } else if row.identifiable {
        "identifiable"
    } else if row.sigma < threshold * row.truth.abs() {
        "NOT identifiable (recorded inputs)"
    } else {
        "NOT identifiable"
    }
}

/// Unknown initial-state components of a segment: u, v, w, p, q, r, three
/// small body-axis rotations of the attitude, and the altitude.
const NUISANCE: usize = 10;

/// The state `x` with nuisance component `component` moved by `delta`.
fn perturbed_state(x: &StateVector, component: usize, delta: f64) -> StateVector {
    let mut x = *x;
    match component {
        0..=5 => x[state::U + component] += delta,
        6..=8 => {
            let mut axis = Vector3::zeros();
            axis[component - 6] = delta;
            let attitude = state::attitude(&x) * UnitQuaternion::from_scaled_axis(axis);
            state::set_attitude(&mut x, &attitude);
        }
        _ => x[state::DOWN] -= delta,
    }
    x
}

/// Central-difference step of nuisance component `component` (m/s, rad/s, rad, m).
fn nuisance_step(component: usize) -> f64 {
    match component {
        0..=2 => 1e-2,
        3..=5 => 1e-4,
        6..=8 => 1e-4,
        _ => 0.1,
    }
}

/// Analyses which of the scenario aircraft's parameters the profile's
/// channels can identify (see the module documentation).
pub fn analyse(
    scenario: &Scenario,
    profile: &Profile,
    options: &IdentifiabilityOptions,
) -> Result<Identifiability> {
    if let Some(segment) = options.segment
        && !(segment.is_finite() && segment >= scenario.step)
    {
        return Err(Error::Segment {
            length: segment,
            step: scenario.step,
            scenario: scenario.path.clone(),
        });
    }
    if !scenario.parameter_changes.is_empty() {
        return Err(Error::ChangingParameters {
            scenario: scenario.name.clone(),
            path: scenario.path.clone(),
        });
    }
    let simulation = Simulation::prepare(scenario)?;
    let aero = &scenario.aircraft.aero;
    let requested: Vec<String> = match &options.parameters {
        Some(names) => names.clone(),
        None => aero.parameters.names().to_vec(),
    };
    let (mut names, mut truths) = (Vec::new(), Vec::new());
    let mut parameters_left_out = Vec::new();
    for name in requested {
        let index = aero
            .parameters
            .index(&name)
            .ok_or_else(|| aeroid_core::Error::Unknown {
                kind: "parameter",
                name: name.clone(),
                known: aero.parameters.names().to_vec(),
            })?;
        let truth = aero.parameters.values()[index];
        // A parameter the central differences cannot move both ways
        // without changing the model (τ1 = 0 makes χ algebraic).
        let h = options.parameter_step(truth);
        let fixed = [truth + h, truth - h]
            .into_iter()
            .find_map(|value| aero.check_replacement(&name, value).err());
        match fixed {
            None => {
                names.push(name);
                truths.push(truth);
            }
            Some(reason) if options.parameters.is_none() => {
                parameters_left_out.push((name, reason.to_string()));
            }
            Some(reason) => {
                return Err(Error::Identifiability {
                    scenario: scenario.name.clone(),
                    reason: format!(
                        "parameter {name} = {truth} cannot be moved by ±{h:.1e} for its sensitivity: {reason}"
                    ),
                });
            }
        }
    }
    let (channels, excluded) = usable_channels(profile, options.channels.as_deref())?;
    let clean = profile.without_random_errors();
    let nominal_trace = simulation.run()?;
    let nominal_states: Vec<StateVector> = nominal_trace.samples.iter().map(|s| s.state).collect();
    let duration = nominal_trace.samples.last().map_or(0.0, |s| s.time);
    let segment = options
        .segment
        .filter(|t| *t < duration)
        .unwrap_or(duration.max(simulation.step));
    let segment_steps = ((segment / simulation.step).round() as usize).max(1);
    let segments = nominal_states.len().div_ceil(segment_steps);
    // Flies `simulation` with one parameter changed or one initial-state
    // component moved in every segment, restarting every segment from the
    // nominal flight's state there.
    let fly = |simulation: &Simulation,
               nominal_states: &[StateVector],
               parameter: Option<(&str, f64)>,
               nuisance: Option<(usize, f64)>| {
        let mut simulation = simulation.clone();
        if let Some((name, value)) = parameter {
            simulation.model.aircraft.aero.parameters.set(name, value)?;
        }
        let trace = simulation
            .run_with_restarts(|k| {
                (k % segment_steps == 0).then(|| match nuisance {
                    Some((component, delta)) => {
                        perturbed_state(&nominal_states[k], component, delta)
                    }
                    None => nominal_states[k],
                })
            })
            .map_err(|error| Error::Identifiability {
                scenario: scenario.name.clone(),
                reason: format!("a perturbed flight failed: {error}"),
            })?;
        Ok::<_, Error>(clean.record(&trace, &scenario.aircraft, scenario.seed)?)
    };
    // The nominal record: the flight already flown (a restart at its own state changes nothing).
    let nominal = clean.record(&nominal_trace, &scenario.aircraft, scenario.seed)?;
    let wraps = |name: &str| {
        profile
            .channels
            .iter()
            .any(|c| c.measurand.name == name && c.measurand.wraps)
    };
    let mut uses = Vec::new();
    let mut segment_of_row = Vec::new();
    for (name, sigma) in &channels {
        let channel = nominal.channel(name)?;
        segment_of_row.extend(
            channel
                .times
                .iter()
                .map(|t| ((t / segment).floor().max(0.0) as usize).min(segments - 1)),
        );
        uses.push(ChannelUse {
            name: name.clone(),
            sigma: *sigma,
            samples: channel.values.len(),
        });
    }
    let rows_total = segment_of_row.len();
    let columns = names.len() + NUISANCE * segments;
    // Weighted central difference of the recorded channels, row by row.
    let difference = |plus: &FlightRecord, minus: &FlightRecord, h: f64| -> Result<Vec<f64>> {
        let mut column = Vec::with_capacity(rows_total);
        for channel in &uses {
            let (up, down) = (plus.channel(&channel.name)?, minus.channel(&channel.name)?);
            let angle = wraps(&channel.name);
            for (a, b) in up.values.iter().zip(&down.values) {
                let mut d = a - b;
                if angle {
                    // Heading-like channels wrap at 2π; a tiny perturbation never moves π.
                    d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
                }
                column.push(d / (2.0 * h) / channel.sigma);
            }
        }
        Ok(column)
    };
    // The weighted sensitivities of a flight (its simulation and states)
    // to the parameters, then to each segment's initial state.
    let sensitivities_of = |simulation: &Simulation, states: &[StateVector]| {
        let mut sensitivities = DMatrix::zeros(rows_total, columns);
        for (j, (name, truth)) in names.iter().zip(&truths).enumerate() {
            let h = options.parameter_step(*truth);
            let plus = fly(simulation, states, Some((name, truth + h)), None)?;
            let minus = fly(simulation, states, Some((name, truth - h)), None)?;
            for (row, value) in difference(&plus, &minus, h)?.into_iter().enumerate() {
                sensitivities[(row, j)] = value;
            }
        }
        // An initial-state component moved in every segment at once:
        // segments are independent, so each row's difference belongs to
        // its own segment's unknown.
        for component in 0..NUISANCE {
            let h = nuisance_step(component);
            let plus = fly(simulation, states, None, Some((component, h)))?;
            let minus = fly(simulation, states, None, Some((component, -h)))?;
            for (row, value) in difference(&plus, &minus, h)?.into_iter().enumerate() {
                let column = names.len() + NUISANCE * segment_of_row[row] + component;
                sensitivities[(row, column)] = value;
            }
        }
        Ok::<_, Error>(sensitivities)
    };
    // The bounds σ_j of the parameters from a flight's sensitivities.
    let bounds = |sensitivities: &DMatrix<f64>| {
        let information = sensitivities.transpose() * sensitivities;
        let covariance =
            pseudo_inverse_or_infinite(&marginal_information(&information, names.len()));
        (0..names.len())
            .map(|j| covariance[(j, j)].max(0.0).sqrt())
            .collect::<Vec<f64>>()
    };
    // The model errors: the record of a flight (its states and record)
    // minus the record of the flight an estimator's model flies, weighted
    // as the sensitivities.
    let errors = |flight: &Simulation,
                  states: &[StateVector],
                  nominal: &FlightRecord,
                  what: &str|
     -> Result<DVector<f64>> {
        let trace = flight
            .run_with_restarts(|k| (k % segment_steps == 0).then(|| states[k]))
            .map_err(|error| Error::Identifiability {
                scenario: scenario.name.clone(),
                reason: format!("the flight {what} failed: {error}"),
            })?;
        let modelled = clean.record(&trace, &scenario.aircraft, scenario.seed)?;
        // (nominal − modelled)/(2·1): `difference` divides by 2h.
        Ok(DVector::from_vec(difference(nominal, &modelled, 0.5)?))
    };
    // A flight's bounds, its least-squares solver and the first-order
    // error of the controls as the recorder writes them (at their rate,
    // slot, delay and lag, and quantized to their resolution), from the
    // flight's trace, its states and its record.
    let analyse_flight = |simulation: &Simulation,
                          trace: &aeroid_sim::trace::TruthTrace,
                          states: &[StateVector],
                          record: &FlightRecord| {
        let sensitivities = sensitivities_of(simulation, states)?;
        let solve = least_squares_solver(&sensitivities);
        let controls = profile
            .without_noise()
            .record(trace, &scenario.aircraft, scenario.seed)?;
        let input_error = solve(&errors(
            &with_recorded_inputs(simulation, &controls)?,
            states,
            record,
            "with the inputs as recorded",
        )?);
        Ok::<_, Error>((bounds(&sensitivities), input_error, solve))
    };
    let (sigmas, input_error, solve) =
        analyse_flight(&simulation, &nominal_trace, &nominal_states, &nominal)?;
    let calm = without_gusts(scenario, &simulation)?;
    let wind_error = solve(&errors(
        &calm,
        &nominal_states,
        &nominal,
        "without gusts and turbulence",
    )?);
    // The same flight without its gusts and turbulence: what the controls
    // alone give.
    let gusty = !scenario.wind.gusts.is_empty() || scenario.wind.turbulence.is_some();
    let calm = match gusty {
        true => {
            let trace = calm.run()?;
            let states: Vec<StateVector> = trace.samples.iter().map(|s| s.state).collect();
            let record = clean.record(&trace, &scenario.aircraft, scenario.seed)?;
            let (sigmas, input_error, _) = analyse_flight(&calm, &trace, &states, &record)?;
            Some((sigmas, input_error))
        }
        false => None,
    };
    let modes = governing_modes(scenario, &simulation, &names, &truths)?;
    let rate = uses.iter().try_fold(0.0f64, |rate, channel| {
        Ok::<_, Error>(rate.max(nominal.channel(&channel.name)?.rate))
    })?;
    let rows = names
        .iter()
        .zip(&truths)
        .zip(modes)
        .enumerate()
        .map(|(j, ((name, &truth), mode))| {
            let sigma = sigmas[j];
            IdentifiabilityRow {
                parameter: name.clone(),
                truth,
                sigma,
                calm: calm.as_ref().map(|(sigmas, errors)| (sigmas[j], errors[j])),
                input_error: input_error[j],
                wind_error: wind_error[j],
                identifiable: sigma < options.threshold * truth.abs()
                    && input_error[j].abs() < 2.0 * options.threshold * truth.abs(),
                mode,
            }
        })
        .collect();
    Ok(Identifiability {
        scenario: scenario.name.clone(),
        profile: profile.name.clone(),
        threshold: options.threshold,
        segment,
        channels: uses,
        rate,
        parameters_left_out,
        excluded,
        notes: gusty
            .then(|| geometric_flow_angles_note(profile))
            .flatten()
            .into_iter()
            .collect(),
        rows,
    })
}

/// The note for a gusty flight on a record without a usable angle of
/// attack or sideslip channel (module documentation, "The geometric flow
/// angles").
fn geometric_flow_angles_note(profile: &Profile) -> Option<String> {
    let has = |name: &str| profile.channels.iter().any(|c| c.measurand.name == name);
    let vane = |name: &str| {
        profile
            .channels
            .iter()
            .any(|c| c.measurand.name == name && c.fault.is_none())
    };
    // The channels Eqs. 1–6 need without the wind correction.
    let geometric = aeroid_record::prep::flow_angles::INPUT_CHANNELS[..6]
        .iter()
        .all(|name| has(name));
    let lacking: Vec<&str> = [("alpha", "angle of attack"), ("beta", "sideslip")]
        .into_iter()
        .filter(|(name, _)| !vane(name))
        .map(|(_, words)| words)
        .collect();
    (geometric && !lacking.is_empty()).then(|| {
        format!(
            "'{}' records no usable {}: an estimator takes the geometric angles (aeroid derive), which miss the gusts the wind channels miss; these bounds know the gusts, and in turbulence that error alone can make a regression's static and roll derivatives a third or more too small (docs/findings.md, \"The geometric flow angles in turbulence\")",
            profile.name,
            lacking.join(" or ")
        )
    })
}

/// The mode each parameter moves furthest at the scenario's trim (module
/// documentation, "The sampling rule"), or None.
fn governing_modes(
    scenario: &Scenario,
    simulation: &Simulation,
    names: &[String],
    truths: &[f64],
) -> Result<Vec<Option<GoverningMode>>> {
    const KINDS: [ModeKind; 5] = [
        ModeKind::ShortPeriod,
        ModeKind::Phugoid,
        ModeKind::DutchRoll,
        ModeKind::Roll,
        ModeKind::Spiral,
    ];
    let wind = simulation.winds.first().copied().unwrap_or_default();
    // The steady wind the simulation trims in (`Simulation::prepare`).
    let steady = WindSample {
        ned: wind.ned,
        body: Default::default(),
    };
    let nominal = linearize(&simulation.model, &simulation.trim, &wind).modes();
    names
        .iter()
        .zip(truths)
        .map(|(name, &truth)| {
            let scale = truth.abs().max(1e-2);
            let h = 1e-3 * scale;
            // The aircraft with the parameter moved, trimmed again.
            let moved = |value: f64| {
                let mut model = simulation.model.clone();
                model.aircraft.aero.parameters.set(name, value)?;
                let trim = aeroid_sim::trim::trim(&model, &scenario.trim, &steady)?;
                Ok::<_, Error>(linearize(&model, &trim, &wind).modes())
            };
            let (plus, minus) = (moved(truth + h)?, moved(truth - h)?);
            Ok(KINDS
                .iter()
                .filter_map(|&kind| {
                    let size = find(&nominal, kind)?.eigenvalue.norm();
                    let change = find(&plus, kind)?.eigenvalue - find(&minus, kind)?.eigenvalue;
                    (size > 0.0).then(|| GoverningMode {
                        kind,
                        frequency: size / std::f64::consts::TAU,
                        elasticity: change.norm() / size * scale / (2.0 * h),
                    })
                })
                .max_by(|a, b| {
                    (a.elasticity * a.frequency).total_cmp(&(b.elasticity * b.frequency))
                })
                .filter(|m| m.elasticity >= GOVERNING_ELASTICITY))
        })
        .collect()
}

/// δ = S⁺·r for a weighted output error r: the first-order move of every
/// unknown (parameters, then the segments' initial states) of a
/// least-squares fit, by the SVD of S with unit-norm columns; directions
/// the data cannot separate (σ = ∞) drop out.
fn least_squares_solver(
    sensitivities: &DMatrix<f64>,
) -> impl Fn(&DVector<f64>) -> DVector<f64> + use<> {
    let norms: Vec<f64> = sensitivities
        .column_iter()
        .map(|c| {
            let n = c.norm();
            if n > 0.0 { 1.0 / n } else { 0.0 }
        })
        .collect();
    let scaled = DMatrix::from_fn(sensitivities.nrows(), sensitivities.ncols(), |i, j| {
        sensitivities[(i, j)] * norms[j]
    });
    let svd = scaled.svd(true, true);
    let tolerance = 1e-12 * svd.singular_values.max();
    move |residual: &DVector<f64>| {
        let solution = svd
            .solve(residual, tolerance)
            .unwrap_or_else(|_| DVector::zeros(norms.len()));
        DVector::from_iterator(norms.len(), solution.iter().zip(&norms).map(|(x, n)| x * n))
    }
}

/// The flight with the controls an estimator knows: each control channel
/// of the (noise-free) record, split surfaces combined, reconstructed at
/// every simulation step by the scenario's interpolation; a control the
/// record lacks stays as flown.
fn with_recorded_inputs(simulation: &Simulation, record: &FlightRecord) -> Result<Simulation> {
    let (record, _) = aeroid_record::prep::surfaces::with_combined_surfaces(record)?;
    let times: Vec<f64> = (0..simulation.exogenous.len())
        .map(|k| k as f64 * simulation.step)
        .collect();
    let mut flight = simulation.clone();
    for control in Control::ALL {
        let Ok(channel) = record.channel(control.name()) else {
            continue;
        };
        let values = channel.sampled_at(&times, simulation.interpolation)?;
        for (exogenous, value) in flight.exogenous.iter_mut().zip(values) {
            if value.is_finite() {
                exogenous[control.index()] = value;
            }
        }
    }
    Ok(flight)
}

/// The flight in the scenario's steady wind, without gusts or turbulence,
/// the controls as flown.
fn without_gusts(scenario: &Scenario, simulation: &Simulation) -> Result<Simulation> {
    let mut calm = scenario.clone();
    calm.wind.gusts.clear();
    calm.wind.turbulence = None;
    let calm = Simulation::prepare(&calm)?;
    let mut flight = simulation.clone();
    for (exogenous, steady) in flight.exogenous.iter_mut().zip(&calm.exogenous) {
        for i in CONTROL_COUNT..exogenous.len() {
            exogenous[i] = steady[i];
        }
    }
    flight.winds = calm.winds;
    Ok(flight)
}

/// The information about the first `count` unknowns with the others
/// (nuisance initial states) marginalised: the Schur complement
/// M_θθ − M_θn·M_nn⁺·M_nθ. Nuisance directions that the data cannot
/// separate (two initial-state components with the same effect) drop out of
/// the pseudo-inverse instead of making parameters look unidentifiable.
fn marginal_information(information: &DMatrix<f64>, count: usize) -> DMatrix<f64> {
    let total = information.nrows();
    if total == count {
        return information.clone();
    }
    let nuisance = information
        .view((count, count), (total - count, total - count))
        .into_owned();
    let scale = unit_diagonal_scale(&nuisance);
    let scaled = DMatrix::from_fn(total - count, total - count, |i, j| {
        nuisance[(i, j)] * scale[i] * scale[j]
    });
    let svd = scaled.svd(true, true);
    let tolerance = 1e-12 * svd.singular_values.max();
    let inverse = svd
        .pseudo_inverse(tolerance)
        .unwrap_or_else(|_| DMatrix::zeros(total - count, total - count));
    let inverse = DMatrix::from_fn(total - count, total - count, |i, j| {
        inverse[(i, j)] * scale[i] * scale[j]
    });
    let cross = information.view((0, count), (count, total - count));
    information.view((0, 0), (count, count)) - cross * inverse * cross.transpose()
}

/// The profile's channels that carry information, with √R_c, and those left out with why.
type ChannelSelection = (Vec<(String, f64)>, Vec<(String, String)>);

fn usable_channels(profile: &Profile, wanted: Option<&[String]>) -> Result<ChannelSelection> {
    if let Some(wanted) = wanted {
        for name in wanted {
            if !profile
                .channels
                .iter()
                .any(|c| c.measurand.name == name.as_str())
            {
                return Err(aeroid_core::Error::Unknown {
                    kind: "channel",
                    name: name.clone(),
                    known: profile
                        .channels
                        .iter()
                        .map(|c| c.measurand.name.to_string())
                        .collect(),
                }
                .into());
            }
        }
    }
    let mut used = Vec::new();
    let mut excluded = Vec::new();
    for channel in &profile.channels {
        let name = channel.measurand.name.to_string();
        if wanted.is_some_and(|w| !w.contains(&name)) {
            continue;
        }
        if wanted.is_none()
            && let Some(reason) = not_aerodynamic(&name)
        {
            excluded.push((name, reason.into()));
            continue;
        }
        let quantization = channel.resolution.map_or(0.0, |lsb| lsb * lsb / 12.0);
        let variance = channel.noise * channel.noise + quantization;
        if channel.fault.is_some() {
            excluded.push((name, "faulty in this profile".into()));
        } else if variance <= 0.0 {
            excluded.push((
                name,
                "no noise or quantization in this profile (its information would be infinite)"
                    .into(),
            ));
        } else {
            used.push((name, variance.sqrt()));
        }
    }
    if used.is_empty() {
        return Err(Error::NoChannels {
            profile: profile.name.clone(),
        });
    }
    Ok((used, excluded))
}

/// Why a channel is not, by default, a response an aerodynamic model predicts.
fn not_aerodynamic(name: &str) -> Option<&'static str> {
    let starts = |prefixes: &[&str]| prefixes.iter().any(|p| name.starts_with(p));
    if starts(&["elevator", "aileron", "rudder", "flap", "throttle"]) {
        Some("an input of the experiment, not a response")
    } else if starts(&["gross_weight", "n1_", "n2_", "fuel_flow", "exhaust_gas"]) {
        Some("engine or weight: not a response of the aerodynamics")
    } else if starts(&[
        "north",
        "east",
        "latitude",
        "longitude",
        "ground_speed",
        "track",
        "flight_path_angle",
    ]) {
        Some(
            "inertial navigation: it integrates the wind, which an aerodynamic model does not know",
        )
    } else if starts(&["wind_"]) {
        Some("the recorder's wind estimate, not a response")
    } else {
        None
    }
}
