//! What evaluations of a driven model share and keep: the measured
//! signals' angles and air at the points where RK4 evaluates them, the
//! grid points 2k and the steps' midpoints 2k + 1, linear between samples
//! ([`Frozen`]); the angles and air of the last state seen, recomputed only
//! for what moved, an integrated angle moved from its anchor by the
//! addition theorems ([`Memo`]); and the kinematics and forcing of the last
//! point a filter evaluated its sigma points at ([`PointMemo`]).

use super::kinematics::{Angles, kinematics};
use super::measured::{Ambient, Surroundings};
use super::{ALPHA, ALTITUDE, BETA, FLIGHT_PATH_SIZE, FlightPathState, PITCH, ROLL};
use aeroid_sim::atmosphere::Atmosphere;
use aeroid_sim::dynamics::{FlightModel, Forcing, Kinematics};
use aeroid_sim::state::Controls;
use std::sync::OnceLock;

/// The measured signals' angle sines and cosines, the record's measured
/// quantities and the air at the points where RK4 evaluates them, the grid
/// points (index 2k) and the steps' midpoints (2k + 1): the same in every
/// simulation of a record, so computed once (the air for the first
/// atmosphere asked for, at the measured altitude).
#[derive(Debug, Clone, Default)]
pub(super) struct Frozen {
    pub(super) angles: Vec<Angles>,
    pub(super) ambient: Vec<Ambient>,
    pub(super) air: OnceLock<(Atmosphere, Vec<Surroundings>)>,
}

impl Frozen {
    pub(super) fn new(measured: &[FlightPathState], ambient: &[Ambient]) -> Frozen {
        Frozen {
            angles: frozen_points(measured).map(|x| Angles::of(&x)).collect(),
            ambient: frozen_ambient(ambient).collect(),
            air: OnceLock::new(),
        }
    }

    /// The air and thrust at every point for `atmosphere` and the measured
    /// altitude; None for another atmosphere than the first.
    pub(super) fn air(
        &self,
        measured: &[FlightPathState],
        atmosphere: &Atmosphere,
    ) -> Option<&[Surroundings]> {
        let (first, air) = self.air.get_or_init(|| {
            let air = frozen_points(measured)
                .zip(&self.ambient)
                .map(|(x, ambient)| ambient.surroundings(atmosphere, x[ALTITUDE]))
                .collect();
            (*atmosphere, air)
        });
        (first == atmosphere).then_some(air.as_slice())
    }

    /// The frozen points' angles and air (for `atmosphere`), and their
    /// measured quantities: what a [`Memo`] reads.
    pub(super) fn for_memo<'a>(
        &'a self,
        measured: &[FlightPathState],
        atmosphere: &Atmosphere,
    ) -> FrozenPoints<'a> {
        FrozenPoints {
            angles: &self.angles,
            air: self.air(measured, atmosphere),
            ambient: &self.ambient,
        }
    }
}

/// What a [`Memo`] reads of [`Frozen`] (empty: nothing frozen).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct FrozenPoints<'a> {
    pub(super) angles: &'a [Angles],
    pub(super) air: Option<&'a [Surroundings]>,
    pub(super) ambient: &'a [Ambient],
}

/// The measured quantities at the grid points and the steps' midpoints,
/// interpolated as [`frozen_points`].
fn frozen_ambient(ambient: &[Ambient]) -> impl Iterator<Item = Ambient> + '_ {
    ambient.iter().enumerate().flat_map(move |(k, &point)| {
        let midpoint = ambient.get(k + 1).map(|next| point.between(*next, 0.5));
        std::iter::once(point).chain(midpoint)
    })
}

/// The measured state a fraction θ into the step from `start` to `end`:
/// linear (measured pseudo-controls are continuous signals).
pub(super) fn between(
    start: &FlightPathState,
    end: &FlightPathState,
    theta: f64,
) -> FlightPathState {
    start + (end - start) * theta
}

/// The measured states at the grid points and the steps' midpoints,
/// interpolated as [`DrivenSimulation::simulate`](super::DrivenSimulation::simulate) does.
fn frozen_points(measured: &[FlightPathState]) -> impl Iterator<Item = FlightPathState> + '_ {
    measured.iter().enumerate().flat_map(move |(k, &point)| {
        let midpoint = measured.get(k + 1).map(|next| between(&point, next, 0.5));
        std::iter::once(point).chain(midpoint)
    })
}

/// The angles' sines and cosines and the air of the last state seen,
/// recomputed only for what moved: RK4's two middle stages share the
/// measured pseudo-controls, and a step's last stage has the next grid
/// point's, so most are reused; measured ones come from [`Frozen`] at the
/// point set by [`Memo::at_point`].
#[derive(Clone, Copy)]
pub(super) struct Memo<'a> {
    pub(super) x: Option<FlightPathState>,
    pub(super) angles: Angles,
    /// The integrated angles where the library last gave their sines and
    /// cosines, and those: the others are moved from there
    /// ([`Angles::moved_from`]), each within an ulp or two of the library's
    /// (no error carried from one to the next).
    pub(super) anchor: (FlightPathState, Angles),
    pub(super) air: Surroundings,
    /// The record's measured quantities at the point, and those `air` was
    /// computed with.
    pub(super) ambient: Ambient,
    air_ambient: Ambient,
    /// Which states are measured, the frozen points, and the point.
    pub(super) measured: [bool; FLIGHT_PATH_SIZE],
    pub(super) frozen: FrozenPoints<'a>,
    pub(super) point: usize,
}

impl<'a> Memo<'a> {
    pub(super) fn new(measured: [bool; FLIGHT_PATH_SIZE], frozen: FrozenPoints<'a>) -> Memo<'a> {
        Memo {
            x: None,
            angles: Angles::ZERO,
            anchor: (FlightPathState::zeros(), Angles::ZERO),
            air: Surroundings::default(),
            ambient: frozen.ambient.first().copied().unwrap_or_default(),
            air_ambient: Ambient::default(),
            measured,
            frozen,
            point: 0,
        }
    }

    /// The states that follow are at frozen point `index` (2k: grid point
    /// k; 2k + 1: the midpoint of step k).
    pub(super) fn at_point(&mut self, index: usize) {
        self.point = index;
        if let Some(&ambient) = self.frozen.ambient.get(index) {
            self.ambient = ambient;
        }
    }

    /// Forgets the last state and the anchors: the next state's integrated
    /// angles are the library's. Called at every grid point, so that an
    /// integration step depends on its start state alone, not on the path
    /// that led there (a filter steps from states no simulation visited).
    pub(super) fn restart(&mut self) {
        self.x = None;
    }

    pub(super) fn of(
        &mut self,
        x: &FlightPathState,
        atmosphere: &Atmosphere,
    ) -> (Angles, Surroundings) {
        let (first, last) = (self.x.is_none(), self.x.unwrap_or(*x));
        let FrozenPoints { angles, air, .. } = self.frozen;
        let frozen_air = air.map(|air| air[self.point]);
        for i in [ALPHA, BETA, ROLL, PITCH] {
            if self.measured[i] {
                let frozen = angles[self.point].get(i);
                // The frozen point is x's (every test that simulates checks it).
                debug_assert_eq!(frozen, Some(x[i].sin_cos()));
                *self.angles.slot(i).expect("an angle") = frozen.expect("an angle");
            } else if first {
                self.angles = self.angles.moved(i, x[i]);
            } else if x[i] != last[i] {
                let (at, angles) = &mut self.anchor;
                let anchor = (at[i], angles.get(i).expect("an angle"));
                if self.angles.moved_from(i, anchor, x[i]) {
                    at[i] = x[i];
                    *angles.slot(i).expect("an angle") = self.angles.get(i).expect("an angle");
                }
            }
        }
        if first {
            self.anchor = (*x, self.angles);
        }
        match frozen_air {
            Some(air) if self.measured[ALTITUDE] => {
                debug_assert_eq!(air, self.ambient.surroundings(atmosphere, x[ALTITUDE]));
                self.air = air
            }
            _ if first || x[ALTITUDE] != last[ALTITUDE] || self.ambient != self.air_ambient => {
                self.air = self.ambient.surroundings(atmosphere, x[ALTITUDE]);
                self.air_ambient = self.ambient;
            }
            _ => {}
        }
        self.x = Some(*x);
        (self.angles, self.air)
    }
}

/// The angles' sines and cosines, the kinematics and the forcing
/// ([`FlightModel::forcing`]) of the last full state and controls an
/// evaluation was at (with the measured quantities and the atmosphere it
/// was taken with): a filter evaluates its sigma points' outputs at one
/// time, most of them (those that move only an augmented model's
/// parameters) at one state, and they share them.
#[derive(Debug, Clone, Default)]
pub(in crate::model) struct PointMemo {
    last: Option<PointKey>,
}

/// What a [`PointMemo`] keeps: the point, and what was computed there.
#[derive(Debug, Clone)]
struct PointKey {
    pub(super) x: FlightPathState,
    pub(super) controls: Controls,
    pub(super) ambient: Ambient,
    pub(super) atmosphere: Atmosphere,
    pub(super) angles: Angles,
    pub(super) kinematics: Kinematics,
    pub(super) forcing: Forcing,
}

impl PointMemo {
    /// The library's sines and cosines of x's angles, the kinematics with
    /// the air at x's altitude ([`Ambient::surroundings`]) and their
    /// forcing by `model` with `controls`; the kept ones when x, the
    /// controls, the measured quantities and the atmosphere are the last
    /// call's (`model` differing from the last call's in its aerodynamic
    /// parameters at most).
    pub(super) fn of(
        &mut self,
        model: &FlightModel,
        x: &FlightPathState,
        controls: &Controls,
        ambient: Ambient,
    ) -> (&Angles, &Kinematics, &Forcing) {
        let atmosphere = &model.environment.atmosphere;
        let kept = matches!(&self.last, Some(last) if last.x == *x
            && last.controls == *controls
            && last.ambient == ambient
            && last.atmosphere == *atmosphere);
        if !kept {
            self.last = None;
        }
        let last = self.last.get_or_insert_with(|| {
            let angles = Angles::of(x);
            let air = ambient.surroundings(atmosphere, x[ALTITUDE]);
            let kinematics = kinematics(x, &angles, &air);
            let forcing = model.forcing(&kinematics, controls);
            PointKey {
                x: *x,
                controls: *controls,
                ambient,
                atmosphere: *atmosphere,
                angles,
                kinematics,
                forcing,
            }
        });
        (&last.angles, &last.kinematics, &last.forcing)
    }
}
