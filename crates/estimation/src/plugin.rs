//! Estimators in any language, run as programs beside aeroid's own (the
//! plug-in protocol; docs/plugins.md). A plug-in is a file,
//! `estimators/NAME.toml` in the data folder or in a folder of
//! `AEROID_ESTIMATORS`:
//!
//! ```toml
//! description = "least squares in NumPy"
//! command = ["python3", "least_squares.py"]   # the work folder is appended
//! working_directory = "."                     # relative to this file (default: its folder)
//! time_limit = "60 s"
//! records = "one"                             # or "many": several manoeuvres at once
//! record_folders = true                       # also write each record as a record folder
//! settings = ["ridge"]                        # the [methods.NAME] keys it takes (default: any)
//! [environment]
//! OMP_NUM_THREADS = "1"
//! ```
//!
//! For each estimate aeroid makes a fresh work folder holding
//! `problem.json` (the [`EstimationProblem`], every record inside it) and
//! `record-K/` (each record in the record-folder format, without its truth;
//! unless `record_folders = false`),
//! runs the command with the work folder as its last argument (its own
//! process group; stdout and stderr to files in the work folder; `TMPDIR`
//! the work folder), and reads back `estimate.json` or `refusal.json`
//! ([`ESTIMATE_SCHEMA`], [`REFUSAL_SCHEMA`]). What comes back is checked:
//! the format tag, every field's type, every free parameter once and no
//! other, finite values, non-negative standard errors, a square covariance
//! of the parameters' size. A plug-in past its time limit is killed with its
//! whole process group, and when a run ends every process it left running
//! is ended, those that left the group too (module `processes`); a non-zero exit, a crash, a missing or malformed
//! result is an error naming the plug-in and the reason, with the end of
//! its stderr — in a study a counted failure, never an abort. The work
//! folder is removed afterwards.

use crate::error::{Error, Result};
use crate::estimate::{Estimate, ParameterEstimate, Status};
use crate::estimator::{Capabilities, Estimator, MethodInfo, Refusal, SettingInfo, Settings};
use crate::problem::EstimationProblem;
use crate::sandbox::Sandbox;
use crate::structure::Structure;
use aeroid_core::error::{read_text, write_error};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

mod processes;

/// The folder of plug-in files inside the data folder.
pub(crate) const PLUGIN_FOLDER: &str = "estimators";
/// Extra folders of plug-in files, separated by ':'.
pub(crate) const PLUGIN_VARIABLE: &str = "AEROID_ESTIMATORS";
/// The format tag of a plug-in's estimate.
pub(crate) const ESTIMATE_FORMAT: &str = "aeroid-plugin-estimate-1";

/// JSON Schema of `estimate.json`.
pub const ESTIMATE_SCHEMA: &str = r#"{
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "aeroid plug-in estimate (estimate.json)",
  "type": "object",
  "additionalProperties": false,
  "required": ["format", "status", "parameters"],
  "properties": {
    "format": { "const": "aeroid-plugin-estimate-1" },
    "status": { "enum": ["converged", "iteration_limit", "diverged", "no_progress"] },
    "reason": { "type": "string", "description": "why it diverged or made no progress" },
    "parameters": {
      "type": "array",
      "description": "every free parameter of problem.json, once",
      "items": {
        "type": "object",
        "additionalProperties": false,
        "required": ["name", "value", "standard_error"],
        "properties": {
          "name": { "type": "string" },
          "value": { "type": "number" },
          "standard_error": {
            "description": "Cramér–Rao bound, ≥ 0; the string \"inf\" when not determined",
            "oneOf": [ { "type": "number", "minimum": 0 }, { "const": "inf" } ]
          }
        }
      }
    },
    "covariance": {
      "description": "optional, in the order of parameters; default diag(standard_error²)",
      "type": "array", "items": { "type": "array", "items": { "type": "number" } }
    },
    "iterations": { "type": "integer", "minimum": 0 },
    "notes": { "type": "array", "items": { "type": "string" } }
  }
}
"#;

/// JSON Schema of `refusal.json` (the [`Refusal`] aeroid's own methods give).
pub const REFUSAL_SCHEMA: &str = r#"{
  "$schema": "https://json-schema.org/draft/2020-12/schema",
  "title": "aeroid plug-in refusal (refusal.json)",
  "type": "object",
  "required": ["kind", "method"],
  "oneOf": [
    { "properties": { "kind": { "const": "missing-channels" }, "method": { "type": "string" },
        "channels": { "type": "array", "items": { "type": "object", "required": ["name", "purpose"],
          "properties": { "name": { "type": "string" }, "purpose": { "type": "string" } }, "additionalProperties": false } },
        "present": { "type": "array", "items": { "type": "string" } } },
      "required": ["channels", "present"], "additionalProperties": false },
    { "properties": { "kind": { "const": "not-linear-in-parameters" }, "method": { "type": "string" },
        "model": { "type": "string" }, "model_kind": { "type": "string" } },
      "required": ["model", "model_kind"], "additionalProperties": false },
    { "properties": { "kind": { "const": "nothing-to-estimate" }, "method": { "type": "string" },
        "model": { "type": "string" } },
      "required": ["model"], "additionalProperties": false },
    { "properties": { "kind": { "const": "too-few-data" }, "method": { "type": "string" },
        "data": { "type": "integer" }, "unknowns": { "type": "integer" } },
      "required": ["data", "unknowns"], "additionalProperties": false },
    { "properties": { "kind": { "const": "unsuitable-model" }, "method": { "type": "string" },
        "model": { "type": "string" }, "reason": { "type": "string" } },
      "required": ["model", "reason"], "additionalProperties": false }
  ]
}
"#;

/// How many records a plug-in takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Records {
    #[default]
    One,
    Many,
}

/// A plug-in file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PluginFile {
    /// Default: the file's stem.
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub description: String,
    /// Where the method comes from, shown by `aeroid methods`.
    #[serde(default)]
    pub paper: String,
    pub command: Vec<String>,
    #[serde(default)]
    pub working_directory: Option<PathBuf>,
    #[serde(
        default = "default_time_limit",
        deserialize_with = "aeroid_core::units::seconds"
    )]
    pub time_limit: f64,
    #[serde(default)]
    pub records: Records,
    /// The `[methods.NAME]` keys it takes; None: any.
    #[serde(default)]
    pub settings: Option<Vec<String>>,
    #[serde(default)]
    pub environment: BTreeMap<String, String>,
    /// Whether the records are also written as record folders (a plug-in
    /// that reads only problem.json saves the time).
    #[serde(default = "yes")]
    pub record_folders: bool,
    /// Whether the plug-in may write only in its work folder, where the
    /// platform allows ([`crate::sandbox`]).
    #[serde(default = "yes")]
    pub sandbox: bool,
}

fn yes() -> bool {
    true
}

/// The longest time limit a plug-in may set (a week, in seconds): a
/// longer one is a typo, and beyond about 1.8e19 s no clock can count it.
pub(crate) const MAX_TIME_LIMIT: f64 = 7.0 * 24.0 * 3600.0;

fn default_time_limit() -> f64 {
    60.0
}

/// A plug-in estimator.
#[derive(Debug, Clone)]
pub struct Plugin {
    name: &'static str,
    description: &'static str,
    paper: &'static str,
    path: PathBuf,
    command: Vec<String>,
    working_directory: PathBuf,
    time_limit: f64,
    records: Records,
    settings: Option<Vec<String>>,
    environment: BTreeMap<String, String>,
    record_folders: bool,
    sandbox: bool,
}

impl Plugin {
    /// Reads and checks a plug-in file.
    pub fn load(path: &Path) -> Result<Plugin> {
        let file: PluginFile = aeroid_core::error::parse_toml(path, &read_text(path)?)?;
        let invalid = |field: &str, message: String| aeroid_core::Error::Invalid {
            path: path.to_path_buf(),
            problems: vec![aeroid_core::error::FieldError {
                field: field.into(),
                message,
            }],
        };
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let name = file.name.clone().unwrap_or(stem);
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(invalid(
                "name",
                format!("'{name}': a method name is letters, digits, '-' and '_'"),
            )
            .into());
        }
        if file.command.is_empty() || file.command[0].trim().is_empty() {
            return Err(invalid("command", "must name a program".into()).into());
        }
        if !(file.time_limit > 0.0 && file.time_limit <= MAX_TIME_LIMIT) {
            return Err(invalid(
                "time_limit",
                format!(
                    "{} s: must be positive and at most {MAX_TIME_LIMIT} s (a week)",
                    file.time_limit
                ),
            )
            .into());
        }
        let base = path.parent().unwrap_or(Path::new("."));
        let working_directory = match &file.working_directory {
            Some(dir) if dir.is_absolute() => dir.clone(),
            Some(dir) => base.join(dir),
            None => base.to_path_buf(),
        };
        if !working_directory.is_dir() {
            return Err(invalid(
                "working_directory",
                format!("{} is not a folder", working_directory.display()),
            )
            .into());
        }
        let leak = |text: String| -> &'static str { Box::leak(text.into_boxed_str()) };
        Ok(Plugin {
            name: leak(name),
            description: leak(if file.description.is_empty() {
                format!("plug-in {}", path.display())
            } else {
                file.description
            }),
            paper: leak(if file.paper.is_empty() {
                "(the plug-in's own)".into()
            } else {
                file.paper
            }),
            path: path.to_path_buf(),
            command: file.command,
            working_directory,
            time_limit: file.time_limit,
            records: file.records,
            settings: file.settings,
            environment: file.environment,
            record_folders: file.record_folders,
            sandbox: file.sandbox,
        })
    }

    /// The plug-in file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Runs the plug-in on `problem` in a fresh work folder (module header).
    fn run(&self, problem: &EstimationProblem) -> Result<Estimate> {
        let started = Instant::now();
        let work = WorkFolder::new(self.name)?;
        problem.write_json(&work.path.join("problem.json"))?;
        if self.record_folders {
            for (k, record) in problem.records.iter().enumerate() {
                let folder = work.path.join(format!("record-{k}"));
                if record.seed.is_some_and(|seed| i64::try_from(seed).is_err()) {
                    // record.toml holds TOML integers; a study's recorder
                    // seed may exceed them (problem.json keeps it).
                    let mut copy = record.clone();
                    copy.seed = None;
                    copy.write(&folder)?;
                } else {
                    record.write(&folder)?;
                }
            }
        }
        let sandbox = self.sandbox.then(|| Sandbox::for_work_folder(&work.path));
        let unsandboxed = match &sandbox {
            Some(Sandbox::Unavailable(reason)) => Some(format!(
                "not sandboxed: {reason}; the plug-in could write outside its work folder"
            )),
            _ => None,
        };
        let outcome = self.execute(&work.path, sandbox);
        let left = processes::end_run(&run_of(&work.path));
        let outcome = outcome?;
        let left_note = (left > 0).then(|| {
            format!("{left} process(es) the plug-in left running (outside its process group) ended")
        });
        let stderr = tail(&work.path.join("stderr.txt"));
        let failure = |reason: String| Error::Plugin {
            reason: format!(
                "plug-in {}: {reason}{}{}",
                self.name,
                left_note
                    .as_ref()
                    .map_or(String::new(), |note| format!("; {note}")),
                if stderr.is_empty() {
                    String::new()
                } else {
                    format!("; its stderr ends: {stderr}")
                }
            ),
        };
        match outcome {
            Outcome::TimedOut => {
                return Err(failure(format!(
                    "still running after its time limit of {} s: killed",
                    self.time_limit
                )));
            }
            Outcome::Exited(Some(0)) => {}
            Outcome::Exited(Some(code)) => {
                return Err(failure(format!("exited with status {code}")));
            }
            Outcome::Exited(None) => return Err(failure("killed by a signal".into())),
        }
        let refusal_path = work.path.join("refusal.json");
        if refusal_path.symlink_metadata().is_ok() {
            let text =
                read_written(&refusal_path).map_err(|e| failure(format!("refusal.json: {e}")))?;
            let refusal: Refusal =
                serde_json::from_str(&text).map_err(|e| failure(format!("refusal.json: {e}")))?;
            return Err(Error::Refused(refusal));
        }
        let estimate_path = work.path.join("estimate.json");
        if estimate_path.symlink_metadata().is_err() {
            return Err(failure(
                "wrote neither estimate.json nor refusal.json in the work folder".into(),
            ));
        }
        let text =
            read_written(&estimate_path).map_err(|e| failure(format!("estimate.json: {e}")))?;
        let mut estimate = self
            .estimate_from(problem, &text)
            .map_err(|reason| failure(format!("estimate.json: {reason}")))?;
        if !stderr.is_empty() {
            estimate.notes.push(format!("plug-in stderr: {stderr}"));
        }
        estimate.notes.extend(unsandboxed);
        estimate.notes.extend(left_note);
        estimate.wall_time = started.elapsed().as_secs_f64();
        Ok(estimate)
    }

    /// Runs the command, in the sandbox when there is one, killing its
    /// process group at the time limit.
    fn execute(&self, work: &Path, sandbox: Option<Sandbox>) -> Result<Outcome> {
        use std::os::unix::process::CommandExt;
        let output = |name: &str| {
            let path = work.join(name);
            std::fs::File::create(&path).map_err(|e| write_error(&path, e))
        };
        let mut command = Command::new(&self.command[0]);
        command
            .args(&self.command[1..])
            .arg(work)
            .current_dir(&self.working_directory)
            .envs(&self.environment)
            .env("TMPDIR", work)
            .env(processes::MARKER, run_of(work))
            .stdin(Stdio::null())
            .stdout(output("stdout.txt")?)
            .stderr(output("stderr.txt")?)
            .process_group(0);
        let rules = match sandbox {
            Some(Sandbox::Landlock(rules)) => Some(rules),
            _ => None,
        };
        // SAFETY: `die_with_parent` and `enter` make system calls only (no
        // allocation, no lock), as the time between fork and exec requires.
        unsafe {
            command.pre_exec(move || {
                processes::die_with_parent()?;
                match &rules {
                    Some(rules) => rules.enter(),
                    None => Ok(()),
                }
            });
        }
        let mut child = command.spawn().map_err(|e| Error::Plugin {
            reason: format!(
                "plug-in {}: cannot start '{}' (from {}): {e}",
                self.name,
                self.command[0],
                self.path.display()
            ),
        })?;
        // A thread blocks in wait() and reports the exit at once; this one
        // waits for that report until the time limit.
        let group = libc::pid_t::try_from(child.id()).ok();
        let (sender, receiver) = std::sync::mpsc::channel();
        let waiter = std::thread::Builder::new()
            .name(format!("plug-in {}", self.name))
            .spawn(move || {
                let status = child.wait();
                let _ = sender.send(());
                status
            })
            .map_err(|e| {
                kill_group(group);
                Error::Plugin {
                    reason: format!(
                        "plug-in {}: no thread to wait for it ({e}): killed",
                        self.name
                    ),
                }
            })?;
        let limit = Duration::from_secs_f64(self.time_limit);
        let timed_out = matches!(
            receiver.recv_timeout(limit),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout)
        );
        if timed_out {
            // The whole process group (a shell's children too), by the
            // system call: the group is the child's own (process_group(0)
            // above), never aeroid's. Had the child ended in the instant
            // between, the signal finds at most its leftover children.
            kill_group(group);
        }
        let status = waiter.join().map_err(|_| Error::Plugin {
            reason: format!("plug-in {}: the thread waiting for it failed", self.name),
        })?;
        match status {
            _ if timed_out => Ok(Outcome::TimedOut),
            Ok(status) => Ok(Outcome::Exited(status.code())),
            Err(e) => Err(Error::Plugin {
                reason: format!("plug-in {}: waiting for it: {e}", self.name),
            }),
        }
    }

    /// The estimate a plug-in wrote, checked against the problem.
    fn estimate_from(
        &self,
        problem: &EstimationProblem,
        text: &str,
    ) -> std::result::Result<Estimate, WrittenError> {
        let written: Written = serde_json::from_str(text)?;
        if written.format != ESTIMATE_FORMAT {
            return Err(WrittenError::Format(written.format));
        }
        let structure = &problem.structure;
        let parameters = written_parameters(structure, &written.parameters)?;
        let covariance = match written.covariance {
            Some(covariance) => checked_covariance(covariance, parameters.len())?,
            None => crate::estimate::diagonal_covariance(
                &parameters
                    .iter()
                    .map(|p| p.standard_error)
                    .collect::<Vec<_>>(),
            ),
        };
        let reason = written.reason.unwrap_or_default();
        let status = match written.status.as_str() {
            "converged" => Status::Converged,
            "iteration_limit" => Status::IterationLimit,
            "diverged" => Status::Diverged(reason),
            "no_progress" => Status::NoProgress,
            other => {
                return Err(WrittenError::Status(other.to_string()));
            }
        };
        Ok(Estimate {
            method: self.name.to_string(),
            model: structure.name().to_string(),
            record: problem
                .records
                .iter()
                .map(|r| r.scenario.as_str())
                .collect::<Vec<_>>()
                .join(" + "),
            diagnoses: Vec::new(),
            status,
            parameters,
            covariance,
            fits: Vec::new(),
            iterations: written.iterations.unwrap_or(0),
            cost_history: Vec::new(),
            wall_time: 0.0,
            notes: written.notes,
            details: String::new(),
            network: None,
            distributions: Vec::new(),
            histories: Vec::new(),
        })
    }
}

/// The written parameters checked against the model: each free, named
/// once, finite, with a standard error ≥ 0 and inside its bounds, and
/// every free parameter there.
fn written_parameters(
    structure: &Structure,
    written: &[WrittenParameter],
) -> std::result::Result<Vec<ParameterEstimate>, WrittenError> {
    let free_names = structure.free_names();
    let free: Vec<&str> = free_names.iter().map(String::as_str).collect();
    let (names, values) = structure.parameters();
    let mut parameters = Vec::with_capacity(free.len());
    for (i, p) in written.iter().enumerate() {
        let name = || p.name.clone();
        if !free.contains(&p.name.as_str()) {
            return Err(WrittenError::NotFree {
                index: i,
                name: name(),
                model: structure.name().to_string(),
                free: free.join(", "),
            });
        }
        if written[..i].iter().any(|q| q.name == p.name) {
            return Err(WrittenError::Twice {
                index: i,
                name: name(),
            });
        }
        if !p.value.is_finite() {
            return Err(WrittenError::Value {
                index: i,
                name: name(),
            });
        }
        if p.standard_error.is_nan() || p.standard_error < 0.0 {
            return Err(WrittenError::StandardError {
                index: i,
                name: name(),
            });
        }
        let position = names.iter().position(|n| n == &p.name);
        if let Some((low, high)) = position.map(|j| structure.bounds()[j])
            && !(low..=high).contains(&p.value)
        {
            return Err(WrittenError::Bounds {
                index: i,
                name: name(),
                value: p.value,
                low,
                high,
            });
        }
        parameters.push(ParameterEstimate {
            name: name(),
            value: p.value,
            standard_error: p.standard_error,
            start: position.map_or(f64::NAN, |j| values[j]),
        });
    }
    let missing: Vec<&str> = free
        .iter()
        .filter(|n| !written.iter().any(|p| p.name == **n))
        .copied()
        .collect();
    if !missing.is_empty() {
        return Err(WrittenError::Missing(missing.join(", ")));
    }
    Ok(parameters)
}

/// A written covariance of `n` parameters checked: n × n, no NaN, no
/// negative variance, symmetric to the rounding of a printed number.
fn checked_covariance(
    covariance: Vec<Vec<f64>>,
    n: usize,
) -> std::result::Result<Vec<Vec<f64>>, WrittenError> {
    if covariance.len() != n || covariance.iter().any(|row| row.len() != n) {
        return Err(WrittenError::CovarianceShape(n));
    }
    if covariance.iter().flatten().any(|v| v.is_nan()) {
        return Err(WrittenError::CovarianceNan);
    }
    if let Some(i) = (0..n).find(|&i| covariance[i][i] < 0.0) {
        return Err(WrittenError::NegativeVariance {
            index: i,
            value: covariance[i][i],
        });
    }
    let asymmetric = |i: usize, j: usize| {
        let (a, b) = (covariance[i][j], covariance[j][i]);
        let scale = (covariance[i][i] * covariance[j][j]).sqrt().max(a.abs());
        (a - b).abs() > 1e-9 * scale && !(a.is_infinite() && a == b)
    };
    if let Some((i, j)) = (0..n)
        .flat_map(|i| (0..i).map(move |j| (i, j)))
        .find(|&(i, j)| asymmetric(i, j))
    {
        return Err(WrittenError::Asymmetric { row: i, column: j });
    }
    Ok(covariance)
}

/// Kills process group `group` (a plug-in's own group, never aeroid's:
/// groups 0 and 1 are left alone).
fn kill_group(group: Option<libc::pid_t>) {
    if let Some(group) = group.filter(|&g| g > 1) {
        // SAFETY: killpg only sends a signal; it touches no memory.
        unsafe {
            libc::killpg(group, libc::SIGKILL);
        }
    }
}

/// `estimate.json` as a plug-in writes it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Written {
    format: String,
    status: String,
    #[serde(default)]
    reason: Option<String>,
    parameters: Vec<WrittenParameter>,
    #[serde(default)]
    covariance: Option<Vec<Vec<f64>>>,
    #[serde(default)]
    iterations: Option<usize>,
    #[serde(default)]
    notes: Vec<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WrittenParameter {
    name: String,
    value: f64,
    #[serde(deserialize_with = "number_or_inf")]
    standard_error: f64,
}

fn number_or_inf<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Value {
        Number(f64),
        Text(String),
    }
    match Value::deserialize(d)? {
        Value::Number(v) => Ok(v),
        Value::Text(t) if t == "inf" => Ok(f64::INFINITY),
        Value::Text(t) => Err(serde::de::Error::custom(format!(
            "'{t}' is not a number (\"inf\" is the only text allowed)"
        ))),
    }
}

enum Outcome {
    Exited(Option<i32>),
    TimedOut,
}

/// A fresh folder under the system's temporary folder, removed on drop.
struct WorkFolder {
    path: PathBuf,
}

impl WorkFolder {
    fn new(plugin: &str) -> Result<WorkFolder> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let path = std::env::temp_dir().join(format!(
            "aeroid-plugin-{plugin}-{}-{}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&path).map_err(|e| write_error(&path, e))?;
        Ok(WorkFolder { path })
    }
}

/// The run whose work folder is `work`: the folder's name.
fn run_of(work: &Path) -> String {
    work.file_name()
        .map(|name| name.to_string_lossy().into_owned())
        .unwrap_or_default()
}

impl Drop for WorkFolder {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// The last 500 characters of a file, on one line (empty if none).
/// The most bytes of a plug-in's stderr that are read (its end).
const STDERR_TAIL: u64 = 64 * 1024;

/// The largest estimate.json or refusal.json a plug-in may write: a
/// thousand parameters with their covariance take about 20 MB.
const MAX_WRITTEN: u64 = 64 * 1024 * 1024;

/// A file a plug-in wrote, read if it is a plain file (not a link, FIFO
/// or device, which could block or never end) of at most [`MAX_WRITTEN`]
/// bytes.
fn read_written(path: &Path) -> std::result::Result<String, Unreadable> {
    use std::io::Read;
    if !std::fs::symlink_metadata(path)?.file_type().is_file() {
        return Err(Unreadable::NotPlain);
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_WRITTEN + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_WRITTEN {
        return Err(Unreadable::TooLarge);
    }
    String::from_utf8(bytes).map_err(|_| Unreadable::NotText)
}

/// Why a file a plug-in wrote is not read.
#[derive(Debug, thiserror::Error)]
enum Unreadable {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(
        "not a plain file (a link, FIFO or device): aeroid reads only files the plug-in writes"
    )]
    NotPlain,
    #[error("larger than {MAX_WRITTEN} bytes")]
    TooLarge,
    #[error("not UTF-8 text")]
    NotText,
}

fn tail(path: &Path) -> String {
    use std::io::{Read, Seek, SeekFrom};
    // Only the end of a plain file is read: a plug-in's stderr may be
    // gigabytes, or replaced by a FIFO that never ends.
    let read = || -> std::io::Result<String> {
        if !std::fs::symlink_metadata(path)?.file_type().is_file() {
            return Ok(String::new());
        }
        let mut file = std::fs::File::open(path)?;
        let length = file.metadata()?.len();
        file.seek(SeekFrom::Start(length.saturating_sub(STDERR_TAIL)))?;
        let mut bytes = Vec::new();
        file.take(STDERR_TAIL).read_to_end(&mut bytes)?;
        Ok(String::from_utf8_lossy(&bytes).into_owned())
    };
    let text = read().unwrap_or_default();
    let text = text.trim();
    let start = text.char_indices().rev().nth(499).map_or(0, |(i, _)| i);
    text[start..].replace('\n', " | ")
}

impl Estimator for Plugin {
    fn name(&self) -> &'static str {
        self.name
    }

    fn info(&self) -> MethodInfo {
        MethodInfo {
            title: self.description,
            paper: self.paper,
            equations: "(the plug-in's own; aeroid runs it through the plug-in protocol, docs/plugins.md)",
            needs: "what the plug-in refuses without (refusal.json)",
            settings: self
                .settings
                .iter()
                .flatten()
                .map(|name| SettingInfo {
                    name: Box::leak(name.clone().into_boxed_str()),
                    default: "(none)".into(),
                    meaning: "passed to the plug-in in problem.json",
                })
                .collect(),
        }
    }

    fn check_settings(&self, settings: &Settings) -> Result<()> {
        let Some(known) = &self.settings else {
            return Ok(());
        };
        match settings.keys().find(|key| !known.contains(key)) {
            Some(key) => Err(Error::Plugin {
                reason: format!(
                    "[methods.{}]: unknown setting '{key}'; the plug-in takes: {}",
                    self.name,
                    known.join(", ")
                ),
            }),
            None => Ok(()),
        }
    }

    /// Any structure (the plug-in refuses what it does not fit itself),
    /// several records unless its file says `records = "one"`, no ties.
    fn capabilities(&self) -> Capabilities {
        Capabilities {
            six_dof: true,
            linear: true,
            several_records: self.records != Records::One,
            tied_parameters: false,
            moment_reference: true,
            starts_from: None,
        }
    }

    fn estimate(&self, problem: &EstimationProblem, _start: Option<&Estimate>) -> Result<Estimate> {
        if self.records == Records::One && problem.records.len() > 1 {
            return Err(Error::Plugin {
                reason: format!(
                    "plug-in {} takes one record ({}: records = \"one\"); {} were given",
                    self.name,
                    self.path.display(),
                    problem.records.len()
                ),
            });
        }
        self.run(problem)
    }
}

/// Every plug-in file in the data folder's `estimators/` and the folders
/// of `AEROID_ESTIMATORS`, loaded; a file that cannot be loaded is its
/// path and error beside the others.
pub(crate) fn discover() -> (Vec<Plugin>, Vec<(PathBuf, Error)>) {
    let mut folders = vec![aeroid_core::catalog::data_folder().join(PLUGIN_FOLDER)];
    if let Ok(extra) = std::env::var(PLUGIN_VARIABLE) {
        folders.extend(
            extra
                .split(':')
                .filter(|s| !s.is_empty())
                .map(PathBuf::from),
        );
    }
    let (mut plugins, mut problems) = (Vec::new(), Vec::new());
    for folder in folders {
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        for file in files {
            match Plugin::load(&file) {
                Ok(plugin) => plugins.push(plugin),
                Err(error) => problems.push((file, error)),
            }
        }
    }
    (plugins, problems)
}

/// What is wrong with the estimate a plug-in wrote (`estimate.json`).
#[derive(Debug, thiserror::Error)]
enum WrittenError {
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    #[error("format '{0}', expected '{ESTIMATE_FORMAT}'")]
    Format(String),
    #[error(
        "parameters[{index}]: '{name}' is not a free parameter of model '{model}' (free: {free})"
    )]
    NotFree {
        index: usize,
        name: String,
        model: String,
        free: String,
    },
    #[error("parameters[{index}]: '{name}' is given twice")]
    Twice { index: usize, name: String },
    #[error("parameters[{index}] ('{name}'): value is not a finite number")]
    Value { index: usize, name: String },
    #[error("parameters[{index}] ('{name}'): standard_error must be ≥ 0 or \"inf\"")]
    StandardError { index: usize, name: String },
    #[error("free parameters missing: {0}")]
    Missing(String),
    #[error("covariance: expected {0}×{0}")]
    CovarianceShape(usize),
    #[error("covariance: holds NaN")]
    CovarianceNan,
    #[error("covariance[{index}][{index}] = {value}: a variance must not be negative")]
    NegativeVariance { index: usize, value: f64 },
    #[error(
        "covariance[{row}][{column}] differs from covariance[{column}][{row}]: a covariance is symmetric"
    )]
    Asymmetric { row: usize, column: usize },
    #[error(
        "parameters[{index}] ('{name}'): {value} is outside the model's bounds [{low}, {high}]"
    )]
    Bounds {
        index: usize,
        name: String,
        value: f64,
        low: f64,
        high: f64,
    },
    #[error("status '{0}': expected converged, iteration_limit, diverged or no_progress")]
    Status(String),
}
