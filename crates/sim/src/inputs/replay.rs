//! The CSV replay input: a column of a CSV file with a header line (path
//! relative to the scenario file, inside its folder), converted from its
//! unit to SI and interpolated linearly in the time column shifted by
//! `start`; 0 before the first and after the last sample. The file is read
//! by the same reader as records, once the specs are free of problems.

use super::checker::Checker;
use super::signal::{Polyline, Signal};
use super::spec::CsvSpec;
use aeroid_core::csv_table::CsvTable;
use aeroid_core::units::{Dimension, unit_factor};
use std::path::{Path, PathBuf};

/// A validated `csv` spec whose file is still to be read.
pub(super) struct CsvRequest {
    control: usize,
    file: PathBuf,
    /// The spec's field naming the file (`inputs[2].file`), for errors.
    field: String,
    time_column: String,
    column: String,
    /// Factor from the column's unit to SI.
    factor: f64,
    /// Added to the file's times.
    shift: f64,
}

impl CsvSpec {
    /// Checks the unit and shift; the file is read later by [`CsvRequest::load`].
    pub(super) fn resolve(&self, checker: &mut Checker) -> Option<CsvRequest> {
        // A shift, not a start: a negative one moves a file whose clock
        // starts late back to the flight's 0 s.
        let shift = checker.quantity("start", &self.start, Dimension::Time);
        let factor = (self.unit.as_deref())
            .map_or(Ok(1.0), |unit| unit_factor(unit, self.control.dimension()));
        let factor = factor.map_err(|message| checker.push("unit", message)).ok();
        let file = self.file.to_string_lossy();
        if !aeroid_core::paths::stays_inside(&file) {
            checker.push(
                "file",
                format!(
                    "'{file}' leaves the scenario's folder; name a CSV file inside it by a relative path without '..'"
                ),
            );
            return None;
        }
        Some(CsvRequest {
            control: self.control.index(),
            file: self.file.clone(),
            field: format!("{}.file", checker.prefix),
            time_column: self.time_column.clone(),
            column: self.column.clone(),
            factor: factor?,
            shift: shift?,
        })
    }
}

impl CsvRequest {
    pub(super) fn load(self, base_dir: &Path, scenario_path: &Path) -> aeroid_core::Result<Signal> {
        let path = aeroid_core::paths::inside(
            base_dir,
            &self.file.to_string_lossy(),
            scenario_path,
            &self.field,
        )?;
        let (times, values) = read_csv_columns(&path, &self.time_column, &self.column)?;
        Ok(Signal::Polyline(Polyline {
            control: self.control,
            times: times.into_iter().map(|time| time + self.shift).collect(),
            values: values
                .into_iter()
                .map(|value| value * self.factor)
                .collect(),
            after: 0.0,
        }))
    }
}

/// The time column (finite, strictly increasing) and value column (finite)
/// of a CSV file with a header line; errors name the line (1-based, as in the
/// file) and column.
fn read_csv_columns(
    path: &Path,
    time_column: &str,
    column: &str,
) -> aeroid_core::Result<(Vec<f64>, Vec<f64>)> {
    let table = CsvTable::read(path)?;
    let time_index = table.column_index(time_column)?;
    let value_index = table.column_index(column)?;
    let times = table.time_column(time_index)?;
    let values = table.finite_numbers(value_index)?;
    if times.len() < 2 {
        return Err(aeroid_core::Error::Csv {
            path: path.to_path_buf(),
            line: times.len() as u64 + 1,
            column: time_column.to_string(),
            message: "needs at least 2 samples".into(),
        });
    }
    Ok((times, values))
}
