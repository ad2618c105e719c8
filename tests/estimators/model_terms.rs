//! Richer model structures, each flown in the TRUTH and recovered:
//! polynomial and product terms (`alpha^2`, `alpha*de`, `alpha^3`), a
//! moment reference point other than the CG, and parameters tied by a
//! linear relation. Every case is the ATTAS elevator 3211 (60 s, 25 Hz)
//! with the bundled aircraft's terms plus the new ones, fitted by equation
//! error and output error with the matching structure.
//!
//! Bounds, and why:
//! - ideal record (no noise), output error: 1e-4 relative (the issue's
//!   gate; the model integrates with the truth's step and input hold, so
//!   the floor is rounding);
//! - ideal record, equation error: 1e-4 too (the forces come from the load
//!   factors without differentiation; the 3211's steps fall on the sample
//!   grid and the differentiator leaves out the windows across them, so
//!   the moments, measured at 5e-6, are well inside it);
//! - noisy records: every parameter within k = 4 Cramér–Rao σ on each of
//!   two seeds. With about 15 Gaussian estimates per fit, the chance that
//!   any exceeds 4σ is 15·6.3e-5 ≈ 1e-3, so a failure means a bias or
//!   bounds that are too optimistic. Output error: flight-test noise on
//!   every sensor but the control surfaces (inputs taken as exact).
//!   Equation error: noise on the load factors only (its regressors must
//!   be exact, errors in variables otherwise), force parameters only (the
//!   load factors carry no moment information). Measured worst: 3.6σ
//!   (CL_de, seed 12), where the same flight without the new terms gives
//!   3.9σ: a property of equation error's bound on this record, not of
//!   the terms.

use crate::common;
use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::methods::equation_error::{EquationErrorOptions, equation_error};
use aeroid::estimation::methods::output_error::{OutputErrorOptions, output_error};
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::Profile;
use aeroid::sim::scenario::Scenario;
use std::path::PathBuf;

/// Terms added to the bundled ATTAS truth: a polynomial drag polar in α
/// (in place of the Oswald factor, which over the range of α flown is
/// nearly a copy of it), lift curving with α², an α·δe
/// elevator-effectiveness term and a cubic pitching moment.
const PRODUCT_TERMS: &str = r#"
[aero.CD]
0 = 0.03
alpha = 0.1
"alpha^2" = 1.0

[aero.CL]
0 = 0.158
alpha = 3.30
q = 5.0
de = 0.105
"alpha^2" = -1.5

[aero.Cm]
0 = 0.051
alpha = -0.176
q = -12.3
de = -0.391
"alpha*de" = -0.8
"alpha^3" = -4.0
"#;

/// The moments taken about a point 0.15 m aft of and 0.3 m below the CG.
const MOMENT_REFERENCE: &str = r#"
[aero.moment_reference]
offset = [-0.15, 0.0, 0.3]
"#;

/// The bundled ATTAS aircraft with its longitudinal tables replaced by
/// `longitudinal`, the tables `extra` added to its `[aero]` table, and no
/// Oswald factor (the drag is the polar of `longitudinal`).
fn aircraft_text(longitudinal: &str, extra: &str) -> String {
    common::attas_with(|text| {
        let text = text.replace("oswald_efficiency = 0.839", "");
        let start = text.find("[aero.CD]").unwrap();
        let end = text.find("[aero.CY]").unwrap();
        format!(
            "{}{extra}\n{longitudinal}\n{}",
            &text[..start],
            &text[end..]
        )
    })
}

/// A case: an aircraft file, the elevator 3211 scenario flying it, and a
/// longitudinal model of it, written to a fresh folder.
struct Case {
    folder: PathBuf,
}

impl Case {
    fn new(test: &str, aircraft: &str) -> Case {
        let folder = common::temp_folder(test);
        common::write(&folder, "truth.toml", aircraft);
        let scenario = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenarios/attas-elevator-3211.toml"
        ))
        .unwrap()
        .replace("aircraft = \"attas\"", "aircraft = \"truth.toml\"")
        .replace("models = [\"attas-longitudinal\"]", "");
        common::write(&folder, "scenario.toml", &scenario);
        Case { folder }
    }

    fn scenario(&self, seed: u64) -> Scenario {
        let mut scenario = Scenario::load(self.path("scenario.toml").to_str().unwrap()).unwrap();
        scenario.seed = seed;
        scenario
    }

    fn path(&self, name: &str) -> PathBuf {
        self.folder.join(name)
    }

    /// A longitudinal model (start values 20 % off the truth's) with the
    /// `[aero]` head `head`, the tables `tables` and the extra text `extra`.
    fn model(&self, name: &str, head: &str, tables: &str, extra: &str) -> ModelStructure {
        let text = format!(
            r#"name = "{name}"
aircraft = "truth.toml"
integrate = ["airspeed", "alpha", "q", "pitch"]
outputs = ["airspeed", "alpha", "q", "pitch", "nx", "nz"]
{extra}
[aero]
model = "linear"
force_axes = "wind"
rate_normalization = "2V"
rate_speed = "airspeed"
{head}
{}
[methods.oem]
estimate_initial_state = true
"#,
            scale_values(tables, 0.8)
        );
        let path = common::write(&self.folder, &format!("{name}.toml"), &text);
        ModelStructure::load(path.to_str().unwrap()).unwrap()
    }

    /// The flight recorded by `profile` (a bundled name or a path).
    fn record(&self, profile: &str, seed: u64) -> (FlightRecord, Scenario) {
        let scenario = self.scenario(seed);
        let profile = Profile::load(profile, None).unwrap();
        let (record, _) = common::fly_and_record(&scenario, &profile);
        (record, scenario)
    }
}

/// `tables` with every number after `=` (not in a table header) times `factor`.
fn scale_values(tables: &str, factor: f64) -> String {
    tables
        .lines()
        .map(|line| match line.split_once(" = ") {
            Some((key, value)) if !line.starts_with('[') => match value.parse::<f64>() {
                Ok(v) => format!("{key} = {:?}", v * factor),
                Err(_) => line.to_string(),
            },
            _ => line.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Each estimated parameter that the truth has: (name, estimate, σ, truth).
/// (name, estimate, standard error, truth) of each parameter with a truth.
type Rows = Vec<(String, f64, f64, f64)>;

fn rows(estimate: &Estimate, scenario: &Scenario) -> Rows {
    common::against_truth(estimate, scenario)
        .into_iter()
        .filter(|(_, _, _, truth)| truth.is_finite())
        .collect()
}

fn is_force(name: &str) -> bool {
    name.starts_with("CL_") || name.starts_with("CD_")
}

/// The worst relative error of the rows `select` picks, with its name.
fn worst_relative(
    rows: &[(String, f64, f64, f64)],
    select: impl Fn(&str) -> bool,
) -> (f64, String) {
    rows.iter()
        .filter(|(name, ..)| select(name))
        .map(|(name, value, _, truth)| (((value - truth) / truth).abs(), name.clone()))
        .fold((0.0, String::new()), |worst, row| {
            if row.0 > worst.0 { row } else { worst }
        })
}

/// The worst |error|/σ of the rows `select` picks, with its name.
fn worst_sigma(rows: &[(String, f64, f64, f64)], select: impl Fn(&str) -> bool) -> (f64, String) {
    rows.iter()
        .filter(|(name, ..)| select(name))
        .map(|(name, value, sigma, truth)| (((value - truth) / sigma).abs(), name.clone()))
        .fold((0.0, String::new()), |worst, row| {
            if row.0 > worst.0 { row } else { worst }
        })
}

fn fit_output_error(record: &FlightRecord, structure: &ModelStructure) -> Estimate {
    let options = OutputErrorOptions::for_structure(structure).unwrap();
    let estimate = output_error(&[record], structure, &options).unwrap();
    assert_eq!(
        estimate.status,
        Status::Converged,
        "{:?}",
        estimate.cost_history
    );
    estimate
}

fn fit_equation_error(record: &FlightRecord, structure: &ModelStructure) -> Estimate {
    let estimate = equation_error(record, structure, &EquationErrorOptions::default()).unwrap();
    assert_eq!(estimate.status, Status::Converged, "{:?}", estimate.notes);
    estimate
}

/// On ideal data: output error and equation error within 1e-4 on every
/// parameter; every parameter of the truth is estimated.
fn ideal_checks(case: &Case, structure: &ModelStructure, label: &str) {
    let (record, scenario) = case.record("ideal", 4);
    let output = fit_output_error(&record, structure);
    let output_rows = rows(&output, &scenario);
    assert_eq!(output_rows.len(), structure.free_names().len());
    let (worst, name) = worst_relative(&output_rows, |_| true);
    eprintln!("{label}: output error, ideal: worst relative error {worst:.2e} ({name})");
    assert!(
        worst < 1e-4,
        "{label} oem: {name} {worst:.2e}\n{}",
        common::truth_table(&output_rows)
    );
    let equation = fit_equation_error(&record, structure);
    let equation_rows = rows(&equation, &scenario);
    assert_eq!(equation_rows.len(), structure.free_names().len());
    let (forces, force_name) = worst_relative(&equation_rows, is_force);
    let (moments, moment_name) = worst_relative(&equation_rows, |n| !is_force(n));
    eprintln!(
        "{label}: equation error, ideal: worst force {forces:.2e} ({force_name}), moment {moments:.2e} ({moment_name})"
    );
    let table = common::truth_table(&equation_rows);
    assert!(forces.max(moments) < 1e-4, "{label} ee:\n{table}");
}

/// On two seeds of noisy data: output error (flight-test noise, exact
/// controls) and equation error (noise on the load factors, force
/// parameters) within 4σ.
fn noisy_checks(case: &Case, structure: &ModelStructure, label: &str) {
    let sensors = common::profile_variant(&case.folder, "flight-test-25hz", "", |name, table| {
        let control = ["elevator", "aileron", "rudder", "flap", "throttle"].contains(&name);
        Some(match control {
            true => strip_noise(table),
            false => table.to_string(),
        })
    });
    let accelerations =
        common::profile_variant(&case.folder, "flight-test-25hz", "", |name, table| {
            Some(match ["nx", "ny", "nz"].contains(&name) {
                true => table.to_string(),
                false => strip_noise(table),
            })
        });
    for seed in [11, 12] {
        let scenario = case.scenario(seed);
        let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
        let record = sensors.record(&trace, &scenario.aircraft, seed).unwrap();
        let output_rows = rows(&fit_output_error(&record, structure), &scenario);
        let (worst, name) = worst_sigma(&output_rows, |_| true);
        eprintln!("{label}: output error, seed {seed}: worst {worst:.2} σ ({name})");
        assert!(
            worst < 4.0,
            "{label} oem seed {seed}:\n{}",
            common::truth_table(&output_rows)
        );
        let record = accelerations
            .record(&trace, &scenario.aircraft, seed)
            .unwrap();
        let equation_rows = rows(&fit_equation_error(&record, structure), &scenario);
        let (worst, name) = worst_sigma(&equation_rows, is_force);
        eprintln!("{label}: equation error, seed {seed}: worst force {worst:.2} σ ({name})");
        assert!(
            worst < 4.0,
            "{label} ee seed {seed}:\n{}",
            common::truth_table(&equation_rows)
        );
    }
}

/// A recorder channel table without its noise line.
fn strip_noise(table: &str) -> String {
    table
        .lines()
        .filter(|line| !line.starts_with("noise"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn polynomial_and_product_terms_are_flown_and_recovered() {
    let case = Case::new("product-terms", &aircraft_text(PRODUCT_TERMS, ""));
    let scenario = case.scenario(4);
    let truth = &scenario.aircraft.aero.parameters;
    assert_eq!(truth.get("CD_alpha^2"), Some(1.0));
    assert_eq!(truth.get("Cm_alpha*de"), Some(-0.8));
    let structure = case.model("products", "", PRODUCT_TERMS, "");
    ideal_checks(&case, &structure, "products");
    noisy_checks(&case, &structure, "products");
}

/// The product terms change the flight: without them the same aircraft
/// flies another trajectory (so the recovery above is not vacuous).
#[test]
fn product_terms_move_the_flight() {
    let with = Case::new("products-on", &aircraft_text(PRODUCT_TERMS, ""));
    let without = Case::new(
        "products-off",
        &aircraft_text(
            &PRODUCT_TERMS
                .lines()
                .filter(|l| !l.contains('^') && !l.contains('*'))
                .collect::<Vec<_>>()
                .join("\n"),
            "",
        ),
    );
    let alpha = |case: &Case| {
        let (trace, _) = aeroid::sim::fly(&case.scenario(4)).unwrap();
        trace.values("alpha").unwrap()
    };
    let (a, b) = (alpha(&with), alpha(&without));
    let largest = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(largest > 1e-3, "α moved by only {largest:e} rad");
}

#[test]
fn moment_reference_point_is_flown_and_recovered() {
    let case = Case::new(
        "moment-reference",
        &aircraft_text(PRODUCT_TERMS, MOMENT_REFERENCE),
    );
    let structure = case.model("reference", MOMENT_REFERENCE, PRODUCT_TERMS, "");
    ideal_checks(&case, &structure, "moment reference");
    noisy_checks(&case, &structure, "moment reference");
    // The same flight fitted about the CG gives other moment derivatives:
    // Cm_alpha about the CG is Cm_alpha about the point plus
    // (z·CX_alpha − x·CZ_alpha)/c̄ ≈ −0.15·CL_alpha/c̄ = −0.157 off.
    let (record, scenario) = case.record("ideal", 4);
    let about_cg = case.model("about-cg", "", PRODUCT_TERMS, "");
    let estimate = fit_output_error(&record, &about_cg);
    let truth = scenario.aircraft.aero.parameters.get("Cm_alpha").unwrap();
    let value = estimate.parameter("Cm_alpha").unwrap().value;
    eprintln!("Cm_alpha fitted about the CG: {value:.4} (about the point: {truth})");
    assert!((value - truth).abs() > 0.1, "{value} vs {truth}");
}

/// The two spellings of a reference point give one model: 0.30 c̄ and
/// 0.25 c̄ aft of the MAC leading edge is 0.05·c̄ aft of the CG.
#[test]
fn moment_reference_in_fractions_of_the_chord() {
    let chord = 3.159;
    let case = Case::new(
        "reference-mac",
        &aircraft_text(
            PRODUCT_TERMS,
            "[aero.moment_reference]\npoint_mac = 0.30\ncg_mac = 0.25\n",
        ),
    );
    let aero = &case.scenario(1).aircraft.aero;
    let offset = aero.moment_reference;
    assert!((offset.x + 0.05 * chord).abs() < 1e-12 && offset.y == 0.0 && offset.z == 0.0);
}

/// Every bad term or reference is an error naming the file and the key.
#[test]
fn bad_terms_name_the_file_and_the_key() {
    let cases: [(&str, &str, &str); 7] = [
        (
            "\"alpha*bogus\" = 1.0",
            "aero.CL.alpha*bogus",
            "unknown regressor 'bogus'",
        ),
        (
            "\"alpha^0\" = 1.0",
            "aero.CL.alpha^0",
            "must be an integer ≥ 1",
        ),
        (
            "\"alpha^-1\" = 1.0",
            "aero.CL.alpha^-1",
            "must be an integer ≥ 1",
        ),
        ("\"de*alpha\" = 1.0", "aero.CL.de*alpha", "as 'alpha*de'"),
        ("\"alpha^5\" = 1.0", "aero.CL.alpha^5", "degree above 4"),
        (
            "\"0*alpha\" = 1.0",
            "aero.CL.0*alpha",
            "constant 0 cannot be a factor",
        ),
        (
            "\"alpha*CL2\" = 1.0",
            "aero.CL.alpha*CL2",
            "CL2 is a drag term",
        ),
    ];
    for (line, key, message) in cases {
        let folder = common::temp_folder("bad-terms");
        let text = aircraft_text(&format!("[aero.CL]\n0 = 0.158\nalpha = 3.3\n{line}\n"), "");
        let path = common::write(&folder, "bad.toml", &text);
        let error = aeroid::sim::aircraft::Aircraft::load(&path)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("bad.toml") && error.contains(key) && error.contains(message),
            "{line}: {error}"
        );
    }
    let folder = common::temp_folder("bad-reference");
    for (table, message) in [
        ("offset = [1.0, 0.0]", "three numbers"),
        ("point_mac = 0.3", "both point_mac and cg_mac"),
        ("offset = [0.1, 0.0, 0.0]\ncg_mac = 0.25", "either offset"),
    ] {
        let text = aircraft_text(
            PRODUCT_TERMS,
            &format!("[aero.moment_reference]\n{table}\n"),
        );
        let path = common::write(&folder, "reference.toml", &text);
        let error = aeroid::sim::aircraft::Aircraft::load(&path)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("reference.toml")
                && error.contains("moment_reference")
                && error.contains(message),
            "{table}: {error}"
        );
    }
}

/// CLδe = −Cmδe·c̄/l_t with the tail arm l_t = 11.8 m (how the bundled
/// ATTAS states its CL_de), and the α·δe term of Cm following Cm_de.
const TAIL_FACTOR: f64 = -3.159 / 11.8;
const PRODUCT_FACTOR: f64 = 2.0;
const PRODUCT_OFFSET: f64 = -0.018;

/// The product terms with CL_de and Cm_alpha*de at the values the ties give.
fn tied_tables() -> String {
    let cm_de = -0.391;
    PRODUCT_TERMS
        .replace("de = 0.105", &format!("de = {:?}", TAIL_FACTOR * cm_de))
        .replace(
            "\"alpha*de\" = -0.8",
            &format!(
                "\"alpha*de\" = {:?}",
                PRODUCT_FACTOR * cm_de + PRODUCT_OFFSET
            ),
        )
}

fn ties() -> String {
    format!(
        "[parameters.CL_de]\ntie = {{ to = \"Cm_de\", factor = {TAIL_FACTOR:?} }}\n\
         [parameters.\"Cm_alpha*de\"]\ntie = {{ to = \"Cm_de\", factor = {PRODUCT_FACTOR:?}, offset = {PRODUCT_OFFSET:?} }}\n"
    )
}

/// Parameters tied by a linear relation, across coefficients (CL_de to
/// Cm_de) and within one (Cm_alpha*de to Cm_de, with an offset): not
/// unknowns, their values follow the master's estimate.
#[test]
fn tied_parameters_are_flown_and_recovered() {
    let tables = tied_tables();
    let case = Case::new("tied", &aircraft_text(&tables, ""));
    // The ties must sit after the top-level keys: the model puts `extra` there.
    let structure = case.model("tied", "", &tables, &ties());
    let free = structure.free_names();
    assert!(!free.contains(&"CL_de".to_string()) && !free.contains(&"Cm_alpha*de".to_string()));
    assert!(free.contains(&"Cm_de".to_string()));
    let aero = &structure.aircraft.aero;
    let start = aero.parameters.get("Cm_de").unwrap();
    assert_eq!(aero.parameters.get("CL_de"), Some(TAIL_FACTOR * start));
    ideal_checks(&case, &structure, "tied");
    noisy_checks(&case, &structure, "tied");
}

/// Through the registry: a tied parameter is reported in the notes with
/// its value and σ = |c|·σ_master from the master's estimate, and is not
/// among the estimated (scored) parameters; a method that cannot fit ties
/// refuses the model and says why.
#[test]
fn tied_parameters_are_reported_and_refused_where_unsupported() {
    let tables = tied_tables();
    let case = Case::new("tied-notes", &aircraft_text(&tables, ""));
    let structure = case.model("tied", "", &tables, &ties());
    let (record, scenario) = case.record("ideal", 4);
    let problem = crate::common::registry()
        .problem("oem", vec![record.clone()], structure.clone(), &[])
        .unwrap();
    let estimate = crate::common::registry().estimate(&problem, None).unwrap();
    assert!(estimate.parameter("CL_de").is_none());
    let master = estimate.parameter("Cm_de").unwrap();
    let note = estimate
        .notes
        .iter()
        .find(|n| n.starts_with("CL_de is tied"))
        .unwrap_or_else(|| panic!("{:?}", estimate.notes));
    let value = TAIL_FACTOR * master.value;
    let sigma = TAIL_FACTOR.abs() * master.standard_error;
    assert!(
        note.contains(&format!("{value:.6e} ± {sigma:.3e}")),
        "{note}"
    );
    let truth = scenario.aircraft.aero.parameters.get("CL_de").unwrap();
    assert!(((value - truth) / truth).abs() < 1e-4, "{value} vs {truth}");
    let problem = crate::common::registry()
        .problem("rbf-delta", vec![record.clone()], structure, &[])
        .unwrap();
    let error = crate::common::registry()
        .estimate(&problem, None)
        .unwrap_err()
        .to_string();
    assert!(error.contains("tied parameters"), "{error}");
    // Equation error fits masters first: ties both ways between CL and Cm
    // leave no order, and are refused.
    let both_ways = format!(
        "{}[parameters.Cm_q]\ntie = {{ to = \"CL_q\", factor = -2.0 }}\n",
        ties()
    );
    let structure = case.model("both-ways", "", &tables, &both_ways);
    let problem = crate::common::registry()
        .problem("ee", vec![record], structure, &[])
        .unwrap();
    let error = crate::common::registry()
        .estimate(&problem, None)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("tied in a cycle") && error.contains("CL"),
        "{error}"
    );
}

/// A tie to an unknown parameter, to itself, to a tied parameter, in a
/// cycle, of a fixed parameter, or of a parameter that is no term's, is an
/// error naming the model file and the parameter's key.
#[test]
fn bad_ties_name_the_file_and_the_key() {
    let tables = tied_tables();
    let case = Case::new("bad-ties", &aircraft_text(&tables, ""));
    let cases: [(&str, &str, &str); 6] = [
        (
            "[parameters.CL_de]\ntie = { to = \"Cm_bogus\", factor = 1.0 }",
            "parameters.CL_de.tie",
            "unknown parameter 'Cm_bogus'",
        ),
        (
            "[parameters.CL_de]\ntie = { to = \"CL_de\", factor = 1.0 }",
            "parameters.CL_de.tie",
            "tied to itself",
        ),
        (
            "[parameters.CL_de]\ntie = { to = \"Cm_de\", factor = 1.0 }\n[parameters.Cm_de]\ntie = { to = \"Cm_q\", factor = 1.0 }",
            "parameters.Cm_de.tie",
            "master",
        ),
        (
            "[parameters.CL_de]\ntie = { to = \"Cm_de\", factor = 1.0 }\n[parameters.Cm_de]\ntie = { to = \"CL_de\", factor = 1.0 }",
            "parameters.Cm_de.tie",
            "master",
        ),
        (
            "[parameters.CL_de]\nfixed = true\ntie = { to = \"Cm_de\", factor = 1.0 }",
            "parameters.CL_de.tie",
            "neither fixed nor bounded",
        ),
        (
            "[parameters.CL_de]\ntie = { to = \"Cm_de\" }",
            "line ",
            "missing field `factor`",
        ),
    ];
    for (settings, key, message) in cases {
        let text = format!(
            "name = \"bad\"\naircraft = \"truth.toml\"\nintegrate = [\"airspeed\", \"alpha\", \"q\", \"pitch\"]\noutputs = [\"alpha\"]\n[aero]\n{tables}\n{settings}\n"
        );
        let path = common::write(&case.folder, "bad-tie.toml", &text);
        let error = ModelStructure::load(path.to_str().unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("bad-tie.toml") && error.contains(key) && error.contains(message),
            "{settings}: {error}"
        );
    }
}

/// Every new structure at once (products, ties, a moment reference point)
/// through the registry's state-space methods, which evaluate the model
/// through the same aero routine: filter error, EKF and UKF recover it
/// within 1e-4 on the ideal record (their status there is "unsettled":
/// noise-free innovations are no test of the predicted covariance), and
/// within 4σ on the flight-test record (noise on every channel, 0.01° on
/// the surfaces). Measured: 2e-7, 2e-7, 8e-7; 2.0σ, 2.9σ, 2.9σ.
#[test]
fn state_space_methods_fit_every_new_structure() {
    let tables = tied_tables();
    let case = Case::new("filters", &aircraft_text(&tables, MOMENT_REFERENCE));
    let structure = case.model("all", MOMENT_REFERENCE, &tables, &ties());
    for (profile, bound, sigmas) in [
        ("ideal", 1e-4, f64::INFINITY),
        ("flight-test-25hz", f64::INFINITY, 4.0),
    ] {
        let (record, scenario) = case.record(profile, 4);
        for method in ["fem", "ekf", "ukf"] {
            let problem = crate::common::registry()
                .problem(method, vec![record.clone()], structure.clone(), &[])
                .unwrap();
            let estimate = crate::common::registry().estimate(&problem, None).unwrap();
            let rows = rows(&estimate, &scenario);
            assert_eq!(rows.len(), structure.free_names().len());
            let (relative, name) = worst_relative(&rows, |_| true);
            let (sigma, sigma_name) = worst_sigma(&rows, |_| true);
            eprintln!(
                "{profile} {method}: {:?}, worst {relative:.2e} ({name}), {sigma:.2} σ ({sigma_name})",
                estimate.status
            );
            let table = common::truth_table(&rows);
            assert!(
                relative < bound && sigma < sigmas,
                "{profile} {method}:\n{table}"
            );
            assert!(
                estimate
                    .notes
                    .iter()
                    .any(|n| n.starts_with("CL_de is tied"))
            );
        }
    }
}

/// The bundled quasi-steady stall flight (`scenarios/attas-stall.toml`)
/// with `edit` applied to the `[aero.stall]` table of both its truth
/// aircraft and the bundled `attas-stall` model: (case, model).
fn stall_case(test: &str, truth: &str, start: &str) -> (Case, ModelStructure) {
    let read = |path: &str| {
        std::fs::read_to_string(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap()
    };
    let edit = |text: String, replacement: &str| {
        let start = text.find("[aero.stall]").unwrap();
        let end = start + text[start..].find("\n[aero.C").unwrap();
        format!(
            "{}[aero.stall]\n{replacement}\n{}",
            &text[..start],
            &text[end..]
        )
    };
    let folder = common::temp_folder(test);
    common::write(
        &folder,
        "truth.toml",
        &edit(read("aircraft/attas-stall.toml"), truth),
    );
    let scenario = read("scenarios/attas-stall.toml")
        .replace("aircraft = \"attas-stall\"", "aircraft = \"truth.toml\"")
        .replace("models = [\"attas-stall\"]", "");
    common::write(&folder, "scenario.toml", &scenario);
    let model = edit(read("models/attas-stall.toml"), start)
        .replace("aircraft = \"attas-stall\"", "aircraft = \"truth.toml\"");
    let path = common::write(&folder, "model.toml", &model);
    (
        Case { folder },
        ModelStructure::load(path.to_str().unwrap()).unwrap(),
    )
}

/// A stall variant flown and fitted by output error (equation error
/// refuses the stall model: χ is not measured): the ideal record within
/// 1e-4, the flight-test record (noise on every channel) within 4σ — the
/// bundled stall gate's bound, whose worst is Cm_chi at −2.2σ; the
/// parameters in `wider` within their own bound in σ.
fn stall_checks(case: &Case, structure: &ModelStructure, label: &str, wider: &[(&str, f64)]) {
    let (record, scenario) = case.record("ideal", 6);
    let rows_ideal = rows(&fit_output_error(&record, structure), &scenario);
    assert_eq!(rows_ideal.len(), structure.free_names().len());
    let (worst, name) = worst_relative(&rows_ideal, |_| true);
    eprintln!("{label}: output error, ideal: worst {worst:.2e} ({name})");
    assert!(
        worst < 1e-4,
        "{label}:\n{}",
        common::truth_table(&rows_ideal)
    );
    let (record, scenario) = case.record("flight-test-25hz", 6);
    let rows_noisy = rows(&fit_output_error(&record, structure), &scenario);
    let table = common::truth_table(&rows_noisy);
    let (worst, name) = worst_sigma(&rows_noisy, |n| wider.iter().all(|(w, _)| *w != n));
    eprintln!("{label}: output error, flight test: worst {worst:.2} σ ({name})");
    assert!(worst < 4.0, "{label}:\n{table}");
    for (parameter, bound) in wider {
        let (sigma, _) = worst_sigma(&rows_noisy, |n| n == *parameter);
        eprintln!("{label}: {parameter} {sigma:.2} σ");
        assert!(sigma < *bound, "{label}:\n{table}");
    }
}

/// τ2 in units of c̄/V: 27 c̄/V is 0.9 s at 95 m/s (the bundled truth's),
/// and varies with the speed through the manoeuvre.
#[test]
fn stall_time_constants_in_chord_units_are_flown_and_recovered() {
    let (case, structure) = stall_case(
        "stall-chord",
        "a1 = 23.7\nalpha_star = 0.309\ntau1 = 0.0\ntau2 = 27.0\ntime_unit = \"chord/V\"",
        "a1 = 20.0\nalpha_star = 0.29\ntau1 = 0.0\ntau2 = 18.0\ntime_unit = \"chord/V\"",
    );
    stall_checks(&case, &structure, "τ in c̄/V", &[]);
}

/// The α̇ of the separation equation from the smoothed derivative of the
/// measured α (`alpha_dot = "measured"`), on the bundled stall flight
/// (τ2 0.9 s; the truth is simulated with the state's α̇, which the
/// simulator alone has). Bounds, and why:
/// - ideal record (100 Hz): 1e-4 relative, the issue's gate. The model
///   differs from the truth only by the differentiator's error (degree 4,
///   ±0.1 s: a gain within 2e-5 of the derivative's at 0.5 Hz, and the
///   first and last 0.1 s held); measured worst 1.6e-5 (a1), τ2 2e-5.
/// - flight-test noise (0.1° on α, 25 Hz; seeds 6, 7, 8): a finding,
///   asserted as measured. The differentiated α carries noise of 0.1°·12.8/s ≈ 0.022
///   rad/s (the 7-sample quartic's noise gain), twice the stall entry's α̇
///   (0.01 rad/s); in the separation equation it is an error in a
///   variable, which biases a1 by +11 to +15 % (23–34σ), α* and τ2 by
///   up to 18σ, and its trace in nx and nz makes the fit a poor fit.
#[test]
fn stall_alpha_dot_from_the_measured_alpha() {
    let truth = "a1 = 23.7\nalpha_star = 0.309\ntau1 = 0.0\ntau2 = 0.9";
    let start = "a1 = 20.0\nalpha_star = 0.29\ntau1 = 0.0\ntau2 = 0.6\nalpha_dot = \"measured\"";
    let (case, structure) = stall_case("stall-measured-alpha-dot", truth, start);
    let (record, scenario) = case.record("ideal", 6);
    let estimate = fit_output_error(&record, &structure);
    assert!(
        estimate.notes.iter().any(|n| n
            .starts_with("α̇ of the separation equation: the derivative of the record's 'alpha'")),
        "{:?}",
        estimate.notes
    );
    let rows_ideal = rows(&estimate, &scenario);
    assert_eq!(rows_ideal.len(), structure.free_names().len());
    let (worst, name) = worst_relative(&rows_ideal, |_| true);
    eprintln!("measured α̇, ideal: worst {worst:.2e} ({name})");
    assert!(worst < 1e-4, "{}", common::truth_table(&rows_ideal));
    let noisy = Profile::load("flight-test-25hz", None).unwrap();
    for seed in [6, 7, 8] {
        let scenario = case.scenario(seed);
        let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
        let record = noisy.record(&trace, &scenario.aircraft, seed).unwrap();
        let options = OutputErrorOptions::for_structure(&structure).unwrap();
        let estimate = output_error(&[&record], &structure, &options).unwrap();
        let rows_noisy = rows(&estimate, &scenario);
        let (_, value, sigma, truth) = rows_noisy.iter().find(|r| r.0 == "a1").unwrap();
        let a1 = (value - truth) / sigma;
        eprintln!(
            "measured α̇, noise on α, seed {seed}: {}, a1 {a1:+.1} σ",
            estimate.status
        );
        let table = common::truth_table(&rows_noisy);
        assert!(
            estimate.status == Status::Converged
                && common::coloured_outputs(&estimate).contains(&"nx".to_string()),
            "seed {seed}: {} {:?}\n{table}",
            estimate.status,
            estimate.diagnoses
        );
        assert!(a1 > 10.0, "seed {seed}:\n{table}");
    }
}

/// The stall lag τ1 and τ2 in c̄/V: the flown values and the a-priori start.
const CHORD_LAG_TRUTH: &str =
    "a1 = 23.7\nalpha_star = 0.309\ntau1 = 3.0\ntau2 = 27.0\ntime_unit = \"chord/V\"";
const CHORD_LAG_START: &str =
    "a1 = 20.0\nalpha_star = 0.29\ntau1 = 2.0\ntau2 = 18.0\ntime_unit = \"chord/V\"";

/// τ1 in units of c̄/V with χ a state (Eq. 2): the truth τ1 = 3 c̄/V
/// (0.10 s at 95 m/s), τ2 = 27 c̄/V; fitted with τ1 free (no bound) from
/// 2 c̄/V, τ2 from 18, the other stall values as in the other variants'
/// tests.
///
/// From these a-priori values a fit of every parameter at once runs τ1
/// to 0 (a valley toward the algebraic limit τ1 = 0, where τ2 alone makes
/// the lag); output error's first stage holds τ1 at its start value with
/// the initial state, and the note says so.
///
/// Bounds: ideal record within 1e-4 (measured 3e-7, τ1). Flight-test
/// records, seeds 1–12: each converges, and with the recorded inputs'
/// noise in the bounds (below) every parameter is within 3σ (measured
/// worst 2.62σ, a1 on seed 8; 5 of the 48 stall values beyond 2σ: τ1
/// 2.23 and 2.52, τ2 2.02 and 2.41, a1 2.62). By the white bounds the
/// worst is 5.14σ (τ1, seed 12).
///
/// The bounds, over the twelve seeds (`bound_honesty`: the estimates'
/// scatter over the mean bound, σ_MC/bound, 1 for an honest bound; with
/// 12 seeds the scatter itself is uncertain by about 1/√22 = 21 %, so an
/// honest bound measures within 0.6–1.6 at 2 standard errors):
/// - white, as output error's likelihood gives them: 2.65 for τ1 (error/σ
///   of mean −0.50), 50 % of the errors within ±1.96σ. Asserted above 1.6.
/// - corrected for coloured residuals (`correlation_lag = 1 s`, Morelli &
///   Klein 1997): 2.66, the bound 0.99 of the white; the residuals are
///   white (structured residual ≤ 0.003), there is no colour to correct.
///   Asserted: above 1.6, within 20 % of the white.
/// - the cause: the recorder's 0.01° of elevator and flap noise (and
///   0.001 of throttle), which output error takes as exact inputs. The
///   same flights recorded with exact inputs (`flight-test-25hz` without
///   its control channels' noise) give 1.00 with the white bounds.
///   Asserted within 0.6–1.6.
/// - with that noise stated (`[methods.oem] input_noise`, its share of the
///   bounds from 200 simulated draws): 1.31 (the bound 2.0 times the white
///   one on seed 1), 83 % within ±1.96 bounds. Asserted within 0.6–1.6.
///
/// Fast dynamics driven through an input's direct effect carry its noise:
/// χ, with τ1 = 0.1 s, follows α − τ2·α̇, and α̇ holds the elevator's
/// direct lift.
#[test]
fn stall_lag_in_chord_units_is_flown_and_recovered() {
    let (case, _) = stall_case("stall-chord-tau1", CHORD_LAG_TRUTH, CHORD_LAG_START);
    let text = std::fs::read_to_string(case.path("model.toml"))
        .unwrap()
        .replace("[parameters.tau1]\nfixed = true\n", "");
    let path = common::write(&case.folder, "model-tau1.toml", &text);
    let structure = ModelStructure::load(path.to_str().unwrap()).unwrap();
    let tau1 = structure.aircraft.aero.parameters.index("tau1").unwrap();
    assert!(structure.free[tau1] && structure.aircraft.aero.chi_is_state());
    assert_eq!(structure.bounds[tau1].0, f64::NEG_INFINITY);
    let (record, scenario) = case.record("ideal", 6);
    let estimate = fit_output_error(&record, &structure);
    assert!(
        estimate
            .notes
            .iter()
            .any(|n| n.contains("tau1 released after a first fit")),
        "{:?}",
        estimate.notes
    );
    let rows_ideal = rows(&estimate, &scenario);
    assert_eq!(rows_ideal.len(), structure.free_names().len());
    let (worst, name) = worst_relative(&rows_ideal, |_| true);
    eprintln!("τ1 in c̄/V, ideal: worst {worst:.2e} ({name})");
    assert!(worst < 1e-4, "{}", common::truth_table(&rows_ideal));
    let options = OutputErrorOptions::for_structure(&structure).unwrap();
    let exact_inputs = exact_inputs_profile(&case);
    let mut fits = Vec::new();
    let mut exact = Vec::new();
    for seed in 1..=12 {
        let (bounds, r, status, exact_bounds) =
            bounds_of_seed(&case, &structure, "tau1", &options, (seed, &exact_inputs));
        assert_eq!(status, (Status::Converged, Vec::new()), "seed {seed}");
        let (worst, name) = worst_sigma(&r, |_| true);
        let z = |n: &str| {
            let (_, value, sigma, truth) = r.iter().find(|row| row.0 == n).unwrap();
            (value - truth) / sigma
        };
        eprintln!(
            "τ1 in c̄/V, seed {seed}: τ1 {:+.2}σ, τ2 {:+.2}σ, a1 {:+.2}σ, α* {:+.2}σ, worst {worst:.2}σ ({name})",
            z("tau1"),
            z("tau2"),
            z("a1"),
            z("alpha_star")
        );
        assert!(worst < 3.0, "seed {seed}:\n{}", common::truth_table(&r));
        fits.push(bounds);
        exact.push(exact_bounds);
    }
    let ([white, coloured, inputs], _) = bound_honesty("τ1 in c̄/V", &fits);
    assert!(white > 1.6 && white < 4.0, "{white:.2}");
    assert!(coloured > 1.6, "{coloured:.2}");
    let widening = fits.iter().map(|f| f.coloured / f.white).sum::<f64>() / fits.len() as f64;
    assert!((widening - 1.0).abs() < 0.2, "{widening:.2}");
    assert!(inputs > 0.6 && inputs < 1.6, "{inputs:.2}");
    let ([exact, ..], _) = bound_honesty("τ1 in c̄/V, exact inputs", &exact);
    assert!(exact > 0.6 && exact < 1.6, "{exact:.2}");
}

/// `flight-test-25hz` with exact control channels (their noise removed),
/// written into the case's folder: its path.
fn exact_inputs_profile(case: &Case) -> String {
    let mut text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/recorders/flight-test-25hz.toml"
    ))
    .unwrap()
    .replace("name = \"flight-test-25hz\"", "name = \"exact-inputs\"");
    for (name, noise) in RECORDED_INPUT_NOISE {
        let line = format!("name = \"{name}\"\nrate = \"25 Hz\"\nnoise = \"{noise}\"");
        assert!(text.contains(&line), "{line}");
        text = text.replace(&line, &format!("name = \"{name}\"\nrate = \"25 Hz\"\n#"));
    }
    let path = common::write(&case.folder, "exact-inputs.toml", &text);
    path.to_str().unwrap().to_string()
}

/// The residuals' autocorrelation summed to this lag in the coloured
/// Cramér–Rao bounds (`correlation_lag`).
const COLOURED_LAG: f64 = 1.0;

/// The recorded inputs' noise as `flight-test-25hz` records them (the
/// stall flight's inputs): `[methods.oem] input_noise`.
const RECORDED_INPUT_NOISE: [(&str, &str); 3] = [
    ("elevator", "0.01 deg"),
    ("flap", "0.01 deg"),
    ("throttle", "0.001"),
];

/// One fit's error in a parameter and its three bounds: white, corrected
/// for coloured residuals (`correlation_lag`, Morelli & Klein 1997), and
/// with the recorded inputs' noise (`input_noise`).
struct Bounds {
    error: f64,
    white: f64,
    coloured: f64,
    inputs: f64,
}

/// `parameter`'s [`Bounds`] on the flight of `seed` recorded by
/// `flight-test-25hz`, from fits of `structure` with `white` (white),
/// then with the coloured correction, then with the inputs' noise; the
/// rows of the fit with the inputs' noise, the white fit's status; and
/// its error and white bound on the same
/// flight recorded with exact inputs (`exact_inputs`, the other bounds
/// not computed).
fn bounds_of_seed(
    case: &Case,
    structure: &ModelStructure,
    parameter: &str,
    white: &OutputErrorOptions,
    (seed, exact_inputs): (u64, &str),
) -> (Bounds, Rows, (Status, Vec<String>), Bounds) {
    let coloured = OutputErrorOptions {
        correlation_lag: COLOURED_LAG,
        ..white.clone()
    };
    let mut inputs = white.clone();
    for (name, noise) in RECORDED_INPUT_NOISE {
        inputs
            .input_noise
            .insert(name.into(), aeroid::units::Quantity::Text(noise.into()));
    }
    let fit = |record: &FlightRecord, scenario: &Scenario, options: &OutputErrorOptions| {
        let estimate = output_error(&[record], structure, options).unwrap();
        let coloured = common::coloured_outputs(&estimate);
        (rows(&estimate, scenario), (estimate.status, coloured))
    };
    let find = |rows: &Rows| {
        let (_, value, sigma, truth) = rows.iter().find(|r| r.0 == parameter).unwrap();
        (value - truth, *sigma)
    };
    let (record, scenario) = case.record("flight-test-25hz", seed);
    let (white_rows, status) = fit(&record, &scenario, white);
    let (error, white_sigma) = find(&white_rows);
    let bounds = Bounds {
        error,
        white: white_sigma,
        coloured: find(&fit(&record, &scenario, &coloured).0).1,
        inputs: f64::NAN,
    };
    let (input_rows, _) = fit(&record, &scenario, &inputs);
    let bounds = Bounds {
        inputs: find(&input_rows).1,
        ..bounds
    };
    let (record, scenario) = case.record(exact_inputs, seed);
    let (exact_rows, exact_status) = fit(&record, &scenario, white);
    assert_eq!(
        exact_status,
        (Status::Converged, Vec::new()),
        "exact inputs, seed {seed}"
    );
    let (error, white_sigma) = find(&exact_rows);
    let exact = Bounds {
        error,
        white: white_sigma,
        coloured: f64::NAN,
        inputs: f64::NAN,
    };
    (bounds, input_rows, status, exact)
}

/// How honest each bound is over seeds: the scatter of the estimates (their
/// standard deviation) over the mean bound (σ_MC/CRB), and the fraction
/// of errors within 1.96 bounds. Returns ([white, coloured, inputs] ratios,
/// [white, coloured, inputs] coverages).
fn bound_honesty(label: &str, fits: &[Bounds]) -> ([f64; 3], [f64; 3]) {
    let n = fits.len() as f64;
    let mean = fits.iter().map(|f| f.error).sum::<f64>() / n;
    let scatter = (fits.iter().map(|f| (f.error - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let sigma = |f: &Bounds, k: usize| [f.white, f.coloured, f.inputs][k];
    let ratio = |k: usize| scatter / (fits.iter().map(|f| sigma(f, k)).sum::<f64>() / n);
    let cover = |k: usize| {
        fits.iter()
            .filter(|f| f.error.abs() <= 1.96 * sigma(f, k))
            .count() as f64
            / n
    };
    let ratios = [ratio(0), ratio(1), ratio(2)];
    let coverages = [cover(0), cover(1), cover(2)];
    let coloured = format!("coloured ({COLOURED_LAG} s)");
    let kinds = ["white", &coloured, "with the inputs' noise"];
    let measured: Vec<String> = (0..3)
        .filter(|&k| ratios[k].is_finite())
        .map(|k| {
            format!(
                "{} {:.2} ({:.0} % within ±1.96 bounds)",
                kinds[k],
                ratios[k],
                100.0 * coverages[k]
            )
        })
        .collect();
    eprintln!("{label}: σ_MC/bound {}", measured.join(", "));
    (ratios, coverages)
}

/// τ2 acting only while α̇ < 0: the separation follows α without lag on
/// the way up, and lags it on the way down (hysteresis). With the sharp
/// switch min(α̇, 0) the recorded elevator's noise flips the switch: on
/// the flight-test record τ2 lies 7.0σ from the truth by its white
/// Cramér–Rao bound, about 5.6 times smaller than its scatter over seeds
/// (`one_sided_hysteresis_bounds_hold_with_the_inputs_noise`, where the
/// bound with the inputs' noise holds); every other parameter within 2σ
/// here. The bound here pins the measured state (10σ).
#[test]
fn one_sided_hysteresis_is_flown_and_recovered() {
    let (case, structure) = stall_case(
        "stall-one-sided",
        "a1 = 23.7\nalpha_star = 0.309\ntau1 = 0.0\ntau2 = 0.9\ntau2_only_while_decreasing = true",
        "a1 = 20.0\nalpha_star = 0.29\ntau1 = 0.0\ntau2 = 0.6\ntau2_only_while_decreasing = true",
    );
    stall_checks(&case, &structure, "τ2 while α̇ < 0", &[("tau2", 10.0)]);
}

/// The induced drag from the attached-flow lift CL0 + CLα·α (χ = 1), not
/// from the lift the separated flow leaves.
#[test]
fn induced_drag_from_attached_lift_is_flown_and_recovered() {
    let (case, structure) = stall_case(
        "stall-attached-drag",
        "a1 = 23.7\nalpha_star = 0.309\ntau1 = 0.0\ntau2 = 0.9\ninduced_drag_lift = \"attached\"",
        "a1 = 20.0\nalpha_star = 0.29\ntau1 = 0.0\ntau2 = 0.6\ninduced_drag_lift = \"attached\"",
    );
    stall_checks(&case, &structure, "attached induced drag", &[]);
}

/// The `[aero.stall]` tables of the stall variants, truth and a-priori
/// start (a1 −16 %, α* −6 %, τ2 −33 % off): (label, truth, start).
fn stall_variants() -> Vec<(&'static str, String, String)> {
    let truth = "a1 = 23.7\nalpha_star = 0.309\ntau1 = 0.0\ntau2 = 0.9";
    let start = "a1 = 20.0\nalpha_star = 0.29\ntau1 = 0.0\ntau2 = 0.6";
    let both = |extra: &str| (format!("{truth}\n{extra}"), format!("{start}\n{extra}"));
    let chord = (
        "a1 = 23.7\nalpha_star = 0.309\ntau1 = 0.0\ntau2 = 27.0\ntime_unit = \"chord/V\""
            .to_string(),
        "a1 = 20.0\nalpha_star = 0.29\ntau1 = 0.0\ntau2 = 18.0\ntime_unit = \"chord/V\""
            .to_string(),
    );
    let one_sided = both("tau2_only_while_decreasing = true");
    let attached = both("induced_drag_lift = \"attached\"");
    vec![
        ("τ2 in s", truth.to_string(), start.to_string()),
        ("τ2 in c̄/V", chord.0, chord.1),
        ("τ2 while α̇ < 0", one_sided.0, one_sided.1),
        ("attached induced drag", attached.0, attached.1),
    ]
}

fn from_model_values(structure: &ModelStructure, starts: usize) -> OutputErrorOptions {
    OutputErrorOptions {
        start: aeroid::estimation::methods::output_error::Start::Model,
        starts,
        ..OutputErrorOptions::for_structure(structure).unwrap()
    }
}

/// The stall parameters, which the bound of 2σ applies to.
const STALL_PARAMETERS: [&str; 3] = ["a1", "alpha_star", "tau2"];

/// Each stall variant flown with flight-test noise (seeds 6, 7, 8) and
/// fitted by output error with the matching structure from the a-priori
/// start values (`start = "model"`, the staged fit).
///
/// Truth: the bundled ATTAS stall values (a1 23.7, α* 0.309, τ2 0.9 s or
/// 27 c̄/V, CD_χ 0.079, Cm_χ −0.126, …). Tolerance, and why: the issue's
/// target is the stall parameters (a1, α*, τ2) within 2σ. Over the 36
/// values of the four variants an unbiased estimate with an honest bound
/// falls outside 2σ 4.6 % of the time, so a test of each against 2σ
/// would fail on some seed by chance; what is asserted is that the bounds
/// hold: the RMS of error/σ over the 36 is at most 1.45 (χ² with 36
/// degrees of freedom exceeds 1.45²·36 = 76 with probability below
/// 1e-4), and each within 3σ. Measured: RMS 1.10, 33 of 36 within 2σ,
/// worst 2.65σ (a1, c̄/V, seed 8). Every other parameter (10 per fit)
/// within 4.5σ: measured worst 4.26σ (Cm_χ, c̄/V, seed 8), the others
/// within 3σ. The one-sided hysteresis is fitted with the recorder's
/// input noise stated (`input_noise`): its white bounds miss what that
/// noise does through the switch
/// (`one_sided_hysteresis_bounds_hold_with_the_inputs_noise`); with it,
/// its stall parameters within 2.24σ (a1, seed 7), the others 2.48σ.
///
/// A single fit either converges there, or lands in another minimum and
/// says so: on seed 8 (τ2 in s, and the attached induced drag) the staged
/// fit stops with τ2 131–134σ off, reproducing α, q and nx with a
/// structured residual of 0.2–0.38 of their variation: a poor fit, never
/// "converged". Four starts (`starts = 4`, spread 0.5) always reach the
/// minimum at the truth, converged, and their notes say how the other
/// starts ended.
#[test]
fn stall_variants_from_a_priori_starts_reach_the_truth() {
    let mut wrong_minima = 0;
    let mut stall_errors = Vec::new();
    for (index, (label, truth, start)) in stall_variants().into_iter().enumerate() {
        let (case, structure) = stall_case(&format!("stall-start-{index}"), &truth, &start);
        // The one-sided hysteresis's bounds hold only with the recorded
        // inputs' noise in them (`one_sided_hysteresis_bounds_hold_with_the_inputs_noise`).
        let one_sided = label == "τ2 while α̇ < 0";
        let options = |starts: usize| {
            let mut options = from_model_values(&structure, starts);
            if one_sided {
                for (name, noise) in RECORDED_INPUT_NOISE {
                    options
                        .input_noise
                        .insert(name.into(), aeroid::units::Quantity::Text(noise.into()));
                }
            }
            options
        };
        let (stall_bound, rest_bound) = (3.0, 4.5);
        let bounded = |name: &str| STALL_PARAMETERS.contains(&name);
        for seed in [6, 7, 8] {
            let (record, scenario) = case.record("flight-test-25hz", seed);
            let within = |estimate: &Estimate, what: &str| {
                let rows = rows(estimate, &scenario);
                let table = common::truth_table(&rows);
                let (stall, stall_name) = worst_sigma(&rows, bounded);
                let (rest, rest_name) = worst_sigma(&rows, |n| !STALL_PARAMETERS.contains(&n));
                eprintln!(
                    "{label}, seed {seed}, {what}: {}; stall parameters {stall:.2}σ ({stall_name}), others {rest:.2}σ ({rest_name})",
                    estimate.status
                );
                let errors: Vec<f64> = rows
                    .iter()
                    .filter(|(name, ..)| bounded(name))
                    .map(|(_, value, sigma, truth)| (value - truth) / sigma)
                    .collect();
                (stall < stall_bound && rest < rest_bound, table, errors)
            };
            let single = output_error(&[&record], &structure, &options(1)).unwrap();
            let (good, table, _) = within(&single, "one start");
            assert_eq!(single.status, Status::Converged, "{label}, seed {seed}");
            let outputs = common::coloured_outputs(&single);
            if outputs.is_empty() {
                assert!(good, "{label}, seed {seed}:\n{table}");
            } else {
                assert!(
                    !good && outputs.contains(&"q".to_string()),
                    "{label}, seed {seed}: {outputs:?}\n{table}"
                );
                wrong_minima += 1;
            }
            let several = aeroid::estimation::methods::output_error::multi_start(
                &[&record],
                &structure,
                &options(4),
                None,
            )
            .unwrap();
            let (good, table, errors) = within(&several, "four starts");
            assert_eq!(
                several.status,
                Status::Converged,
                "{label}, seed {seed}: {:?}",
                several.notes
            );
            assert!(good, "{label}, seed {seed}, four starts:\n{table}");
            assert!(several.notes.iter().any(|n| n.starts_with("4 starts")));
            stall_errors.extend(errors);
        }
    }
    let rms = (stall_errors.iter().map(|z| z * z).sum::<f64>() / stall_errors.len() as f64).sqrt();
    let within_two = stall_errors.iter().filter(|z| z.abs() <= 2.0).count();
    eprintln!(
        "stall parameters: RMS {rms:.2}σ over {}, {within_two} within 2σ",
        stall_errors.len()
    );
    assert_eq!(stall_errors.len(), 36);
    assert!(rms <= 1.45, "RMS {rms:.2}σ");
    assert_eq!(
        wrong_minima, 2,
        "seed 8 of τ2 in s and of the attached induced drag"
    );
}

/// Fits of the stall flight (flight-test-25hz, seed 6) with a structure
/// that lacks what the truth has. The criterion (crates/estimation/src/estimate.rs,
/// `assess_residuals`): a poor fit when an output's residuals are
/// correlated (√N·ρ₁ > 4, which white residuals exceed with probability
/// 3e-5) and their structured part √(ρ₁·(1 − R²)) exceeds 0.05 of the
/// output's variation; matched fits stay at or below 0.025 (the gates'
/// and `stall_variants_from_a_priori_starts_reach_the_truth`'s). Measured:
/// a linear model (CL_0, CL_alpha, CD_0, Cm_0, Cm_alpha, Cm_q, Cm_de, e)
/// leaves 0.47–0.95 on α, q, pitch, nx, nz (0.07 on the airspeed); the
/// stall model without hysteresis (τ2 held at 0) 0.25–0.37 on α, q, nx, nz
/// (0.085 on pitch); the two-sided τ2 on a one-sided flight 0.10–0.11 on
/// α, q, nx (0.063 on nz). All three are poor fits naming exactly the
/// outputs beyond 0.05, and none has an infinite σ.
///
/// Two variants a fit cannot tell on this manoeuvre (a finding): τ2 in
/// seconds on a flight in c̄/V (the airspeed falls from 95 to about 80 m/s
/// into the stall, so 27 c̄/V is 0.90–1.07 s; a constant τ2 comes close),
/// and the induced drag from the separated lift on a flight with the
/// attached-flow lift (CD_χ absorbs it, 145σ off). Their residuals are
/// correlated (ρ₁ 0.12–0.59 on α, q, pitch, nx, nz, and 0.31 on nx; 95–100 %
/// of the 20 lags outside the band) but their structured part is at most
/// 0.017 and 0.023, within what matched fits leave: converged, with a note
/// that names the correlated outputs.
#[test]
fn stall_fits_with_a_mismatched_structure_report_a_poor_fit() {
    let variants = stall_variants();
    let (base_truth, base_start) = (&variants[0].1, &variants[0].2);
    let (case, _) = stall_case("stall-mismatch", base_truth, base_start);
    let (record, _) = case.record("flight-test-25hz", 6);
    // A linear model: the stall model's file without χ.
    let text = std::fs::read_to_string(format!(
        "{}/models/attas-stall.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let cut = text.find("[aero.stall]").unwrap();
    let end = cut + text[cut..].find("\n[aero.C").unwrap();
    let linear = format!("{}{}", &text[..cut], &text[end..])
        .replace("model = \"stall\"", "model = \"linear\"")
        .replace("chi = 0.06\n", "")
        .replace("chi = -0.1\n", "")
        .replace("[parameters.tau1]\nfixed = true\n", "")
        .replace("aircraft = \"attas-stall\"", "aircraft = \"truth.toml\"");
    let linear = ModelStructure::load(
        common::write(&case.folder, "linear.toml", &linear)
            .to_str()
            .unwrap(),
    )
    .unwrap();
    let (_, mut no_hysteresis) = stall_case(
        "stall-no-hysteresis",
        base_truth,
        &base_start.replace("tau2 = 0.6", "tau2 = 0.0"),
    );
    let tau2 = no_hysteresis
        .aircraft
        .aero
        .parameters
        .index("tau2")
        .unwrap();
    no_hysteresis.free[tau2] = false;
    let (one_sided_case, _) = stall_case("stall-one-sided-flight", &variants[2].1, &variants[2].2);
    let (one_sided_record, _) = one_sided_case.record("flight-test-25hz", 6);
    let (_, two_sided) = stall_case("stall-two-sided-model", &variants[2].1, base_start);
    let (chord_case, _) = stall_case("stall-chord-flight", &variants[1].1, &variants[1].2);
    let (chord_record, _) = chord_case.record("flight-test-25hz", 6);
    let (attached_case, _) = stall_case("stall-attached-flight", &variants[3].1, &variants[3].2);
    let (attached_record, _) = attached_case.record("flight-test-25hz", 6);
    let fit = |record: &FlightRecord, structure: &ModelStructure| {
        output_error(&[record], structure, &from_model_values(structure, 1)).unwrap()
    };
    let report = |label: &str, estimate: &Estimate| {
        eprintln!("{label}: {}", estimate.status);
        for f in &estimate.fits {
            eprintln!(
                "  {label} {}  R² {:.4}  TIC {:.4}",
                f.whiteness_text(),
                f.r_squared,
                f.theil
            );
        }
        assert!(
            estimate
                .parameters
                .iter()
                .all(|p| p.standard_error.is_finite()),
            "{label}: {:?}",
            estimate.parameters
        );
    };
    for (label, record, structure, poor) in [
        (
            "linear model",
            &record,
            &linear,
            &["alpha", "q", "pitch", "nx", "nz"][..],
        ),
        (
            "no hysteresis",
            &record,
            &no_hysteresis,
            &["alpha", "q", "pitch", "nx", "nz"][..],
        ),
        (
            "two-sided τ2 on a one-sided flight",
            &one_sided_record,
            &two_sided,
            &["alpha", "q", "nx", "nz"][..],
        ),
    ] {
        let estimate = fit(record, structure);
        report(label, &estimate);
        assert_eq!(estimate.status, Status::Converged, "{label}");
        let outputs = &common::coloured_outputs(&estimate);
        for output in poor {
            assert!(
                outputs.contains(&output.to_string()),
                "{label}: {outputs:?}"
            );
        }
        for f in &estimate.fits {
            assert_eq!(
                outputs.contains(&f.channel),
                f.is_structured(),
                "{label}: {}",
                f.whiteness_text()
            );
        }
        let coloured = aeroid::estimation::estimate::DiagnosisKind::ColouredResiduals;
        assert!(
            estimate
                .diagnosis(coloured)
                .is_some_and(|d| d.advice.contains("structured residual")),
            "{label}: {:?}",
            estimate.diagnoses
        );
    }
    let (_, seconds) = stall_case("stall-seconds-model", &variants[1].1, base_start);
    let (_, separated) = stall_case("stall-separated-model", &variants[3].1, base_start);
    for (label, record, structure, correlated) in [
        ("τ2 in s on a c̄/V flight", &chord_record, &seconds, "alpha"),
        (
            "separated-lift induced drag on an attached-lift flight",
            &attached_record,
            &separated,
            "nx",
        ),
    ] {
        let estimate = fit(record, structure);
        report(label, &estimate);
        assert_eq!(estimate.status, Status::Converged, "{label}");
        let fit = estimate
            .fits
            .iter()
            .find(|f| f.channel == correlated)
            .unwrap();
        assert!(
            fit.correlated() && fit.structured < 0.03,
            "{label}: {}",
            fit.whiteness_text()
        );
        assert!(
            estimate
                .notes
                .iter()
                .any(|n| n.starts_with("residuals correlated") && n.contains(correlated)),
            "{label}: {:?}",
            estimate.notes
        );
    }
}

/// How far the Cramér–Rao bound of τ2 understates its scatter, two-sided
/// against one-sided hysteresis, and what makes it honest: twelve
/// flight-test records (seeds 1–12) of each, single fits from the
/// a-priori start. Two-sided: 10 converge, with error/σ of mean −0.58
/// and standard deviation 1.24 (an honest bound gives 1; asserted below
/// 1.6), and seeds 3 and 8 end in the other minimum (τ2 ≈ 0.35, 132σ
/// off), each a poor fit. One-sided (the sharp switch min(α̇, 0)): all
/// 12 converge, with mean +1.71 and standard deviation 5.56 (+6.5σ to
/// −9.6σ; asserted above 3): the white bound is about 5.6 times too
/// small, while the residuals stay white (structured residual ≤ 0.003).
///
/// The cause is the recorded inputs' noise (0.01° on the elevator), which
/// output error takes as exact: α̇ holds the elevator's direct lift, and
/// near α̇ = 0 that noise flips the switch. The same flights recorded with
/// exact inputs give σ_MC/bound 0.92 with the white bounds; with the
/// inputs' noise stated (`[methods.oem] input_noise`) the bounds give
/// 1.05 (all 12 within ±1.96 bounds). Both asserted within 0.6–1.6 (12
/// seeds: the scatter's own uncertainty about 21 %). Coloured-residual
/// bounds (`correlation_lag = 1 s`) do not help: σ_MC/bound 5.53 (white
/// 5.63), the coloured bound 1.02 of the white; asserted above 3.
///
/// A smoothed switch (`tau2_switch_band = 0.03`: α̇·½(1 − tanh(α̇/0.03)),
/// truth and model alike) passes less of that noise: all 12 converge with
/// mean −0.42 and standard deviation 1.31 with the white bounds (asserted
/// between 0.6 and 1.6, the control's range). Measured with other widths
/// (same seeds): 0.01 rad/s 4.52, 0.1 rad/s 1.76. A smooth switch is
/// another model, though: the sharp-switch flight fitted with it ends
/// 54–63σ off in τ2 (docs/findings.md).
#[test]
fn one_sided_hysteresis_bounds_hold_with_the_inputs_noise() {
    let variants = stall_variants();
    let smooth = |table: &str| format!("{table}\ntau2_switch_band = 0.03");
    let (_, one_sided_truth, one_sided_start) = &variants[2];
    let cases = [
        (variants[0].clone(), vec![3, 8], 0.6, 1.6),
        (variants[2].clone(), vec![], 3.0, 10.0),
        (
            (
                "τ2 while α̇ < 0, smooth switch",
                smooth(one_sided_truth),
                smooth(one_sided_start),
            ),
            vec![],
            0.6,
            1.6,
        ),
    ];
    for (index, ((label, truth, start), poor_seeds, low, high)) in cases.into_iter().enumerate() {
        let (case, structure) = stall_case(&format!("stall-scatter-{index}"), &truth, &start);
        let options = from_model_values(&structure, 1);
        let exact_inputs = exact_inputs_profile(&case);
        let mut errors = Vec::new();
        let mut fits = Vec::new();
        let mut exact = Vec::new();
        for seed in 1..=12 {
            let (error, status) = if index == 1 {
                let (bounds, _, status, exact_bounds) =
                    bounds_of_seed(&case, &structure, "tau2", &options, (seed, &exact_inputs));
                let error = bounds.error / bounds.white;
                fits.push(bounds);
                exact.push(exact_bounds);
                (error, status)
            } else {
                let (record, scenario) = case.record("flight-test-25hz", seed);
                let estimate = output_error(&[&record], &structure, &options).unwrap();
                let (_, value, sigma, truth) = rows(&estimate, &scenario)
                    .into_iter()
                    .find(|r| r.0 == "tau2")
                    .unwrap();
                let coloured = common::coloured_outputs(&estimate);
                ((value - truth) / sigma, (estimate.status, coloured))
            };
            eprintln!(
                "{label}, seed {seed}: {}, coloured {:?}, τ2 {error:+.2}σ",
                status.0, status.1
            );
            if poor_seeds.contains(&seed) {
                assert!(
                    status.0 == Status::Converged && !status.1.is_empty() && error.abs() > 100.0,
                    "{label}, seed {seed}: {status:?}"
                );
            } else {
                assert_eq!(
                    status,
                    (Status::Converged, Vec::new()),
                    "{label}, seed {seed}"
                );
                errors.push(error);
            }
        }
        let n = errors.len() as f64;
        let mean = errors.iter().sum::<f64>() / n;
        let spread = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        eprintln!("{label}: τ2 error/σ mean {mean:+.2}, standard deviation {spread:.2}");
        assert!(spread > low && spread < high, "{label}: {spread:.2}");
        if index == 1 {
            let ([_, coloured, inputs], coverage) = bound_honesty(label, &fits);
            assert!(coloured > 3.0 && coverage[1] < 0.6, "{label}");
            assert!(inputs > 0.6 && inputs < 1.6, "{label}: {inputs:.2}");
            let ([exact, ..], _) = bound_honesty(&format!("{label}, exact inputs"), &exact);
            assert!(exact > 0.6 && exact < 1.6, "{label}: {exact:.2}");
        }
    }
}
