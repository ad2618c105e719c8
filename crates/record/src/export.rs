//! A record as one file for other tools (`aeroid export`, `docs/import.md`):
//!
//! - MATLAB level-5 MAT-file: per time base a double matrix with the time
//!   (s) in column 1 and one column per channel in SI (angles in rad),
//!   with character matrices naming each column and its unit. A record
//!   whose channels share one time base gives `data`, `names` and `units`
//!   (`load rec.mat; alpha = data(:, strcmp(cellstr(names), 'alpha'))`,
//!   the matrix-of-columns layout SIDPAC's `fdata` and FVSysID's `Z` and
//!   `Uinp` are cut from); several time bases give `data_STEM`,
//!   `names_STEM` and `units_STEM`, STEM being the record folder's CSV
//!   file of that base (`data_rate_25hz`). A dropout is NaN.
//! - CSV: `time [s]`, then one column per channel headed `name [unit]`,
//!   one row per instant of any channel; a cell is empty where its channel
//!   has no sample at that instant and `NaN` where a sample was lost.

use crate::error::{Error, Result};
use crate::mat::write::{Values, Variable, is_variable_name};
use crate::{FlightRecord, TIME_HEADER, shortest};
use std::path::Path;

/// The file formats a record is exported to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// MATLAB level-5 MAT-file.
    Mat,
    /// One comma-separated file with a header.
    Csv,
}

impl ExportFormat {
    /// The format a file name's extension implies (`.mat`, `.csv`).
    pub fn from_extension(path: &Path) -> Option<ExportFormat> {
        let extension = path.extension()?.to_str()?.to_ascii_lowercase();
        match extension.as_str() {
            "mat" => Some(ExportFormat::Mat),
            "csv" => Some(ExportFormat::Csv),
            _ => None,
        }
    }
}

/// Writes `record` to the file `out` in `format`; returns what the file
/// holds, one line per variable (MAT) or the columns (CSV).
pub fn export(record: &FlightRecord, format: ExportFormat, out: &Path) -> Result<Vec<String>> {
    record.validate(out)?;
    match format {
        ExportFormat::Mat => {
            let variables = mat_variables(record)?;
            let summary = variables
                .iter()
                .map(|v| match v {
                    Variable::Numeric {
                        name, rows, cols, ..
                    } => format!("{name}: {rows} × {cols} double"),
                    Variable::Text { name, lines } => format!("{name}: {} names", lines.len()),
                })
                .collect();
            crate::mat::write::write(out, &variables, &format!("aeroid record {}", record.name()))?;
            Ok(summary)
        }
        ExportFormat::Csv => {
            let text = csv_text(record);
            aeroid_core::atomic::write_text(out, &text)?;
            Ok(vec![format!(
                "{} columns: time and {} channels",
                record.channels.len() + 1,
                record.channels.len()
            )])
        }
    }
}

/// The variables of the MAT export (module documentation).
pub(crate) fn mat_variables(record: &FlightRecord) -> Result<Vec<Variable>> {
    let bases = record.time_bases();
    let mut variables = Vec::with_capacity(3 * bases.len());
    let mut used: Vec<String> = Vec::new();
    for base in &bases {
        let suffix = match bases.len() {
            1 => String::new(),
            _ => {
                let stem = base.file.strip_suffix(".csv").unwrap_or(&base.file);
                let clean: String = stem
                    .chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect();
                format!("_{clean}")
            }
        };
        let mut suffix = suffix;
        suffix.truncate(52);
        let mut k = 2;
        while used.contains(&suffix) {
            suffix = format!("{}_{k}", &suffix[..suffix.len().min(48)]);
            k += 1;
        }
        used.push(suffix.clone());
        let times = &record.channels[base.channels[0]].times;
        let mut values = Vec::with_capacity(times.len() * (base.channels.len() + 1));
        values.extend_from_slice(times);
        for &i in &base.channels {
            values.extend_from_slice(&record.channels[i].values);
        }
        let names = std::iter::once("time".to_string())
            .chain(
                base.channels
                    .iter()
                    .map(|&i| record.channels[i].name.clone()),
            )
            .collect();
        let units = std::iter::once("s".to_string())
            .chain(
                base.channels
                    .iter()
                    .map(|&i| record.channels[i].unit.clone()),
            )
            .collect();
        let numeric = Variable::Numeric {
            name: format!("data{suffix}"),
            rows: times.len(),
            cols: base.channels.len() + 1,
            values: Values::Double(values),
        };
        for name in [format!("data{suffix}"), format!("names{suffix}")] {
            if !is_variable_name(&name) {
                return Err(Error::Serialize {
                    reason: format!("'{name}' cannot be a MATLAB variable name"),
                });
            }
        }
        variables.push(numeric);
        variables.push(Variable::Text {
            name: format!("names{suffix}"),
            lines: names,
        });
        variables.push(Variable::Text {
            name: format!("units{suffix}"),
            lines: units,
        });
    }
    Ok(variables)
}

/// The CSV export (module documentation): every channel on the union of
/// the record's instants.
pub fn csv_text(record: &FlightRecord) -> String {
    let mut instants: Vec<f64> = record
        .channels
        .iter()
        .flat_map(|c| c.times.iter().copied())
        .collect();
    instants.sort_by(f64::total_cmp);
    instants.dedup();
    let mut text = String::with_capacity(instants.len() * (record.channels.len() + 1) * 20);
    let mut header = csv::Writer::from_writer(Vec::new());
    // Channel names and units hold no quotes or commas (check_name, SI
    // units), but the header goes through the csv crate all the same.
    let header_line = header
        .write_record(
            std::iter::once(TIME_HEADER.to_string())
                .chain(record.channels.iter().map(|c| c.header())),
        )
        .ok()
        .and_then(|()| header.into_inner().ok())
        .and_then(|bytes| String::from_utf8(bytes).ok())
        .unwrap_or_default();
    text += &header_line;
    let mut next = vec![0usize; record.channels.len()];
    let mut digits = zmij::Buffer::new();
    for &t in &instants {
        text += shortest(&mut digits, t);
        for (channel, k) in record.channels.iter().zip(next.iter_mut()) {
            text.push(',');
            if channel.times.get(*k) == Some(&t) {
                let value = channel.values[*k];
                if value.is_nan() {
                    text += "NaN";
                } else {
                    text += shortest(&mut digits, value);
                }
                *k += 1;
            }
        }
        text.push('\n');
    }
    text
}
