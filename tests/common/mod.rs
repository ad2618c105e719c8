//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// A fresh folder in cargo's scratch folder for integration tests
/// (`target/tmp`), unique per test and process.
pub fn temp_folder(test: &str) -> PathBuf {
    let folder = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("aeroid-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&folder);
    std::fs::create_dir_all(&folder).unwrap();
    folder
}

/// Writes `text` to `name` inside `folder`, returning the path.
pub fn write(folder: &std::path::Path, name: &str, text: &str) -> PathBuf {
    let path = folder.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The bundled ATTAS aircraft file with `edit` applied to its text.
pub fn attas_with(edit: impl Fn(String) -> String) -> String {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/aircraft/attas.toml"))
        .unwrap();
    edit(text)
}

/// Imports `csv` with the column map `map`, both written to a fresh folder
/// named after `test` (as `flight.csv` and `map.toml`).
pub fn import_case(
    test: &str,
    csv: &str,
    map: &str,
) -> aeroid::record::Result<aeroid::record::import::ImportOutcome> {
    let folder = temp_folder(test);
    let data = write(&folder, "flight.csv", csv);
    let map = write(&folder, "map.toml", map);
    aeroid::record::import::import(&data, &map, aeroid::estimation::CHANNELS_READ)
}

/// Flies `scenario` and records it with `profile` (its recorder draws from
/// the scenario's seed): the record and the truth trace.
pub fn fly_and_record(
    scenario: &aeroid::sim::scenario::Scenario,
    profile: &aeroid::record::recorder::Profile,
) -> (aeroid::record::FlightRecord, aeroid::sim::trace::TruthTrace) {
    let (trace, _) = aeroid::sim::fly(scenario).unwrap();
    let record = profile
        .record(&trace, &scenario.aircraft, scenario.seed)
        .unwrap();
    (record, trace)
}

/// The truth column `name` at `times`, interpolated linearly.
pub fn truth_at(trace: &aeroid::sim::trace::TruthTrace, name: &str, times: &[f64]) -> Vec<f64> {
    let grid: Vec<f64> = trace.samples.iter().map(|s| s.time).collect();
    let values = trace.values(name).unwrap();
    times
        .iter()
        .map(|&t| aeroid::record::recorder::interpolate(&grid, &values, t))
        .collect()
}

/// Each estimated parameter against the scenario's truth: (name, estimate,
/// σ, truth); NaN where the truth model has no such parameter.
pub fn against_truth(
    estimate: &aeroid::estimation::estimate::Estimate,
    scenario: &aeroid::sim::scenario::Scenario,
) -> Vec<(String, f64, f64, f64)> {
    estimate
        .parameters
        .iter()
        .map(|p| {
            let truth = scenario
                .aircraft
                .aero
                .parameters
                .get(&p.name)
                .unwrap_or(f64::NAN);
            (p.name.clone(), p.value, p.standard_error, truth)
        })
        .collect()
}

/// Rows of [`against_truth`] as text: value ± σ, truth, error in % and σ.
pub fn truth_table(rows: &[(String, f64, f64, f64)]) -> String {
    rows.iter()
        .map(|(name, value, sigma, truth)| {
            format!(
                "{name}: {value:.5} ± {sigma:.5} (truth {truth:.5}, {:+.2} %, {:+.2} σ)\n",
                100.0 * (value - truth) / truth,
                (value - truth) / sigma
            )
        })
        .collect()
}

/// The parameters the a-priori identifiability analysis calls identifiable
/// on the bundled transport approach recorded by qar-seed000, in 20-s
/// segments with the controls as recorded (`qar_identifiability_table` in
/// tests/estimators/identifiability.rs checks the analysis against this list; the
/// QAR end-to-end test checks which of them an estimator reaches).
pub const APPROACH_IDENTIFIABLE: [&str; 20] = [
    "CD_0", "CD_df", "CL_0", "CL_alpha", "CL_df", "CY_beta", "CY_p", "CY_r", "Cl_beta", "Cl_da",
    "Cl_p", "Cl_r", "Cm_0", "Cm_alpha", "Cm_de", "Cm_df", "Cm_q", "Cn_beta", "Cn_r", "e",
];

/// Of [`APPROACH_IDENTIFIABLE`], those the analysis calls identifiable
/// only through the gusts (the calm flight does not identify them).
pub const APPROACH_THROUGH_GUSTS: [&str; 5] = ["CY_p", "CY_r", "Cl_p", "Cl_r", "Cn_r"];

/// Of [`APPROACH_IDENTIFIABLE`], those whose mode the QAR's 1 Hz samples
/// below the sampling rule of Wang et al. 2012 (25 times the mode's
/// frequency at the trim).
pub const APPROACH_BELOW_RULE: [&str; 5] = ["CL_alpha", "Cl_p", "Cm_alpha", "Cm_q", "Cn_beta"];

/// The bundled transport approach, optionally without gusts and turbulence
/// (its steady 20 kt wind from 250° stays).
pub fn approach(gusty: bool) -> aeroid::sim::scenario::Scenario {
    let mut scenario = aeroid::sim::scenario::Scenario::load("transport-approach").unwrap();
    if !gusty {
        scenario.wind.gusts.clear();
        scenario.wind.turbulence = None;
    }
    scenario
}

/// A bundled recorder profile (`recorders/BASE.toml`) rewritten channel by
/// channel and loaded: `header` is appended to the top-level keys; for each
/// `[[channels]]` table `edit(name, table)` returns its new text, or None
/// to leave the channel out.
pub fn profile_variant(
    folder: &std::path::Path,
    base: &str,
    header: &str,
    edit: impl Fn(&str, &str) -> Option<String>,
) -> aeroid::record::recorder::Profile {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("recorders/{base}.toml")),
    )
    .unwrap();
    let mut parts = text.split("[[channels]]");
    let mut out = parts.next().unwrap().to_string() + header + "\n";
    let mut kept = 0;
    for part in parts {
        let name = part.split('"').nth(1).unwrap();
        if let Some(table) = edit(name, part) {
            out += "[[channels]]";
            out += &table;
            out += "\n";
            kept += 1;
        }
    }
    let path = write(folder, &format!("{base}-variant-{kept}.toml"), &out);
    aeroid::record::recorder::Profile::load(path.to_str().unwrap(), None).unwrap()
}

/// The largest error of an estimate's parameters that have a truth,
/// relative to max(|truth|, `floor`), with the parameter's name.
pub fn worst_relative_error(
    estimate: &aeroid::estimation::estimate::Estimate,
    truth: &aeroid::sim::truth::RunTruth,
    floor: f64,
) -> (f64, String) {
    estimate
        .parameters
        .iter()
        .filter_map(|p| {
            let t = *truth.parameters.get(&p.name)?;
            Some(((p.value - t).abs() / t.abs().max(floor), p.name.clone()))
        })
        .fold((0.0, String::new()), |a, b| if b.0 > a.0 { b } else { a })
}

/// The HANSA-3 longitudinal multistep (seed 5) recorded by the
/// flight-test profile at 1.25 Hz: a record whose sample period is coarse
/// for the short period (h·|λ| = 2.3).
pub fn hansa3_at_1_25_hz() -> aeroid::record::FlightRecord {
    let mut scenario = aeroid::sim::scenario::Scenario::load("hansa3-elevator-multistep").unwrap();
    scenario.seed = 5;
    let profile = aeroid::record::recorder::Profile::load("flight-test-25hz", None)
        .unwrap()
        .with_rate(1.25);
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    profile.record(&trace, &scenario.aircraft, 5).unwrap()
}

/// The note an estimate gives when it integrates in sub-steps, and the
/// step it names.
pub fn integration_step_note(estimate: &aeroid::estimation::estimate::Estimate) -> (String, f64) {
    let note = estimate
        .notes
        .iter()
        .find(|n| n.starts_with("integration step"))
        .unwrap_or_else(|| panic!("no step note: {:?}", estimate.notes));
    // The grid step over the RK4 steps per grid interval where the note
    // gives them (the step itself is printed to 4 decimals).
    let after = |key: &str| -> Option<f64> {
        let start = note.find(key)? + key.len();
        note[start..].split(' ').next()?.parse().ok()
    };
    let step = match (after("the grid step "), after("integrated in ")) {
        (Some(grid), Some(substeps)) => grid / substeps,
        _ => after("integration step ").unwrap_or_else(|| panic!("no step in '{note}'")),
    };
    (note.clone(), step)
}

/// The largest change of an estimate between two fits, in the first
/// fit's standard errors.
pub fn largest_move_in_sigma(
    first: &aeroid::estimation::estimate::Estimate,
    second: &aeroid::estimation::estimate::Estimate,
) -> f64 {
    first
        .parameters
        .iter()
        .zip(&second.parameters)
        .map(|(a, b)| ((a.value - b.value) / a.standard_error).abs())
        .fold(0.0, f64::max)
}

/// The derive step as the QAR approach's tests take it: its defaults and
/// the thrust from the fuel flow by the engine map the recorder's flows
/// come from (TSFC 2.0e-5 kg/(N·s), idle 0.02 kg/s per engine).
pub fn qar_derive_options() -> aeroid::prep::derive::Options {
    aeroid::prep::derive::DeriveTable {
        thrust_from_fuel_flow: Some(2.0e-5),
        idle_fuel_flow: 0.02,
        ..Default::default()
    }
    .options()
}

/// The gusty transport approach recorded by the QAR profile and derived
/// ([`qar_derive_options`]), with the truth trace.
pub fn derived_qar_approach() -> (aeroid::record::FlightRecord, aeroid::sim::trace::TruthTrace) {
    let scenario = approach(true);
    let profile = aeroid::record::recorder::Profile::load("qar-seed000", None).unwrap();
    let (recorded, trace) = fly_and_record(&scenario, &profile);
    let record = aeroid::prep::derive::derive(&recorded, &qar_derive_options())
        .unwrap()
        .record;
    (record, trace)
}

/// The outputs an estimate's coloured-residuals diagnosis names; empty
/// without one.
pub fn coloured_outputs(estimate: &aeroid::estimation::estimate::Estimate) -> Vec<String> {
    estimate
        .diagnosis(aeroid::estimation::estimate::DiagnosisKind::ColouredResiduals)
        .map(|d| d.about.clone())
        .unwrap_or_default()
}

/// The built-in estimators, as every test that runs a method by name uses
/// them (plug-in folders are not scanned: a test that needs a plug-in
/// builds its own registry).
pub fn registry() -> &'static aeroid::estimation::registry::Registry {
    static REGISTRY: std::sync::OnceLock<aeroid::estimation::registry::Registry> =
        std::sync::OnceLock::new();
    REGISTRY.get_or_init(aeroid::estimation::registry::Registry::built_in)
}
