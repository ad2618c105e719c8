//! Reading a recorder profile file: each channel's keys checked and turned
//! into SI ([`ChannelModel`]), every problem recorded under its key
//! (`channels.NAME.KEY`) so that a profile's faults are reported at once.

use super::{ChannelModel, ChannelSpec, Fault, FaultSpec, OriginSpec};
use crate::derived::{self, GeographicOrigin};
use aeroid_core::error::FieldErrors;
use aeroid_core::limits;
use aeroid_core::units::{Dimension, Quantity, unit_factor};
use nalgebra::Vector3;
use std::collections::BTreeSet;

/// Frame length and words per frame, for placing channels in the frame.
pub(super) struct FrameLayout {
    pub(super) frame: f64,
    pub(super) words: Option<u32>,
}

/// A positive value, else NaN with the problem recorded under `field`.
pub(super) fn positive(
    value: aeroid_core::Result<f64>,
    field: &str,
    problems: &mut FieldErrors,
) -> f64 {
    match value {
        Ok(v) if v > 0.0 => v,
        Ok(v) => {
            problems.push(field, format!("must be positive, is {v}"));
            f64::NAN
        }
        Err(message) => {
            problems.push(field, message);
            f64::NAN
        }
    }
}

/// The profile's origin (default 0, 0): latitude within ±89°, longitude
/// within ±180°.
pub(super) fn read_origin(
    spec: Option<&OriginSpec>,
    problems: &mut FieldErrors,
) -> GeographicOrigin {
    let Some(spec) = spec else {
        return GeographicOrigin::default();
    };
    let mut angle = |field: &str, q: &Quantity, limit: f64| match q.si(Dimension::Angle) {
        Ok(v) if v.abs() <= limit => v,
        Ok(_) => {
            problems.push(field, format!("must be within ±{} deg", limit.to_degrees()));
            0.0
        }
        Err(message) => {
            problems.push(field, message);
            0.0
        }
    };
    GeographicOrigin {
        latitude: angle("origin.latitude", &spec.latitude, 89.0_f64.to_radians()),
        longitude: angle("origin.longitude", &spec.longitude, std::f64::consts::PI),
    }
}

/// Checks that each quantity stated absent is known and not recorded.
pub(super) fn check_absent(
    absent: &[String],
    recorded: &BTreeSet<&str>,
    problems: &mut FieldErrors,
) {
    for name in absent {
        if derived::measurand(name).is_none() {
            problems.push(
                "absent",
                format!(
                    "unknown quantity '{name}'; known: {}",
                    derived::measurand_names().join(", ")
                ),
            );
        } else if recorded.contains(name.as_str()) {
            problems.push("absent", format!("'{name}' is also recorded as a channel"));
        }
    }
}

/// Validates one channel; `None` when its name is unknown (the problem is recorded).
pub(super) fn read_channel(
    spec: &ChannelSpec,
    layout: &FrameLayout,
    problems: &mut FieldErrors,
) -> Option<ChannelModel> {
    let prefix = format!("channels.{}", spec.name);
    let Some(measurand) = derived::measurand(&spec.name) else {
        problems.push(
            format!("{prefix}.name"),
            format!(
                "unknown quantity; known: {}",
                derived::measurand_names().join(", ")
            ),
        );
        return None;
    };
    let dimension = measurand.dimension;
    let mut reader = FieldReader {
        prefix: &prefix,
        problems,
    };
    let rate = reader.rate(&spec.rate);
    let phase = reader.non_negative("phase", &spec.phase, Dimension::Time);
    let slot = reader.slot(spec, layout);
    let model = ChannelModel {
        measurand,
        label: spec.label.clone(),
        rate,
        offset: phase + slot * layout.frame,
        resolution: spec.resolution.as_ref().map(|q| {
            reader.check(
                "resolution",
                q.si(dimension),
                |v| v > 0.0,
                "must be positive",
            )
        }),
        saturation: spec
            .saturation
            .as_ref()
            .map(|limits| reader.saturation(limits, dimension)),
        noise: reader.non_negative("noise", &spec.noise, dimension),
        noise_time: reader.sensor_time("noise_time", &spec.noise_time),
        bias: reader.value("bias", &spec.bias, dimension),
        scale_factor: reader.check(
            "scale_factor",
            Ok(spec.scale_factor.unwrap_or(1.0)),
            f64::is_finite,
            "must be a finite number",
        ),
        delay: reader.sensor_time("delay", &spec.delay),
        lag: reader.sensor_time("lag", &spec.lag),
        anti_alias: spec.anti_alias.as_ref().map(|q| {
            reader.check(
                "anti_alias",
                q.si(Dimension::Frequency),
                |v| v > 0.0,
                "must be positive",
            )
        }),
        dropout: reader.check(
            "dropout",
            Ok(spec.dropout),
            |p| (0.0..=1.0).contains(&p),
            "must be a probability within [0, 1]",
        ),
        fault: spec.fault.as_ref().map(|f| reader.fault(f, dimension)),
        position: reader.position(spec),
    };
    Some(model)
}

/// Reads the fields of one channel, recording problems under `channels.NAME.`.
struct FieldReader<'a> {
    prefix: &'a str,
    problems: &'a mut FieldErrors,
}

impl FieldReader<'_> {
    fn push(&mut self, field: &str, message: impl std::fmt::Display) {
        self.problems
            .push(format!("{}.{field}", self.prefix), message);
    }

    fn check(
        &mut self,
        field: &str,
        value: aeroid_core::Result<f64>,
        valid: impl Fn(f64) -> bool,
        requirement: &str,
    ) -> f64 {
        match value {
            Ok(v) if valid(v) => v,
            Ok(v) => {
                self.push(field, format!("{requirement}, is {v}"));
                f64::NAN
            }
            Err(message) => {
                self.push(field, message);
                f64::NAN
            }
        }
    }

    fn value(&mut self, field: &str, q: &Quantity, dimension: Dimension) -> f64 {
        self.check(field, q.si(dimension), |_| true, "")
    }

    fn non_negative(&mut self, field: &str, q: &Quantity, dimension: Dimension) -> f64 {
        self.check(field, q.si(dimension), |v| v >= 0.0, "must not be negative")
    }

    /// A sample rate within (0, [`limits::MAX_RATE`]].
    fn rate(&mut self, q: &Quantity) -> f64 {
        let rate = self.check("rate", parse_rate(q), |v| v > 0.0, "must be positive");
        if rate > limits::MAX_RATE {
            self.push("rate", rate_limit_message(rate));
            return f64::NAN;
        }
        rate
    }

    /// A delay or lag time constant within [0, [`limits::MAX_SENSOR_TIME`]].
    fn sensor_time(&mut self, field: &str, q: &Quantity) -> f64 {
        let value = self.non_negative(field, q, Dimension::Time);
        if value > limits::MAX_SENSOR_TIME {
            self.push(
                field,
                format!(
                    "{} s is above the longest {} s (longer than the slowest aircraft mode's period: such a sensor records no motion)",
                    limits::number(value),
                    limits::number(limits::MAX_SENSOR_TIME)
                ),
            );
            return f64::NAN;
        }
        value
    }

    /// The channel's place in the frame as a fraction, from `slot` or `word`.
    fn slot(&mut self, spec: &ChannelSpec, layout: &FrameLayout) -> f64 {
        match (spec.slot, spec.word, layout.words) {
            (Some(_), Some(_), _) => {
                self.push("slot", "give either slot or word, not both");
                0.0
            }
            (Some(slot), None, _) => self.check(
                "slot",
                Ok(slot),
                |s| (0.0..1.0).contains(&s),
                "must be a fraction of the frame within [0, 1)",
            ),
            (None, Some(word), Some(words)) if word < words => f64::from(word) / f64::from(words),
            (None, Some(word), Some(words)) => {
                self.push(
                    "word",
                    format!("{word} is not below words_per_frame = {words}"),
                );
                0.0
            }
            (None, Some(_), None) => {
                self.push("word", "needs words_per_frame at the top of the profile");
                0.0
            }
            (None, None, _) => 0.0,
        }
    }

    fn saturation(&mut self, limits: &[Quantity; 2], dimension: Dimension) -> (f64, f64) {
        let low = self.value("saturation", &limits[0], dimension);
        let high = self.value("saturation", &limits[1], dimension);
        if low >= high {
            self.push(
                "saturation",
                "the lower limit must be below the upper limit",
            );
        }
        (low, high)
    }

    fn fault(&mut self, spec: &FaultSpec, dimension: Dimension) -> Fault {
        match spec {
            FaultSpec::Stuck { from, value } => Fault::Stuck {
                from: self.non_negative("fault.from", from, Dimension::Time),
                value: value
                    .as_ref()
                    .map(|v| self.value("fault.value", v, dimension)),
            },
            FaultSpec::Levels { values } => {
                if values.is_empty() {
                    self.push("fault.values", "needs at least one value");
                }
                Fault::Levels(
                    values
                        .iter()
                        .map(|v| self.value("fault.values", v, dimension))
                        .collect(),
                )
            }
        }
    }

    fn position(&mut self, spec: &ChannelSpec) -> Vector3<f64> {
        let Some(position) = &spec.position else {
            return Vector3::zeros();
        };
        if !matches!(spec.name.as_str(), "nx" | "ny" | "nz") {
            self.push(
                "position",
                "only load-factor channels (nx, ny, nz) have a sensor position",
            );
        }
        Vector3::from_fn(|i, _| self.value("position", &position[i], Dimension::Length))
    }
}

/// Why a sample rate above [`limits::MAX_RATE`] is refused.
pub fn rate_limit_message(rate: f64) -> String {
    format!(
        "{} Hz is above the highest rate {} Hz (far above any flight-test system's sampling of aircraft motion)",
        limits::number(rate),
        limits::number(limits::MAX_RATE)
    )
}

/// A rate as written in a profile: a number (Hz), `"25 Hz"`, `"0.5"`, or a fraction `"1/64 Hz"`.
pub fn parse_rate(q: &Quantity) -> aeroid_core::Result<f64> {
    let Quantity::Text(text) = q else {
        return q.si(Dimension::Frequency);
    };
    let text = text.trim();
    let (number, unit) = text.split_once(char::is_whitespace).unwrap_or((text, "Hz"));
    let parse = |s: &str| s.trim().parse::<f64>().ok();
    let value = match number.split_once('/') {
        Some((numerator, denominator)) => {
            parse(numerator).zip(parse(denominator)).map(|(n, d)| n / d)
        }
        None => parse(number),
    };
    match value {
        Some(value) => Ok(value * unit_factor(unit, Dimension::Frequency)?),
        None => q.si(Dimension::Frequency),
    }
}
