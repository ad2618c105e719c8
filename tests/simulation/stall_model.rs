//! The quasi-steady stall model with Kirchhoff flow separation (Verma & Peyada 2020,
//! Eqs. 2–4): static lift curve, first-order χ dynamics, τ2 hysteresis, and
//! α̇ taken from the state derivative in the full simulator.

use crate::common;
use aeroid::sim::aero::{AeroInput, AeroModel};
use aeroid::sim::aircraft::Aircraft;
use aeroid::sim::integrator::rk4_step;
use nalgebra::Vector1;

const A1: f64 = 23.7;
const ALPHA_STAR: f64 = 0.309;
const CL0: f64 = 0.158;
const CL_ALPHA: f64 = 3.30;

/// ATTAS with the stall model of DATA.md, τ1 and τ2 as given.
fn stall_aircraft(tau1: f64, tau2: f64) -> Aircraft {
    let text = common::attas_with(|text| {
        text.replace("model = \"linear\"", "model = \"stall\"")
            .replace("[aero.CD]", "[aero.CD]\nchi = 0.079")
            .replace("[aero.Cm]", "[aero.Cm]\nchi = -0.126")
            + &format!(
                "\n[aero.stall]\na1 = {A1}\nalpha_star = {ALPHA_STAR}\ntau1 = {tau1}\ntau2 = {tau2}\n"
            )
    });
    let file = toml::from_str(&text).unwrap();
    Aircraft::from_file(&file, std::path::Path::new("attas-stall-test")).unwrap()
}

fn closed_form_chi(alpha: f64) -> f64 {
    0.5 * (1.0 - (A1 * (alpha - ALPHA_STAR)).tanh())
}

fn input(model: &AeroModel, alpha: f64, alpha_dot: f64, chi: f64) -> AeroInput {
    let _ = model;
    AeroInput {
        alpha,
        alpha_dot,
        chi,
        airspeed: 85.0,
        mach: 0.26,
        ..Default::default()
    }
}

/// With τ1 = 0 the static CL(α) curve equals CL0 + CLα·((1+√χ)/2)²·α with
/// χ = ½(1 − tanh(a1(α − α*))) to 1e-12 (evaluated with q = δe = 0; the
/// ATTAS CL has no other terms at that point).
#[test]
fn static_lift_curve_matches_closed_form() {
    let model = stall_aircraft(0.0, 0.9).aero;
    assert!(!model.chi_is_state());
    for i in 0..=400 {
        let alpha = -0.1 + 0.6 * i as f64 / 400.0;
        let chi = closed_form_chi(alpha);
        let expected = CL0 + CL_ALPHA * (0.5 * (1.0 + chi.sqrt())).powi(2) * alpha;
        let lift = model
            .coefficients(&input(&model, alpha, 0.0, f64::NAN))
            .lift;
        assert!(
            (lift - expected).abs() < 1e-12,
            "α = {alpha}: {lift} vs {expected}"
        );
    }
    // The curve really stalls: lift falls past α*.
    let lift = |alpha| model.coefficients(&input(&model, alpha, 0.0, 0.0)).lift;
    assert!(lift(0.30) > lift(0.40) && lift(0.40) < 0.8 * lift(0.30));
}

/// With τ1 > 0 a step in α makes χ relax to its new equilibrium as a first
/// order lag; the time constant fitted by log-linear least squares to the
/// integrated χ(t) equals τ1 within 1 % (RK4 at τ1/100 is exact to ~1e-9).
#[test]
fn separation_point_lags_alpha_step_with_tau1() {
    let tau1 = 0.35;
    let model = stall_aircraft(tau1, 0.9).aero;
    assert!(model.chi_is_state());
    let (alpha_before, alpha_after) = (0.25, 0.33);
    let target = model.steady_separation(alpha_after);
    let mut chi = Vector1::new(model.steady_separation(alpha_before));
    let step = tau1 / 100.0;
    let (mut times, mut logs) = (Vec::new(), Vec::new());
    for k in 1..=300 {
        chi = rk4_step(&chi, step, |c, _| {
            Vector1::new(model.separation_rate(alpha_after, 0.0, c[0], 100.0))
        });
        times.push(k as f64 * step);
        logs.push((chi[0] - target).abs().ln());
    }
    let n = times.len() as f64;
    let (mean_t, mean_l) = (times.iter().sum::<f64>() / n, logs.iter().sum::<f64>() / n);
    let slope = times
        .iter()
        .zip(&logs)
        .map(|(t, l)| (t - mean_t) * (l - mean_l))
        .sum::<f64>()
        / times.iter().map(|t| (t - mean_t).powi(2)).sum::<f64>();
    let fitted = -1.0 / slope;
    assert!((fitted / tau1 - 1.0).abs() < 0.01, "fitted τ1 = {fitted}");
}

/// A slow sweep of α up then down at |α̇| = 2°/s: by Eq. 3 the separation
/// point sees α − τ2·α̇, so the upstroke lift equals the static curve at
/// α − τ2·α̇ and the downstroke at α + τ2·|α̇| — a clockwise loop with more
/// lift going up. The loop area equals the integral of the difference of the
/// two shifted static curves (checked to 1e-9), and is not small.
#[test]
fn slow_sweep_shows_tau2_hysteresis() {
    let tau2 = 0.9;
    let model = stall_aircraft(0.0, tau2).aero;
    let rate = 2f64.to_radians();
    let static_lift = |alpha: f64| {
        let chi = closed_form_chi(alpha);
        CL0 + CL_ALPHA * (0.5 * (1.0 + chi.sqrt())).powi(2)
    };
    let (mut area, mut expected_area) = (0.0, 0.0);
    let d_alpha = 1e-4;
    let mut alpha = 0.15;
    while alpha < 0.45 {
        let up = model.coefficients(&input(&model, alpha, rate, 0.0)).lift;
        let down = model.coefficients(&input(&model, alpha, -rate, 0.0)).lift;
        assert!(
            up >= down,
            "at α = {alpha}: upstroke {up} below downstroke {down}"
        );
        area += (up - down) * d_alpha;
        expected_area +=
            alpha * (static_lift(alpha - tau2 * rate) - static_lift(alpha + tau2 * rate)) * d_alpha;
        alpha += d_alpha;
    }
    assert!(
        (area - expected_area).abs() < 1e-9,
        "{area} vs {expected_area}"
    );
    assert!(area > 0.01, "loop area {area}");
}

/// In the full simulator with χ algebraic (τ1 = 0, τ2 = 0.9 s) the forces
/// depend on α̇ and α̇ on the forces; the simulator solves that loop from the
/// state derivative. Check on a nose-up elevator ramp into the stall: the α̇
/// of the trace equals the central difference of the α trace (error O(h²),
/// below 1e-4 rad/s at h = 0.01 s for this smooth manoeuvre), and χ equals
/// Eq. 3 evaluated at the trace's α and α̇ to 1e-12 (the loop is converged).
#[test]
fn simulator_solves_alpha_dot_loop_from_state_derivative() {
    let mut scenario = aeroid::sim::scenario::Scenario::load("attas-trim").unwrap();
    scenario.aircraft = stall_aircraft(0.0, 0.9);
    scenario.duration = 20.0;
    scenario.trim.airspeed = 95.0;
    let mut simulation = aeroid::sim::Simulation::prepare(&scenario).unwrap();
    simulation.exogenous.truncate(scenario.step_count() + 1);
    for (k, exogenous) in simulation.exogenous.iter_mut().enumerate() {
        let time = k as f64 * scenario.step;
        exogenous[0] -= (0.6f64.to_radians() * time).min(8f64.to_radians());
    }
    simulation.winds.truncate(simulation.exogenous.len());
    let trace = simulation.run().unwrap();
    let alpha = trace.values("alpha").unwrap();
    let alpha_dot = trace.values("alpha_dot").unwrap();
    let chi = trace.values("chi").unwrap();
    let step = scenario.step;
    let mut largest_difference: f64 = 0.0;
    for k in 1..alpha.len() - 1 {
        let differenced = (alpha[k + 1] - alpha[k - 1]) / (2.0 * step);
        largest_difference = largest_difference.max((differenced - alpha_dot[k]).abs());
        let eq3 = closed_form_chi(alpha[k] - 0.9 * alpha_dot[k]);
        assert!(
            (chi[k] - eq3).abs() < 1e-12,
            "t = {}: χ {} vs Eq. 3 {}",
            k as f64 * step,
            chi[k],
            eq3
        );
    }
    assert!(
        largest_difference < 1e-4,
        "α̇ differs from differenced α by {largest_difference}"
    );
    let peak_alpha = alpha.iter().cloned().fold(f64::MIN, f64::max);
    let lowest_chi = chi.iter().cloned().fold(f64::MAX, f64::min);
    assert!(
        peak_alpha > ALPHA_STAR && lowest_chi < 0.3,
        "the ramp reached the stall: α {peak_alpha}, χ {lowest_chi}"
    );
}

/// Truth for a linear postulate of a stall-model flight is the local
/// derivative at trim (DESIGN.md). For the linear ATTAS the local derivatives
/// equal the file's parameters (to 1e-8: central differences of a linear
/// function are exact up to rounding); for the stall model the local lift
/// slope equals the analytic derivative of Eq. 4 with Eq. 3,
/// CLα·[K + α·dK/dχ·dχ/dα], K = ((1+√χ)/2)², to 1e-6 (difference step 1e-5).
#[test]
fn local_derivatives_at_trim() {
    let linear = Aircraft::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/aircraft/attas.toml"
    )))
    .unwrap()
    .aero;
    let at = AeroInput {
        alpha: 0.15,
        beta: 0.01,
        airspeed: 100.0,
        mach: 0.3,
        ..Default::default()
    };
    let local: std::collections::HashMap<String, f64> =
        linear.local_derivatives(&at).into_iter().collect();
    for name in [
        "CL_alpha", "CL_q", "CL_de", "Cm_alpha", "Cm_q", "Cl_p", "Cn_r", "CY_beta", "Cn_dr",
        "CL_0", "Cm_0",
    ] {
        let exact = linear.parameters.get(name).unwrap();
        assert!(
            (local[name] - exact).abs() < 1e-8,
            "{name}: {} vs {exact}",
            local[name]
        );
    }
    assert!(
        local["Cm_beta"].abs() < 1e-12,
        "absent terms have zero local derivative"
    );

    let stall = stall_aircraft(0.0, 0.9).aero;
    let alpha = 0.28;
    let local: std::collections::HashMap<String, f64> = stall
        .local_derivatives(&AeroInput {
            alpha,
            airspeed: 85.0,
            mach: 0.26,
            ..Default::default()
        })
        .into_iter()
        .collect();
    let chi = closed_form_chi(alpha);
    let k = (0.5 * (1.0 + chi.sqrt())).powi(2);
    let dk_dchi = (1.0 + chi.sqrt()) / (4.0 * chi.sqrt());
    let dchi_dalpha = -0.5 * A1 / (A1 * (alpha - ALPHA_STAR)).cosh().powi(2);
    let expected = CL_ALPHA * (k + alpha * dk_dchi * dchi_dalpha);
    assert!(
        (local["CL_alpha"] - expected).abs() < 1e-6,
        "{} vs {expected}",
        local["CL_alpha"]
    );
    assert!(
        local["CL_alpha"] < 0.6 * CL_ALPHA,
        "near stall the local slope is far below CLα"
    );
}
