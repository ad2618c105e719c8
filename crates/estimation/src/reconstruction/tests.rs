//! Tests of the reconstruction: it inverts the simulator's equations of
//! motion, with the accelerometers at the CG and away from it.

use super::*;
use aeroid_sim::dynamics::Exogenous;
use aeroid_sim::state::{P, Q, R};

/// The reconstruction inverts the simulator exactly: at a trimmed ATTAS
/// state given rates p, q, r and deflected controls, the load factors,
/// angular accelerations, throttle, altitude and q̄ of `dynamics.rs`
/// give back the coefficients the aero model produced, to 1e-12 — a
/// check of the signs of every term (Ixz couplings, thrust moment with
/// the engine 1.5 m above the centre of gravity, nz positive up).
#[test]
fn reconstruction_inverts_the_equations_of_motion() {
    inverts_the_equations_of_motion(Vector3::zeros());
}

/// The same with the accelerometers 6 m ahead of, 1.5 m right of and
/// 0.8 m above the CG: the load factors the recorder writes there
/// (`aeroid_record::derived::load_factor`) carried back to the CG give
/// the coefficients to 1e-12 (read as if at the CG, CZ would be off
/// by Δa·m/(q̄S), which the check below shows is not small).
#[test]
fn reconstruction_carries_the_accelerometers_to_the_cg() {
    inverts_the_equations_of_motion(Vector3::new(6.0, 1.5, -0.8));
}

fn inverts_the_equations_of_motion(arm: Vector3<f64>) {
    let scenario = aeroid_sim::scenario::Scenario::load("attas-trim").unwrap();
    let simulation = aeroid_sim::Simulation::prepare(&scenario).unwrap();
    let aircraft = &scenario.aircraft;
    let mut x = simulation.trim.state;
    (x[P], x[Q], x[R]) = (0.1, -0.05, 0.08);
    let mut controls = simulation.trim.controls;
    controls[Control::Elevator.index()] += 0.02;
    controls[Control::Aileron.index()] -= 0.03;
    controls[Control::Rudder.index()] += 0.01;
    let exogenous = Exogenous {
        controls,
        ..Default::default()
    };
    let evaluation = simulation.model.evaluate(&x, &exogenous);
    let omega = Vector3::new(x[P], x[Q], x[R]);
    let at_sensor = evaluation.specific_force
        + evaluation.angular_acceleration.cross(&arm)
        + omega.cross(&omega.cross(&arm));
    let shift = (at_sensor - evaluation.specific_force) * aircraft.mass.mass
        / (evaluation.air_data.dynamic_pressure * aircraft.wing_area);
    assert!(
        arm == Vector3::zeros() || shift.norm() > 1e-3,
        "the sensor's place matters: {shift}"
    );
    let f = at_sensor / STANDARD_GRAVITY;
    let air = &evaluation.air_data;
    let values = [
        ("nx", f.x),
        ("ny", f.y),
        ("nz", -f.z),
        ("alpha", air.alpha),
        ("beta", air.beta),
        ("airspeed", air.airspeed),
        ("p", x[P]),
        ("q", x[Q]),
        ("r", x[R]),
        ("throttle", controls[Control::Throttle.index()]),
        ("altitude", aeroid_sim::state::altitude(&x)),
        ("dynamic_pressure", air.dynamic_pressure),
        ("elevator", controls[Control::Elevator.index()]),
        ("aileron", controls[Control::Aileron.index()]),
        ("rudder", controls[Control::Rudder.index()]),
    ];
    let sampled: BTreeMap<&str, Vec<f64>> =
        values.iter().map(|(name, v)| (*name, vec![*v])).collect();
    let omega_dot = evaluation.angular_acceleration;
    let derivatives: BTreeMap<&str, Vec<f64>> = [
        ("p", vec![omega_dot.x]),
        ("q", vec![omega_dot.y]),
        ("r", vec![omega_dot.z]),
    ]
    .into_iter()
    .collect();
    let signals = Signals::new(&sampled, &derivatives);
    let request = Request {
        coefficients: Coefficient::ALL.to_vec(),
        regressors: vec![Regressor::Beta, Regressor::RollRate, Regressor::Aileron],
    };
    let (measured, regressors) = sample(aircraft, &request, &signals, 0, &arm).unwrap();
    let c = &evaluation.coefficients;
    let expected = [
        c.lift, c.force.y, c.drag, c.moment.x, c.moment.y, c.moment.z,
    ];
    for (i, (m, e)) in measured.iter().zip(expected).enumerate() {
        assert!(
            (m - e).abs() < 1e-12,
            "{:?}: {m} vs {e}",
            Coefficient::ALL[i]
        );
    }
    let thrust_moment = aircraft
        .propulsion
        .position
        .cross(&(aircraft.propulsion.direction * evaluation.thrust));
    assert!(
        thrust_moment.y.abs() > 1e3,
        "the check includes a thrust moment"
    );
    let p_hat = x[P] * aircraft.geometry.span / (2.0 * air.airspeed);
    assert!((regressors[Regressor::RollRate as usize] - p_hat).abs() < 1e-15);
}
