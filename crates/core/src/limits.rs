//! Bounds on what a file may ask of aeroid, and the memory budget that a
//! simulation, record or study is checked against before anything is
//! allocated. Each bound states its reason; a refusal gives the numbers.
//!
//! The memory budget is half of the machine's memory (`MemTotal` of
//! `/proc/meminfo` on Linux, 4 GiB elsewhere), or the value of
//! the environment variable `AEROID_MEMORY_BUDGET`: bytes, or a number with
//! `kB`, `MB`, `GB`, `TB`, `KiB`, `MiB`, `GiB` or `TiB` (`AEROID_MEMORY_BUDGET=2GB`).

use std::fmt;

/// The environment variable that overrides the memory budget.
pub(crate) const BUDGET_VARIABLE: &str = "AEROID_MEMORY_BUDGET";

/// The budget when the machine's memory cannot be read: 4 GiB, what any
/// machine that builds aeroid has.
pub(crate) const FALLBACK_BUDGET: u64 = 4 << 30;

/// Smallest integration step, 1 µs: a thousand times below the fastest
/// aircraft mode's time constant (a few ms for actuators and small UAVs),
/// where RK4's truncation error is already below double-precision round-off;
/// a smaller step only adds round-off and samples.
pub const MIN_STEP: f64 = 1e-6;

/// Longest scenario, 100 000 s (27.8 h): longer than any aircraft's endurance.
pub const MAX_DURATION: f64 = 100_000.0;

/// Highest recorder sample rate, 10 kHz: far above any flight-test
/// system's sampling of aircraft motion (at most a few hundred Hz).
pub const MAX_RATE: f64 = 10_000.0;

/// Longest sensor lag time constant or delay, 100 s: longer than the
/// period of the slowest aircraft mode (the phugoid); a sensor that slow
/// records no aircraft motion.
pub const MAX_SENSOR_TIME: f64 = 100.0;

/// Most runs per sweep point of a Monte Carlo study, 1 000 000: statistics
/// of a thousand runs are within a few percent; a million runs of even a
/// one-second fit take more than eleven days of one core.
pub const MAX_RUNS: usize = 1_000_000;

/// Largest input amplitude of a control surface, 90°: no surface deflects
/// further (the aircraft's own limits saturate it far earlier).
pub const MAX_DEFLECTION: f64 = std::f64::consts::FRAC_PI_2;

/// Largest input amplitude of the throttle, 1: the whole range of thrust.
pub const MAX_THROTTLE: f64 = 1.0;

/// The memory a run may use, and where the number comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    pub bytes: u64,
    pub source: String,
}

impl fmt::Display for Budget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", bytes_text(self.bytes as f64), self.source)
    }
}

/// The memory budget: [`BUDGET_VARIABLE`] if set, else half of the
/// machine's memory, else [`FALLBACK_BUDGET`]. An unreadable variable is an
/// error that says what it holds.
pub(crate) fn memory_budget() -> crate::Result<Budget> {
    if let Ok(text) = std::env::var(BUDGET_VARIABLE) {
        return parse_bytes(&text)
            .map(|bytes| Budget {
                bytes,
                source: format!("{BUDGET_VARIABLE}={}", text.trim()),
            })
            .ok_or(crate::Error::MemoryBudget {
                variable: BUDGET_VARIABLE,
                text: text.clone(),
            });
    }
    Ok(match machine_memory() {
        Some(total) => Budget {
            bytes: total / 2,
            source: format!(
                "half of the machine's {}; set {BUDGET_VARIABLE} to change it",
                bytes_text(total as f64)
            ),
        },
        None => Budget {
            bytes: FALLBACK_BUDGET,
            source: format!("the machine's memory is unknown; set {BUDGET_VARIABLE} to change it"),
        },
    })
}

/// Checks that `count` items of `item_bytes` each fit the memory budget;
/// the refusal names what, how many, the bytes and the budget. `count` is
/// a float so that a count beyond `usize` is refused, not wrapped.
pub fn check_memory(what: &str, count: f64, item_bytes: usize) -> crate::Result<()> {
    let budget = memory_budget()?;
    let bytes = count * item_bytes as f64;
    if bytes.is_finite() && bytes <= budget.bytes as f64 && count < usize::MAX as f64 {
        Ok(())
    } else {
        Err(crate::Error::Memory {
            what: what.into(),
            count,
            item_bytes,
            bytes,
            budget,
        })
    }
}

/// Total memory of the machine in bytes (`MemTotal` of `/proc/meminfo`),
/// read once: every simulation and record of a study is checked against it.
fn machine_memory() -> Option<u64> {
    static MEMORY: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
    *MEMORY.get_or_init(read_machine_memory)
}

fn read_machine_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut words = line.split_whitespace().skip(1);
    let value: u64 = words.next()?.parse().ok()?;
    let factor = match words.next() {
        Some("kB") => 1024,
        None => 1,
        Some(_) => return None,
    };
    value.checked_mul(factor).filter(|&bytes| bytes > 0)
}

/// Bytes from `"123"`, `"2GB"`, `"1.5 GiB"`; `None` when not a positive size.
pub(crate) fn parse_bytes(text: &str) -> Option<u64> {
    let text = text.trim();
    let split = text
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == 'e' || c == 'E'))
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(split);
    let value: f64 = number.parse().ok()?;
    let factor: f64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "kb" => 1e3,
        "mb" => 1e6,
        "gb" => 1e9,
        "tb" => 1e12,
        "kib" => 1024.0,
        "mib" => 1024.0 * 1024.0,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        "tib" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        _ => return None,
    };
    let bytes = value * factor;
    (bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64).then_some(bytes as u64)
}

/// A number for a message: plain for ordinary magnitudes, in scientific
/// notation when tiny or huge (`1e-300`, not three hundred zeros).
pub fn number(value: f64) -> String {
    if value == 0.0 || !value.is_finite() || (1e-4..1e15).contains(&value.abs()) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}

/// A count for a message: exact below 10¹², else in scientific notation.
pub(crate) fn count_text(count: f64) -> String {
    if count < 1e12 && count.fract() == 0.0 {
        format!("{count:.0}")
    } else {
        format!("{count:.3e}")
    }
}

/// Bytes for a message, in decimal units.
pub(crate) fn bytes_text(bytes: f64) -> String {
    if !bytes.is_finite() {
        return "more bytes than a number holds".into();
    }
    let units = [
        (1e15, "PB"),
        (1e12, "TB"),
        (1e9, "GB"),
        (1e6, "MB"),
        (1e3, "kB"),
    ];
    match units.iter().find(|(size, _)| bytes >= *size) {
        Some((size, unit)) if bytes / size < 1e4 => format!("{:.1} {unit}", bytes / size),
        Some(_) => format!("{bytes:.3e} bytes"),
        None => format!("{bytes:.0} bytes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_sizes_parse_with_units() {
        assert_eq!(parse_bytes("2048"), Some(2048));
        assert_eq!(parse_bytes("2GB"), Some(2_000_000_000));
        assert_eq!(parse_bytes(" 1.5 KiB "), Some(1536));
        assert_eq!(parse_bytes("3 GiB"), Some(3 << 30));
        assert_eq!(parse_bytes("lots"), None);
        assert_eq!(parse_bytes("-1"), None);
        assert_eq!(parse_bytes("0"), None);
        assert_eq!(parse_bytes("1e400"), None);
        assert_eq!(parse_bytes("5 parsecs"), None);
    }

    #[test]
    fn a_request_beyond_the_budget_gives_the_numbers() {
        let message = check_memory("the simulation", 1e11, 400)
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with(
                "the simulation would need 100000000000 × 400 bytes = 40.0 TB, more than the memory budget of "
            ),
            "{message}"
        );
        assert!(check_memory("a small record", 1000.0, 16).is_ok());
        assert!(check_memory("a count past usize", 1e30, 1).is_err());
        assert!(check_memory("a count past usize", f64::INFINITY, 1).is_err());
    }

    #[test]
    fn numbers_in_messages_stay_short() {
        assert_eq!(number(1e-300), "1e-300");
        assert_eq!(number(5e-324), "5e-324");
        assert_eq!(number(1e-6), "1e-6");
        assert_eq!(number(0.01), "0.01");
        assert_eq!(number(1e9), "1000000000");
        assert_eq!(number(1e308), "1e308");
    }

    #[test]
    fn byte_counts_read_in_decimal_units() {
        assert_eq!(bytes_text(512.0), "512 bytes");
        assert_eq!(bytes_text(1.5e9), "1.5 GB");
        assert_eq!(bytes_text(4.8e12), "4.8 TB");
        assert_eq!(bytes_text(4.8e20), "4.800e20 bytes");
    }
}
