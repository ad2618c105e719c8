//! JSBSim through FFI (feature `jsbsim`; run in release:
//! `cargo test --release --features jsbsim --test jsbsim`). Each known trap
//! of driving JSBSim from a library has a test here, as do the export and
//! the cross-check of aeroid's simulator against JSBSim.
#![cfg(feature = "jsbsim")]

mod common;

use aeroid::Error;
use aeroid::aircraft::Aircraft;
use aeroid::jsbsim::export::{ExportOptions, aircraft_xml, export, model_name};
use aeroid::jsbsim::{Exec, FT, InitialConditions, InitialSpeed, TrimMode};
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

fn load(folder: &Path, model: &str, allow_io: bool) -> aeroid::Result<Exec> {
    let mut exec = Exec::new()?;
    exec.load_model_in(folder, model, allow_io)?;
    Ok(exec)
}

fn message(error: &Error) -> String {
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
    let scenario = aeroid::scenario::Scenario::load(scenario).unwrap();
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
    cross_check_agrees(
        "attas-elevator-3211",
        &["u", "w", "q", "theta", "airspeed", "alpha", "altitude"],
    );
}

#[test]
fn cross_check_attas_lateral_multistep() {
    cross_check_agrees(
        "attas-lateral-multistep",
        &[
            "v", "p", "r", "phi", "psi", "beta", "u", "theta", "airspeed",
        ],
    );
}

#[test]
fn cross_check_cdrw_longitudinal() {
    cross_check_agrees(
        "cdrw-longitudinal",
        &["u", "w", "q", "theta", "airspeed", "alpha", "altitude"],
    );
}

#[test]
fn cross_check_cdrw_lateral() {
    cross_check_agrees("cdrw-lateral", &["v", "p", "r", "phi", "psi", "beta"]);
}

/// With JSBSim's own atmosphere (geopotential altitude) the trims differ by
/// the density at 3.7 m of altitude at 4877 m, and the ATTAS elevator 3211's
/// speed then drifts by more than with aeroid's ISA in the exported file: the
/// difference the README documents.
#[test]
fn jsbsim_atmosphere_is_a_measurable_convention_difference() {
    use aeroid::jsbsim::crosscheck::{CrossCheckOptions, crosscheck};
    let scenario = aeroid::scenario::Scenario::load("attas-elevator-3211").unwrap();
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
/// derivatives of the same model: all 48 within 1e-6 + 1e-5 relative. The
/// machinery that will give a JSBSim aircraft's truth (issue 5, use 2).
#[test]
fn central_differences_through_jsbsim_recover_the_exported_derivatives() {
    use aeroid::jsbsim::derivatives::{ControlSurfaces, local_derivatives};
    use aeroid::jsbsim::export::{CONTROL_PROPERTIES, THROTTLE_PROPERTY};
    use aeroid::state::Control;
    let scenario = aeroid::scenario::Scenario::load("attas-elevator-3211").unwrap();
    let simulation = aeroid::sim::Simulation::prepare(&scenario).unwrap();
    let trim = &simulation.trim;
    let truth = aeroid::truth::RunTruth::exact(&scenario, trim);
    let folder = common::temp_folder("jsbsim-derivatives");
    export(&scenario.aircraft, &ExportOptions::default(), &folder).unwrap();
    let mut exec = load(&folder, &model_name(&scenario.aircraft), false).unwrap();
    exec.set(THROTTLE_PROPERTY, trim.controls[Control::Throttle.index()])
        .unwrap();
    let euler = aeroid::state::euler(&trim.state);
    let at = InitialConditions {
        latitude: 0.0,
        longitude: 0.0,
        altitude: aeroid::state::altitude(&trim.state),
        attitude: [euler.roll, euler.pitch, euler.yaw],
        speed: InitialSpeed::TrueAirspeed {
            speed: scenario.trim.airspeed,
            alpha: trim.alpha,
            beta: trim.beta,
        },
        rates: [0.0; 3],
    };
    let surface = |control: Control| {
        (
            CONTROL_PROPERTIES[control.index()],
            trim.controls[control.index()],
        )
    };
    let controls = ControlSurfaces {
        elevator: surface(Control::Elevator),
        aileron: surface(Control::Aileron),
        rudder: surface(Control::Rudder),
    };
    let derivatives = local_derivatives(&mut exec, &at, &controls).unwrap();
    assert_eq!(derivatives.len(), 48);
    for (name, jsbsim) in &derivatives {
        let expected = truth.local_derivatives[name];
        assert!(
            (jsbsim - expected).abs() <= 1e-6 + 1e-5 * expected.abs(),
            "{name}: JSBSim {jsbsim} vs aeroid {expected}"
        );
    }
    let value = |name: &str| derivatives.iter().find(|(n, _)| n == name).unwrap().1;
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
        assert!(
            (value(name) - file).abs() <= 1e-5 * file.abs(),
            "{name}: {} vs {file}",
            value(name)
        );
    }
}

/// The 737 trims with JSBSim's own trim (engines running, gear up, 10 000 ft,
/// 280 kt), and central differences through JSBSim at that trim give the
/// file's roll damping Clp = −0.4 (a constant in 737.xml, with no side force
/// from p to move it). Not yet usable as truth (README, "Still to do"): its
/// flight-control system rewrites the surface positions in every RunIC, so
/// surface derivatives must go through the commands, and its yaw damper and
/// the α̇ term fold into Cn_r and Cm_q.
#[test]
fn the_737_trims_and_its_roll_damping_is_recovered() {
    use aeroid::jsbsim::derivatives::{ControlSurfaces, local_derivatives};
    let mut exec = Exec::new().unwrap();
    exec.load_model("737").unwrap();
    let mut at = b737_cruise();
    at.altitude = 10_000.0 * FT;
    exec.set_initial_conditions(&at).unwrap();
    exec.set("propulsion/set-running", -1.0).unwrap();
    exec.set("gear/gear-cmd-norm", 0.0).unwrap();
    exec.run_ic().unwrap();
    exec.trim(TrimMode::Full).unwrap();
    let alpha = exec.get("aero/alpha-rad").unwrap();
    assert!((0.0..0.2).contains(&alpha), "trim α {alpha} rad");
    at.attitude[1] = exec.get("attitude/theta-rad").unwrap();
    at.speed = InitialSpeed::TrueAirspeed {
        speed: exec.get("velocities/vt-fps").unwrap() * FT,
        alpha,
        beta: exec.get("aero/beta-rad").unwrap(),
    };
    let surface = |exec: &Exec, name: &'static str| (name, exec.get(name).unwrap());
    let controls = ControlSurfaces {
        elevator: surface(&exec, "fcs/elevator-pos-rad"),
        aileron: surface(&exec, "fcs/left-aileron-pos-rad"),
        rudder: surface(&exec, "fcs/rudder-pos-rad"),
    };
    let derivatives = local_derivatives(&mut exec, &at, &controls).unwrap();
    let value = |name: &str| derivatives.iter().find(|(n, _)| n == name).unwrap().1;
    assert!((value("Cl_p") + 0.4).abs() < 1e-9, "Cl_p {}", value("Cl_p"));
    assert!(value("CL_alpha") > 3.0 && value("Cm_alpha") < 0.0);
}
