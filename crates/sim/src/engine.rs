//! ASSUMED engine map. The simulator models thrust only; a recorder also
//! stores fan and core speed, fuel flow and exhaust-gas temperature (Wang et al. 2012,
//! Table 1, records EGT, fuel flow and N2 of both engines). These are smooth,
//! monotonic, made-up functions of the corrected thrust fraction of one
//! engine, good enough to give engine channels realistic magnitudes and
//! trends. They are NOT a model of any real engine and no estimator should
//! treat them as physics.
//!
//! With `c = T / (T_max·σ)` (thrust over maximum sea-level thrust, corrected
//! by the density ratio σ = ρ/ρ0), per engine:
//! - N1 = 0.20 + 0.80·√c            (fraction of rated fan speed)
//! - N2 = 0.55 + 0.45·c^0.4         (fraction of rated core speed)
//! - fuel flow = 0.02 kg/s + TSFC·T_engine, TSFC = 2.0e-5 kg/(N·s)
//!   (≈ 0.7 lb/(lbf·h), a low-bypass turbofan)
//! - EGT = T_static + 200 K + 450 K·c
//!
//! The thrust is split equally over `ENGINE_COUNT` engines (ASSUMED twin).

use crate::aircraft::Propulsion;
use crate::atmosphere::SEA_LEVEL_DENSITY;

/// Number of engines the thrust is split over (ASSUMED: a twin, as Wang et al. 2012's airplane and ATTAS).
pub(crate) const ENGINE_COUNT: f64 = 2.0;
/// Thrust-specific fuel consumption, kg/(N·s) (ASSUMED).
const SPECIFIC_FUEL_CONSUMPTION: f64 = 2.0e-5;
/// Fuel flow at zero thrust, kg/s per engine (ASSUMED idle flow).
const IDLE_FUEL_FLOW: f64 = 0.02;

/// The state of one engine, as its recorder channels would read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngineReading {
    /// Fan speed, fraction of rated.
    pub n1: f64,
    /// Core speed, fraction of rated.
    pub n2: f64,
    /// Fuel flow, kg/s.
    pub fuel_flow: f64,
    /// Exhaust-gas temperature, K.
    pub exhaust_gas_temperature: f64,
}

/// One engine's reading for the total thrust `thrust` (N) at density `density`
/// and static temperature `temperature` (K).
pub fn reading(
    propulsion: &Propulsion,
    thrust: f64,
    density: f64,
    temperature: f64,
) -> EngineReading {
    let available = propulsion.max_thrust * density / SEA_LEVEL_DENSITY;
    let fraction = if available > 0.0 {
        (thrust / available).max(0.0)
    } else {
        0.0
    };
    EngineReading {
        n1: 0.20 + 0.80 * fraction.sqrt(),
        n2: 0.55 + 0.45 * fraction.powf(0.4),
        fuel_flow: IDLE_FUEL_FLOW + SPECIFIC_FUEL_CONSUMPTION * thrust / ENGINE_COUNT,
        exhaust_gas_temperature: temperature + 200.0 + 450.0 * fraction,
    }
}
