//! The command line and the plug-in protocol.
//!
//! One test binary for the area (each file a module), so that a fresh
//! `cargo test` links a few binaries rather than one per file.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod cli_contracts;
mod plugins;
mod stall_example;
