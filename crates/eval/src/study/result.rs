//! What a study produced ([`StudyResult`]): its summary, how its fits
//! ended, `summary.csv` and `study.json`, the terminal table; and
//! [`assemble`], the result of a study from its journals.

use crate::error::{Error, Result};
use crate::journal;
use crate::summary::{Ending, Summariser, SummaryRow};
use aeroid_core::atomic::AtomicFile;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What a study produced: its summary and how its fits ended.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StudyResult {
    pub study: String,
    pub seed: u64,
    pub runs: usize,
    /// Cases and rows (`runs.csv`'s) the summary is of.
    pub cases: usize,
    pub rows: usize,
    pub summary: Vec<SummaryRow>,
    /// How the fits ended, each status with its count and first fit.
    pub endings: Vec<Ending>,
}

/// The result of a study from the journals in `folders` (one whole
/// study's, or every shard's): `runs.csv` written to `out` case by case in
/// case order, then `summary.csv` and `study.json`. The same bytes
/// whether the cases ran on one machine, in shards, resumed, or on any
/// number of threads; memory independent of the number of cases.
pub fn assemble(folders: &[PathBuf], out: &Path) -> Result<StudyResult> {
    let mut cases = journal::open(folders)?;
    let header = cases.header().clone();
    std::fs::create_dir_all(out).map_err(|e| aeroid_core::error::write_error(out, e))?;
    crate::histories::copy_all(folders, out)?;
    // runs.csv, summary.csv and study.json are each written whole or not
    // at all, study.json last: a kill leaves the folder's old result (or
    // none), never a runs.csv cut mid-field.
    let path = out.join("runs.csv");
    let io_error = |e: csv::Error| aeroid_core::error::write_error(&path, e);
    let mut atomic = AtomicFile::create(&path)?;
    let mut writer = csv::Writer::from_writer(atomic.file());
    let mut summariser = Summariser::default();
    cases.for_each(|_, rows| {
        for row in &rows {
            writer.serialize(row).map_err(io_error)?;
        }
        summariser.add(&rows);
        Ok(())
    })?;
    writer
        .flush()
        .map_err(|e| aeroid_core::error::write_error(&path, e))?;
    drop(writer);
    atomic.commit()?;
    let result = StudyResult::of(
        &header.study,
        header.seed,
        header.runs,
        header.cases,
        &summariser,
    );
    result.write(out)?;
    Ok(result)
}

impl StudyResult {
    /// The result of `cases` cases summarised by `summariser`.
    pub fn of(
        study: &str,
        seed: u64,
        runs: usize,
        cases: usize,
        summariser: &Summariser,
    ) -> StudyResult {
        StudyResult {
            study: study.to_string(),
            seed,
            runs,
            cases,
            rows: summariser.rows(),
            summary: summariser.summary(),
            endings: summariser.endings().to_vec(),
        }
    }

    /// Writes `summary.csv` and `study.json` (the result; a non-finite
    /// number is the string "NaN", "inf" or "-inf" there) into `folder`,
    /// creating it.
    pub fn write(&self, folder: &Path) -> Result<()> {
        let io = |path: &Path, e: std::io::Error| aeroid_core::error::write_error(path, e);
        std::fs::create_dir_all(folder).map_err(|e| io(folder, e))?;
        write_csv(&folder.join("summary.csv"), &self.summary)?;
        let path = folder.join("study.json");
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::Json {
            path: path.clone(),
            reason: e.to_string(),
        })?;
        Ok(aeroid_core::atomic::write_text(&path, &text)?)
    }

    /// The summary as a fixed-width table for the terminal.
    /// Per sweep point, model and method whose fits carried diagnoses, one
    /// line each: how many fits carried which (`kind:count`).
    pub fn diagnosed(&self) -> Vec<String> {
        let mut seen = std::collections::BTreeSet::new();
        self.summary
            .iter()
            .filter(|s| !s.diagnosed.is_empty())
            .filter(|s| seen.insert((s.point, s.model.clone(), s.method.clone())))
            .map(|s| {
                format!(
                    "point {} {} {}: {} of {} fits diagnosed: {}",
                    s.point, s.model, s.method, s.diagnosed_fits, s.runs, s.diagnosed
                )
            })
            .collect()
    }

    pub fn table(&self) -> String {
        // The text columns are as wide as their longest entry, so that long
        // model names keep the numbers in line.
        let width = |header: &str, field: fn(&SummaryRow) -> &str| {
            self.summary
                .iter()
                .map(|s| field(s).chars().count())
                .chain([header.chars().count()])
                .max()
                .unwrap_or(0)
        };
        let model = width("model", |s| &s.model);
        let method = width("meth", |s| &s.method);
        let parameter = width("parameter", |s| &s.parameter);
        let mut text = format!(
            "{:<model$} {:<method$} {:<parameter$} {:>11} {:>11} {:>8} {:>7} {:>7} {:>7} {:>6} {:>9}\n",
            "model",
            "meth",
            "parameter",
            "truth",
            "mean",
            "bias %",
            "bias/σ",
            "b/CRB",
            "σ/CRB",
            "cov95",
            "conv/runs"
        );
        let mut point = usize::MAX;
        for s in &self.summary {
            if s.point != point {
                point = s.point;
                text += &format!("point {point}: {}\n", s.axes().label());
            }
            text += &format!(
                "{:<model$} {:<method$} {:<parameter$} {:>11.5} {:>11.5} {:>8.2} {:>7.2} {:>7.2} {:>7.2} {:>5.0}% {:>9}\n",
                s.model,
                s.method,
                s.parameter,
                s.truth,
                s.mean,
                100.0 * s.relative_bias,
                s.bias_over_std,
                s.bias_over_crb,
                s.std_over_crb,
                100.0 * s.coverage,
                format!("{}/{}", s.converged, s.runs)
            );
        }
        text
    }
}

fn write_csv<T: Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    let io_error = |e: csv::Error| aeroid_core::error::write_error(path, e);
    let mut atomic = AtomicFile::create(path)?;
    let mut writer = csv::Writer::from_writer(atomic.file());
    for row in rows {
        writer.serialize(row).map_err(io_error)?;
    }
    writer
        .flush()
        .map_err(|e| aeroid_core::error::write_error(path, e))?;
    drop(writer);
    Ok(atomic.commit()?)
}
