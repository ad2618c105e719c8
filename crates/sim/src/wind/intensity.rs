//! Turbulence scales and intensities by altitude (MIL-F-8785C):
//! * below 1000 ft (h in ft, clamped to ≥ 10 ft): W20 = 15, 30, 45 kt for
//!   light, moderate, severe; σw = 0.1·W20,
//!   σu = σv = σw/(0.177 + 0.000823h)^0.4; Lw = h,
//!   Lu = Lv = h/(0.177 + 0.000823h)^1.2;
//! * above 2000 ft: Lu = Lv = Lw = 1750 ft and σu = σv = σw from MIL-F-8785C
//!   Figure 10 at the probability of exceedance 10⁻² (light), 10⁻³ (moderate),
//!   10⁻⁵ (severe), interpolated linearly in altitude in the tabulation of
//!   Gage (AIAA 2003-5529);
//! * in between: linear in altitude between the 1000 ft and the 2000 ft values.
//!
//! Explicit lengths default by the same altitude rules.

use aeroid_core::units::{FOOT, KNOT};

/// The turbulence intensities of MIL-F-8785C.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Intensity {
    Light,
    Moderate,
    Severe,
}

/// Altitudes (ft) of the tabulated MIL-F-8785C Figure 10 (Gage, AIAA 2003-5529).
const EXCEEDANCE_ALTITUDES: [f64; 12] = [
    500.0, 1750.0, 3750.0, 7500.0, 15000.0, 25000.0, 35000.0, 45000.0, 55000.0, 65000.0, 75000.0,
    80000.0,
];
/// RMS intensity (ft/s) at probability of exceedance 10⁻² (light).
const LIGHT_SIGMAS: [f64; 12] = [6.6, 6.9, 7.4, 6.7, 4.6, 2.7, 0.4, 0.0, 0.0, 0.0, 0.0, 0.0];
/// RMS intensity (ft/s) at probability of exceedance 10⁻³ (moderate).
const MODERATE_SIGMAS: [f64; 12] = [8.6, 9.6, 10.6, 10.1, 8.0, 6.6, 5.0, 4.2, 2.7, 0.0, 0.0, 0.0];
/// RMS intensity (ft/s) at probability of exceedance 10⁻⁵ (severe).
const SEVERE_SIGMAS: [f64; 12] = [
    15.6, 17.6, 23.0, 23.6, 22.1, 20.0, 16.0, 15.1, 12.1, 7.9, 6.2, 5.1,
];

/// Top of the low-altitude model and bottom of the medium/high-altitude model, ft.
const LOW_ALTITUDE_TOP: f64 = 1000.0;
const MEDIUM_ALTITUDE_BOTTOM: f64 = 2000.0;
/// Scale length of the medium/high-altitude model, ft.
const MEDIUM_ALTITUDE_LENGTH: f64 = 1750.0;
/// Lowest altitude the low-altitude model is evaluated at, ft.
const MINIMUM_ALTITUDE: f64 = 10.0;

impl Intensity {
    pub(super) fn parse(name: &str) -> Option<Intensity> {
        match name.trim().to_ascii_lowercase().as_str() {
            "light" => Some(Intensity::Light),
            "moderate" => Some(Intensity::Moderate),
            "severe" => Some(Intensity::Severe),
            _ => None,
        }
    }

    /// Wind speed at 20 ft, m/s.
    fn wind_at_20_ft(self) -> f64 {
        let knots = match self {
            Intensity::Light => 15.0,
            Intensity::Moderate => 30.0,
            Intensity::Severe => 45.0,
        };
        knots * KNOT
    }

    /// σu, σv, σw (m/s) of the low-altitude model at `altitude` ft.
    fn low_altitude_sigmas(self, altitude: f64) -> [f64; 3] {
        let sigma_w = 0.1 * self.wind_at_20_ft();
        let sigma_u = sigma_w / low_altitude_factor(altitude).powf(0.4);
        [sigma_u, sigma_u, sigma_w]
    }

    /// σ (m/s, equal for u, v, w) of the medium/high-altitude model at `altitude` ft.
    fn medium_altitude_sigma(self, altitude: f64) -> f64 {
        let table = match self {
            Intensity::Light => &LIGHT_SIGMAS,
            Intensity::Moderate => &MODERATE_SIGMAS,
            Intensity::Severe => &SEVERE_SIGMAS,
        };
        interpolate(&EXCEEDANCE_ALTITUDES, table, altitude) * FOOT
    }

    /// σu, σv, σw (m/s) at `altitude` ft, blending the models between 1000 and 2000 ft.
    pub(super) fn sigmas(self, altitude: f64) -> [f64; 3] {
        let low = self.low_altitude_sigmas(altitude.clamp(MINIMUM_ALTITUDE, LOW_ALTITUDE_TOP));
        let medium = [self.medium_altitude_sigma(altitude.max(MEDIUM_ALTITUDE_BOTTOM)); 3];
        blend(low, medium, altitude)
    }
}

/// 0.177 + 0.000823·h of the low-altitude model, h in ft.
fn low_altitude_factor(altitude: f64) -> f64 {
    0.177 + 0.000823 * altitude
}

/// Lu, Lv, Lw (ft) of the low-altitude model at `altitude` ft.
fn low_altitude_lengths(altitude: f64) -> [f64; 3] {
    let length_u = altitude / low_altitude_factor(altitude).powf(1.2);
    [length_u, length_u, altitude]
}

/// Lu, Lv, Lw (ft) at `altitude` ft, blending the models between 1000 and 2000 ft.
pub(super) fn scale_lengths(altitude: f64) -> [f64; 3] {
    let low = low_altitude_lengths(altitude.clamp(MINIMUM_ALTITUDE, LOW_ALTITUDE_TOP));
    blend(low, [MEDIUM_ALTITUDE_LENGTH; 3], altitude)
}

/// `low` below 1000 ft, `medium` above 2000 ft, linear in altitude (ft) in between.
fn blend(low: [f64; 3], medium: [f64; 3], altitude: f64) -> [f64; 3] {
    let span = MEDIUM_ALTITUDE_BOTTOM - LOW_ALTITUDE_TOP;
    let fraction = ((altitude - LOW_ALTITUDE_TOP) / span).clamp(0.0, 1.0);
    std::array::from_fn(|axis| low[axis] + fraction * (medium[axis] - low[axis]))
}

/// Piecewise-linear interpolation of (xs, ys) at x, held constant outside.
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let upper = xs.partition_point(|&knot| knot < x);
    if upper == 0 {
        return ys[0];
    }
    if upper == xs.len() {
        return ys[xs.len() - 1];
    }
    let fraction = (x - xs[upper - 1]) / (xs[upper] - xs[upper - 1]);
    ys[upper - 1] + fraction * (ys[upper] - ys[upper - 1])
}
