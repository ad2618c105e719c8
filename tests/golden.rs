//! The accuracy gates of golden/gates.toml as tests: every case passes its
//! tolerances, and its estimates (4 significant digits) match the committed
//! insta snapshot in golden/snapshots, so any change in what an estimator
//! returns is seen in review even while it stays inside its gate.

use aeroid::eval::gate;

#[test]
fn every_gate_passes_and_matches_its_snapshot() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(gate::GATE_FILE);
    let gates = gate::load(&path).unwrap();
    assert!(!gates.cases.is_empty());
    let mut failures = String::new();
    for case in &gates.cases {
        let result = gate::run_case(case).unwrap_or_else(|e| panic!("{}: {e}", case.name));
        if !result.passed() {
            failures += &format!("{}\n{}", case.name, result.failures());
        }
        insta::with_settings!({ snapshot_path => "../golden/snapshots", prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!(case.name.clone(), result.snapshot());
        });
    }
    assert!(failures.is_empty(), "gates failed:\n{failures}");
}

/// A gate must be able to fail: a case with a tolerance far below the
/// estimator's accuracy fails, and its failure table names the parameters;
/// likewise a σ gate, and a case that expects a refusal from an estimator
/// that does run.
#[test]
fn a_tight_gate_fails_with_a_readable_table() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(gate::GATE_FILE);
    let cases = gate::load(&path).unwrap().cases;
    let find = |name: &str| cases.iter().find(|c| c.name == name).unwrap().clone();

    let mut relative = find("attas-lateral-ft-ee");
    relative.relative_tolerance = Some(1e-9);
    relative.tolerance.clear();
    relative.absolute_floor = 0.0;
    let result = gate::run_case(&relative).unwrap();
    assert!(!result.passed());
    let table = result.failures();
    assert!(
        table.contains("allowed") && table.contains("FAIL") && table.lines().count() > 3,
        "{table}"
    );

    let mut sigma = find("attas-lateral-ideal-oem");
    sigma.relative_tolerance = None;
    sigma.sigma_tolerance = Some(1e-3);
    assert!(!gate::run_case(&sigma).unwrap().passed());

    let mut refusal = find("attas-lateral-ideal-oem");
    refusal.expect_refusal = Some(aeroid::estimation::estimator::RefusalKind::MissingChannels);
    assert!(!gate::run_case(&refusal).unwrap().passed());
}
