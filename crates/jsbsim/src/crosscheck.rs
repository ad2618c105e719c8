//! `aeroid crosscheck SCENARIO`: flies a scenario in aeroid's simulator and in
//! JSBSim (the aircraft exported by [`super::export`]), from the same trim
//! state with the same control inputs, no wind and no parameter changes
//! (the aircraft of the scenario's start throughout), and reports the
//! largest difference of every state.
//!
//! The JSBSim half is the one flight loop of [`super::flight`] (zero-order
//! hold of the controls, third-order Adams–Bashforth with
//! [`CrossCheckOptions::substeps`] steps per aeroid step; aeroid uses RK4),
//! and both halves are compared through the same truth samples.

use super::export::{CONTROL_PROPERTIES, ExportOptions, export, model_name};
use super::flight::{ControlCommand, ControlReading, JsbsimFlight};
use super::{Exec, FT, InitialConditions, InitialSpeed};
use crate::error::Result;
use aeroid_sim::Simulation;
use aeroid_sim::scenario::Scenario;
use aeroid_sim::state::{self, Controls};
use aeroid_sim::wind::WindSpec;
use std::path::PathBuf;
use std::time::Instant;

/// One compared state ([`compared_values`] gives it from a sample): its name
/// and unit, and the smallest excursion worth a relative figure.
struct Compared {
    name: &'static str,
    unit: &'static str,
    floor: f64,
    angle: bool,
}

const DEG: f64 = std::f64::consts::PI / 180.0;

const COMPARED: [Compared; 13] = [
    Compared {
        name: "u",
        unit: "m/s",
        floor: 0.05,
        angle: false,
    },
    Compared {
        name: "v",
        unit: "m/s",
        floor: 0.05,
        angle: false,
    },
    Compared {
        name: "w",
        unit: "m/s",
        floor: 0.05,
        angle: false,
    },
    Compared {
        name: "p",
        unit: "rad/s",
        floor: 0.05 * DEG,
        angle: false,
    },
    Compared {
        name: "q",
        unit: "rad/s",
        floor: 0.05 * DEG,
        angle: false,
    },
    Compared {
        name: "r",
        unit: "rad/s",
        floor: 0.05 * DEG,
        angle: false,
    },
    Compared {
        name: "phi",
        unit: "rad",
        floor: 0.05 * DEG,
        angle: true,
    },
    Compared {
        name: "theta",
        unit: "rad",
        floor: 0.05 * DEG,
        angle: true,
    },
    Compared {
        name: "psi",
        unit: "rad",
        floor: 0.05 * DEG,
        angle: true,
    },
    Compared {
        name: "airspeed",
        unit: "m/s",
        floor: 0.05,
        angle: false,
    },
    Compared {
        name: "alpha",
        unit: "rad",
        floor: 0.05 * DEG,
        angle: true,
    },
    Compared {
        name: "beta",
        unit: "rad",
        floor: 0.05 * DEG,
        angle: true,
    },
    Compared {
        name: "altitude",
        unit: "m",
        floor: 0.5,
        angle: false,
    },
];

/// The compared states of one truth sample (either simulator's).
fn compared_values(sample: &aeroid_sim::trace::TruthSample) -> [f64; 13] {
    let x = &sample.state;
    let air = &sample.evaluation.air_data;
    [
        x[state::U],
        x[state::V],
        x[state::W],
        x[state::P],
        x[state::Q],
        x[state::R],
        sample.euler.roll,
        sample.euler.pitch,
        sample.euler.yaw,
        air.airspeed,
        air.alpha,
        air.beta,
        state::altitude(x),
    ]
}

/// The comparison of one state over the flight.
#[derive(Debug, Clone, PartialEq)]
pub struct StateDifference {
    pub name: &'static str,
    pub unit: &'static str,
    /// max |aeroid − JSBSim| over the flight (SI).
    pub max_difference: f64,
    /// When the largest difference occurred (s).
    pub time_of_max: f64,
    /// aeroid's excursion max − min over the flight (SI).
    pub excursion: f64,
    /// `max_difference / excursion`, when the excursion is above the floor
    /// (0.05 m/s, 0.05°, 0.05°/s, 0.5 m) that makes a ratio meaningful.
    pub relative: Option<f64>,
}

/// The result of a cross-check.
#[derive(Debug, Clone)]
pub struct CrossCheck {
    pub scenario: String,
    pub duration: f64,
    pub step: f64,
    pub steps: usize,
    pub differences: Vec<StateDifference>,
    /// Steps per second of aeroid's simulator (RK4, trace recording included).
    pub aeroid_steps_per_second: f64,
    /// JSBSim steps (`Run` calls, substeps included) per second, control
    /// writes and state reads included.
    pub jsbsim_steps_per_second: f64,
    /// JSBSim steps per aeroid step.
    pub substeps: usize,
}

impl CrossCheck {
    /// The difference of a state by name.
    pub fn state(&self, name: &str) -> Option<&StateDifference> {
        self.differences.iter().find(|d| d.name == name)
    }

    /// The largest relative difference over the states with an excursion.
    pub fn worst_relative(&self) -> Option<&StateDifference> {
        self.differences
            .iter()
            .filter(|d| d.relative.is_some())
            .max_by(|a, b| {
                a.relative
                    .partial_cmp(&b.relative)
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
    }
}

/// Options of a cross-check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossCheckOptions {
    /// Flight time (s); the scenario's duration when `None`.
    pub duration: Option<f64>,
    /// Keep JSBSim's own standard atmosphere (geopotential altitude) instead
    /// of overriding it with aeroid's ISA.
    pub jsbsim_atmosphere: bool,
    /// JSBSim steps per aeroid step (at least 1). JSBSim's Adams–Bashforth
    /// integrators extrapolate their derivative history across each input
    /// step, which moves the step by about half a time step; n substeps cut
    /// that n-fold (see [`DEFAULT_SUBSTEPS`]).
    pub substeps: usize,
}

/// Substeps that bring the cross-checks of the bundled ATTAS and CDRW
/// scenarios within 0.05 % (ATTAS) and 0.42 % (CDRW, short period 18 rad/s)
/// of each state's excursion; with one substep the CDRW pitch rate differs
/// by 11 %.
pub const DEFAULT_SUBSTEPS: usize = 20;

impl Default for CrossCheckOptions {
    fn default() -> Self {
        CrossCheckOptions {
            duration: None,
            jsbsim_atmosphere: false,
            substeps: DEFAULT_SUBSTEPS,
        }
    }
}

/// Starts the exported aircraft of a prepared [`Simulation`] in JSBSim from
/// the same trim with the same controls: the JSBSim half of a cross-check,
/// and what `benches/jsbsim.rs` times. The controls are written straight into
/// the surface properties the export reads (it has no flight-control system).
pub fn start_exported(
    simulation: &Simulation,
    jsbsim_atmosphere: bool,
    substeps: usize,
) -> Result<JsbsimFlight> {
    let environment = &simulation.model.environment;
    let export_options = ExportOptions {
        gravity: environment.gravity,
        aeroid_atmosphere: !jsbsim_atmosphere,
        temperature_offset: environment.atmosphere.temperature_offset,
    };
    let mut exec = load_exported(simulation, &export_options)?;
    let trim_state = &simulation.trim.state;
    if jsbsim_atmosphere {
        // aeroid's offset changes temperature at constant pressure, JSBSim's
        // delta-T changes both; only the standard day compares exactly.
        exec.set(
            "atmosphere/delta-T",
            environment.atmosphere.temperature_offset * 1.8,
        )?;
    } else {
        // The override functions run in a system, after JSBSim's atmosphere
        // model, so RunIC's first frame would see an empty override (zero
        // density, no lift) and JSBSim would seed its integrator history
        // with that frame: a 1 g jump in the first step. Seed the override
        // with aeroid's air at the initial altitude.
        let air = environment.atmosphere.at(state::altitude(trim_state));
        exec.set("atmosphere/override/temperature", air.temperature * 1.8)?;
        exec.set(
            "atmosphere/override/pressure",
            air.pressure * FT * FT / super::LBF,
        )?;
        exec.set(
            "atmosphere/override/density",
            air.density * FT.powi(3) / super::SLUG,
        )?;
    }
    let euler = state::euler(trim_state);
    exec.set_initial_conditions(&InitialConditions {
        latitude: 0.0,
        longitude: 0.0,
        altitude: state::altitude(trim_state),
        attitude: [euler.roll, euler.pitch, euler.yaw],
        speed: InitialSpeed::Body([
            trim_state[state::U],
            trim_state[state::V],
            trim_state[state::W],
        ]),
        rates: [
            trim_state[state::P],
            trim_state[state::Q],
            trim_state[state::R],
        ],
    })?;
    let properties = CONTROL_PROPERTIES
        .iter()
        .map(|name| exec.property(name))
        .collect::<Result<Vec<_>>>()?;
    let commands = properties
        .iter()
        .map(|property| {
            Some(ControlCommand {
                commands: vec![*property],
                base_command: 0.0,
                base_value: 0.0,
                per_unit: 1.0,
            })
        })
        .collect();
    let readings = std::array::from_fn(|i| ControlReading::Property {
        property: properties[i],
        scale: 1.0,
    });
    JsbsimFlight::start(
        exec,
        commands,
        readings,
        (simulation.step, substeps, simulation.interpolation),
        &saturated_controls(simulation, 0),
    )
}

/// The controls of step k as aeroid's simulator applies them (saturated).
pub fn saturated_controls(simulation: &Simulation, k: usize) -> Controls {
    let mut controls: Controls = simulation.exogenous[k]
        .fixed_rows::<{ aeroid_sim::state::CONTROL_COUNT }>(0)
        .into_owned();
    simulation.model.aircraft.saturate(&mut controls);
    controls
}

/// Flies `scenario` in both simulators and compares every state.
pub fn crosscheck(scenario: &Scenario, options: &CrossCheckOptions) -> Result<CrossCheck> {
    let mut scenario = scenario.clone();
    scenario.wind = WindSpec::default();
    scenario.parameter_changes.clear();
    // Both simulators fly the same control history: open loop.
    scenario.feedback = None;
    if let Some(duration) = options.duration {
        scenario.duration = duration;
    }
    let simulation = Simulation::prepare(&scenario)?;
    let started = Instant::now();
    let trace = simulation.run()?;
    let aeroid_seconds = started.elapsed().as_secs_f64();
    let steps = trace.samples.len() - 1;

    let mut flight = start_exported(&simulation, options.jsbsim_atmosphere, options.substeps)?;
    let mut jsbsim = Vec::with_capacity(steps + 1);
    let started = Instant::now();
    for (k, sample) in trace.samples.iter().enumerate() {
        jsbsim.push(compared_values(&flight.sample(sample.time)?));
        if k < steps {
            flight.advance(k, &saturated_controls(&simulation, k + 1))?;
        }
    }
    let jsbsim_seconds = started.elapsed().as_secs_f64();
    let substeps = flight.substeps();

    let differences = COMPARED
        .iter()
        .enumerate()
        .map(|(i, compared)| {
            let mut largest = (0.0_f64, 0.0);
            let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
            for (sample, theirs) in trace.samples.iter().zip(&jsbsim) {
                let ours = compared_values(sample)[i];
                low = low.min(ours);
                high = high.max(ours);
                let mut difference = ours - theirs[i];
                if compared.angle {
                    difference = (difference + std::f64::consts::PI)
                        .rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI;
                }
                if difference.abs() > largest.0 || difference.is_nan() {
                    largest = (difference.abs(), sample.time);
                }
            }
            let excursion = high - low;
            StateDifference {
                name: compared.name,
                unit: compared.unit,
                max_difference: largest.0,
                time_of_max: largest.1,
                excursion,
                relative: (excursion > compared.floor).then(|| largest.0 / excursion),
            }
        })
        .collect();
    Ok(CrossCheck {
        scenario: scenario.name.clone(),
        duration: scenario.duration,
        step: simulation.step,
        steps,
        differences,
        aeroid_steps_per_second: steps as f64 / aeroid_seconds,
        jsbsim_steps_per_second: (steps * substeps) as f64 / jsbsim_seconds,
        substeps,
    })
}

/// Exports the simulation's aircraft into a fresh temporary folder, loads it
/// into a new executive and removes the folder.
fn load_exported(simulation: &Simulation, options: &ExportOptions) -> Result<Exec> {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let dir: PathBuf = std::env::temp_dir().join(format!(
        "aeroid-crosscheck-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    let result = (|| {
        export(&simulation.model.aircraft, options, &dir)?;
        let mut exec = Exec::new()?;
        exec.load_model_in(&dir, &model_name(&simulation.model.aircraft), false)?;
        Ok(exec)
    })();
    // The file is read completely while loading; a folder left behind is harmless.
    let _ = std::fs::remove_dir_all(&dir);
    result
}
