//! Every data folder aeroid reads by name, and where they are found, so
//! that adding a file never needs a recompile: the folder named by
//! `AEROID_DATA`, else the current folder if it holds `aircraft/` or
//! `scenarios/`, else the source tree aeroid was built from.

use crate::error::{Error, Result};
use crate::paths;
use std::path::{Path, PathBuf};

pub const AIRCRAFT_FOLDER: &str = "aircraft";
pub const SCENARIO_FOLDER: &str = "scenarios";
/// Recorder (sensor) profiles, `recorders/*.toml`.
pub const RECORDER_FOLDER: &str = "recorders";
/// Monte Carlo study files, `studies/*.toml`.
pub const STUDY_FOLDER: &str = "studies";
/// Postulated model structures, `models/*.toml`.
pub const MODEL_FOLDER: &str = "models";
/// The accuracy gates and their snapshots.
pub const GOLDEN_FOLDER: &str = "golden";
/// The gate file, relative to the data folder.
pub const GATE_FILE: &str = "golden/gates.toml";
/// The folders of named files, in the order `aeroid list` shows them.
pub const LISTED_FOLDERS: [&str; 5] = [
    AIRCRAFT_FOLDER,
    SCENARIO_FOLDER,
    RECORDER_FOLDER,
    MODEL_FOLDER,
    STUDY_FOLDER,
];

/// The environment variable that names the data folder.
pub(crate) const DATA_VARIABLE: &str = "AEROID_DATA";

/// The data folder holding `aircraft/` and `scenarios/`.
pub fn data_folder() -> PathBuf {
    if let Some(folder) = std::env::var_os(DATA_VARIABLE) {
        return PathBuf::from(folder);
    }
    let current = PathBuf::from(".");
    if current.join(AIRCRAFT_FOLDER).is_dir() || current.join(SCENARIO_FOLDER).is_dir() {
        return current;
    }
    source_tree()
}

/// The source tree aeroid was built from: two folders above this crate's.
pub fn source_tree() -> PathBuf {
    let crate_folder = Path::new(env!("CARGO_MANIFEST_DIR"));
    crate_folder
        .ancestors()
        .nth(2)
        .unwrap_or(crate_folder)
        .to_path_buf()
}

/// The data folder's gate file (`golden/gates.toml`).
pub fn gate_file() -> PathBuf {
    data_folder().join(GATE_FILE)
}

/// Names (file stems) of the `.toml` files in a data sub-folder, sorted.
pub fn bundled(folder: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(data_folder().join(folder))
        .into_iter()
        .flatten()
        .flatten()
        .map(|entry| entry.path())
        .filter(|path| path.extension().is_some_and(|e| e == "toml"))
        .filter_map(|path| path.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    names.sort();
    names
}

/// What a file of `folder` is called in messages.
fn kind(folder: &str) -> &'static str {
    match folder {
        AIRCRAFT_FOLDER => "aircraft",
        RECORDER_FOLDER => "recorder profile",
        STUDY_FOLDER => "study",
        MODEL_FOLDER => "model structure",
        _ => "scenario",
    }
}

/// Resolves a file reference. Without `base` (a reference the user typed):
/// an existing path, else a bundled name in `folder`. With `base` (the
/// folder of the file that names it): a path inside `base`, a name in the
/// `folder` beside `base`, a path inside the data folder or a bundled name;
/// an absolute path, a `..` component or a file inside `base` that a
/// symbolic link takes out of it is refused — the rule of
/// [`paths::inside`] for every file that names another.
pub fn resolve(reference: &str, folder: &str, base: Option<&Path>) -> Result<PathBuf> {
    if let Some(base) = base {
        let refuse = |reason: String| Error::Reference {
            kind: kind(folder),
            reference: reference.into(),
            reason,
            base: paths::shown(base).to_path_buf(),
        };
        if let Some(reason) = paths::escape_reason(reference) {
            return Err(refuse(reason.to_string()));
        }
        if let Some(target) = paths::leads_out(base, reference) {
            return Err(refuse(format!(
                "leads to {} through a symbolic link, outside the folder",
                target.display()
            )));
        }
    }
    find(reference, folder, base)
}

/// [`resolve`] for the field `field` of the file `naming_file`, which the
/// error of a reference that leaves its folder names; a file beside
/// `naming_file` reached through a symbolic link that leads out of its
/// folder is refused too.
pub fn resolve_named(
    reference: &str,
    folder: &str,
    naming_file: &Path,
    field: &str,
) -> Result<PathBuf> {
    let base = naming_file.parent().unwrap_or(Path::new(""));
    if let Some(reason) = paths::escape_reason(reference) {
        return Err(Error::Escape {
            path: naming_file.to_path_buf(),
            field: field.to_string(),
            reference: reference.to_string(),
            reason: format!(
                "{reason}; name a file inside {} by a relative path, or a bundled name",
                paths::shown(base).display()
            ),
        });
    }
    paths::inside(base, reference, naming_file, field)?;
    find(reference, folder, Some(base))
}

fn find(reference: &str, folder: &str, base: Option<&Path>) -> Result<PathBuf> {
    let direct = PathBuf::from(reference);
    let bundled_file = data_folder().join(folder).join(format!("{reference}.toml"));
    let candidates = match base {
        Some(base) => vec![
            base.join(&direct),
            base.join("..")
                .join(folder)
                .join(format!("{reference}.toml")),
            data_folder().join(&direct),
            bundled_file,
        ],
        None => vec![direct, bundled_file],
    };
    candidates
        .into_iter()
        .find(|c| c.is_file())
        .ok_or_else(|| Error::Unknown {
            kind: kind(folder),
            name: reference.to_string(),
            known: bundled(folder),
        })
}
