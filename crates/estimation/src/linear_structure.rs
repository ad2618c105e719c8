//! Linear state-space model structures (`kind = "linear"` model files):
//! small models in dimensional derivatives, ẋ = A·x + B·u + b,
//! y = C·x + D·u + c, with named states, inputs and outputs, whose entries
//! are fixed numbers or named parameters. The inputs and outputs are record
//! channels (SI units, as every record channel: rad, rad/s, rad/s², load
//! factors). A fit starts the states from `initial_state` when the file
//! states it (whatever the states' names); without it, a state named like
//! a record channel starts from that channel's value at the first grid
//! point, any other from 0. Output error can estimate them instead
//! (`[methods.oem] estimate_initial_state = true`), and does so when a
//! state would start from a channel that carries a free output bias
//! ([`LinearStructure::started_through_a_bias`]).
//!
//! ```toml
//! kind = "linear"
//! name = "linear-lateral"
//! states = ["beta", "p", "r"]
//! inputs = ["aileron", "rudder"]
//! outputs = ["beta", "p", "r", "ny"]        # rows of C and D, and of output_bias
//! rate_outputs = { p_dot = "p", r_dot = "r" } # outputs that are state rates (after `outputs`)
//! interpolation = "auto"                    # inputs inside a step: "auto" (per input from its samples), "zoh" (held), "linear" (first-order hold) or { aileron = "linear" }
//! A = [["Yb", 0.0, -1.0], ["Lb", "Lp", "Lr"], ["Nb", "Np", "Nr"]]
//! B = [[0.0, "Ydr"], ["Lda", "Ldr"], ["Nda", "Ndr"]]
//! C = [[1, 0, 0], [0, 1, 0], [0, 0, 1], ["Cyb", 0, 0]]
//! D = [[0, 0], [0, 0], [0, 0], [0, "Cydr"]]   # default zeros
//! state_bias = [0, 0, 0]                    # b, default zeros
//! output_bias = [0, 0, 0, "ny0"]            # c, default zeros
//! initial_state = [0.0, 0.0, 0.0]           # x0, one number per state; default from the record
//! [parameters.Lp]
//! start = -2.0
//! lower = -10.0                             # optional bounds
//! upper = 0.0
//! [parameters.ny0]
//! start = 0.0
//! fixed = true                              # a parameter held at its start value
//! ```
//!
//! A parameter may set several entries (Z_w in A and in a_z's row of C);
//! each entry holds its value. The model is continuous in
//! time and discretised exactly ([`crate::model::linear::LinearStateSpace`]). The parameters'
//! start values are the model's own values: a linear flight
//! (`aeroid_eval::linear_flight`) flies them as its truth.

use crate::error::Result;
use crate::input_timing::InputInterpolation;
use crate::settings::MethodTables;
use aeroid_core::catalog;
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_record::FlightRecord;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The `kind` of a linear model file.
pub const KIND: &str = "linear";

/// One entry of a matrix as a file writes it: a fixed number or a parameter's name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Cell {
    Number(f64),
    Parameter(String),
}

/// A `[parameters.NAME]` table of a linear model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearParameter {
    pub start: f64,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fixed: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lower: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub upper: Option<f64>,
}

/// A linear model file as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearFile {
    pub kind: String,
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub states: Vec<String>,
    #[serde(default)]
    pub inputs: Vec<String>,
    #[serde(default)]
    pub outputs: Vec<String>,
    /// Output channel → the state whose rate it is.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub rate_outputs: BTreeMap<String, String>,
    #[serde(default)]
    pub interpolation: InputInterpolation,
    #[serde(rename = "A")]
    pub a: Vec<Vec<Cell>>,
    #[serde(rename = "B", default)]
    pub b: Vec<Vec<Cell>>,
    #[serde(rename = "C", default)]
    pub c: Vec<Vec<Cell>>,
    #[serde(rename = "D", default, skip_serializing_if = "Vec::is_empty")]
    pub d: Vec<Vec<Cell>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub state_bias: Vec<Cell>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub output_bias: Vec<Cell>,
    /// x₀, one number per state; None: from the record (module header).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_state: Option<Vec<f64>>,
    #[serde(default)]
    pub parameters: BTreeMap<String, LinearParameter>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub methods: MethodTables,
}

/// A validated linear model structure.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearStructure {
    pub name: String,
    pub path: PathBuf,
    pub file: LinearFile,
    pub states: Vec<String>,
    pub inputs: Vec<String>,
    /// Every output: those of C and D, then the rate outputs.
    pub outputs: Vec<String>,
    /// The matrices with every parameter at its start value.
    pub matrices: Matrices,
    /// The states whose rates are outputs (after C's), in `outputs` order.
    pub rate_states: Vec<usize>,
    /// x₀ as the file states it; None: from the record.
    pub initial_state: Option<DVector<f64>>,
    pub interpolation: InputInterpolation,
    /// Parameter names, in file (alphabetical) order, with the entries
    /// each sets (one or more, in file order: A, B, C, D, b, c).
    pub names: Vec<String>,
    pub entries: Vec<Vec<Entry>>,
    pub starts: Vec<f64>,
    pub free: Vec<bool>,
    pub bounds: Vec<(f64, f64)>,
    pub methods: MethodTables,
}

impl LinearStructure {
    /// Loads a linear structure by bundled name (`models/NAME.toml`) or path.
    pub fn load(reference: &str) -> Result<LinearStructure> {
        let path = catalog::resolve(reference, catalog::MODEL_FOLDER, None)?;
        let file: LinearFile = parse_toml(&path, &read_text(&path)?)?;
        LinearStructure::from_file(&file, &path)
    }

    /// Validates a parsed file; every problem is reported at once, named
    /// by its key (`A[1][2]`, `parameters.Lp`, `rate_outputs.p_dot`).
    pub fn from_file(file: &LinearFile, path: &Path) -> Result<LinearStructure> {
        let mut problems = FieldErrors::default();
        if file.kind != KIND {
            problems.push(
                "kind",
                format!("is '{}'; a linear model is \"{KIND}\"", file.kind),
            );
        }
        if file.states.is_empty() {
            problems.push("states", "a linear model needs at least one state");
        }
        for (field, names) in [
            ("states", &file.states),
            ("inputs", &file.inputs),
            ("outputs", &file.outputs),
        ] {
            check_names(field, names, &mut problems);
        }
        let (n, m, l) = (file.states.len(), file.inputs.len(), file.outputs.len());
        let mut reader = Reader {
            parameters: &file.parameters,
            used: BTreeMap::new(),
            problems: &mut problems,
        };
        let a = reader.matrix("A", &file.a, n, n, true);
        let b = reader.matrix("B", &file.b, n, m, m > 0);
        let c = reader.matrix("C", &file.c, l, n, l > 0);
        let d = reader.matrix("D", &file.d, l, m, false);
        let state_bias = reader.vector("state_bias", &file.state_bias, n);
        let output_bias = reader.vector("output_bias", &file.output_bias, l);
        let used = std::mem::take(&mut reader.used);
        let initial_state = read_initial_state(file.initial_state.as_deref(), n, &mut problems);
        let (outputs, rate_states) = read_rate_outputs(file, &mut problems);
        let Parameters {
            names,
            entries,
            starts,
            free,
            bounds,
        } = read_parameters(file, &used, &mut problems);
        let inputs: Vec<&str> = file.inputs.iter().map(String::as_str).collect();
        if let Err(error) = file.interpolation.check_channels(&inputs) {
            let text = error.to_string();
            problems.push(
                "interpolation",
                text.trim_start_matches("interpolation: ").to_string(),
            );
        }
        let mut matrices = Matrices {
            a,
            b,
            c,
            d,
            state_bias,
            output_bias,
        };
        for (set, &start) in entries.iter().zip(&starts) {
            for entry in set {
                *matrices.entry_mut(entry) = start;
            }
        }
        let structure = LinearStructure {
            name: file.name.clone(),
            path: path.to_path_buf(),
            file: file.clone(),
            states: file.states.clone(),
            inputs: file.inputs.clone(),
            outputs,
            matrices,
            rate_states,
            initial_state,
            interpolation: file.interpolation.clone(),
            names,
            entries,
            starts,
            free,
            bounds,
            methods: file.methods.clone(),
        };
        Ok(problems.finish(path, structure)?)
    }

    /// The parameters' start values: the model's own, a linear flight's truth.
    pub fn parameter_values(&self) -> DVector<f64> {
        DVector::from_column_slice(&self.starts)
    }

    /// The names of the free parameters.
    pub fn free_names(&self) -> Vec<String> {
        (0..self.names.len())
            .filter(|&i| self.free[i])
            .map(|i| self.names[i].clone())
            .collect()
    }

    /// The states a fit would start from a recorded channel that carries a
    /// free output bias: with no `initial_state` in the file, a state named
    /// like an output of C whose `output_bias` entry is a free parameter
    /// (y = x + c: the record holds x + c, not x).
    pub fn started_through_a_bias(&self) -> Vec<&str> {
        if self.initial_state.is_some() {
            return Vec::new();
        }
        let biased = |o: usize| {
            self.entries.iter().zip(&self.free).any(|(set, &free)| {
                free && set
                    .iter()
                    .any(|e| e.matrix == Matrix::OutputBias && e.row == o)
            })
        };
        self.states
            .iter()
            .filter(|state| {
                self.outputs[..self.matrices.c.nrows()]
                    .iter()
                    .position(|o| o == *state)
                    .is_some_and(biased)
            })
            .map(String::as_str)
            .collect()
    }

    /// The channels `record` lacks that a fit needs: the inputs and the outputs.
    pub fn missing_channels(
        &self,
        record: &FlightRecord,
    ) -> Vec<aeroid_core::refusal::MissingChannel> {
        let inputs = self
            .inputs
            .iter()
            .map(|n| (n, "an input of the linear model"));
        let outputs = self.outputs.iter().map(|n| (n, "a compared output"));
        inputs
            .chain(outputs)
            .filter(|(name, _)| record.channel(name).is_err())
            .map(|(name, purpose)| aeroid_core::refusal::MissingChannel {
                name: name.clone(),
                purpose: purpose.into(),
            })
            .collect()
    }
}

/// `initial_state` as a vector: one finite number per state.
fn read_initial_state(
    values: Option<&[f64]>,
    states: usize,
    problems: &mut FieldErrors,
) -> Option<DVector<f64>> {
    let values = values?;
    if values.len() != states {
        problems.push(
            "initial_state",
            format!(
                "must have {states} entries, one per state; it has {}",
                values.len()
            ),
        );
    } else if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        problems.push(format!("initial_state[{i}]"), "must be finite");
    }
    Some(DVector::from_column_slice(values))
}

/// Names must be present and distinct.
fn check_names(field: &str, names: &[String], problems: &mut FieldErrors) {
    let mut seen = BTreeSet::new();
    for (i, name) in names.iter().enumerate() {
        if name.trim().is_empty() {
            problems.push(format!("{field}[{i}]"), "is empty");
        } else if !seen.insert(name) {
            problems.push(format!("{field}[{i}]"), format!("'{name}' is named twice"));
        }
    }
}

/// The outputs with the rate outputs appended, and the state of each
/// rate output.
fn read_rate_outputs(file: &LinearFile, problems: &mut FieldErrors) -> (Vec<String>, Vec<usize>) {
    let mut outputs = file.outputs.clone();
    let mut rate_states = Vec::new();
    for (output, state) in &file.rate_outputs {
        let field = format!("rate_outputs.{output}");
        match file.states.iter().position(|s| s == state) {
            Some(i) => rate_states.push(i),
            None => problems.push(
                field.clone(),
                format!(
                    "unknown state '{state}'; states: {}",
                    file.states.join(", ")
                ),
            ),
        }
        if outputs.contains(output) || file.inputs.contains(output) {
            problems.push(field, format!("'{output}' is named twice"));
        }
        outputs.push(output.clone());
    }
    if outputs.is_empty() {
        problems.push("outputs", "a linear model needs at least one output");
    }
    (outputs, rate_states)
}

/// The parameters of a linear model file, in the file's order: each
/// name, the matrix entries it sets, its start value, whether it is free
/// and its bounds.
struct Parameters {
    names: Vec<String>,
    entries: Vec<Vec<Entry>>,
    starts: Vec<f64>,
    free: Vec<bool>,
    bounds: Vec<(f64, f64)>,
}

/// The file's parameters that set a matrix entry (`used`), their start
/// values and bounds checked.
fn read_parameters(
    file: &LinearFile,
    used: &BTreeMap<String, Vec<Entry>>,
    problems: &mut FieldErrors,
) -> Parameters {
    let mut names = Vec::new();
    let (mut entries, mut starts, mut free, mut bounds) = (vec![], vec![], vec![], vec![]);
    for (name, spec) in &file.parameters {
        let field = format!("parameters.{name}");
        let Some(set) = used.get(name) else {
            problems.push(field, "is not used in any matrix entry");
            continue;
        };
        let range = (
            spec.lower.unwrap_or(f64::NEG_INFINITY),
            spec.upper.unwrap_or(f64::INFINITY),
        );
        if !spec.start.is_finite()
            || range.0 >= range.1
            || !(range.0..=range.1).contains(&spec.start)
        {
            problems.push(
                field,
                "the start value must be finite and the bounds ordered around it",
            );
        }
        names.push(name.clone());
        entries.push(set.clone());
        starts.push(spec.start);
        free.push(!spec.fixed);
        bounds.push(range);
    }
    Parameters {
        names,
        entries,
        starts,
        free,
        bounds,
    }
}

/// Reads matrices, recording which entries each parameter sets.
struct Reader<'a> {
    parameters: &'a BTreeMap<String, LinearParameter>,
    used: BTreeMap<String, Vec<Entry>>,
    problems: &'a mut FieldErrors,
}

impl Reader<'_> {
    /// A rows × columns matrix; an absent optional one is zero.
    fn matrix(
        &mut self,
        field: &str,
        cells: &[Vec<Cell>],
        rows: usize,
        columns: usize,
        required: bool,
    ) -> DMatrix<f64> {
        let mut matrix = DMatrix::zeros(rows, columns);
        if cells.is_empty() && (!required || rows == 0 || columns == 0) {
            return matrix;
        }
        let which = match field {
            "A" => Matrix::A,
            "B" => Matrix::B,
            "C" => Matrix::C,
            _ => Matrix::D,
        };
        if cells.len() != rows || cells.iter().any(|row| row.len() != columns) {
            let shape: Vec<String> = cells.iter().map(|r| r.len().to_string()).collect();
            self.problems.push(
                field,
                format!(
                    "must be {rows}×{columns} (rows × columns); it has {} rows of [{}] entries",
                    cells.len(),
                    shape.join(", ")
                ),
            );
            return matrix;
        }
        for (i, row) in cells.iter().enumerate() {
            for (j, cell) in row.iter().enumerate() {
                let entry = Entry {
                    matrix: which,
                    row: i,
                    column: j,
                };
                matrix[(i, j)] = self.cell(&format!("{field}[{i}][{j}]"), cell, entry);
            }
        }
        matrix
    }

    /// A vector of `len` entries; an absent one is zero.
    fn vector(&mut self, field: &str, cells: &[Cell], len: usize) -> DVector<f64> {
        let mut vector = DVector::zeros(len);
        if cells.is_empty() {
            return vector;
        }
        if cells.len() != len {
            self.problems.push(
                field,
                format!("must have {len} entries; it has {}", cells.len()),
            );
            return vector;
        }
        let which = match field {
            "state_bias" => Matrix::StateBias,
            _ => Matrix::OutputBias,
        };
        for (i, cell) in cells.iter().enumerate() {
            let entry = Entry {
                matrix: which,
                row: i,
                column: 0,
            };
            vector[i] = self.cell(&format!("{field}[{i}]"), cell, entry);
        }
        vector
    }

    fn cell(&mut self, field: &str, cell: &Cell, entry: Entry) -> f64 {
        match cell {
            Cell::Number(value) if value.is_finite() => *value,
            Cell::Number(_) => {
                self.problems.push(field, "must be finite");
                0.0
            }
            Cell::Parameter(name) => {
                if !self.parameters.contains_key(name) {
                    self.problems.push(
                        field,
                        format!("'{name}' is not a declared parameter ([parameters.{name}] with its start value)"),
                    );
                } else {
                    self.used.entry(name.clone()).or_default().push(entry);
                }
                0.0
            }
        }
    }
}

/// Which matrix a parameter is an entry of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Matrix {
    A,
    B,
    C,
    D,
    /// b, the constant term of the state equations (column 0).
    StateBias,
    /// c, the constant term of the outputs C·x + D·u + c (column 0).
    OutputBias,
}

/// An entry (row, column) of one of the matrices that a parameter sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    pub matrix: Matrix,
    pub row: usize,
    pub column: usize,
}

impl std::fmt::Display for Entry {
    /// As the model file names it: `A[1][0]`, `state_bias[2]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.matrix {
            Matrix::StateBias => write!(f, "state_bias[{}]", self.row),
            Matrix::OutputBias => write!(f, "output_bias[{}]", self.row),
            matrix => write!(f, "{matrix:?}[{}][{}]", self.row, self.column),
        }
    }
}

/// A, B, C, D, b, c with θ written in.
#[derive(Debug, Clone, PartialEq)]
pub struct Matrices {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
    pub state_bias: DVector<f64>,
    pub output_bias: DVector<f64>,
}

impl Matrices {
    pub(crate) fn entry_mut(&mut self, entry: &Entry) -> &mut f64 {
        match entry.matrix {
            Matrix::A => &mut self.a[(entry.row, entry.column)],
            Matrix::B => &mut self.b[(entry.row, entry.column)],
            Matrix::C => &mut self.c[(entry.row, entry.column)],
            Matrix::D => &mut self.d[(entry.row, entry.column)],
            Matrix::StateBias => &mut self.state_bias[entry.row],
            Matrix::OutputBias => &mut self.output_bias[entry.row],
        }
    }

    /// ẋ = A·x + B·u + b.
    pub fn rates(&self, x: &DVector<f64>, u: &DVector<f64>) -> DVector<f64> {
        &self.a * x + &self.b * u + &self.state_bias
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
kind = "linear"
name = "test"
states = ["alpha", "q"]
inputs = ["elevator"]
outputs = ["alpha", "q"]
rate_outputs = { q_dot = "q" }
A = [["Za", 1.0], ["Ma", "Mq"]]
B = [[0.0], ["Mde"]]
C = [[1, 0], [0, 1]]
output_bias = [0.0, "q0"]
[parameters.Za]
start = -1.0
[parameters.Ma]
start = -5.0
[parameters.Mq]
start = -2.0
lower = -10.0
upper = 0.0
[parameters.Mde]
start = -8.0
[parameters.q0]
start = 0.0
fixed = true
"#;

    fn parse(text: &str) -> Result<LinearStructure> {
        let path = Path::new("models/test.toml");
        let file: LinearFile = parse_toml(path, text)?;
        LinearStructure::from_file(&file, path)
    }

    #[test]
    fn a_good_file_gives_its_matrices_and_parameters() {
        let s = parse(GOOD).unwrap();
        assert_eq!(s.names, ["Ma", "Mde", "Mq", "Za", "q0"]);
        assert_eq!(s.outputs, ["alpha", "q", "q_dot"]);
        assert_eq!(s.matrices.a[(1, 1)], -2.0);
        assert_eq!(s.matrices.b[(1, 0)], -8.0);
        assert_eq!(s.free, [true, true, true, true, false]);
        assert_eq!(s.bounds[2], (-10.0, 0.0));
        assert_eq!(s.rate_states, [1]);
        assert_eq!(s.initial_state, None);
        let stated = parse(&GOOD.replace(
            "[parameters.Za]",
            "initial_state = [0.1, -0.2]\n[parameters.Za]",
        ))
        .unwrap();
        assert_eq!(stated.initial_state.unwrap().as_slice(), [0.1, -0.2]);
    }

    /// A parameter may set several entries (Z_w in A and in C, Z_δe in B
    /// and in D): every one of them holds its value.
    #[test]
    fn a_parameter_may_set_several_entries() {
        let text = GOOD
            .replace(
                r#"outputs = ["alpha", "q"]"#,
                r#"outputs = ["alpha", "q", "az"]"#,
            )
            .replace("C = [[1, 0], [0, 1]]", r#"C = [[1, 0], [0, 1], ["Za", 0]]"#)
            .replace(
                r#"output_bias = [0.0, "q0"]"#,
                r#"output_bias = [0.0, "q0", 0.0]"#,
            )
            .replace(
                "B = [[0.0], [\"Mde\"]]",
                "B = [[0.0], [\"Mde\"]]\nD = [[0.0], [0.0], [\"Mde\"]]",
            );
        let s = parse(&text).unwrap();
        let za = s.names.iter().position(|n| n == "Za").unwrap();
        let mde = s.names.iter().position(|n| n == "Mde").unwrap();
        let named: Vec<String> = s.entries[za].iter().map(Entry::to_string).collect();
        assert_eq!(named, ["A[0][0]", "C[2][0]"]);
        assert_eq!(s.entries[mde].len(), 2);
        assert_eq!((s.matrices.a[(0, 0)], s.matrices.c[(2, 0)]), (-1.0, -1.0));
        assert_eq!((s.matrices.b[(1, 0)], s.matrices.d[(2, 0)]), (-8.0, -8.0));
    }

    /// Every kind of mistake is reported, named by its key, all at once.
    #[test]
    fn bad_files_name_the_key() {
        let cases = [
            (GOOD.replace(r#"["Za", 1.0], "#, ""), "A: must be 2×2"),
            (
                GOOD.replace(r#"q_dot = "q""#, r#"q_dot = "w""#),
                "rate_outputs.q_dot: unknown state 'w'",
            ),
            (
                GOOD.replace(r#"["Mde"]"#, r#"["Mdx"]"#),
                "B[1][0]: 'Mdx' is not a declared parameter",
            ),
            (
                GOOD.replace(r#"["Mde"]"#, "[1.0]"),
                "parameters.Mde: is not used",
            ),
            (
                GOOD.replace("lower = -10.0", "lower = 1.0"),
                "parameters.Mq: the start value",
            ),
            (
                GOOD.replace(
                    r#"outputs = ["alpha", "q"]"#,
                    r#"outputs = ["alpha", "alpha"]"#,
                ),
                "outputs[1]: 'alpha' is named twice",
            ),
            (
                GOOD.replace(r#"output_bias = [0.0, "q0"]"#, r#"output_bias = ["q0"]"#),
                "output_bias: must have 2 entries",
            ),
            (
                GOOD.replace(r#"kind = "linear""#, r#"kind = "lineal""#),
                "kind: is 'lineal'",
            ),
            (
                GOOD.replace("[parameters.Za]", "initial_state = [0.1]\n[parameters.Za]"),
                "initial_state: must have 2 entries",
            ),
        ];
        for (text, expected) in cases {
            let error = parse(&text).unwrap_err().to_string();
            assert!(error.contains("models/test.toml"), "{error}");
            assert!(
                error.contains(expected),
                "expected '{expected}' in: {error}"
            );
        }
    }

    #[test]
    fn a_misspelt_key_is_a_toml_error_with_its_line() {
        let error = parse(&GOOD.replace("states =", "stats ="))
            .unwrap_err()
            .to_string();
        assert!(error.contains("line") && error.contains("stats"), "{error}");
    }
}
