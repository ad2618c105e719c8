//! The estimation problem: everything an estimator reads, resolved — the
//! record or records (every channel in SI at its own sample instants, NaN a
//! dropout), the model structure (its file and its aircraft's file, its
//! free and fixed parameters with start values and bounds, the integrated
//! states, the pseudo-controls and the compared outputs) and the method's
//! settings (its `[methods.NAME]` tables merged: model file, then scenario,
//! then study or gate case).
//!
//! It serialises to JSON and reads back identically: the contract for
//! estimators written in other languages. The JSON holds the source files
//! of the model (so aeroid rebuilds the same structure from it) beside the
//! resolved view a foreign program reads directly (`parameters`,
//! `integrate`, `pseudo_controls`, `outputs`). A dropout is `null`, an
//! unbounded side of a parameter's range is `null`.
//!
//! ```json
//! { "format": "aeroid-estimation-problem-1", "method": "oem",
//!   "settings": { "estimate_initial_state": true },
//!   "parameters": [ { "name": "Cl_beta", "start": -0.05, "free": true,
//!                     "lower": null, "upper": null } ],
//!   "integrate": ["beta", "p", "r", "roll"], "pseudo_controls": ["airspeed", …],
//!   "outputs": ["beta", "p", "r", "roll", "ny"],
//!   "model": { "structure": { … model file … }, "aircraft": { … aircraft file … } },
//!   "records": [ { "scenario": "…", "channels": [ { "name": "p", "unit": "rad/s",
//!                  "rate": 25.0, "times": [ … ], "values": [ … ] } ] } ] }
//! ```

use crate::error::{Error, Result};
use crate::linear_structure::{LinearFile, LinearStructure};
use crate::settings::{MethodTables, Settings, merge_settings};
use crate::structure::{ModelStructure, Structure, StructureFile, ZERO_SOURCE};
use aeroid_record::FlightRecord;
use aeroid_sim::aircraft::AircraftFile;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format tag of a problem's JSON.
pub const FORMAT: &str = "aeroid-estimation-problem-1";

/// The end of a channel's source once the problem has unwrapped it.
pub(crate) const UNWRAPPED_SOURCE: &str = "unwrapped for the estimators";

/// Unwraps every heading or direction channel (yaw, track, wind direction:
/// recorders wrap them at 360°) whose successive samples jump by more than
/// 180°, so that an estimator comparing or differentiating it sees a
/// continuous angle; its source then ends with [`UNWRAPPED_SOURCE`].
fn unwrap_headings(records: &mut [FlightRecord]) {
    for channel in records.iter_mut().flat_map(|r| r.channels.iter_mut()) {
        let wraps = aeroid_record::derived::measurand(&channel.name).is_some_and(|m| m.wraps);
        if !wraps {
            continue;
        }
        let mut previous: Option<f64> = None;
        let jumps = channel.values.iter().filter(|v| !v.is_nan()).any(|&v| {
            let jump = previous.is_some_and(|p| (v - p).abs() > std::f64::consts::PI);
            previous = Some(v);
            jump
        });
        if jumps {
            aeroid_record::unwrap_angles(&mut channel.values);
            channel.source = format!("{}; {UNWRAPPED_SOURCE}", channel.source);
        }
    }
}

/// One estimator's problem.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimationProblem {
    /// The registered method that solves it.
    pub method: String,
    /// One record, or several manoeuvres fitted together.
    pub records: Vec<FlightRecord>,
    /// The model structure, of either kind.
    pub structure: Structure,
    /// The method's settings: the merged `[methods.NAME]` tables.
    pub settings: Settings,
    /// A note per record split at its gaps into separate manoeuvres
    /// ([`FlightRecord::split_at_gaps`]).
    pub gap_notes: Vec<String>,
}

impl EstimationProblem {
    /// The problem of `method` on `records`, its settings the structure's
    /// `[methods.NAME]` table overridden key by key by each of `layers`
    /// (scenario, then study or gate case). The settings are checked
    /// against the method where it is found: a program builds a problem
    /// with [`crate::registry::Registry::problem`].
    pub fn new(
        method: &str,
        records: Vec<FlightRecord>,
        structure: impl Into<Structure>,
        layers: &[&MethodTables],
    ) -> Result<EstimationProblem> {
        let structure = structure.into();
        let mut all = vec![structure.methods()];
        all.extend_from_slice(layers);
        let settings = merge_settings(method, &all);
        if records.is_empty() {
            return Err(Error::File {
                reason: format!("{method} on model '{}': no record given", structure.name()),
            });
        }
        // A record with gaps is fitted as the manoeuvres between them.
        let mut gap_notes = Vec::new();
        let records: Vec<FlightRecord> = records
            .into_iter()
            .flat_map(|record| {
                let (pieces, note) = record.split_at_gaps();
                gap_notes.extend(note);
                pieces
            })
            .collect();
        let mut records = match &structure {
            Structure::SixDof(six_dof) => six_dof.with_zero_channels(records),
            Structure::Linear(_) => records,
        };
        unwrap_headings(&mut records);
        Ok(EstimationProblem {
            method: method.to_string(),
            records,
            structure,
            settings,
            gap_notes,
        })
    }

    /// What the problem changed for the estimator: a note per channel of
    /// zeros the model's `zero_when_absent` put in a record, and per
    /// heading or direction it unwrapped.
    pub fn notes(&self) -> Vec<String> {
        let changed = self.records.iter().flat_map(|record| {
            record.channels.iter().filter_map(|c| {
                if c.source.starts_with(ZERO_SOURCE) {
                    Some(format!(
                        "no '{}' channel in '{}': held at 0 (the model's zero_when_absent)",
                        c.name, record.scenario
                    ))
                } else if c.source.ends_with(UNWRAPPED_SOURCE) {
                    Some(format!(
                        "'{}' in '{}': unwrapped (the record wraps it at 360°; the estimator sees a continuous angle)",
                        c.name, record.scenario
                    ))
                } else {
                    None
                }
            })
        });
        self.gap_notes.iter().cloned().chain(changed).collect()
    }

    /// The first (or only) record.
    pub fn record(&self) -> &FlightRecord {
        &self.records[0]
    }

    /// The problem as JSON (see the module documentation).
    pub fn to_json(&self) -> Result<String> {
        let mut text = Vec::new();
        self.serialize_into(&mut text).map_err(|e| Error::File {
            reason: format!("estimation problem as JSON: {e}"),
        })?;
        String::from_utf8(text).map_err(|e| Error::File {
            reason: format!("estimation problem as JSON: {e}"),
        })
    }

    /// Writes the JSON of [`EstimationProblem::to_json`] to `writer`: the
    /// document through serde, its records (the samples, most of it) by
    /// [`write_records`] as its last key.
    fn serialize_into<W: std::io::Write>(&self, mut writer: W) -> serde_json::Result<()> {
        let samples: usize = self
            .records
            .iter()
            .flat_map(|r| &r.channels)
            .map(|c| 2 * c.times.len())
            .sum();
        let mut text = Vec::with_capacity(16_384 + 24 * samples);
        let mut serializer = serde_json::Serializer::with_formatter(&mut text, Layout::default());
        Document::of(self).serialize(&mut serializer)?;
        // The document without records ends in its closing "\n}".
        let end = text.len() - b"\n}".len();
        text.truncate(end);
        text.extend_from_slice(b",\n  \"records\": ");
        write_records(&self.records, 1, &mut text);
        text.extend_from_slice(b"\n}");
        writer.write_all(&text).map_err(serde_json::Error::io)
    }

    /// Reads a problem written by [`EstimationProblem::to_json`]; `origin`
    /// names the file in errors. The structure is rebuilt from the files
    /// the JSON carries and must agree with its resolved view.
    pub fn from_json(text: &str, origin: &Path) -> Result<EstimationProblem> {
        let document: Document = serde_json::from_str(text).map_err(|e| Error::File {
            reason: format!(
                "{}: not an estimation problem: line {}, column {}: {e}",
                origin.display(),
                e.line(),
                e.column()
            ),
        })?;
        if document.format != FORMAT {
            return Err(Error::File {
                reason: format!(
                    "{}: format '{}' is not '{FORMAT}'",
                    origin.display(),
                    document.format
                ),
            });
        }
        let path = PathBuf::from(&document.model.path);
        let structure = document.model.structure(&path)?;
        let resolved = Document::parameters(&structure);
        let aircraft_agrees = match &structure {
            Structure::SixDof(six_dof) => document
                .aircraft
                .as_ref()
                .is_none_or(|view| *view == AircraftView::of(six_dof)),
            Structure::Linear(_) => document.aircraft.is_none(),
        };
        if resolved != document.parameters || !aircraft_agrees {
            return Err(Error::File {
                reason: format!(
                    "{}: the parameters or the aircraft do not agree with the model files they came with",
                    origin.display()
                ),
            });
        }
        if document.records.is_empty() {
            return Err(Error::File {
                reason: format!("{}: no record", origin.display()),
            });
        }
        for record in document.records.iter() {
            record.validate(origin)?;
        }
        Ok(EstimationProblem {
            method: document.method,
            records: document.records,
            structure,
            settings: document.settings,
            gap_notes: Vec::new(),
        })
    }

    /// Writes [`EstimationProblem::to_json`] into the file `path`.
    pub fn write_json(&self, path: &Path) -> Result<()> {
        let io = |source: std::io::Error| aeroid_core::Error::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut writer = std::fs::File::create(path).map_err(io)?;
        self.serialize_into(&mut writer)
            .map_err(|e| match e.io_error_kind() {
                Some(kind) => io(std::io::Error::new(kind, e.to_string())).into(),
                None => Error::File {
                    reason: format!("estimation problem as JSON: {e}"),
                },
            })?;
        Ok(std::io::Write::flush(&mut writer).map_err(io)?)
    }

    pub fn read_json(path: &Path) -> Result<EstimationProblem> {
        EstimationProblem::from_json(&aeroid_core::error::read_text(path)?, path)
    }
}

/// One parameter of the model as the problem states it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ProblemParameter {
    pub name: String,
    pub start: f64,
    pub free: bool,
    /// None: unbounded below.
    pub lower: Option<f64>,
    /// None: unbounded above.
    pub upper: Option<f64>,
}

/// The model's source files: a 6-DOF structure with its aircraft, or a
/// linear model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelDocument {
    /// Where the model file was read from (named in errors).
    path: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    structure: Option<StructureFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    aircraft: Option<AircraftFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    linear: Option<LinearFile>,
}

impl ModelDocument {
    fn of(structure: &Structure) -> ModelDocument {
        match structure {
            Structure::SixDof(s) => ModelDocument {
                path: s.path.display().to_string(),
                structure: Some(s.file.clone()),
                aircraft: Some(s.aircraft_file.clone()),
                linear: None,
            },
            Structure::Linear(s) => ModelDocument {
                path: s.path.display().to_string(),
                structure: None,
                aircraft: None,
                linear: Some(s.file.clone()),
            },
        }
    }

    /// The structure rebuilt from the files.
    fn structure(&self, path: &Path) -> Result<Structure> {
        match (&self.structure, &self.aircraft, &self.linear) {
            (Some(structure), Some(aircraft), None) => {
                ModelStructure::from_parts(structure, aircraft, path)
                    .map(|s| Structure::SixDof(Box::new(s)))
            }
            (None, None, Some(linear)) => {
                LinearStructure::from_file(linear, path).map(|s| Structure::Linear(Box::new(s)))
            }
            _ => Err(Error::File {
                reason: format!(
                    "{}: the model holds either `structure` and `aircraft` (6-DOF) or `linear`",
                    path.display()
                ),
            }),
        }
    }
}

/// The JSON form. Its records are written by [`write_records`], after the
/// rest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Document {
    format: String,
    method: String,
    settings: Settings,
    parameters: Vec<ProblemParameter>,
    integrate: Vec<String>,
    pseudo_controls: Vec<String>,
    outputs: Vec<String>,
    /// The aircraft in SI, as the model uses it (read for programs; on
    /// reading it must agree with the files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    aircraft: Option<AircraftView>,
    model: ModelDocument,
    #[serde(skip_serializing)]
    records: Vec<FlightRecord>,
}

/// The aircraft and the model's conventions in SI, for programs that read
/// the problem: mass (kg), wing area (m²), span and chord (m), the inertia
/// tensor's Ixx, Iyy, Izz, Ixz (kg·m²), the rate normalisation (`2V`: p̂ =
/// p·b/(2V)) and the speed it uses (`airspeed` or `reference`, then
/// `reference_airspeed`, m/s, null when the model sets none).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct AircraftView {
    pub mass: f64,
    pub wing_area: f64,
    pub span: f64,
    pub chord: f64,
    pub ixx: f64,
    pub iyy: f64,
    pub izz: f64,
    pub ixz: f64,
    pub rate_normalization: String,
    pub rate_speed: String,
    /// None (null) when the model sets none.
    pub reference_airspeed: Option<f64>,
}

impl AircraftView {
    fn of(structure: &ModelStructure) -> AircraftView {
        let aircraft = &structure.aircraft;
        let inertia = &aircraft.mass.inertia;
        let aero = &structure.file.aero;
        AircraftView {
            mass: aircraft.mass.mass,
            wing_area: aircraft.wing_area,
            span: aircraft.geometry.span,
            chord: aircraft.geometry.chord,
            ixx: inertia[(0, 0)],
            iyy: inertia[(1, 1)],
            izz: inertia[(2, 2)],
            ixz: -inertia[(0, 2)],
            rate_normalization: value_text(&aero.rate_normalization),
            rate_speed: value_text(&aero.rate_speed),
            reference_airspeed: Some(aircraft.aero.reference_airspeed).filter(|v| v.is_finite()),
        }
    }
}

/// A setting's text as the files write it.
fn value_text<T: Serialize>(value: &T) -> String {
    serde_json::to_value(value)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

impl Document {
    /// The problem's document without its records.
    fn of(problem: &EstimationProblem) -> Document {
        let structure = &problem.structure;
        let (integrate, pseudo_controls, aircraft) = match structure {
            Structure::SixDof(s) => (
                s.file.integrate.clone(),
                s.pseudo_controls().into_iter().map(String::from).collect(),
                Some(AircraftView::of(s)),
            ),
            Structure::Linear(s) => (s.states.clone(), s.inputs.clone(), None),
        };
        Document {
            format: FORMAT.to_string(),
            method: problem.method.clone(),
            settings: problem.settings.clone(),
            parameters: Document::parameters(structure),
            integrate,
            pseudo_controls,
            outputs: structure.outputs().to_vec(),
            aircraft,
            model: ModelDocument::of(structure),
            records: Vec::new(),
        }
    }

    fn parameters(structure: &Structure) -> Vec<ProblemParameter> {
        let (names, starts, free, bounds) = match structure {
            Structure::SixDof(s) => {
                let parameters = &s.aircraft.aero.parameters;
                (parameters.names(), parameters.values(), &s.free, &s.bounds)
            }
            Structure::Linear(s) => (&s.names[..], &s.starts[..], &s.free, &s.bounds),
        };
        let finite = |v: f64| v.is_finite().then_some(v);
        names
            .iter()
            .zip(starts)
            .enumerate()
            .map(|(i, (name, &start))| ProblemParameter {
                name: name.clone(),
                start,
                free: free[i],
                lower: finite(bounds[i].0),
                upper: finite(bounds[i].1),
            })
            .collect()
    }
}

/// serde_json's pretty layout (one key or value per line, two-space
/// indent), except that an array of numbers (and nulls: dropouts) stands on
/// one line: `"times": [0, 0.04, 0.08]`. Line-oriented readers still find
/// every key on a line of its own; a record's samples take a line per
/// array instead of one per number.
#[derive(Default)]
struct Layout {
    /// Open arrays and objects, innermost last.
    open: Vec<Open>,
    /// A value of the innermost array is about to start (`true`: the first).
    pending: Option<bool>,
}

struct Open {
    /// An array of numbers on one line (decided by its first value).
    inline: bool,
    has_value: bool,
}

impl Layout {
    const INDENT: &'static [u8] = b"  ";

    fn newline<W: ?Sized + std::io::Write>(&self, writer: &mut W) -> std::io::Result<()> {
        writer.write_all(b"\n")?;
        for _ in 0..self.open.len() {
            writer.write_all(Self::INDENT)?;
        }
        Ok(())
    }

    /// Writes the separator of a pending array value; `number`: the value
    /// is a number or null.
    fn start_value<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        number: bool,
    ) -> std::io::Result<()> {
        let Some(first) = self.pending.take() else {
            return Ok(());
        };
        let Some(array) = self.open.last_mut() else {
            return Ok(());
        };
        if first {
            array.inline = number;
        }
        match (array.inline, first) {
            (true, true) => Ok(()),
            (true, false) => writer.write_all(b", "),
            (false, first) => {
                if !first {
                    writer.write_all(b",")?;
                }
                self.newline(writer)
            }
        }
    }

    fn open<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        bracket: &[u8],
    ) -> std::io::Result<()> {
        self.start_value(writer, false)?;
        self.open.push(Open {
            inline: false,
            has_value: false,
        });
        writer.write_all(bracket)
    }

    /// The innermost array or object holds a value.
    fn mark_value(&mut self) {
        if let Some(open) = self.open.last_mut() {
            open.has_value = true;
        }
    }

    fn close<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        bracket: &[u8],
    ) -> std::io::Result<()> {
        let open = self.open.pop();
        if open.is_some_and(|o| o.has_value && !o.inline) {
            self.newline(writer)?;
        }
        writer.write_all(bracket)
    }
}

/// A scalar's writer: the pending separator first, then serde_json's own.
macro_rules! scalar {
    ($($name:ident($($arg:ident: $ty:ty),*) $number:expr;)*) => {$(
        fn $name<W: ?Sized + std::io::Write>(&mut self, writer: &mut W $(, $arg: $ty)*) -> std::io::Result<()> {
            self.start_value(writer, $number)?;
            serde_json::ser::CompactFormatter.$name(writer $(, $arg)*)
        }
    )*};
}

impl serde_json::ser::Formatter for Layout {
    scalar! {
        write_null() true;
        write_bool(value: bool) false;
        write_i8(value: i8) true;
        write_i16(value: i16) true;
        write_i32(value: i32) true;
        write_i64(value: i64) true;
        write_i128(value: i128) true;
        write_u8(value: u8) true;
        write_u16(value: u16) true;
        write_u32(value: u32) true;
        write_u64(value: u64) true;
        write_u128(value: u128) true;
        write_f32(value: f32) true;
        write_f64(value: f64) true;
        write_number_str(value: &str) true;
        begin_string() false;
        write_byte_array(value: &[u8]) false;
        write_raw_fragment(fragment: &str) false;
    }

    fn begin_array<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.open(writer, b"[")
    }

    fn end_array<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.close(writer, b"]")
    }

    fn begin_array_value<W: ?Sized + std::io::Write>(
        &mut self,
        _writer: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        self.pending = Some(first);
        Ok(())
    }

    fn end_array_value<W: ?Sized + std::io::Write>(
        &mut self,
        _writer: &mut W,
    ) -> std::io::Result<()> {
        self.mark_value();
        Ok(())
    }

    fn begin_object<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.open(writer, b"{")
    }

    fn end_object<W: ?Sized + std::io::Write>(&mut self, writer: &mut W) -> std::io::Result<()> {
        self.close(writer, b"}")
    }

    fn begin_object_key<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        if !first {
            writer.write_all(b",")?;
        }
        self.newline(writer)
    }

    fn begin_object_value<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
    ) -> std::io::Result<()> {
        writer.write_all(b": ")
    }

    fn end_object_value<W: ?Sized + std::io::Write>(
        &mut self,
        _writer: &mut W,
    ) -> std::io::Result<()> {
        self.mark_value();
        Ok(())
    }
}

/// `records` as JSON in [`Layout`]'s layout, `depth` levels in (written
/// by hand: a problem's samples are most of its JSON). The text equals
/// serde's serialisation of the records with [`Layout`] byte for byte (a
/// test checks it); a channel's times equal to the channel's before are
/// copied as text.
fn write_records(records: &[FlightRecord], depth: usize, out: &mut Vec<u8>) {
    use json_text::{array, key, newline, string};
    let mut digits = zmij::Buffer::new();
    array(out, depth, records, |out, record| {
        out.push(b'{');
        let inner = depth + 2;
        key(out, inner, true, "scenario");
        string(out, &record.scenario);
        key(out, inner, false, "seed");
        match record.seed {
            Some(seed) => out.extend_from_slice(seed.to_string().as_bytes()),
            None => out.extend_from_slice(b"null"),
        }
        key(out, inner, false, "profile");
        string(out, &record.profile);
        key(out, inner, false, "absent");
        array(out, inner, &record.absent, |out, name| string(out, name));
        key(out, inner, false, "channels");
        write_channels(&record.channels, inner, out, &mut digits);
        newline(out, depth + 1);
        out.push(b'}');
    });
}

/// A record's `channels` as a JSON array, `inner` levels in (the
/// record's fields' depth).
fn write_channels(
    channels: &[aeroid_record::Channel],
    inner: usize,
    out: &mut Vec<u8>,
    digits: &mut zmij::Buffer,
) {
    use json_text::{array, key, newline, number, numbers, string};
    let mut times: Option<(&[f64], std::ops::Range<usize>)> = None;
    array(out, inner, channels, |out, channel| {
        out.push(b'{');
        let fields = inner + 2;
        key(out, fields, true, "name");
        string(out, &channel.name);
        key(out, fields, false, "unit");
        string(out, &channel.unit);
        key(out, fields, false, "rate");
        number(out, digits, channel.rate);
        key(out, fields, false, "resolution");
        match channel.resolution {
            Some(resolution) => number(out, digits, resolution),
            None => out.extend_from_slice(b"null"),
        }
        key(out, fields, false, "source");
        string(out, &channel.source);
        key(out, fields, false, "times");
        match &times {
            Some((previous, text)) if *previous == channel.times.as_slice() => {
                out.extend_from_within(text.clone());
            }
            _ => {
                let start = out.len();
                numbers(out, digits, &channel.times);
                times = Some((&channel.times, start..out.len()));
            }
        }
        key(out, fields, false, "values");
        numbers(out, digits, &channel.values);
        newline(out, inner + 1);
        out.push(b'}');
    });
}

/// The pieces of the JSON [`write_records`] writes by hand.
mod json_text {
    use super::Layout;

    /// A new line, `depth` levels in.
    pub(super) fn newline(out: &mut Vec<u8>, depth: usize) {
        out.push(b'\n');
        for _ in 0..depth {
            out.extend_from_slice(Layout::INDENT);
        }
    }

    /// `text` as a JSON string.
    pub(super) fn string(out: &mut Vec<u8>, text: &str) {
        // Writing a string into a Vec cannot fail.
        let _ = serde_json::to_writer(&mut *out, text);
    }

    /// `value` in its shortest round-trip digits (null when not finite).
    pub(super) fn number(out: &mut Vec<u8>, digits: &mut zmij::Buffer, value: f64) {
        if value.is_finite() {
            out.extend_from_slice(digits.format_finite(value).as_bytes());
        } else {
            out.extend_from_slice(b"null");
        }
    }

    /// `items` as a JSON array `depth` levels in, each on a line of its own
    /// one level further in, written by `item`; `[]` when empty.
    pub(super) fn array<'a, T>(
        out: &mut Vec<u8>,
        depth: usize,
        items: &'a [T],
        mut item: impl FnMut(&mut Vec<u8>, &'a T),
    ) {
        if items.is_empty() {
            out.extend_from_slice(b"[]");
            return;
        }
        out.push(b'[');
        for (i, each) in items.iter().enumerate() {
            if i > 0 {
                out.push(b',');
            }
            newline(out, depth + 1);
            item(out, each);
        }
        newline(out, depth);
        out.push(b']');
    }

    /// `values` as a JSON array on one line.
    pub(super) fn numbers(out: &mut Vec<u8>, digits: &mut zmij::Buffer, values: &[f64]) {
        out.push(b'[');
        for (k, &value) in values.iter().enumerate() {
            if k > 0 {
                out.extend_from_slice(b", ");
            }
            number(out, digits, value);
        }
        out.push(b']');
    }

    /// The key `name` of an object's field, `depth` levels in, after a comma
    /// unless it is the `first`.
    pub(super) fn key(out: &mut Vec<u8>, depth: usize, first: bool, name: &str) {
        if !first {
            out.push(b',');
        }
        newline(out, depth);
        string(out, name);
        out.extend_from_slice(b": ");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_record::Channel;

    /// A heading that the recorder wraps at 360° reaches the estimators
    /// continuous (359.7° → 0.3° is +0.6°, not −359.4°), across a dropout
    /// too, and the problem says so; an angle that does not wrap (pitch)
    /// and a heading without a jump are left as they are.
    #[test]
    fn wrapped_headings_are_unwrapped_for_the_estimators() {
        let degrees = |values: &[f64]| values.iter().map(|v| v.to_radians()).collect::<Vec<_>>();
        let channel = |name: &str, values: Vec<f64>| Channel {
            name: name.into(),
            unit: "rad".into(),
            rate: 1.0,
            resolution: None,
            source: "profile \"qar\"".into(),
            times: (0..values.len()).map(|i| i as f64).collect(),
            values,
        };
        let mut records = vec![FlightRecord {
            scenario: "turn".into(),
            seed: None,
            profile: "qar".into(),
            absent: Vec::new(),
            channels: vec![
                channel("yaw", degrees(&[359.4, 359.7, 0.3, f64::NAN, 1.2, 359.0])),
                channel("pitch", degrees(&[-179.0, 179.0, 0.0, 1.0, 2.0, 3.0])),
                channel("track", degrees(&[10.0, 11.0, 12.0, 13.0, 14.0, 15.0])),
            ],
            bridge_gaps: false,
        }];
        unwrap_headings(&mut records);
        let yaw = &records[0].channels[0];
        let expected = degrees(&[359.4, 359.7, 360.3, f64::NAN, 361.2, 359.0]);
        for (got, want) in yaw.values.iter().zip(&expected) {
            assert!(
                (got.is_nan() && want.is_nan()) || (got - want).abs() < 1e-12,
                "{:?}",
                yaw.values
            );
        }
        assert!(yaw.source.ends_with(UNWRAPPED_SOURCE));
        assert_eq!(
            records[0].channels[1].values,
            degrees(&[-179.0, 179.0, 0.0, 1.0, 2.0, 3.0])
        );
        assert!(!records[0].channels[2].source.ends_with(UNWRAPPED_SOURCE));
        let problem = EstimationProblem::new(
            "oem",
            records,
            crate::structure::Structure::load("attas-lateral").unwrap(),
            &[],
        )
        .unwrap();
        assert_eq!(
            problem.notes(),
            [
                "'yaw' in 'turn': unwrapped (the record wraps it at 360°; the estimator sees a continuous angle)"
            ]
        );
    }

    /// The hand-written records equal serde's, with dropouts, an unset
    /// resolution and seed, absent quantities, shared and own time bases.
    #[test]
    fn records_are_written_as_serde_writes_them() {
        let channel = |name: &str, times: Vec<f64>, values: Vec<f64>| Channel {
            name: name.into(),
            unit: "rad/s".into(),
            rate: 25.0,
            resolution: Some(0.01),
            source: "profile \"x\", p".into(),
            times,
            values,
        };
        let base = vec![0.0, 0.04, 0.08];
        let first = FlightRecord {
            scenario: "a \u{3b1} scenario".into(),
            seed: Some(u64::MAX),
            profile: "flight-test-25hz".into(),
            absent: vec!["p".into(), "q".into()],
            channels: vec![
                channel("p", base.clone(), vec![1.0, f64::NAN, -2.5e-7]),
                channel("q", base.clone(), vec![0.1, 0.2, 0.30000000000000004]),
                channel("r", vec![0.01, 1.0], vec![3.0, 1e300]),
                Channel {
                    resolution: None,
                    ..channel("roll", base.clone(), vec![-0.0, 0.0, 2.0])
                },
            ],
            bridge_gaps: false,
        };
        let second = FlightRecord {
            seed: None,
            absent: Vec::new(),
            channels: vec![channel("beta", vec![0.5], vec![f64::NAN])],
            ..first.clone()
        };
        for records in [vec![], vec![first.clone()], vec![first, second]] {
            let mut serde = Vec::new();
            let mut serializer = serde_json::Serializer::with_formatter(
                &mut serde,
                Layout {
                    open: vec![Open {
                        inline: false,
                        has_value: true,
                    }],
                    pending: None,
                },
            );
            records.serialize(&mut serializer).unwrap();
            let mut ours = Vec::new();
            write_records(&records, 1, &mut ours);
            assert_eq!(
                String::from_utf8(ours).unwrap(),
                String::from_utf8(serde).unwrap()
            );
        }
    }
}
