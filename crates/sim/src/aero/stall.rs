//! The quasi-steady stall model with Kirchhoff flow separation (Verma &
//! Peyada 2020, Eqs. 2–4, after Fischenberg):
//!
//! `τ1·dχ/dt + χ = ½·(1 − tanh(a1·(α − τ2·α̇ − α*)))`   (Eq. 2; Eq. 3 when τ1 = 0)
//! `CL = CL0 + CLα·((1 + √χ)/2)²·α`,
//! `CD = CD0 + CL²/(e·π·Λ) + CDχ·(1 − χ)`,
//! `Cm = Cm0 + Cmα·α + Cmq·q̂ + Cmδe·δe + Cmχ·(1 − χ)`   (Eq. 4).
//!
//! χ (1 attached, 0 separated) is a state when τ1 > 0 and algebraic when
//! τ1 = 0. Variants: τ in c̄/V, τ2 only while α̇ < 0 (a sharp switch, or the
//! smooth α̇·½(1 − tanh(α̇/b))), the induced drag of the attached lift, α̇
//! from the state or from the measured α
//! ([`AeroInput::measured_alpha_dot`]).

use super::model::{AeroInput, AeroModel};
use super::spec::{ModelKind, RateSpeed, StallAlphaDot, StallTimeUnit};
use aeroid_numerics::dual::Real;

impl AeroModel {
    /// True when χ is integrated as a state (stall model with τ1 > 0).
    pub fn chi_is_state(&self) -> bool {
        self.stall
            .is_some_and(|s| self.parameters.values()[s.tau1] > 0.0)
    }

    /// True when the forces depend on the state's α̇ algebraically (α̇
    /// terms, or algebraic χ with τ2 ≠ 0), so the equations of motion must
    /// be solved for α̇, in a model driven by a record: one whose
    /// separation takes the measured α̇ (`alpha_dot = "measured"`) is given
    /// it there, and its χ does not depend on the state's α̇.
    pub fn forces_depend_on_alpha_dot(&self) -> bool {
        self.forces_depend_on_state_alpha_dot(true)
    }

    /// [`AeroModel::forces_depend_on_alpha_dot`] where a measured α̇ is
    /// given (`measured`) or not (the simulator flying a truth, whose
    /// separation then takes the state's α̇ whatever the option).
    pub fn forces_depend_on_state_alpha_dot(&self, measured: bool) -> bool {
        let values = self.parameters.values();
        let stall = self.stall.is_some_and(|s| {
            values[s.tau1] == 0.0
                && values[s.tau2] != 0.0
                && !(measured && self.takes_measured_alpha_dot())
        });
        stall || self.has_alpha_dot_terms
    }

    /// Whether the separation equation takes the measured α̇ where there is
    /// one (`alpha_dot = "measured"`).
    pub fn takes_measured_alpha_dot(&self) -> bool {
        self.stall.is_some() && self.stall_options.alpha_dot == StallAlphaDot::Measured
    }

    /// The α̇ of the separation equation: the measured one with
    /// `alpha_dot = "measured"` when there is one, else the state's
    /// `alpha_dot`.
    pub fn separation_alpha_dot<T: Real>(&self, alpha_dot: T, measured: Option<f64>) -> T {
        match measured {
            Some(rate) if self.takes_measured_alpha_dot() => T::constant(rate),
            _ => alpha_dot,
        }
    }

    /// Steady-state separation point χ∞ = ½(1 − tanh(a1·(α − τ2·α̇ − α*))) (Verma & Peyada 2020, Eq. 3); 1 without stall model.
    /// at `airspeed` (it scales τ given in units of c̄/V); τ2·α̇ acts only
    /// while α̇ < 0 when the model says so.
    pub fn separation_target<T: Real>(&self, alpha: T, alpha_dot: T, airspeed: T) -> T {
        match self.stall {
            Some(s) => {
                let v = self.parameters.values();
                let rate = self.hysteresis_rate(alpha_dot);
                let lag = match self.chord_time(airspeed) {
                    None => rate * v[s.tau2],
                    Some(scale) => rate * scale * v[s.tau2],
                };
                (T::constant(1.0) - ((alpha - lag - v[s.alpha_star]) * v[s.a1]).tanh()) * 0.5
            }
            None => T::constant(1.0),
        }
    }

    /// χ∞ at α̇ = 0 (Eq. 3 with no hysteresis lag, whatever the airspeed).
    pub fn steady_separation(&self, alpha: f64) -> f64 {
        self.separation_target(alpha, 0.0, 1.0)
    }

    /// dχ/dt = (χ∞ − χ)/τ1 (Verma & Peyada 2020, Eq. 2); 0 when χ is not a state.
    pub fn separation_rate<T: Real>(&self, alpha: T, alpha_dot: T, chi: T, airspeed: T) -> T {
        match self.stall {
            Some(s) if self.chi_is_state() => {
                let tau1 = self.parameters.values()[s.tau1];
                let lag = self.separation_target(alpha, alpha_dot, airspeed) - chi;
                match self.chord_time(airspeed) {
                    None => lag / tau1,
                    Some(scale) => lag / (scale * tau1),
                }
            }
            _ => T::zero(),
        }
    }

    /// ∂(dχ/dt)/∂α̇ = ½·a1·τ2·(1 − tanh²(a1·(α − τ2·α̇ − α*)))/τ1 (from Eqs. 2–3,
    /// τ in seconds); 0 when χ is not a state, or τ2 does not act (α̇ ≥ 0
    /// with `tau2_only_while_decreasing`), or the separation takes the
    /// measured α̇ (in a model driven by a record, which gives it).
    pub fn separation_rate_slope(&self, alpha: f64, alpha_dot: f64, airspeed: f64) -> f64 {
        match self.stall {
            Some(s) if self.chi_is_state() && !self.takes_measured_alpha_dot() => {
                let v = self.parameters.values();
                let scale = self.chord_time(airspeed).unwrap_or(1.0);
                let (tau1, tau2) = (v[s.tau1] * scale, v[s.tau2] * scale);
                let rate = self.hysteresis_rate(alpha_dot);
                let t = (v[s.a1] * (alpha - tau2 * rate - v[s.alpha_star])).tanh();
                0.5 * v[s.a1] * tau2 * (1.0 - t * t) * self.hysteresis_rate_slope(alpha_dot) / tau1
            }
            _ => 0.0,
        }
    }

    /// Seconds per unit of the stall time constants at `airspeed`: None
    /// for τ in seconds, c̄/V for τ in units of c̄/V.
    fn chord_time<T: Real>(&self, airspeed: T) -> Option<T> {
        match self.stall_options.time_unit {
            StallTimeUnit::Seconds => None,
            StallTimeUnit::ChordTimes => {
                let speed = match self.rate_speed {
                    RateSpeed::Airspeed => airspeed,
                    RateSpeed::Reference => T::constant(self.reference_airspeed),
                };
                Some(T::constant(self.geometry.chord) / speed)
            }
        }
    }

    /// The α̇ the hysteresis τ2 acts on: α̇, or with
    /// `tau2_only_while_decreasing` α̇ while it is negative and 0 otherwise.
    /// With a `tau2_switch_band` b > 0 the switch is the smooth step
    /// α̇·½(1 − tanh(α̇/b)): α̇ below −2b (within 2 %), 0 above 2b.
    fn hysteresis_rate<T: Real>(&self, alpha_dot: T) -> T {
        let band = self.stall_options.tau2_switch_band;
        match (self.stall_options.tau2_only_while_decreasing, band > 0.0) {
            (false, _) => alpha_dot,
            (true, true) => {
                alpha_dot * (T::constant(1.0) - (alpha_dot * (1.0 / band)).tanh()) * 0.5
            }
            (true, false) if alpha_dot.value() >= 0.0 => T::zero(),
            (true, false) => alpha_dot,
        }
    }

    /// d/dα̇ of [`AeroModel::hysteresis_rate`] (0 at α̇ = 0 of the sharp switch).
    fn hysteresis_rate_slope(&self, alpha_dot: f64) -> f64 {
        let band = self.stall_options.tau2_switch_band;
        match (self.stall_options.tau2_only_while_decreasing, band > 0.0) {
            (false, _) => 1.0,
            (true, true) => {
                let t = (alpha_dot / band).tanh();
                0.5 * (1.0 - t) - 0.5 * alpha_dot / band * (1.0 - t * t)
            }
            (true, false) if alpha_dot >= 0.0 => 0.0,
            (true, false) => 1.0,
        }
    }

    /// The χ the forces use: the state when τ1 > 0, Eq. 3 when τ1 = 0, 1 without stall.
    #[inline(always)]
    pub fn effective_chi<T: Real>(&self, input: &AeroInput<T>) -> T {
        if self.stall.is_none() {
            T::constant(1.0)
        } else if self.chi_is_state() {
            input.chi
        } else {
            let alpha_dot = self.separation_alpha_dot(input.alpha_dot, input.measured_alpha_dot);
            self.separation_target(input.alpha, alpha_dot, input.airspeed)
        }
    }

    /// The factor on the lift-type `alpha` term: the Kirchhoff
    /// ((1 + √χ)/2)² of the stall model, 1 for a linear one.
    #[inline(always)]
    pub(super) fn kirchhoff<T: Real>(&self, chi: T) -> T {
        match self.kind {
            ModelKind::Stall => {
                let root = (chi.max_value(0.0).sqrt() + 1.0) * 0.5;
                root * root
            }
            ModelKind::Linear => T::constant(1.0),
        }
    }
}
