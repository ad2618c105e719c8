//! A study's journal, `cases.jsonl` in its output folder: every finished
//! case's rows, streamed to disk as the case finishes, so that an
//! interrupted study resumes without losing or repeating a case, and the
//! shards of a study run on several machines merge into the result one
//! machine would have written.
//!
//! The first line is a [`Header`]: the study, a fingerprint of everything
//! that decides its numbers (seed, runs, sweep points, scenarios, profile,
//! models, methods, settings), the number of cases and the shard. Each
//! further line is one case, `{"case": i, "rows": [...]}`, written whole
//! and flushed before the next; lines are in the order cases finished.
//! Non-finite numbers are written as the strings `"NaN"`, `"inf"` and
//! `"-inf"` (JSON has no such numbers), every other number exactly
//! (shortest round-trip form). A last line cut short by an interruption is
//! dropped when the journal is resumed or read; a malformed line anywhere
//! else is an error naming the file and line.
//!
//! Shard K of N holds the cases whose index i (point·runs + run) has
//! i mod N = K − 1.

use crate::error::{Error, Result};
use crate::row::Row;
use aeroid_core::error::write_error;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The journal's file name inside a study's output folder.
pub const JOURNAL_FILE: &str = "cases.jsonl";
/// The format tag of a journal's header.
pub const FORMAT: &str = "aeroid-study-journal-1";

/// Which share of a study's cases a run takes: shard `index` (1-based)
/// of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Default for Shard {
    fn default() -> Self {
        Shard { index: 1, count: 1 }
    }
}

impl Shard {
    /// Parses `K/N` (1 ≤ K ≤ N).
    pub fn parse(text: &str) -> Result<Shard> {
        let invalid = || Error::Shard { text: text.into() };
        let (index, count) = text.split_once('/').ok_or_else(invalid)?;
        let index: usize = index.trim().parse().map_err(|_| invalid())?;
        let count: usize = count.trim().parse().map_err(|_| invalid())?;
        if index == 0 || index > count {
            return Err(invalid());
        }
        Ok(Shard { index, count })
    }

    /// Whether case `case` belongs to this shard.
    pub fn holds(self, case: usize) -> bool {
        case % self.count == self.index - 1
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The first line of a journal.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    pub format: String,
    pub study: String,
    pub seed: u64,
    /// Runs per sweep point.
    pub runs: usize,
    /// A hash of everything that decides the study's numbers.
    pub fingerprint: String,
    /// Cases in the whole study (every shard).
    pub cases: usize,
    pub shard: Shard,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    case: usize,
    rows: Vec<Row>,
}

/// The cases a journal holds.
pub(crate) type Finished = std::collections::BTreeSet<usize>;

/// An open journal, appended to by the threads of a study.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: Mutex<File>,
}

impl Journal {
    /// Starts a journal in `folder` (created if needed). An error when one
    /// is there already: resume it, or choose another folder.
    pub fn create(folder: &Path, header: &Header) -> Result<Journal> {
        std::fs::create_dir_all(folder).map_err(|e| write_error(folder, e))?;
        let path = folder.join(JOURNAL_FILE);
        let mut file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::AlreadyExists => Error::JournalExists { path: path.clone() },
                _ => write_error(&path, e).into(),
            })?;
        lock(&file, &path)?;
        let line = serde_json::to_string(header).map_err(|e| write_error(&path, e))?;
        writeln!(file, "{line}")
            .and_then(|_| file.flush())
            .map_err(|e| write_error(&path, e))?;
        Ok(Journal {
            path,
            file: Mutex::new(file),
        })
    }

    /// Reopens the journal in `folder` to continue it: checks that it is
    /// the journal of the same study and shard as `header`, drops a last
    /// line cut short, and returns the journal with the cases it holds.
    pub fn resume(folder: &Path, header: &Header) -> Result<(Journal, Finished)> {
        let path = folder.join(JOURNAL_FILE);
        // Locked before it is read: a second resume on the same folder
        // would otherwise cut and append through its own handle.
        let mut file = match OpenOptions::new().write(true).open(&path) {
            Ok(file) => file,
            // A missing journal is said by the index, with its own message.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                index_journal(&path)?;
                return Err(write_error(&path, e).into());
            }
            Err(e) => return Err(write_error(&path, e).into()),
        };
        lock(&file, &path)?;
        let index = index_journal(&path)?;
        let found = &index.header;
        if *found != *header {
            return Err(Error::Journal {
                reason: format!(
                    "the journal is of another study or shard (study '{}', shard {}, fingerprint {}; this run: study '{}', shard {}, fingerprint {}); a study resumes only with the files, seed, runs and shard it started with",
                    found.study,
                    found.shard,
                    found.fingerprint,
                    header.study,
                    header.shard,
                    header.fingerprint
                ),
                path,
            });
        }
        file.set_len(index.complete_length)
            .map_err(|e| write_error(&path, e))?;
        use std::io::Seek;
        file.seek(std::io::SeekFrom::End(0))
            .map_err(|e| write_error(&path, e))?;
        Ok((
            Journal {
                path,
                file: Mutex::new(file),
            },
            index.entries.keys().copied().collect(),
        ))
    }

    /// Appends one finished case, whole, and flushes it.
    pub fn append(&self, case: usize, rows: &[Row]) -> Result<()> {
        let entry = EntryRef { case, rows };
        let mut line = serde_json::to_string(&entry).map_err(|e| write_error(&self.path, e))?;
        line.push('\n');
        let mut file = self.file.lock().map_err(|_| Error::Journal {
            path: self.path.clone(),
            reason: "a writer panicked".into(),
        })?;
        file.write_all(line.as_bytes())
            .and_then(|_| file.flush())
            .map_err(|e| write_error(&self.path, e).into())
    }

    /// The journal's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Takes the journal's exclusive lock for as long as `file` is open (an
/// advisory lock: every aeroid process asks for it), or says that another
/// process holds it.
fn lock(file: &File, path: &Path) -> Result<()> {
    match file.try_lock() {
        Ok(()) => Ok(()),
        Err(std::fs::TryLockError::WouldBlock) => Err(Error::JournalBusy {
            path: path.to_path_buf(),
        }),
        Err(std::fs::TryLockError::Error(e)) => Err(write_error(path, e).into()),
    }
}

#[derive(Serialize)]
struct EntryRef<'a> {
    case: usize,
    rows: &'a [Row],
}

/// Reads the journal in `folder`: its header and finished cases.
pub fn read(folder: &Path) -> Result<(Header, Finished)> {
    let index = index_journal(&folder.join(JOURNAL_FILE))?;
    Ok((index.header, index.entries.keys().copied().collect()))
}

/// Where each case of a journal is: its header, the byte range of each
/// case's line, and the length of the file up to its last complete line.
#[derive(Debug)]
struct Index {
    header: Header,
    entries: BTreeMap<usize, (u64, usize)>,
    complete_length: u64,
}

/// The journal at `path` to read line by line, and its length in bytes.
fn open_journal(path: &Path) -> Result<(BufReader<File>, u64)> {
    let file = File::open(path).map_err(|source| aeroid_core::Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let size = file
        .metadata()
        .map_err(|source| aeroid_core::Error::Io {
            path: path.to_path_buf(),
            source,
        })?
        .len();
    Ok((BufReader::new(file), size))
}

/// Indexes a journal, checking every line (each is parsed, then only its
/// place kept).
fn index_journal(path: &Path) -> Result<Index> {
    let (mut reader, size) = open_journal(path)?;
    let malformed = |line: usize, reason: String| Error::JournalLine {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let mut line = String::new();
    let mut read_line = |line: &mut String| {
        line.clear();
        reader
            .read_line(line)
            .map_err(|source| aeroid_core::Error::Io {
                path: path.to_path_buf(),
                source,
            })
    };
    if read_line(&mut line)? == 0 {
        return Err(malformed(1, "an empty journal (no header)".into()));
    }
    let header: Header =
        serde_json::from_str(line.trim_end()).map_err(|e| malformed(1, format!("header: {e}")))?;
    if header.format != FORMAT {
        return Err(malformed(
            1,
            format!("format '{}', expected '{FORMAT}'", header.format),
        ));
    }
    let mut entries = BTreeMap::new();
    let mut offset = line.len() as u64;
    let mut number = 1;
    loop {
        let read = read_line(&mut line)?;
        if read == 0 {
            break;
        }
        number += 1;
        let complete = line.ends_with('\n');
        let last = offset + read as u64 == size;
        match serde_json::from_str::<Entry>(line.trim_end()) {
            Ok(entry) if complete => {
                if entry.case >= header.cases || !header.shard.holds(entry.case) {
                    return Err(malformed(
                        number,
                        format!(
                            "case {} is not a case of shard {}",
                            entry.case, header.shard
                        ),
                    ));
                }
                if entries.insert(entry.case, (offset, read)).is_some() {
                    return Err(malformed(
                        number,
                        format!("case {} appears twice", entry.case),
                    ));
                }
            }
            // The last line, cut short by an interruption: dropped.
            _ if last && !complete => break,
            Ok(_) => return Err(malformed(number, "a line without its end".into())),
            Err(e) => return Err(malformed(number, e.to_string())),
        }
        offset += read as u64;
    }
    Ok(Index {
        header,
        entries,
        complete_length: offset,
    })
}

/// The journals of a study's shards (or of a whole study), read case by
/// case in case order.
#[derive(Debug)]
pub struct Cases {
    header: Header,
    files: Vec<(PathBuf, File)>,
    /// Case → (file, offset, length).
    places: BTreeMap<usize, (usize, u64, usize)>,
}

impl Cases {
    /// The header of the whole study (shard 1/1).
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Calls `each` with every case's index and rows, in case order.
    pub fn for_each(&mut self, mut each: impl FnMut(usize, Vec<Row>) -> Result<()>) -> Result<()> {
        use std::io::{Read, Seek, SeekFrom};
        let mut buffer = Vec::new();
        for (&case, &(file, offset, length)) in &self.places {
            let (path, handle) = &mut self.files[file];
            buffer.resize(length, 0);
            handle
                .seek(SeekFrom::Start(offset))
                .and_then(|_| handle.read_exact(&mut buffer))
                .map_err(|source| aeroid_core::Error::Io {
                    path: path.clone(),
                    source,
                })?;
            let entry: Entry = serde_json::from_slice(&buffer).map_err(|e| Error::Journal {
                path: path.clone(),
                reason: format!("case {case}: {e}"),
            })?;
            each(case, entry.rows)?;
        }
        Ok(())
    }
}

/// Opens the journals of a study's shards for reading in case order:
/// every shard of one study, each once, each complete; or the one
/// journal of a whole study, complete.
pub fn open(folders: &[PathBuf]) -> Result<Cases> {
    let mut merged: Option<Header> = None;
    let mut seen: BTreeMap<usize, PathBuf> = BTreeMap::new();
    let mut files = Vec::new();
    let mut places = BTreeMap::new();
    for folder in folders {
        let path = folder.join(JOURNAL_FILE);
        let index = index_journal(&path)?;
        let header = index.header;
        let whole = Header {
            shard: Shard::default(),
            ..header.clone()
        };
        match &merged {
            None => merged = Some(whole),
            Some(first) if *first != whole => {
                return Err(Error::Journal {
                    reason: format!(
                        "a shard of another study (study '{}', fingerprint {}; the first folder's: '{}', {})",
                        header.study, header.fingerprint, first.study, first.fingerprint
                    ),
                    path,
                });
            }
            Some(_) => {}
        }
        if let Some(other) = seen.insert(header.shard.index, path.clone()) {
            return Err(Error::Merge {
                reason: format!(
                    "shard {} is both in {} and in {}",
                    header.shard,
                    other.display(),
                    path.display()
                ),
            });
        }
        let expected = (0..header.cases).filter(|&c| header.shard.holds(c)).count();
        if index.entries.len() != expected {
            return Err(Error::Journal {
                reason: format!(
                    "shard {} has {} of its {expected} cases: finish it with --resume first",
                    header.shard,
                    index.entries.len()
                ),
                path,
            });
        }
        let file = File::open(&path).map_err(|source| aeroid_core::Error::Io {
            path: path.clone(),
            source,
        })?;
        for (case, (offset, length)) in index.entries {
            places.insert(case, (files.len(), offset, length));
        }
        files.push((path, file));
    }
    let Some(header) = merged else {
        return Err(Error::Merge {
            reason: "no shard folders given to merge".into(),
        });
    };
    if places.len() != header.cases {
        let missing: Vec<usize> = (0..header.cases)
            .filter(|c| !places.contains_key(c))
            .take(5)
            .collect();
        return Err(Error::Merge {
            reason: format!(
                "the shards hold {} of the study's {} cases; missing shards hold cases such as {missing:?}",
                places.len(),
                header.cases
            ),
        });
    }
    Ok(Cases {
        header,
        files,
        places,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> Header {
        Header {
            format: FORMAT.into(),
            study: "locked".into(),
            seed: 1,
            runs: 2,
            fingerprint: "f".into(),
            cases: 4,
            shard: Shard::default(),
        }
    }

    /// While one study writes a journal, a second resume of the same folder
    /// is refused (it would cut and append through its own handle) and the
    /// journal keeps every case; once the first has ended it resumes.
    #[test]
    fn a_journal_in_use_is_not_resumed_by_a_second_study() {
        let folder =
            std::env::temp_dir().join(format!("aeroid-journal-lock-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&folder);
        let first = Journal::create(&folder, &header()).unwrap();
        first.append(0, &[]).unwrap();
        let error = Journal::resume(&folder, &header()).unwrap_err();
        assert!(matches!(error, Error::JournalBusy { .. }), "{error}");
        assert!(error.to_string().contains(JOURNAL_FILE), "{error}");
        first.append(1, &[]).unwrap();
        drop(first);
        let (second, finished) = Journal::resume(&folder, &header()).unwrap();
        assert_eq!(finished, [0, 1].into());
        drop(second);
        std::fs::remove_dir_all(&folder).unwrap();
    }
}
