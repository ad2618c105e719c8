//! The aircraft of a simulator other than aeroid's (JSBSim): which model
//! names it has. A scenario that names one of them is checked against this
//! catalogue when it loads; [`crate::source`] flies it. A program registers
//! the simulator once ([`crate::source::register_jsbsim`]), and with it
//! this catalogue, so that the simulator layer does not depend on JSBSim.

use std::sync::OnceLock;

/// The aircraft a foreign simulator has.
pub trait AircraftCatalog: Send + Sync {
    /// `Ok` when the simulator has the aircraft `model`; else an error
    /// naming what was looked for ([`crate::error::Error::Foreign`]).
    fn check_model(&self, model: &str) -> std::result::Result<(), crate::error::Error>;
}

static JSBSIM_AIRCRAFT: OnceLock<&'static dyn AircraftCatalog> = OnceLock::new();

/// Makes `catalog` JSBSim's (the first registration holds).
pub(crate) fn register_jsbsim(catalog: &'static dyn AircraftCatalog) {
    let _ = JSBSIM_AIRCRAFT.set(catalog);
}

/// JSBSim's aircraft, when a JSBSim is registered.
pub fn jsbsim() -> Option<&'static dyn AircraftCatalog> {
    JSBSIM_AIRCRAFT.get().copied()
}
