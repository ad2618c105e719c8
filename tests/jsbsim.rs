//! JSBSim through FFI (feature `jsbsim`; run in release:
//! `cargo test --release --features jsbsim --test jsbsim`). Each known trap
//! of driving JSBSim from a library has a test here, as do the export and
//! the cross-check of aeroid's simulator against JSBSim.
#![cfg(feature = "jsbsim")]

mod common;

use aeroid::jsbsim::Error;
use aeroid::jsbsim::export::{ExportOptions, aircraft_xml, export, model_name};
use aeroid::jsbsim::{Exec, FT, InitialConditions, InitialSpeed, TrimMode};
use aeroid::sim::aircraft::Aircraft;
use std::path::{Path, PathBuf};

fn attas() -> Aircraft {
    Aircraft::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/aircraft/attas.toml"
    )))
    .unwrap()
}

/// Writes the exported ATTAS with `extra` XML inserted before the closing
/// tag into a fresh folder; returns the aircraft folder and the model name.
fn exported_attas(test: &str, extra: &str) -> (PathBuf, String) {
    let folder = common::temp_folder(test);
    let aircraft = attas();
    let model = model_name(&aircraft);
    let xml = aircraft_xml(&aircraft, &ExportOptions::default())
        .unwrap()
        .replace("</fdm_config>", &format!("{extra}\n</fdm_config>"));
    std::fs::create_dir_all(folder.join(&model)).unwrap();
    common::write(&folder.join(&model), &format!("{model}.xml"), &xml);
    (folder, model)
}

fn load(folder: &Path, model: &str, allow_io: bool) -> aeroid::jsbsim::Result<Exec> {
    let mut exec = Exec::new()?;
    exec.load_model_in(folder, model, allow_io)?;
    Ok(exec)
}

fn message(error: &impl std::fmt::Display) -> String {
    error.to_string()
}

/// The 737 at 280 kt true airspeed, 30 000 ft, wings level.
fn b737_cruise() -> InitialConditions {
    InitialConditions {
        latitude: 0.5,
        longitude: -1.5,
        altitude: 30_000.0 * FT,
        attitude: [0.0, 0.03, 0.0],
        speed: InitialSpeed::TrueAirspeed {
            speed: 280.0 * 1852.0 / 3600.0,
            alpha: 0.03,
            beta: 0.0,
        },
        rates: [0.0; 3],
    }
}

#[test]
fn loads_the_737_and_steps_at_the_set_rate() {
    aeroid::jsbsim::register();
    let mut exec = Exec::new().unwrap();
    exec.load_model("737").unwrap();
    exec.set_dt(1.0 / 120.0).unwrap();
    exec.set_initial_conditions(&b737_cruise()).unwrap();
    exec.run_ic().unwrap();
    for _ in 0..120 {
        exec.step().unwrap();
    }
    // 120 steps of 1/120 s: one second of simulated time, to rounding.
    assert!((exec.time().unwrap() - 1.0).abs() < 1e-9);
    assert!((exec.dt().unwrap() - 1.0 / 120.0).abs() < 1e-15);
    // Still near its initial altitude after one second (climb rate below 50 ft/s).
    let altitude = exec.get("position/h-sl-ft").unwrap();
    assert!((altitude - 30_000.0).abs() < 50.0, "altitude {altitude} ft");
}

/// A C++ exception (here: JSBSim's TrimFailureException, and an
/// XMLLogException for a malformed function) becomes an Err, never an abort.
#[test]
fn cpp_exceptions_become_errors() {
    aeroid::jsbsim::register();
    let mut exec = Exec::new().unwrap();
    exec.load_model("737").unwrap();
    let mut stalled = b737_cruise();
    stalled.speed = InitialSpeed::TrueAirspeed {
        speed: 20.0,
        alpha: 0.0,
        beta: 0.0,
    };
    exec.set_initial_conditions(&stalled).unwrap();
    exec.run_ic().unwrap();
    let error = exec.trim(TrimMode::Full).unwrap_err();
    assert!(matches!(error, Error::Jsbsim { .. }), "{error:?}");
    assert!(message(&error).contains("Trim Failed"), "{error}");

    // A quotient needs two arguments: JSBSim throws while loading.
    let (folder, model) = exported_attas(
        "jsbsim-bad-function",
        "<system name=\"broken\"><channel name=\"c\"><fcs_function name=\"aeroid/broken\">\
         <function><quotient><value>1</value></quotient></function></fcs_function></channel></system>",
    );
    let error = load(&folder, &model, false).unwrap_err();
    assert!(matches!(error, Error::Jsbsim { .. }), "{error:?}");
    assert!(message(&error).contains("loading aircraft"), "{error}");
    assert!(message(&error).contains("argument"), "{error}");
}

#[test]
fn a_missing_aircraft_is_an_error_naming_the_file() {
    aeroid::jsbsim::register();
    let mut exec = Exec::new().unwrap();
    let error = exec.load_model("no-such-aircraft").unwrap_err();
    assert!(message(&error).contains("no-such-aircraft.xml"), "{error}");
    let error = Exec::with_root(Path::new("/no/such/jsbsim/root")).unwrap_err();
    assert!(message(&error).contains("/no/such/jsbsim/root"), "{error}");
}

/// JSBSim reads an unknown property as 0.0 without complaint; the wrapper
/// makes reading, writing and caching one an error that names it.
#[test]
fn unknown_properties_are_errors() {
    aeroid::jsbsim::register();
    let mut exec = Exec::new().unwrap();
    exec.load_model("737").unwrap();
    assert!(exec.has_property("fcs/elevator-cmd-norm").unwrap());
    assert!(!exec.has_property("fcs/elevator-cmd-nrom").unwrap());
    for error in [
        exec.get("fcs/elevator-cmd-nrom").unwrap_err(),
        exec.property("fcs/elevator-cmd-nrom").unwrap_err(),
        exec.set("fcs/elevator-cmd-nrom", 0.1).unwrap_err(),
    ] {
        assert!(message(&error).contains("fcs/elevator-cmd-nrom"), "{error}");
    }
    // A malformed path is an error too, not an exception.
    assert!(exec.get("fcs/elevator cmd!").is_err());
}

#[test]
fn cached_handles_read_and_write_the_named_property() {
    aeroid::jsbsim::register();
    let mut exec = Exec::new().unwrap();
    exec.load_model("737").unwrap();
    let elevator = exec.property("fcs/elevator-cmd-norm").unwrap();
    exec.set_cached(elevator, -0.25).unwrap();
    assert_eq!(exec.get("fcs/elevator-cmd-norm").unwrap(), -0.25);
    exec.set("fcs/elevator-cmd-norm", 0.5).unwrap();
    assert_eq!(exec.get_cached(elevator).unwrap(), 0.5);
    // A handle only works with the executive that made it.
    let mut other = Exec::new().unwrap();
    other.load_model("737").unwrap();
    let error = other.get_cached(elevator).unwrap_err();
    assert!(message(&error).contains("another executive"), "{error}");
    assert!(other.set_cached(elevator, 0.0).is_err());
}

/// Aircraft files may declare input sockets and CSV or socket outputs (the
/// 737 listens on ports 5137 and 5139, the c172p writes JSBout172C.csv). The
/// wrapper disables input and output before loading and detaches the output
/// instances, so nothing is opened; with I/O allowed, both appear, which
/// shows that the test can see them.
#[test]
fn loading_opens_no_socket_and_writes_no_file() {
    aeroid::jsbsim::register();
    let folder = common::temp_folder("jsbsim-io");
    let csv = folder.join("written-by-jsbsim.csv");
    let port = {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        listener.local_addr().unwrap().port()
    };
    let (aircraft_folder, model) = exported_attas(
        "jsbsim-io-aircraft",
        &format!(
            "<input port=\"{port}\"/>\n<output name=\"{}\" type=\"CSV\" rate=\"10\">\
             <property>position/h-sl-ft</property></output>",
            csv.display()
        ),
    );
    let listening = || std::net::TcpStream::connect(("127.0.0.1", port)).is_ok();

    let mut quiet = load(&aircraft_folder, &model, false).unwrap();
    quiet.run_ic().unwrap();
    for _ in 0..20 {
        quiet.step().unwrap();
    }
    assert!(!csv.exists(), "output file written with output disabled");
    assert!(!listening(), "input socket opened with input disabled");
    drop(quiet);

    let mut noisy = load(&aircraft_folder, &model, true).unwrap();
    noisy.run_ic().unwrap();
    for _ in 0..20 {
        noisy.step().unwrap();
    }
    assert!(csv.exists(), "with I/O allowed the CSV file appears");
    assert!(listening(), "with I/O allowed the input socket listens");
}

/// JSBSim keeps the speed type set last and re-derives the speed when the
/// altitude changes afterwards. The wrapper sets position first, so 280 kt
/// true airspeed at 30 000 ft stays 280 kt; setting the speed at the
/// default altitude (sea level) and the altitude after gives another speed.
#[test]
fn initial_conditions_set_position_before_speed() {
    aeroid::jsbsim::register();
    let wanted = 280.0;
    let mut exec = Exec::new().unwrap();
    exec.load_model("737").unwrap();
    exec.set_initial_conditions(&b737_cruise()).unwrap();
    exec.run_ic().unwrap();
    let true_airspeed = exec.get("velocities/vtrue-kts").unwrap();
    assert!(
        (true_airspeed - wanted).abs() < 0.01,
        "vtrue {true_airspeed} kt"
    );
    assert!((exec.get("position/h-sl-ft").unwrap() - 30_000.0).abs() < 0.01);

    let mut wrong = Exec::new().unwrap();
    wrong.load_model("737").unwrap();
    wrong.set("ic/vc-kts", wanted).unwrap();
    wrong.set("ic/h-sl-ft", 30_000.0).unwrap();
    wrong.run_ic().unwrap();
    let mach = wrong.get("velocities/mach").unwrap();
    let calibrated = wrong.get("velocities/vc-kts").unwrap();
    let right_mach = exec.get("velocities/mach").unwrap();
    eprintln!(
        "speed then altitude: vc {calibrated:.1} kt, Mach {mach:.3}; position first: Mach {right_mach:.3}"
    );
    assert!(
        (mach - right_mach).abs() > 0.1,
        "the order made no difference: Mach {mach} vs {right_mach}"
    );
}

/// JSBSim's unit-conversion table is a static filled by the first XML element
/// ever constructed; the shim fills it once before any executive exists, so
/// threads may load their first models at the same time. Each thread has its
/// own executive (`Exec` is not `Send`) and all must agree.
#[test]
fn threads_load_models_at_once_and_agree() {
    aeroid::jsbsim::register();
    let barrier = std::sync::Arc::new(std::sync::Barrier::new(4));
    let handles: Vec<_> = (0..4)
        .map(|_| {
            let barrier = barrier.clone();
            std::thread::spawn(move || {
                barrier.wait();
                let mut exec = Exec::new().unwrap();
                exec.load_model("737").unwrap();
                exec.set_initial_conditions(&b737_cruise()).unwrap();
                exec.run_ic().unwrap();
                for _ in 0..240 {
                    exec.step().unwrap();
                }
                [
                    exec.get("attitude/theta-rad").unwrap(),
                    exec.get("velocities/vtrue-kts").unwrap(),
                    exec.get("position/h-sl-ft").unwrap(),
                    exec.get("inertia/weight-lbs").unwrap(),
                ]
            })
        })
        .collect();
    let results: Vec<[f64; 4]> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    for result in &results[1..] {
        assert_eq!(result, &results[0], "threads disagree");
    }
}

/// `Exec` holds a raw FGFDMExec: it must not be sent to another thread.
/// (Compile-time check: `assert_not_send::<Exec>()` resolves only because the
/// blanket impl for `Send` types does not apply.)
#[test]
fn an_executive_is_not_send() {
    aeroid::jsbsim::register();
    trait AmbiguousIfSend<A> {
        fn check() -> bool {
            true
        }
    }
    impl<T: ?Sized> AmbiguousIfSend<()> for T {}
    #[allow(dead_code)]
    struct Invalid;
    impl<T: ?Sized + Send> AmbiguousIfSend<Invalid> for T {}
    // Were Exec Send, both impls would apply and this would not compile.
    assert!(<Exec as AmbiguousIfSend<_>>::check());
}

/// The exported ATTAS carries aeroid's mass, inertia and geometry: JSBSim
/// reports them back to 1e-6 (the file is in slug·ft², lbs and ft with exact
/// factors; JSBSim's own kg·m² factor would be 9e-5 off).
#[test]
fn export_carries_mass_inertia_and_geometry() {
    aeroid::jsbsim::register();
    let aircraft = attas();
    let folder = common::temp_folder("jsbsim-export");
    let file = export(&aircraft, &ExportOptions::default(), &folder).unwrap();
    assert!(file.ends_with("attas/attas.xml"), "{}", file.display());
    let mut exec = load(&folder, "attas", false).unwrap();
    // JSBSim computes the mass properties when the model first runs.
    exec.run_ic().unwrap();
    let slug_ft2 = aeroid::jsbsim::SLUG * FT * FT;
    let inertia = aircraft.mass.inertia;
    // JSBSim's inertia/ixz-slugs_ft2 is the tensor element J13 = −∫xz dm
    // (−1.1442e4 kg·m² here), unlike inertia/iyz-slugs_ft2, which is −J23.
    // The sign inside the dynamics is checked by the lateral cross-checks.
    let expected = [
        (
            "inertia/mass-slugs",
            aeroid::jsbsim::SLUG,
            aircraft.mass.mass,
        ),
        ("inertia/ixx-slugs_ft2", slug_ft2, inertia[(0, 0)]),
        ("inertia/iyy-slugs_ft2", slug_ft2, inertia[(1, 1)]),
        ("inertia/izz-slugs_ft2", slug_ft2, inertia[(2, 2)]),
        ("inertia/ixz-slugs_ft2", slug_ft2, inertia[(0, 2)]),
        ("metrics/Sw-sqft", FT * FT, aircraft.wing_area),
        ("metrics/bw-ft", FT, aircraft.geometry.span),
        ("metrics/cbarw-ft", FT, aircraft.geometry.chord),
    ];
    for (property, to_si, aeroid) in expected {
        let jsbsim = exec.get(property).unwrap() * to_si;
        assert!(
            (jsbsim - aeroid).abs() <= 1e-6 * aeroid.abs(),
            "{property}: JSBSim {jsbsim} vs aeroid {aeroid}"
        );
    }
}

#[test]
fn export_refuses_the_stall_model() {
    aeroid::jsbsim::register();
    let aircraft = Aircraft::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/aircraft/attas-stall.toml"
    )))
    .unwrap();
    let error = aircraft_xml(&aircraft, &ExportOptions::default()).unwrap_err();
    assert!(message(&error).contains("only linear"), "{error}");
}

/// Flies `scenario` for 60 s in both simulators and checks that every state
/// with an excursion (above 0.05 m/s, 0.05°, 0.05°/s, 0.5 m) agrees within
/// 0.5 % of it, and that the states the manoeuvre excites are among them.
fn cross_check_agrees(scenario: &str, excited: &[&str]) {
    use aeroid::jsbsim::crosscheck::{CrossCheckOptions, crosscheck};
    let scenario = aeroid::sim::scenario::Scenario::load(scenario).unwrap();
    let options = CrossCheckOptions {
        duration: Some(60.0),
        ..CrossCheckOptions::default()
    };
    let check = crosscheck(&scenario, &options).unwrap();
    assert_eq!(check.steps, 6000);
    for name in excited {
        let state = check.state(name).unwrap();
        assert!(
            state.relative.is_some(),
            "{}: {name} was not excited: {state:?}",
            check.scenario
        );
    }
    for state in &check.differences {
        eprintln!(
            "{} {:<9} max diff {:.3e} {} at {:.2} s, excursion {:.3e}, {:?}",
            check.scenario,
            state.name,
            state.max_difference,
            state.unit,
            state.time_of_max,
            state.excursion,
            state.relative
        );
        if let Some(relative) = state.relative {
            assert!(
                relative <= 0.005,
                "{}: {} differs by {:.3} % of its excursion",
                check.scenario,
                state.name,
                100.0 * relative
            );
        }
    }
}

#[test]
fn cross_check_attas_elevator_3211() {
    aeroid::jsbsim::register();
    cross_check_agrees(
        "attas-elevator-3211",
        &["u", "w", "q", "theta", "airspeed", "alpha", "altitude"],
    );
}

/// The multisine is flown with linear interpolation of the inputs inside a
/// step (the scenario's `interpolation = "linear"`); JSBSim interpolates
/// them at every substep too. Measured: within 0.08 % (altitude), every
/// other state within 0.05 %; held over the step instead, p differed by
/// 0.71 %, v and β by 0.52 %, so the 0.5 % bound tells the two apart.
#[test]
fn cross_check_attas_multisine_with_linear_inputs() {
    aeroid::jsbsim::register();
    cross_check_agrees(
        "attas-multisine",
        &[
            "u", "v", "w", "p", "q", "r", "phi", "theta", "alpha", "beta",
        ],
    );
}

#[test]
fn cross_check_attas_lateral_multistep() {
    aeroid::jsbsim::register();
    cross_check_agrees(
        "attas-lateral-multistep",
        &[
            "v", "p", "r", "phi", "psi", "beta", "u", "theta", "airspeed",
        ],
    );
}

#[test]
fn cross_check_cdrw_longitudinal() {
    aeroid::jsbsim::register();
    cross_check_agrees(
        "cdrw-longitudinal",
        &["u", "w", "q", "theta", "airspeed", "alpha", "altitude"],
    );
}

#[test]
fn cross_check_cdrw_lateral() {
    aeroid::jsbsim::register();
    cross_check_agrees("cdrw-lateral", &["v", "p", "r", "phi", "psi", "beta"]);
}

/// With JSBSim's own atmosphere (geopotential altitude) the trims differ by
/// the density at 3.7 m of altitude at 4877 m, and the ATTAS elevator 3211's
/// speed then drifts by more than with aeroid's ISA in the exported file: the
/// difference docs/jsbsim.md documents.
#[test]
fn jsbsim_atmosphere_is_a_measurable_convention_difference() {
    aeroid::jsbsim::register();
    use aeroid::jsbsim::crosscheck::{CrossCheckOptions, crosscheck};
    let scenario = aeroid::sim::scenario::Scenario::load("attas-elevator-3211").unwrap();
    let ours = crosscheck(
        &scenario,
        &CrossCheckOptions {
            duration: Some(60.0),
            ..Default::default()
        },
    )
    .unwrap();
    let theirs = crosscheck(
        &scenario,
        &CrossCheckOptions {
            duration: Some(60.0),
            jsbsim_atmosphere: true,
            ..Default::default()
        },
    )
    .unwrap();
    let speed =
        |c: &aeroid::jsbsim::crosscheck::CrossCheck| c.state("airspeed").unwrap().max_difference;
    eprintln!(
        "airspeed difference: aeroid ISA {:.4} m/s, JSBSim atmosphere {:.4} m/s",
        speed(&ours),
        speed(&theirs)
    );
    assert!(speed(&theirs) > 3.0 * speed(&ours));
}

/// `load_model` looks in the executive's own root, not the default one.
#[test]
fn load_model_uses_the_executives_root() {
    aeroid::jsbsim::register();
    let root = common::temp_folder("jsbsim-root");
    export(&attas(), &ExportOptions::default(), &root.join("aircraft")).unwrap();
    for folder in ["engine", "systems"] {
        std::fs::create_dir_all(root.join(folder)).unwrap();
    }
    let mut exec = Exec::with_root(&root).unwrap();
    assert_eq!(exec.root(), root.as_path());
    exec.load_model("attas").unwrap();
    assert!(
        Exec::new().unwrap().load_model("attas").is_err(),
        "the default root has no attas"
    );
}

/// Central differences through JSBSim (perturb α, β, p̂, q̂, r̂, δe, δa, δr
/// one at a time, RunIC, read the coefficients back from JSBSim's forces and
/// moments) recover, on the exported ATTAS at its trim, aeroid's own local
/// derivatives of the same model, constant terms included: all 54 within
/// 1e-6 + 1e-5 relative. The machinery that gives a JSBSim aircraft's truth.
#[test]
fn central_differences_through_jsbsim_recover_the_exported_derivatives() {
    aeroid::jsbsim::register();
    use aeroid::jsbsim::derivatives::{SurfaceBinding, local_derivatives};
    use aeroid::jsbsim::export::{CONTROL_PROPERTIES, THROTTLE_PROPERTY};
    use aeroid::sim::state::Control;
    let scenario = aeroid::sim::scenario::Scenario::load("attas-elevator-3211").unwrap();
    let simulation = aeroid::sim::Simulation::prepare(&scenario).unwrap();
    let trim = &simulation.trim;
    let truth = aeroid::sim::truth::RunTruth::exact(&scenario, trim);
    let folder = common::temp_folder("jsbsim-derivatives");
    export(&scenario.aircraft, &ExportOptions::default(), &folder).unwrap();
    let mut exec = load(&folder, &model_name(&scenario.aircraft), false).unwrap();
    exec.set(THROTTLE_PROPERTY, trim.controls[Control::Throttle.index()])
        .unwrap();
    let euler = aeroid::sim::state::euler(&trim.state);
    let at = InitialConditions {
        latitude: 0.0,
        longitude: 0.0,
        altitude: aeroid::sim::state::altitude(&trim.state),
        attitude: [euler.roll, euler.pitch, euler.yaw],
        speed: InitialSpeed::TrueAirspeed {
            speed: scenario.trim.airspeed,
            alpha: trim.alpha,
            beta: trim.beta,
        },
        rates: [0.0; 3],
    };
    let surface = |control: Control| {
        SurfaceBinding::direct(
            CONTROL_PROPERTIES[control.index()],
            trim.controls[control.index()],
        )
    };
    let controls = [
        surface(Control::Elevator),
        surface(Control::Aileron),
        surface(Control::Rudder),
    ];
    let derivatives = local_derivatives(&mut exec, &at, &controls).unwrap();
    assert_eq!(derivatives.values.len(), 54);
    for gain in derivatives.deflection_per_command {
        assert!((gain - 1.0).abs() < 1e-12, "{gain}");
    }
    for (name, jsbsim) in &derivatives.values {
        let expected = truth.local_derivatives[name];
        assert!(
            (jsbsim - expected).abs() <= 1e-6 + 1e-5 * expected.abs(),
            "{name}: JSBSim {jsbsim} vs aeroid {expected}"
        );
    }
    // The eight the issue scores, against the file's values.
    for (name, file) in [
        ("CL_alpha", 3.30),
        ("Cm_alpha", -0.176),
        ("Cm_q", -12.3),
        ("Cm_de", -0.391),
        ("Cl_beta", -0.0614),
        ("Cl_p", -0.3888),
        ("Cn_beta", 0.1304),
        ("Cn_r", -0.0746),
    ] {
        let value = derivatives.get(name).unwrap();
        assert!(
            (value - file).abs() <= 1e-5 * file.abs(),
            "{name}: {value} vs {file}"
        );
    }
}

// ---------------------------------------------------------------------------
// JSBSim's own 737 as truth
// ---------------------------------------------------------------------------

use aeroid::jsbsim::own;
use aeroid::sim::scenario::Scenario;

const B737_3211: &str = "b737-elevator-3211";
const B737_LATERAL: &str = "b737-lateral-multistep";

/// The truth file of a recorded 737 flight holds JSBSim's local derivatives
/// at the trim point, exactly what `local_derivatives` gives at JSBSim's
/// trim, and the trim point itself; the derivatives are 737.xml's constants
/// where the file makes them so. Cn_r = −0.35 and Cl_r = 0.09 only because
/// the yaw damper's share (r into the rudder) is taken out by the chain rule
/// (through the yaw damper Cn_r reads −0.35 − 0.2·0.35·2V/b ≈ −1.05); Cm_q = −43 is Cmq −27 plus Cmα̇ −16 (∂α̇/∂q = 1, the
/// 737 has no lift from q); Cl_da = −(0.1 − 0.0335·M) in aeroid's sign.
#[test]
fn the_737_truth_file_holds_jsbsims_local_derivatives_at_trim() {
    aeroid::jsbsim::register();
    let scenario = Scenario::load(B737_3211).unwrap();
    let profile = aeroid::record::recorder::profile_for(&scenario, None).unwrap();
    let (record, truth) = aeroid::record::recorder::record_scenario(&scenario, &profile).unwrap();
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    // Flown from JSBSim's trim, the 737 holds it until the 3211 starts at 2 s.
    for sample in trace.samples.iter().take_while(|s| s.time < 2.0) {
        let air = &sample.evaluation.air_data;
        assert!(
            (air.alpha - truth.trim.alpha).abs() < 1e-5
                && (air.airspeed - truth.trim.airspeed).abs() < 1e-3
                && sample.state[aeroid::sim::state::Q].abs() < 1e-5,
            "t = {}: α {}, V {}, q {}",
            sample.time,
            air.alpha,
            air.airspeed,
            sample.state[aeroid::sim::state::Q]
        );
    }
    assert_eq!(truth.kind, aeroid::sim::truth::TruthKind::LocalDerivative);
    assert_eq!(truth.aircraft, "jsbsim:737");
    assert!(truth.parameters.is_empty());
    assert!(record.channels.len() >= 18);
    // The same trim and central differences, independently.
    let mut trimmed = own::trim(&scenario).unwrap();
    let derivatives = trimmed.derivatives().unwrap();
    assert_eq!(truth.local_derivatives.len(), derivatives.values.len());
    for (name, value) in &derivatives.values {
        assert_eq!(truth.local_derivatives[name], *value, "{name}");
    }
    assert!((truth.trim.airspeed - 144.0).abs() < 1e-6);
    assert!((truth.trim.altitude - 3048.0).abs() < 0.01);
    assert!((truth.trim.alpha - trimmed.alpha).abs() < 1e-12);
    assert!(
        (0.03..0.1).contains(&truth.trim.alpha),
        "trim α {}",
        truth.trim.alpha
    );
    assert!((truth.trim.controls["elevator"] - derivatives.deflections[0]).abs() < 1e-12);
    // Recorded thrust over max_thrust: ≈ 41 kN of 178 kN at trim.
    assert!((0.15..0.35).contains(&truth.trim.controls["throttle"]));
    // Round trip through truth.toml.
    let folder = common::temp_folder("b737-truth");
    let path = folder.join(aeroid::sim::truth::TRUTH_FILE);
    truth.write(&path).unwrap();
    assert_eq!(aeroid::sim::truth::RunTruth::read(&path).unwrap(), truth);

    let mach = trimmed.exec.get("velocities/mach").unwrap();
    let value = |name: &str| truth.local_derivatives[name];
    for (name, expected) in [
        ("Cl_p", -0.4),
        ("Cl_r", 0.09),
        ("Cl_dr", 0.01),
        ("Cn_r", -0.35),
        ("Cn_dr", -0.2),
        ("CL_alpha", 1.0 / 0.23),
        ("CL_de", 0.2),
        ("CL_q", 0.0),
        ("Cm_q", -43.0),
        ("Cl_da", -(0.1 - 0.067 / 2.0 * mach)),
    ] {
        assert!(
            (value(name) - expected).abs() < 1e-8,
            "{name}: {} vs {expected}",
            value(name)
        );
    }
    // The gear is up and the flight is over aeroid's flat earth: g0 less
    // the 2h/R of a planet of radius 1e9 m (6e-6 at 3 km).
    assert_eq!(trimmed.exec.get("gear/gear-pos-norm").unwrap(), 0.0);
    let gravity = trimmed.exec.get("accelerations/gravity-ft_sec2").unwrap() * FT;
    assert!((gravity / 9.80665 - 1.0).abs() < 1e-5, "g = {gravity}");
}

/// The 737's flight-control system rewrites the surface positions in every
/// RunIC (the trap): a surface position written directly does not survive,
/// and central differences through the positions are refused with an error
/// naming the properties. Through the commands each surface moves by its
/// gain (0.3 rad per unit elevator command, 0.35 aileron and rudder) and its
/// coefficient moves with the sign of aeroid's conventions (Cmδe < 0,
/// Clδa < 0 with aileron = −left aileron, Cnδr < 0).
#[test]
fn the_737_fcs_moves_every_surface_only_through_its_command() {
    aeroid::jsbsim::register();
    use aeroid::jsbsim::derivatives::{SurfaceBinding, coefficients, local_derivatives};
    let scenario = Scenario::load(B737_3211).unwrap();
    let mut trimmed = own::trim(&scenario).unwrap();
    let surfaces = trimmed.surfaces();
    let at = trimmed.at;
    let exec = &mut trimmed.exec;
    let evaluate = |exec: &mut Exec, commands: [f64; 3]| {
        for (surface, command) in surfaces.iter().zip(commands) {
            exec.set(&surface.command, command).unwrap();
        }
        exec.set_initial_conditions(&at).unwrap();
        exec.run_ic().unwrap();
        let positions: Vec<f64> = surfaces
            .iter()
            .map(|s| s.sign * exec.get(&s.position).unwrap())
            .collect();
        (coefficients(exec).unwrap(), positions)
    };
    let trim_commands = surfaces.each_ref().map(|s| s.command_value);
    let (base, base_positions) = evaluate(exec, trim_commands);
    // Coefficient index (CL, CY, CD, Cl, Cm, Cn) each surface moves, the
    // gain of deflection (aeroid's sign) per unit command, the sign of ∂C/∂δ.
    for (k, (coefficient, gain, sign)) in [(4, 0.3, -1.0), (3, -0.35, -1.0), (5, 0.35, -1.0)]
        .into_iter()
        .enumerate()
    {
        let mut commands = trim_commands;
        commands[k] += 0.05;
        let (moved, positions) = evaluate(exec, commands);
        let deflection = positions[k] - base_positions[k];
        assert!(
            (deflection - 0.05 * gain).abs() < 1e-12,
            "{}: deflection {deflection}",
            surfaces[k].command
        );
        let change = moved[coefficient] - base[coefficient];
        assert!(
            change * sign / deflection > 0.0 && change.abs() > 1e-3,
            "{}: coefficient change {change} for {deflection} rad",
            surfaces[k].command
        );
    }
    // Written directly, a position is overwritten by the FCS in RunIC.
    evaluate(exec, trim_commands);
    exec.set("fcs/elevator-pos-rad", 0.1).unwrap();
    exec.run_ic().unwrap();
    let elevator = exec.get("fcs/elevator-pos-rad").unwrap();
    assert!(
        (elevator - base_positions[0]).abs() < 1e-12,
        "the FCS keeps {elevator}"
    );
    let direct = surfaces
        .each_ref()
        .map(|s| SurfaceBinding::direct(&s.position, 0.0));
    let error = local_derivatives(exec, &at, &direct).unwrap_err();
    let text = message(&error);
    assert!(
        text.contains("does not move") && text.contains("fcs/elevator-pos-rad"),
        "{text}"
    );
}

/// Bad input: a JSBSim aircraft JSBSim does not have, a JSBSim scenario
/// without its `[jsbsim]` table, a `[jsbsim]` table on an aeroid aircraft,
/// wind (not fed to JSBSim) and a rigid body that is not JSBSim's: each a
/// clear error naming the file and the field.
#[test]
fn bad_jsbsim_scenarios_are_clear_errors() {
    aeroid::jsbsim::register();
    let folder = common::temp_folder("b737-bad-input");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/b737-elevator-3211.toml"
    ))
    .unwrap();
    let load = |name: &str, edited: String| {
        let path = common::write(&folder, name, &edited);
        (
            path.clone(),
            message(&Scenario::load(path.to_str().unwrap()).unwrap_err()),
        )
    };
    let (path, text_unknown) = load(
        "unknown.toml",
        text.replace("jsbsim:737", "jsbsim:747-400x"),
    );
    for expected in [
        path.to_str().unwrap(),
        "aircraft",
        "JSBSim has no aircraft '747-400x'",
        "737, 787-8",
        "c172p",
    ] {
        assert!(
            text_unknown.contains(expected),
            "{expected}: {text_unknown}"
        );
    }
    let without_table = text
        .replace("[jsbsim]", "[other]")
        .replace("rigid_body = \"b737-jsbsim\"", "");
    let (_, missing) = load("missing.toml", without_table.replace("[other]\n", ""));
    assert!(
        missing.contains("jsbsim") && missing.contains("rigid_body"),
        "{missing}"
    );
    let (_, stray) = load("stray.toml", text.replace("\"jsbsim:737\"", "\"attas\""));
    assert!(
        stray.contains("only a scenario whose aircraft is"),
        "{stray}"
    );
    let (_, windy) = load("windy.toml", format!("{text}\n[wind]\nspeed = \"10 kt\"\n"));
    assert!(
        windy.contains("wind") && windy.contains("still air"),
        "{windy}"
    );
    // A rigid body that is not the 737's is refused when flown, listing JSBSim's values.
    let mut scenario = Scenario::load(B737_3211).unwrap();
    scenario.aircraft = attas();
    let refused = message(&own::fly(&scenario).unwrap_err());
    assert!(
        refused.contains("mass is 1.763100e4, JSBSim has 4.853"),
        "{refused}"
    );
}

/// The eight derivatives the issue scores, with the scenario that excites
/// each, and the tolerances (relative to JSBSim's local derivative):
/// - output error on the flight recorded WITHOUT noise (same profile, noise
///   lines removed): about 1.5 times the error measured (floor 0.1 %). This
///   error is deterministic: model structure, which
///   [`the_linear_postulate_fits_jsbsims_own_coefficients`] measures (up to
///   1 %, Cm_q), and, for Cn_beta and Cn_r (1.3–1.5 %), the yaw damper's
///   share of the rudder, continuous between the 25 Hz samples that the
///   estimator holds (0.3 % at 100 Hz). A regression of the truth, the
///   flight or the estimator moves it.
/// - output error on the flight-test record: the no-noise error measured
///   plus 3 Cramér–Rao σ (measured σ of these fits), rounded up: the noise
///   may add what the bound allows, no more.
/// - equation error on the flight-test record: about twice the error
///   measured, and towards zero. On noisy data it is biased towards zero by
///   3.5–15 % (errors in variables, the reflex-wing UAV paper; the moments were 7–18 % off
///   while the differentiator smeared the control steps).
const SCORED: [(&str, &str, f64, f64, f64); 8] = [
    ("CL_alpha", B737_3211, 0.001, 0.020, 0.25),
    ("Cm_alpha", B737_3211, 0.005, 0.010, 0.30),
    ("Cm_q", B737_3211, 0.025, 0.040, 0.16),
    ("Cm_de", B737_3211, 0.012, 0.030, 0.17),
    ("Cl_beta", B737_LATERAL, 0.003, 0.011, 0.10),
    ("Cl_p", B737_LATERAL, 0.001, 0.007, 0.071),
    ("Cn_beta", B737_LATERAL, 0.022, 0.018, 0.07),
    ("Cn_r", B737_LATERAL, 0.020, 0.028, 0.071),
];

/// Flies a 737 scenario in JSBSim and records it with its (flight-test)
/// profile and with the same profile without noise; gives both records and
/// the truth.
fn fly_737(
    name: &str,
) -> (
    aeroid::record::FlightRecord,
    aeroid::record::FlightRecord,
    aeroid::sim::truth::RunTruth,
) {
    let scenario = Scenario::load(name).unwrap();
    let profile = aeroid::record::recorder::profile_for(&scenario, None).unwrap();
    assert_eq!(profile.name, "flight-test-25hz");
    let (trace, truth) = aeroid::sim::fly(&scenario).unwrap();
    let noisy = profile
        .record(&trace, &scenario.aircraft, scenario.seed)
        .unwrap();
    let clean = profile
        .without_random_errors()
        .record(&trace, &scenario.aircraft, scenario.seed)
        .unwrap();
    (noisy, clean, truth)
}

/// Equation error and output error on the JSBSim 737's elevator 3211 and
/// aileron/rudder multistep, recorded by the 25 Hz flight-test profile, on
/// the decoupled models `b737-longitudinal` and `b737-lateral`: each of
/// CL_alpha, Cm_alpha, Cm_q, Cm_de, Cl_beta, Cl_p, Cn_beta, Cn_r scored
/// against JSBSim's local derivatives at trim within the tolerances of
/// [`SCORED`]. Prints the table docs/jsbsim.md quotes (`-- --nocapture`).
#[test]
fn estimators_recover_the_737_derivatives_from_flight_test_data() {
    aeroid::jsbsim::register();
    use aeroid::estimation::structure::{ModelStructure, Structure};
    println!(
        "{:<9} {:<12} {:>10} {:>10} {:>9} {:>9} {:>7}",
        "parameter", "method", "estimate", "JSBSim", "rel.err", "σ", "err/σ"
    );
    let mut failures = Vec::new();
    for (scenario_name, model) in [
        (B737_3211, "b737-longitudinal"),
        (B737_LATERAL, "b737-lateral"),
    ] {
        let (noisy, clean, truth) = fly_737(scenario_name);
        let structure = ModelStructure::load(model).unwrap();
        let kinds = Structure::from(structure.clone());
        // The pilot's commands are piecewise constant; JSBSim's yaw damper
        // moves the rudder between samples, so the default input timing
        // takes the recorded rudder linearly and the aileron held. Against
        // JSBSim's local derivatives at trim (a linear postulate of
        // nonlinear tables) that moves output error's Cn_r from −1.4 % to
        // −3.6 % and Cl_p from +0.5 % to −0.3 % on the noisy record
        // (docs/jsbsim.md). The tolerances of [`SCORED`] are those of
        // every input held, which this test sets.
        let held: aeroid::estimation::estimator::MethodTables =
            toml::from_str("[oem]\ninterpolation = \"zoh\"\n").unwrap();
        for (method, record, label) in [
            ("oem", &clean, "oem no noise"),
            ("oem", &noisy, "oem"),
            ("ee", &noisy, "ee"),
        ] {
            let aeroid::eval::run::Outcome::Estimated { estimate, scores } =
                aeroid::eval::run::estimate_scored(
                    crate::common::registry(),
                    method,
                    record,
                    &truth,
                    &kinds,
                    &[&held],
                    None,
                )
            else {
                panic!("{label} on {scenario_name}: no estimate");
            };
            let fit_quality = estimate
                .fits
                .iter()
                .map(|f| {
                    format!(
                        "{} R² {:.5} structured {:.4}",
                        f.channel, f.r_squared, f.structured
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            println!(
                "{label} on {scenario_name}: {} ({fit_quality})",
                estimate.status
            );
            // Noise-free, every residual is the linear model's error
            // against JSBSim's tables: the elevator fit leaves a structured
            // residual at the coloured-residual limit in pitch (measured
            // 0.0502, R² 0.9975), which may be diagnosed; every output stays
            // below 0.06. Every fit converges.
            use aeroid::estimation::estimate::Status;
            let acceptable = match label {
                "oem no noise" => {
                    estimate.status == Status::Converged
                        && estimate.fits.iter().all(|f| f.structured < 0.06)
                }
                _ => estimate.status == Status::Converged,
            };
            assert!(
                acceptable,
                "{label} on {scenario_name}: {} ({fit_quality})",
                estimate.status
            );
            for (name, _, clean_tolerance, oem_tolerance, ee_tolerance) in
                SCORED.iter().filter(|row| row.1 == scenario_name)
            {
                let score = scores.iter().find(|s| s.name == *name).unwrap();
                let (jsbsim, kind) = truth.value_for(name, structure.aircraft.aero.kind).unwrap();
                assert_eq!(kind, aeroid::sim::truth::TruthKind::LocalDerivative);
                let relative = (score.estimate - jsbsim) / jsbsim;
                println!(
                    "{:<9} {:<12} {:>10.5} {:>10.5} {:>+8.2}% {:>9.2e} {:>+7.2}",
                    name,
                    label,
                    score.estimate,
                    jsbsim,
                    100.0 * relative,
                    score.standard_error,
                    (score.estimate - jsbsim) / score.standard_error
                );
                let tolerance = match label {
                    "oem no noise" => *clean_tolerance,
                    "oem" => *oem_tolerance,
                    _ => *ee_tolerance,
                };
                let towards_zero = method == "oem" || score.estimate.abs() < jsbsim.abs();
                if relative.abs() > tolerance || !towards_zero {
                    failures.push(format!(
                        "{label} {name}: {:.5} vs JSBSim {jsbsim:.5} ({:+.2} %, allowed {:.1} %{})",
                        score.estimate,
                        100.0 * relative,
                        100.0 * tolerance,
                        if towards_zero {
                            ""
                        } else {
                            ", not towards zero"
                        }
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The model-structure error, measured without any estimator: JSBSim's own
/// coefficients along each noise-free flight (every 10 ms sample of the
/// trace), fitted by least squares with the postulated terms (CL, Cm on 1, α,
/// q̂, δe; Cl, Cn on 1, β, p̂, r̂, δa, δr), against the local derivatives at
/// trim. The differences are what linearising a table-driven model with an
/// α̇ term at one point costs: Cm_q 1.0 % (the α̇ term's share depends on V
/// and θ too), Cm_de and Cm_alpha 0.3 %, Cl_beta 0.3 %, the rest < 0.1 %.
/// Required: within 1.5 %. Output error cannot be asked to beat this.
#[test]
fn the_linear_postulate_fits_jsbsims_own_coefficients() {
    aeroid::jsbsim::register();
    use nalgebra::{DMatrix, DVector};
    for (scenario_name, coefficient, terms) in [
        (B737_3211, "Cm", &["alpha", "q", "de"][..]),
        (B737_3211, "CL", &["alpha", "de"][..]),
        (B737_LATERAL, "Cl", &["beta", "p", "r", "da", "dr"][..]),
        (B737_LATERAL, "Cn", &["beta", "p", "r", "da", "dr"][..]),
    ] {
        let scenario = Scenario::load(scenario_name).unwrap();
        let (trace, truth) = aeroid::sim::fly(&scenario).unwrap();
        let (span, chord) = (
            scenario.aircraft.geometry.span,
            scenario.aircraft.geometry.chord,
        );
        let regressor = |s: &aeroid::sim::trace::TruthSample, term: &str| {
            let air = &s.evaluation.air_data;
            let rates = aeroid::sim::state::rates(&s.state);
            let u = &s.evaluation.controls;
            match term {
                "alpha" => air.alpha,
                "beta" => air.beta,
                "p" => rates.x * span / (2.0 * air.airspeed),
                "q" => rates.y * chord / (2.0 * air.airspeed),
                "r" => rates.z * span / (2.0 * air.airspeed),
                "de" => u[0],
                "da" => u[1],
                "dr" => u[2],
                _ => 1.0,
            }
        };
        let value = |s: &aeroid::sim::trace::TruthSample| {
            let c = &s.evaluation.coefficients;
            match coefficient {
                "Cm" => c.moment.y,
                "CL" => c.lift,
                "Cl" => c.moment.x,
                _ => c.moment.z,
            }
        };
        let samples = &trace.samples;
        let a = DMatrix::from_fn(samples.len(), terms.len() + 1, |i, j| {
            if j == 0 {
                1.0
            } else {
                regressor(&samples[i], terms[j - 1])
            }
        });
        let y = DVector::from_fn(samples.len(), |i, _| value(&samples[i]));
        let fit = a.svd(true, true).solve(&y, 1e-14).unwrap();
        for (j, term) in terms.iter().enumerate() {
            let name = format!("{coefficient}_{term}");
            let local = truth.local_derivatives[&name];
            let along = fit[j + 1];
            let scored = SCORED.iter().any(|row| row.0 == name);
            println!(
                "{name:<9} local {local:>10.5}  along the flight {along:>10.5}  (difference {:+.2e})",
                along - local
            );
            if scored {
                assert!(
                    (along - local).abs() <= 0.015 * local.abs(),
                    "{name}: {along} along the flight vs {local} at trim"
                );
            }
        }
    }
}
