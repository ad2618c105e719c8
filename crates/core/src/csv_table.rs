//! The one CSV reader of aeroid: flight records, imported flight data and
//! replayed inputs are all read as a [`CsvTable`], so that every bad cell is
//! reported the same way, by file, line and column. Imported data may also
//! be headerless ASCII, whitespace- or comma-separated, with comment lines
//! ([`Layout`]).

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What separates the cells of a line of an imported data file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Delimiter {
    /// Commas in a file with a header; without a header, commas on a line
    /// that has one, else runs of spaces and tabs.
    #[default]
    Auto,
    Comma,
    /// Runs of spaces and tabs (no empty cells).
    Whitespace,
    Semicolon,
    Tab,
}

/// How an imported data file is laid out. Whatever the layout, a UTF-8
/// byte-order mark is ignored, lines may end in CRLF, and blank lines and
/// lines starting with `#` or `%` are comments.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Whether the first line that is not a comment names the columns;
    /// without one, columns are known by number (1 is the first).
    pub header: bool,
    pub delimiter: Delimiter,
}

/// Whether a line is a comment (or blank) in an imported data file.
fn is_comment(line: &str) -> bool {
    let line = line.trim();
    line.is_empty() || line.starts_with('#') || line.starts_with('%')
}

/// A CSV file read whole, for naming the line and column of every bad cell.
pub struct CsvTable {
    pub path: PathBuf,
    pub headers: Vec<String>,
    /// Each data row with its line number in the file (the header is line 1).
    rows: Vec<(u64, csv::StringRecord)>,
}

impl CsvTable {
    /// Reads a CSV with a header row; a ragged row or a repeated header is an error.
    pub fn read(path: &Path) -> Result<CsvTable> {
        let reader = csv::Reader::from_path(path).map_err(|e| Error::Io {
            path: path.to_path_buf(),
            source: e.into(),
        })?;
        Self::parse_csv(path, reader)
    }

    fn parse_csv<R: std::io::Read>(path: &Path, mut reader: csv::Reader<R>) -> Result<CsvTable> {
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
        Self::check_headers(path, &headers)?;
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

    /// A header named twice is an error.
    fn check_headers(path: &Path, headers: &[String]) -> Result<()> {
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
        Ok(())
    }

    /// Reads an imported data file laid out as `layout`.
    pub fn read_layout(path: &Path, layout: Layout) -> Result<CsvTable> {
        let text = crate::error::read_text(path)?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        if layout.header && matches!(layout.delimiter, Delimiter::Auto | Delimiter::Comma) {
            // Comment lines become blank lines, which the CSV reader skips,
            // so that line numbers stay those of the file.
            let blanked: String = text
                .lines()
                .map(|line| if is_comment(line) { "" } else { line })
                .collect::<Vec<_>>()
                .join("\n");
            return Self::parse_csv(path, csv::Reader::from_reader(blanked.as_bytes()));
        }
        Self::parse_lines(path, text, layout)
    }

    /// A file split line by line on `layout`'s delimiter.
    fn parse_lines(path: &Path, text: &str, layout: Layout) -> Result<CsvTable> {
        let split = |line: &str| -> Vec<String> {
            let cells: Vec<&str> = match layout.delimiter {
                Delimiter::Comma => line.split(',').collect(),
                Delimiter::Semicolon => line.split(';').collect(),
                Delimiter::Tab => line.split('\t').collect(),
                Delimiter::Whitespace => line.split_whitespace().collect(),
                Delimiter::Auto if line.contains(',') => line.split(',').collect(),
                Delimiter::Auto => line.split_whitespace().collect(),
            };
            cells.into_iter().map(|c| c.trim().to_string()).collect()
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, line)| !is_comment(line))
            .map(|(k, line)| (k as u64 + 1, split(line)));
        let headers: Vec<String> = match layout.header {
            true => lines.next().map(|(_, cells)| cells).unwrap_or_default(),
            false => Vec::new(),
        };
        let mut rows: Vec<(u64, csv::StringRecord)> = Vec::new();
        let mut width = (!headers.is_empty()).then_some((1, headers.len()));
        for (line, cells) in lines {
            let (first, expected) = *width.get_or_insert((line, cells.len()));
            if cells.len() != expected {
                return Err(Error::Csv {
                    path: path.to_path_buf(),
                    line,
                    column: String::new(),
                    message: format!(
                        "the line has {} cells, line {first} has {expected}; every line needs the same number of cells",
                        cells.len()
                    ),
                });
            }
            rows.push((line, csv::StringRecord::from(cells)));
        }
        let headers = match layout.header {
            true => headers,
            false => (1..=width.map_or(0, |(_, n)| n))
                .map(|n| n.to_string())
                .collect(),
        };
        Self::check_headers(path, &headers)?;
        Ok(CsvTable {
            path: path.to_path_buf(),
            headers,
            rows,
        })
    }

    /// The index of column `number` (1 is the first), or an error naming
    /// the first data line when the rows are shorter.
    pub fn column_by_number(&self, number: u64) -> Result<usize> {
        let width = self.headers.len();
        match usize::try_from(number) {
            Ok(n) if (1..=width).contains(&n) => Ok(n - 1),
            _ => Err(Error::Csv {
                path: self.path.clone(),
                line: self.rows.first().map_or(1, |(line, _)| *line),
                column: number.to_string(),
                message: match number {
                    0 => "column numbers start at 1".to_string(),
                    _ => format!(
                        "column number {number} is beyond the row, which has {width} columns"
                    ),
                },
            }),
        }
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
                message: match self.headers.is_empty() {
                    true => "the file has no data rows; a record needs samples".into(),
                    false => {
                        "the file has a header but no data rows; a record needs samples".into()
                    }
                },
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
pub fn first_disorder(times: &[f64]) -> Option<usize> {
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
