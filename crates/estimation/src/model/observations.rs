//! A record's measurements of a model's outputs on the model's grid: what
//! a filter's measurement updates read. Each channel's samples inside the
//! grid are taken at the grid point nearest their instant; a sample more
//! than 10⁻⁶ of a step off its grid point is counted as moved (the filter
//! then compares it with the model's output up to half a step away: choose
//! a step that divides every output's sample period to avoid it). NaN
//! samples (dropouts) are left out; two samples of one channel at one
//! grid point keep the later.

use crate::error::{Error, Result};
use aeroid_record::FlightRecord;

/// Measurements per grid point: (output index, value), outputs in the
/// model's order.
#[derive(Debug, Clone, PartialEq)]
pub struct Observations {
    /// The outputs' channel names.
    pub names: Vec<String>,
    /// At each grid point, the outputs measured there and their values.
    pub at: Vec<Vec<(usize, f64)>>,
    /// Samples taken at a grid point more than 10⁻⁶ of a step away.
    pub moved: usize,
}

impl Observations {
    /// The fewest grid steps between two successive samples of one output
    /// (the fastest output's sample period in steps: 1 where every output
    /// is sampled at every grid point, more on a grid divided into
    /// sub-steps); 1 when no output has two samples.
    pub fn stride(&self) -> usize {
        let mut last: Vec<Option<usize>> = vec![None; self.names.len()];
        let mut stride = usize::MAX;
        for (k, present) in self.at.iter().enumerate() {
            for &(o, _) in present {
                if let Some(previous) = last[o] {
                    stride = stride.min(k - previous);
                }
                last[o] = Some(k);
            }
        }
        if stride == usize::MAX {
            1
        } else {
            stride.max(1)
        }
    }

    /// The samples of the channels `outputs` of `record` on the grid
    /// start + k·step, k < len. An error for a channel the record lacks.
    pub fn from_record(
        record: &FlightRecord,
        outputs: &[String],
        start: f64,
        step: f64,
        len: usize,
    ) -> Result<Observations> {
        if len == 0 || !(step > 0.0 && step.is_finite()) {
            return Err(Error::Grid {
                reason: "observations need a grid with points and a positive step".into(),
            });
        }
        let mut at: Vec<Vec<(usize, f64)>> = vec![Vec::new(); len];
        let mut moved = 0;
        for (output, name) in outputs.iter().enumerate() {
            let channel = record.channel(name)?;
            for (&t, &value) in channel.times.iter().zip(&channel.values) {
                let position = (t - start) / step;
                let k = position.round();
                if !value.is_finite() || k < 0.0 || k >= len as f64 {
                    continue;
                }
                if (position - k).abs() > 1e-6 {
                    moved += 1;
                }
                let here = &mut at[k as usize];
                match here.iter_mut().find(|(o, _)| *o == output) {
                    Some(slot) => slot.1 = value,
                    None => here.push((output, value)),
                }
            }
        }
        Ok(Observations {
            names: outputs.to_vec(),
            at,
            moved,
        })
    }

    /// The number of measurements of each output.
    pub fn counts(&self) -> Vec<usize> {
        let mut counts = vec![0; self.names.len()];
        for point in &self.at {
            for &(output, _) in point {
                counts[output] += 1;
            }
        }
        counts
    }

    /// A note for the estimate when samples were moved to the grid.
    pub fn note(&self, step: f64) -> Option<String> {
        (self.moved > 0).then(|| {
            format!(
                "{} samples lie off the {} s grid and were compared with the model at the nearest grid point",
                self.moved,
                aeroid_record::rounded(step)
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_record::{Channel, FlightRecord};

    fn record() -> FlightRecord {
        let channel = |name: &str, times: Vec<f64>, values: Vec<f64>| Channel {
            name: name.into(),
            unit: "rad".into(),
            rate: 1.0 / (times[1] - times[0]),
            resolution: None,
            source: "test".into(),
            times,
            values,
        };
        FlightRecord {
            scenario: "test".into(),
            channels: vec![
                channel(
                    "alpha",
                    vec![0.0, 0.1, 0.2, 0.3],
                    vec![1.0, 2.0, f64::NAN, 4.0],
                ),
                channel("q", vec![0.0, 0.2], vec![5.0, 6.0]),
                channel("pitch", vec![0.04, 0.16], vec![7.0, 8.0]),
            ],
            ..FlightRecord::default()
        }
    }

    #[test]
    fn samples_land_on_their_grid_points_and_dropouts_are_left_out() {
        let names = ["alpha", "q", "pitch"].map(String::from).to_vec();
        let o = Observations::from_record(&record(), &names, 0.0, 0.1, 4).unwrap();
        assert_eq!(o.at[0], vec![(0, 1.0), (1, 5.0), (2, 7.0)]);
        assert_eq!(o.at[2], vec![(1, 6.0), (2, 8.0)]);
        assert_eq!(o.counts(), vec![3, 2, 2]);
        // 0.04 and 0.16 lie 0.4 of a step off the grid.
        assert_eq!(o.moved, 2);
        assert!(o.note(0.1).is_some());
    }

    #[test]
    fn a_missing_channel_is_named() {
        let names = vec!["beta".to_string()];
        let error = Observations::from_record(&record(), &names, 0.0, 0.1, 4).unwrap_err();
        assert!(error.to_string().contains("beta"), "{error}");
    }
}
