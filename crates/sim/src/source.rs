//! Where a flight comes from: aeroid's own simulator (trim, RK4) for an
//! aeroid aircraft, or JSBSim for one of JSBSim's own aircraft (feature
//! `jsbsim`). [`Scenario::source`] is the one place that tells them apart;
//! everything that flies a scenario goes through [`FlightSource::fly`].
//!
//! The simulator layer does not depend on JSBSim: JSBSim is a
//! [`ForeignSimulator`] that the `jsbsim` module implements and a program
//! registers once ([`register_jsbsim`]; the `aeroid` binary built with the
//! feature does, through `aeroid::jsbsim::register`).

use crate::Simulation;
use crate::error::{Error, Result};
pub use crate::foreign::AircraftCatalog;
use crate::scenario::{JsbsimAircraft, Scenario};
use crate::trace::TruthTrace;
use crate::truth::RunTruth;
use std::sync::OnceLock;

/// A simulator other than aeroid's that flies the scenarios whose aircraft
/// is one of its own ([`AircraftCatalog`]: which they are).
pub trait ForeignSimulator: AircraftCatalog {
    /// Trims and flies `scenario` to its end or its departure.
    fn fly(&self, scenario: &Scenario) -> Result<Flight>;
}

static JSBSIM: OnceLock<&'static dyn ForeignSimulator> = OnceLock::new();

/// Makes `simulator` the one that flies JSBSim's aircraft, and its
/// catalogue the one a scenario is checked against (the first registration
/// holds).
pub fn register_jsbsim(simulator: &'static dyn ForeignSimulator) {
    let _ = JSBSIM.set(simulator);
    crate::foreign::register_jsbsim(simulator);
}

/// The registered JSBSim, if any.
pub fn jsbsim() -> Option<&'static dyn ForeignSimulator> {
    JSBSIM.get().copied()
}

/// The simulator that flies a scenario.
#[derive(Debug, Clone, Copy)]
pub enum FlightSource<'a> {
    /// aeroid's simulator; the run's truth is exact.
    Aeroid,
    /// JSBSim flying one of its own aircraft; the run's truth is JSBSim's
    /// local derivatives at the trim point.
    Jsbsim(&'a JsbsimAircraft),
}

/// The moment a flight left its limits, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Departure {
    pub time: f64,
    pub reason: String,
}

impl Departure {
    /// The error of a flight that had to stay within its limits.
    pub fn into_error(self) -> Error {
        Error::Departed {
            time: self.time,
            reason: self.reason,
        }
    }
}

/// A flown scenario. When it departed, `trace` ends at the last step before
/// the departure, so that nothing computed is lost.
#[derive(Debug, Clone)]
pub struct Flight {
    pub trace: TruthTrace,
    pub truth: RunTruth,
    pub departure: Option<Departure>,
}

impl Flight {
    /// The trace and truth of a flight that stayed within its limits; a
    /// departure is an [`Error::Departed`].
    pub fn complete(self) -> Result<(TruthTrace, RunTruth)> {
        match self.departure {
            None => Ok((self.trace, self.truth)),
            Some(departure) => Err(departure.into_error()),
        }
    }
}

impl Scenario {
    /// The simulator that flies this scenario: JSBSim when its aircraft is
    /// one of JSBSim's own (`"jsbsim:NAME"`), else aeroid's.
    pub fn source(&self) -> FlightSource<'_> {
        match &self.jsbsim {
            Some(aircraft) => FlightSource::Jsbsim(aircraft),
            None => FlightSource::Aeroid,
        }
    }
}

impl FlightSource<'_> {
    /// The simulator's name, for messages.
    pub fn name(&self) -> &'static str {
        match self {
            FlightSource::Aeroid => "aeroid",
            FlightSource::Jsbsim(_) => "JSBSim",
        }
    }

    /// Trims and flies `scenario` (whose source this is) to its end or its departure.
    pub fn fly(&self, scenario: &Scenario) -> Result<Flight> {
        // aeroid's own flight checks the scenario's size in
        // `Simulation::prepare`; a JSBSim flight is checked here.
        if let FlightSource::Jsbsim(_) = self {
            scenario.check_size()?;
        }
        match self {
            FlightSource::Aeroid => {
                let simulation = Simulation::prepare(scenario)?;
                let (trace, departure) = simulation.fly();
                Ok(Flight {
                    trace,
                    truth: RunTruth::exact(scenario, &simulation.trim),
                    departure,
                })
            }
            FlightSource::Jsbsim(_) => match jsbsim() {
                Some(simulator) => simulator.fly(scenario),
                None => Err(aeroid_core::Error::Invalid {
                    path: scenario.path.clone(),
                    problems: vec![aeroid_core::error::FieldError {
                        field: "aircraft".into(),
                        message: "is one of JSBSim's own aircraft, and no JSBSim is registered: the aeroid program built with `--features jsbsim` flies it (a library user calls aeroid::jsbsim::register())".into(),
                    }],
                }.into()),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An aeroid aircraft is flown by aeroid's simulator: the flight through
    /// the source is the simulation's own run, bit for bit, with the exact truth.
    #[test]
    fn an_aeroid_scenario_is_flown_by_the_aeroid_simulator() {
        let mut scenario = Scenario::load("attas-trim").unwrap();
        scenario.duration = 2.0;
        let source = scenario.source();
        assert!(matches!(source, FlightSource::Aeroid), "{source:?}");
        let flight = source.fly(&scenario).unwrap();
        assert!(flight.departure.is_none());
        let direct = Simulation::prepare(&scenario).unwrap().run().unwrap();
        assert_eq!(flight.trace, direct);
        assert_eq!(flight.truth.kind, crate::truth::TruthKind::Exact);
    }
}
