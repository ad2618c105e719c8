//! Where aeroid reads and writes. A file named inside another file (a
//! record's `record.toml`, a scenario, a study) stays inside the folder of
//! the file that names it: `..` components, absolute paths and symbolic links
//! that lead out are refused, naming the file and the field. Every output
//! location is checked before the work that fills it starts.

use crate::error::{Error, Result, write_error};
use std::path::{Component, Path, PathBuf};

/// How a reference leaves its folder, if it does by its words alone.
pub(crate) fn escape_reason(reference: &str) -> Option<&'static str> {
    let path = Path::new(reference);
    if path.is_absolute() || reference.starts_with('/') || reference.starts_with('\\') {
        return Some("is an absolute path");
    }
    for component in path.components() {
        match component {
            Component::ParentDir => return Some("leaves the folder with '..'"),
            Component::RootDir | Component::Prefix(_) => return Some("is an absolute path"),
            _ => {}
        }
    }
    None
}

/// Whether a reference stays inside the folder that names it by its words
/// alone (relative, no `..`).
pub fn stays_inside(reference: &str) -> bool {
    escape_reason(reference).is_none()
}

/// The path of `reference`, a file named by field `field` of the file
/// `naming_file`, inside `folder`. A reference that is absolute, has a `..`
/// component or (existing) resolves through a symbolic link to outside
/// `folder` is an [`Error::Escape`].
pub fn inside(folder: &Path, reference: &str, naming_file: &Path, field: &str) -> Result<PathBuf> {
    let escape = |reason: String| Error::Escape {
        path: naming_file.to_path_buf(),
        field: field.to_string(),
        reference: reference.to_string(),
        reason,
    };
    let shown = shown(folder);
    if let Some(reason) = escape_reason(reference) {
        return Err(escape(format!(
            "{reason}; name a file inside {} by a relative path",
            shown.display()
        )));
    }
    if let Some(target) = leads_out(folder, reference) {
        return Err(escape(format!(
            "leads to {}, outside {}; name a file inside it",
            target.display(),
            shown.display()
        )));
    }
    Ok(folder.join(reference))
}

/// Where `reference`, an existing file inside `folder` by its words,
/// really is when a symbolic link takes it out of `folder`; None when it
/// stays inside or does not exist.
pub(crate) fn leads_out(folder: &Path, reference: &str) -> Option<PathBuf> {
    let target = folder.join(reference).canonicalize().ok()?;
    let root = shown(folder).canonicalize().ok()?;
    (!target.starts_with(&root)).then_some(target)
}

/// A folder as shown in messages: `.` for the current folder.
pub(crate) fn shown(folder: &Path) -> &Path {
    if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    }
}

/// Checks before any work that `path` can be written as a file: not a
/// folder, its folder exists, and the file can be created or appended to
/// (a file created by the check is removed again).
pub fn check_output_file(path: &Path) -> Result<()> {
    if path.is_dir() {
        return Err(write_error(path, "it is a folder; name a file"));
    }
    let parent = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        let reason = if parent.exists() {
            format!("{} is not a folder", parent.display())
        } else {
            format!("the folder {} does not exist", parent.display())
        };
        return Err(write_error(path, reason));
    }
    if path.exists() {
        std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map(drop)
            .map_err(|e| write_error(path, e))
    } else {
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(|e| write_error(path, e))?;
        std::fs::remove_file(path).map_err(|e| write_error(path, e))
    }
}

/// An error when writing the file `output` would overwrite an input the
/// command reads: one of the `inputs` files, or a file inside one of the
/// `inputs` folders other than those whose names end with one of
/// `allowed_suffixes` (a study folder's own `.html` report). An output that
/// does not exist yet overwrites nothing.
pub fn check_not_input(output: &Path, inputs: &[&Path], allowed_suffixes: &[&str]) -> Result<()> {
    let Ok(written) = output.canonicalize() else {
        return Ok(());
    };
    let name = written.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let allowed = allowed_suffixes.iter().any(|suffix| name.ends_with(suffix));
    for input in inputs {
        let Ok(read) = input.canonicalize() else {
            continue;
        };
        if written == read {
            return Err(write_error(
                output,
                "it is a file this command reads; name another file",
            ));
        }
        if read.is_dir() && written.starts_with(&read) && !allowed {
            return Err(write_error(
                output,
                format!(
                    "it is inside {}, which this command reads; name a file outside it",
                    input.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Checks before any work that `path` can be written as a folder: not an
/// existing file, and its nearest existing ancestor is a folder that takes
/// new files. Nothing is left behind.
pub fn check_output_folder(path: &Path) -> Result<()> {
    if path.exists() && !path.is_dir() {
        return Err(write_error(path, "it is a file, not a folder"));
    }
    let mut existing = path;
    while !existing.as_os_str().is_empty() && !existing.exists() {
        existing = existing.parent().unwrap_or(Path::new(""));
    }
    let existing = if existing.as_os_str().is_empty() {
        Path::new(".")
    } else {
        existing
    };
    if !existing.is_dir() {
        return Err(write_error(
            path,
            format!("{} is a file, not a folder", existing.display()),
        ));
    }
    let probe = existing.join(format!(".aeroid-write-check-{}", std::process::id()));
    let in_folder = |e: std::io::Error| {
        if existing == path {
            write_error(path, e)
        } else {
            write_error(
                path,
                format!("cannot create it in {}: {e}", existing.display()),
            )
        }
    };
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .map_err(in_folder)?;
    std::fs::remove_file(&probe).map_err(|e| write_error(&probe, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_that_leave_the_folder_are_refused() {
        let naming = Path::new("rec/record.toml");
        let error = inside(
            Path::new("rec"),
            "../../etc/passwd",
            naming,
            "channels[0].file",
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.contains(
                "rec/record.toml: channels[0].file: '../../etc/passwd' leaves the folder with '..'"
            ),
            "{error}"
        );
        let error = inside(Path::new("rec"), "/etc/passwd", naming, "channels[0].file")
            .unwrap_err()
            .to_string();
        assert!(error.contains("is an absolute path"), "{error}");
        assert_eq!(
            inside(Path::new("rec"), "sub/a.csv", naming, "f").unwrap(),
            Path::new("rec/sub/a.csv")
        );
        assert!(stays_inside("a/b.csv") && !stays_inside("a/../../b.csv"));
    }

    #[test]
    fn an_output_folder_that_is_a_file_is_refused() {
        let file = std::env::temp_dir().join(format!("aeroid-paths-{}", std::process::id()));
        std::fs::write(&file, "x").unwrap();
        let error = check_output_folder(&file).unwrap_err().to_string();
        assert!(error.ends_with("it is a file, not a folder"), "{error}");
        let error = check_output_folder(&file.join("below"))
            .unwrap_err()
            .to_string();
        assert!(error.contains("is a file, not a folder"), "{error}");
        check_output_file(&file).unwrap();
        std::fs::remove_file(&file).unwrap();
        check_output_file(&file).unwrap();
        assert!(!file.exists());
        let error = check_output_file(&file.join("x.csv"))
            .unwrap_err()
            .to_string();
        assert!(error.contains("does not exist"), "{error}");
    }
}
