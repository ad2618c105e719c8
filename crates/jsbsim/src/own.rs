//! JSBSim's own aircraft as truth: a scenario whose aircraft
//! is `"jsbsim:NAME"` is trimmed and flown by JSBSim, read back as aeroid's
//! truth trace ([`super::flight`]) for the recorder, and its truth is the local
//! derivative of JSBSim's aerodynamics at the trim point
//! ([`super::derivatives`]; DESIGN.md, "Truth when the structures differ").
//!
//! Conventions and choices (each one a trap met on the 737; docs/jsbsim.md lists
//! them with the agreement found):
//! - World: the aircraft flies over aeroid's flat, non-rotating earth with the
//!   scenario's constant gravity (the planet of [`super::export`], loaded with
//!   `FGFDMExec::LoadPlanet`), so that the equations the estimators postulate
//!   (DESIGN.md, "Models") hold; the atmosphere is JSBSim's standard one
//!   (with `atmosphere/delta-T` from the scenario's temperature offset).
//! - In flight: every engine running (`propulsion/set-running = -1`; the 737
//!   trims only so) and the gear up (`gear/gear-cmd-norm = 0` where it
//!   exists), then the scenario's `[jsbsim] properties`; JSBSim's full trim at
//!   the scenario's true airspeed, altitude, flight-path angle and heading.
//! - Controls go through the flight-control system, as a pilot's would:
//!   `fcs/elevator-cmd-norm`, `fcs/aileron-cmd-norm`, `fcs/rudder-cmd-norm`
//!   (normalised commands) and every engine's `fcs/throttle-cmd-norm[i]`. An
//!   input of Δ rad moves the command by Δ over the surface's measured
//!   deflection per unit command (0.3 rad for the 737's elevator, 0.35 for its
//!   ailerons and rudder). What is recorded is the surface position JSBSim's
//!   aerodynamics used, in aeroid's sign (DESIGN.md "Controls"):
//!   elevator `fcs/elevator-pos-rad`, aileron `−fcs/left-aileron-pos-rad`
//!   (JSBSim's positive aileron rolls right, Clδa > 0; aeroid's rolls left),
//!   rudder `fcs/rudder-pos-rad`. Any feedback the FCS adds (the 737's yaw
//!   damper, r into the rudder) is in the recorded surface, as on a real
//!   aircraft. Flaps are held (set them with `[jsbsim] properties`).
//! - Thrust is recorded as measured: the `throttle` of the trace is JSBSim's
//!   propulsion force over the rigid body's `max_thrust` (whose thrust model is
//!   then T = δT·Tmax with `density_exponent = 0`), so that the estimators'
//!   equations of motion get JSBSim's thrust. A throttle input moves every
//!   engine's command by the same amount.
//! - The rigid body the estimators use is an aeroid aircraft file
//!   (`[jsbsim] rigid_body`); its mass, inertia, geometry and thrust line are
//!   checked against JSBSim's at the trim point ([`check_rigid_body`]).

use super::derivatives::{LocalDerivatives, SurfaceBinding, local_derivatives};
use super::export::write_planet;
use super::flight::{ControlCommand, ControlReading, JsbsimFlight};
use super::{Exec, FT, InitialConditions, InitialSpeed, LBF, SLUG, TrimMode};
use crate::error::{Error, Result};
use aeroid_core::error::FieldError;
use aeroid_sim::aircraft::Aircraft;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::state::{CONTROL_COUNT, Control, Controls};
use aeroid_sim::trace::TruthTrace;
use aeroid_sim::truth::{RunTruth, TrimPoint, TruthKind};
use aeroid_sim::{Departure, Flight};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// JSBSim steps per aeroid step (as the cross-check's, see
/// [`super::crosscheck::DEFAULT_SUBSTEPS`]).
pub const SUBSTEPS: usize = super::crosscheck::DEFAULT_SUBSTEPS;

/// How aeroid's elevator, aileron and rudder map onto JSBSim's standard
/// flight-control properties: (command, surface position, aeroid sign).
pub const SURFACES: [(&str, &str, f64); 3] = [
    ("fcs/elevator-cmd-norm", "fcs/elevator-pos-rad", 1.0),
    ("fcs/aileron-cmd-norm", "fcs/left-aileron-pos-rad", -1.0),
    ("fcs/rudder-cmd-norm", "fcs/rudder-pos-rad", 1.0),
];

/// Relative tolerance of the rigid-body check (the file's values are
/// rounded to five significant digits).
pub const RIGID_BODY_TOLERANCE: f64 = 1e-3;

/// `Ok` when JSBSim's root has `aircraft/MODEL/MODEL.xml`; else an error
/// naming the file looked for and the aircraft there are.
pub fn check_model(model: &str) -> Result<()> {
    let aircraft = super::default_root().join("aircraft");
    let file = aircraft.join(model).join(format!("{model}.xml"));
    if !model.is_empty() && !model.contains(['/', '\\']) && file.is_file() {
        return Ok(());
    }
    let mut known: Vec<String> = std::fs::read_dir(&aircraft)
        .map(|entries| {
            entries
                .filter_map(|entry| entry.ok())
                .filter_map(|entry| entry.file_name().into_string().ok())
                .filter(|name| aircraft.join(name).join(format!("{name}.xml")).is_file())
                .collect()
        })
        .unwrap_or_default();
    known.sort();
    Err(Error::NoAircraft {
        model: model.into(),
        file,
        known,
    })
}

/// A JSBSim aircraft trimmed at a scenario's condition.
pub struct Trimmed {
    pub exec: Exec,
    /// The trim point (true airspeed, α, β, attitude, rates).
    pub at: InitialConditions,
    /// True airspeed (m/s), α and β (rad) at trim, as in `at`.
    pub airspeed: f64,
    pub alpha: f64,
    pub beta: f64,
    /// Pilot commands at trim: elevator, aileron, rudder.
    pub surface_commands: [f64; 3],
    /// Throttle command at trim and the engines' command properties.
    pub throttle_command: f64,
    pub throttle_properties: Vec<String>,
}

fn invalid(scenario: &Scenario, field: &str, message: impl Into<String>) -> Error {
    aeroid_core::Error::Invalid {
        path: scenario.path.clone(),
        problems: vec![FieldError {
            field: field.into(),
            message: message.into(),
        }],
    }
    .into()
}

/// Loads the scenario's JSBSim aircraft over aeroid's flat earth, sets it up
/// in flight and trims it with JSBSim's full trim.
pub fn trim(scenario: &Scenario) -> Result<Trimmed> {
    let jsbsim = scenario
        .jsbsim
        .as_ref()
        .ok_or_else(|| invalid(scenario, "aircraft", "is not one of JSBSim's aircraft"))?;
    if scenario.trim.flap != 0.0 {
        return Err(invalid(
            scenario,
            "trim.flap",
            "a JSBSim aircraft's flaps are set with [jsbsim] properties (e.g. \"fcs/flap-cmd-norm\")",
        ));
    }
    check_model(&jsbsim.model).map_err(|error| invalid(scenario, "aircraft", error.to_string()))?;
    let mut exec = Exec::new()?;
    exec.load_model(&jsbsim.model)?;
    load_flat_earth(&mut exec, scenario.environment.gravity)?;
    exec.set("propulsion/set-running", -1.0)?;
    if exec.has_property("gear/gear-cmd-norm")? {
        exec.set("gear/gear-cmd-norm", 0.0)?;
    }
    for (property, value) in &jsbsim.properties {
        exec.set(property, *value).map_err(|error| {
            invalid(
                scenario,
                &format!("jsbsim.properties.\"{property}\""),
                error.to_string(),
            )
        })?;
    }
    exec.set(
        "atmosphere/delta-T",
        scenario.environment.atmosphere.temperature_offset * 1.8,
    )?;
    let condition = &scenario.trim;
    exec.set_initial_conditions(&InitialConditions {
        latitude: 0.0,
        longitude: 0.0,
        altitude: condition.altitude,
        attitude: [0.0, condition.flight_path_angle, condition.heading],
        speed: InitialSpeed::TrueAirspeed {
            speed: condition.airspeed,
            alpha: 0.0,
            beta: 0.0,
        },
        rates: [0.0; 3],
    })?;
    exec.set("ic/gamma-rad", condition.flight_path_angle)?;
    exec.run_ic()?;
    exec.trim(TrimMode::Full)?;
    let (airspeed, alpha, beta) = (
        exec.get("velocities/vt-fps")? * FT,
        exec.get("aero/alpha-rad")?,
        exec.get("aero/beta-rad")?,
    );
    let at = InitialConditions {
        latitude: 0.0,
        longitude: 0.0,
        altitude: exec.get("position/h-sl-ft")? * FT,
        attitude: [
            exec.get("attitude/phi-rad")?,
            exec.get("attitude/theta-rad")?,
            exec.get("attitude/psi-rad")?,
        ],
        speed: InitialSpeed::TrueAirspeed {
            speed: airspeed,
            alpha,
            beta,
        },
        rates: [
            exec.get("velocities/p-rad_sec")?,
            exec.get("velocities/q-rad_sec")?,
            exec.get("velocities/r-rad_sec")?,
        ],
    };
    let mut surface_commands = [0.0; 3];
    for (command, (property, _, _)) in surface_commands.iter_mut().zip(SURFACES) {
        *command = exec.get(property)?;
    }
    let mut throttle_properties = Vec::new();
    while exec.has_property(&format!(
        "fcs/throttle-cmd-norm[{}]",
        throttle_properties.len()
    ))? {
        throttle_properties.push(format!(
            "fcs/throttle-cmd-norm[{}]",
            throttle_properties.len()
        ));
    }
    let throttle_command = match throttle_properties.first() {
        Some(first) => exec.get(first)?,
        None => 0.0,
    };
    Ok(Trimmed {
        exec,
        at,
        airspeed,
        alpha,
        beta,
        surface_commands,
        throttle_command,
        throttle_properties,
    })
}

/// Replaces the model's planet with aeroid's flat earth (see
/// [`super::export`]): a temporary planet file, loaded and removed.
fn load_flat_earth(exec: &mut Exec, gravity: f64) -> Result<()> {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let file: PathBuf = std::env::temp_dir().join(format!(
        "aeroid-planet-{}-{}.xml",
        std::process::id(),
        COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    let mut text = String::from("<?xml version=\"1.0\"?>\n");
    write_planet(&mut text, gravity);
    aeroid_core::atomic::write_text(&file, &text)?;
    let result = exec.load_planet(&file);
    // The file is read completely while loading; a file left behind is harmless.
    let _ = std::fs::remove_file(&file);
    result
}

impl Trimmed {
    /// The elevator, aileron and rudder bindings at trim (commands perturbed,
    /// positions read back, aeroid's sign).
    pub fn surfaces(&self) -> [SurfaceBinding; 3] {
        std::array::from_fn(|k| SurfaceBinding {
            command: SURFACES[k].0.to_owned(),
            command_value: self.surface_commands[k],
            position: SURFACES[k].1.to_owned(),
            sign: SURFACES[k].2,
        })
    }

    /// JSBSim's local derivatives at the trim point; the executive is left
    /// at the trim point.
    pub fn derivatives(&mut self) -> Result<LocalDerivatives> {
        let surfaces = self.surfaces();
        local_derivatives(&mut self.exec, &self.at, &surfaces)
    }

    /// The surface deflections now (rad, aeroid's sign): elevator, aileron, rudder.
    pub fn deflections(&self) -> Result<[f64; 3]> {
        let mut deflections = [0.0; 3];
        for (deflection, (_, position, sign)) in deflections.iter_mut().zip(SURFACES) {
            *deflection = sign * self.exec.get(position)?;
        }
        Ok(deflections)
    }

    /// The total propulsion force now (N).
    pub fn thrust(&self) -> Result<f64> {
        let force = [
            "forces/fbx-prop-lbs",
            "forces/fby-prop-lbs",
            "forces/fbz-prop-lbs",
        ]
        .iter()
        .map(|name| self.exec.get(name).map(|f| f * LBF))
        .collect::<Result<Vec<_>>>()?;
        Ok(force.iter().map(|f| f * f).sum::<f64>().sqrt())
    }
}

/// JSBSim's mass, inertia, geometry and (with engines) thrust line now, in
/// aeroid's axes and units, as (name, value, unit) rows: what the
/// rigid-body file must hold.
pub fn rigid_body(exec: &Exec) -> Result<Vec<(&'static str, f64, &'static str)>> {
    let inertia = SLUG * FT * FT;
    // The thrusters' points, structural frame (in).
    let mut thrusters = Vec::new();
    while exec.has_property(&format!(
        "propulsion/engine[{}]/x-position",
        thrusters.len()
    ))? {
        let i = thrusters.len();
        let mut point = [0.0; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            point[k] = exec.get(&format!("propulsion/engine[{i}]/{axis}-position"))?;
        }
        thrusters.push(point);
    }
    let cg = [
        exec.get("inertia/cg-x-in")?,
        exec.get("inertia/cg-y-in")?,
        exec.get("inertia/cg-z-in")?,
    ];
    let inch = FT / 12.0;
    let mut rows = vec![
        ("mass", exec.get("inertia/mass-slugs")? * SLUG, "kg"),
        ("ixx", exec.get("inertia/ixx-slugs_ft2")? * inertia, "kg*m2"),
        ("iyy", exec.get("inertia/iyy-slugs_ft2")? * inertia, "kg*m2"),
        ("izz", exec.get("inertia/izz-slugs_ft2")? * inertia, "kg*m2"),
        // The property is the tensor element J13 = −Ixz (docs/jsbsim.md, "Inertia").
        (
            "ixz",
            -exec.get("inertia/ixz-slugs_ft2")? * inertia,
            "kg*m2",
        ),
        ("wing_area", exec.get("metrics/Sw-sqft")? * FT * FT, "m2"),
        ("span", exec.get("metrics/bw-ft")? * FT, "m"),
        ("chord", exec.get("metrics/cbarw-ft")? * FT, "m"),
    ];
    if !thrusters.is_empty() {
        // Their mean relative to the CG, in body axes (x forward, z down).
        let mean = |k: usize| thrusters.iter().map(|p| p[k]).sum::<f64>() / thrusters.len() as f64;
        rows.push(("thrust_x", -(mean(0) - cg[0]) * inch, "m"));
        rows.push(("thrust_y", (mean(1) - cg[1]) * inch, "m"));
        rows.push(("thrust_z", -(mean(2) - cg[2]) * inch, "m"));
    }
    Ok(rows)
}

/// Checks the rigid-body file against JSBSim's values (see [`rigid_body`]):
/// every value within [`RIGID_BODY_TOLERANCE`] relative (lengths of the
/// thrust line within 1 cm), the thrust along body x with no inclination and
/// `density_exponent = 0` (thrust recorded as measured), and a positive
/// `max_thrust`. The error lists JSBSim's value of every mismatch.
pub fn check_rigid_body(scenario: &Scenario, exec: &Exec) -> Result<()> {
    let aircraft: &Aircraft = &scenario.aircraft;
    let p = &aircraft.propulsion;
    let mass = &aircraft.mass;
    let ours = [
        mass.mass,
        mass.inertia[(0, 0)],
        mass.inertia[(1, 1)],
        mass.inertia[(2, 2)],
        -mass.inertia[(0, 2)],
        aircraft.wing_area,
        aircraft.geometry.span,
        aircraft.geometry.chord,
        p.position.x,
        p.position.y,
        p.position.z,
    ];
    let mut problems = Vec::new();
    let jsbsim = rigid_body(exec)?;
    let engines = jsbsim
        .iter()
        .any(|(name, _, _)| name.starts_with("thrust_"));
    for ((name, theirs, unit), ours) in jsbsim.into_iter().zip(ours) {
        let close = if name.starts_with("thrust_") {
            (ours - theirs).abs() <= 0.01
        } else {
            (ours - theirs).abs() <= RIGID_BODY_TOLERANCE * theirs.abs()
        };
        if !close {
            problems.push(format!(
                "{name} is {ours:.6e}, JSBSim has {theirs:.6e} {unit}"
            ));
        }
    }
    if engines && p.max_thrust <= 0.0 {
        problems.push(
            "propulsion.max_thrust must be positive (the recorded throttle is the thrust over it)"
                .into(),
        );
    }
    if p.inclination != 0.0 || p.density_exponent != 0.0 {
        problems.push(
            "propulsion.inclination and density_exponent must be 0: JSBSim's thrust is recorded as measured, T = δT·Tmax".into(),
        );
    }
    if problems.is_empty() {
        return Ok(());
    }
    Err(aeroid_core::Error::Invalid {
        path: scenario.aircraft_path.clone(),
        problems: problems
            .into_iter()
            .map(|message| FieldError {
                field: format!("rigid body of JSBSim's {}", aircraft.name),
                message,
            })
            .collect(),
    }
    .into())
}

/// Flies a JSBSim scenario: trim, the rigid-body check, the local derivatives
/// at the trim point, then the flight with the scenario's inputs. Returns the
/// truth trace (a departure stops it as in aeroid's simulator) and the run's
/// truth (kind `local_derivative`).
pub fn fly(scenario: &Scenario) -> Result<Flight> {
    let mut trimmed = trim(scenario)?;
    check_rigid_body(scenario, &trimmed.exec)?;
    let derivatives = trimmed.derivatives()?;
    let max_thrust = scenario.aircraft.propulsion.max_thrust;
    let throttle = if trimmed.throttle_properties.is_empty() {
        0.0
    } else {
        trimmed.thrust()? / max_thrust
    };
    let mut trim_controls = Controls::zeros();
    trim_controls
        .fixed_rows_mut::<3>(0)
        .copy_from_slice(&derivatives.deflections);
    trim_controls[Control::Throttle.index()] = throttle;

    let steps = scenario.step_count();
    let controls: Vec<Controls> = (0..=steps)
        .map(|k| trim_controls + scenario.inputs.deviation(k as f64 * scenario.step))
        .collect();
    if controls.iter().any(|c| c[Control::Flap.index()] != 0.0) {
        return Err(invalid(
            scenario,
            "inputs",
            "a JSBSim aircraft's flaps are not driven by inputs here; set them with [jsbsim] properties",
        ));
    }
    let truth = run_truth(scenario, &trimmed, &derivatives, &trim_controls);
    let mut flight = start(
        scenario,
        trimmed,
        &derivatives,
        &trim_controls,
        &controls[0],
    )?;
    let mut trace = TruthTrace {
        scenario: scenario.name.clone(),
        step: scenario.step,
        samples: Vec::with_capacity(steps + 1),
    };
    for k in 0..=steps {
        let time = k as f64 * scenario.step;
        let sample = flight.sample(time)?;
        if let Some(reason) =
            aeroid_sim::departure_reason(&scenario.departure, &sample.state, &sample.evaluation)
        {
            return Ok(Flight {
                trace,
                truth,
                departure: Some(Departure { time, reason }),
            });
        }
        trace.samples.push(sample);
        if k < steps {
            flight.advance(k, &controls[k + 1])?;
        }
    }
    Ok(Flight {
        trace,
        truth,
        departure: None,
    })
}

/// The flight from the trim point: surface commands scaled by the measured
/// deflection per command, throttle commands moved by the throttle input,
/// surfaces read back in aeroid's sign and the thrust as a fraction.
fn start(
    scenario: &Scenario,
    trimmed: Trimmed,
    derivatives: &LocalDerivatives,
    trim_controls: &Controls,
    first: &Controls,
) -> Result<JsbsimFlight> {
    let exec = trimmed.exec;
    let timing = (scenario.step, SUBSTEPS, scenario.interpolation);
    let mut commands: Vec<Option<ControlCommand>> = vec![None; CONTROL_COUNT];
    let mut readings = [ControlReading::Constant(0.0); CONTROL_COUNT];
    for (k, (command, position, sign)) in SURFACES.iter().enumerate() {
        commands[k] = Some(ControlCommand {
            commands: vec![exec.property(command)?],
            base_command: trimmed.surface_commands[k],
            base_value: trim_controls[k],
            per_unit: 1.0 / derivatives.deflection_per_command[k],
        });
        readings[k] = ControlReading::Property {
            property: exec.property(position)?,
            scale: *sign,
        };
    }
    let throttle = Control::Throttle.index();
    if trimmed.throttle_properties.is_empty() {
        return JsbsimFlight::start(exec, commands, readings, timing, first);
    }
    commands[throttle] = Some(ControlCommand {
        commands: trimmed
            .throttle_properties
            .iter()
            .map(|name| exec.property(name))
            .collect::<Result<_>>()?,
        base_command: trimmed.throttle_command,
        base_value: trim_controls[throttle],
        per_unit: 1.0,
    });
    readings[throttle] = ControlReading::ThrustFraction {
        max_thrust: scenario.aircraft.propulsion.max_thrust,
    };
    JsbsimFlight::start(exec, commands, readings, timing, first)
}

/// The truth file of a JSBSim flight: JSBSim's local derivatives at the trim
/// point (kind `local_derivative`; JSBSim's aircraft has no parameters in
/// aeroid's sense, so `parameters` is empty) and the trim point.
fn run_truth(
    scenario: &Scenario,
    trimmed: &Trimmed,
    derivatives: &LocalDerivatives,
    trim_controls: &Controls,
) -> RunTruth {
    let jsbsim = scenario.jsbsim.as_ref().map_or("", |j| j.model.as_str());
    RunTruth {
        kind: TruthKind::LocalDerivative,
        scenario: scenario.name.clone(),
        seed: scenario.seed,
        aircraft: format!("{}{jsbsim}", aeroid_sim::scenario::JSBSIM_PREFIX),
        trim: TrimPoint {
            airspeed: trimmed.airspeed,
            altitude: trimmed.at.altitude,
            flight_path_angle: scenario.trim.flight_path_angle,
            heading: trimmed.at.attitude[2],
            alpha: trimmed.alpha,
            beta: trimmed.beta,
            pitch: trimmed.at.attitude[1],
            controls: Control::ALL
                .iter()
                .map(|c| (c.name().to_string(), trim_controls[c.index()]))
                .collect(),
        },
        model: Default::default(),
        parameters: BTreeMap::new(),
        local_derivatives: derivatives.values.iter().cloned().collect(),
        parameter_changes: Vec::new(),
    }
}
