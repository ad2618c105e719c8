//! The data file of an import as columns: a text file read as a
//! [`CsvTable`], or a level-5 MAT-file read as a [`MatTable`] (numbered
//! columns of its matrix, vectors by name), chosen by the file's first
//! bytes ([`mat::sniff`]). Bad cells are reported by line and column in a
//! text file, by variable and row in a MAT-file.

use super::{ColumnRef, FileLayout};
use crate::error::{Error, Result};
use crate::mat::{self, DataFormat, MatTable};
use aeroid_core::csv_table::{CsvTable, Layout, first_disorder};
use std::path::Path;

/// The columns of a data file.
pub(super) enum Source {
    Text(CsvTable),
    Mat(MatTable),
}

impl Source {
    /// Reads `data` as its first bytes say: a level-5 MAT-file or text.
    pub(super) fn read(data: &Path, layout: &FileLayout) -> Result<Source> {
        match mat::sniff(data)? {
            DataFormat::Mat5 => Ok(Source::Mat(MatTable::read(data, layout.matrix.as_deref())?)),
            DataFormat::Text => {
                let table = CsvTable::read_layout(
                    data,
                    Layout {
                        header: layout.header,
                        delimiter: layout.delimiter,
                    },
                )?;
                table.require_rows()?;
                Ok(Source::Text(table))
            }
        }
    }

    /// Every column's header (numbers for a headerless text file,
    /// `data(:,3)` for a matrix column).
    pub(super) fn headers(&self) -> Vec<String> {
        match self {
            Source::Text(table) => table.headers.clone(),
            Source::Mat(table) => table.headers(),
        }
    }

    /// The index of a mapped column.
    pub(super) fn index(&self, column: &ColumnRef) -> Result<usize> {
        match (self, column) {
            (Source::Text(table), ColumnRef::Number(n)) => {
                Ok(table.column_by_number(u64::try_from(*n).unwrap_or(0))?)
            }
            (Source::Text(table), ColumnRef::Name(name)) => Ok(table.column_index(name)?),
            (Source::Mat(table), ColumnRef::Number(n)) => table.column_by_number(*n),
            (Source::Mat(table), ColumnRef::Name(name)) => table.column_index(name),
        }
    }

    /// The time column: numbers, finite, strictly increasing.
    pub(super) fn times(&self, index: usize) -> Result<Vec<f64>> {
        match self {
            Source::Text(table) => Ok(table.time_column(index)?),
            Source::Mat(table) => {
                let rows = table.len(index);
                let times = table.values(index, rows)?.to_vec();
                if rows == 0 {
                    return Err(mat_error(
                        table,
                        format!(
                            "the time column {} is empty; a record needs samples",
                            table.header(index)
                        ),
                    ));
                }
                match first_disorder(&times) {
                    None => Ok(times),
                    Some(k) => Err(mat_error(
                        table,
                        format!(
                            "time column {}, row {}: {} is {}",
                            table.header(index),
                            k + 1,
                            times[k],
                            match times[k].is_finite() {
                                false => "not a finite number".to_string(),
                                true => format!(
                                    "not after the previous time {} (the time column must increase strictly)",
                                    times[k - 1]
                                ),
                            }
                        ),
                    )),
                }
            }
        }
    }

    /// The cells of column `index`, `rows` of them: `None` where a text
    /// cell is empty. NaN or an infinity is an error (`hint` says what to
    /// do), or a NaN dropout when `non_finite_is_dropout`.
    pub(super) fn cells(
        &self,
        index: usize,
        rows: usize,
        non_finite_is_dropout: bool,
        hint: &str,
    ) -> Result<Vec<Option<f64>>> {
        match self {
            Source::Text(table) => Ok(table.measurements(index, non_finite_is_dropout, hint)?),
            Source::Mat(table) => {
                let values = table.values(index, rows)?;
                match values.iter().position(|v| !v.is_finite()) {
                    Some(k) if !non_finite_is_dropout => Err(mat_error(
                        table,
                        format!(
                            "{}, row {}: {} is not a finite number; {hint}",
                            table.header(index),
                            k + 1,
                            values[k]
                        ),
                    )),
                    _ => Ok(values
                        .iter()
                        .map(|&v| Some(if v.is_finite() { v } else { f64::NAN }))
                        .collect()),
                }
            }
        }
    }
}

fn mat_error(table: &MatTable, reason: String) -> Error {
    Error::DataFormat {
        path: table.path.clone(),
        reason,
    }
}
