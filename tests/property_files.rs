//! Property-based tests over every file kind aeroid reads: bundled files
//! (aircraft, scenarios, model structures, recorder profiles, studies, the
//! gate file), an import column map with its CSV or its headerless ASCII file (comments,
//! BOM, CRLF, numbered and combined columns), a scenario replaying an
//! input CSV, record folders, every method's settings table and a study's
//! journal (lines truncated, duplicated, deleted, reordered), each
//! mutated (a key or table deleted, an array element duplicated, a value's
//! type swapped, extreme numbers, NaN and infinities as TOML floats and as
//! quantities with units, empty values, a line duplicated or deleted, the
//! file truncated, random bytes inserted).
//!
//! The property: every loader returns either a valid result or a clean
//! error, never a panic or a hang (each case runs on its own thread with a
//! time limit), and `aeroid check` never accepts a file that its loader
//! rejects. What loads is used (a scenario flies briefly, a profile records,
//! a record is described) without a panic. A record read or imported
//! without error is valid and reads back identically after being written.
//!
//! Cases per file kind: `AEROID_FUZZ_CASES` (default 500); see docs/testing.md.

use aeroid::check::check_file;
use aeroid::estimation::structure::Structure;
use aeroid::eval::gate;
use aeroid::eval::study::Study;
use aeroid::record::recorder::Profile;
use aeroid::record::{Channel, FlightRecord, import};
use aeroid::sim::aircraft::Aircraft;
use aeroid::sim::scenario::Scenario;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;
use toml::Value;

/// The time one case may take before it counts as a hang.
const CASE_LIMIT: Duration = Duration::from_secs(30);

/// The random stream's seed: fixed, so that `cargo test` checks the same
/// cases every run; `AEROID_FUZZ_SEED=N` explores others.
fn seed() -> u64 {
    std::env::var("AEROID_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2026)
}

fn cases() -> u32 {
    std::env::var("AEROID_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(500)
}

/// Runs `property` on `cases()` inputs drawn from `strategy`, failing with the
/// (shrunk) input and the property's message.
fn check_property<S>(
    kind: &str,
    strategy: S,
    property: impl Fn(S::Value) -> Result<Outcome, String>,
) where
    S: Strategy,
    S::Value: std::fmt::Debug,
{
    let mut seed_bytes = [0u8; 32];
    seed_bytes[..8].copy_from_slice(&seed().to_le_bytes());
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: cases(),
            failure_persistence: None,
            max_shrink_iters: 256,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &seed_bytes),
    );
    let start = std::time::Instant::now();
    let counts = std::cell::RefCell::new([0usize; 2]);
    let result = runner.run(&strategy, |case| {
        let outcome = property(case).map_err(TestCaseError::fail)?;
        counts.borrow_mut()[outcome as usize] += 1;
        Ok(())
    });
    if let Err(error) = result {
        panic!("{kind}: {error}");
    }
    let [accepted, refused] = *counts.borrow();
    eprintln!(
        "{kind}: {} cases (seed {}) in {:.1} s: {accepted} accepted, {refused} refused",
        cases(),
        seed(),
        start.elapsed().as_secs_f64()
    );
    // Both paths are exercised: a generator that only ever produced
    // refusals would test the error messages and nothing of what loads,
    // and the other way round. At the default 500 cases the bundled kinds
    // are accepted 8–24 % of the time (headerless imports the least); 3 %
    // lies more than 4 binomial standard deviations below the lowest.
    if cases() >= 100 {
        let floor = (0.03 * cases() as f64) as usize;
        assert!(
            accepted >= floor && refused >= floor,
            "{kind}: {accepted} accepted, {refused} refused of {}: the mutations no longer exercise both paths",
            cases()
        );
    }
}

/// What a case came to: the loader accepted or refused the input.
#[derive(Debug, Clone, Copy)]
enum Outcome {
    Accepted,
    Refused,
}

/// Runs `work` on its own thread: a panic or a run longer than
/// [`CASE_LIMIT`] is an error carrying `input`.
fn guarded(
    input: &str,
    work: impl FnOnce() -> Result<Outcome, String> + Send + 'static,
) -> Result<Outcome, String> {
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || {
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
            let _ = sender.send(outcome);
        })
        .map_err(|e| e.to_string())?;
    match receiver.recv_timeout(CASE_LIMIT) {
        Ok(Ok(Ok(outcome))) => Ok(outcome),
        Ok(Ok(Err(message))) => Err(format!("{message}\n--- input ---\n{input}")),
        Ok(Err(payload)) => {
            let message = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(format!("panicked: {message}\n--- input ---\n{input}"))
        }
        Err(_) => Err(format!(
            "no answer within {CASE_LIMIT:?}\n--- input ---\n{input}"
        )),
    }
}

/// A fresh folder for one case, removed when dropped.
struct CaseFolder(PathBuf);

impl CaseFolder {
    fn new(kind: &str) -> CaseFolder {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let folder = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!(
            "aeroid-fuzz-{kind}-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&folder);
        std::fs::create_dir_all(&folder).unwrap();
        CaseFolder(folder)
    }
}

impl Drop for CaseFolder {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

// ---------------------------------------------------------------- mutations

/// A mutation of the parsed TOML tree; the numbers pick a node and a value.
#[derive(Debug, Clone)]
enum TreeMutation {
    Delete(usize),
    Duplicate(usize),
    SwapType(usize, usize),
    Extreme(usize, usize),
    NonFinite(usize, usize),
    Empty(usize, usize),
}

/// A mutation of the file's bytes, after the tree mutations.
#[derive(Debug, Clone)]
enum TextMutation {
    Truncate(u16),
    InsertBytes(u16, Vec<u8>),
    DuplicateLine(u16),
    DeleteLine(u16),
}

fn tree_mutation() -> impl Strategy<Value = TreeMutation> {
    let (i, j) = (any::<usize>(), any::<usize>());
    prop_oneof![
        i.prop_map(TreeMutation::Delete),
        i.prop_map(TreeMutation::Duplicate),
        (i, j).prop_map(|(i, j)| TreeMutation::SwapType(i, j)),
        (i, j).prop_map(|(i, j)| TreeMutation::Extreme(i, j)),
        (i, j).prop_map(|(i, j)| TreeMutation::NonFinite(i, j)),
        (i, j).prop_map(|(i, j)| TreeMutation::Empty(i, j)),
    ]
}

fn text_mutation() -> impl Strategy<Value = TextMutation> {
    prop_oneof![
        any::<u16>().prop_map(TextMutation::Truncate),
        (any::<u16>(), prop::collection::vec(any::<u8>(), 1..8))
            .prop_map(|(at, bytes)| TextMutation::InsertBytes(at, bytes)),
        any::<u16>().prop_map(TextMutation::DuplicateLine),
        any::<u16>().prop_map(TextMutation::DeleteLine),
    ]
}

/// Mutations of one file: mostly a few tree mutations, sometimes a text one.
#[derive(Debug, Clone)]
struct Mutations {
    tree: Vec<TreeMutation>,
    text: Vec<TextMutation>,
}

fn mutations() -> impl Strategy<Value = Mutations> {
    (
        prop::collection::vec(tree_mutation(), 0..4),
        prop::collection::vec(text_mutation(), 0..2),
        any::<bool>(),
    )
        .prop_map(|(tree, text, keep_text)| Mutations {
            text: if keep_text || tree.is_empty() {
                text
            } else {
                Vec::new()
            },
            tree,
        })
}

#[derive(Debug, Clone, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// Every node of the tree (not the root), depth first.
fn paths(value: &Value, prefix: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
    match value {
        Value::Table(table) => {
            for (key, child) in table {
                prefix.push(Step::Key(key.clone()));
                out.push(prefix.clone());
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        Value::Array(array) => {
            for (i, child) in array.iter().enumerate() {
                prefix.push(Step::Index(i));
                out.push(prefix.clone());
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

fn node_mut<'a>(root: &'a mut Value, path: &[Step]) -> Option<&'a mut Value> {
    path.iter().try_fold(root, |node, step| match (node, step) {
        (Value::Table(t), Step::Key(k)) => t.get_mut(k),
        (Value::Array(a), Step::Index(i)) => a.get_mut(*i),
        _ => None,
    })
}

/// The unit of a quantity written as `"value unit"`, else "".
fn unit_of(value: &Value) -> String {
    match value {
        Value::String(s) => s
            .trim()
            .split_once(' ')
            .map_or(String::new(), |(_, unit)| unit.trim().to_string()),
        _ => String::new(),
    }
}

fn with_unit(number: &str, unit: &str) -> Value {
    match unit {
        "" => Value::String(number.to_string()),
        unit => Value::String(format!("{number} {unit}")),
    }
}

fn pick<T: Clone>(options: &[T], i: usize) -> T {
    options[i % options.len()].clone()
}

fn replacement(mutation: &TreeMutation, old: &Value) -> Option<Value> {
    let unit = unit_of(old);
    Some(match *mutation {
        TreeMutation::SwapType(_, j) => {
            let options = [
                Value::Integer(1),
                Value::Float(2.5),
                Value::String("abc".into()),
                Value::String("1".into()),
                with_unit("1", &unit),
                Value::Boolean(true),
                Value::Boolean(false),
                Value::Array(vec![Value::Integer(1), Value::String("x".into())]),
                Value::Array(vec![old.clone()]),
                Value::Table(toml::Table::from_iter([("x".to_string(), old.clone())])),
            ];
            pick(&options, j)
        }
        TreeMutation::Extreme(_, j) => {
            let options = [
                Value::Float(0.0),
                Value::Float(-0.0),
                Value::Float(1e308),
                Value::Float(-1e308),
                Value::Float(5e-324),
                Value::Float(-5e-324),
                Value::Integer(0),
                Value::Integer(-1),
                Value::Integer(i64::MAX),
                Value::Integer(i64::MIN),
                with_unit("0", &unit),
                with_unit("-0", &unit),
                with_unit("1e308", &unit),
                with_unit("-1e308", &unit),
                with_unit("5e-324", &unit),
                with_unit("1e400", &unit),
                with_unit("123456789012345678901234567890", &unit),
            ];
            pick(&options, j)
        }
        TreeMutation::NonFinite(_, j) => {
            let options = [
                Value::Float(f64::NAN),
                Value::Float(f64::INFINITY),
                Value::Float(f64::NEG_INFINITY),
                with_unit("nan", &unit),
                with_unit("NaN", &unit),
                with_unit("inf", &unit),
                with_unit("-inf", &unit),
                with_unit("infinity", &unit),
            ];
            pick(&options, j)
        }
        TreeMutation::Empty(_, j) => {
            let options = [
                Value::String(String::new()),
                Value::String(" ".into()),
                Value::Array(Vec::new()),
                Value::Table(toml::Table::new()),
                with_unit("", &unit),
            ];
            pick(&options, j)
        }
        TreeMutation::Delete(_) | TreeMutation::Duplicate(_) => return None,
    })
}

fn apply_tree(root: &mut Value, mutation: &TreeMutation) {
    let mut all = Vec::new();
    paths(root, &mut Vec::new(), &mut all);
    let index = match *mutation {
        TreeMutation::Delete(i)
        | TreeMutation::Duplicate(i)
        | TreeMutation::SwapType(i, _)
        | TreeMutation::Extreme(i, _)
        | TreeMutation::NonFinite(i, _)
        | TreeMutation::Empty(i, _) => i,
    };
    match mutation {
        TreeMutation::Delete(_) | TreeMutation::Duplicate(_) => {
            // Delete and duplicate act on a table key or an array element.
            if all.is_empty() {
                return;
            }
            let path = &all[index % all.len()];
            let (last, parent) = path.split_last().unwrap();
            let Some(parent) = node_mut(root, parent) else {
                return;
            };
            match (parent, last, mutation) {
                (Value::Table(t), Step::Key(k), TreeMutation::Delete(_)) => {
                    t.remove(k);
                }
                (Value::Array(a), Step::Index(i), TreeMutation::Delete(_)) => {
                    a.remove(*i);
                }
                (Value::Array(a), Step::Index(i), _) => {
                    let copy = a[*i].clone();
                    a.insert(*i, copy);
                }
                (Value::Table(t), Step::Key(k), _) => {
                    // A table cannot hold a key twice: copy the value under a new key.
                    let copy = t[k].clone();
                    t.insert(format!("{k}_copy"), copy);
                }
                _ => {}
            }
        }
        _ => {
            let scalars: Vec<&Vec<Step>> = all.iter().collect();
            if scalars.is_empty() {
                return;
            }
            let path = scalars[index % scalars.len()].clone();
            if let Some(node) = node_mut(root, &path)
                && let Some(value) = replacement(mutation, node)
            {
                *node = value;
            }
        }
    }
}

fn apply_text(bytes: &mut Vec<u8>, mutation: &TextMutation) {
    let at = |k: u16, len: usize| (k as usize * (len + 1)) / (u16::MAX as usize + 1);
    match mutation {
        TextMutation::Truncate(k) => bytes.truncate(at(*k, bytes.len())),
        TextMutation::InsertBytes(k, inserted) => {
            let position = at(*k, bytes.len());
            bytes.splice(position..position, inserted.iter().copied());
        }
        TextMutation::DuplicateLine(k) | TextMutation::DeleteLine(k) => {
            let mut lines: Vec<Vec<u8>> =
                bytes.split(|b| *b == b'\n').map(<[u8]>::to_vec).collect();
            let line = at(*k, lines.len().saturating_sub(1));
            match mutation {
                TextMutation::DuplicateLine(_) => {
                    let copy = lines[line].clone();
                    lines.insert(line, copy);
                }
                _ => {
                    lines.remove(line);
                }
            }
            *bytes = lines.join(&b'\n');
        }
    }
}

/// The file `text` after `mutations`.
fn mutate(text: &str, mutations: &Mutations) -> Vec<u8> {
    let mut bytes = if mutations.tree.is_empty() {
        text.as_bytes().to_vec()
    } else {
        let mut root = Value::Table(toml::from_str(text).expect("a bundled file parses"));
        for mutation in &mutations.tree {
            apply_tree(&mut root, mutation);
        }
        match root {
            Value::Table(table) => toml::to_string(&table).expect("a TOML tree serialises"),
            _ => unreachable!(),
        }
        .into_bytes()
    };
    for mutation in &mutations.text {
        apply_text(&mut bytes, mutation);
    }
    bytes
}

// ------------------------------------------------------- bundled file kinds

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Aircraft,
    Scenario,
    Model,
    Profile,
    Study,
    Gates,
}

impl Kind {
    fn files(self) -> Vec<PathBuf> {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let folder = match self {
            Kind::Aircraft => "aircraft",
            Kind::Scenario => "scenarios",
            Kind::Model => "models",
            Kind::Profile => "recorders",
            Kind::Study => "studies",
            Kind::Gates => return vec![root.join("golden/gates.toml")],
        };
        let mut files: Vec<PathBuf> = std::fs::read_dir(root.join(folder))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        files
    }

    /// Loads the file with its kind's loader: Ok(()) or the error's text.
    fn load(self, path: &Path) -> Result<(), String> {
        let reference = path.to_str().unwrap();
        let outcome = match self {
            Kind::Aircraft => Aircraft::load(path).map(drop).map_err(aeroid::Error::from),
            Kind::Scenario => Scenario::load(reference)
                .map(drop)
                .map_err(aeroid::Error::from),
            Kind::Model => Structure::load(reference)
                .map(drop)
                .map_err(aeroid::Error::from),
            Kind::Profile => Profile::load(reference, None)
                .map(drop)
                .map_err(aeroid::Error::from),
            Kind::Study => Study::load(
                &aeroid::estimation::registry::Registry::built_in(),
                reference,
            )
            .map(drop)
            .map_err(aeroid::Error::from),
            Kind::Gates => gate::load(&aeroid::estimation::registry::Registry::built_in(), path)
                .map(drop)
                .map_err(aeroid::Error::from),
        };
        outcome.map_err(|e| e.to_string())
    }
}

/// Loads a mutated bundled file with its loader and with `check`.
fn bundled_file_property(
    kind: Kind,
    (file, mutations): (usize, Mutations),
) -> Result<Outcome, String> {
    let files = kind.files();
    let original = files[file % files.len()].clone();
    let text = std::fs::read_to_string(&original).unwrap();
    let bytes = mutate(&text, &mutations);
    let input = format!(
        "{} with {mutations:?}\n{}",
        original.display(),
        String::from_utf8_lossy(&bytes)
    );
    guarded(&input, move || {
        let folder = CaseFolder::new(&format!("{kind:?}"));
        let path = folder.0.join(original.file_name().unwrap());
        std::fs::write(&path, &bytes).unwrap();
        let loaded = kind.load(&path);
        if kind != Kind::Gates {
            let checked = check_file(&aeroid::estimation::registry::Registry::built_in(), &path);
            if let (Err(error), Ok(report)) = (&loaded, &checked) {
                return Err(format!(
                    "check accepts ({}: {:?}) a file the {kind:?} loader rejects: {error}",
                    report.kind, report.lines
                ));
            }
        }
        if loaded.is_ok() {
            use_loaded(kind, &path)?;
        }
        Ok(match loaded {
            Ok(()) => Outcome::Accepted,
            Err(_) => Outcome::Refused,
        })
    })
}

/// The steps of a shortened flight: enough to cover the inputs' start
/// without making a mutated scenario a long simulation.
const SHORT_FLIGHT_STEPS: usize = 400;

/// Uses what loaded: a scenario flies (shortened) and a recorder profile
/// records a short flight; either gives a result or a clean error, and a
/// record made is valid.
fn use_loaded(kind: Kind, path: &Path) -> Result<(), String> {
    match kind {
        Kind::Scenario => {
            let mut scenario = Scenario::load(path.to_str().unwrap()).unwrap();
            let steps = scenario.step_count().min(SHORT_FLIGHT_STEPS);
            scenario.duration = steps as f64 * scenario.step;
            let _ = aeroid::sim::fly(&scenario);
        }
        Kind::Profile => {
            let profile = Profile::load(path.to_str().unwrap(), None).unwrap();
            let (scenario, trace) = short_flight();
            if let Ok(record) = profile.record(trace, &scenario.aircraft, 7) {
                record
                    .validate(path)
                    .map_err(|e| format!("the profile recorded an invalid record: {e}"))?;
            }
        }
        _ => {}
    }
    Ok(())
}

/// A 4 s ATTAS elevator 3-2-1-1, flown once.
fn short_flight() -> &'static (Scenario, aeroid::sim::trace::TruthTrace) {
    static FLIGHT: std::sync::OnceLock<(Scenario, aeroid::sim::trace::TruthTrace)> =
        std::sync::OnceLock::new();
    FLIGHT.get_or_init(|| {
        let mut scenario = Scenario::load("attas-elevator-3211").unwrap();
        scenario.duration = 4.0;
        let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
        (scenario, trace)
    })
}

fn bundled_strategy() -> impl Strategy<Value = (usize, Mutations)> {
    (any::<usize>(), mutations())
}

#[test]
fn mutated_aircraft_files_load_or_fail_cleanly() {
    check_property("aircraft", bundled_strategy(), |case| {
        bundled_file_property(Kind::Aircraft, case)
    });
}

#[test]
fn mutated_scenarios_load_or_fail_cleanly() {
    check_property("scenario", bundled_strategy(), |case| {
        bundled_file_property(Kind::Scenario, case)
    });
}

#[test]
fn mutated_model_structures_load_or_fail_cleanly() {
    check_property("model structure", bundled_strategy(), |case| {
        bundled_file_property(Kind::Model, case)
    });
}

#[test]
fn mutated_recorder_profiles_load_or_fail_cleanly() {
    check_property("recorder profile", bundled_strategy(), |case| {
        bundled_file_property(Kind::Profile, case)
    });
}

#[test]
fn mutated_studies_load_or_fail_cleanly() {
    check_property("study", bundled_strategy(), |case| {
        bundled_file_property(Kind::Study, case)
    });
}

#[test]
fn mutated_gate_files_load_or_fail_cleanly() {
    check_property("gate file", bundled_strategy(), |case| {
        bundled_file_property(Kind::Gates, case)
    });
}

// ------------------------------------------------------------ record folders

/// Values as read back: equal, or both NaN (a dropout).
fn same_record(a: &FlightRecord, b: &FlightRecord) -> bool {
    let same = |x: &[f64], y: &[f64]| {
        x.len() == y.len()
            && x.iter()
                .zip(y)
                .all(|(p, q)| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()))
    };
    a.scenario == b.scenario
        && a.seed == b.seed
        && a.profile == b.profile
        && a.absent == b.absent
        && a.channels.len() == b.channels.len()
        && a.channels.iter().zip(&b.channels).all(|(c, d)| {
            c.name == d.name
                && c.unit == d.unit
                && c.rate.to_bits() == d.rate.to_bits()
                && c.resolution.map(f64::to_bits) == d.resolution.map(f64::to_bits)
                && c.source == d.source
                && same(&c.times, &d.times)
                && same(&c.values, &d.values)
        })
}

/// A record read without error is valid, and writing it and reading it
/// back gives the same record.
fn round_trip(record: &FlightRecord, folder: &Path) -> Result<Outcome, String> {
    record
        .validate(folder)
        .map_err(|e| format!("a record that loaded is not valid: {e}"))?;
    let _ = record.describe();
    let copy = folder.join("copy");
    record
        .write(&copy)
        .map_err(|e| format!("a record that loaded cannot be written: {e}"))?;
    let again = FlightRecord::read(&copy)
        .map_err(|e| format!("a written record does not read back: {e}"))?;
    if !same_record(record, &again) {
        return Err(format!(
            "the record changed on a write and read:\n{record:?}\n{again:?}"
        ));
    }
    Ok(Outcome::Accepted)
}

fn sample_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -1e3..1e3f64,
        1 => Just(f64::NAN),
        1 => prop::sample::select(vec![0.0, -0.0, 1e308, -1e308, 5e-324, 1e-300, 123456789.125]),
    ]
}

/// A valid record: up to four channels on one to three time bases, each
/// channel with at least one sample.
fn record() -> impl Strategy<Value = FlightRecord> {
    let base = (-100.0..100.0f64, prop::collection::vec(1e-3..2.0f64, 1..25)).prop_map(
        |(start, steps)| {
            steps
                .iter()
                .scan(start, |t, dt| {
                    let now = *t;
                    *t += dt;
                    Some(now)
                })
                .collect::<Vec<f64>>()
        },
    );
    let channel = (
        any::<usize>(),
        prop::collection::vec(sample_value(), 25),
        prop::sample::select(vec![25.0, 1.0, 0.5, 1e-3, 100.0, 8.0]),
        prop::option::of(prop::sample::select(vec![1e-3, 0.25, 1.0])),
    );
    (
        prop::collection::vec(base, 1..4),
        prop::collection::vec(channel, 1..5),
        prop::option::of(0..=i64::MAX as u64),
    )
        .prop_map(|(bases, channels, seed)| {
            let names = ["alpha", "q", "nz", "elevator", "airspeed", "probe_1.x"];
            let units = ["rad", "rad/s", "-", "rad", "m/s", "K"];
            FlightRecord {
                scenario: "fuzz".into(),
                seed,
                profile: "fuzz-profile".into(),
                absent: vec!["p".into()],
                channels: channels
                    .into_iter()
                    .enumerate()
                    .map(|(i, (b, values, rate, resolution))| {
                        let times = bases[b % bases.len()].clone();
                        Channel {
                            name: names[i].into(),
                            unit: units[i].into(),
                            rate,
                            resolution,
                            source: format!("fuzz {i}"),
                            values: values[..times.len()].to_vec(),
                            times,
                        }
                    })
                    .collect(),
                bridge_gaps: false,
            }
        })
}

/// A mutation of a CSV file: a cell replaced, or a text mutation.
#[derive(Debug, Clone)]
enum CsvMutation {
    Cell(u16, u16, usize),
    Text(TextMutation),
}

fn csv_mutation() -> impl Strategy<Value = CsvMutation> {
    prop_oneof![
        3 => (any::<u16>(), any::<u16>(), any::<usize>())
            .prop_map(|(row, column, value)| CsvMutation::Cell(row, column, value)),
        1 => text_mutation().prop_map(CsvMutation::Text),
    ]
}

const CELLS: &[&str] = &[
    "",
    " ",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "infinity",
    "1e400",
    "-1e400",
    "1e308",
    "5e-324",
    "-0",
    "0",
    "abc",
    "1,5",
    "\"1\"",
    "\"",
    "0x10",
    "1e",
    "--1",
    "12 m",
    "é",
    "99999999999999999999999999",
];

fn apply_csv(bytes: &mut Vec<u8>, mutation: &CsvMutation) {
    apply_delimited(bytes, mutation, ",");
}

/// A mutation of a file whose cells are separated by `delimiter`.
fn apply_delimited(bytes: &mut Vec<u8>, mutation: &CsvMutation, delimiter: &str) {
    match mutation {
        CsvMutation::Text(text) => apply_text(bytes, text),
        CsvMutation::Cell(row, column, value) => {
            let text = String::from_utf8_lossy(bytes).into_owned();
            let mut lines: Vec<String> = text.split('\n').map(str::to_string).collect();
            let line = *row as usize % lines.len();
            let mut cells: Vec<String> = lines[line].split(delimiter).map(str::to_string).collect();
            let cell = *column as usize % cells.len();
            cells[cell] = pick(CELLS, *value).to_string();
            lines[line] = cells.join(delimiter);
            *bytes = lines.join("\n").into_bytes();
        }
    }
}

/// Mutations of a TOML file and of a CSV file beside it: a third of the
/// cases mutate only the TOML file, a third only the CSV file, a third both.
fn toml_and_csv_mutations() -> impl Strategy<Value = (Mutations, Vec<CsvMutation>)> {
    (
        mutations(),
        prop::collection::vec(csv_mutation(), 1..4),
        0..3u8,
    )
        .prop_map(|(toml, csv, side)| match side {
            0 => (toml, Vec::new()),
            1 => (
                Mutations {
                    tree: Vec::new(),
                    text: Vec::new(),
                },
                csv,
            ),
            _ => (toml, csv),
        })
}

#[test]
fn mutated_record_folders_read_or_fail_cleanly() {
    let strategy = (record(), toml_and_csv_mutations(), any::<usize>());
    check_property(
        "record folder",
        strategy,
        |(record, (mutations, csv), file)| {
            let csv: Vec<(usize, CsvMutation)> = csv.into_iter().map(|m| (file, m)).collect();
            let input = format!("{record:?}\nrecord.toml: {mutations:?}\nCSV: {csv:?}");
            guarded(&input, move || {
                let folder = CaseFolder::new("record");
                let data = folder.0.join("rec");
                record
                    .write(&data)
                    .map_err(|e| format!("a valid record cannot be written: {e}"))?;
                let toml_path = data.join("record.toml");
                let text = std::fs::read_to_string(&toml_path).unwrap();
                std::fs::write(&toml_path, mutate(&text, &mutations)).unwrap();
                let mut csv_files: Vec<PathBuf> = std::fs::read_dir(&data)
                    .unwrap()
                    .map(|e| e.unwrap().path())
                    .filter(|p| p.extension().is_some_and(|e| e == "csv"))
                    .collect();
                csv_files.sort();
                for (file, mutation) in &csv {
                    let path = &csv_files[file % csv_files.len()];
                    let mut bytes = std::fs::read(path).unwrap();
                    apply_csv(&mut bytes, mutation);
                    std::fs::write(path, bytes).unwrap();
                }
                let unchanged =
                    mutations.tree.is_empty() && mutations.text.is_empty() && csv.is_empty();
                let read = FlightRecord::read(&data);
                match read {
                    Ok(read) if unchanged && !same_record(&record, &read) => Err(format!(
                        "an unchanged record reads back different:\n{read:?}"
                    )),
                    Ok(read) => round_trip(&read, &folder.0),
                    Err(_) if unchanged => Err(format!(
                        "a valid record does not read back: {}",
                        read.unwrap_err()
                    )),
                    Err(_) => Ok(Outcome::Refused),
                }
            })
        },
    );
}

// ------------------------------------------------------------- CSV import

const COLUMN_MAP: &str = r#"
name = "fuzz flight"

[time]
column = "Time"
unit = "s"
scale = 1.0
offset = 0.0

[[channels]]
name = "airspeed"
column = "TAS"
unit = "kt"
scale = 1.0
offset = 0.0
rate = "8 Hz"
resolution = "0.25 kt"
empty = "dropout"

[[channels]]
name = "alpha"
column = "AOA"
unit = "deg"
empty = "skip"

[[channels]]
name = "nz"
column = "NZ"

[[channels]]
name = "oat"
column = "OAT"
unit = "degC"
"#;

/// A CSV file of flight data: a strictly increasing time column, the mapped
/// columns (some cells empty) and one the map does not mention.
fn flight_csv() -> impl Strategy<Value = String> {
    let row = (
        1e-3..1.0f64,
        -1e3..1e3f64,
        prop::option::of(-20.0..20.0f64),
        -3.0..3.0f64,
        -60.0..40.0f64,
        any::<u8>(),
    );
    (-1e4..1e4f64, prop::collection::vec(row, 0..30)).prop_map(|(start, rows)| {
        let mut text = String::from("Time,TAS,AOA,NZ,OAT,EXTRA\n");
        let mut time = start;
        for (dt, tas, aoa, nz, oat, extra) in rows {
            time += dt;
            let aoa = aoa.map_or(String::new(), |a| a.to_string());
            text.push_str(&format!("{time},{tas},{aoa},{nz},{oat},{extra}\n"));
        }
        text
    })
}

#[test]
fn mutated_imports_read_or_fail_cleanly() {
    let strategy = (toml_and_csv_mutations(), flight_csv());
    check_property("import", strategy, |((mutations, csv_mutations), csv)| {
        let map = mutate(COLUMN_MAP, &mutations);
        let mut data = csv.into_bytes();
        for mutation in &csv_mutations {
            apply_csv(&mut data, mutation);
        }
        let input = format!(
            "map with {mutations:?}:\n{}\n--- CSV ---\n{}",
            String::from_utf8_lossy(&map),
            String::from_utf8_lossy(&data)
        );
        guarded(&input, move || {
            let folder = CaseFolder::new("import");
            let map_path = folder.0.join("map.toml");
            let data_path = folder.0.join("flight.csv");
            std::fs::write(&map_path, &map).unwrap();
            std::fs::write(&data_path, &data).unwrap();
            match import::import(&data_path, &map_path, aeroid::estimation::CHANNELS_READ) {
                Ok(outcome) => round_trip(&outcome.record, &folder.0),
                Err(_) => Ok(Outcome::Refused),
            }
        })
    });
}

/// Unmutated CSV files through the unmutated map: every file with rows and
/// an α cell is imported (one without is refused naming α), and every
/// value is its cell in SI: airspeed kt × 1852/3600,
/// α deg × π/180 (empty cells skipped), n_z as it is, the outside air
/// temperature °C + 273.15, each within 1e-12 relative.
#[test]
fn imported_values_are_their_cells_in_si() {
    check_property("import values", flight_csv(), |csv| {
        let input = format!("--- CSV ---\n{csv}");
        guarded(&input.clone(), move || {
            let folder = CaseFolder::new("import-values");
            let map_path = folder.0.join("map.toml");
            let data_path = folder.0.join("flight.csv");
            std::fs::write(&map_path, COLUMN_MAP).unwrap();
            std::fs::write(&data_path, &csv).unwrap();
            let rows: Vec<Vec<&str>> = csv
                .lines()
                .skip(1)
                .map(|l| l.split(',').collect())
                .collect();
            let column = |index: usize, scale: f64, offset: f64| -> Vec<f64> {
                rows.iter()
                    .filter(|r| !r[index].is_empty())
                    .map(|r| r[index].parse::<f64>().unwrap() * scale + offset)
                    .collect()
            };
            // A channel with no sample at all is refused, naming it.
            let record =
                match import::import(&data_path, &map_path, aeroid::estimation::CHANNELS_READ) {
                    Ok(outcome) => outcome.record,
                    Err(error) if rows.is_empty() || column(2, 1.0, 0.0).is_empty() => {
                        let text = error.to_string();
                        return match rows.is_empty() || text.contains("alpha") {
                            true => Ok(Outcome::Refused),
                            false => Err(format!("refused without naming alpha: {text}")),
                        };
                    }
                    Err(error) => return Err(format!("refused {} rows: {error}", rows.len())),
                };
            for (channel, expected) in [
                ("airspeed", column(1, 1852.0 / 3600.0, 0.0)),
                ("alpha", column(2, std::f64::consts::PI / 180.0, 0.0)),
                ("nz", column(3, 1.0, 0.0)),
                ("oat", column(4, 1.0, 273.15)),
            ] {
                let values = &record.channel(channel).map_err(|e| e.to_string())?.values;
                let same = values.len() == expected.len()
                    && values
                        .iter()
                        .zip(&expected)
                        .all(|(v, e)| (v - e).abs() <= 1e-12 * e.abs().max(1.0));
                if !same {
                    return Err(format!(
                        "{channel}: {values:?} against the cells {expected:?}"
                    ));
                }
            }
            Ok(Outcome::Accepted)
        })
    });
}

// ------------------------------------------------- headerless ASCII import

const ASCII_MAP: &str = r#"
name = "fuzz ascii"

[file]
header = false
delimiter = "auto"

[time]
column = 1
unit = "s"

[[channels]]
name = "airspeed"
column = 2
unit = "kt"
rate = "8 Hz"

[[channels]]
name = "altitude"
column = 3
unit = "ft"
convention = "geometric"

[[channels]]
name = "thrust"
columns = [4, 5]
combine = "sum"
unit = "lbf"

[[channels]]
name = "aileron"
columns = [6, 7]
combine = "half_difference"
unit = "deg"

[[channels]]
name = "density"
column = 8
unit = "slug/ft3"
non_finite = "dropout"

[[channels]]
name = "q_dot"
column = 9
unit = "deg/s2"
"#;

/// A headerless ASCII file: comment lines, optional BOM and CRLF, cells
/// separated by runs of spaces, a strictly increasing first column.
fn flight_ascii() -> impl Strategy<Value = String> {
    let row = (
        1e-3..1.0f64,
        prop::collection::vec(-1e4..1e4f64, 8),
        any::<bool>(),
    );
    (
        -1e4..1e4f64,
        prop::collection::vec(row, 0..30),
        any::<bool>(),
        any::<bool>(),
    )
        .prop_map(|(start, rows, bom, crlf)| {
            let end = if crlf { "\r\n" } else { "\n" };
            let mut text = String::new();
            if bom {
                text.push('\u{feff}');
            }
            text.push_str(&format!(
                "% time tas alt thrust1 thrust2 ail_l ail_r rho qdot{end}"
            ));
            let mut time = start;
            for (dt, cells, comment) in rows {
                time += dt;
                let cells: Vec<String> = cells.iter().map(f64::to_string).collect();
                text.push_str(&format!("{time}  {}{end}", cells.join("  ")));
                if comment {
                    text.push_str(&format!("# a comment{end}"));
                }
            }
            text
        })
}

#[test]
fn mutated_headerless_imports_read_or_fail_cleanly() {
    let strategy = (toml_and_csv_mutations(), flight_ascii());
    check_property(
        "headerless import",
        strategy,
        |((mutations, cell_mutations), ascii)| {
            let map = mutate(ASCII_MAP, &mutations);
            let mut data = ascii.into_bytes();
            for mutation in &cell_mutations {
                apply_delimited(&mut data, mutation, "  ");
            }
            let input = format!(
                "map with {mutations:?}:\n{}\n--- ASCII ---\n{}",
                String::from_utf8_lossy(&map),
                String::from_utf8_lossy(&data)
            );
            guarded(&input, move || {
                let folder = CaseFolder::new("import-ascii");
                let map_path = folder.0.join("map.toml");
                let data_path = folder.0.join("flight.asc");
                std::fs::write(&map_path, &map).unwrap();
                std::fs::write(&data_path, &data).unwrap();
                match import::import(&data_path, &map_path, aeroid::estimation::CHANNELS_READ) {
                    Ok(outcome) => round_trip(&outcome.record, &folder.0),
                    Err(_) => Ok(Outcome::Refused),
                }
            })
        },
    );
}

// ------------------------------------------------- replayed input CSV

/// A scenario whose elevator replays a CSV file beside it.
const REPLAY_SCENARIO: &str = r#"
name = "replay"
aircraft = "attas"
duration = "10 s"
step = "0.01 s"
seed = 1

[trim]
airspeed = "103 m/s"
altitude = "4877 m"

[[inputs]]
kind = "csv"
control = "elevator"
file = "elevator.csv"
time_column = "t"
column = "de"
unit = "deg"
start = "1 s"
"#;

/// An elevator input: a strictly increasing time column, the deflection
/// and a column the scenario does not use.
fn input_csv() -> impl Strategy<Value = String> {
    let row = (1e-3..2.0f64, -3.0..3.0f64, any::<i16>());
    (-5.0..5.0f64, prop::collection::vec(row, 0..20)).prop_map(|(start, rows)| {
        let mut text = String::from("t,de,extra\n");
        let mut time = start;
        for (dt, de, extra) in rows {
            time += dt;
            text.push_str(&format!("{time},{de},{extra}\n"));
        }
        text
    })
}

#[test]
fn mutated_replayed_inputs_load_or_fail_cleanly() {
    let strategy = (toml_and_csv_mutations(), input_csv());
    check_property(
        "replayed input",
        strategy,
        |((mutations, csv_mutations), csv)| {
            let scenario = mutate(REPLAY_SCENARIO, &mutations);
            let mut data = csv.into_bytes();
            for mutation in &csv_mutations {
                apply_csv(&mut data, mutation);
            }
            let input = format!(
                "scenario with {mutations:?}:\n{}\n--- CSV ---\n{}",
                String::from_utf8_lossy(&scenario),
                String::from_utf8_lossy(&data)
            );
            guarded(&input, move || {
                let folder = CaseFolder::new("replay");
                let path = folder.0.join("replay.toml");
                std::fs::write(&path, &scenario).unwrap();
                std::fs::write(folder.0.join("elevator.csv"), &data).unwrap();
                let loaded = Kind::Scenario.load(&path);
                if let (Err(error), Ok(report)) = (
                    &loaded,
                    check_file(&aeroid::estimation::registry::Registry::built_in(), &path),
                ) {
                    return Err(format!(
                        "check accepts ({}: {:?}) a scenario the loader rejects: {error}",
                        report.kind, report.lines
                    ));
                }
                match loaded {
                    Ok(()) => {
                        use_loaded(Kind::Scenario, &path)?;
                        Ok(Outcome::Accepted)
                    }
                    Err(_) => Ok(Outcome::Refused),
                }
            })
        },
    );
}

// ------------------------------------------------------- method settings

/// A value a user might write for a setting: numbers at and beyond every
/// edge, non-finite floats, quantities with absurd magnitudes or units,
/// and the wrong types.
fn setting_value() -> impl Strategy<Value = serde_json::Value> {
    use serde_json::json;
    prop_oneof![
        prop::sample::select(vec![
            json!(0),
            json!(-1),
            json!(1),
            json!(i64::MAX),
            json!(u64::MAX),
            json!(1e308),
            json!(-1e308),
            json!(1e-300),
            json!(0.5),
            json!("NaN"),
            json!("inf"),
            json!("1e-9 s"),
            json!("1e300 s"),
            json!("-5 s"),
            json!("0.1 parsec"),
            json!(""),
            json!(true),
            json!([]),
            json!([1, 2, 3]),
            json!({ "half_width": "1e9 s", "degree": 4 }),
            json!({ "half_width": "0.1 s", "degree": 100_000_000_000u64 }),
            json!({ "elevator": "1e300 deg" }),
        ]),
        any::<f64>().prop_map(|v| json!(v)),
        any::<i64>().prop_map(|v| json!(v)),
    ]
}

/// Every built-in method's settings check, given its own keys (and an
/// unknown one) with any value: an accepted table or a clean error naming
/// the method, never a panic or a hang.
#[test]
fn any_method_settings_are_accepted_or_refused_cleanly() {
    let registry = aeroid::estimation::registry::Registry::built_in();
    let methods: Vec<(String, Vec<String>)> = registry
        .names()
        .into_iter()
        .map(|name| {
            let keys = registry
                .find(&name)
                .unwrap()
                .info()
                .settings
                .iter()
                .map(|s| s.name.to_string())
                .chain(["no_such_key".to_string()])
                .collect();
            (name, keys)
        })
        .collect();
    let strategy = (
        0..methods.len(),
        prop::collection::vec((any::<usize>(), setting_value()), 1..4),
    );
    check_property("method settings", strategy, |(method, entries)| {
        let (name, keys) = methods[method].clone();
        let mut settings = aeroid::estimation::estimator::Settings::new();
        for (key, value) in entries {
            settings.insert(keys[key % keys.len()].clone(), value);
        }
        let input = format!("[methods.{name}] {settings:?}");
        guarded(&input, move || {
            let registry = aeroid::estimation::registry::Registry::built_in();
            match registry.find(&name).unwrap().check_settings(&settings) {
                Ok(()) => Ok(Outcome::Accepted),
                Err(error) if error.to_string().trim().is_empty() => {
                    Err("an error without a message".into())
                }
                Err(_) => Ok(Outcome::Refused),
            }
        })
    });
}

// ------------------------------------------------------------ journals

/// A line-level edit of a study journal: what an interrupted, copied or
/// hand-edited journal may look like.
#[derive(Debug, Clone)]
enum JournalEdit {
    Truncate(u16),
    DuplicateLine(u16),
    DeleteLine(u16),
    SwapLines(u16, u16),
    InsertBytes(u16, Vec<u8>),
}

fn journal_edit() -> impl Strategy<Value = JournalEdit> {
    prop_oneof![
        any::<u16>().prop_map(JournalEdit::Truncate),
        any::<u16>().prop_map(JournalEdit::DuplicateLine),
        any::<u16>().prop_map(JournalEdit::DeleteLine),
        (any::<u16>(), any::<u16>()).prop_map(|(a, b)| JournalEdit::SwapLines(a, b)),
        (any::<u16>(), prop::collection::vec(any::<u8>(), 1..6))
            .prop_map(|(at, bytes)| JournalEdit::InsertBytes(at, bytes)),
    ]
}

/// A journal's bytes with `edit` applied.
fn edit_journal(bytes: &mut Vec<u8>, edit: &JournalEdit) {
    let mut lines: Vec<Vec<u8>> = bytes
        .split_inclusive(|&b| b == b'\n')
        .map(<[u8]>::to_vec)
        .collect();
    let pick = |i: u16, n: usize| (i as usize) % n.max(1);
    match edit {
        JournalEdit::Truncate(at) => {
            let at = pick(*at, bytes.len());
            bytes.truncate(at);
            return;
        }
        JournalEdit::InsertBytes(at, inserted) => {
            let at = pick(*at, bytes.len() + 1);
            bytes.splice(at..at, inserted.iter().copied());
            return;
        }
        JournalEdit::DuplicateLine(i) if !lines.is_empty() => {
            let i = pick(*i, lines.len());
            lines.insert(i, lines[i].clone());
        }
        JournalEdit::DeleteLine(i) if !lines.is_empty() => {
            lines.remove(pick(*i, lines.len()));
        }
        JournalEdit::SwapLines(a, b) if !lines.is_empty() => {
            let n = lines.len();
            lines.swap(pick(*a, n), pick(*b, n));
        }
        _ => {}
    }
    *bytes = lines.concat();
}

/// A study journal truncated, with lines duplicated, deleted, reordered or
/// bytes inserted, is read and resumed either as a journal of cases of its
/// study, or refused cleanly naming the file — never a panic or a hang.
#[test]
fn edited_study_journals_read_or_fail_cleanly() {
    use aeroid::eval::journal::{self, FORMAT, Header, JOURNAL_FILE, Journal, Shard};
    let header = Header {
        format: FORMAT.into(),
        study: "fuzzed".into(),
        seed: 7,
        runs: 3,
        fingerprint: "0123456789abcdef".into(),
        cases: 6,
        shard: Shard::default(),
    };
    let original = {
        let folder = CaseFolder::new("journal-original");
        let written = Journal::create(&folder.0, &header).unwrap();
        for case in [0, 2, 1, 5] {
            written.append(case, &[]).unwrap();
        }
        drop(written);
        std::fs::read(folder.0.join(JOURNAL_FILE)).unwrap()
    };
    let strategy = prop::collection::vec(journal_edit(), 1..4);
    check_property("study journal", strategy, |edits| {
        let mut bytes = original.clone();
        for edit in &edits {
            edit_journal(&mut bytes, edit);
        }
        let input = format!("{edits:?}:\n{}", String::from_utf8_lossy(&bytes));
        let header = header.clone();
        guarded(&input, move || {
            let folder = CaseFolder::new("journal");
            let path = folder.0.join(JOURNAL_FILE);
            std::fs::write(&path, &bytes).unwrap();
            let read = journal::read(&folder.0);
            let resumed = Journal::resume(&folder.0, &header).map(|(_, finished)| finished);
            for result in [
                &read.as_ref().map(|(_, f)| f.clone()),
                &resumed.as_ref().cloned(),
            ] {
                match result {
                    Ok(finished) if finished.iter().any(|&case| case >= header.cases) => {
                        return Err(format!("accepted cases beyond the study's: {finished:?}"));
                    }
                    Err(error) if !error.to_string().contains(JOURNAL_FILE) => {
                        return Err(format!("an error that does not name the journal: {error}"));
                    }
                    _ => {}
                }
            }
            Ok(if resumed.is_ok() {
                Outcome::Accepted
            } else {
                Outcome::Refused
            })
        })
    });
}
