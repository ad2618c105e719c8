//! The linearisation of a scenario's aircraft at its trim point
//! ([`super::linearize`]) as a linear model file (`kind = "linear"`,
//! [`aeroid_estimation::linear_structure`]), in dimensional derivatives
//! whose values are the truth of a flight of that file.
//!
//! The states are record channels: airspeed V, angle of attack α and
//! sideslip β instead of the body velocities u, v, w, by the exact
//! first-order change of variables z − z₀ = T·(x − x₀) at trim, T = ∂z/∂x
//! (V = |(u, v, w)|, α = atan(w/u), β = asin(v/V)), so that A_z = T·A·T⁻¹
//! and B_z = T·B. The heading is left out (over a flat earth nothing
//! depends on it); the altitude is a longitudinal state (the density
//! gradient), left out of the short-period approximation. The file is written in absolute quantities: the state
//! bias b = −A_z·z₀ − B_z·δ₀ puts the equilibrium at the trim state z₀
//! with the trim controls δ₀, so that a record's channels are its states
//! and inputs as they are. The outputs are the states (C = I).
//! Every entry of A_z and B_z that is not zero is a named parameter
//! (`A_alpha_q` is ∂α̇/∂q, `B_p_aileron` is ∂ṗ/∂δa); the biases are fixed
//! numbers. Assumes no steady wind (u, v, w are then the air-relative velocities).

use super::linearize::{H, Linearization, P, PHI, Q, R, THETA, U, V, W};
use aeroid_estimation::input_timing::InputInterpolation;
use aeroid_estimation::linear_structure::{Cell, KIND, LinearFile, LinearParameter};
use aeroid_sim::state::Control;
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeMap;

/// Which states the file keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Axes {
    /// V, α, q, θ, h with the elevator and throttle.
    Longitudinal,
    /// α, q with the elevator: the short-period approximation (the
    /// longitudinal model with V and θ held).
    ShortPeriod,
    /// β, p, r, φ with the aileron and rudder.
    Lateral,
    /// All nine, with the elevator, aileron, rudder and throttle.
    All,
}

impl Axes {
    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Axes::Longitudinal => "longitudinal",
            Axes::ShortPeriod => "short-period",
            Axes::Lateral => "lateral",
            Axes::All => "all",
        }
    }

    /// The record names of the states.
    fn states(self) -> &'static [&'static str] {
        match self {
            Axes::Longitudinal => &["airspeed", "alpha", "q", "pitch", "altitude"],
            Axes::ShortPeriod => &["alpha", "q"],
            Axes::Lateral => &["beta", "p", "r", "roll"],
            Axes::All => &RECORD_STATES,
        }
    }

    fn controls(self) -> &'static [Control] {
        match self {
            Axes::Longitudinal => &[Control::Elevator, Control::Throttle],
            Axes::ShortPeriod => &[Control::Elevator],
            Axes::Lateral => &[Control::Aileron, Control::Rudder],
            Axes::All => &[
                Control::Elevator,
                Control::Aileron,
                Control::Rudder,
                Control::Throttle,
            ],
        }
    }
}

/// The nine record states in the order of [`Axes::All`].
const RECORD_STATES: [&str; 9] = [
    "airspeed", "alpha", "beta", "p", "q", "r", "roll", "pitch", "altitude",
];

/// The linear model in the record states z = (V, α, β, p, q, r, φ, θ, h):
/// (A_z, B_z over all controls, z₀).
fn in_record_states(linear: &Linearization) -> (DMatrix<f64>, DMatrix<f64>, DVector<f64>) {
    let x = &linear.state;
    let euler = [U, V, W, P, Q, R, PHI, THETA, H];
    let (u, v, w) = (x[U], x[V], x[W]);
    let speed = (u * u + v * v + w * w).sqrt();
    let planar = u * u + w * w;
    let mut t = DMatrix::zeros(9, 9);
    for (j, value) in [u, v, w].iter().enumerate() {
        t[(0, j)] = value / speed;
    }
    t[(1, 0)] = -w / planar;
    t[(1, 2)] = u / planar;
    let scale = speed * speed * planar.sqrt();
    t[(2, 0)] = -u * v / scale;
    t[(2, 1)] = planar / scale;
    t[(2, 2)] = -v * w / scale;
    for i in 3..9 {
        t[(i, i)] = 1.0;
    }
    let a = DMatrix::from_fn(9, 9, |i, j| linear.a[(euler[i], euler[j])]);
    let b = DMatrix::from_fn(9, linear.b.ncols(), |i, j| linear.b[(euler[i], j)]);
    let inverse = t
        .clone()
        .try_inverse()
        .unwrap_or_else(|| DMatrix::identity(9, 9));
    let z0 = DVector::from_vec(vec![
        speed,
        w.atan2(u),
        (v / speed).asin(),
        x[P],
        x[Q],
        x[R],
        x[PHI],
        x[THETA],
        x[H],
    ]);
    (&t * a * inverse, t * b, z0)
}

/// The linear model file of `linear` (a linearisation at a trim) for `axes`,
/// named `name`; `description` says where it came from.
pub(crate) fn linear_model_file(
    linear: &Linearization,
    axes: Axes,
    name: &str,
    description: &str,
) -> LinearFile {
    let (a_all, b_all, z0) = in_record_states(linear);
    let states = axes.states();
    let rows: Vec<usize> = states
        .iter()
        .map(|s| RECORD_STATES.iter().position(|r| r == s).unwrap_or(0))
        .collect();
    let controls = axes.controls();
    let a = DMatrix::from_fn(rows.len(), rows.len(), |i, j| a_all[(rows[i], rows[j])]);
    let b = DMatrix::from_fn(rows.len(), controls.len(), |i, j| {
        b_all[(rows[i], controls[j].index())]
    });
    let state0 = DVector::from_fn(rows.len(), |i, _| z0[rows[i]]);
    let control0 = DVector::from_fn(controls.len(), |j, _| linear.controls[controls[j].index()]);
    let bias = -(&a * &state0) - &b * &control0;
    let mut parameters = BTreeMap::new();
    let mut cells = |matrix: &DMatrix<f64>, prefix: &str, columns: &[&str]| -> Vec<Vec<Cell>> {
        (0..matrix.nrows())
            .map(|i| {
                (0..matrix.ncols())
                    .map(|j| {
                        let value = matrix[(i, j)];
                        // Exact zeros of the linearisation (kinematic rows,
                        // decoupled axes) stay fixed numbers.
                        if value.abs() < 1e-12 {
                            return Cell::Number(0.0);
                        }
                        if prefix == "A" && is_kinematic(states[i], columns[j]) {
                            return Cell::Number(value);
                        }
                        let name = format!("{prefix}_{}_{}", states[i], columns[j]);
                        parameters.insert(
                            name.clone(),
                            LinearParameter {
                                start: value,
                                fixed: false,
                                lower: None,
                                upper: None,
                            },
                        );
                        Cell::Parameter(name)
                    })
                    .collect()
            })
            .collect()
    };
    let control_names: Vec<&str> = controls.iter().map(|c| c.name()).collect();
    let a_cells = cells(&a, "A", states);
    let b_cells = cells(&b, "B", &control_names);
    let identity = |i: usize, j: usize| Cell::Number(if i == j { 1.0 } else { 0.0 });
    LinearFile {
        kind: KIND.to_string(),
        name: name.to_string(),
        description: description.to_string(),
        states: states.iter().map(|s| s.to_string()).collect(),
        inputs: control_names.iter().map(|s| s.to_string()).collect(),
        outputs: states.iter().map(|s| s.to_string()).collect(),
        rate_outputs: BTreeMap::new(),
        interpolation: InputInterpolation::default(),
        a: a_cells,
        b: b_cells,
        c: (0..rows.len())
            .map(|i| (0..rows.len()).map(|j| identity(i, j)).collect())
            .collect(),
        d: Vec::new(),
        state_bias: bias.iter().map(|&v| Cell::Number(v)).collect(),
        output_bias: Vec::new(),
        initial_state: None,
        parameters,
        methods: BTreeMap::new(),
    }
}

/// The attitude rows' entries of the body rates (φ̇ = p + …, θ̇ = q·cos φ − …):
/// kinematics, not aerodynamics, so they stay fixed numbers.
fn is_kinematic(state: &str, column: &str) -> bool {
    matches!(
        (state, column),
        ("roll", "p" | "q" | "r") | ("pitch", "q" | "r")
    )
}

/// Trims and linearises a scenario's aircraft (in its steady wind at the
/// start) and gives the linear model file for `axes`.
pub fn linearise_scenario(
    scenario: &aeroid_sim::scenario::Scenario,
    axes: Axes,
) -> crate::Result<LinearFile> {
    let simulation = aeroid_sim::Simulation::prepare(scenario)?;
    let linear =
        super::linearize::linearize(&simulation.model, &simulation.trim, &simulation.winds[0]);
    let axes_name = axes.name();
    Ok(linear_model_file(
        &linear,
        axes,
        &format!("{}-linear-{axes_name}", scenario.name),
        &format!(
            "{axes_name} linearisation of {} at the trim of scenario {} ({:.1} m/s, {:.0} m), by `aeroid linearise`",
            scenario.aircraft.name, scenario.name, scenario.trim.airspeed, scenario.trim.altitude
        ),
    ))
}

/// The file as TOML.
pub fn to_toml(file: &LinearFile) -> crate::Result<String> {
    toml::to_string(file).map_err(|e| crate::Error::Format {
        what: "linear model",
        reason: e.to_string(),
    })
}
