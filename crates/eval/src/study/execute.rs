//! Running a study's cases on threads, in memory ([`Study::run`]) or
//! journaled case by case ([`Study::run_journaled`]: started, resumed or
//! one shard of several), and the journal header with the study's
//! fingerprint (FNV-1a, 64 bits, of everything that decides its numbers).

use super::result::StudyResult;
use super::{Case, Row, Study, Summariser};
use crate::axis::Axis;
use crate::error::{Error, Result};
use crate::histories::CaseHistories;
use crate::journal::{self, Finished, Header, Journal, Shard};
use aeroid_core::error::read_text;
use std::collections::BTreeMap;
use std::path::Path;

impl Study {
    /// Runs every case on `threads` threads (0: one per core), calling
    /// `progress` with each case's rows as it finishes, and summarises
    /// them in case order: the same numbers for any thread count. Nothing
    /// is written; [`Study::run_journaled`] keeps every row.
    pub fn run(&self, threads: usize, progress: &(dyn Fn(&[Row]) + Sync)) -> Result<StudyResult> {
        let cases = self.cases();
        let ordered = std::sync::Mutex::new((0usize, BTreeMap::new(), Summariser::default()));
        self.run_cases(&cases, threads, false, &|position, rows, _| {
            progress(&rows);
            let mut guard = ordered.lock().map_err(|_| Error::Panicked)?;
            let (next, pending, summariser) = &mut *guard;
            pending.insert(position, rows);
            while let Some(rows) = pending.remove(next) {
                summariser.add(&rows);
                *next += 1;
            }
            Ok(())
        })?;
        let (_, _, summariser) = ordered.into_inner().map_err(|_| Error::Panicked)?;
        Ok(StudyResult::of(
            &self.name,
            self.seed,
            self.runs,
            cases.len(),
            &summariser,
        ))
    }

    /// Runs `cases` on `threads` threads (0: one per core), each thread
    /// taking the next case in order, and hands each case's position in
    /// `cases`, its rows and, when `histories` and the case is a point's
    /// first run, its histories to `finish` as it finishes. The first error
    /// `finish` returns stops the run (cases already running complete).
    pub fn run_cases(
        &self,
        cases: &[Case],
        threads: usize,
        histories: bool,
        finish: &(dyn Fn(usize, Vec<Row>, Option<CaseHistories>) -> Result<()> + Sync),
    ) -> Result<()> {
        use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
        let threads = match threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        }
        .min(cases.len().max(1));
        let next = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        let failure = std::sync::Mutex::new(None);
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(|| {
                    while !stop.load(Ordering::Relaxed) {
                        let position = next.fetch_add(1, Ordering::Relaxed);
                        let Some(&case) = cases.get(position) else {
                            break;
                        };
                        let (rows, kept) =
                            self.run_case_with_histories(case, histories && case.run == 0);
                        if let Err(error) = finish(position, rows, kept) {
                            stop.store(true, Ordering::Relaxed);
                            if let Ok(mut first) = failure.lock() {
                                first.get_or_insert(error);
                            }
                        }
                    }
                });
            }
        });
        match failure.into_inner() {
            Ok(None) => Ok(()),
            Ok(Some(error)) => Err(error),
            Err(_) => Err(Error::Panicked),
        }
    }

    /// The cases of `shard` not yet in `finished`.
    pub fn remaining(&self, shard: Shard, finished: &Finished) -> Vec<Case> {
        self.cases()
            .into_iter()
            .filter(|&case| {
                let index = self.case_index(case);
                shard.holds(index) && !finished.contains(&index)
            })
            .collect()
    }

    /// The journal header of this study's `shard`.
    pub fn journal_header(&self, shard: Shard) -> Result<Header> {
        Ok(Header {
            format: journal::FORMAT.into(),
            study: self.name.clone(),
            seed: self.seed,
            runs: self.runs,
            fingerprint: self.fingerprint()?,
            cases: self.cases().len(),
            shard,
        })
    }

    /// A hash (FNV-1a, 64 bits) of everything that decides the study's
    /// numbers: seed, runs, methods and settings, every sweep point's
    /// values on every axis, and the text of every file the study reads (its
    /// scenarios and their aircraft, the profile, the models and their
    /// aircraft) — the same on every machine that has the same files,
    /// wherever they are.
    pub fn fingerprint(&self) -> Result<String> {
        let mut identity = format!(
            "{:?}|{}|{}|{:?}|{:?}",
            self.name, self.seed, self.runs, self.methods, self.settings
        );
        identity += &format!("|{:?}", self.setting_variants);
        for p in &self.points {
            for axis in Axis::PRODUCT {
                identity += &format!("|{}", p.identity(axis));
            }
        }
        for scenario in &self.scenarios {
            identity += &read_text(&scenario.path)?;
            identity += &read_text(&scenario.aircraft_path)?;
            // The inputs as loaded: a pilot-input CSV the scenario names is
            // in its values, not in the scenario file's text.
            identity += &format!("{:?}", scenario.inputs);
            if let Some(linear) = &scenario.linear {
                identity += &read_text(&linear.model_path)?;
            }
        }
        for profile in &self.profiles {
            identity += &read_text(&profile.path)?;
        }
        for model in &self.models {
            identity += &model.files_json().map_err(|e| Error::Model {
                name: model.name().to_string(),
                reason: e.to_string(),
            })?;
        }
        let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
        for byte in identity.bytes() {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
        Ok(format!("{hash:016x}"))
    }

    /// Runs the cases of `shard` still missing from the journal in
    /// `folder` (started there, or continued when `resume`), appending
    /// each to it as it finishes.
    pub fn run_journaled(
        &self,
        folder: &Path,
        shard: Shard,
        resume: bool,
        threads: usize,
        progress: &(dyn Fn(&[Row]) + Sync),
    ) -> Result<JournaledRun> {
        let header = self.journal_header(shard)?;
        let (journal, finished) = if resume {
            Journal::resume(folder, &header)?
        } else {
            (Journal::create(folder, &header)?, Finished::new())
        };
        let remaining = self.remaining(shard, &finished);
        self.run_cases(&remaining, threads, true, &|position, rows, histories| {
            if let Some(histories) = histories {
                histories.write(folder)?;
            }
            journal.append(self.case_index(remaining[position]), &rows)?;
            progress(&rows);
            Ok(())
        })?;
        Ok(JournaledRun {
            resumed: finished.len(),
            ran: remaining.len(),
        })
    }
}

/// What a journaled run did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JournaledRun {
    /// Cases found in the journal when it resumed.
    pub resumed: usize,
    /// Cases run now.
    pub ran: usize,
}
