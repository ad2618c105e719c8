//! Estimators as programs (the plug-in protocol, docs/plugins.md): the two
//! example plug-ins in examples/plugins give aeroid's own equation-error
//! numbers on the same record, and every way a plug-in can go wrong — past
//! its time limit, a non-zero exit, invalid JSON, a NaN, an unknown or a
//! missing parameter, no result at all — is an error with its reason in
//! `estimate` and a counted failure in a study, never an abort. A plug-in
//! never sees the truth.

use crate::common;
use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::plugin::Plugin;
use aeroid::estimation::registry::Registry;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/plugins")
}

/// The ATTAS lateral multistep recorded by the 25 Hz flight-test profile.
fn record() -> FlightRecord {
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    record_scenario(&scenario, &profile).unwrap().0
}

/// The built-in estimators and the plug-ins this file's tests added.
fn plugins() -> &'static std::sync::Mutex<Registry> {
    static REGISTRY: std::sync::OnceLock<std::sync::Mutex<Registry>> = std::sync::OnceLock::new();
    REGISTRY.get_or_init(|| std::sync::Mutex::new(Registry::built_in()))
}

/// The registry as it stands, the plug-ins added so far among its methods.
fn registry() -> Registry {
    plugins().lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// Adds a plug-in file to this file's registry (once) and names it.
fn registered(path: &Path) -> String {
    let plugin = Plugin::load(path).unwrap();
    let name = aeroid::estimation::estimator::Estimator::name(&plugin).to_string();
    let mut registry = plugins().lock().unwrap_or_else(|e| e.into_inner());
    if registry.find(&name).is_err() {
        registry.add(Arc::new(plugin)).unwrap();
    }
    name
}

fn estimate(
    method: &str,
    record: &FlightRecord,
    structure: &ModelStructure,
) -> aeroid::estimation::Result<Estimate> {
    let registry = registry();
    let problem = registry.problem(method, vec![record.clone()], structure.clone(), &[])?;
    registry.estimate(&problem, None)
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-12)
}

/// The Python example implements equation error's regression: on the
/// side force (no differentiation) it gives the same numbers to 1e-9
/// (the same sums in another order: rounding ~1e-13); on the moments it
/// differentiates with NumPy's central differences instead of aeroid's
/// differentiator (both leaving out the samples at control steps): two
/// estimates from the same noisy data through different noise filters,
/// measured within 2.3 of aeroid's standard errors, asserted within 3.
#[test]
fn python_least_squares_matches_equation_error() {
    let numpy = std::process::Command::new("python3")
        .args(["-c", "import numpy"])
        .status()
        .is_ok_and(|s| s.success());
    if !numpy {
        println!("SKIPPED: python3 with NumPy is not installed (pip install numpy)");
        return;
    }
    let name = registered(&examples().join("least-squares.toml"));
    let record = record();
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let theirs = estimate(&name, &record, &structure).unwrap();
    let ours = estimate("ee", &record, &structure).unwrap();
    assert_eq!(theirs.status.to_string(), "converged", "{:?}", theirs.notes);
    for p in &theirs.parameters {
        let own = ours.parameter(&p.name).unwrap();
        if p.name.starts_with("CY_") {
            assert!(
                relative(p.value, own.value) < 1e-9,
                "{}: {} vs {}",
                p.name,
                p.value,
                own.value
            );
        } else {
            let gap = (p.value - own.value).abs() / own.standard_error;
            assert!(
                gap < 3.0,
                "{}: {} vs {} ({gap:.2} σ)",
                p.name,
                p.value,
                own.value
            );
        }
    }
}

/// A model with only CY_beta free (the others held at the truth).
fn cy_beta_model(folder: &Path) -> ModelStructure {
    let truth = aeroid::sim::aircraft::Aircraft::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("aircraft/attas.toml"),
    )
    .unwrap();
    let value = |name: &str| truth.aero.parameters.get(name).unwrap();
    let mut text = String::from(
        "name = \"attas-cy-beta\"\naircraft = \"attas\"\nintegrate = [\"beta\", \"p\", \"r\", \"roll\"]\noutputs = [\"beta\", \"p\", \"r\", \"roll\", \"ny\"]\n[aero]\nmodel = \"linear\"\nforce_axes = \"wind\"\nrate_normalization = \"2V\"\nrate_speed = \"airspeed\"\n",
    );
    for coefficient in ["CY", "Cl", "Cn"] {
        text += &format!("[aero.{coefficient}]\n");
        for term in ["0", "beta", "p", "r", "da", "dr"] {
            let name = format!("{coefficient}_{term}");
            let start = if name == "CY_beta" {
                -0.8
            } else {
                value(&name)
            };
            text += &format!("{term} = {start}\n");
        }
    }
    for coefficient in ["CY", "Cl", "Cn"] {
        for term in ["0", "beta", "p", "r", "da", "dr"] {
            let name = format!("{coefficient}_{term}");
            if name != "CY_beta" {
                text += &format!("[parameters.{name}]\nfixed = true\n");
            } else {
                text += "[parameters.CY_beta]\nlower = -5.0\nupper = 5.0\n";
            }
        }
    }
    let path = common::write(folder, "attas-cy-beta.toml", &text);
    ModelStructure::load(path.to_str().unwrap()).unwrap()
}

/// The shell-and-awk example fits CY_beta with the other terms held: the
/// regression equation error makes on the same model, to 1e-9 (awk's
/// doubles, printed with 17 digits).
#[test]
fn shell_and_awk_example_matches_equation_error() {
    let name = registered(&examples().join("side-force.toml"));
    let folder = common::temp_folder("plugin_awk");
    let structure = cy_beta_model(&folder);
    let record = record();
    let theirs = estimate(&name, &record, &structure).unwrap();
    let ours = estimate("ee", &record, &structure).unwrap();
    let (a, b) = (
        theirs.parameter("CY_beta").unwrap(),
        ours.parameter("CY_beta").unwrap(),
    );
    assert!(
        relative(a.value, b.value) < 1e-9,
        "{} vs {}",
        a.value,
        b.value
    );
    // On the full model it refuses, saying why.
    let full = ModelStructure::load("attas-lateral").unwrap();
    let error = estimate(&name, &record, &full).unwrap_err();
    assert!(error.refusal().is_some(), "{error}");
    assert!(error.to_string().contains("CY_beta alone"), "{error}");
}

/// A plug-in written as a shell one-liner in `folder`.
fn fault(folder: &Path, name: &str, script: &str, limit: &str) -> String {
    common::write(folder, &format!("{name}.sh"), script);
    let path = common::write(
        folder,
        &format!("{name}.toml"),
        &format!("command = [\"sh\", \"{name}.sh\"]\ntime_limit = \"{limit}\"\n"),
    );
    registered(&path)
}

#[test]
fn every_fault_is_an_error_with_its_reason_and_a_counted_failure() {
    let folder = common::temp_folder("plugin_faults");
    let good = |value: &str| {
        format!(
            "cat > \"$1/estimate.json\" <<'END'\n{{\"format\": \"aeroid-plugin-estimate-1\", \"status\": \"converged\", \"parameters\": [{{\"name\": \"CY_beta\", \"value\": {value}, \"standard_error\": 0.01}}]}}\nEND\n"
        )
    };
    let cases = [
        (
            "fault-sleep",
            "sleep 30\n".to_string(),
            "0.5 s",
            "time limit",
        ),
        (
            "fault-exit",
            "echo broken >&2; exit 3\n".to_string(),
            "10 s",
            "exited with status 3",
        ),
        (
            "fault-json",
            "echo '{not json' > \"$1/estimate.json\"\n".to_string(),
            "10 s",
            "estimate.json",
        ),
        ("fault-nan", good("NaN"), "10 s", "estimate.json"),
        (
            "fault-fifo",
            "mkfifo \"$1/estimate.json\"\n".to_string(),
            "10 s",
            "not a plain file",
        ),
        (
            "fault-zero",
            "ln -s /dev/zero \"$1/estimate.json\"\n".to_string(),
            "10 s",
            "not a plain file",
        ),
        (
            "fault-stderr",
            "head -c 20000000 /dev/zero | tr '\\0' x >&2; exit 3\n".to_string(),
            "10 s",
            "exited with status 3",
        ),
        (
            "fault-bounds",
            good("7.0"),
            "10 s",
            "outside the model's bounds [-5, 5]",
        ),
        (
            "fault-variance",
            good("-0.9").replace(
                "\"standard_error\": 0.01}]",
                "\"standard_error\": 0.01}], \"covariance\": [[-0.0001]]",
            ),
            "10 s",
            "a variance must not be negative",
        ),
        (
            "fault-unknown",
            good("-0.9").replace("CY_beta", "CY_gamma"),
            "10 s",
            "'CY_gamma' is not a free parameter",
        ),
        (
            "fault-nothing",
            "true\n".to_string(),
            "10 s",
            "wrote neither",
        ),
        (
            "fault-truth",
            format!(
                "test ! -e \"$1/record-0/truth.toml\" || exit 9\n{}",
                good("-0.9")
            ),
            "10 s",
            "",
        ),
    ];
    let structure = cy_beta_model(&folder);
    let record = record();
    for (name, script, limit, reason) in &cases {
        let method = fault(&folder, name, script, limit);
        let started = std::time::Instant::now();
        let result = estimate(&method, &record, &structure);
        if reason.is_empty() {
            // The truth is not in the work folder: the plug-in succeeds.
            let estimate = result.unwrap();
            assert_eq!(estimate.parameter("CY_beta").unwrap().value, -0.9);
            continue;
        }
        let error = result.unwrap_err().to_string();
        assert!(error.contains(reason), "{name}: {error}");
        assert!(
            error.contains(name),
            "{name}: the plug-in is not named: {error}"
        );
        if *name == "fault-exit" {
            assert!(error.contains("broken"), "stderr is not shown: {error}");
        }
        if *name == "fault-sleep" {
            assert!(
                started.elapsed().as_secs_f64() < 5.0,
                "not killed at its limit"
            );
        }
    }
    // In a study each is a counted failure, the study goes on.
    let study_text = "name = \"faults\"\nscenarios = [\"attas-lateral-multistep\"]\nprofile = \"flight-test-25hz\"\nmodels = [\"attas-cy-beta.toml\"]\nmethods = [\"fault-exit\", \"fault-truth\"]\nruns = 2\nseed = 3\n";
    let path = common::write(&folder, "faults.toml", study_text);
    let study = aeroid::eval::study::Study::load(&registry(), path.to_str().unwrap()).unwrap();
    let result = study.run(2, &|_| {}).unwrap();
    let count = |status: aeroid::eval::row::RowStatus| {
        result
            .endings
            .iter()
            .find(|e| e.status == status)
            .map_or(0, |e| e.count)
    };
    assert_eq!(
        (
            count(aeroid::eval::row::RowStatus::Failed),
            count(aeroid::eval::row::RowStatus::Converged)
        ),
        (2, 2),
        "{:?}",
        result.endings
    );
}

/// A plug-in may write only in its work folder where the platform allows
/// (Linux with Landlock): a script that writes a file in its own working
/// directory, another in the system's temporary folder (where the work
/// folders are made) and one in a folder of the user's, then answers,
/// leaves no file behind and
/// its answer counts; with `sandbox = false` the same script leaves all
/// three. Where Landlock is missing the test says so and checks the note
/// that tells the user.
#[test]
fn a_plugin_writes_only_in_its_work_folder() {
    let folder = common::temp_folder("plugin_sandbox");
    let outside = common::temp_folder("plugin_sandbox_outside");
    let targets = [
        folder.join("escaped.txt"),
        outside.join("escaped.txt"),
        std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("aeroid-escaped-{}.txt", std::process::id())),
    ];
    let mut script = String::new();
    for target in &targets {
        script += &format!("echo escaped > '{}' 2>/dev/null\n", target.display());
    }
    script += "cat > \"$1/estimate.json\" <<'END'\n{\"format\": \"aeroid-plugin-estimate-1\", \"status\": \"converged\", \"parameters\": [{\"name\": \"CY_beta\", \"value\": -0.9, \"standard_error\": 0.01}]}\nEND\n";
    common::write(&folder, "escape.sh", &script);
    let structure = cy_beta_model(&folder);
    let record = record();
    for sandbox in [true, false] {
        let name = if sandbox { "escape" } else { "escape-open" };
        let path = common::write(
            &folder,
            &format!("{name}.toml"),
            &format!("command = [\"sh\", \"escape.sh\"]\nsandbox = {sandbox}\n"),
        );
        let method = registered(&path);
        let estimate = estimate(&method, &record, &structure).unwrap();
        assert_eq!(estimate.parameter("CY_beta").unwrap().value, -0.9);
        let unsandboxed = estimate
            .notes
            .iter()
            .find(|n| n.starts_with("not sandboxed"));
        let escaped: Vec<&PathBuf> = targets.iter().filter(|t| t.exists()).collect();
        if !sandbox {
            assert_eq!(escaped.len(), 3, "without the sandbox every write lands");
            assert!(unsandboxed.is_none(), "{:?}", estimate.notes);
        } else if let Some(note) = unsandboxed {
            println!("SKIPPED: {note}");
            for target in &targets {
                let _ = std::fs::remove_file(target);
            }
        } else {
            assert!(escaped.is_empty(), "the plug-in wrote {escaped:?}");
        }
    }
    for target in &targets {
        let _ = std::fs::remove_file(target);
    }
}

/// A study with a plug-in among its methods is deterministic and resumable
/// like any other: one thread, or two threads after an interruption that
/// kept one case, write the same bytes.
#[test]
fn a_study_with_a_plugin_is_deterministic_and_resumable() {
    use aeroid::eval::journal::{JOURNAL_FILE, Shard};
    use aeroid::eval::study::{Study, assemble};
    let name = registered(&examples().join("side-force.toml"));
    let folder = common::temp_folder("plugin_study");
    cy_beta_model(&folder);
    let text = format!(
        "name = \"with-plugin\"\nscenarios = [\"attas-lateral-multistep\"]\nprofile = \"flight-test-25hz\"\nmodels = [\"attas-cy-beta.toml\"]\nmethods = [\"ee\", \"{name}\"]\nruns = 3\nseed = 8\n"
    );
    let path = common::write(&folder, "with-plugin.toml", &text);
    let study = Study::load(&registry(), path.to_str().unwrap()).unwrap();
    let written = |out: &Path| {
        ["runs.csv", "summary.csv", "study.json"].map(|file| std::fs::read(out.join(file)).unwrap())
    };
    let one = folder.join("one");
    study
        .run_journaled(&one, Shard::default(), false, 1, &|_| {})
        .unwrap();
    let result = assemble(std::slice::from_ref(&one), &one).unwrap();
    assert!(
        result
            .summary
            .iter()
            .any(|s| s.method == name && s.converged == 3),
        "{}{:?}",
        result.table(),
        result.endings
    );
    let resumed = folder.join("resumed");
    study
        .run_journaled(&resumed, Shard::default(), false, 2, &|_| {})
        .unwrap();
    let journal = resumed.join(JOURNAL_FILE);
    let kept: Vec<String> = std::fs::read_to_string(&journal)
        .unwrap()
        .lines()
        .take(2)
        .map(String::from)
        .collect();
    std::fs::write(&journal, kept.join("\n") + "\n").unwrap();
    let run = study
        .run_journaled(&resumed, Shard::default(), true, 2, &|_| {})
        .unwrap();
    assert_eq!((run.resumed, run.ran), (1, 2));
    assemble(std::slice::from_ref(&resumed), &resumed).unwrap();
    assert_eq!(written(&resumed), written(&one));
}

/// A time limit no clock can count (1e300 s), or zero, is a clear error
/// naming the file and the key when the plug-in is loaded, never a panic
/// when it runs; a week is the longest a plug-in may set.
#[test]
fn a_time_limit_beyond_a_week_or_not_positive_is_refused_at_load() {
    let folder = common::temp_folder("plugin_time_limit");
    for limit in ["1e300 s", "0 s", "-5 s", "604801 s"] {
        let path = common::write(
            &folder,
            "limited.toml",
            &format!("command = [\"sh\", \"limited.sh\"]\ntime_limit = \"{limit}\"\n"),
        );
        let error = Plugin::load(&path).unwrap_err().to_string();
        assert!(
            error.contains("limited.toml") && error.contains("time_limit"),
            "{limit}: {error}"
        );
    }
    let path = common::write(
        &folder,
        "limited.toml",
        "command = [\"sh\", \"limited.sh\"]\ntime_limit = \"604800 s\"\n",
    );
    Plugin::load(&path).unwrap();
}

/// A plug-in that leaves a process running outside its process group
/// (`setsid`, the way a daemon detaches) has it ended when its run ends,
/// at the time limit as when it answers; the estimate says so. Linux
/// only: elsewhere the process group alone is ended (docs/plugins.md).
#[cfg(target_os = "linux")]
#[test]
fn processes_a_plugin_detaches_are_ended_with_its_run() {
    let folder = common::temp_folder("plugin_detached");
    let structure = cy_beta_model(&folder);
    let record = record();
    let alive = |pid: u32| {
        std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
            stat.rsplit(") ")
                .next()
                .is_some_and(|rest| !rest.starts_with('Z'))
        })
    };
    let answer = "cat > \"$1/estimate.json\" <<'END'\n{\"format\": \"aeroid-plugin-estimate-1\", \"status\": \"converged\", \"parameters\": [{\"name\": \"CY_beta\", \"value\": -0.9, \"standard_error\": 0.01}]}\nEND\n";
    // The detached process writes its pid to the plug-in's stderr, whose
    // end aeroid reports (the sandbox lets nothing be written elsewhere).
    for (name, tail, limit) in [
        ("detach-answer", answer, "20 s"),
        ("detach-hang", "sleep 30\n", "1 s"),
    ] {
        let script = format!(
            "setsid sh -c 'echo \"detached=$$\" >&2; exec sleep 300' &\nwhile ! grep -q detached= \"$1/stderr.txt\"; do sleep 0.05; done\n{tail}"
        );
        let method = fault(&folder, name, &script, limit);
        let said = match estimate(&method, &record, &structure) {
            Ok(estimate) => estimate.notes.join("; "),
            Err(error) => error.to_string(),
        };
        let pid: u32 = said
            .split("detached=")
            .nth(1)
            .and_then(|rest| rest.split(|c: char| !c.is_ascii_digit()).next())
            .and_then(|digits| digits.parse().ok())
            .unwrap_or_else(|| panic!("{name}: no pid in {said}"));
        // SIGKILL is delivered at once; give the kernel a moment to end it.
        let ended = (0..50).any(|_| {
            std::thread::sleep(std::time::Duration::from_millis(20));
            !alive(pid)
        });
        assert!(ended, "{name}: the detached process {pid} is still running");
        assert!(
            said.contains("1 process(es) the plug-in left running"),
            "{name}: {said}"
        );
    }
}
