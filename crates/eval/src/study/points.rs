//! The sweep grid: every axis' checked values, and the points as their
//! cartesian product in [`Axis::PRODUCT`] order (the last axis varying
//! fastest), each with its recorder profile modified for it (channels left
//! out, then rates, noise, resolution) and its recording (the point
//! without its settings variant).

use super::SweepPoint;
use crate::axis::Axis;
use crate::error::Result;
use aeroid_estimation::estimator::MethodTables;
use aeroid_record::recorder::Profile;

/// Every sweep axis' values, checked (an axis the study leaves out holds
/// its one default).
#[derive(Debug, Clone)]
pub(super) struct Grid<'a> {
    pub scenarios: usize,
    pub profiles: &'a [Profile],
    pub missing: Vec<Vec<String>>,
    pub channel_rates: Vec<Vec<(String, f64)>>,
    pub turbulence: Vec<Option<String>>,
    pub input_scales: Vec<f64>,
    pub sample_rates: Vec<Option<f64>>,
    pub noise_scales: Vec<f64>,
    pub resolution_scales: Vec<f64>,
    pub settings: &'a [MethodTables],
}

/// A point's index on every axis, in [`Axis::PRODUCT`] order.
type Index = [usize; Axis::PRODUCT.len()];

impl Grid<'_> {
    /// The number of values on `axis`.
    pub fn len(&self, axis: Axis) -> usize {
        match axis {
            Axis::Scenario => self.scenarios,
            Axis::Profile => self.profiles.len(),
            Axis::Missing => self.missing.len(),
            Axis::ChannelRate => self.channel_rates.len(),
            Axis::Turbulence => self.turbulence.len(),
            Axis::InputScale => self.input_scales.len(),
            Axis::SampleRate => self.sample_rates.len(),
            Axis::NoiseScale => self.noise_scales.len(),
            Axis::ResolutionScale => self.resolution_scales.len(),
            Axis::Settings => self.settings.len(),
        }
    }

    /// Every point's index, the last axis varying fastest.
    fn indices(&self) -> Vec<Index> {
        let mut indices = vec![[0; Axis::PRODUCT.len()]];
        for axis in Axis::PRODUCT {
            indices = indices
                .into_iter()
                .flat_map(|index| {
                    (0..self.len(axis)).map(move |i| {
                        let mut next = index;
                        next[axis.index()] = i;
                        next
                    })
                })
                .collect();
        }
        indices
    }

    /// The points of the grid. Points that differ only in their settings
    /// variant share a recording and its profile.
    pub fn points(&self) -> Result<Vec<SweepPoint>> {
        let variants = self.len(Axis::Settings);
        let mut points: Vec<SweepPoint> = Vec::new();
        for (n, index) in self.indices().into_iter().enumerate() {
            let mut point = self.point(&index);
            point.recording = n / variants;
            point.profile = match points.last() {
                Some(last) if index[Axis::Settings.index()] != 0 => last.profile.clone(),
                _ => self.profile(&index, &point.channel_rates)?,
            };
            points.push(point);
        }
        Ok(points)
    }

    /// The point at `index`, with the study's profile unmodified and
    /// recording 0.
    fn point(&self, index: &Index) -> SweepPoint {
        let at = |axis: Axis| index[axis.index()];
        let profile = &self.profiles[at(Axis::Profile)];
        let missing = &self.missing[at(Axis::Missing)];
        // A rate for a channel this point leaves out is moot.
        let channel_rates = self.channel_rates[at(Axis::ChannelRate)]
            .iter()
            .filter(|(name, _)| !missing.contains(name))
            .cloned()
            .collect();
        SweepPoint {
            scenario: at(Axis::Scenario),
            recorder: profile.name.clone(),
            turbulence: self.turbulence[at(Axis::Turbulence)].clone(),
            input_scale: self.input_scales[at(Axis::InputScale)],
            sample_rate: self.sample_rates[at(Axis::SampleRate)],
            noise_scale: self.noise_scales[at(Axis::NoiseScale)],
            resolution_scale: self.resolution_scales[at(Axis::ResolutionScale)],
            missing: missing.clone(),
            channel_rates,
            settings: at(Axis::Settings),
            recording: 0,
            profile: profile.clone(),
        }
    }

    /// The recorder profile of the point at `index`: channels left out,
    /// then every channel's rate, the channels' own rates, the noise and
    /// the resolution scaled.
    fn profile(&self, index: &Index, channel_rates: &[(String, f64)]) -> Result<Profile> {
        let at = |axis: Axis| index[axis.index()];
        let kept = self.profiles[at(Axis::Profile)].without(&self.missing[at(Axis::Missing)])?;
        let rated = self.sample_rates[at(Axis::SampleRate)]
            .map_or_else(|| kept.clone(), |r| kept.with_rate(r))
            .with_channel_rates(channel_rates)?;
        let noise_scale = self.noise_scales[at(Axis::NoiseScale)];
        let noisy = if noise_scale == 1.0 {
            rated
        } else {
            rated.with_noise_scaled(noise_scale)
        };
        let resolution_scale = self.resolution_scales[at(Axis::ResolutionScale)];
        Ok(if resolution_scale == 1.0 {
            noisy
        } else {
            noisy.with_resolution_scaled(resolution_scale)
        })
    }
}
