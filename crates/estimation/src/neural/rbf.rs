//! The radial-basis-function network of Wang et al., "Aerodynamic modeling
//! and parameter estimation from QAR data of an airplane approaching a
//! high-altitude airport", Chinese J. Aeronautics 25 (2012), §3.3:
//!
//! - output `ŷ(x) = Σⱼ wⱼ·Rⱼ(x)` (Eq. 25), one output per network;
//! - Gaussian basis `Rⱼ(x) = exp(−‖x − cⱼ‖²/σⱼ²)` (Eq. 26; the transcript
//!   of Eq. 26 is damaged, this is its standard textbook form);
//! - centres and their number by clustering the training inputs, scaled
//!   to a range ([`Scaling`], Verma & Peyada 2020 Eq. 16), with radius d
//!   (Steps 1–4, Eqs. 28–29). Step 2's "select arbitrarily a sample" is
//!   the first unmarked sample in record order, so the clustering is
//!   deterministic; Step 3 passes over the unmarked samples again while a
//!   pass incorporates one (each incorporation moves the centre, Eq. 29:
//!   `cⱼ(k) = ((k − 1)·cⱼ(k−1) + xᵢ)/k`);
//! - widths `σⱼ = λ·d` with λ from a golden-section search (Eq. 30's cost,
//!   Σ (y − ŷ)²) — on the training samples, or on held-out samples (see
//!   [`WidthSearch`]);
//! - output weights by least squares `W = (RᵀR)⁻¹RᵀY` (Eqs. 31–32),
//!   computed by the shared SVD solver ([`LeastSquares::fit`]); inside the
//!   width search, where only the held-out cost is needed, by the same
//!   truncated solution reduced by QR first ([`LeastSquares::solve`]).
//!
//! The gradient of the output with respect to the scaled inputs is
//! analytic for Gaussians: `∂ŷ/∂xᵢ = −Σⱼ wⱼ·Rⱼ(x)·2(xᵢ − cⱼᵢ)/σ²`
//! ([`RbfNetwork::scaled_gradient`]); the Delta method's central
//! differences (Eq. 33) are [`RbfNetwork::central_difference`].
//! No evaluation allocates: callers pass the sample's buffers.

use crate::error::{Error, Result};
use crate::neural::Scaling;
use aeroid_numerics::regression::LeastSquares;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Which samples the width search (Eq. 30) scores λ on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WidthSearch {
    /// Eq. 30 as printed: the cost on the training samples themselves.
    Training,
    /// The cost on held-out samples (segments 2, 5 and 8 of ten
    /// consecutive segments of the record), the network's weights fitted
    /// to the others; the final weights are fitted to every sample.
    HeldOut,
}

/// How a network is built.
#[derive(Debug, Clone, PartialEq)]
pub struct RbfOptions {
    /// Cluster radius d in scaled units (Eq. 28).
    pub radius: f64,
    /// The range of λ searched (σ = λ·d).
    pub width_factors: (f64, f64),
    pub search: WidthSearch,
    /// The range inputs and output are scaled to (Eq. 16 of Verma & Peyada).
    pub scaling: (f64, f64),
}

impl Default for RbfOptions {
    fn default() -> Self {
        RbfOptions {
            radius: 0.5,
            width_factors: (0.5, 8.0),
            search: WidthSearch::HeldOut,
            scaling: (-1.0, 1.0),
        }
    }
}

/// A trained network: scaled inputs in, scaled output out.
#[derive(Debug, Clone, PartialEq)]
pub struct RbfNetwork {
    pub input_scaling: Scaling,
    pub output_scaling: Scaling,
    /// Centres, one row of `inputs` values each (scaled units).
    pub centres: Vec<f64>,
    pub inputs: usize,
    pub radius: f64,
    /// λ of σ = λ·d.
    pub width_factor: f64,
    /// Output weights wⱼ (Eq. 32).
    pub weights: Vec<f64>,
    /// The Eq. 30 cost at each λ the search evaluated, in order.
    pub search_history: Vec<(f64, f64)>,
}

/// Clusters samples (rows of `dimension` values, flat) with radius
/// `radius` (Steps 1–4, Eqs. 28–29): the centres, flat, row by row.
pub fn cluster(samples: &[f64], dimension: usize, radius: f64) -> Vec<f64> {
    let count = samples.len().checked_div(dimension).unwrap_or(0);
    let mut marked = vec![false; count];
    let mut centres: Vec<f64> = Vec::new();
    let mut centre = vec![0.0; dimension];
    let mut next = 0;
    while let Some(first) = (next..count).find(|&i| !marked[i]) {
        next = first + 1;
        marked[first] = true;
        centre.copy_from_slice(&samples[first * dimension..(first + 1) * dimension]);
        let mut members = 1usize;
        loop {
            let mut incorporated = false;
            for i in next..count {
                if marked[i] {
                    continue;
                }
                let x = &samples[i * dimension..(i + 1) * dimension];
                if squared_distance(x, &centre) < radius * radius {
                    marked[i] = true;
                    members += 1;
                    let k = members as f64;
                    for (c, &xi) in centre.iter_mut().zip(x) {
                        *c = ((k - 1.0) * *c + xi) / k;
                    }
                    incorporated = true;
                }
            }
            if !incorporated {
                break;
            }
        }
        centres.extend_from_slice(&centre);
    }
    centres
}

#[inline]
fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Whether sample k of n is held out of the width search's fit.
fn held_out(k: usize, n: usize) -> bool {
    (k * 10 / n.max(1)) % 3 == 1
}

/// Fills `design` (samples × centres) with Rⱼ(xₖ) for width σ (Eq. 26).
fn fill_design(
    design: &mut DMatrix<f64>,
    samples: &[f64],
    centres: &[f64],
    dimension: usize,
    sigma: f64,
) {
    let scale = 1.0 / (sigma * sigma);
    for (k, x) in samples.chunks_exact(dimension).enumerate() {
        for (j, c) in centres.chunks_exact(dimension).enumerate() {
            design[(k, j)] = (-squared_distance(x, c) * scale).exp();
        }
    }
}

impl RbfNetwork {
    /// Trains one network on `rows` (one sample each, `names` its input
    /// columns) and `targets`; an error when the data are empty, not
    /// finite, or fewer than the centres.
    pub fn train(
        rows: &[Vec<f64>],
        names: &[String],
        targets: &[f64],
        options: &RbfOptions,
    ) -> Result<RbfNetwork> {
        let (low, high) = options.scaling;
        let input_scaling = Scaling::fit(rows, names, low, high)?;
        let target_rows: Vec<Vec<f64>> = targets.iter().map(|&y| vec![y]).collect();
        let output_scaling = Scaling::fit(&target_rows, &["output".to_string()], low, high)?;
        let dimension = names.len();
        let mut samples = Vec::with_capacity(rows.len() * dimension);
        for row in rows {
            let start = samples.len();
            samples.extend_from_slice(&row[..dimension]);
            input_scaling.apply(&mut samples[start..]);
        }
        let scaled_targets: Vec<f64> = targets
            .iter()
            .map(|&y| {
                let mut v = [y];
                output_scaling.apply(&mut v);
                v[0]
            })
            .collect();
        let centres = cluster(&samples, dimension, options.radius);
        let count = centres.len() / dimension.max(1);
        if count == 0 || count >= rows.len() {
            return Err(Error::Network {
                reason: format!(
                    "the RBF network has {count} centres for {} samples: choose another cluster radius",
                    rows.len()
                ),
            });
        }
        let mut network = RbfNetwork {
            input_scaling,
            output_scaling,
            centres,
            inputs: dimension,
            radius: options.radius,
            width_factor: f64::NAN,
            weights: Vec::new(),
            search_history: Vec::new(),
        };
        network.search_width(&samples, &scaled_targets, options)?;
        let mut design = DMatrix::zeros(rows.len(), count);
        let sigma = network.width_factor * network.radius;
        fill_design(&mut design, &samples, &network.centres, dimension, sigma);
        let fit = LeastSquares::fit(&design, &DVector::from_column_slice(&scaled_targets));
        network.weights = fit.theta.iter().copied().collect();
        Ok(network)
    }

    /// The golden-section search for λ on Eq. 30's cost (module header).
    fn search_width(
        &mut self,
        samples: &[f64],
        targets: &[f64],
        options: &RbfOptions,
    ) -> Result<()> {
        let dimension = self.inputs;
        let n = targets.len();
        let (fit_rows, score_rows): (Vec<usize>, Vec<usize>) = match options.search {
            WidthSearch::Training => ((0..n).collect(), (0..n).collect()),
            WidthSearch::HeldOut => (0..n).partition(|&k| !held_out(k, n)),
        };
        let count = self.centres.len() / dimension;
        if fit_rows.len() <= count || score_rows.is_empty() {
            return Err(Error::Network {
                reason: format!(
                    "the RBF width search has {} samples to fit {count} centres",
                    fit_rows.len()
                ),
            });
        }
        // ‖xₖ − cⱼ‖² of the picked samples, in the design's column-major
        // order: computed once, reused at every λ.
        let pick = |rows: &[usize]| -> (DMatrix<f64>, DVector<f64>) {
            let distances = DMatrix::from_fn(rows.len(), count, |r, j| {
                let k = rows[r];
                squared_distance(
                    &samples[k * dimension..(k + 1) * dimension],
                    &self.centres[j * dimension..(j + 1) * dimension],
                )
            });
            (
                distances,
                DVector::from_iterator(rows.len(), rows.iter().map(|&k| targets[k])),
            )
        };
        let (fit_distances, fit_y) = pick(&fit_rows);
        let (score_distances, score_y) = pick(&score_rows);
        let mut fit_design = DMatrix::zeros(fit_rows.len(), count);
        let mut score_design = DMatrix::zeros(score_rows.len(), count);
        let radius = self.radius;
        let mut history = Vec::new();
        let mut cost = |lambda: f64| -> f64 {
            let sigma = lambda * radius;
            let scale = 1.0 / (sigma * sigma);
            // Rⱼ(xₖ) as `fill_design` computes it (Eq. 26).
            let basis = |design: &mut DMatrix<f64>, distances: &DMatrix<f64>| {
                for (r, d) in design.iter_mut().zip(distances.iter()) {
                    *r = (-d * scale).exp();
                }
            };
            basis(&mut fit_design, &fit_distances);
            // Only θ is needed here: the QR-reduced solve, equal to the
            // final fit's SVD solution to rounding.
            let theta = LeastSquares::solve(&fit_design, &fit_y);
            basis(&mut score_design, &score_distances);
            let residual = &score_y - &score_design * &theta;
            let value = residual.norm_squared();
            history.push((lambda, value));
            if value.is_finite() {
                value
            } else {
                f64::INFINITY
            }
        };
        let (lower, upper) = options.width_factors;
        // The search runs on ln λ: the cost varies over decades of width.
        let (best, least) = golden_section((lower.ln(), upper.ln()), |x| cost(x.exp()));
        self.width_factor = best.exp();
        self.search_history = history;
        if !self.width_factor.is_finite() || !least.is_finite() {
            return Err(Error::Network {
                reason: "the RBF width search found no finite cost".into(),
            });
        }
        Ok(())
    }

    /// The number of centres (hidden neurons).
    pub fn centre_count(&self) -> usize {
        self.weights.len()
    }

    /// σ = λ·d.
    pub fn width(&self) -> f64 {
        self.width_factor * self.radius
    }

    /// The scaled output at scaled inputs `x` (Eqs. 25–26).
    pub fn scaled_output(&self, x: &[f64]) -> f64 {
        let scale = 1.0 / (self.width() * self.width());
        self.centres
            .chunks_exact(self.inputs)
            .zip(&self.weights)
            .map(|(c, w)| w * (-squared_distance(x, c) * scale).exp())
            .sum()
    }

    /// The output for unscaled inputs `x`; `buffer` (length `inputs`) is
    /// overwritten with the scaled inputs.
    pub fn predict(&self, x: &[f64], buffer: &mut [f64]) -> f64 {
        buffer.copy_from_slice(&x[..self.inputs]);
        self.input_scaling.apply(buffer);
        let mut y = [self.scaled_output(buffer)];
        self.output_scaling.invert(&mut y);
        y[0]
    }

    /// The analytic gradient of the scaled output with respect to the
    /// scaled inputs at `x`, written to `gradient`.
    pub fn scaled_gradient(&self, x: &[f64], gradient: &mut [f64]) {
        let sigma2 = self.width() * self.width();
        gradient.iter_mut().for_each(|g| *g = 0.0);
        for (c, w) in self.centres.chunks_exact(self.inputs).zip(&self.weights) {
            let basis = w * (-squared_distance(x, c) / sigma2).exp();
            for ((g, xi), ci) in gradient.iter_mut().zip(x).zip(c) {
                *g -= basis * 2.0 * (xi - ci) / sigma2;
            }
        }
    }

    /// ∂ŷ/∂xᵢ in scaled units by central differences of step `step`
    /// (Eq. 33) at scaled inputs `x` (restored on return).
    pub fn central_difference(&self, x: &mut [f64], input: usize, step: f64) -> f64 {
        let centre = x[input];
        x[input] = centre + step;
        let plus = self.scaled_output(x);
        x[input] = centre - step;
        let minus = self.scaled_output(x);
        x[input] = centre;
        (plus - minus) / (2.0 * step)
    }

    /// The factor from a scaled derivative ∂ŷ/∂xᵢ to the unscaled ∂y/∂xᵢ.
    pub fn derivative_factor(&self, input: usize) -> f64 {
        let input_factor = self.input_scaling.unscale_factor(input);
        if input_factor > 0.0 {
            self.output_scaling.unscale_factor(0) / input_factor
        } else {
            0.0
        }
    }
}

/// The golden-section search for the least of `cost` on [a, b], to a
/// bracket of 10⁻³: the point kept and its cost.
fn golden_section((mut a, mut b): (f64, f64), mut cost: impl FnMut(f64) -> f64) -> (f64, f64) {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - ratio * (b - a), a + ratio * (b - a));
    let (mut fc, mut fd) = (cost(c), cost(d));
    while b - a > 1e-3 {
        if fc <= fd {
            (b, d, fd) = (d, c, fc);
            c = b - ratio * (b - a);
            fc = cost(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + ratio * (b - a);
            fd = cost(d);
        }
    }
    if fc <= fd { (c, fc) } else { (d, fd) }
}
#[cfg(test)]
mod tests {
    use super::*;

    /// Four points: two pairs 0.1 apart, the pairs 5 apart. Radius 1 gives
    /// two centres at the pairs' means (Eq. 29's running mean), in record
    /// order; a radius below 0.1 keeps every point its own centre.
    #[test]
    fn clustering_finds_the_pairs() {
        let points = [0.0, 0.0, 5.0, 5.0, 0.1, 0.0, 5.0, 5.1];
        let centres = cluster(&points, 2, 1.0);
        assert_eq!(centres.len(), 4);
        let expected = [0.05, 0.0, 5.0, 5.05];
        for (c, e) in centres.iter().zip(expected) {
            assert!((c - e).abs() < 1e-15, "{centres:?}");
        }
        assert_eq!(cluster(&points, 2, 0.05), points.to_vec());
    }

    /// Step 3 passes again when a centre has moved: the point at 1.9 is
    /// outside radius 1.5 of the first centre (0) but inside it once the
    /// point at 0.9 has joined and moved the centre to 0.45.
    #[test]
    fn clustering_repeats_a_pass_after_the_centre_moves() {
        let points = [0.0, 1.9, 0.9];
        // Pass 1 from centre 0: 1.9 is out, 0.9 joins → centre 0.45.
        // Pass 2: |1.9 − 0.45| = 1.45 > 1, stays out → second cluster.
        let centres = cluster(&points, 1, 1.0);
        assert_eq!(centres, vec![0.45, 1.9]);
        // Radius 1.5: pass 1 adds 0.9 (centre 0.45); 1.9 was 1.9 away at its
        // turn, pass 2 finds it 1.45 away: joined, centre (0.9 + 1.9)/3.
        let centres = cluster(&points, 1, 1.5);
        assert_eq!(centres.len(), 1);
        assert!((centres[0] - 2.8 / 3.0).abs() < 1e-15, "{centres:?}");
    }

    /// The smooth function y = sin(x₁) + 0.5·x₂² on a 30 × 30 grid of
    /// [−1, 1]²: the trained network (d = 0.3: 24 centres, λ 7.44 from the
    /// held-out search) reproduces it between the grid points (a 17 × 17
    /// grid offset from the training one) to 1e-3 of the output's range
    /// RMS (measured 4.5e-4), and its analytic gradient equals central
    /// differences of step 1e-5 to 1e-6 (their truncation error is of order
    /// step²·y‴ ≈ 1e-9, rounding ~1e-10). Its slope in a at the centre is
    /// cos 0 = 1 within 1 % (measured 1.0044: the interpolation error).
    #[test]
    fn network_reproduces_a_smooth_function_and_its_gradient() {
        let f = |a: f64, b: f64| a.sin() + 0.5 * b * b;
        let grid = |n: usize, offset: f64| -> Vec<Vec<f64>> {
            let mut rows = Vec::new();
            for i in 0..n {
                for j in 0..n {
                    let step = 2.0 / (n as f64 - 1.0 + 2.0 * offset);
                    rows.push(vec![
                        -1.0 + step * (i as f64 + offset),
                        -1.0 + step * (j as f64 + offset),
                    ]);
                }
            }
            rows
        };
        let rows = grid(30, 0.0);
        let targets: Vec<f64> = rows.iter().map(|r| f(r[0], r[1])).collect();
        let names = vec!["a".to_string(), "b".to_string()];
        let options = RbfOptions {
            radius: 0.3,
            ..RbfOptions::default()
        };
        let network = RbfNetwork::train(&rows, &names, &targets, &options).unwrap();
        assert!(network.centre_count() > 10 && network.centre_count() < 200);
        let test = grid(17, 0.5);
        let mut buffer = [0.0; 2];
        let range = targets.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - targets.iter().cloned().fold(f64::INFINITY, f64::min);
        let rms = (test
            .iter()
            .map(|r| (network.predict(r, &mut buffer) - f(r[0], r[1])).powi(2))
            .sum::<f64>()
            / test.len() as f64)
            .sqrt()
            / range;
        assert!(rms < 1e-3, "RMS error {rms:e}");
        let mut gradient = [0.0; 2];
        for r in &test {
            buffer.copy_from_slice(r);
            network.input_scaling.apply(&mut buffer);
            network.scaled_gradient(&buffer, &mut gradient);
            for (i, &g) in gradient.iter().enumerate() {
                let difference = network.central_difference(&mut buffer, i, 1e-5);
                assert!(
                    (difference - g).abs() < 1e-6 * g.abs().max(1.0),
                    "{difference} vs {g}"
                );
            }
        }
        buffer = [0.0, 0.0];
        let slope = network.central_difference(&mut buffer, 0, 1e-3) * network.derivative_factor(0);
        assert!((slope - 1.0).abs() < 0.01, "∂y/∂a at 0: {slope}");
    }
}
