//! The time histories a study keeps of the first run of every sweep point,
//! for the report's proof-of-match and smoothed-coefficient plots: the
//! measured outputs; per model and method that converged, the estimated
//! model simulated on the same record with nothing adjusted (initial state
//! from the record's first samples: [`output_error::match_histories`]);
//! the histories a method estimated along the record (estimation before
//! modelling's smoothed coefficients with their σ); and, beside those, the
//! simulator's true coefficients.
//!
//! Each point's histories are one JSON file, `histories/point-NNNNN.json`
//! in the study's folder, written (to a temporary name, then renamed)
//! before its case enters the journal: a resumed study finds it whole, and
//! a shard's files are copied unchanged by `aeroid study merge`, so the
//! merged folder holds the same bytes as a one-machine run's.

use crate::error::{Error, Result};
use aeroid_core::error::{read_text, write_error};
use aeroid_estimation::estimate::{Estimate, History};
use aeroid_estimation::methods::output_error;
use aeroid_estimation::model::coefficient_states::COEFFICIENT_NAMES;
use aeroid_estimation::structure::Structure;
use aeroid_record::FlightRecord;
use aeroid_sim::trace::TruthTrace;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The folder of the histories inside a study's folder.
pub(crate) const HISTORIES_FOLDER: &str = "histories";

/// One method's histories on one model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MethodHistories {
    pub model: String,
    pub method: String,
    /// The estimated model's outputs at the measured samples (proof of match).
    pub predicted: Vec<History>,
    /// Histories the method estimated (smoothed coefficients).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub estimated: Vec<History>,
    /// Why there is no proof of match, when there is none.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// The histories of one case (the first run of a sweep point).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseHistories {
    pub point: usize,
    pub run: usize,
    /// The sweep point's label.
    pub label: String,
    /// The record's samples of every model's outputs.
    pub measured: Vec<History>,
    /// The simulator's true coefficients, kept when a method estimated
    /// coefficient histories to lay them over.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub truth: Vec<History>,
    pub methods: Vec<MethodHistories>,
}

impl CaseHistories {
    /// A case's histories with its measured outputs and nothing else yet.
    pub fn new(
        point: usize,
        run: usize,
        label: String,
        record: &FlightRecord,
        models: &[Structure],
    ) -> CaseHistories {
        let mut measured: Vec<History> = Vec::new();
        for model in models {
            for name in model.outputs() {
                if measured.iter().any(|s| &s.name == name) {
                    continue;
                }
                if let Ok(channel) = record.channel(name) {
                    let (times, values) = channel
                        .times
                        .iter()
                        .zip(&channel.values)
                        .filter(|(_, v)| v.is_finite())
                        .unzip();
                    measured.push(History {
                        name: name.clone(),
                        times,
                        values,
                        sigma: Vec::new(),
                    });
                }
            }
        }
        CaseHistories {
            point,
            run,
            label,
            measured,
            truth: Vec::new(),
            methods: Vec::new(),
        }
    }

    /// Adds a method's histories: its proof of match on `record` when its
    /// estimate converged on a 6-DOF model, and the histories it estimated.
    pub fn add(
        &mut self,
        model: &Structure,
        estimate: &Estimate,
        record: &FlightRecord,
        trace: Option<&TruthTrace>,
    ) {
        let (predicted, note) = if !estimate.status.is_success() {
            (
                Vec::new(),
                format!("no proof of match: {}", estimate.status),
            )
        } else {
            match model
                .six_dof("proof of match")
                .and_then(|structure| output_error::match_histories(estimate, structure, record))
            {
                Ok(matched) => (
                    matched
                        .into_iter()
                        .map(|m| History {
                            name: m.channel,
                            times: m.times,
                            values: m.predicted,
                            sigma: Vec::new(),
                        })
                        .collect(),
                    String::new(),
                ),
                Err(error) => (Vec::new(), format!("no proof of match: {error}")),
            }
        };
        let estimated = estimate.histories.clone();
        if !estimated.is_empty() && self.truth.is_empty() {
            self.truth = trace.map_or_else(Vec::new, true_coefficients);
        }
        self.methods.push(MethodHistories {
            model: model.name().to_string(),
            method: estimate.method.clone(),
            predicted,
            estimated,
            note,
        });
    }

    /// The file of a point's histories in `folder`.
    pub fn path(folder: &Path, point: usize) -> PathBuf {
        folder
            .join(HISTORIES_FOLDER)
            .join(format!("point-{point:05}.json"))
    }

    /// Writes the histories into `folder`'s histories folder, whole or not
    /// at all (a temporary file renamed into place).
    pub fn write(&self, folder: &Path) -> Result<()> {
        let path = Self::path(folder, self.point);
        let parent = folder.join(HISTORIES_FOLDER);
        std::fs::create_dir_all(&parent).map_err(|e| write_error(&parent, e))?;
        let text = serde_json::to_string(self).map_err(|e| write_error(&path, e))?;
        let temporary = path.with_extension("json.partial");
        std::fs::write(&temporary, text).map_err(|e| write_error(&temporary, e))?;
        std::fs::rename(&temporary, &path).map_err(|e| write_error(&path, e).into())
    }

    /// Every point's histories in `folder`, in point order (none when the
    /// folder has no histories).
    pub fn read_all(folder: &Path) -> Result<Vec<CaseHistories>> {
        let mut all = Vec::new();
        for path in history_files(folder)? {
            let text = read_text(&path)?;
            let histories: CaseHistories =
                serde_json::from_str(&text).map_err(|e| Error::Json {
                    path: path.clone(),
                    reason: e.to_string(),
                })?;
            all.push(histories);
        }
        all.sort_by_key(|h| h.point);
        Ok(all)
    }
}

/// The histories files in `folder`'s histories folder, in name order.
fn history_files(folder: &Path) -> Result<Vec<PathBuf>> {
    let dir = folder.join(HISTORIES_FOLDER);
    if !dir.is_dir() {
        return Ok(Vec::new());
    }
    let entries = std::fs::read_dir(&dir).map_err(|source| aeroid_core::Error::Io {
        path: dir.clone(),
        source,
    })?;
    let mut files = Vec::new();
    for entry in entries {
        let path = entry
            .map_err(|source| aeroid_core::Error::Io {
                path: dir.clone(),
                source,
            })?
            .path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.starts_with("point-") && name.ends_with(".json") {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

/// Copies the histories of the study folders `from` into `out` (a shard's
/// files unchanged); a folder that is `out` itself is skipped.
pub(crate) fn copy_all(from: &[PathBuf], out: &Path) -> Result<()> {
    let target = out.join(HISTORIES_FOLDER);
    for folder in from {
        let same = match (folder.canonicalize(), out.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if same {
            continue;
        }
        for path in history_files(folder)? {
            std::fs::create_dir_all(&target).map_err(|e| write_error(&target, e))?;
            let Some(name) = path.file_name() else {
                continue;
            };
            let copy = target.join(name);
            std::fs::copy(&path, &copy).map_err(|e| write_error(&copy, e))?;
        }
    }
    Ok(())
}

/// The simulator's body-axis coefficients along its trace.
fn true_coefficients(trace: &TruthTrace) -> Vec<History> {
    let times: Vec<f64> = trace.samples.iter().map(|s| s.time).collect();
    COEFFICIENT_NAMES
        .iter()
        .filter_map(|name| {
            trace.values(name).ok().map(|values| History {
                name: (*name).to_string(),
                times: times.clone(),
                values,
                sigma: Vec::new(),
            })
        })
        .collect()
}
