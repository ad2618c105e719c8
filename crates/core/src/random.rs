//! Seeded random streams. Every random draw in aeroid comes from a ChaCha8
//! stream keyed by (seed, stream), so that a seed gives the same numbers
//! whatever the thread count or shard split. Each consumer owns a fixed stream
//! number; a Monte Carlo case uses its case index as stream of the study seed.

use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// Stream numbers of the consumers inside one simulated flight.
pub mod streams {
    /// Dryden turbulence of the wind model.
    pub const TURBULENCE: u64 = 1;
    /// Sensor noise, dropouts and faults of the recorder.
    pub const RECORDER: u64 = 2;
    /// Process noise of a linear model's flight.
    pub const PROCESS_NOISE: u64 = 3;
    /// Random input weights and biases of a neural estimator's network.
    pub const NETWORK_WEIGHTS: u64 = 4;
    /// The extra start values of output error's several starts.
    pub const MULTI_START: u64 = 5;
}

/// The generator for `stream` of `seed`.
pub fn stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}
