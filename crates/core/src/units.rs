//! Units. Inside aeroid everything is SI with angles in radians. Files may
//! write any quantity either as a plain number (taken as SI / radians) or as a
//! string with a unit, e.g. `"5 deg"`, `"250 kt"`, `"16000 ft"`; the unit is
//! checked against the dimension the field expects.

use serde::{Deserialize, Serialize};
use std::fmt;

pub const DEG: f64 = std::f64::consts::PI / 180.0;
pub const FOOT: f64 = 0.3048;
pub const KNOT: f64 = 1852.0 / 3600.0;
pub const STANDARD_GRAVITY: f64 = 9.80665;
/// The international pound-force (N).
pub const POUND_FORCE: f64 = 4.448_221_615_260_5;
/// The slug (kg): one pound-force accelerates it by one foot per second squared.
pub const SLUG: f64 = POUND_FORCE / FOOT;
/// One inch of mercury at 0 °C (Pa).
pub(crate) const INCH_OF_MERCURY: f64 = 3_386.389;

/// The physical dimension a field expects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    Dimensionless,
    Angle,
    AngularRate,
    Length,
    Area,
    Speed,
    Acceleration,
    AngularAcceleration,
    Time,
    Frequency,
    Mass,
    Force,
    Inertia,
    TemperatureDifference,
    MassFlow,
    Pressure,
    Density,
    /// Load factor: specific force in units of standard gravity (dimensionless).
    LoadFactor,
}

impl Dimension {
    /// Every dimension, for finding the one a unit belongs to.
    pub const ALL: [Dimension; 18] = [
        Dimension::Dimensionless,
        Dimension::Angle,
        Dimension::AngularRate,
        Dimension::Length,
        Dimension::Area,
        Dimension::Speed,
        Dimension::Acceleration,
        Dimension::AngularAcceleration,
        Dimension::Time,
        Dimension::Frequency,
        Dimension::Mass,
        Dimension::Force,
        Dimension::Inertia,
        Dimension::TemperatureDifference,
        Dimension::MassFlow,
        Dimension::Pressure,
        Dimension::Density,
        Dimension::LoadFactor,
    ];

    /// Units accepted for this dimension with their factor to SI.
    // A table, one arm per dimension: the units and their factors are data, not steps.
    fn units(self) -> &'static [(&'static str, f64)] {
        use Dimension::*;
        match self {
            Dimensionless => &[("", 1.0), ("-", 1.0), ("%", 0.01)],
            Angle => &[("rad", 1.0), ("deg", DEG), ("°", DEG)],
            AngularRate => &[("rad/s", 1.0), ("deg/s", DEG), ("°/s", DEG)],
            AngularAcceleration => &[
                ("rad/s2", 1.0),
                ("rad/s^2", 1.0),
                ("rad/s²", 1.0),
                ("deg/s2", DEG),
                ("deg/s^2", DEG),
                ("deg/s²", DEG),
                ("°/s²", DEG),
            ],
            Length => &[
                ("m", 1.0),
                ("km", 1000.0),
                ("ft", FOOT),
                ("nmi", 1852.0),
                ("FL", 100.0 * FOOT),
            ],
            Area => &[
                ("m2", 1.0),
                ("m^2", 1.0),
                ("m²", 1.0),
                ("ft2", FOOT * FOOT),
                ("ft^2", FOOT * FOOT),
                ("ft²", FOOT * FOOT),
            ],
            Speed => &[
                ("m/s", 1.0),
                ("kt", KNOT),
                ("kts", KNOT),
                ("kn", KNOT),
                ("km/h", 1.0 / 3.6),
                ("ft/s", FOOT),
                ("ft/min", FOOT / 60.0),
            ],
            Acceleration => &[
                ("m/s2", 1.0),
                ("m/s^2", 1.0),
                ("m/s²", 1.0),
                ("g", STANDARD_GRAVITY),
                ("ft/s2", FOOT),
                ("ft/s^2", FOOT),
                ("ft/s²", FOOT),
            ],
            Time => &[("s", 1.0), ("ms", 1e-3), ("min", 60.0), ("h", 3600.0)],
            Frequency => &[("Hz", 1.0), ("1/s", 1.0)],
            Mass => &[
                ("kg", 1.0),
                ("t", 1000.0),
                ("lb", 0.453_592_37),
                ("slug", SLUG),
            ],
            Force => &[
                ("N", 1.0),
                ("kN", 1000.0),
                ("daN", 10.0),
                ("lbf", POUND_FORCE),
            ],
            Inertia => &[
                ("kg*m2", 1.0),
                ("kg m^2", 1.0),
                ("kg*m^2", 1.0),
                ("kg m2", 1.0),
                ("slug*ft2", 1.355_817_948_331_4),
            ],
            TemperatureDifference => &[("K", 1.0), ("degC", 1.0), ("°C", 1.0)],
            MassFlow => &[
                ("kg/s", 1.0),
                ("kg/h", 1.0 / 3600.0),
                ("lb/h", 0.453_592_37 / 3600.0),
            ],
            Pressure => &[
                ("Pa", 1.0),
                ("N/m2", 1.0),
                ("hPa", 100.0),
                ("kPa", 1000.0),
                ("mbar", 100.0),
                ("psi", POUND_FORCE / (FOOT * FOOT / 144.0)),
                ("psf", POUND_FORCE / (FOOT * FOOT)),
                ("lbf/ft2", POUND_FORCE / (FOOT * FOOT)),
                ("lbf/ft^2", POUND_FORCE / (FOOT * FOOT)),
                ("lbf/ft²", POUND_FORCE / (FOOT * FOOT)),
                ("inHg", INCH_OF_MERCURY),
            ],
            Density => &[
                ("kg/m3", 1.0),
                ("kg/m^3", 1.0),
                ("kg/m³", 1.0),
                ("slug/ft3", SLUG / (FOOT * FOOT * FOOT)),
                ("slug/ft^3", SLUG / (FOOT * FOOT * FOOT)),
                ("slug/ft³", SLUG / (FOOT * FOOT * FOOT)),
            ],
            LoadFactor => &[
                ("", 1.0),
                ("-", 1.0),
                ("g", 1.0),
                ("m/s2", 1.0 / STANDARD_GRAVITY),
                ("m/s^2", 1.0 / STANDARD_GRAVITY),
                ("m/s²", 1.0 / STANDARD_GRAVITY),
                ("ft/s2", FOOT / STANDARD_GRAVITY),
                ("ft/s^2", FOOT / STANDARD_GRAVITY),
                ("ft/s²", FOOT / STANDARD_GRAVITY),
            ],
        }
    }

    /// The dimension in words, for messages.
    pub fn label(self) -> &'static str {
        use Dimension::*;
        match self {
            Dimensionless => "a dimensionless quantity",
            Angle => "angle",
            AngularRate => "angular rate",
            AngularAcceleration => "angular acceleration",
            Length => "length",
            Area => "area",
            Speed => "speed",
            Acceleration => "acceleration",
            Time => "time",
            Frequency => "frequency",
            Mass => "mass",
            Force => "force",
            Inertia => "moment of inertia",
            TemperatureDifference => "temperature",
            MassFlow => "mass flow",
            Pressure => "pressure",
            Density => "density",
            LoadFactor => "load factor",
        }
    }

    /// The SI unit this dimension is stored in, for messages and CSV headers.
    pub fn si_unit(self) -> &'static str {
        self.units()[0].0
    }

    fn accepted(self) -> String {
        self.units()
            .iter()
            .map(|(u, _)| if u.is_empty() { "(none)" } else { u })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Factor from `unit` to SI for a dimension, or an error listing accepted units.
pub fn unit_factor(unit: &str, dimension: Dimension) -> crate::Result<f64> {
    let unit = unit.trim();
    dimension
        .units()
        .iter()
        .find(|(name, _)| {
            name.eq_ignore_ascii_case(unit) && (unit == *name || !is_case_sensitive(name))
        })
        .map(|(_, factor)| *factor)
        .ok_or_else(|| crate::Error::Unit {
            unit: unit.into(),
            dimension: dimension.label(),
            accepted: dimension.accepted(),
        })
}

/// Units whose case carries meaning (`g` vs `G`, `kN`, `Hz`): compared exactly.
fn is_case_sensitive(name: &str) -> bool {
    matches!(
        name,
        "t" | "g" | "kN" | "N" | "daN" | "Hz" | "K" | "Pa" | "hPa" | "kPa"
    )
}

/// A quantity as written in a file: a plain number (SI) or `"value unit"`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Quantity {
    Number(f64),
    Text(String),
}

/// What a quantity field takes, in the words of an error about anything else.
pub(crate) const QUANTITY_EXPECTED: &str = "a quantity (a number or a string such as \"5 deg\")";

impl<'de> Deserialize<'de> for Quantity {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = Quantity;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(QUANTITY_EXPECTED)
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Quantity, E> {
                Ok(Quantity::Number(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Quantity, E> {
                Ok(Quantity::Number(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Quantity, E> {
                Ok(Quantity::Number(v as f64))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Quantity, E> {
                Ok(Quantity::Text(v.to_string()))
            }
            fn visit_string<E: serde::de::Error>(self, v: String) -> Result<Quantity, E> {
                Ok(Quantity::Text(v))
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

impl Default for Quantity {
    fn default() -> Self {
        Quantity::Number(0.0)
    }
}

impl From<f64> for Quantity {
    fn from(value: f64) -> Self {
        Quantity::Number(value)
    }
}

impl fmt::Display for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Quantity::Number(v) => write!(f, "{v}"),
            Quantity::Text(t) => write!(f, "\"{t}\""),
        }
    }
}

impl Quantity {
    /// The value in SI units (radians for angles). Rejects NaN and infinities.
    pub fn si(&self, dimension: Dimension) -> crate::Result<f64> {
        let value = match self {
            Quantity::Number(v) => *v,
            Quantity::Text(text) => parse_with_unit(text, dimension)?,
        };
        if value.is_finite() {
            Ok(value)
        } else {
            Err(crate::Error::NotFinite {
                value: self.to_string(),
            })
        }
    }
}

fn parse_with_unit(text: &str, dimension: Dimension) -> crate::Result<f64> {
    let text = text.trim();
    let split = text
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit()
                || matches!(c, '.' | '+' | '-')
                || (matches!(c, 'e' | 'E') && is_exponent(text, i)))
        })
        .map_or(text.len(), |(i, _)| i);
    let (number, unit) = text.split_at(split);
    let value: f64 = number
        .trim()
        .parse()
        .map_err(|_| crate::Error::NotANumber { text: text.into() })?;
    Ok(value * unit_factor(unit, dimension)?)
}

/// An `e` at byte `i` is an exponent when a digit or sign follows it.
fn is_exponent(text: &str, i: usize) -> bool {
    text[i + 1..]
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_digit() || c == '-' || c == '+')
}

/// Serde: a time written as a quantity (`"0.1 s"` or `0.1`), read as seconds.
pub fn seconds<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<f64, D::Error> {
    Quantity::deserialize(deserializer)?
        .si(Dimension::Time)
        .map_err(serde::de::Error::custom)
}

/// Serde: an optional time written as a quantity, read as seconds.
pub fn optional_seconds<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<Option<f64>, D::Error> {
    Option::<Quantity>::deserialize(deserializer)?
        .map(|q| q.si(Dimension::Time).map_err(serde::de::Error::custom))
        .transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_si_and_strings_carry_units() {
        assert_eq!(Quantity::Number(2.0).si(Dimension::Angle).unwrap(), 2.0);
        let deg = Quantity::Text("5 deg".into()).si(Dimension::Angle).unwrap();
        assert!((deg - 5.0 * DEG).abs() < 1e-15);
        let kt = Quantity::Text("100kt".into()).si(Dimension::Speed).unwrap();
        assert!((kt - 51.444_444_444_444_44).abs() < 1e-9);
        let ft = Quantity::Text("-1.5e3 ft".into())
            .si(Dimension::Length)
            .unwrap();
        assert!((ft + 457.2).abs() < 1e-9);
        assert_eq!(
            Quantity::Text("3 g".into())
                .si(Dimension::Acceleration)
                .unwrap(),
            3.0 * STANDARD_GRAVITY
        );
    }

    #[test]
    fn wrong_unit_and_nan_are_rejected() {
        let err = Quantity::Text("5 kt".into())
            .si(Dimension::Angle)
            .unwrap_err()
            .to_string();
        assert!(err.contains("'kt'") && err.contains("deg"), "{err}");
        assert!(Quantity::Number(f64::NAN).si(Dimension::Length).is_err());
    }

    #[test]
    fn a_boolean_is_not_a_quantity() {
        #[derive(Debug, Deserialize)]
        struct File {
            #[allow(dead_code)]
            duration: Quantity,
        }
        let error = toml::from_str::<File>("duration = true").unwrap_err();
        assert!(
            error
                .message()
                .contains("expected a quantity (a number or a string such as \"5 deg\")"),
            "{error}"
        );
        let file: File = toml::from_str("duration = 5").unwrap();
        assert_eq!(file.duration, Quantity::Number(5.0));
        let file: File = toml::from_str("duration = \"5 s\"").unwrap();
        assert_eq!(file.duration, Quantity::Text("5 s".into()));
        assert!(Quantity::Text("abc".into()).si(Dimension::Length).is_err());
    }

    /// Every unit of every dimension against a value from its definition
    /// (NIST SP 811 factors), and every listed unit is covered.
    #[test]
    fn every_unit_converts_to_its_known_si_value() {
        use Dimension::*;
        let cases: &[(Dimension, &str, f64)] = &[
            (Dimensionless, "", 1.0),
            (Dimensionless, "-", 1.0),
            (Dimensionless, "%", 0.01),
            (Angle, "rad", 1.0),
            (Angle, "deg", 0.017_453_292_519_943_295),
            (Angle, "°", 0.017_453_292_519_943_295),
            (AngularRate, "rad/s", 1.0),
            (AngularRate, "deg/s", 0.017_453_292_519_943_295),
            (AngularRate, "°/s", 0.017_453_292_519_943_295),
            (AngularAcceleration, "rad/s2", 1.0),
            (AngularAcceleration, "rad/s^2", 1.0),
            (AngularAcceleration, "rad/s²", 1.0),
            (AngularAcceleration, "deg/s2", 0.017_453_292_519_943_295),
            (AngularAcceleration, "deg/s^2", 0.017_453_292_519_943_295),
            (AngularAcceleration, "deg/s²", 0.017_453_292_519_943_295),
            (AngularAcceleration, "°/s²", 0.017_453_292_519_943_295),
            (Length, "m", 1.0),
            (Length, "km", 1000.0),
            (Length, "ft", 0.3048),
            (Length, "nmi", 1852.0),
            (Length, "FL", 30.48),
            (Area, "m2", 1.0),
            (Area, "m^2", 1.0),
            (Area, "m²", 1.0),
            (Area, "ft2", 0.092_903_04),
            (Area, "ft^2", 0.092_903_04),
            (Area, "ft²", 0.092_903_04),
            (Speed, "m/s", 1.0),
            (Speed, "kt", 0.514_444_444_444_444_4),
            (Speed, "kts", 0.514_444_444_444_444_4),
            (Speed, "kn", 0.514_444_444_444_444_4),
            (Speed, "km/h", 0.277_777_777_777_777_8),
            (Speed, "ft/s", 0.3048),
            (Speed, "ft/min", 0.00508),
            (Acceleration, "m/s2", 1.0),
            (Acceleration, "m/s^2", 1.0),
            (Acceleration, "m/s²", 1.0),
            (Acceleration, "g", 9.80665),
            (Acceleration, "ft/s2", 0.3048),
            (Acceleration, "ft/s^2", 0.3048),
            (Acceleration, "ft/s²", 0.3048),
            (Time, "s", 1.0),
            (Time, "ms", 0.001),
            (Time, "min", 60.0),
            (Time, "h", 3600.0),
            (Frequency, "Hz", 1.0),
            (Frequency, "1/s", 1.0),
            (Mass, "kg", 1.0),
            (Mass, "t", 1000.0),
            (Mass, "lb", 0.453_592_37),
            (Mass, "slug", 14.593_902_937_206_364),
            (Force, "N", 1.0),
            (Force, "kN", 1000.0),
            (Force, "daN", 10.0),
            (Force, "lbf", 4.448_221_615_260_5),
            (Inertia, "kg*m2", 1.0),
            (Inertia, "kg m^2", 1.0),
            (Inertia, "kg*m^2", 1.0),
            (Inertia, "kg m2", 1.0),
            (Inertia, "slug*ft2", 1.355_817_948_331_4),
            (TemperatureDifference, "K", 1.0),
            (TemperatureDifference, "degC", 1.0),
            (TemperatureDifference, "°C", 1.0),
            (MassFlow, "kg/s", 1.0),
            (MassFlow, "kg/h", 1.0 / 3600.0),
            (MassFlow, "lb/h", 0.453_592_37 / 3600.0),
            (Pressure, "Pa", 1.0),
            (Pressure, "N/m2", 1.0),
            (Pressure, "hPa", 100.0),
            (Pressure, "kPa", 1000.0),
            (Pressure, "mbar", 100.0),
            (Pressure, "psi", 6_894.757_293_168_361),
            (Pressure, "psf", 47.880_258_980_335_84),
            (Pressure, "lbf/ft2", 47.880_258_980_335_84),
            (Pressure, "lbf/ft^2", 47.880_258_980_335_84),
            (Pressure, "lbf/ft²", 47.880_258_980_335_84),
            (Pressure, "inHg", 3_386.389),
            (Density, "kg/m3", 1.0),
            (Density, "kg/m^3", 1.0),
            (Density, "kg/m³", 1.0),
            (Density, "slug/ft3", 515.378_818_393_196),
            (Density, "slug/ft^3", 515.378_818_393_196),
            (Density, "slug/ft³", 515.378_818_393_196),
            (LoadFactor, "", 1.0),
            (LoadFactor, "-", 1.0),
            (LoadFactor, "g", 1.0),
            (LoadFactor, "m/s2", 1.0 / 9.80665),
            (LoadFactor, "m/s^2", 1.0 / 9.80665),
            (LoadFactor, "m/s²", 1.0 / 9.80665),
            (LoadFactor, "ft/s2", 0.3048 / 9.80665),
            (LoadFactor, "ft/s^2", 0.3048 / 9.80665),
            (LoadFactor, "ft/s²", 0.3048 / 9.80665),
        ];
        for &(dimension, unit, expected) in cases {
            let factor = unit_factor(unit, dimension).unwrap();
            assert!(
                (factor / expected - 1.0).abs() < 1e-14,
                "{unit} as {dimension:?}: {factor}, expected {expected}"
            );
        }
        for dimension in Dimension::ALL {
            for (unit, _) in dimension.units() {
                assert!(
                    cases.iter().any(|&(d, u, _)| d == dimension && u == *unit),
                    "{unit} of {dimension:?} has no test"
                );
            }
        }
        // Known values: 1 slug/ft³ is 515.379 kg/m³; 29.92 inHg is 1013.2 hPa;
        // FL100 is 3048 m; 1 psf is 47.88 Pa.
        assert!((29.92 * unit_factor("inHg", Pressure).unwrap() - 101_320.76).abs() < 0.01);
        let error = unit_factor("kg/m3", Dimensionless).unwrap_err().to_string();
        assert!(
            error.starts_with("unit 'kg/m3' is not a unit of a dimensionless quantity"),
            "{error}"
        );
    }
}
