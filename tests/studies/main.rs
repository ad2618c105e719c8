//! Monte Carlo studies: acceptance studies, journals, resume, shards and merge, the pipeline, reports and Slurm.
//!
//! One test binary for the area (each file a module), so that a fresh
//! `cargo test` links a few binaries rather than one per file.

#[path = "../common/mod.rs"]
mod common;

mod filter_error_study;
mod frequency_domain_study;
mod monte_carlo;
mod neural_study;
mod pipeline;
mod report;
mod slurm;
mod study_journal;
