//! Data quality of a record, channel by channel: what a recorded channel
//! cannot be trusted for before any estimator reads it. Four checks, each
//! from the channel's own samples:
//!
//! - **stuck**, two kinds. *Levels*: at least `MIN_SAMPLES` valid
//!   samples that take only two or three distinct values and change between
//!   them in at least a quarter of the intervals, the values further apart
//!   than `DITHER_STEPS` declared resolutions (or no resolution declared):
//!   a moving quantity passes through the values between, a one-step dither
//!   of a quantized quantity is quantization. This is the angle-of-attack
//!   channel of Wang et al. 2012 (Sec. 4), which reads only 109.70° or
//!   108.30°. *Frozen*: a channel that never repeats a value exactly
//!   elsewhere (fewer than 5 % of its other intervals, as a noisy sensor)
//!   but holds one value for at least `MIN_SAMPLES` samples and a tenth
//!   of the record. A noise-free quantized channel repeats values as a
//!   matter of course, so there a frozen sensor cannot be told from a
//!   quantity that holds still, and a channel constant throughout (a rudder
//!   that never moved) is not flagged either;
//! - **quantized**: the resolution inferred from the spacing of the
//!   distinct values (at least three, all spacings whole multiples of the
//!   smallest, to 1e-3 of it), shown beside the declared one. Information,
//!   not a flag;
//! - **dropouts**: samples whose value is missing (NaN), with the longest
//!   run;
//! - **implausible steps**: a jump between consecutive valid samples larger
//!   than what the quantity can physically change in the interval
//!   (`rate_limit` × interval) plus `NEIGHBOURHOOD_FACTOR` times the
//!   typical jump around it (the median of the |jumps| within
//!   ±`NEIGHBOURHOOD` intervals, at least two resolutions: the noise and
//!   quantization the channel shows). Neither term alone will do: at 1 Hz
//!   an attitude moves degrees per sample, and at 25 Hz the noise alone
//!   exceeds a rate limit's share of a sample now and then. Headings and
//!   directions are differenced across north (359° → 1° is a 2° jump).
//!   Control positions (elevator, aileron, rudder, flap, throttle and their
//!   left/right channels) are not checked: a simulated step input jumps in
//!   one sample, and an actuator's rate depends on the aircraft; neither
//!   is a channel whose name is not a recorder quantity, or whose
//!   dimension has no limit.
//!
//! A channel is *flagged* when it is stuck, has dropouts or implausible
//! steps; it is *unusable* when stuck or stepping, and the geometric
//! angle-of-attack step (`crate::prep::flow_angles::with_geometric_flow_angles`)
//! replaces an unusable `alpha` or `beta` channel and says so.

use crate::{Channel, FlightRecord, derived, rounded};
use aeroid_core::units::{DEG, Dimension};
use aeroid_sim::state::Control;

/// The fewest valid samples a stuck verdict is made on.
pub(crate) const MIN_SAMPLES: usize = 10;
/// Levels at most this many declared resolutions apart are a dither.
pub(crate) const DITHER_STEPS: f64 = 4.0;
/// One-spacing changes that make a grid of values a quantisation ([`quantum`]).
pub(crate) const LSB_FLIPS: usize = 20;
/// A channel whose range spans at most this many LSB is near-constant: its
/// changes are quantisation, not control steps
/// ([`crate::prep::differentiation::transitions`]).
pub(crate) const FEW_LSB: f64 = 3.0;
/// A jump this many times the typical jump around it is out of place.
pub(crate) const NEIGHBOURHOOD_FACTOR: f64 = 10.0;
/// Intervals on each side whose jumps make the neighbourhood.
pub(crate) const NEIGHBOURHOOD: usize = 10;

/// What is wrong with a stuck channel.
#[derive(Debug, Clone, PartialEq)]
pub enum Stuck {
    /// Reads only these values (ascending), changing between them at random.
    Levels { values: Vec<f64> },
    /// Holds `value` from `from` to `to` (s).
    Frozen { value: f64, from: f64, to: f64 },
}

/// Missing samples of a channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dropouts {
    pub count: usize,
    /// The longest run of consecutive missing samples.
    pub longest: usize,
    /// The instant of the first missing sample (s).
    pub first: f64,
}

/// An implausible jump between two consecutive valid samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// The instant of the later sample (s).
    pub time: f64,
    /// The jump (channel unit).
    pub jump: f64,
    /// The typical jump around it (channel unit).
    pub typical: f64,
}

/// The quality of one channel.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelQuality {
    pub name: String,
    pub unit: String,
    pub samples: usize,
    pub declared_resolution: Option<f64>,
    pub inferred_resolution: Option<f64>,
    pub stuck: Option<Stuck>,
    pub dropouts: Option<Dropouts>,
    pub steps: Vec<Step>,
}

impl ChannelQuality {
    /// Stuck, dropouts or implausible steps.
    pub fn is_flagged(&self) -> bool {
        self.dropouts.is_some() || self.is_unusable()
    }

    /// Stuck or stepping: the values cannot be used as a measurement.
    pub fn is_unusable(&self) -> bool {
        self.stuck.is_some() || !self.steps.is_empty()
    }

    /// The flags in words, one per problem ("" when none).
    pub fn flags(&self) -> String {
        let mut flags = Vec::new();
        match &self.stuck {
            Some(Stuck::Levels { values }) => flags.push(format!(
                "stuck: reads only {} {}",
                values
                    .iter()
                    .map(|v| rounded(*v))
                    .collect::<Vec<_>>()
                    .join(", "),
                self.unit
            )),
            Some(Stuck::Frozen { value, from, to }) => flags.push(format!(
                "stuck: holds {} {} from {} s to {} s",
                rounded(*value),
                self.unit,
                rounded(*from),
                rounded(*to)
            )),
            None => {}
        }
        if let Some(d) = &self.dropouts {
            flags.push(format!(
                "{} dropouts (longest run {}, first at {} s)",
                d.count,
                d.longest,
                rounded(d.first)
            ));
        }
        if let Some(first) = self.steps.first() {
            flags.push(format!(
                "{} implausible steps (first at {} s: {} {} where {} is typical)",
                self.steps.len(),
                rounded(first.time),
                rounded(first.jump),
                self.unit,
                rounded(first.typical)
            ));
        }
        flags.join("; ")
    }
}

/// The quality of every channel of a record, in record order.
#[derive(Debug, Clone, PartialEq)]
pub struct QualityReport {
    pub channels: Vec<ChannelQuality>,
}

impl QualityReport {
    /// The quality of the channel with this name, if the record has it.
    pub fn channel(&self, name: &str) -> Option<&ChannelQuality> {
        self.channels.iter().find(|c| c.name == name)
    }

    /// Names of the flagged channels.
    pub fn flagged(&self) -> Vec<&str> {
        self.channels
            .iter()
            .filter(|c| c.is_flagged())
            .map(|c| c.name.as_str())
            .collect()
    }

    /// The `aeroid inspect --quality` table: per channel the samples,
    /// declared and inferred resolution, and the flags ("ok" when none).
    pub fn table(&self) -> String {
        let mut text = format!(
            "{:<30} {:<6} {:>7} {:>10} {:>10}  flags\n",
            "channel", "unit", "samples", "declared", "inferred"
        );
        for c in &self.channels {
            let resolution = |r: Option<f64>| r.map_or("-".to_string(), rounded);
            let flags = c.flags();
            text += &format!(
                "{:<30} {:<6} {:>7} {:>10} {:>10}  {}\n",
                c.name,
                c.unit,
                c.samples,
                resolution(c.declared_resolution),
                resolution(c.inferred_resolution),
                if flags.is_empty() { "ok" } else { &flags }
            );
        }
        let flagged = self.flagged();
        text += &match flagged.is_empty() {
            true => "no channel flagged\n".to_string(),
            false => format!("flagged: {}\n", flagged.join(", ")),
        };
        text
    }
}

/// Assesses every channel of a record (see the module documentation).
pub fn assess(record: &FlightRecord) -> QualityReport {
    QualityReport {
        channels: record.channels.iter().map(assess_channel).collect(),
    }
}

/// Assesses one channel.
pub(crate) fn assess_channel(channel: &Channel) -> ChannelQuality {
    let valid: Vec<(f64, f64)> = channel
        .times
        .iter()
        .zip(&channel.values)
        .filter(|(_, v)| !v.is_nan())
        .map(|(t, v)| (*t, *v))
        .collect();
    let inferred_resolution = inferred_resolution(&valid);
    let resolution = channel.resolution.or(inferred_resolution);
    ChannelQuality {
        name: channel.name.clone(),
        unit: channel.unit.clone(),
        samples: channel.values.len(),
        declared_resolution: channel.resolution,
        inferred_resolution,
        stuck: levels(&valid, channel.resolution).or_else(|| frozen(&valid)),
        dropouts: dropouts(channel),
        steps: steps(channel, &valid, resolution),
    }
}

/// The distinct values, ascending.
fn distinct(valid: &[(f64, f64)]) -> Vec<f64> {
    let mut values: Vec<f64> = valid.iter().map(|(_, v)| *v).collect();
    values.sort_by(f64::total_cmp);
    values.dedup();
    values
}

/// The smallest spacing of the distinct values when every spacing is a
/// whole multiple of it (at least three distinct values).
fn inferred_resolution(valid: &[(f64, f64)]) -> Option<f64> {
    let values = distinct(valid);
    if values.len() < 3 {
        return None;
    }
    grid_spacing(&values)
}

/// The smallest spacing of ascending distinct values (two at least) when
/// every spacing is a whole multiple of it, to 1e-3 of it.
fn grid_spacing(levels: &[f64]) -> Option<f64> {
    let spacings: Vec<f64> = levels.windows(2).map(|w| w[1] - w[0]).collect();
    let step = spacings.iter().copied().fold(f64::INFINITY, f64::min);
    let whole = |s: &f64| ((s / step) - (s / step).round()).abs() < 1e-3;
    (step.is_finite() && step > 0.0 && spacings.iter().all(whole)).then_some(step)
}

/// The least significant bit of a sampled channel (finite values, in
/// order) for telling quantisation from control steps: the declared
/// resolution, else the smallest spacing of the distinct values when they
/// lie on a grid of it and at least [`LSB_FLIPS`] consecutive samples
/// differ by exactly that spacing. A designed input changes level a few
/// times; a near-constant quantised channel at a level's edge flips by one
/// LSB again and again. Values on a grid that seldom move by one spacing
/// (a step input's few levels) have no LSB.
pub(crate) fn quantum(values: &[f64], declared: Option<f64>) -> Option<f64> {
    if let Some(resolution) = declared.filter(|r| r.is_finite() && *r > 0.0) {
        return Some(resolution);
    }
    let mut levels = values.to_vec();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let step = grid_spacing(&levels)?;
    let flips = values
        .windows(2)
        .filter(|w| ((w[1] - w[0]).abs() - step).abs() < 1e-3 * step)
        .count();
    (flips >= LSB_FLIPS).then_some(step)
}

/// Two or three levels changing at random, further apart than a dither.
fn levels(valid: &[(f64, f64)], declared: Option<f64>) -> Option<Stuck> {
    let values = distinct(valid);
    if valid.len() < MIN_SAMPLES || !(2..=3).contains(&values.len()) {
        return None;
    }
    let changes = valid.windows(2).filter(|w| w[0].1 != w[1].1).count();
    let spacing = values
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    let dither = declared.is_some_and(|r| spacing <= DITHER_STEPS * r);
    (4 * changes >= valid.len() - 1 && !dither).then_some(Stuck::Levels { values })
}

/// The longest run of one exact value in a channel that otherwise never
/// repeats (a live, noisy sensor that froze).
fn frozen(valid: &[(f64, f64)]) -> Option<Stuck> {
    let intervals = valid.len().saturating_sub(1);
    let (mut best, mut start) = ((0, 0), 0);
    for k in 1..=valid.len() {
        if k == valid.len() || valid[k].1 != valid[start].1 {
            if k - start > best.1 - best.0 {
                best = (start, k);
            }
            start = k;
        }
    }
    let run = best.1 - best.0;
    let repeats_inside = run.saturating_sub(1);
    let repeats = valid.windows(2).filter(|w| w[0].1 == w[1].1).count();
    let outside = intervals.saturating_sub(repeats_inside);
    let live = outside >= MIN_SAMPLES && 20 * (repeats - repeats_inside) < outside;
    (live && run >= MIN_SAMPLES && 10 * run >= valid.len()).then(|| Stuck::Frozen {
        value: valid[best.0].1,
        from: valid[best.0].0,
        to: valid[best.1 - 1].0,
    })
}

fn dropouts(channel: &Channel) -> Option<Dropouts> {
    let count = channel.dropouts();
    let first = channel.values.iter().position(|v| v.is_nan())?;
    let (mut longest, mut run) = (0, 0);
    for value in &channel.values {
        run = if value.is_nan() { run + 1 } else { 0 };
        longest = longest.max(run);
    }
    Some(Dropouts {
        count,
        longest,
        first: channel.times[first],
    })
}

/// The fastest a quantity of this dimension changes in flight, per second
/// (ASSUMED generous bounds for aircraft up to transport size: a fast
/// roll, 60°/s; 2 g along the path; 5 g/s; 100 m/s vertically; 100°/s² of
/// angular acceleration; a Mach number, 1 per second), if one is known. Channels of other dimensions
/// (temperatures, masses, flows, pressures) are not checked for steps.
pub(crate) fn rate_limit(dimension: Dimension) -> Option<f64> {
    match dimension {
        Dimension::Dimensionless => Some(1.0),
        Dimension::Angle => Some(60.0 * DEG),
        Dimension::Speed => Some(2.0 * aeroid_core::units::STANDARD_GRAVITY),
        Dimension::LoadFactor => Some(5.0),
        Dimension::Length => Some(100.0),
        Dimension::AngularRate => Some(100.0 * DEG),
        _ => None,
    }
}

/// Jumps beyond the physical rate limit plus the neighbourhood's noise.
fn steps(channel: &Channel, valid: &[(f64, f64)], resolution: Option<f64>) -> Vec<Step> {
    let measurand = derived::measurand(&channel.name);
    let wraps = measurand.is_some_and(|m| m.wraps);
    let control = |name: &str| {
        let base = name.split('_').next().unwrap_or(name);
        Control::ALL.iter().any(|c| c.name() == base)
    };
    let limit = measurand
        .filter(|m| !control(m.name))
        .and_then(|m| rate_limit(m.dimension));
    let Some(limit) = limit else {
        return Vec::new();
    };
    let jumps: Vec<f64> = valid
        .windows(2)
        .map(|w| {
            let jump = w[1].1 - w[0].1;
            match wraps {
                true => jump - std::f64::consts::TAU * (jump / std::f64::consts::TAU).round(),
                false => jump,
            }
        })
        .collect();
    let floor = 2.0 * resolution.unwrap_or(0.0);
    (0..jumps.len())
        .filter_map(|k| {
            let low = k.saturating_sub(NEIGHBOURHOOD);
            let high = (k + NEIGHBOURHOOD + 1).min(jumps.len());
            let mut around: Vec<f64> = (low..high)
                .filter(|&j| j != k)
                .map(|j| jumps[j].abs())
                .collect();
            if around.is_empty() {
                return None;
            }
            around.sort_by(f64::total_cmp);
            let typical = around[around.len() / 2].max(floor);
            let interval = valid[k + 1].0 - valid[k].0;
            let allowed = limit * interval + NEIGHBOURHOOD_FACTOR * typical;
            (jumps[k].abs() > allowed).then_some(Step {
                time: valid[k + 1].0,
                jump: jumps[k],
                typical,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(name: &str, rate: f64, values: Vec<f64>) -> Channel {
        Channel::uniform(name, rate, values)
    }

    /// A slow sinusoid (a healthy channel).
    fn smooth(count: usize) -> Vec<f64> {
        (0..count).map(|k| 0.1 * (k as f64 * 0.05).sin()).collect()
    }

    /// Wang et al.'s AoA: 109.70° or 108.30° at random → stuck at levels;
    /// the same two values a declared resolution of 1.4° apart are a dither.
    #[test]
    fn two_random_levels_are_stuck_unless_one_resolution_apart() {
        let values: Vec<f64> = (0..40)
            .map(|k| {
                if (k * 7) % 3 == 0 {
                    109.7 * DEG
                } else {
                    108.3 * DEG
                }
            })
            .collect();
        let quality = assess_channel(&channel("alpha", 0.5, values.clone()));
        assert_eq!(
            quality.stuck,
            Some(Stuck::Levels {
                values: vec![108.3 * DEG, 109.7 * DEG]
            })
        );
        assert!(quality.is_unusable() && quality.steps.is_empty());
        let mut dithering = channel("alpha", 0.5, values);
        dithering.resolution = Some(1.4 * DEG);
        assert_eq!(assess_channel(&dithering).stuck, None);
    }

    /// A noisy channel that freezes at its last value from sample 60 of
    /// 100 is stuck (frozen) from that instant; the same channel without
    /// the freeze, or quantized so that it repeats values, is not.
    #[test]
    fn a_noisy_channel_that_freezes_is_stuck() {
        let noisy: Vec<f64> = (0..100)
            .map(|k| 0.01 * (k as f64 * 1.7).sin() + 0.1 * (k as f64 * 0.05).sin())
            .collect();
        let mut frozen = noisy.clone();
        frozen[60..].fill(noisy[59]);
        let quality = assess_channel(&channel("pitch", 25.0, frozen));
        assert_eq!(
            quality.stuck,
            Some(Stuck::Frozen {
                value: noisy[59],
                from: 59.0 / 25.0,
                to: 99.0 / 25.0
            })
        );
        assert_eq!(assess_channel(&channel("pitch", 25.0, noisy)).stuck, None);
        let constant = assess_channel(&channel("rudder", 1.0, vec![0.0; 50]));
        assert!(!constant.is_flagged(), "{}", constant.flags());
    }

    /// Values on multiples of 0.1° (with gaps of several steps) give 0.1°.
    #[test]
    fn resolution_is_inferred_from_the_spacing() {
        let lsb = 0.1 * DEG;
        let values: Vec<f64> = [3.0, 4.0, 4.0, 7.0, 5.0, 12.0]
            .iter()
            .map(|k| k * lsb)
            .collect();
        let inferred = assess_channel(&channel("pitch", 1.0, values))
            .inferred_resolution
            .unwrap();
        assert!((inferred - lsb).abs() < 1e-12 * lsb, "{inferred}");
        let quality = assess_channel(&channel("pitch", 1.0, smooth(50)));
        assert_eq!(quality.inferred_resolution, None);
        assert!(!quality.is_flagged(), "{}", quality.flags());
    }

    /// Dropouts are counted with their longest run and first instant.
    #[test]
    fn dropouts_are_counted() {
        let mut values = smooth(30);
        for k in [4, 10, 11, 12] {
            values[k] = f64::NAN;
        }
        let quality = assess_channel(&channel("roll", 1.0, values));
        assert_eq!(
            quality.dropouts,
            Some(Dropouts {
                count: 4,
                longest: 3,
                first: 4.0
            })
        );
        assert!(quality.is_flagged() && !quality.is_unusable());
    }

    /// A 10° spike in a smooth 25 Hz pitch channel is two implausible steps
    /// (up and down: each beyond 60°/s × 0.04 s = 2.4° plus ten times the
    /// smooth neighbourhood's jumps); at 1 Hz the same spike is within what
    /// an attitude may do in a second (60°), and a heading crossing north
    /// is no step.
    #[test]
    fn a_spike_is_two_implausible_steps() {
        let mut values = smooth(100);
        values[50] += 10.0 * DEG;
        let quality = assess_channel(&channel("pitch", 25.0, values.clone()));
        assert_eq!(quality.steps.len(), 2, "{:?}", quality.steps);
        assert_eq!(quality.steps[0].time, 2.0);
        assert!((quality.steps[1].jump + 10.0 * DEG).abs() < 0.01);
        assert!(
            assess_channel(&channel("pitch", 1.0, values))
                .steps
                .is_empty()
        );
        let heading: Vec<f64> = (0..60)
            .map(|k| (350.0 + 0.4 * k as f64) * DEG % std::f64::consts::TAU)
            .collect();
        let quality = assess_channel(&channel("yaw", 25.0, heading));
        assert!(!quality.is_flagged(), "{}", quality.flags());
    }
}
