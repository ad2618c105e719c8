//! The accuracy gates of golden/gates.toml as tests: every case passes its
//! tolerances, and its estimates (4 significant digits) match the committed
//! insta snapshot in golden/snapshots, so any change in what an estimator
//! returns is seen in review even while it stays inside its gate. The
//! gates gate: no row prints `ok` at half its truth or with a wrong sign,
//! and a 10 % bias put on one derivative of any case's estimate fails
//! that case, wherever the case's bounds can see one (a derivative gated
//! below 5 % of its truth: its present error and the bias then exceed its
//! allowance).

use aeroid::eval::gate::{self, Check, Flown, GateCase, GateResult};

fn gate_file() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(gate::GATE_FILE)
}

/// The `ok` rows of a printed gate table whose error reaches half a
/// non-zero truth, or whose estimate has the truth's opposite sign: none
/// may exist. Read from the text a user sees (`aeroid gate --verbose`).
fn ok_rows_beyond_half(table: &str) -> Vec<String> {
    table
        .lines()
        .filter(|line| line.trim_end().ends_with(" ok"))
        .filter(|line| {
            let columns: Vec<f64> = line
                .split_whitespace()
                .skip(1)
                .take(4)
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect();
            let (estimate, truth, error) = (columns[0], columns[2], columns[3]);
            truth.abs() > 1e-12
                && (error.abs() >= gate::HALF_THE_TRUTH * truth.abs() || estimate * truth < 0.0)
        })
        .map(str::to_string)
        .collect()
}

/// The derivatives of a flown case whose 10 % bias (of the truth, away
/// from it) the case catches, and those it does not; None for a refusal.
/// `Some` with both empty when no derivative is gated.
fn caught_biases(case: &GateCase, flown: &Flown) -> Option<(Vec<String>, Vec<String>)> {
    let estimate = flown.estimate.as_ref()?;
    let (mut caught, mut missed) = (Vec::new(), Vec::new());
    for (j, p) in estimate.parameters.iter().enumerate() {
        let Some(&truth) = flown.truths.get(&p.name) else {
            continue;
        };
        if truth.abs() < 1e-12 {
            continue;
        }
        let mut biased = flown.clone();
        let away = if p.value >= truth { 1.0 } else { -1.0 };
        let parameters = &mut biased.estimate.as_mut().unwrap().parameters;
        parameters[j].value += away * 0.1 * truth.abs();
        let result = gate::judge(case, biased);
        let row = result.rows.iter().find(|r| r.parameter == p.name);
        match row.map(|r| &r.check) {
            Some(Check::NotIdentifiable) | None => {}
            _ if result.passed() => missed.push(p.name.clone()),
            _ => caught.push(p.name.clone()),
        }
    }
    Some((caught, missed))
}

#[test]
fn every_gate_passes_and_matches_its_snapshot() {
    let gates = gate::load(
        &aeroid::estimation::registry::Registry::built_in(),
        &gate_file(),
    )
    .unwrap();
    assert!(!gates.cases.is_empty());
    let mut failures = String::new();
    let mut blind = Vec::new();
    for case in &gates.cases {
        let flown = gate::fly_case(&aeroid::estimation::registry::Registry::built_in(), case)
            .unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let result: GateResult = gate::judge(case, flown.clone());
        if !result.passed() {
            failures += &format!("{}\n{}", case.name, result.failures());
        }
        let table = result.table(false);
        let beyond = ok_rows_beyond_half(&table);
        assert!(
            beyond.is_empty(),
            "{}: ok at half the truth or a wrong sign:\n{}",
            case.name,
            beyond.join("\n")
        );
        if let Some((caught, missed)) = caught_biases(case, &flown) {
            eprintln!(
                "{}: a 10 % bias caught on {} of {} derivatives",
                case.name,
                caught.len(),
                caught.len() + missed.len()
            );
            let visible = result.rows.iter().any(|r| {
                r.check == Check::Ok && r.truth.abs() > 1e-12 && r.allowed < 0.05 * r.truth.abs()
            });
            if caught.is_empty() && visible {
                blind.push(format!("{} (missed: {})", case.name, missed.join(", ")));
            }
        }
        insta::with_settings!({ snapshot_path => "../golden/snapshots", prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!(case.name.clone(), result.snapshot());
        });
    }
    assert!(failures.is_empty(), "gates failed:\n{failures}");
    assert!(
        blind.is_empty(),
        "cases that catch a 10 % bias on none of their derivatives:\n{}",
        blind.join("\n")
    );
}

/// A gate must be able to fail: a case with a tolerance far below the
/// estimator's accuracy fails, and its failure table names the parameters;
/// likewise a σ gate, and a case that expects a refusal from an estimator
/// that does run.
#[test]
fn a_tight_gate_fails_with_a_readable_table() {
    let cases = gate::load(
        &aeroid::estimation::registry::Registry::built_in(),
        &gate_file(),
    )
    .unwrap()
    .cases;
    let find = |name: &str| cases.iter().find(|c| c.name == name).unwrap().clone();

    let mut relative = find("attas-lateral-ft-ee");
    relative.sigma_tolerance = None;
    relative.relative_tolerance = Some(1e-9);
    relative.tolerance.clear();
    relative.known.clear();
    relative.absolute_floor = 0.0;
    let result = gate::run_case(
        &aeroid::estimation::registry::Registry::built_in(),
        &relative,
    )
    .unwrap();
    assert!(!result.passed());
    let table = result.failures();
    assert!(
        table.contains("allowed") && table.contains("FAIL") && table.lines().count() > 3,
        "{table}"
    );

    let mut sigma = find("attas-lateral-ideal-oem");
    sigma.relative_tolerance = None;
    sigma.sigma_tolerance = Some(1e-3);
    assert!(
        !gate::run_case(&aeroid::estimation::registry::Registry::built_in(), &sigma)
            .unwrap()
            .passed()
    );

    let mut refusal = find("attas-lateral-ideal-oem");
    refusal.expect_refusal = Some(aeroid::estimation::estimator::RefusalKind::MissingChannels);
    assert!(
        !gate::run_case(
            &aeroid::estimation::registry::Registry::built_in(),
            &refusal
        )
        .unwrap()
        .passed()
    );
}
