//! Wind model of a scenario: steady wind, discrete gusts and Dryden
//! turbulence, produced as one [`WindSample`] per integration step (the
//! simulator interpolates between samples within a step).
//!
//! The file syntax (`[wind]`, `[[wind.gusts]]`, `[wind.turbulence]`) is in
//! docs/files.md. Steady wind: `speed` and `from_direction` (where it blows
//! FROM, clockwise from north) give the air mass's NED velocity
//! `−speed·(cos ψ, sin ψ, 0)`.
//!
//! # Discrete gusts
//! The 1−cosine gust of MIL-F-8785C §3.7.3, written in time:
//! `u(t) = A/2·(1 − cos(2π(t − start)/duration))` for
//! `start ≤ t ≤ start + duration`, zero outside. `direction` names where the
//! gust air moves TOWARDS ("up" is an updraft: a negative NED-down component).
//! Gusts add to the steady wind in [`WindSample::ned`].
//!
//! # Dryden turbulence
//! The Dryden forms of MIL-F-8785C §3.7.2.2 (one-sided spatial spectra in
//! Ω, rad/m, with `∫₀^∞ Φ(Ω) dΩ = σ²`):
//!
//! ```text
//! Φu(Ω) = σu²·(2Lu/π) / (1 + (Lu·Ω)²)
//! Φv(Ω) = σv²·(Lv/π)·(1 + 3(Lv·Ω)²) / (1 + (Lv·Ω)²)²
//! Φw(Ω) = σw²·(Lw/π)·(1 + 3(Lw·Ω)²) / (1 + (Lw·Ω)²)²
//! ```
//!
//! Frozen turbulence (ω = Ω·V at the trim airspeed V) gives the forming
//! filters, driven by white noise of unit one-sided PSD:
//!
//! ```text
//! Hu(s) = σu·√(2Lu/(πV)) / (1 + Lu·s/V)
//! Hv(s) = σv·√(Lv/(πV))·(1 + √3·Lv·s/V) / (1 + Lv·s/V)²
//! Hw(s) = σw·√(Lw/(πV))·(1 + √3·Lw·s/V) / (1 + Lw·s/V)²
//! ```
//!
//! Their one-sided PSD in Hz is `S(f) = (2π/V)·Φ(2πf/V)`.
//!
//! **Scales and intensities.** Either explicit `sigma_u, sigma_v, sigma_w`
//! (and optional `length_u, length_v, length_w`), or an `intensity`:
//! * below 1000 ft (h in ft, clamped to ≥ 10 ft): W20 = 15, 30, 45 kt for
//!   light, moderate, severe; σw = 0.1·W20,
//!   σu = σv = σw/(0.177 + 0.000823h)^0.4; Lw = h,
//!   Lu = Lv = h/(0.177 + 0.000823h)^1.2;
//! * above 2000 ft: Lu = Lv = Lw = 1750 ft and σu = σv = σw from MIL-F-8785C
//!   Figure 10 at the probability of exceedance 10⁻² (light), 10⁻³ (moderate),
//!   10⁻⁵ (severe), interpolated linearly in altitude in the tabulation of
//!   Gage (AIAA 2003-5529);
//! * in between: linear in altitude between the 1000 ft and the 2000 ft values.
//!
//! Explicit lengths default by the same altitude rules.
//!
//! **Exact discretisation.** Each filter is written in normalised state space
//! whose stationary covariance is the identity, and discretised exactly for
//! the step dt with θ = V·dt/L:
//! * u: `z[k+1] = e^{−θ}·z[k] + √(1 − e^{−2θ})·n[k]`, `u_g = σu·z`;
//! * v, w: `z' = (V/L)·[[0, 1], [−1, −2]]·z + 2√(V/L)·[0, 1]ᵀ·n(t)`,
//!   `y = σ/2·(z₁ + √3·z₂)`, so `Φ = e^{−θ}·[[1+θ, θ], [−θ, 1−θ]]` and
//!   `Qd = ∫₀^dt e^{Aτ}BBᵀe^{Aᵀτ} dτ` in closed form (see
//!   `transverse_process_noise`); the draw is `Φ·z + chol(Qd)·n`. Here z is
//!   the controllable-canonical state of Hv scaled to unit stationary
//!   covariance and n(t) has unit intensity (E[n(t)n(t+τ)] = δ(τ)), which is
//!   the MIL convention's unit one-sided PSD up to the factor √π absorbed in y.
//!
//! Each filter starts from its stationary distribution (a standard normal
//! state), so there is no start-up transient. The sampled sequence has exactly
//! the variance and autocorrelation of the continuous process at the sample
//! times. White noise comes from [`random::stream`]`(seed, TURBULENCE)` in a
//! fixed order: the initial states, then per step u (one draw), v (two), w
//! (two); results are bit-identical for a seed and a sequence of `count`
//! samples is a prefix of any longer one.

use aeroid_core::error::Problems;
use aeroid_core::random;
use aeroid_core::units::{Dimension, FOOT, KNOT, Quantity};
use nalgebra::{Matrix2, RowVector2, Vector2, Vector3};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// The `[wind]` table of a scenario file (every field optional, default calm).
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindSpec {
    /// Steady wind speed (Speed).
    pub speed: Quantity,
    /// Direction the steady wind blows FROM, clockwise from north (Angle).
    pub from_direction: Quantity,
    /// Discrete 1−cosine gusts, `[[wind.gusts]]`.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub gusts: Vec<GustSpec>,
    /// Dryden turbulence, `[wind.turbulence]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub turbulence: Option<TurbulenceSpec>,
}

/// One `[[wind.gusts]]` entry: a 1−cosine gust.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GustSpec {
    /// Time the gust begins (Time, default 0).
    #[serde(default)]
    pub start: Quantity,
    /// Length of the gust in time (Time, > 0).
    pub duration: Quantity,
    /// Peak gust speed (Speed, ≥ 0).
    pub amplitude: Quantity,
    /// Where the gust air moves towards: up, down, north, east, south or west.
    pub direction: String,
}

/// The `[wind.turbulence]` table: an `intensity` or explicit `sigma_*`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct TurbulenceSpec {
    /// "light", "moderate" or "severe"; excludes the `sigma_*` fields.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub intensity: Option<String>,
    /// RMS longitudinal turbulence (Speed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_u: Option<Quantity>,
    /// RMS lateral turbulence (Speed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_v: Option<Quantity>,
    /// RMS vertical turbulence (Speed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_w: Option<Quantity>,
    /// Longitudinal scale length (Length; default by the altitude rules).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_u: Option<Quantity>,
    /// Lateral scale length (Length; default by the altitude rules).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_v: Option<Quantity>,
    /// Vertical scale length (Length; default by the altitude rules).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub length_w: Option<Quantity>,
}

/// Wind at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WindSample {
    /// Steady wind plus gusts: velocity of the air mass in NED, m/s.
    pub ned: Vector3<f64>,
    /// Turbulence u_g, v_g, w_g in body axes, m/s.
    pub body: Vector3<f64>,
}

/// Conditions the turbulence forms depend on (frozen turbulence).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightConditions {
    /// Trim true airspeed V, m/s.
    pub airspeed: f64,
    /// Altitude of the flight, m (the scale and intensity rules use it in ft).
    pub altitude: f64,
}

/// RMS intensities (m/s) and scale lengths (m) of the components u, v, w.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurbulenceParameters {
    pub sigma: [f64; 3],
    pub length: [f64; 3],
}

impl WindSpec {
    /// Collects every problem into `problems` with field paths prefixed "wind.".
    pub fn validate(&self, problems: &mut Problems) {
        let speed = quantity_value(problems, "wind.speed", &self.speed, Dimension::Speed);
        if speed.is_some_and(|speed| speed < 0.0) {
            problems.push(
                "wind.speed",
                "must not be negative (turn from_direction instead)",
            );
        }
        quantity_value(
            problems,
            "wind.from_direction",
            &self.from_direction,
            Dimension::Angle,
        );
        for (index, gust) in self.gusts.iter().enumerate() {
            gust.validate(&format!("wind.gusts[{index}]"), problems);
        }
        if let Some(turbulence) = &self.turbulence {
            turbulence.validate("wind.turbulence", problems);
        }
    }

    /// One sample per step at t_k = k·step, k = 0..count; bit-identical for a seed.
    /// Fails when `validate` finds a problem or the conditions or step are unusable.
    pub fn generate(
        &self,
        conditions: &FlightConditions,
        step: f64,
        count: usize,
        seed: u64,
    ) -> Result<Vec<WindSample>, String> {
        let mut problems = Problems::default();
        self.validate(&mut problems);
        if !problems.is_empty() {
            let list: Vec<String> = problems.0.iter().map(ToString::to_string).collect();
            return Err(list.join("; "));
        }
        if !(step.is_finite() && step > 0.0) {
            return Err(format!("wind: step {step} s is not a positive number"));
        }
        let steady = self.steady_velocity()?;
        let gusts = self
            .gusts
            .iter()
            .map(Gust::resolve)
            .collect::<Result<Vec<_>, _>>()?;
        let mut rng = random::stream(seed, random::streams::TURBULENCE);
        let mut turbulence = match &self.turbulence {
            Some(spec) => Some(Turbulence::start(spec, conditions, step, &mut rng)?),
            None => None,
        };
        let mut samples = Vec::with_capacity(count);
        for index in 0..count {
            let time = index as f64 * step;
            let gust_sum: Vector3<f64> = gusts.iter().map(|gust| gust.velocity(time)).sum();
            let body = turbulence
                .as_ref()
                .map_or_else(Vector3::zeros, Turbulence::velocity);
            samples.push(WindSample {
                ned: steady + gust_sum,
                body,
            });
            if let Some(turbulence) = turbulence.as_mut() {
                turbulence.advance(&mut rng);
            }
        }
        Ok(samples)
    }

    /// NED velocity of the steady air mass.
    fn steady_velocity(&self) -> Result<Vector3<f64>, String> {
        let speed = self.speed.si(Dimension::Speed)?;
        let from = self.from_direction.si(Dimension::Angle)?;
        Ok(Vector3::new(-speed * from.cos(), -speed * from.sin(), 0.0))
    }
}

/// The SI value of `quantity`, or `None` after recording why it has none.
fn quantity_value(
    problems: &mut Problems,
    field: &str,
    quantity: &Quantity,
    dimension: Dimension,
) -> Option<f64> {
    quantity
        .si(dimension)
        .map_err(|message| problems.push(field, message))
        .ok()
}

/// Checks `quantity` and that its value satisfies `condition`, else records `requirement`.
fn require(
    problems: &mut Problems,
    field: &str,
    quantity: &Quantity,
    dimension: Dimension,
    condition: fn(f64) -> bool,
    requirement: &str,
) {
    let value = quantity_value(problems, field, quantity, dimension);
    if value.is_some_and(|value| !condition(value)) {
        problems.push(field, format!("{quantity} {requirement}"));
    }
}

/// A field check for [`require`]: name, quantity, dimension, condition, requirement.
type FieldCheck<'a> = (&'a str, &'a Quantity, Dimension, fn(f64) -> bool, &'a str);

fn is_positive(value: f64) -> bool {
    value > 0.0
}

fn is_not_negative(value: f64) -> bool {
    value >= 0.0
}

/// Names of the gust directions, for messages.
const GUST_DIRECTIONS: &str = "up, down, north, east, south, west";

/// Unit NED vector of a gust direction (where the gust air moves towards).
fn gust_direction(name: &str) -> Option<Vector3<f64>> {
    let vector = match name.trim().to_ascii_lowercase().as_str() {
        "up" => Vector3::new(0.0, 0.0, -1.0),
        "down" => Vector3::new(0.0, 0.0, 1.0),
        "north" => Vector3::new(1.0, 0.0, 0.0),
        "south" => Vector3::new(-1.0, 0.0, 0.0),
        "east" => Vector3::new(0.0, 1.0, 0.0),
        "west" => Vector3::new(0.0, -1.0, 0.0),
        _ => return None,
    };
    Some(vector)
}

impl GustSpec {
    /// Records the problems of this gust under `path` (e.g. "wind.gusts[1]").
    fn validate(&self, path: &str, problems: &mut Problems) {
        let field = |name: &str| format!("{path}.{name}");
        let checks: [FieldCheck; 3] = [
            (
                "start",
                &self.start,
                Dimension::Time,
                is_not_negative,
                "must not be negative",
            ),
            (
                "duration",
                &self.duration,
                Dimension::Time,
                is_positive,
                "must be positive",
            ),
            (
                "amplitude",
                &self.amplitude,
                Dimension::Speed,
                is_not_negative,
                "must not be negative (choose the opposite direction instead)",
            ),
        ];
        for (name, quantity, dimension, condition, rule) in checks {
            require(problems, &field(name), quantity, dimension, condition, rule);
        }
        if gust_direction(&self.direction).is_none() {
            let message = format!(
                "unknown direction '{}'; known: {GUST_DIRECTIONS}",
                self.direction
            );
            problems.push(field("direction"), message);
        }
    }
}

/// A gust in SI units.
struct Gust {
    start: f64,
    duration: f64,
    amplitude: f64,
    direction: Vector3<f64>,
}

impl Gust {
    fn resolve(spec: &GustSpec) -> Result<Gust, String> {
        Ok(Gust {
            start: spec.start.si(Dimension::Time)?,
            duration: spec.duration.si(Dimension::Time)?,
            amplitude: spec.amplitude.si(Dimension::Speed)?,
            direction: gust_direction(&spec.direction)
                .ok_or_else(|| format!("unknown gust direction '{}'", spec.direction))?,
        })
    }

    /// NED velocity of the gust at `time`: A/2·(1 − cos(2π(t − start)/duration)) inside the window.
    fn velocity(&self, time: f64) -> Vector3<f64> {
        let elapsed = time - self.start;
        if !(0.0..=self.duration).contains(&elapsed) {
            return Vector3::zeros();
        }
        let phase = std::f64::consts::TAU * elapsed / self.duration;
        self.direction * (0.5 * self.amplitude * (1.0 - phase.cos()))
    }
}

/// The turbulence intensities of MIL-F-8785C.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Intensity {
    Light,
    Moderate,
    Severe,
}

/// Altitudes (ft) of the tabulated MIL-F-8785C Figure 10 (Gage, AIAA 2003-5529).
const EXCEEDANCE_ALTITUDES: [f64; 12] = [
    500.0, 1750.0, 3750.0, 7500.0, 15000.0, 25000.0, 35000.0, 45000.0, 55000.0, 65000.0, 75000.0,
    80000.0,
];
/// RMS intensity (ft/s) at probability of exceedance 10⁻² (light).
const LIGHT_SIGMAS: [f64; 12] = [6.6, 6.9, 7.4, 6.7, 4.6, 2.7, 0.4, 0.0, 0.0, 0.0, 0.0, 0.0];
/// RMS intensity (ft/s) at probability of exceedance 10⁻³ (moderate).
const MODERATE_SIGMAS: [f64; 12] = [8.6, 9.6, 10.6, 10.1, 8.0, 6.6, 5.0, 4.2, 2.7, 0.0, 0.0, 0.0];
/// RMS intensity (ft/s) at probability of exceedance 10⁻⁵ (severe).
const SEVERE_SIGMAS: [f64; 12] = [
    15.6, 17.6, 23.0, 23.6, 22.1, 20.0, 16.0, 15.1, 12.1, 7.9, 6.2, 5.1,
];

/// Top of the low-altitude model and bottom of the medium/high-altitude model, ft.
const LOW_ALTITUDE_TOP: f64 = 1000.0;
const MEDIUM_ALTITUDE_BOTTOM: f64 = 2000.0;
/// Scale length of the medium/high-altitude model, ft.
const MEDIUM_ALTITUDE_LENGTH: f64 = 1750.0;
/// Lowest altitude the low-altitude model is evaluated at, ft.
const MINIMUM_ALTITUDE: f64 = 10.0;

impl Intensity {
    fn parse(name: &str) -> Option<Intensity> {
        match name.trim().to_ascii_lowercase().as_str() {
            "light" => Some(Intensity::Light),
            "moderate" => Some(Intensity::Moderate),
            "severe" => Some(Intensity::Severe),
            _ => None,
        }
    }

    /// Wind speed at 20 ft, m/s.
    fn wind_at_20_ft(self) -> f64 {
        let knots = match self {
            Intensity::Light => 15.0,
            Intensity::Moderate => 30.0,
            Intensity::Severe => 45.0,
        };
        knots * KNOT
    }

    /// σu, σv, σw (m/s) of the low-altitude model at `altitude` ft.
    fn low_altitude_sigmas(self, altitude: f64) -> [f64; 3] {
        let sigma_w = 0.1 * self.wind_at_20_ft();
        let sigma_u = sigma_w / low_altitude_factor(altitude).powf(0.4);
        [sigma_u, sigma_u, sigma_w]
    }

    /// σ (m/s, equal for u, v, w) of the medium/high-altitude model at `altitude` ft.
    fn medium_altitude_sigma(self, altitude: f64) -> f64 {
        let table = match self {
            Intensity::Light => &LIGHT_SIGMAS,
            Intensity::Moderate => &MODERATE_SIGMAS,
            Intensity::Severe => &SEVERE_SIGMAS,
        };
        interpolate(&EXCEEDANCE_ALTITUDES, table, altitude) * FOOT
    }

    /// σu, σv, σw (m/s) at `altitude` ft, blending the models between 1000 and 2000 ft.
    fn sigmas(self, altitude: f64) -> [f64; 3] {
        let low = self.low_altitude_sigmas(altitude.clamp(MINIMUM_ALTITUDE, LOW_ALTITUDE_TOP));
        let medium = [self.medium_altitude_sigma(altitude.max(MEDIUM_ALTITUDE_BOTTOM)); 3];
        blend(low, medium, altitude)
    }
}

/// 0.177 + 0.000823·h of the low-altitude model, h in ft.
fn low_altitude_factor(altitude: f64) -> f64 {
    0.177 + 0.000823 * altitude
}

/// Lu, Lv, Lw (ft) of the low-altitude model at `altitude` ft.
fn low_altitude_lengths(altitude: f64) -> [f64; 3] {
    let length_u = altitude / low_altitude_factor(altitude).powf(1.2);
    [length_u, length_u, altitude]
}

/// Lu, Lv, Lw (ft) at `altitude` ft, blending the models between 1000 and 2000 ft.
fn scale_lengths(altitude: f64) -> [f64; 3] {
    let low = low_altitude_lengths(altitude.clamp(MINIMUM_ALTITUDE, LOW_ALTITUDE_TOP));
    blend(low, [MEDIUM_ALTITUDE_LENGTH; 3], altitude)
}

/// `low` below 1000 ft, `medium` above 2000 ft, linear in altitude (ft) in between.
fn blend(low: [f64; 3], medium: [f64; 3], altitude: f64) -> [f64; 3] {
    let span = MEDIUM_ALTITUDE_BOTTOM - LOW_ALTITUDE_TOP;
    let fraction = ((altitude - LOW_ALTITUDE_TOP) / span).clamp(0.0, 1.0);
    std::array::from_fn(|axis| low[axis] + fraction * (medium[axis] - low[axis]))
}

/// Piecewise-linear interpolation of (xs, ys) at x, held constant outside.
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let upper = xs.partition_point(|&knot| knot < x);
    if upper == 0 {
        return ys[0];
    }
    if upper == xs.len() {
        return ys[xs.len() - 1];
    }
    let fraction = (x - xs[upper - 1]) / (xs[upper] - xs[upper - 1]);
    ys[upper - 1] + fraction * (ys[upper] - ys[upper - 1])
}

impl TurbulenceSpec {
    fn sigmas(&self) -> [(&'static str, Option<&Quantity>); 3] {
        [
            ("sigma_u", self.sigma_u.as_ref()),
            ("sigma_v", self.sigma_v.as_ref()),
            ("sigma_w", self.sigma_w.as_ref()),
        ]
    }

    fn lengths(&self) -> [(&'static str, Option<&Quantity>); 3] {
        [
            ("length_u", self.length_u.as_ref()),
            ("length_v", self.length_v.as_ref()),
            ("length_w", self.length_w.as_ref()),
        ]
    }

    /// Records the problems of this table under `path` ("wind.turbulence").
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        let field = |name: &str| format!("{path}.{name}");
        let given_sigmas = self
            .sigmas()
            .iter()
            .filter(|(_, sigma)| sigma.is_some())
            .count();
        match &self.intensity {
            Some(name) if Intensity::parse(name).is_none() => problems.push(
                field("intensity"),
                format!("unknown intensity '{name}'; known: light, moderate, severe"),
            ),
            Some(_) if given_sigmas > 0 => problems.push(
                path,
                "give either intensity or sigma_u, sigma_v, sigma_w, not both",
            ),
            Some(_) => {}
            None => {
                for (name, sigma) in self.sigmas() {
                    if sigma.is_none() {
                        let message = "missing: give intensity or all of sigma_u, sigma_v, sigma_w";
                        problems.push(field(name), message);
                    }
                }
            }
        }
        for (name, sigma) in self.sigmas() {
            if let Some(sigma) = sigma {
                let rule = "must not be negative";
                require(
                    problems,
                    &field(name),
                    sigma,
                    Dimension::Speed,
                    is_not_negative,
                    rule,
                );
            }
        }
        for (name, length) in self.lengths() {
            if let Some(length) = length {
                require(
                    problems,
                    &field(name),
                    length,
                    Dimension::Length,
                    is_positive,
                    "must be positive",
                );
            }
        }
    }

    /// σ and L of the three components at `altitude` (m), by the intensity or
    /// altitude rules where not given explicitly. Expects a validated table.
    pub fn parameters(&self, altitude: f64) -> Result<TurbulenceParameters, String> {
        let altitude_ft = altitude / FOOT;
        let sigma = match &self.intensity {
            Some(name) => Intensity::parse(name)
                .ok_or_else(|| format!("unknown turbulence intensity '{name}'"))?
                .sigmas(altitude_ft),
            None => explicit_values(self.sigmas(), Dimension::Speed, [None; 3])?,
        };
        let default_lengths = scale_lengths(altitude_ft).map(|length| Some(length * FOOT));
        let length = explicit_values(self.lengths(), Dimension::Length, default_lengths)?;
        Ok(TurbulenceParameters { sigma, length })
    }
}

/// SI values of `fields`, each falling back to its default.
fn explicit_values(
    fields: [(&'static str, Option<&Quantity>); 3],
    dimension: Dimension,
    defaults: [Option<f64>; 3],
) -> Result<[f64; 3], String> {
    let mut values = [0.0; 3];
    for ((value, (name, quantity)), default) in values.iter_mut().zip(fields).zip(defaults) {
        *value = match (quantity, default) {
            (Some(quantity), _) => quantity.si(dimension)?,
            (None, Some(default)) => default,
            (None, None) => return Err(format!("wind.turbulence.{name} is missing")),
        };
    }
    Ok(values)
}

/// One Dryden forming filter discretised exactly, in normalised coordinates
/// whose stationary covariance is the identity.
#[derive(Debug, Clone)]
struct FormingFilter {
    /// Number of white-noise draws per step (the filter order, 1 or 2).
    order: usize,
    /// State transition Φ over one step.
    transition: Matrix2<f64>,
    /// Lower Cholesky factor of the process-noise covariance Qd over one step.
    noise_factor: Matrix2<f64>,
    /// Output row: turbulence velocity = output·state.
    output: RowVector2<f64>,
    state: Vector2<f64>,
}

impl FormingFilter {
    /// The first-order u filter with θ = V·dt/L.
    fn longitudinal(sigma: f64, theta: f64) -> FormingFilter {
        let correlation = (-theta).exp();
        let innovation = (-(-2.0 * theta).exp_m1()).sqrt();
        FormingFilter {
            order: 1,
            transition: Matrix2::new(correlation, 0.0, 0.0, 0.0),
            noise_factor: Matrix2::new(innovation, 0.0, 0.0, 0.0),
            output: RowVector2::new(sigma, 0.0),
            state: Vector2::zeros(),
        }
    }

    /// The second-order v or w filter with θ = V·dt/L.
    fn transverse(sigma: f64, theta: f64) -> FormingFilter {
        FormingFilter {
            order: 2,
            transition: transverse_transition(theta),
            noise_factor: cholesky_2x2(&transverse_process_noise(theta)),
            output: RowVector2::new(0.5 * sigma, 0.5 * 3f64.sqrt() * sigma),
            state: Vector2::zeros(),
        }
    }

    /// `order` standard normal draws, the rest zero.
    fn draw(&self, rng: &mut ChaCha8Rng) -> Vector2<f64> {
        let mut noise = Vector2::zeros();
        for entry in noise.iter_mut().take(self.order) {
            *entry = rng.sample(StandardNormal);
        }
        noise
    }

    /// Draws the state from the stationary distribution (the identity covariance).
    fn start(&mut self, rng: &mut ChaCha8Rng) {
        self.state = self.draw(rng);
    }

    fn advance(&mut self, rng: &mut ChaCha8Rng) {
        let noise = self.draw(rng);
        self.state = self.transition * self.state + self.noise_factor * noise;
    }

    fn value(&self) -> f64 {
        (self.output * self.state)[0]
    }
}

/// Φ = exp(A·dt) of the normalised v/w filter, A = (V/L)·[[0, 1], [−1, −2]], θ = V·dt/L.
fn transverse_transition(theta: f64) -> Matrix2<f64> {
    Matrix2::new(1.0 + theta, theta, -theta, 1.0 - theta) * (-theta).exp()
}

/// Qd = ∫₀^dt e^{Aτ}BBᵀe^{Aᵀτ} dτ of the normalised v/w filter (B = 2√(V/L)·[0, 1]ᵀ),
/// in closed form. With e^{Aτ}B = 2√λ·e^{−λτ}·[λτ, 1 − λτ]ᵀ (λ = V/L) and s = τ/dt:
/// Qd = 4θ·∫₀¹ e^{−2θs}·[[θ²s², θs(1−θs)], [θs(1−θs), (1−θs)²]] ds.
fn transverse_process_noise(theta: f64) -> Matrix2<f64> {
    let [g0, g1, g2] = exponential_moments(2.0 * theta);
    let q11 = 4.0 * theta.powi(3) * g2;
    let q12 = 4.0 * theta.powi(2) * (g1 - theta * g2);
    let q22 = 4.0 * theta * (g0 - 2.0 * theta * g1 + theta * theta * g2);
    Matrix2::new(q11, q12, q12, q22)
}

/// gₙ(x) = ∫₀¹ sⁿ·e^{−x·s} ds for n = 0, 1, 2, accurate for every x ≥ 0:
/// the power series below x = 1, the stable upward recurrence
/// gₙ = (n·gₙ₋₁ − e^{−x})/x above.
fn exponential_moments(x: f64) -> [f64; 3] {
    if x < 1.0 {
        let mut moments = [0.0; 3];
        let mut term = 1.0; // (−x)^k / k!
        for k in 0..24 {
            for (n, moment) in moments.iter_mut().enumerate() {
                *moment += term / (n + k + 1) as f64;
            }
            term *= -x / (k + 1) as f64;
        }
        moments
    } else {
        let decay = (-x).exp();
        let g0 = -(-x).exp_m1() / x;
        let g1 = (g0 - decay) / x;
        let g2 = (2.0 * g1 - decay) / x;
        [g0, g1, g2]
    }
}

/// Lower Cholesky factor of a symmetric positive semi-definite 2×2 matrix.
fn cholesky_2x2(matrix: &Matrix2<f64>) -> Matrix2<f64> {
    let l11 = matrix[(0, 0)].max(0.0).sqrt();
    let l21 = if l11 > 0.0 { matrix[(1, 0)] / l11 } else { 0.0 };
    let l22 = (matrix[(1, 1)] - l21 * l21).max(0.0).sqrt();
    Matrix2::new(l11, 0.0, l21, l22)
}

/// The three running forming filters.
struct Turbulence {
    filters: [FormingFilter; 3],
}

impl Turbulence {
    /// Builds the filters for the conditions and step and draws their initial states.
    fn start(
        spec: &TurbulenceSpec,
        conditions: &FlightConditions,
        step: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Turbulence, String> {
        let FlightConditions { airspeed, altitude } = *conditions;
        if !(airspeed.is_finite() && airspeed > 0.0) {
            return Err(format!(
                "wind.turbulence: airspeed {airspeed} m/s is not positive"
            ));
        }
        if !altitude.is_finite() {
            return Err(format!(
                "wind.turbulence: altitude {altitude} m is not finite"
            ));
        }
        let TurbulenceParameters { sigma, length } = spec.parameters(altitude)?;
        let theta = length.map(|length| airspeed * step / length);
        let mut turbulence = Turbulence {
            filters: [
                FormingFilter::longitudinal(sigma[0], theta[0]),
                FormingFilter::transverse(sigma[1], theta[1]),
                FormingFilter::transverse(sigma[2], theta[2]),
            ],
        };
        turbulence
            .filters
            .iter_mut()
            .for_each(|filter| filter.start(rng));
        Ok(turbulence)
    }

    /// u_g, v_g, w_g in body axes, m/s.
    fn velocity(&self) -> Vector3<f64> {
        Vector3::from_fn(|axis, _| self.filters[axis].value())
    }

    /// Moves every filter one step on, drawing noise in the order u, v, w.
    fn advance(&mut self, rng: &mut ChaCha8Rng) {
        self.filters
            .iter_mut()
            .for_each(|filter| filter.advance(rng));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Complex, Matrix4};
    use std::f64::consts::{PI, TAU};

    /// Parses a scenario fragment holding a `[wind]` table.
    fn parse(text: &str) -> WindSpec {
        #[derive(Deserialize)]
        struct Scenario {
            wind: WindSpec,
        }
        toml::from_str::<Scenario>(text).expect("valid TOML").wind
    }

    const CRUISE: FlightConditions = FlightConditions {
        airspeed: 100.0,
        altitude: 300.0,
    };

    fn explicit_turbulence(sigma: [f64; 3], length: [f64; 3]) -> WindSpec {
        WindSpec {
            turbulence: Some(TurbulenceSpec {
                sigma_u: Some(sigma[0].into()),
                sigma_v: Some(sigma[1].into()),
                sigma_w: Some(sigma[2].into()),
                length_u: Some(length[0].into()),
                length_v: Some(length[1].into()),
                length_w: Some(length[2].into()),
                ..TurbulenceSpec::default()
            }),
            ..WindSpec::default()
        }
    }

    fn assert_close(actual: f64, expected: f64, tolerance: f64, what: &str) {
        assert!(
            (actual - expected).abs() <= tolerance,
            "{what}: {actual} vs {expected}"
        );
    }

    #[test]
    fn steady_wind_from_west_blows_towards_east() {
        let spec = parse("[wind]\nspeed = \"10 kt\"\nfrom_direction = \"270 deg\"\n");
        let samples = spec.generate(&CRUISE, 0.01, 3, 1).unwrap();
        let expected = Vector3::new(0.0, 10.0 * KNOT, 0.0);
        for sample in samples {
            assert!((sample.ned - expected).norm() < 1e-12, "{:?}", sample.ned);
            assert_eq!(sample.body, Vector3::zeros());
        }
        let from_north = parse("[wind]\nspeed = 4.0\nfrom_direction = 0.0\n");
        let sample = from_north.generate(&CRUISE, 0.01, 1, 1).unwrap()[0];
        assert!((sample.ned - Vector3::new(-4.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn gust_has_one_minus_cosine_shape_on_top_of_steady_wind() {
        let spec = parse(
            r#"
            [wind]
            speed = 2.0
            from_direction = "180 deg"
            [[wind.gusts]]
            start = "1 s"
            duration = "2 s"
            amplitude = 6.0
            direction = "up"
            "#,
        );
        let samples = spec.generate(&CRUISE, 0.5, 9, 1).unwrap();
        let down: Vec<f64> = samples.iter().map(|sample| sample.ned.z).collect();
        let expected = [0.0, 0.0, 0.0, -3.0, -6.0, -3.0, 0.0, 0.0, 0.0];
        for (time_index, (actual, expected)) in down.iter().zip(expected).enumerate() {
            assert_close(
                *actual,
                expected,
                1e-12,
                &format!("down at sample {time_index}"),
            );
        }
        for sample in &samples {
            assert_close(sample.ned.x, 2.0, 1e-12, "wind from south blows north");
        }
    }

    #[test]
    fn documented_example_is_valid() {
        let documentation = include_str!("../../../docs/files.md");
        let example: String = documentation
            .split("```toml\n")
            .find(|block| block.starts_with("[wind]"))
            .and_then(|rest| rest.split("```").next())
            .expect("docs/files.md holds a [wind] example")
            .to_string();
        let spec = parse(&example);
        let mut problems = Problems::default();
        spec.validate(&mut problems);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(spec.gusts.len(), 1);
        let samples = spec.generate(&CRUISE, 0.01, 1000, 3).unwrap();
        assert_close(samples[600].ned.z, -4.0, 1e-9, "gust peak at 6 s");
        assert_close(samples[0].ned.y, 15.0 * KNOT, 1e-9, "steady east wind");
    }

    #[test]
    fn validation_collects_every_problem_at_once() {
        let spec = parse(
            r#"
            [wind]
            speed = "5 deg"
            [[wind.gusts]]
            duration = 3.0
            amplitude = 1.0
            direction = "up"
            [[wind.gusts]]
            duration = -1.0
            amplitude = 1.0
            direction = "sideways"
            [wind.turbulence]
            intensity = "moderate"
            sigma_u = 1.0
            length_w = 0.0
            "#,
        );
        let mut problems = Problems::default();
        spec.validate(&mut problems);
        let fields: Vec<&str> = problems
            .0
            .iter()
            .map(|problem| problem.field.as_str())
            .collect();
        assert_eq!(
            fields,
            [
                "wind.speed",
                "wind.gusts[1].duration",
                "wind.gusts[1].direction",
                "wind.turbulence",
                "wind.turbulence.length_w",
            ],
            "{problems:?}"
        );
        let error = spec.generate(&CRUISE, 0.01, 10, 1).unwrap_err();
        assert!(
            error.contains("wind.gusts[1].direction") && error.contains("sideways"),
            "{error}"
        );
    }

    #[test]
    fn partial_explicit_sigmas_and_unknown_fields_are_rejected() {
        let spec = parse("[wind.turbulence]\nsigma_u = 1.0\n");
        let mut problems = Problems::default();
        spec.validate(&mut problems);
        let fields: Vec<&str> = problems
            .0
            .iter()
            .map(|problem| problem.field.as_str())
            .collect();
        assert_eq!(
            fields,
            ["wind.turbulence.sigma_v", "wind.turbulence.sigma_w"]
        );
        assert!(toml::from_str::<WindSpec>("speeed = 3.0").is_err());
        assert!(WindSpec::default().generate(&CRUISE, 0.0, 1, 1).is_err());
    }

    #[test]
    fn intensity_rules_at_500_ft() {
        let parameters = |intensity: &str| {
            let spec = TurbulenceSpec {
                intensity: Some(intensity.into()),
                ..Default::default()
            };
            spec.parameters(500.0 * FOOT).unwrap()
        };
        // σw = 0.1·W20; σu = σv = σw/(0.177 + 0.000823·500)^0.4 = σw/0.80888.
        let expected_sigmas = [
            ("light", 0.953_962_172_090_088_3, 0.771_666_666_666_666_7),
            ("moderate", 1.907_924_344_180_176_5, 1.543_333_333_333_333_4),
            ("severe", 2.861_886_516_270_265, 2.315_000_000_000_000_4),
        ];
        for (intensity, sigma_u, sigma_w) in expected_sigmas {
            let TurbulenceParameters { sigma, length } = parameters(intensity);
            let tolerance = 1e-12;
            assert_close(sigma[0], sigma_u, tolerance, intensity);
            assert_close(sigma[1], sigma_u, tolerance, intensity);
            assert_close(sigma[2], sigma_w, 1e-12, intensity);
            // Lw = h = 152.4 m; Lu = Lv = 500 ft/0.5885^1.2 = 944.65 ft.
            assert_close(length[0], 287.931_517_669_529, 1e-9, "Lu");
            assert_close(length[1], 287.931_517_669_529, 1e-9, "Lv");
            assert_close(length[2], 152.4, 1e-9, "Lw");
        }
    }

    #[test]
    fn intensity_rules_above_and_between_the_low_altitude_model() {
        let moderate = TurbulenceSpec {
            intensity: Some("Moderate".into()),
            ..Default::default()
        };
        // 5000 ft: 10.6 + (10.1 − 10.6)·1250/3750 ft/s, L = 1750 ft.
        let high = moderate.parameters(5000.0 * FOOT).unwrap();
        assert_eq!(high.sigma.map(|s| (s * 1e9).round()), [3.180_08e9; 3]);
        assert_eq!(high.length.map(|l| (l * 1e9).round()), [533.4e9; 3]);
        // 1500 ft: half-way between 0.1·30 kt (1000 ft) and 9.725 ft/s (2000 ft); L half-way
        // between 1000 ft and 1750 ft.
        let between = moderate.parameters(1500.0 * FOOT).unwrap();
        for axis in 0..3 {
            assert_close(
                between.sigma[axis],
                2.253_756_666_666_667,
                1e-9,
                "σ at 1500 ft",
            );
            assert_close(between.length[axis], 419.1, 1e-9, "L at 1500 ft");
        }
        // Explicit lengths override the altitude rules; missing ones follow them.
        let mut explicit = explicit_turbulence([1.0, 2.0, 3.0], [10.0, 20.0, 30.0])
            .turbulence
            .unwrap();
        explicit.length_v = None;
        let parameters = explicit.parameters(500.0 * FOOT).unwrap();
        assert_eq!(parameters.sigma, [1.0, 2.0, 3.0]);
        assert_close(
            parameters.length[1],
            287.931_517_669_529,
            1e-9,
            "default Lv",
        );
        assert_eq!([parameters.length[0], parameters.length[2]], [10.0, 30.0]);
    }

    #[test]
    fn same_seed_is_bit_identical_and_different_seed_differs() {
        let mut spec = explicit_turbulence([1.0, 2.0, 3.0], [100.0, 80.0, 60.0]);
        spec.speed = 5.0.into();
        let bits = |samples: &[WindSample]| -> Vec<u64> {
            samples
                .iter()
                .flat_map(|s| s.ned.iter().chain(s.body.iter()).map(|v| v.to_bits()))
                .collect()
        };
        let first = spec.generate(&CRUISE, 0.01, 500, 42).unwrap();
        let again = spec.generate(&CRUISE, 0.01, 500, 42).unwrap();
        let shorter = spec.generate(&CRUISE, 0.01, 200, 42).unwrap();
        let other = spec.generate(&CRUISE, 0.01, 500, 43).unwrap();
        assert_eq!(bits(&first), bits(&again));
        assert_eq!(
            bits(&first[..200]),
            bits(&shorter),
            "a shorter run is a prefix"
        );
        let differing = first
            .iter()
            .zip(&other)
            .filter(|(a, b)| a.body != b.body)
            .count();
        assert_eq!(differing, 500, "another seed gives other turbulence");
    }

    /// Φ and Qd by Van Loan's method: expm([[−A, BBᵀ], [0, Aᵀ]]·dt) = [[·, Φ⁻¹Qd], [0, Φᵀ]].
    fn van_loan(theta: f64) -> (Matrix2<f64>, Matrix2<f64>) {
        // Time in units of L/V: A = [[0, 1], [−1, −2]], B = [0, 2]ᵀ, dt = θ.
        let system = Matrix2::new(0.0, 1.0, -1.0, -2.0);
        let noise = Matrix2::new(0.0, 0.0, 0.0, 4.0);
        let mut block = Matrix4::zeros();
        block
            .fixed_view_mut::<2, 2>(0, 0)
            .copy_from(&(-system * theta));
        block
            .fixed_view_mut::<2, 2>(0, 2)
            .copy_from(&(noise * theta));
        block
            .fixed_view_mut::<2, 2>(2, 2)
            .copy_from(&(system.transpose() * theta));
        let exponential = block.exp();
        let transition: Matrix2<f64> = exponential.fixed_view::<2, 2>(2, 2).transpose();
        let covariance = transition * exponential.fixed_view::<2, 2>(0, 2);
        (transition, covariance)
    }

    #[test]
    fn closed_form_discretisation_matches_van_loan_and_stationarity() {
        for theta in [1e-3, 0.02, 0.3, 0.99, 1.01, 3.0] {
            let (transition, covariance) = van_loan(theta);
            let closed = transverse_process_noise(theta);
            assert!(
                (transverse_transition(theta) - transition).amax() < 1e-12,
                "Φ at θ = {theta}"
            );
            for (row, column) in [(0, 0), (0, 1), (1, 1)] {
                let scale = (closed[(row, row)] * closed[(column, column)]).sqrt();
                let difference = (closed[(row, column)] - covariance[(row, column)]).abs();
                assert!(
                    difference < 1e-8 * scale,
                    "Qd[{row}{column}] at θ = {theta}: {closed} vs {covariance}"
                );
            }
        }
        // A stationary identity covariance is kept: Qd = I − ΦΦᵀ.
        for theta in [0.5, 5.0, 50.0] {
            let transition = transverse_transition(theta);
            let residual = Matrix2::identity() - transition * transition.transpose();
            assert!(
                (residual - transverse_process_noise(theta)).amax() < 1e-13,
                "θ = {theta}"
            );
        }
    }

    /// MIL-F-8785C Dryden spatial spectrum Φ(Ω) of `axis` (0 = u, 1 = v, 2 = w), one-sided.
    fn spatial_spectrum(axis: usize, sigma: f64, length: f64, frequency: f64) -> f64 {
        let scaled = (length * frequency).powi(2);
        if axis == 0 {
            sigma * sigma * 2.0 * length / PI / (1.0 + scaled)
        } else {
            sigma * sigma * length / PI * (1.0 + 3.0 * scaled) / (1.0 + scaled).powi(2)
        }
    }

    /// One-sided PSD in Hz of the continuous process seen at airspeed V.
    /// With Ω = 2πf/V, dΩ = (2π/V)·df and σ² = ∫₀^∞ Φ(Ω) dΩ = ∫₀^∞ (2π/V)·Φ(2πf/V) df,
    /// so S(f) = (2π/V)·Φ(2πf/V) (Φ is already one-sided: no further factor 2).
    fn time_spectrum(axis: usize, sigma: f64, length: f64, airspeed: f64, frequency: f64) -> f64 {
        TAU / airspeed * spatial_spectrum(axis, sigma, length, TAU * frequency / airspeed)
    }

    /// One-sided PSD of the sampled sequence: the aliased sum Σₖ S(|f + k·fs|).
    fn sampled_spectrum(
        axis: usize,
        sigma: f64,
        length: f64,
        airspeed: f64,
        step: f64,
        frequency: f64,
    ) -> f64 {
        (-4000..=4000_i32)
            .map(|k| (frequency + f64::from(k) / step).abs())
            .map(|alias| time_spectrum(axis, sigma, length, airspeed, alias))
            .sum()
    }

    /// ∫₀^∞ g(f) df by the midpoint rule on [0, 4000·fc], fc = V/(2πL); integrands fall as f⁻².
    fn integrate_spectrum(corner: f64, integrand: impl Fn(f64) -> f64) -> f64 {
        let width = corner / 400.0;
        (0..1_600_000)
            .map(|i| integrand((i as f64 + 0.5) * width) * width)
            .sum()
    }

    #[test]
    fn analytic_spectra_integrate_to_the_variance() {
        for axis in 0..3 {
            let (sigma, length, airspeed) = (1.7, 40.0, 60.0);
            let corner = airspeed / (TAU * length);
            let variance =
                integrate_spectrum(corner, |f| time_spectrum(axis, sigma, length, airspeed, f));
            assert_close(
                variance,
                sigma * sigma,
                2e-3 * sigma * sigma,
                &format!("axis {axis}"),
            );
        }
    }

    #[test]
    fn filters_start_from_their_stationary_distribution() {
        let sigma = [2.0, 1.5, 1.0];
        let spec = explicit_turbulence(sigma, [500.0, 400.0, 300.0]);
        let runs = 4000;
        let mut squares = [0.0; 3];
        for seed in 0..runs {
            let first = spec.generate(&CRUISE, 0.01, 1, seed).unwrap()[0].body;
            for axis in 0..3 {
                squares[axis] += first[axis].powi(2) / runs as f64;
            }
        }
        // The mean of n squared normals has relative standard error √(2/n) = 2.2 %; allow 5 of them.
        let tolerance = 5.0 * (2.0 / runs as f64).sqrt();
        for axis in 0..3 {
            let ratio = squares[axis] / sigma[axis].powi(2);
            assert!(
                (ratio - 1.0).abs() < tolerance,
                "axis {axis}: first-sample variance ratio {ratio}"
            );
        }
    }

    /// In-place iterative radix-2 FFT, X[k] = Σ x[n]·e^{−2πikn/N}.
    fn fft(buffer: &mut [Complex<f64>]) {
        let size = buffer.len();
        assert!(size.is_power_of_two());
        let mut reversed = 0;
        for index in 1..size {
            let mut bit = size >> 1;
            while reversed & bit != 0 {
                reversed ^= bit;
                bit >>= 1;
            }
            reversed |= bit;
            if index < reversed {
                buffer.swap(index, reversed);
            }
        }
        let mut span = 2;
        while span <= size {
            let root = Complex::from_polar(1.0, -TAU / span as f64);
            for chunk in buffer.chunks_exact_mut(span) {
                let mut twiddle = Complex::new(1.0, 0.0);
                let (lower, upper) = chunk.split_at_mut(span / 2);
                for (even, odd) in lower.iter_mut().zip(upper.iter_mut()) {
                    let product = *odd * twiddle;
                    *odd = *even - product;
                    *even += product;
                    twiddle *= root;
                }
            }
            span *= 2;
        }
    }

    fn hann(size: usize) -> Vec<f64> {
        (0..size)
            .map(|n| 0.5 - 0.5 * (TAU * n as f64 / size as f64).cos())
            .collect()
    }

    /// Welch one-sided PSD (non-overlapping Hann segments, no detrending):
    /// P[k] = 2·dt/(K·Σw²)·Σ_segments |X_k|², valid for 0 < k < M/2.
    fn welch(signal: &[f64], segment: usize, step: f64) -> Vec<f64> {
        let window = hann(segment);
        let window_power: f64 = window.iter().map(|w| w * w).sum();
        let mut power = vec![0.0; segment / 2 + 1];
        let mut buffer = vec![Complex::new(0.0, 0.0); segment];
        let segments = signal.len() / segment;
        for chunk in signal.chunks_exact(segment) {
            for ((slot, value), weight) in buffer.iter_mut().zip(chunk).zip(&window) {
                *slot = Complex::new(value * weight, 0.0);
            }
            fft(&mut buffer);
            for (bin, accumulated) in power.iter_mut().enumerate() {
                *accumulated += buffer[bin].norm_sqr();
            }
        }
        let scale = 2.0 * step / (segments as f64 * window_power);
        power.iter().map(|p| p * scale).collect()
    }

    /// Variance of a band mean of `band` adjacent Welch bins of one segment, relative to the
    /// squared spectrum: for a locally flat Gaussian spectrum Cov(|X_i|², |X_j|²) ∝ |c_{i−j}|²
    /// with c_m = Σ w²·e^{−2πimn/M} / Σ w² (Hann: c₀ = 1, c±₁ = −2/3, c±₂ = 1/6), so the
    /// variance is (1/B²)·Σ_{i,j} |c_{i−j}|² (≈ 1.94/B). Over K independent segments divide by K.
    fn band_variance_factor(segment: usize, band: usize) -> f64 {
        let squares: Vec<f64> = hann(segment).iter().map(|w| w * w).collect();
        let total: f64 = squares.iter().sum();
        let correlation = |lag: usize| -> f64 {
            let sum: Complex<f64> = squares
                .iter()
                .enumerate()
                .map(|(n, s)| Complex::from_polar(*s, -TAU * (lag * n) as f64 / segment as f64))
                .sum();
            sum.norm_sqr() / (total * total)
        };
        let mut factor = 0.0;
        for i in 0..band {
            for j in 0..band {
                factor += correlation(i.abs_diff(j));
            }
        }
        factor / (band * band) as f64
    }

    #[test]
    fn fft_matches_a_plain_dft() {
        let signal: Vec<Complex<f64>> = (0..16)
            .map(|n| Complex::new((n as f64 * 0.7).sin() + 0.1 * n as f64, 0.0))
            .collect();
        let mut transformed = signal.clone();
        fft(&mut transformed);
        for (k, value) in transformed.iter().enumerate() {
            let direct: Complex<f64> = signal
                .iter()
                .enumerate()
                .map(|(n, x)| x * Complex::from_polar(1.0, -TAU * (k * n) as f64 / 16.0))
                .sum();
            assert!((value - direct).norm() < 1e-12, "bin {k}");
        }
    }

    /// A 2^18-sample record (0.02 s, V = 100 m/s) against the analytic Dryden spectra.
    ///
    /// Welch: 128 independent Hann segments of 2048 samples (Δf = 0.0244 Hz). A band mean of
    /// B = 10 bins has relative standard error √(band_variance_factor/K) ≈ 3.9 %; each band
    /// up to a quarter of Nyquist (6.25 Hz) must lie within 4 standard errors of the aliased
    /// analytic spectrum (window leakage bias is ≈ S''/(6S) bin² < 0.3 % here).
    ///
    /// Variance: for a Gaussian process the mean square over T has variance
    /// (1/T)·∫₀^∞ S(f)² df (Parseval on 2∫R(τ)²dτ); the estimate must lie within 5 of its
    /// standard errors (≈ 1.4 % for u).
    #[test]
    fn welch_spectrum_and_variance_match_dryden() {
        const SAMPLES: usize = 1 << 18;
        const SEGMENT: usize = 2048;
        const BAND: usize = 10;
        let (step, airspeed) = (0.02, 100.0);
        let sigma = [2.0, 1.5, 1.0];
        let length = [50.0, 30.0, 20.0];
        let conditions = FlightConditions {
            airspeed,
            altitude: 300.0,
        };
        let spec = explicit_turbulence(sigma, length);
        let samples = spec.generate(&conditions, step, SAMPLES, 7).unwrap();
        let segments = SAMPLES / SEGMENT;
        let relative_error = (band_variance_factor(SEGMENT, BAND) / segments as f64).sqrt();
        let resolution = 1.0 / (SEGMENT as f64 * step);
        let last_bin = (0.25 * 0.5 / step / resolution).round() as usize;
        let duration = SAMPLES as f64 * step;
        for axis in 0..3 {
            let signal: Vec<f64> = samples.iter().map(|sample| sample.body[axis]).collect();
            let estimate = welch(&signal, SEGMENT, step);
            let mut worst: f64 = 0.0;
            for first in (1..=last_bin + 1 - BAND).step_by(BAND) {
                let bins = first..first + BAND;
                let measured = bins.clone().map(|bin| estimate[bin]).sum::<f64>() / BAND as f64;
                let expected = bins
                    .map(|bin| {
                        sampled_spectrum(
                            axis,
                            sigma[axis],
                            length[axis],
                            airspeed,
                            step,
                            bin as f64 * resolution,
                        )
                    })
                    .sum::<f64>()
                    / BAND as f64;
                let deviation = (measured / expected - 1.0) / relative_error;
                worst = worst.max(deviation.abs());
                assert!(
                    deviation.abs() < 4.0,
                    "axis {axis}, bins {first}..{}: {measured} vs {expected} ({deviation:.2} standard errors)",
                    first + BAND
                );
            }
            let variance = signal.iter().map(|v| v * v).sum::<f64>() / SAMPLES as f64;
            let corner = airspeed / (TAU * length[axis]);
            let squared_spectrum = integrate_spectrum(corner, |f| {
                time_spectrum(axis, sigma[axis], length[axis], airspeed, f).powi(2)
            });
            let standard_error = (squared_spectrum / duration).sqrt();
            let variance_deviation = (variance - sigma[axis].powi(2)) / standard_error;
            eprintln!(
                "axis {axis}: worst band {worst:.2} SE (SE {:.1} %), variance {variance:.4} vs {:.4} ({variance_deviation:.2} SE)",
                100.0 * relative_error,
                sigma[axis].powi(2)
            );
            assert!(
                variance_deviation.abs() < 5.0,
                "axis {axis}: variance {variance} vs {}",
                sigma[axis].powi(2)
            );
        }
    }
}
