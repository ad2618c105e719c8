//! The errors of recording and preparing data: a recorder profile asked
//! for a channel it does not record, a channel name that cannot be a file
//! or column name, an anti-alias filter the simulator's grid cannot hold,
//! a channel without a valid sample, a truth too short to record, a
//! derived channel that cannot be made from the record. The errors of the
//! crates below are wrapped whole, so that their messages read the same.

/// Every error of the recording and preparing flight data: each variant says what went wrong and names the file, field or value.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or data error (`aeroid_core`).
    #[error(transparent)]
    Core(#[from] aeroid_core::Error),

    /// An error of the simulator's own (`aeroid_sim`).
    #[error(transparent)]
    Sim(#[from] aeroid_sim::error::Error),

    /// A channel with no finite sample.
    #[error("channel '{channel}' has no valid sample")]
    NoValidSample { channel: String },

    /// A truth or signals too short to record.
    #[error("{reason}")]
    Recording { reason: &'static str },

    /// A channel the prep step cannot derive from this record (angular
    /// rates, flow angles, surfaces, thrust): a channel missing, in
    /// another unit, too short, or channels without a common span.
    #[error("{reason}")]
    Derivation { reason: String },

    /// A data file the import cannot read: a MAT-file of another format
    /// than level 5, binary data that is no text, a MAT-file variable that
    /// cannot be a column.
    #[error("{}: {reason}", path.display())]
    DataFormat {
        path: std::path::PathBuf,
        reason: String,
    },

    /// An imported channel whose value cannot be physical (a temperature
    /// below absolute zero, an altitude below the Earth's centre).
    #[error(
        "channel '{channel}' ({origin}) reads {value} {unit} at t = {time} s, {what}: check its unit, scale and offset in the map"
    )]
    Unphysical {
        channel: String,
        /// Where it came from: the data file's column, or the map's constant.
        origin: String,
        time: f64,
        value: f64,
        unit: &'static str,
        what: &'static str,
    },

    /// A record that cannot be written as TOML.
    #[error("{reason}")]
    Serialize { reason: String },

    /// A channel named (left out, or given its own rate) that the profile
    /// does not record.
    #[error("the profile '{profile}' records no channel '{channel}'")]
    NoChannel { profile: String, channel: String },

    /// A channel name that cannot be a CSV header and file name.
    #[error(
        "channel name '{name}' must be non-empty and use only letters, digits, '_', '-' and '.'"
    )]
    ChannelName { name: String },

    /// An anti-alias cut-off at or above the simulator's Nyquist frequency.
    #[error(
        "channel {channel}: the anti-alias cut-off {cutoff} Hz is not below the simulator's Nyquist frequency {nyquist} Hz"
    )]
    AntiAlias {
        channel: String,
        cutoff: f64,
        nyquist: f64,
    },
}

impl Error {
    /// The problems found in a file that does not validate.
    pub fn field_errors(&self) -> Option<&[aeroid_core::error::FieldError]> {
        match self {
            Error::Core(error) => error.field_errors(),
            _ => None,
        }
    }
}

/// A result whose error is this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
