//! MATLAB MAT-files, level 5 (what `save` writes with `-v6` or `-v7`,
//! compressed or not): the variables of a file read as columns for the
//! import ([`MatTable`], through the `matfile` crate), and the writer of
//! aeroid's exports ([`mod@write`]). The level-5 layout is MathWorks' "MAT-File
//! Format" (a 128-byte header, then tagged data elements, each 8-byte
//! aligned). HDF5-based v7.3 files and level-4 files are recognised by
//! their first bytes and refused with the format named.

pub mod write;

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// The 8-byte signature of an HDF5 file, at offset 0 or after a user block
/// of 512 bytes (where MATLAB v7.3 puts its header text).
const HDF5_SIGNATURE: &[u8] = b"\x89HDF\r\n\x1a\n";

/// What a data file for the import is, from its first bytes and its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum DataFormat {
    /// Text: CSV or whitespace-separated ASCII.
    Text,
    /// A MATLAB level-5 MAT-file.
    Mat5,
}

/// The format of `path`: a level-5 MAT-file by its header, text when it is
/// valid UTF-8 (whatever its name); an HDF5 (MATLAB v7.3) file, a level-4
/// MAT-file or other binary data is an error that says what the file is.
pub(crate) fn sniff(path: &Path) -> Result<DataFormat> {
    let bytes = std::fs::read(path).map_err(|source| aeroid_core::Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let refuse = |reason: String| {
        Err(Error::DataFormat {
            path: path.to_path_buf(),
            reason,
        })
    };
    let save_as = "save it from MATLAB with save(FILE, '-v7') or '-v6', which aeroid reads";
    if bytes.starts_with(b"MATLAB 7.3 MAT-file")
        || bytes.starts_with(HDF5_SIGNATURE)
        || bytes.get(512..520) == Some(HDF5_SIGNATURE)
    {
        return refuse(format!(
            "a MATLAB v7.3 MAT-file (HDF5-based), which aeroid does not read; {save_as}"
        ));
    }
    if is_level5(&bytes) {
        return Ok(DataFormat::Mat5);
    }
    let named_mat = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"));
    if looks_level4(&bytes) && (named_mat || std::str::from_utf8(&bytes).is_err()) {
        return refuse(format!(
            "not a MATLAB level-5 file: it looks like a level-4 MAT-file, which aeroid does not read; {save_as}"
        ));
    }
    match (std::str::from_utf8(&bytes), named_mat) {
        // Text, whatever its name (`save -ascii` writes text into a .mat).
        (Ok(_), _) => Ok(DataFormat::Text),
        (Err(_), true) => refuse(
            "not a MATLAB level-5 file (its first 128 bytes are not a level-5 header); aeroid reads \
             level-5 MAT-files (save with '-v7' or '-v6'), CSV and whitespace-separated ASCII"
                .to_string(),
        ),
        (Err(e), false) => refuse(format!(
            "not a MATLAB level-5 file, nor text (not UTF-8 at byte {}); aeroid reads level-5 \
             MAT-files, CSV and whitespace-separated ASCII",
            e.valid_up_to()
        )),
    }
}

/// A level-5 header: descriptive text whose first four bytes are not zero,
/// version 0x0100 and the endian indicator `IM` or `MI` at bytes 126–127.
fn is_level5(bytes: &[u8]) -> bool {
    let Some(header) = bytes.get(..128) else {
        return false;
    };
    let version_le = u16::from_le_bytes([header[124], header[125]]);
    let version_be = u16::from_be_bytes([header[124], header[125]]);
    header[..4].iter().all(|&b| b != 0)
        && matches!(
            (&header[126..128], version_le, version_be),
            (b"IM", 0x0100, _) | (b"MI", _, 0x0100)
        )
}

/// A level-4 matrix header: type MOPT (M machine 0–4, O 0, P precision
/// 0–5, T 0–2), rows, columns, imaginary flag and name length, all plausible.
fn looks_level4(bytes: &[u8]) -> bool {
    let Some(header) = bytes.get(..20) else {
        return false;
    };
    [true, false].into_iter().any(|little| {
        let word = |k: usize| {
            let four = [
                header[4 * k],
                header[4 * k + 1],
                header[4 * k + 2],
                header[4 * k + 3],
            ];
            if little {
                i32::from_le_bytes(four)
            } else {
                i32::from_be_bytes(four)
            }
        };
        let kind = word(0);
        let (m, o, p, t) = (kind / 1000, kind / 100 % 10, kind / 10 % 10, kind % 10);
        (0..5000).contains(&kind)
            && m <= 4
            && o == 0
            && p <= 5
            && t <= 2
            && word(1) >= 0
            && word(2) >= 0
            && (0..=1).contains(&word(3))
            && (1..=64).contains(&word(4))
    })
}

/// The numeric variables of a level-5 MAT-file as the import's columns: the
/// columns of one matrix, known by number (1 is the first), then every
/// vector (N×1 or 1×N), known by its variable name. Character, cell,
/// structure and sparse variables are not columns and are skipped.
pub struct MatTable {
    pub path: PathBuf,
    /// The matrix whose columns are numbered: its name, rows and columns.
    matrix: Option<(String, usize, usize)>,
    /// Why there is no numbered matrix, when there is none.
    no_matrix: String,
    /// Every column: the matrix's, then the vectors; with its header.
    columns: Vec<(String, Vec<f64>)>,
}

/// A variable of a MAT-file: its name, size and values (column-major).
type Variable = (String, Vec<usize>, Vec<f64>);

/// Whether a size is a row or column vector.
fn is_vector(size: &[usize]) -> bool {
    size.len() == 2 && (size[0] == 1 || size[1] == 1)
}

/// The variable whose columns are numbered: Ok(Ok(index)), or Ok(Err(why
/// there is none)) when the map names none and the file has no single
/// matrix; Err when the map names a variable the file does not hold.
fn numbered_matrix(
    arrays: &[Variable],
    matrix: Option<&str>,
) -> std::result::Result<std::result::Result<usize, String>, String> {
    let names: Vec<&str> = arrays.iter().map(|(name, _, _)| name.as_str()).collect();
    if let Some(name) = matrix {
        return match arrays.iter().position(|(n, _, _)| n == name) {
            Some(i) => Ok(Ok(i)),
            None => Err(format!(
                "no numeric variable '{name}' (file.matrix of the map); numeric variables: {}",
                names.join(", ")
            )),
        };
    }
    let matrices: Vec<usize> = (0..arrays.len())
        .filter(|&i| !is_vector(&arrays[i].1))
        .collect();
    Ok(match (matrices.as_slice(), arrays.len()) {
        ([one], _) => Ok(*one),
        ([], 1) => Ok(0),
        ([], 0) => Err("the file holds no numeric variable".to_string()),
        ([], _) => Err(format!(
            "the file holds no matrix, only vectors ({}): name them in the map",
            names.join(", ")
        )),
        (several, _) => Err(format!(
            "the file holds several matrices ({}): say which one's columns are numbered with \
             matrix = \"NAME\" in the map's [file] table",
            several
                .iter()
                .map(|&i| arrays[i].0.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    })
}

impl MatTable {
    /// Reads a level-5 MAT-file; `matrix` names the variable whose columns
    /// are numbered (else the file's one numeric variable that is not a
    /// vector, or its one variable).
    pub fn read(path: &Path, matrix: Option<&str>) -> Result<MatTable> {
        let bytes = std::fs::read(path).map_err(|source| aeroid_core::Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let refuse = |reason: String| Error::DataFormat {
            path: path.to_path_buf(),
            reason,
        };
        let file = matfile::MatFile::parse(bytes.as_slice()).map_err(|e| {
            refuse(format!(
                "a level-5 MAT-file header, but its contents cannot be read ({e}); \
                 variables of class int32 cannot be read (convert them with double() \
                 before saving), otherwise save it again with save(FILE, '-v7') or '-v6'"
            ))
        })?;
        let mut arrays = Vec::with_capacity(file.arrays().len());
        for array in file.arrays() {
            let values = real_values(array)
                .map_err(|reason| refuse(format!("variable '{}': {reason}", array.name())))?;
            arrays.push((array.name().to_string(), array.size().clone(), values));
        }
        let chosen = numbered_matrix(&arrays, matrix).map_err(refuse)?;
        let mut columns = Vec::new();
        let (matrix, no_matrix) = match chosen {
            Ok(i) => {
                let (name, size, values) = &arrays[i];
                if size.len() != 2 {
                    return Err(refuse(format!(
                        "variable '{name}' has {} dimensions; a matrix of columns has two",
                        size.len()
                    )));
                }
                let (rows, cols) = (size[0], size[1]);
                for k in 0..cols {
                    columns.push((
                        format!("{name}(:,{})", k + 1),
                        values[k * rows..(k + 1) * rows].to_vec(),
                    ));
                }
                (Some((name.clone(), rows, cols)), String::new())
            }
            Err(why) => (None, why),
        };
        for (name, size, values) in arrays {
            if is_vector(&size) {
                columns.push((name, values));
            }
        }
        Ok(MatTable {
            path: path.to_path_buf(),
            matrix,
            no_matrix,
            columns,
        })
    }

    /// The columns' headers: `data(:,3)` for a matrix column, the name for a vector.
    pub fn headers(&self) -> Vec<String> {
        self.columns.iter().map(|(h, _)| h.clone()).collect()
    }

    /// The index of column `number` of the matrix (1 is the first).
    pub fn column_by_number(&self, number: i64) -> Result<usize> {
        let refuse = |reason: String| Error::DataFormat {
            path: self.path.clone(),
            reason,
        };
        let Some((name, _, cols)) = &self.matrix else {
            return Err(refuse(format!(
                "column {number}: numbered columns are a matrix's; {}",
                self.no_matrix
            )));
        };
        match usize::try_from(number) {
            Ok(n) if (1..=*cols).contains(&n) => Ok(n - 1),
            _ => Err(refuse(format!(
                "column {number}: the matrix '{name}' has {cols} columns (1 is the first)"
            ))),
        }
    }

    /// The index of the vector named `name`.
    pub fn column_index(&self, name: &str) -> Result<usize> {
        let first = self.matrix.as_ref().map_or(0, |(_, _, cols)| *cols);
        self.columns[first..]
            .iter()
            .position(|(n, _)| n == name)
            .map(|i| first + i)
            .ok_or_else(|| Error::DataFormat {
                path: self.path.clone(),
                reason: format!(
                    "no vector variable '{name}'; vectors: {}{}",
                    match self.columns[first..].len() {
                        0 => "none".to_string(),
                        _ => self.columns[first..]
                            .iter()
                            .map(|(n, _)| n.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                    },
                    self.matrix
                        .as_ref()
                        .map_or_else(String::new, |(m, _, cols)| format!(
                            "; the matrix '{m}' has {cols} columns, known by number"
                        ))
                ),
            })
    }

    /// The values of column `index`, `rows` long: a column of another
    /// length is an error naming it.
    pub fn values(&self, index: usize, rows: usize) -> Result<&[f64]> {
        let (header, values) = &self.columns[index];
        if values.len() != rows {
            return Err(Error::DataFormat {
                path: self.path.clone(),
                reason: format!(
                    "{header} has {} values, the time column {rows}; every column needs one value per time",
                    values.len()
                ),
            });
        }
        Ok(values)
    }

    /// The header of column `index`.
    pub fn header(&self, index: usize) -> &str {
        &self.columns[index].0
    }

    /// The number of values of column `index`.
    pub fn len(&self, index: usize) -> usize {
        self.columns[index].1.len()
    }
}

/// A numeric variable's values as `f64`, column-major; complex values are refused.
fn real_values(array: &matfile::Array) -> std::result::Result<Vec<f64>, String> {
    use matfile::NumericData as N;
    fn widen<T: Copy + Into<f64>>(real: &[T], imag: &Option<Vec<T>>) -> Result<Vec<f64>, String> {
        match imag {
            Some(_) => Err("complex values; a channel is real".to_string()),
            None => Ok(real.iter().map(|&v| v.into()).collect()),
        }
    }
    let wide = |real: &[i64], imag: &Option<Vec<i64>>| match imag {
        Some(_) => Err("complex values; a channel is real".to_string()),
        None => Ok(real.iter().map(|&v| v as f64).collect()),
    };
    let wide_unsigned = |real: &[u64], imag: &Option<Vec<u64>>| match imag {
        Some(_) => Err("complex values; a channel is real".to_string()),
        None => Ok(real.iter().map(|&v| v as f64).collect()),
    };
    match array.data() {
        N::Int8 { real, imag } => widen(real, imag),
        N::UInt8 { real, imag } => widen(real, imag),
        N::Int16 { real, imag } => widen(real, imag),
        N::UInt16 { real, imag } => widen(real, imag),
        N::Int32 { real, imag } => widen(real, imag),
        N::UInt32 { real, imag } => widen(real, imag),
        N::Int64 { real, imag } => wide(real, imag),
        N::UInt64 { real, imag } => wide_unsigned(real, imag),
        N::Single { real, imag } => widen(real, imag),
        N::Double { real, imag } => widen(real, imag),
    }
}
