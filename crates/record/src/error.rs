//! The errors of recording and preparing data that are the record crate's
//! own: a recorder profile asked for a channel it does not record, a
//! channel name that cannot be a file or column name, an anti-alias filter
//! the simulator's grid cannot hold.

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
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
        "the anti-alias cut-off {cutoff} Hz is not below the simulator's Nyquist frequency {nyquist} Hz"
    )]
    AntiAlias { cutoff: f64, nyquist: f64 },
}
