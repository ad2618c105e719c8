//! International Standard Atmosphere (ICAO Doc 7488), troposphere and lower
//! stratosphere (0–20 km geopotential, taken equal to geometric altitude on
//! a flat earth). A temperature offset shifts temperature at constant
//! pressure, so density follows from the gas law: ρ = p / (R·(T_ISA + ΔT)).

pub const SEA_LEVEL_TEMPERATURE: f64 = 288.15;
pub const SEA_LEVEL_PRESSURE: f64 = 101_325.0;
/// p0/(R·T0) = 1.224 999 kg/m³ (ICAO rounds it to 1.2250).
pub const SEA_LEVEL_DENSITY: f64 = SEA_LEVEL_PRESSURE / (GAS_CONSTANT * SEA_LEVEL_TEMPERATURE);
pub const GAS_CONSTANT: f64 = 287.052_87;
pub const HEAT_CAPACITY_RATIO: f64 = 1.4;
const LAPSE_RATE: f64 = 0.0065;
const TROPOPAUSE: f64 = 11_000.0;
const GRAVITY: f64 = aeroid_core::units::STANDARD_GRAVITY;
/// The earth radius of the ISA's geopotential altitude (m), ICAO Doc 7488.
pub const GEOPOTENTIAL_EARTH_RADIUS: f64 = 6_356_766.0;

/// Air properties at one altitude.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Air {
    pub temperature: f64,
    pub pressure: f64,
    pub density: f64,
    pub speed_of_sound: f64,
    /// ln(ρ/ρ0), for power laws in density without `powf`.
    pub log_density_ratio: f64,
    /// A measured Mach number that stands for V/a (a record's `mach`
    /// channel); None: Mach is the airspeed over `speed_of_sound`.
    pub mach: Option<f64>,
}

/// ISA with a temperature offset `temperature_offset` (K).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Atmosphere {
    pub temperature_offset: f64,
}

impl Atmosphere {
    pub fn new(temperature_offset: f64) -> Self {
        Atmosphere { temperature_offset }
    }

    /// Standard temperature and pressure at `altitude` (m).
    pub fn standard(altitude: f64) -> (f64, f64) {
        let (temperature, _, log_pressure_ratio) = Self::standard_log(altitude);
        (temperature, SEA_LEVEL_PRESSURE * log_pressure_ratio.exp())
    }

    /// Standard temperature, ln(T/T0) and ln(p/p0) at `altitude`: one logarithm, no `powf`.
    fn standard_log(altitude: f64) -> (f64, f64, f64) {
        let exponent = GRAVITY / (GAS_CONSTANT * LAPSE_RATE);
        let tropopause_temperature = SEA_LEVEL_TEMPERATURE - LAPSE_RATE * TROPOPAUSE;
        if altitude <= TROPOPAUSE {
            let temperature = SEA_LEVEL_TEMPERATURE - LAPSE_RATE * altitude;
            let log_temperature_ratio = (temperature / SEA_LEVEL_TEMPERATURE).ln();
            (
                temperature,
                log_temperature_ratio,
                exponent * log_temperature_ratio,
            )
        } else {
            let log_temperature_ratio = (tropopause_temperature / SEA_LEVEL_TEMPERATURE).ln();
            let above =
                -GRAVITY * (altitude - TROPOPAUSE) / (GAS_CONSTANT * tropopause_temperature);
            (
                tropopause_temperature,
                log_temperature_ratio,
                exponent * log_temperature_ratio + above,
            )
        }
    }

    pub fn at(&self, altitude: f64) -> Air {
        let (standard_temperature, log_temperature_ratio, log_pressure_ratio) =
            Self::standard_log(altitude);
        let temperature = standard_temperature + self.temperature_offset;
        let pressure = SEA_LEVEL_PRESSURE * log_pressure_ratio.exp();
        // ρ/ρ0 = (p/p0)·(T0/T); the logarithm serves power laws such as thrust lapse.
        let log_density_ratio = if self.temperature_offset == 0.0 {
            log_pressure_ratio - log_temperature_ratio
        } else {
            log_pressure_ratio - (temperature / SEA_LEVEL_TEMPERATURE).ln()
        };
        Air {
            temperature,
            pressure,
            density: pressure / (GAS_CONSTANT * temperature),
            speed_of_sound: (HEAT_CAPACITY_RATIO * GAS_CONSTANT * temperature).sqrt(),
            log_density_ratio,
            mach: None,
        }
    }

    /// The geopotential altitude H = r0·z/(r0 + z) of the geometric
    /// altitude z (r0 = 6 356 766 m): the altitude the ISA is tabulated in.
    pub fn geopotential_altitude(geometric: f64) -> f64 {
        GEOPOTENTIAL_EARTH_RADIUS * geometric / (GEOPOTENTIAL_EARTH_RADIUS + geometric)
    }

    /// Density altitude: the altitude at which the standard day's (no
    /// temperature offset) density equals `density` (kg/m³). Below the
    /// tropopause ρ/ρ0 = (T/T0)^(g0/(R·L) − 1), so T = T0·(ρ/ρ0)^(1/(g0/(R·L) − 1))
    /// and H = (T0 − T)/L; above it ρ falls exponentially at T11.
    pub fn density_altitude(density: f64) -> f64 {
        let exponent = GRAVITY / (GAS_CONSTANT * LAPSE_RATE) - 1.0;
        let (tropopause_temperature, tropopause_pressure) = Self::standard(TROPOPAUSE);
        let tropopause_density = tropopause_pressure / (GAS_CONSTANT * tropopause_temperature);
        if density >= tropopause_density {
            let temperature =
                SEA_LEVEL_TEMPERATURE * (density / SEA_LEVEL_DENSITY).powf(1.0 / exponent);
            (SEA_LEVEL_TEMPERATURE - temperature) / LAPSE_RATE
        } else {
            TROPOPAUSE
                - GAS_CONSTANT * tropopause_temperature / GRAVITY
                    * (density / tropopause_density).ln()
        }
    }

    /// Pressure altitude: the ISA altitude at which the standard pressure equals `pressure`.
    pub fn pressure_altitude(pressure: f64) -> f64 {
        let exponent = GAS_CONSTANT * LAPSE_RATE / GRAVITY;
        let (tropopause_temperature, tropopause_pressure) = Self::standard(TROPOPAUSE);
        if pressure >= tropopause_pressure {
            (SEA_LEVEL_TEMPERATURE / LAPSE_RATE)
                * (1.0 - (pressure / SEA_LEVEL_PRESSURE).powf(exponent))
        } else {
            TROPOPAUSE
                - GAS_CONSTANT * tropopause_temperature / GRAVITY
                    * (pressure / tropopause_pressure).ln()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ICAO standard atmosphere table values (Doc 7488): 0, 5 000, 11 000, 15 000 m.
    #[test]
    fn matches_icao_table() {
        let atmosphere = Atmosphere::default();
        let cases = [
            (0.0, 288.15, 101_325.0, 1.2250, 340.29),
            (5_000.0, 255.65, 54_019.9, 0.736_12, 320.53),
            (11_000.0, 216.65, 22_632.0, 0.363_91, 295.07),
            (15_000.0, 216.65, 12_044.6, 0.193_67, 295.07),
        ];
        for (h, t, p, rho, a) in cases {
            let air = atmosphere.at(h);
            assert!((air.temperature - t).abs() < 0.01, "T at {h}");
            assert!(
                (air.pressure / p - 1.0).abs() < 2e-4,
                "p at {h}: {}",
                air.pressure
            );
            assert!(
                (air.density / rho - 1.0).abs() < 2e-4,
                "rho at {h}: {}",
                air.density
            );
            assert!((air.speed_of_sound - a).abs() < 0.02, "a at {h}");
            assert!((Atmosphere::pressure_altitude(air.pressure) - h).abs() < 1e-6);
            assert!((Atmosphere::density_altitude(air.density) - h).abs() < 1e-6);
            assert!((air.log_density_ratio.exp() - air.density / SEA_LEVEL_DENSITY).abs() < 1e-4);
        }
    }

    /// 10 000 m geometric is 9 984.3 m geopotential (ICAO Doc 7488 table).
    #[test]
    fn geopotential_altitude_matches_icao() {
        let h = Atmosphere::geopotential_altitude(10_000.0);
        assert!((h - 9_984.3).abs() < 0.05, "{h}");
        assert_eq!(Atmosphere::geopotential_altitude(0.0), 0.0);
    }

    #[test]
    fn temperature_offset_keeps_pressure_and_lowers_density() {
        let hot = Atmosphere::new(15.0).at(2000.0);
        let standard = Atmosphere::default().at(2000.0);
        assert_eq!(hot.pressure, standard.pressure);
        assert!(
            (hot.density * hot.temperature - standard.density * standard.temperature).abs() < 1e-9
        );
    }
}
