//! Ending every process of a plug-in run, those that left its process
//! group too (`setsid`, a daemon's double fork), which killing the group
//! does not reach.
//!
//! On Linux each run's processes carry a marker in their environment,
//! `AEROID_PLUGIN_RUN=<the run's work folder name>`, which every
//! descendant inherits unless it clears its environment. When the run
//! ends (its command exits, or its time limit kills the group) aeroid
//! looks for the marker in `/proc/PID/environ` of every process it may
//! read and kills each one that holds it, again until none is left (a
//! process may fork while the scan runs). The plug-in's own process also
//! gets a parent-death signal (SIGKILL), so it does not outlive aeroid.
//! Elsewhere only the process group is ended, at the time limit.

use std::collections::BTreeSet;

/// The environment variable that marks a run's processes.
pub(crate) const MARKER: &str = "AEROID_PLUGIN_RUN";

/// Kills every process (other than aeroid) whose environment holds
/// `MARKER=run`; returns how many there were.
#[cfg(target_os = "linux")]
pub(crate) fn end_run(run: &str) -> usize {
    let needle = format!("\0{MARKER}={run}\0").into_bytes();
    let me = std::process::id();
    let mut killed = BTreeSet::new();
    // A process forked during a scan is found by the next; 100 rounds
    // bound a fork bomb's chase.
    for _ in 0..100 {
        let found: Vec<u32> = marked(&needle, me)
            .into_iter()
            .filter(|pid| !killed.contains(pid))
            .collect();
        if found.is_empty() {
            break;
        }
        for pid in found {
            if let Ok(pid_t) = libc::pid_t::try_from(pid) {
                // SAFETY: kill only sends a signal; it touches no memory.
                unsafe {
                    libc::kill(pid_t, libc::SIGKILL);
                }
            }
            killed.insert(pid);
        }
    }
    killed.len()
}

/// Elsewhere: nothing beyond the process group (module documentation).
#[cfg(not(target_os = "linux"))]
pub(crate) fn end_run(_run: &str) -> usize {
    0
}

/// The processes other than `me` whose environment (read from /proc, a
/// leading NUL added so the first variable matches too) holds `needle`.
#[cfg(target_os = "linux")]
fn marked(needle: &[u8], me: u32) -> Vec<u32> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter_map(|entry| entry.file_name().to_str()?.parse::<u32>().ok())
        .filter(|&pid| pid != me)
        .filter(|pid| {
            std::fs::read(format!("/proc/{pid}/environ")).is_ok_and(|environ| {
                let mut bytes = Vec::with_capacity(environ.len() + 1);
                bytes.push(0);
                bytes.extend_from_slice(&environ);
                bytes.windows(needle.len()).any(|w| w == needle)
            })
        })
        .collect()
}

/// In the child between fork and exec: the parent-death signal, so that
/// the plug-in's process ends with the thread of aeroid that started it
/// (which waits for it). Makes a system call only, as that moment requires.
#[cfg(target_os = "linux")]
pub(crate) fn die_with_parent() -> std::io::Result<()> {
    // SAFETY: prctl with PR_SET_PDEATHSIG takes a signal number and
    // touches no memory.
    let result = unsafe { libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL) };
    if result == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Elsewhere: no parent-death signal.
#[cfg(not(target_os = "linux"))]
pub(crate) fn die_with_parent() -> std::io::Result<()> {
    Ok(())
}
