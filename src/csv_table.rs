//! The one CSV reader of aeroid: flight records, imported flight data and
//! replayed inputs are all read as a [`CsvTable`], so that every bad cell is
//! reported the same way, by file, line and column.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// A CSV file read whole, for naming the line and column of every bad cell.
pub(crate) struct CsvTable {
    pub path: PathBuf,
    pub headers: Vec<String>,
    /// Each data row with its line number in the file (the header is line 1).
    rows: Vec<(u64, csv::StringRecord)>,
}

impl CsvTable {
    /// Reads a CSV with a header row; a ragged row or a repeated header is an error.
    pub fn read(path: &Path) -> Result<CsvTable> {
        let mut reader = csv::Reader::from_path(path).map_err(|e| Error::Io {
            path: path.to_path_buf(),
            source: e.into(),
        })?;
        let csv_error = |e: csv::Error| Error::Csv {
            path: path.to_path_buf(),
            line: e.position().map_or(0, |p| p.line()),
            column: String::new(),
            message: e.to_string(),
        };
        let headers: Vec<String> = reader
            .headers()
            .map_err(csv_error)?
            .iter()
            .map(|h| h.trim().to_string())
            .collect();
        for (i, header) in headers.iter().enumerate() {
            if headers[..i].contains(header) {
                return Err(Error::Csv {
                    path: path.to_path_buf(),
                    line: 1,
                    column: header.clone(),
                    message: "the column name appears twice in the header".into(),
                });
            }
        }
        let hint = delimiter_hint(&headers);
        let mut rows = Vec::new();
        for row in reader.records() {
            let row = row.map_err(|e| match (&hint, e.kind()) {
                (Some(hint), csv::ErrorKind::UnequalLengths { .. }) => Error::Csv {
                    path: path.to_path_buf(),
                    line: e.position().map_or(0, |p| p.line()),
                    column: String::new(),
                    message: format!("{e}; {hint}"),
                },
                _ => csv_error(e),
            })?;
            rows.push((row.position().map_or(0, |p| p.line()), row));
        }
        Ok(CsvTable {
            path: path.to_path_buf(),
            headers,
            rows,
        })
    }

    /// The index of a header, or an error naming the missing column.
    pub fn column_index(&self, name: &str) -> Result<usize> {
        self.headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| Error::Csv {
                path: self.path.clone(),
                line: 1,
                column: name.to_string(),
                message: format!(
                    "no such column in the header; columns: {}{}",
                    self.headers.join(", "),
                    delimiter_hint(&self.headers)
                        .map_or_else(String::new, |hint| format!("; {hint}"))
                ),
            })
    }

    /// A column parsed as numbers; an empty cell is NaN when `allow_empty`,
    /// anything else that is not a number is an error naming line and column.
    pub fn numbers(&self, column: usize, allow_empty: bool) -> Result<Vec<f64>> {
        self.rows
            .iter()
            .map(|(line, row)| {
                let text = row.get(column).unwrap_or("").trim();
                match text.parse::<f64>() {
                    Ok(value) => Ok(value),
                    Err(_) if text.is_empty() && allow_empty => Ok(f64::NAN),
                    Err(_) => {
                        Err(self.cell_error(*line, column, format!("'{text}' is not a number")))
                    }
                }
            })
            .collect()
    }

    /// A column of measurements: `None` for an empty cell, else the number.
    /// A cell that reads as NaN or an infinity (`inf`, `1e400`) is an error
    /// naming line and column, or a NaN dropout when `non_finite_is_dropout`.
    pub fn measurements(
        &self,
        column: usize,
        non_finite_is_dropout: bool,
        hint: &str,
    ) -> Result<Vec<Option<f64>>> {
        self.rows
            .iter()
            .map(|(line, row)| {
                let text = row.get(column).unwrap_or("").trim();
                if text.is_empty() {
                    return Ok(None);
                }
                match text.parse::<f64>() {
                    Ok(value) if value.is_finite() => Ok(Some(value)),
                    Ok(_) if non_finite_is_dropout => Ok(Some(f64::NAN)),
                    Ok(value) => Err(self.cell_error(
                        *line,
                        column,
                        format!("'{text}' reads as {value}, not a finite number; {hint}"),
                    )),
                    Err(_) => {
                        Err(self.cell_error(*line, column, format!("'{text}' is not a number")))
                    }
                }
            })
            .collect()
    }

    /// An error unless the file has at least one data row below its header.
    pub fn require_rows(&self) -> Result<()> {
        match self.rows.is_empty() {
            false => Ok(()),
            true => Err(Error::Csv {
                path: self.path.clone(),
                line: 1,
                column: String::new(),
                message: "the file has a header but no data rows; a record needs samples".into(),
            }),
        }
    }

    /// A column of finite numbers; anything else is an error naming line and column.
    pub fn finite_numbers(&self, column: usize) -> Result<Vec<f64>> {
        let values = self.numbers(column, false)?;
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(values),
            Some(k) => Err(self.cell_error(
                self.rows[k].0,
                column,
                format!("'{}' is not a finite number", values[k]),
            )),
        }
    }

    /// A time column: numbers, finite, strictly increasing.
    pub fn time_column(&self, column: usize) -> Result<Vec<f64>> {
        let times = self.numbers(column, false)?;
        match first_disorder(&times) {
            None => Ok(times),
            Some(k) if !times[k].is_finite() => Err(self.cell_error(
                self.rows[k].0,
                column,
                format!("time {} is not a finite number", times[k]),
            )),
            Some(k) => Err(self.cell_error(
                self.rows[k].0,
                column,
                format!(
                    "time {} is not after the previous time {} (the time column must increase strictly)",
                    times[k],
                    if k > 0 { times[k - 1] } else { f64::NAN }
                ),
            )),
        }
    }

    fn cell_error(&self, line: u64, column: usize, message: String) -> Error {
        Error::Csv {
            path: self.path.clone(),
            line,
            column: self.headers.get(column).cloned().unwrap_or_default(),
            message,
        }
    }
}

/// A hint when a header of one column looks separated by another
/// delimiter than the comma.
fn delimiter_hint(headers: &[String]) -> Option<String> {
    let [header] = headers else { return None };
    [';', '\t', '|']
        .into_iter()
        .find(|&d| header.contains(d))
        .map(|d| {
            format!(
                "the file seems to use '{}' as delimiter; aeroid reads comma-separated files",
                d.escape_default()
            )
        })
}

/// The index of the first time not after its predecessor (or not finite).
pub(crate) fn first_disorder(times: &[f64]) -> Option<usize> {
    times
        .iter()
        .enumerate()
        .find(|&(k, t)| !t.is_finite() || (k > 0 && *t <= times[k - 1]))
        .map(|(k, _)| k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_semicolon_separated_file_gets_a_delimiter_hint() {
        let path =
            std::env::temp_dir().join(format!("aeroid-semicolon-{}.csv", std::process::id()));
        std::fs::write(&path, "time;alpha\n0,0;1,5\n0,1;1,6\n").unwrap();
        let error = CsvTable::read(&path).err().unwrap().to_string();
        std::fs::write(&path, "time;alpha\n0;1\n1;2\n").unwrap();
        let missing = CsvTable::read(&path)
            .unwrap()
            .column_index("time")
            .unwrap_err();
        std::fs::remove_file(&path).unwrap();
        let hint = "the file seems to use ';' as delimiter; aeroid reads comma-separated files";
        assert!(error.contains("line 2") && error.ends_with(hint), "{error}");
        assert!(missing.to_string().ends_with(hint), "{missing}");
    }
}
