//! The bundled example of docs/import.md, "From a flight-test file to a
//! fitted stall model", run as a user runs it: a flight (the ATTAS stall
//! manoeuvre on the flight-test recorder, standing in for a real one)
//! exported as a MATLAB file and written as whitespace ASCII in the
//! textbook's names and units, each imported with its bundled map
//! (`examples/stall-flight/`), the aerodynamic coefficients computed from
//! the accelerations, and the stall model fitted to them.

use crate::cli::stdout_of;
use crate::common;
use std::path::{Path, PathBuf};

const DEG: f64 = std::f64::consts::PI / 180.0;
const FOOT: f64 = 0.3048;
const G0: f64 = 9.80665;

/// aeroid run from the project's folder (where the example's files are).
fn aeroid() -> std::process::Command {
    let mut command = crate::cli::aeroid();
    command.current_dir(env!("CARGO_MANIFEST_DIR"));
    command
}

/// The record as a whitespace ASCII file with a header row in the
/// textbook's names and units (the map `examples/stall-flight/ascii-map.toml`).
fn textbook_ascii(record: &aeroid::record::FlightRecord) -> String {
    // (header, channel, factor from SI to the file's unit)
    let columns: [(&str, &str, f64); 20] = [
        ("V", "airspeed", 1.0),
        ("alpha", "alpha", 1.0 / DEG),
        ("beta", "beta", 1.0 / DEG),
        ("p", "p", 1.0 / DEG),
        ("q", "q", 1.0 / DEG),
        ("r", "r", 1.0 / DEG),
        ("phi", "roll", 1.0 / DEG),
        ("theta", "pitch", 1.0 / DEG),
        ("psi", "yaw", 1.0 / DEG),
        ("ax", "nx", G0),
        ("ay", "ny", G0),
        ("az", "nz", -G0),
        ("de", "elevator", 1.0 / DEG),
        ("da", "aileron", 1.0 / DEG),
        ("dr", "rudder", 1.0 / DEG),
        ("df", "flap", 1.0 / DEG),
        ("dT", "throttle", 1.0),
        ("h", "altitude", 1.0 / FOOT),
        ("Mach", "mach", 1.0),
        ("qbar", "dynamic_pressure", 1.0),
    ];
    let times = &record.channel("airspeed").unwrap().times;
    let mut text = "t".to_string();
    for (header, ..) in &columns {
        text += &format!("  {header}");
    }
    text += "\n";
    for (k, t) in times.iter().enumerate() {
        text += &t.to_string();
        for (_, channel, factor) in &columns {
            let value = record.channel(channel).unwrap().values[k];
            text += &format!("  {}", value * factor);
        }
        text += "\n";
    }
    text
}

/// The estimate `aeroid estimate --out` wrote: each parameter's value and σ.
fn estimate(folder: &Path) -> Vec<(String, f64, f64)> {
    let text = std::fs::read_to_string(folder.join("estimate.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_string(),
                p["value"].as_f64().unwrap(),
                p["standard_error"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// Both files import to the same record up to the ASCII's unit
/// conversions; the coefficients computed from either give the same fit
/// (within 1e-3 σ); the fit converges and lands every parameter within 3
/// of its Cramér–Rao σ of the flight's truth (the bound's 3σ: a miss has
/// 0.3 % probability per parameter).
#[test]
fn the_stall_example_goes_from_the_files_to_the_fitted_model() {
    let folder = common::temp_folder("stall_example");
    let path = |name: &str| -> PathBuf { folder.join(name) };
    let (flight, mat, ascii) = (path("stall"), path("stall.mat"), path("stall.asc"));
    stdout_of(
        aeroid()
            .args([
                "record",
                "attas-stall",
                "--profile",
                "flight-test-25hz",
                "--out",
            ])
            .arg(&flight),
    );
    stdout_of(aeroid().arg("export").arg(&flight).arg("--out").arg(&mat));
    let record = aeroid::record::FlightRecord::read(&flight).unwrap();
    std::fs::write(&ascii, textbook_ascii(&record)).unwrap();
    let mut fits = Vec::new();
    for (file, map) in [(&mat, "mat-map.toml"), (&ascii, "ascii-map.toml")] {
        let name = file.extension().unwrap().to_str().unwrap();
        let map = Path::new("examples/stall-flight").join(map);
        let (imported, coefficients, fitted) = (
            path(&format!("{name}-imported")),
            path(&format!("{name}-coefficients")),
            path(&format!("{name}-fit")),
        );
        stdout_of(
            aeroid()
                .arg("import")
                .arg(file)
                .arg("--map")
                .arg(&map)
                .arg("--out")
                .arg(&imported),
        );
        let derived = stdout_of(
            aeroid()
                .arg("derive")
                .arg(&imported)
                .arg("--out")
                .arg(&coefficients)
                .args([
                    "--no-flow-angles",
                    "--no-rates",
                    "--coefficients",
                    "attas-stall",
                ]),
        );
        assert!(
            derived.contains("CX, CY, CZ, CL, CD, Cl, Cm, Cn"),
            "{derived}"
        );
        let model = Path::new("examples/stall-flight/stall-coefficients.toml");
        let printed = stdout_of(
            aeroid()
                .arg("estimate")
                .arg(&coefficients)
                .arg("--model")
                .arg(model)
                .args(["--method", "oem", "--out"])
                .arg(&fitted),
        );
        assert!(
            printed.contains("Converged") || printed.contains("converged"),
            "{printed}"
        );
        fits.push(estimate(&fitted));
    }
    let truth = aeroid::sim::scenario::Scenario::load("attas-stall").unwrap();
    let mut worst = (0.0, String::new());
    for ((name, value, sigma), (other, ascii_value, _)) in fits[0].iter().zip(&fits[1]) {
        assert_eq!(name, other);
        assert!(
            (value - ascii_value).abs() <= 1e-3 * sigma,
            "{name}: {value} from the MAT-file, {ascii_value} from the ASCII file (σ {sigma})"
        );
        let expected = truth.aircraft.aero.parameters.get(name).unwrap();
        let off = (value - expected).abs() / sigma;
        if off > worst.0 {
            worst = (off, name.clone());
        }
    }
    eprintln!("worst: {:.2} σ ({})", worst.0, worst.1);
    assert!(worst.0 <= 3.0, "{:.2} σ: {}", worst.0, worst.1);
}
