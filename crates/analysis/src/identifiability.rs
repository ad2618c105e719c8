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
use aeroid_record::FlightRecord;
use aeroid_record::recorder::Profile;
use aeroid_sim::Simulation;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::state::StateVector;
use aeroid_sim::wind::WindSample;
use nalgebra::DVector;

mod flights;

use flights::{Flights, NUISANCE, without_gusts};

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
pub(crate) const RULE_FACTOR: f64 = 25.0;

/// The least elasticity for a mode to count as a parameter's.
pub(crate) const GOVERNING_ELASTICITY: f64 = 0.1;

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
    /// `GOVERNING_ELASTICITY` or more; None otherwise (control
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
            text += &self.table_line(row);
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

    /// The table's line of one parameter.
    fn table_line(&self, row: &IdentifiabilityRow) -> String {
        format!(
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
        )
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

/// Analyses which of the scenario aircraft's parameters the profile's
/// channels can identify (see the module documentation).
pub fn analyse(
    scenario: &Scenario,
    profile: &Profile,
    options: &IdentifiabilityOptions,
) -> Result<Identifiability> {
    check_scenario(scenario, options)?;
    let simulation = Simulation::prepare(scenario)?;
    let Chosen {
        names,
        truths,
        left_out: parameters_left_out,
    } = chosen_parameters(scenario, options)?;
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
    // The nominal record: the flight already flown (a restart at its own state changes nothing).
    let nominal = clean.record(&nominal_trace, &scenario.aircraft, scenario.seed)?;
    let (uses, segment_of_row) = channel_uses(&nominal, &channels, segment, segments)?;
    let flights = Flights {
        scenario,
        profile,
        options,
        clean,
        names: &names,
        truths: &truths,
        uses: &uses,
        segment_of_row: &segment_of_row,
        segment_steps,
        columns: names.len() + NUISANCE * segments,
    };
    let (sigmas, input_error, solver) =
        flights.analyse_flight(&simulation, &nominal_trace, &nominal_states, &nominal)?;
    let calm = without_gusts(scenario, &simulation)?;
    let wind_error = solver.solve(&flights.errors(
        &calm,
        &nominal_states,
        &nominal,
        "without gusts and turbulence",
    )?);
    // The same flight without its gusts and turbulence: what the controls
    // alone give.
    let gusty = !scenario.wind.gusts.is_empty() || scenario.wind.turbulence.is_some();
    let calm = gusty.then(|| flights.analyse_calm(&calm)).transpose()?;
    let modes = governing_modes(scenario, &simulation, &names, &truths)?;
    let rate = uses.iter().try_fold(0.0f64, |rate, channel| {
        Ok::<_, Error>(rate.max(nominal.channel(&channel.name)?.rate))
    })?;
    let rows = rows(
        (&names, &truths, modes),
        (&sigmas, &input_error, &wind_error),
        calm.as_ref(),
        options.threshold,
    );
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

/// The rows of the parameters (`names`, their truths and modes): each
/// one's bound, recorded inputs' and wind's errors, the calm flight's
/// bound and inputs' error, and the verdict at `threshold`.
fn rows(
    (names, truths, modes): (&[String], &[f64], Vec<Option<GoverningMode>>),
    (sigmas, input_error, wind_error): (&[f64], &DVector<f64>, &DVector<f64>),
    calm: Option<&(Vec<f64>, DVector<f64>)>,
    threshold: f64,
) -> Vec<IdentifiabilityRow> {
    names
        .iter()
        .zip(truths)
        .zip(modes)
        .enumerate()
        .map(|(j, ((name, &truth), mode))| {
            let sigma = sigmas[j];
            IdentifiabilityRow {
                parameter: name.clone(),
                truth,
                sigma,
                calm: calm.map(|(sigmas, errors)| (sigmas[j], errors[j])),
                input_error: input_error[j],
                wind_error: wind_error[j],
                identifiable: sigma < threshold * truth.abs()
                    && input_error[j].abs() < 2.0 * threshold * truth.abs(),
                mode,
            }
        })
        .collect()
}

/// An error when the segment is shorter than a step or not finite, or
/// the scenario changes parameters in flight.
fn check_scenario(scenario: &Scenario, options: &IdentifiabilityOptions) -> Result<()> {
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
    Ok(())
}

/// The parameters analysed with their truths, and those left out with
/// the reason.
struct Chosen {
    names: Vec<String>,
    truths: Vec<f64>,
    left_out: Vec<(String, String)>,
}

/// The parameters analysed and their truths: the options' (an error for
/// one the central differences cannot move), else every one the
/// differences can move, those left out with the reason.
fn chosen_parameters(scenario: &Scenario, options: &IdentifiabilityOptions) -> Result<Chosen> {
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
    Ok(Chosen {
        names,
        truths,
        left_out: parameters_left_out,
    })
}

/// The channels used, with √R_c and their samples in the nominal record,
/// and the segment of each of their samples in order (the rows of the
/// sensitivities).
fn channel_uses(
    nominal: &FlightRecord,
    channels: &[(String, f64)],
    segment: f64,
    segments: usize,
) -> Result<(Vec<ChannelUse>, Vec<usize>)> {
    let mut uses = Vec::new();
    let mut segment_of_row = Vec::new();
    for (name, sigma) in channels {
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
    Ok((uses, segment_of_row))
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
