//! The frequency band both frequency-domain methods (Fourier-transform
//! regression and frequency-domain output error) fit over: given, or where
//! the controls' amplitude spectra stay above a fraction of their peak,
//! on a grid of the record's Fourier resolution 1/T or a given spacing
//! (Klein & Morelli, "Aircraft System Identification", AIAA 2006, §7.2;
//! the transform is [`aeroid_numerics::fourier`]).

use crate::error::{Error, Result};
use crate::structure::ModelStructure;
use aeroid_core::units::{Dimension, Quantity};
use aeroid_numerics::fourier::FourierTransform;
use aeroid_sim::aero::{Coefficient, Regressor};
use nalgebra::DMatrix;
use std::f64::consts::PI;

/// The meanings of the band settings both frequency-domain methods take.
pub(crate) const BAND_SETTINGS: [(&str, &str); 3] = [
    (
        "band",
        "[low, high], e.g. [\"0.1 Hz\", \"1.5 Hz\"]; none: from the inputs' spectra",
    ),
    (
        "resolution",
        "frequency spacing, e.g. \"0.04 Hz\"; none: 1/T, the record's Fourier resolution (then trim values and constant biases have no transform)",
    ),
    (
        "input_threshold",
        "the automatic band ends where every control's amplitude spectrum is below this fraction of its peak",
    ),
];

/// Where the frequency-domain methods look: the band and the spacing.
#[derive(Debug, Clone, PartialEq)]
pub struct BandOptions {
    /// (low, high) in Hz; None: from the inputs' spectra.
    pub band: Option<(f64, f64)>,
    /// Spacing (Hz); None: 1/T.
    pub resolution: Option<f64>,
    /// The automatic band ends where every control's amplitude spectrum is
    /// below this fraction of its peak.
    pub input_threshold: f64,
}

impl Default for BandOptions {
    fn default() -> Self {
        BandOptions {
            band: None,
            resolution: None,
            input_threshold: 0.1,
        }
    }
}

impl BandOptions {
    /// The band settings of `[methods.METHOD]` in SI, checked.
    pub(crate) fn read(
        method: &str,
        band: Option<&[Quantity; 2]>,
        resolution: Option<&Quantity>,
        input_threshold: f64,
    ) -> Result<BandOptions> {
        let bad = |message: String| Error::Settings {
            method: method.to_string(),
            reason: message.to_string(),
        };
        let hertz = |q: &Quantity, what: &str| {
            q.si(Dimension::Frequency)
                .map_err(|e| bad(format!("{what}: {e}")))
        };
        let band = match band {
            Some([low, high]) => {
                let (low, high) = (hertz(low, "band")?, hertz(high, "band")?);
                if !(low >= 0.0 && high > low && high.is_finite()) {
                    return Err(bad(format!(
                        "band must be [low, high] with 0 ≤ low < high, is [{low} Hz, {high} Hz]"
                    )));
                }
                Some((low, high))
            }
            None => None,
        };
        let resolution = match resolution {
            Some(q) => {
                let value = hertz(q, "resolution")?;
                if !(value > 0.0 && value.is_finite()) {
                    return Err(bad(format!("resolution must be positive, is {value} Hz")));
                }
                Some(value)
            }
            None => None,
        };
        if !(input_threshold > 0.0 && input_threshold < 1.0) {
            return Err(bad(format!(
                "input_threshold must lie in (0, 1), is {input_threshold}"
            )));
        }
        Ok(BandOptions {
            band,
            resolution,
            input_threshold,
        })
    }

    /// The band's angular frequencies (ω = 0 first when `zero`) on a grid
    /// from `start` with `samples` at `step`, with a description for the
    /// notes. The automatic band reads the `controls` series (name, values).
    pub(crate) fn frequencies(
        &self,
        method: &str,
        controls: &[(&str, Vec<f64>)],
        (start, step, samples): (f64, f64, usize),
        zero: bool,
    ) -> Result<(Vec<f64>, String)> {
        let duration = (samples - 1) as f64 * step;
        let spacing = self.resolution.unwrap_or(1.0 / duration);
        let highest_allowed = 0.25 / step;
        let (low, high, how) = match self.band {
            Some((low, high)) => (low, high.min(highest_allowed), "given".to_string()),
            None => (
                spacing,
                self.automatic_top(method, controls, (start, step, samples), spacing)?,
                format!(
                    "from the inputs' spectra (controls above {} of their peak amplitude)",
                    self.input_threshold
                ),
            ),
        };
        let mut list: Vec<f64> = Vec::new();
        if zero {
            list.push(0.0);
        }
        let first = (low / spacing - 1e-9).ceil().max(1.0) as usize;
        let mut m = first;
        while (m as f64) * spacing <= high * (1.0 + 1e-12) {
            list.push(2.0 * PI * m as f64 * spacing);
            m += 1;
        }
        let count = list.len() - usize::from(zero);
        if count == 0 {
            return Err(Error::Grid {
                reason: format!(
                    "{method}: no frequency of the {spacing:.4} Hz grid lies in the band {low:.4}–{high:.4} Hz"
                ),
            });
        }
        let description = format!(
            "{count} frequencies from {:.4} Hz to {:.4} Hz every {:.4} Hz (band {how}){}",
            first as f64 * spacing,
            (first + count - 1) as f64 * spacing,
            spacing,
            if zero {
                ", and ω = 0 for the bias terms"
            } else {
                ""
            }
        );
        Ok((list, description))
    }

    /// The automatic band's top: the highest frequency at which some
    /// control's amplitude spectrum reaches `input_threshold` of its peak,
    /// on a grid of at most 100 candidates up to a quarter of the sample
    /// rate; an error when the model has no control or none moves.
    fn automatic_top(
        &self,
        method: &str,
        controls: &[(&str, Vec<f64>)],
        (start, step, samples): (f64, f64, usize),
        spacing: f64,
    ) -> Result<f64> {
        let highest_allowed = 0.25 / step;
        if controls.is_empty() {
            return Err(Error::Settings {
                method: method.to_string(),
                reason:
                    "the model has no control term to choose the band from; give band = [low, high]"
                        .to_string(),
            });
        }
        // At most 100 candidates: the band's top to 1 % of the
        // highest allowed frequency is enough.
        let coarse = spacing.max(highest_allowed / 100.0);
        let candidates: Vec<f64> = (1..)
            .map(|m| m as f64 * coarse)
            .take_while(|f| *f <= highest_allowed)
            .collect();
        let omegas: Vec<f64> = candidates.iter().map(|f| 2.0 * PI * f).collect();
        let transform = FourierTransform::new(&omegas, start, step, samples)?;
        let means: Vec<f64> = controls
            .iter()
            .map(|(_, v)| v.iter().sum::<f64>() / v.len() as f64)
            .collect();
        let centred = DMatrix::from_fn(samples, controls.len(), |k, i| controls[i].1[k] - means[i]);
        let mut high: f64 = 0.0;
        for spectrum in transform.transform_columns(&centred)? {
            let amplitude: Vec<f64> = spectrum.iter().map(|c| c.norm()).collect();
            let peak = amplitude.iter().copied().fold(0.0, f64::max);
            if let Some(last) = amplitude
                .iter()
                .rposition(|&a| peak > 0.0 && a >= self.input_threshold * peak)
            {
                high = high.max(candidates[last]);
            }
        }
        if high == 0.0 {
            let names: Vec<&str> = controls.iter().map(|(n, _)| *n).collect();
            return Err(Error::Data {
                reason: format!(
                    "{method}: no control of the model ({}) moves in this record; give band = [low, high]",
                    names.join(", ")
                ),
            });
        }
        Ok(high)
    }
}

/// The control regressors among the model's terms, for the automatic band.
pub(crate) fn model_controls(structure: &ModelStructure) -> Vec<Regressor> {
    let aero = &structure.aircraft.aero;
    [
        Regressor::Elevator,
        Regressor::Aileron,
        Regressor::Rudder,
        Regressor::Flap,
    ]
    .into_iter()
    .filter(|r| {
        Coefficient::ALL
            .into_iter()
            .any(|c| aero.terms(c).any(|(t, _)| t.contains(*r)))
    })
    .collect()
}
