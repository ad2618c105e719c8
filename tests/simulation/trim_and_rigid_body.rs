//! Acceptance tests of the 6-DOF core: trim holds, and a torque-free rigid
//! body conserves angular momentum and rotational kinetic energy.

use aeroid::sim::Simulation;
use aeroid::sim::aircraft::Aircraft;
use aeroid::sim::dynamics::{Environment, Exogenous, FlightModel};
use aeroid::sim::integrator::Interpolation;
use aeroid::sim::scenario::{DepartureLimits, Scenario};
use aeroid::sim::state::{self, StateVector};
use aeroid::sim::trim::Trim;
use aeroid::sim::wind::WindSample;
use nalgebra::Vector3;

/// From a trimmed state with no input and no wind, 60 s of flight stays
/// within 1e-6 of trim in every state. Relative to each state's trim value,
/// with a floor of 1 in that state's unit for states that are zero at trim
/// (rates, roll, the trim residual is ~1e-15 so any error in the equations or
/// the trim shows as a drift many orders larger). Position is compared with
/// the straight line the trim ground velocity predicts.
#[test]
fn trim_holds_for_sixty_seconds() {
    let scenario = Scenario::load("attas-trim").unwrap();
    assert!(scenario.inputs.is_empty() && scenario.duration == 60.0);
    let simulation = Simulation::prepare(&scenario).unwrap();
    let trace = simulation.run().unwrap();
    let x0 = simulation.trim.state;
    let ground_velocity = state::body_to_ned(&x0) * state::velocity(&x0);
    let mut worst = (0.0, "", 0.0);
    for sample in &trace.samples {
        let mut expected = x0;
        expected
            .fixed_rows_mut::<3>(state::NORTH)
            .copy_from(&(x0.fixed_rows::<3>(state::NORTH) + ground_velocity * sample.time));
        for (i, (name, _)) in state::STATE_NAMES.iter().enumerate() {
            let scale = expected[i].abs().max(1.0);
            let error = (sample.state[i] - expected[i]).abs() / scale;
            if error > worst.0 {
                worst = (error, name, sample.time);
            }
        }
    }
    assert!(
        worst.0 < 1e-6,
        "state {} drifted by {:.3e} (relative) at t = {} s",
        worst.1,
        worst.0,
        worst.2
    );
    assert!(simulation.trim.residual < 1e-10);
}

/// A rigid body with no aerodynamics, thrust or gravity.
fn torque_free_body() -> FlightModel {
    let text = r#"
name = "torque-free body"
[geometry]
wing_area = 1.0
span = 1.0
chord = 1.0
[mass]
mass = 100.0
ixx = 120.0
iyy = 250.0
izz = 310.0
ixz = 35.0
[aero]
"#;
    let file = toml::from_str(text).unwrap();
    let aircraft = Aircraft::from_file(&file, std::path::Path::new("torque-free")).unwrap();
    FlightModel::new(
        aircraft,
        Environment {
            gravity: 0.0,
            ..Default::default()
        },
    )
}

/// Angular momentum in inertial (NED) axes and rotational kinetic energy.
fn momentum_and_energy(model: &FlightModel, x: &StateVector) -> (Vector3<f64>, f64) {
    let omega = state::rates(x);
    let body_momentum = model.aircraft.mass.inertia * omega;
    (
        state::body_to_ned(x) * body_momentum,
        0.5 * omega.dot(&body_momentum),
    )
}

/// Torque-free rigid body with an asymmetric inertia including Ixz, tumbling
/// about all three axes: angular momentum (inertial axes) and rotational
/// kinetic energy are conserved to 1e-9 relative over 100 s. RK4 at 1 ms has
/// a local error of ~(ωh)⁵ ≈ 1e-15 per step, so 1e5 steps stay far below
/// 1e-9 unless the Euler equations or the quaternion kinematics are wrong.
/// The quaternion's norm after each raw RK4 step (before renormalisation)
/// stays within 1e-12 of one, which an incorrect kinematic matrix breaks.
#[test]
fn torque_free_body_conserves_momentum_and_energy() {
    let model = torque_free_body();
    let mut x = StateVector::zeros();
    x[state::U] = 50.0;
    x[state::P] = 0.7;
    x[state::Q] = -1.1;
    x[state::R] = 0.4;
    state::set_attitude(
        &mut x,
        &state::quaternion_from_euler(state::EulerAngles {
            roll: 0.2,
            pitch: 0.1,
            yaw: -0.3,
        }),
    );
    x[state::DOWN] = -1000.0;
    let (momentum0, energy0) = momentum_and_energy(&model, &x);
    let steps = 100_000;
    let simulation = Simulation {
        name: "torque-free".into(),
        model,
        changed_models: Vec::new(),
        trim: Trim {
            state: x,
            controls: Default::default(),
            alpha: 0.0,
            beta: 0.0,
            pitch: 0.0,
            residual: 0.0,
            iterations: 0,
        },
        step: 0.001,
        interpolation: Interpolation::ZeroOrderHold,
        departure: DepartureLimits {
            max_alpha: 10.0,
            max_beta: 10.0,
            min_airspeed: 0.0,
            max_airspeed: 1e9,
            min_altitude: -1e9,
        },
        exogenous: vec![Exogenous::pack(&Default::default(), &WindSample::default()); steps + 1],
        winds: vec![WindSample::default(); steps + 1],
        feedback: None,
    };
    let mut worst_norm = 0.0f64;
    for k in 0..steps {
        let raw = aeroid::sim::integrator::rk4_step(&x, simulation.step, |x, _| {
            simulation.model.derivative(x, &Exogenous::default())
        });
        worst_norm = worst_norm.max((raw.fixed_rows::<4>(state::Q0).norm() - 1.0).abs());
        x = simulation.advance(&x, k);
    }
    let (momentum, energy) = momentum_and_energy(&simulation.model, &x);
    let momentum_error = (momentum - momentum0).norm() / momentum0.norm();
    let energy_error = (energy - energy0).abs() / energy0;
    assert!(
        momentum_error < 1e-9,
        "angular momentum changed by {momentum_error:.3e}"
    );
    assert!(
        energy_error < 1e-9,
        "kinetic energy changed by {energy_error:.3e}"
    );
    assert!(
        worst_norm < 1e-12,
        "quaternion norm drifted by {worst_norm:.3e} in one step"
    );
    // The body kept tumbling: the test exercised all three axes.
    assert!(state::rates(&x).iter().all(|w| w.abs() > 1e-3));
    // With no force the inertial velocity is constant too.
    let ground_velocity = state::body_to_ned(&x) * state::velocity(&x);
    assert!(
        (ground_velocity
            - state::body_to_ned(&simulation.trim.state) * Vector3::new(50.0, 0.0, 0.0))
        .norm()
            < 1e-9
    );
}
