//! Files written whole or not at all: the text goes to a temporary file
//! beside the target (`.NAME.partial-PID`, in the same folder so that the
//! rename cannot cross file systems), is synced to disk, and is then
//! renamed over the target. A process killed while writing leaves the
//! target as it was (the old file, or none) and at most a temporary file;
//! a reader never sees a file cut mid-line. POSIX `rename` replaces the
//! target atomically.

use crate::error::{Result, write_error};
use std::fs::File;
use std::path::{Path, PathBuf};

/// A file being written to a temporary path, renamed over its target by
/// [`AtomicFile::commit`]; dropped without a commit, it removes the
/// temporary file and leaves the target untouched.
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    temporary: PathBuf,
    file: Option<File>,
}

impl AtomicFile {
    /// Starts writing `target` (its folder must exist).
    pub fn create(target: &Path) -> Result<AtomicFile> {
        let name = target
            .file_name()
            .map(|name| name.to_string_lossy().into_owned())
            .unwrap_or_default();
        let temporary = target.with_file_name(format!(".{name}.partial-{}", std::process::id()));
        let file = File::create(&temporary).map_err(|e| write_error(&temporary, e))?;
        Ok(AtomicFile {
            target: target.to_path_buf(),
            temporary,
            file: Some(file),
        })
    }

    /// The file to write into.
    pub fn file(&mut self) -> &mut File {
        self.file
            .as_mut()
            .expect("an AtomicFile's file is there until commit")
    }

    /// Syncs the written file to disk and renames it over the target.
    pub fn commit(mut self) -> Result<()> {
        let file = self.file.take().expect("committed once");
        file.sync_all().map_err(|e| write_error(&self.target, e))?;
        drop(file);
        std::fs::rename(&self.temporary, &self.target).map_err(|e| write_error(&self.target, e))
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

/// Writes `text` to `path` whole or not at all ([`AtomicFile`]).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    use std::io::Write;
    let mut atomic = AtomicFile::create(path)?;
    atomic
        .file()
        .write_all(text.as_bytes())
        .map_err(|e| write_error(path, e))?;
    atomic.commit()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn folder(name: &str) -> PathBuf {
        let folder =
            std::env::temp_dir().join(format!("aeroid-atomic-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&folder).unwrap();
        folder
    }

    /// A write that is never committed (a process stopped mid-write)
    /// leaves the old file whole and no temporary file behind.
    #[test]
    fn an_uncommitted_write_leaves_the_old_file_whole() {
        let folder = folder("uncommitted");
        let path = folder.join("runs.csv");
        write_text(&path, "a,b\n1,2\n").unwrap();
        let mut atomic = AtomicFile::create(&path).unwrap();
        atomic.file().write_all(b"a,b\n3,").unwrap();
        drop(atomic);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a,b\n1,2\n");
        assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 1);
        write_text(&path, "a,b\n5,6\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a,b\n5,6\n");
        assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 1);
        std::fs::remove_dir_all(&folder).unwrap();
    }

    /// A folder that does not exist is an error naming the file.
    #[test]
    fn a_missing_folder_is_an_error_naming_the_file() {
        let path = std::env::temp_dir().join("aeroid-atomic-no-such-folder/x/runs.csv");
        let error = write_text(&path, "x").unwrap_err().to_string();
        assert!(error.contains("runs.csv"), "{error}");
    }
}
