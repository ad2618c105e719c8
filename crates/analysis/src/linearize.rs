//! Numerical linearisation of the simulator about an operating point (a
//! trim), and the aircraft's dynamic modes from it.
//!
//! # State and controls
//!
//! The simulator integrates a quaternion state (see [`aeroid_sim::state`]); the
//! linear model uses the classical Euler-angle state
//! `x_e = [u, v, w, p, q, r, φ, θ, ψ, h]`, plus the flow-separation point χ
//! when the aircraft's stall model integrates it ([`aeroid_sim::aero::AeroModel::chi_is_state`]).
//! North and east are left out: over a flat earth nothing depends on them.
//! The controls are `[elevator, aileron, rudder, flap, throttle]` in
//! [`Control`] order.
//!
//! # Method
//!
//! `ẋ_e = f_e(x_e, δ)` is the simulator's own right-hand side,
//! [`FlightModel::derivative`], wrapped in two exact maps: `x_e → x` (the
//! quaternion from (φ, θ, ψ), 3-2-1 sequence; `down = −h`) and `ẋ → ẋ_e`,
//! with `ḣ = −(d/dt) down` and the Euler-angle rates from the body rates
//! (Stevens, Lewis & Johnson, *Aircraft Control and Simulation*, 3rd ed.,
//! Eq. 1.4-4): `φ̇ = p + tan θ·(q sin φ + r cos φ)`, `θ̇ = q cos φ − r sin φ`,
//! `ψ̇ = (q sin φ + r cos φ)/cos θ`.
//! Column j of `A = ∂f_e/∂x_e` (and of `B = ∂f_e/∂δ`) is the central difference
//! `(f_e(x + δ_j e_j) − f_e(x − δ_j e_j)) / (2 δ_j)` (`RELATIVE_STEP`).
//! Exogenous wind is held at the given steady sample, with zero rate.
//!
//! # Modes
//!
//! Eigenvalues come from the real Schur form of `A` after Parlett–Reinsch
//! balancing. Complex pairs are reported once, with Im λ > 0: natural
//! frequency `ωn = |λ|`, damping ratio `ζ = −Re λ/|λ|`, time constant
//! `τ = −1/Re λ` (negative for a diverging mode: then `|τ|` is its
//! e-folding time). Modes are told apart by *participation factors*
//! (Pérez-Arriaga, Verghese & Schweppe 1982):
//! `p_k = |w_k·v_k| / Σ_i |w_i·v_i|` with `v` and `w` the right and left
//! eigenvectors, and named following the classical description of the
//! modes (Etkin & Reid, *Dynamics of Flight*, 3rd ed., §§6.2, 6.4–6.6;
//! Stevens, Lewis & Johnson §4.4): short period, phugoid, Dutch roll,
//! roll subsidence, spiral, height mode ([`ModeKind`]).

use aeroid_sim::dynamics::{Exogenous, FlightModel};
use aeroid_sim::state::{
    self, CHI, CONTROL_COUNT, Control, Controls, DOWN, EulerAngles, StateVector,
};
use aeroid_sim::trim::Trim;
use aeroid_sim::wind::WindSample;
use nalgebra::{Complex, DMatrix, DVector};

/// u, v, w, p, q, r: the first six entries of the Euler-angle state are those of the simulator state.
pub use aeroid_sim::state::{P, Q, R, U, V, W};
pub const PHI: usize = 6;
pub const THETA: usize = 7;
pub const PSI: usize = 8;
pub const H: usize = 9;
/// Index of χ, present only when the stall model integrates it.
pub(crate) const CHI_E: usize = 10;

/// Names of the Euler-angle state entries, in order (χ last, when present).
pub(crate) const EULER_STATE_NAMES: [&str; 11] = [
    "u", "v", "w", "p", "q", "r", "phi", "theta", "psi", "h", "chi",
];

/// The longitudinal entries of the Euler-angle state.
pub const LONGITUDINAL: [usize; 4] = [U, W, Q, THETA];
/// The lateral-directional entries of the Euler-angle state.
pub const LATERAL: [usize; 4] = [V, P, R, PHI];

/// Relative central-difference step ε: the step of entry j is
/// `δ_j = ε·max(|x_j|, s_j)`, near the optimum `(3·ε_mach)^{1/3}` of a
/// central difference, so truncation, O(δ²), and round-off, O(ε_mach/δ),
/// errors are both about 10⁻¹⁰ relative; `s_j` is a typical size of the
/// entry: the airspeed for u, v, w; 1 rad/s, 1 rad, 100 m, 1 for rates,
/// angles, height and χ; 1 rad (or full throttle) for controls. The control
/// limits are lifted while differencing, so that a control sitting on its
/// stop (flap at 0°) gets its two-sided derivative rather than half of it.
pub(crate) const RELATIVE_STEP: f64 = 1e-5;

/// A linear model `ẋ_e = A·x_e + B·δ` about an operating point.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    pub a: DMatrix<f64>,
    /// Columns: elevator, aileron, rudder, flap, throttle.
    pub b: DMatrix<f64>,
    pub state_names: Vec<&'static str>,
    pub control_names: Vec<&'static str>,
    /// The operating point in the Euler-angle state.
    pub state: DVector<f64>,
    pub controls: Controls,
}

/// Which of the classical modes an eigenvalue is.
///
/// A mode belongs to the group of states with the largest participation:
/// longitudinal (u, w, q, θ), lateral-directional (v, p, r, φ), height h,
/// heading ψ, or χ. Participation factors, unlike raw eigenvector entries,
/// do not depend on the units of the states, so a mode in which h moves by
/// metres while α moves by milliradians is still judged fairly. Then:
/// - longitudinal oscillatory modes are ordered by frequency: the fastest is
///   the short period, the slowest the phugoid; when there is only one (or a
///   mode is real, as when the short period splits into two real roots) it is
///   the short period when w and q participate more than u and θ (an
///   angle-of-attack and pitch-rate motion at almost constant speed), else
///   the phugoid (a speed and pitch-attitude exchange at almost constant α);
/// - a lateral oscillatory mode is the Dutch roll;
/// - lateral real modes are ordered by |λ|: the fastest is the roll
///   subsidence, the slowest the spiral; a single one is the roll mode when p
///   participates more than φ and r, else the spiral;
/// - a mode of h is the height mode (the density gradient's slow root); a mode
///   of ψ (the heading integrator, λ = 0 without wind) or χ is "other".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ModeKind {
    ShortPeriod,
    Phugoid,
    DutchRoll,
    Roll,
    Spiral,
    Height,
    Other,
}

impl ModeKind {
    pub fn name(self) -> &'static str {
        match self {
            ModeKind::ShortPeriod => "short period",
            ModeKind::Phugoid => "phugoid",
            ModeKind::DutchRoll => "Dutch roll",
            ModeKind::Roll => "roll",
            ModeKind::Spiral => "spiral",
            ModeKind::Height => "height",
            ModeKind::Other => "other",
        }
    }
}

/// One mode: a real eigenvalue or a complex pair (reported with Im λ > 0).
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    pub kind: ModeKind,
    pub eigenvalue: Complex<f64>,
    pub oscillatory: bool,
    /// |λ| (rad/s).
    pub natural_frequency: f64,
    /// −Re λ/|λ|; ±1 for a real mode.
    pub damping_ratio: f64,
    /// −1/Re λ (s); negative when the mode diverges.
    pub time_constant: f64,
    /// Participation factor of each Euler-angle state (sums to 1).
    pub participation: DVector<f64>,
    /// Right eigenvector in the Euler-angle state, unit norm.
    pub eigenvector: DVector<Complex<f64>>,
}

/// ωn = |λ|.
pub fn natural_frequency(eigenvalue: Complex<f64>) -> f64 {
    eigenvalue.norm()
}

/// ζ = −Re λ/|λ| (1 for a stable real root, −1 for an unstable one).
pub fn damping_ratio(eigenvalue: Complex<f64>) -> f64 {
    -eigenvalue.re / eigenvalue.norm()
}

/// τ = −1/Re λ.
pub fn time_constant(eigenvalue: Complex<f64>) -> f64 {
    -1.0 / eigenvalue.re
}

/// Linearises `model` at a converged trim in the steady `wind`.
pub fn linearize(model: &FlightModel, trim: &Trim, wind: &WindSample) -> Linearization {
    linearize_at(model, &trim.state, &trim.controls, wind)
}

/// Linearises `model` at any state and controls (the derivative there need
/// not vanish; the linear model is then the tangent one).
pub(crate) fn linearize_at(
    model: &FlightModel,
    reference: &StateVector,
    controls: &Controls,
    wind: &WindSample,
) -> Linearization {
    let mut unlimited = model.clone();
    unlimited.aircraft.limits = [(f64::NEG_INFINITY, f64::INFINITY); CONTROL_COUNT];
    let with_chi = model.aircraft.aero.chi_is_state();
    let x0 = euler_state(reference, with_chi);
    let n = x0.len();
    let airspeed = state::velocity(reference).norm().max(1.0);
    let f = |x: &DVector<f64>, u: &Controls| -> DVector<f64> {
        let full = full_state(x, reference);
        let exogenous = Exogenous {
            controls: *u,
            wind: *wind,
            wind_rate: WindSample::default(),
        };
        euler_derivative(&full, &unlimited.derivative(&full, &exogenous), with_chi)
    };
    let mut a = DMatrix::zeros(n, n);
    for j in 0..n {
        let step = RELATIVE_STEP * x0[j].abs().max(typical_size(j, airspeed));
        let (mut plus, mut minus) = (x0.clone(), x0.clone());
        plus[j] += step;
        minus[j] -= step;
        a.set_column(
            j,
            &((f(&plus, controls) - f(&minus, controls)) / (2.0 * step)),
        );
    }
    let mut b = DMatrix::zeros(n, CONTROL_COUNT);
    for j in 0..CONTROL_COUNT {
        let step = RELATIVE_STEP * controls[j].abs().max(1.0);
        let (mut plus, mut minus) = (*controls, *controls);
        plus[j] += step;
        minus[j] -= step;
        b.set_column(j, &((f(&x0, &plus) - f(&x0, &minus)) / (2.0 * step)));
    }
    Linearization {
        a,
        b,
        state_names: EULER_STATE_NAMES[..n].to_vec(),
        control_names: Control::ALL.iter().map(|c| c.name()).collect(),
        state: x0,
        controls: *controls,
    }
}

/// The typical size s_j of Euler-angle state entry j ([`RELATIVE_STEP`]).
fn typical_size(j: usize, airspeed: f64) -> f64 {
    match j {
        U | V | W => airspeed,
        H => 100.0,
        _ => 1.0,
    }
}

/// The Euler-angle state of a simulator state (χ appended when `with_chi`).
pub(crate) fn euler_state(x: &StateVector, with_chi: bool) -> DVector<f64> {
    let euler = state::euler(x);
    let mut e = DVector::zeros(if with_chi { 11 } else { 10 });
    e.rows_mut(0, 6).copy_from(&x.fixed_rows::<6>(0));
    e[PHI] = euler.roll;
    e[THETA] = euler.pitch;
    e[PSI] = euler.yaw;
    e[H] = state::altitude(x);
    if with_chi {
        e[CHI_E] = x[CHI];
    }
    e
}

/// The simulator state of an Euler-angle state: `reference` with u…r, the
/// attitude, the height and (when present) χ replaced.
pub(crate) fn full_state(e: &DVector<f64>, reference: &StateVector) -> StateVector {
    let mut x = *reference;
    x.fixed_rows_mut::<6>(0).copy_from(&e.rows(0, 6));
    let attitude = state::quaternion_from_euler(EulerAngles {
        roll: e[PHI],
        pitch: e[THETA],
        yaw: e[PSI],
    });
    state::set_attitude(&mut x, &attitude);
    x[DOWN] = -e[H];
    if e.len() > CHI_E {
        x[CHI] = e[CHI_E];
    }
    x
}

/// ẋ_e from the simulator's ẋ at x: Euler-angle rates from the body rates, ḣ = −ḋown.
fn euler_derivative(x: &StateVector, derivative: &StateVector, with_chi: bool) -> DVector<f64> {
    let euler = state::euler(x);
    let mut e = DVector::zeros(if with_chi { 11 } else { 10 });
    e.rows_mut(0, 6).copy_from(&derivative.fixed_rows::<6>(0));
    e.rows_mut(PHI, 3).copy_from(&state::euler_rates(
        euler.roll,
        euler.pitch,
        &state::rates(x),
    ));
    e[H] = -derivative[DOWN];
    if with_chi {
        e[CHI_E] = derivative[CHI];
    }
    e
}

impl Linearization {
    /// The sub-matrix of A on the given states (rows and columns).
    pub fn block(&self, rows: &[usize], columns: &[usize]) -> DMatrix<f64> {
        DMatrix::from_fn(rows.len(), columns.len(), |i, j| {
            self.a[(rows[i], columns[j])]
        })
    }

    /// The eigenvalues of A (complex pairs both listed).
    pub fn eigenvalues(&self) -> Vec<Complex<f64>> {
        let (balanced, _) = balance(&self.a);
        balanced.complex_eigenvalues().iter().copied().collect()
    }

    /// The modes of A, classified ([`ModeKind`]), ordered by
    /// kind and then by natural frequency, fastest first.
    pub fn modes(&self) -> Vec<Mode> {
        let (balanced, scaling) = balance(&self.a);
        let eigenvalues = balanced.complex_eigenvalues();
        let size = self.a.norm().max(f64::MIN_POSITIVE);
        let mut modes: Vec<Mode> = Vec::new();
        for &lambda in eigenvalues.iter() {
            let tolerance = 1e-9 * size.max(lambda.norm());
            if lambda.im < -tolerance {
                continue; // the conjugate of a pair, reported once
            }
            let oscillatory = lambda.im > tolerance;
            let lambda = if oscillatory {
                lambda
            } else {
                Complex::new(lambda.re, 0.0)
            };
            let (right, left) = eigenvectors(&balanced, lambda);
            let participation = participation(&right, &left);
            let eigenvector = DVector::from_iterator(
                right.len(),
                right
                    .iter()
                    .zip(scaling.iter())
                    .map(|(v, s)| v * Complex::from(*s)),
            );
            let norm = eigenvector.norm().max(f64::MIN_POSITIVE);
            modes.push(Mode {
                kind: ModeKind::Other,
                eigenvalue: lambda,
                oscillatory,
                natural_frequency: natural_frequency(lambda),
                damping_ratio: damping_ratio(lambda),
                time_constant: time_constant(lambda),
                participation,
                eigenvector: eigenvector.unscale(norm),
            });
        }
        classify(&mut modes);
        modes.sort_by(|a, b| {
            a.kind
                .cmp(&b.kind)
                .then(b.natural_frequency.total_cmp(&a.natural_frequency))
        });
        modes
    }
}

/// The first mode of a kind (the fastest, as [`Linearization::modes`] orders them).
pub fn find(modes: &[Mode], kind: ModeKind) -> Option<&Mode> {
    modes.iter().find(|m| m.kind == kind)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Group {
    Longitudinal,
    Lateral,
    Height,
    Heading,
    Chi,
}

fn group(participation: &DVector<f64>) -> Group {
    let sum = |indices: &[usize]| indices.iter().map(|&i| participation[i]).sum::<f64>();
    let chi = if participation.len() > CHI_E {
        participation[CHI_E]
    } else {
        0.0
    };
    [
        (Group::Longitudinal, sum(&LONGITUDINAL)),
        (Group::Lateral, sum(&LATERAL)),
        (Group::Height, participation[H]),
        (Group::Heading, participation[PSI]),
        (Group::Chi, chi),
    ]
    .into_iter()
    .max_by(|a, b| a.1.total_cmp(&b.1))
    .map_or(Group::Longitudinal, |(g, _)| g)
}

fn classify(modes: &mut [Mode]) {
    let groups: Vec<Group> = modes.iter().map(|m| group(&m.participation)).collect();
    let indices = |wanted: Group, oscillatory: bool| -> Vec<usize> {
        let mut list: Vec<usize> = (0..modes.len())
            .filter(|&i| groups[i] == wanted && modes[i].oscillatory == oscillatory)
            .collect();
        list.sort_by(|&a, &b| {
            modes[b]
                .natural_frequency
                .total_cmp(&modes[a].natural_frequency)
        });
        list
    };
    let short_period_like = |m: &Mode| {
        let p = &m.participation;
        p[W] + p[Q] > p[U] + p[THETA]
    };
    let by_participation = |m: &Mode| {
        if short_period_like(m) {
            ModeKind::ShortPeriod
        } else {
            ModeKind::Phugoid
        }
    };
    let mut kinds = vec![ModeKind::Other; modes.len()];
    let oscillating = indices(Group::Longitudinal, true);
    for (rank, &i) in oscillating.iter().enumerate() {
        kinds[i] = match (rank, oscillating.len()) {
            (_, 1) => by_participation(&modes[i]),
            (0, _) => ModeKind::ShortPeriod,
            (r, n) if r + 1 == n => ModeKind::Phugoid,
            _ => by_participation(&modes[i]),
        };
    }
    for i in indices(Group::Longitudinal, false) {
        kinds[i] = by_participation(&modes[i]);
    }
    for i in indices(Group::Lateral, true) {
        kinds[i] = ModeKind::DutchRoll;
    }
    let real = indices(Group::Lateral, false);
    for (rank, &i) in real.iter().enumerate() {
        let p = &modes[i].participation;
        kinds[i] = match (rank, real.len()) {
            (_, 1) if p[P] > p[PHI] + p[R] => ModeKind::Roll,
            (_, 1) => ModeKind::Spiral,
            (0, _) => ModeKind::Roll,
            (r, n) if r + 1 == n => ModeKind::Spiral,
            _ if p[P] > p[PHI] + p[R] => ModeKind::Roll,
            _ => ModeKind::Spiral,
        };
    }
    for (i, g) in groups.iter().enumerate() {
        if *g == Group::Height {
            kinds[i] = ModeKind::Height;
        }
    }
    for (mode, kind) in modes.iter_mut().zip(kinds) {
        mode.kind = kind;
    }
}

/// Participation factors |w_k v_k|, normalised to sum to 1.
fn participation(right: &DVector<Complex<f64>>, left: &DVector<Complex<f64>>) -> DVector<f64> {
    let products = right.zip_map(left, |v, w| (v * w).norm());
    let total = products.sum();
    if total > 0.0 {
        products / total
    } else {
        products
    }
}

/// Right and left eigenvectors of `a` for the eigenvalue λ: the singular
/// vectors of `A − λI` and `Aᵀ − λI` for their smallest singular value.
pub(crate) fn eigenvectors(
    a: &DMatrix<f64>,
    lambda: Complex<f64>,
) -> (DVector<Complex<f64>>, DVector<Complex<f64>>) {
    let shifted = |m: &DMatrix<f64>| {
        let mut c: DMatrix<Complex<f64>> = m.map(Complex::from);
        for i in 0..c.nrows() {
            c[(i, i)] -= lambda;
        }
        null_vector(c)
    };
    (shifted(a), shifted(&a.transpose()))
}

fn null_vector(m: DMatrix<Complex<f64>>) -> DVector<Complex<f64>> {
    let n = m.ncols();
    let svd = m.svd(false, true);
    let smallest = svd.singular_values.imin();
    match svd.v_t {
        Some(v_t) => v_t.row(smallest).adjoint(),
        None => DVector::from_element(n, Complex::from(0.0)),
    }
}

/// Parlett–Reinsch balancing (powers of two, so exact): returns `D⁻¹·A·D`
/// and the diagonal of D. A diagonal similarity leaves the eigenvalues
/// unchanged and makes the small ones of badly scaled matrices accurate.
pub(crate) fn balance(a: &DMatrix<f64>) -> (DMatrix<f64>, DVector<f64>) {
    let n = a.nrows();
    let mut b = a.clone();
    let mut d = DVector::from_element(n, 1.0);
    let mut converged = false;
    let mut sweeps = 0;
    while !converged && sweeps < 100 {
        converged = true;
        sweeps += 1;
        for i in 0..n {
            let column: f64 = (0..n).filter(|&k| k != i).map(|k| b[(k, i)].abs()).sum();
            let row: f64 = (0..n).filter(|&k| k != i).map(|k| b[(i, k)].abs()).sum();
            if column == 0.0 || row == 0.0 {
                continue;
            }
            let mut factor = 1.0;
            let (mut c, mut r) = (column, row);
            while c < r / 2.0 {
                c *= 2.0;
                r /= 2.0;
                factor *= 2.0;
            }
            while c >= r * 2.0 {
                c /= 2.0;
                r *= 2.0;
                factor /= 2.0;
            }
            if (c + r) < 0.95 * (column + row) {
                converged = false;
                d[i] *= factor;
                for k in 0..n {
                    b[(k, i)] *= factor;
                    b[(i, k)] /= factor;
                }
            }
        }
    }
    (b, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_sim::aircraft::Aircraft;
    use aeroid_sim::dynamics::Environment;
    use aeroid_sim::trim::{TrimCondition, trim};

    fn attas() -> FlightModel {
        let path = aeroid_core::catalog::source_tree().join("aircraft/attas.toml");
        FlightModel::new(Aircraft::load(&path).unwrap(), Environment::default())
    }

    fn condition() -> TrimCondition {
        TrimCondition {
            airspeed: 103.0,
            altitude: 4877.0,
            flight_path_angle: 0.0,
            heading: 0.3,
            flap: 0.0,
        }
    }

    /// Balancing is a similarity: D⁻¹·A·D reproduces A and its eigenvalues.
    #[test]
    fn balancing_is_a_similarity() {
        let a = DMatrix::from_row_slice(3, 3, &[1.0, 1e4, 0.0, 1e-4, 2.0, 3e3, 0.0, 1e-3, -1.0]);
        let (b, d) = balance(&a);
        let back = DMatrix::from_diagonal(&d) * b * DMatrix::from_diagonal(&d.map(|x| 1.0 / x));
        assert!((back - &a).norm() < 1e-12 * a.norm());
        assert!(d.iter().any(|&x| x != 1.0));
    }

    /// The Euler-angle state round-trips through the simulator state.
    #[test]
    fn euler_state_round_trips() {
        let model = attas();
        let trimmed = trim(&model, &condition(), &WindSample::default()).unwrap();
        let mut e = euler_state(&trimmed.state, false);
        e[PHI] = 0.2;
        e[THETA] = -0.1;
        e[H] = 1234.0;
        e[V] = 3.0;
        let back = euler_state(&full_state(&e, &trimmed.state), false);
        assert!((back - e).amax() < 1e-12);
    }

    /// Gravity-free, aerodynamics-free flight: the only dynamics left are the
    /// kinematics, whose Jacobian is known in closed form. At u = V, θ = θ0,
    /// φ = ψ = 0 with zero rates: u̇ = r·v − q·w (so ∂u̇/∂q = −w, ∂u̇/∂r = v),
    /// φ̇ = p + tan θ0·r, θ̇ = q, ψ̇ = r/cos θ0, ḣ = u sin θ0 − w cos θ0 (for
    /// v = 0; ∂ḣ/∂θ = u cos θ0 + w sin θ0).
    #[test]
    fn kinematics_only_model_matches_closed_form() {
        let mut model = attas();
        model.environment.gravity = 0.0;
        let oswald = model.aircraft.aero.parameters.index("e").unwrap();
        for (i, value) in model
            .aircraft
            .aero
            .parameters
            .values_mut()
            .iter_mut()
            .enumerate()
        {
            *value = if i == oswald { 1.0 } else { 0.0 };
        }
        model.aircraft.propulsion.max_thrust = 0.0;
        let theta0: f64 = 0.1;
        let (u0, w0) = (100.0, 5.0);
        let mut x = StateVector::zeros();
        x[state::U] = u0;
        x[state::W] = w0;
        x[DOWN] = -1000.0;
        state::set_attitude(
            &mut x,
            &state::quaternion_from_euler(EulerAngles {
                roll: 0.0,
                pitch: theta0,
                yaw: 0.0,
            }),
        );
        let mut aircraft_controls = Controls::zeros();
        aircraft_controls[Control::Throttle.index()] = 0.5;
        let linear = linearize_at(&model, &x, &aircraft_controls, &WindSample::default());
        let mut expected = DMatrix::zeros(10, 10);
        expected[(U, Q)] = -w0;
        expected[(W, Q)] = u0;
        expected[(U, V)] = 0.0;
        expected[(V, P)] = w0;
        expected[(V, R)] = -u0;
        expected[(PHI, P)] = 1.0;
        expected[(PHI, R)] = theta0.tan();
        expected[(THETA, Q)] = 1.0;
        expected[(PSI, R)] = 1.0 / theta0.cos();
        expected[(H, U)] = theta0.sin();
        expected[(H, W)] = -theta0.cos();
        expected[(H, THETA)] = u0 * theta0.cos() + w0 * theta0.sin();
        let error = (&linear.a - &expected).amax();
        assert!(error < 1e-8, "A = {}\nexpected {}", linear.a, expected);
        assert!(linear.b.amax() < 1e-12);
    }

    /// The pitch stiffness ∂q̇/∂w of ATTAS at trim in closed form: α = atan(w/u)
    /// gives ∂α/∂w = u/(u² + w²), and q̄ = ½ρ(u² + v² + w²) gives ∂q̄/∂w = ρw, so
    /// `∂q̇/∂w = (q̄·S·c̄·Cmα·u/(u² + w²) + ρ·w·S·c̄·Cm)/Iyy` with Cm the trim
    /// value Cm0 + Cmα·α + Cmδe·δe (not zero: it balances the thrust's moment).
    #[test]
    fn pitch_stiffness_matches_closed_form() {
        let model = attas();
        let trimmed = trim(&model, &condition(), &WindSample::default()).unwrap();
        let linear = linearize(&model, &trimmed, &WindSample::default());
        let x = &trimmed.state;
        let (u, w) = (x[state::U], x[state::W]);
        let aircraft = &model.aircraft;
        let get = |name: &str| aircraft.aero.parameters.get(name).unwrap();
        let rho = model.environment.atmosphere.at(4877.0).density;
        let dynamic_pressure = 0.5 * rho * state::velocity(x).norm_squared();
        let (s, c) = (aircraft.wing_area, aircraft.geometry.chord);
        let cm = get("Cm_0")
            + get("Cm_alpha") * trimmed.alpha
            + get("Cm_de") * trimmed.controls[Control::Elevator.index()];
        assert!(cm.abs() > 1e-4);
        let expected = (dynamic_pressure * s * c * get("Cm_alpha") * u / (u * u + w * w)
            + rho * w * s * c * cm)
            / aircraft.mass.inertia[(1, 1)];
        let error = (linear.a[(Q, W)] - expected).abs() / expected.abs();
        assert!(error < 1e-8, "{} vs {expected}", linear.a[(Q, W)]);
    }

    /// With the stall model's χ as a state (τ1 > 0, τ2 = 0) the linear model
    /// has eleven states, and χ̇ = (χ∞(α) − χ)/τ1 with
    /// χ∞ = ½(1 − tanh(a1(α − α*))) gives ∂χ̇/∂χ = −1/τ1 and
    /// ∂χ̇/∂w = χ∞'(α)·u/(u² + w²)/τ1 in closed form; the fast lag it adds is
    /// classified as "other".
    #[test]
    fn separation_point_state_matches_closed_form() {
        let (a1, alpha_star, tau1) = (23.7, 0.309, 0.2);
        let path = aeroid_core::catalog::source_tree().join("aircraft/attas.toml");
        let text = std::fs::read_to_string(path)
            .unwrap()
            .replace("model = \"linear\"", "model = \"stall\"")
            + &format!(
                "\n[aero.stall]\na1 = {a1}\nalpha_star = {alpha_star}\ntau1 = {tau1}\ntau2 = 0.0\n"
            );
        let file = toml::from_str(&text).unwrap();
        let aircraft = Aircraft::from_file(&file, std::path::Path::new("stall")).unwrap();
        let model = FlightModel::new(aircraft, Environment::default());
        let trimmed = trim(&model, &condition(), &WindSample::default()).unwrap();
        let linear = linearize(&model, &trimmed, &WindSample::default());
        assert_eq!(linear.a.nrows(), 11);
        assert_eq!(linear.state_names[CHI_E], "chi");
        assert!((linear.a[(CHI_E, CHI_E)] + 1.0 / tau1).abs() < 1e-8);
        let (u, w) = (trimmed.state[state::U], trimmed.state[state::W]);
        let slope = -0.5 * a1 / (a1 * (trimmed.alpha - alpha_star)).cosh().powi(2);
        let expected = slope * u / (u * u + w * w) / tau1;
        let error = (linear.a[(CHI_E, W)] - expected).abs() / expected.abs();
        assert!(error < 1e-7, "{} vs {expected}", linear.a[(CHI_E, W)]);
        let modes = linear.modes();
        let lag = modes
            .iter()
            .find(|m| (m.eigenvalue.re + 1.0 / tau1).abs() < 0.5)
            .unwrap();
        assert_eq!(lag.kind, ModeKind::Other);
        assert!(find(&modes, ModeKind::ShortPeriod).is_some());
    }

    /// A linear oscillator embedded in a matrix: participation factors find
    /// its states, and the two slowest longitudinal pairs are ordered.
    #[test]
    fn classification_by_participation_and_frequency() {
        let mut a = DMatrix::zeros(10, 10);
        // Short period on (w, q): ωn = 3, ζ = 0.5; phugoid on (u, θ): ωn = 0.1, ζ = 0.05.
        let pair = |a: &mut DMatrix<f64>, i: usize, j: usize, wn: f64, zeta: f64| {
            a[(i, j)] = 1.0;
            a[(j, i)] = -wn * wn;
            a[(j, j)] = -2.0 * zeta * wn;
        };
        pair(&mut a, W, Q, 3.0, 0.5);
        pair(&mut a, THETA, U, 0.1, 0.05);
        pair(&mut a, V, R, 1.5, 0.1);
        a[(P, P)] = -2.0;
        a[(PHI, PHI)] = -0.01;
        a[(PHI, P)] = 1.0;
        a[(H, H)] = -0.001;
        let linear = Linearization {
            a,
            b: DMatrix::zeros(10, 5),
            state_names: EULER_STATE_NAMES[..10].to_vec(),
            control_names: vec![],
            state: DVector::zeros(10),
            controls: Controls::zeros(),
        };
        let modes = linear.modes();
        let get = |kind| find(&modes, kind).unwrap();
        let sp = get(ModeKind::ShortPeriod);
        assert!((sp.natural_frequency - 3.0).abs() < 1e-12);
        assert!((sp.damping_ratio - 0.5).abs() < 1e-12);
        let ph = get(ModeKind::Phugoid);
        assert!((ph.natural_frequency - 0.1).abs() < 1e-12);
        assert!((ph.damping_ratio - 0.05).abs() < 1e-10);
        assert!((get(ModeKind::DutchRoll).natural_frequency - 1.5).abs() < 1e-12);
        assert!((get(ModeKind::Roll).eigenvalue.re + 2.0).abs() < 1e-12);
        assert!((get(ModeKind::Spiral).eigenvalue.re + 0.01).abs() < 1e-12);
        assert!((get(ModeKind::Height).eigenvalue.re + 0.001).abs() < 1e-12);
        assert_eq!(get(ModeKind::Other).eigenvalue, Complex::new(0.0, 0.0));
        assert_eq!(modes.len(), 7);
    }
}
