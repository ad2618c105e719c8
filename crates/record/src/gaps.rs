//! Gaps in a record: a stretch of time in which no channel has a sample,
//! longer than `GAP_FACTOR` sample periods of the fastest channel (two
//! manoeuvres joined in one file, a recorder switched off). An estimator
//! that interpolated across one would integrate or differentiate through
//! time nobody recorded; the estimation problem therefore splits a record
//! at its gaps into pieces that every estimator fits as separate
//! manoeuvres, each with its own initial state, unless the record says
//! to bridge them (`bridge_gaps`, `aeroid import --bridge-gaps`).
//! Shorter holes (a few lost frames) stay inside a piece and are
//! interpolated, as dropouts are.

use crate::FlightRecord;

/// How many sample periods of the record's fastest channel a stretch
/// without any sample must exceed to be a gap: up to nine lost frames in a
/// row are interpolated; a tenth is a recorder that stopped.
pub(crate) const GAP_FACTOR: f64 = 10.0;

impl FlightRecord {
    /// The gaps of the record, each from the last sample before it to the
    /// first after it (s), in time order: a stretch with no sample of any
    /// channel, longer than `GAP_FACTOR` sample periods of every channel
    /// whose samples lie on both sides of it (a channel that starts later
    /// or ends earlier says nothing of it).
    pub fn time_gaps(&self) -> Vec<(f64, f64)> {
        let spans: Vec<(f64, f64, f64)> = self
            .channels
            .iter()
            .filter(|c| c.rate > 0.0)
            .filter_map(|c| Some((*c.times.first()?, *c.times.last()?, GAP_FACTOR / c.rate)))
            .collect();
        let mut instants: Vec<f64> = self
            .channels
            .iter()
            .flat_map(|c| c.times.iter().copied())
            .filter(|t| t.is_finite())
            .collect();
        instants.sort_by(f64::total_cmp);
        instants.dedup();
        instants
            .windows(2)
            .map(|w| (w[0], w[1]))
            .filter(|&(before, after)| {
                let mut covering = spans
                    .iter()
                    .filter(|&&(first, last, _)| first <= before && last >= after)
                    .peekable();
                covering.peek().is_some() && covering.all(|&(_, _, limit)| after - before > limit)
            })
            .collect()
    }

    /// The samples of every channel from `start` to `end` (inclusive), as
    /// a record named `NAME [start–end s]`.
    pub fn between(&self, start: f64, end: f64) -> FlightRecord {
        let mut piece = self.clone();
        piece.scenario = format!("{} [{start:.2}–{end:.2} s]", self.name());
        for channel in &mut piece.channels {
            let first = channel.times.partition_point(|&t| t < start);
            let last = channel.times.partition_point(|&t| t <= end);
            channel.times = channel.times[first..last].to_vec();
            channel.values = channel.values[first..last].to_vec();
        }
        piece.channels.retain(|c| !c.times.is_empty());
        piece
    }

    /// The record split at its [`FlightRecord::time_gaps`] (itself when it
    /// has none or bridges them), and a note that says where, if it was.
    pub fn split_at_gaps(&self) -> (Vec<FlightRecord>, Option<String>) {
        let gaps = self.time_gaps();
        if gaps.is_empty() || self.bridge_gaps {
            return (vec![self.clone()], None);
        }
        let span = self
            .channels
            .iter()
            .filter_map(|c| Some((*c.times.first()?, *c.times.last()?)))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (s, e)| {
                (a.min(s), b.max(e))
            });
        let mut starts = vec![span.0];
        let mut ends = Vec::new();
        for &(before, after) in &gaps {
            ends.push(before);
            starts.push(after);
        }
        ends.push(span.1);
        let pieces: Vec<FlightRecord> = starts
            .iter()
            .zip(&ends)
            .map(|(&start, &end)| self.between(start, end))
            .collect();
        let said: Vec<String> = gaps
            .iter()
            .map(|(before, after)| format!("{before:.2} s to {after:.2} s"))
            .collect();
        let note = format!(
            "'{}' has {} gap(s) without any sample ({}): fitted as {} separate manoeuvres, each from its own initial state (import with --bridge-gaps to interpolate across)",
            self.name(),
            gaps.len(),
            said.join(", "),
            pieces.len()
        );
        (pieces, Some(note))
    }
}

#[cfg(test)]
mod tests {
    use crate::{Channel, FlightRecord};

    fn channel(name: &str, rate: f64, times: Vec<f64>) -> Channel {
        Channel {
            name: name.into(),
            unit: "rad".into(),
            rate,
            resolution: None,
            source: "test".into(),
            values: times.iter().map(|t| t.sin()).collect(),
            times,
        }
    }

    /// Two manoeuvres in one file (25 Hz, to 80.08 s, then from 110.16 s,
    /// as the book's joined flight; a 1 Hz channel stops and starts with
    /// it): one gap, two pieces holding every sample; a hole of five lost
    /// frames is no gap; the slow channel's normal spacing is none either.
    #[test]
    fn a_record_splits_at_its_gaps_only() {
        let step = 0.04;
        let first: Vec<f64> = (0..=2002).map(|k| k as f64 * step).collect();
        let second: Vec<f64> = (0..=500).map(|k| 110.16 + k as f64 * step).collect();
        let mut times = first.clone();
        times.extend(&second);
        times.retain(|t| !(40.0..40.2).contains(t));
        let slow: Vec<f64> = (0..130)
            .map(|k| k as f64)
            .filter(|t| !(80.5..110.0).contains(t))
            .collect();
        let record = FlightRecord {
            scenario: "joined".into(),
            channels: vec![
                channel("q", 25.0, times.clone()),
                channel("pitch", 1.0, slow),
            ],
            ..Default::default()
        };
        let gaps = record.time_gaps();
        assert_eq!(gaps.len(), 1, "{gaps:?}");
        assert!(
            (gaps[0].0 - 80.08).abs() < 1e-9 && (gaps[0].1 - 110.0).abs() < 1e-9,
            "{gaps:?}"
        );
        let (pieces, note) = record.split_at_gaps();
        assert_eq!(pieces.len(), 2);
        let count = |r: &FlightRecord| r.channel("q").unwrap().times.len();
        assert_eq!(count(&pieces[0]) + count(&pieces[1]), times.len());
        assert!(note.unwrap().contains("2 separate manoeuvres"));
        let bridged = FlightRecord {
            bridge_gaps: true,
            ..record
        };
        assert_eq!(bridged.split_at_gaps().0, vec![bridged.clone()]);
    }
}
