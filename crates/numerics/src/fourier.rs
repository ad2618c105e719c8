//! The finite Fourier transform of sampled data at chosen frequencies, the
//! core of the frequency-domain estimators:
//!
//!   x̃(ω) = ∫_{t₀}^{t_N} x(t)·e^{−jωt} dt                                (1)
//!
//! (Klein & Morelli, "Aircraft System Identification", AIAA 2006, §7.2; the
//! phase is referred to t = 0 of the record's clock, not to t₀).
//!
//! **Quadrature: Filon–Simpson.** The samples x_k = x(t₀ + k·h) are joined
//! by a quadratic through each pair of intervals, and (1) is integrated
//! exactly over that interpolant (Filon 1928; Abramowitz & Stegun,
//! "Handbook of Mathematical Functions", 25.4.47, written here in complex
//! form). On a panel centred at t_c, with s = t − t_c and the moments
//! J_n(a, b) = ∫_a^b sⁿ·e^{−jωs} ds, the Lagrange weights of the samples at
//! s = −h, 0, h are
//!
//!   w₋ = (J₂ − h·J₁)/(2h²),  w₀ = (h²·J₀ − J₂)/h²,  w₊ = (J₂ + h·J₁)/(2h²),   (2)
//!
//! each multiplied by e^{−jωt_c}; an odd number of intervals ends with the
//! last interval alone, a single interval is integrated linearly. The rule
//! is exact for a piecewise quadratic and its error is O(h⁴) for a smooth
//! x, so the transform of a derivative, which the estimators take from
//!
//!   (ẋ)~(ω) = jω·x̃(ω) + x(t_N)·e^{−jωt_N} − x(t₀)·e^{−jωt₀}             (3)
//!
//! (integration by parts; K&M §7.2), agrees with the transform of the
//! sampled derivative to O(h⁴): 1e-4 of the value at ω·h = 0.4.
//!
//! **Steps.** A control that steps makes the integrand of (1) jump, which a
//! quadratic would smear over a sample interval. The transform therefore
//! takes breaks, sample indices where the signals may jump ([`breaks_at`]),
//! and integrates the record piecewise between them, each piece ending on
//! its left limit (`left_limit`): a held control is then exact, and (3)
//! still holds for a continuous x.
//!
//! **Recursive form** ([`RunningTransform`]; E. A. Morelli, "Real-time
//! parameter estimation in the frequency domain", J. Guidance, Control, and
//! Dynamics 23(5), 2000: X_k(ω) = X_{k−1}(ω) + x_k·e^{−jωkh}, here with
//! Simpson's weights). The batch transform ([`FourierTransform`]) collects
//! the same weights into a matrix and evaluates every signal at once.

use crate::error::{Error, Result};
use nalgebra::{Complex, DMatrix};

/// Phasors are re-anchored to the library's sine and cosine this often
/// (samples), so a rotation's rounding error does not grow past ~1e-14.
const ANCHOR_INTERVAL: usize = 256;

type C64 = Complex<f64>;

/// J_n(a, b) = ∫_a^b sⁿ·e^{−jωs} ds for n = 0, 1, 2: from their power
/// series where ω·h < 1, otherwise from J₀ = (e^{−jωb} − e^{−jωa})/(−jω),
/// J_n = [sⁿe^{−jωs}/(−jω)]_a^b − n/(−jω)·J_{n−1}.
fn moments(omega: f64, a: f64, b: f64) -> [C64; 3] {
    let reach = a.abs().max(b.abs());
    if omega * reach < 1.0 {
        // Σ_m (−jω)^m/m!·(b^{n+m+1} − a^{n+m+1})/(n+m+1).
        let mut sums = [C64::new(0.0, 0.0); 3];
        for (n, sum) in sums.iter_mut().enumerate() {
            // term = (−jω)^m/m!; b^{n+m+1} and a^{n+m+1} carried along.
            let mut term = C64::new(1.0, 0.0);
            let (mut pa, mut pb) = (a.powi(n as i32 + 1), b.powi(n as i32 + 1));
            let scale = reach.powi(n as i32 + 1);
            for m in 0..60 {
                let power = (n + m + 1) as f64;
                *sum += term * ((pb - pa) / power);
                term *= C64::new(0.0, -omega) / (m + 1) as f64;
                pa *= a;
                pb *= b;
                // Later terms are below (ω·reach)^m/m! of the first.
                if (term.re.abs() + term.im.abs()) * pb.abs().max(pa.abs()) < 1e-18 * scale {
                    break;
                }
            }
        }
        sums
    } else {
        let k = C64::new(0.0, -omega);
        let e = |s: f64| (k * s).exp();
        let j0 = (e(b) - e(a)) / k;
        let j1 = (e(b) * b - e(a) * a) / k - j0 / k;
        let j2 = (e(b) * (b * b) - e(a) * (a * a)) / k - j1 * 2.0 / k;
        [j0, j1, j2]
    }
}

/// The weights (2) of the samples at s = −h, 0, h over s ∈ (a, b): a whole
/// panel is (−h, h); an odd number of intervals ends with the last interval
/// alone, (0, h) about its left sample with the quadratic through the last
/// three samples.
fn quadratic_weights(omega: f64, h: f64, (a, b): (f64, f64)) -> [C64; 3] {
    let [j0, j1, j2] = moments(omega, a, b);
    [
        (j2 - j1 * h) / (2.0 * h * h),
        (j0 * (h * h) - j2) / (h * h),
        (j2 + j1 * h) / (2.0 * h * h),
    ]
}

/// The weights of one interval's linear interpolant, samples at s = 0, h:
/// w_a = J₀ − J₁/h, w_b = J₁/h on (0, h).
fn linear_weights(omega: f64, h: f64) -> [C64; 2] {
    let [j0, j1, _] = moments(omega, 0.0, h);
    [j0 - j1 / h, j1 / h]
}

/// e^{−jωt}.
fn phasor(omega: f64, t: f64) -> C64 {
    let (s, c) = (omega * t).sin_cos();
    C64::new(c, -s)
}

/// The rule's weights at one frequency.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Weights {
    panel: [C64; 3],
    tail: [C64; 3],
    linear: [C64; 2],
    /// A whole-panel piece's first and last samples, referred to their own
    /// phasors: w₋·e^{−jωh} and w₊·e^{jωh}.
    first: C64,
    last: C64,
    /// Its inner samples: a panel's join (first + last, real) and centre
    /// (w₀, real).
    even: f64,
    odd: f64,
}

impl Weights {
    fn new(omega: f64, h: f64) -> Weights {
        let panel = quadratic_weights(omega, h, (-h, h));
        let rotation = phasor(omega, h);
        let (first, last) = (panel[0] * rotation, panel[2] * rotation.conj());
        Weights {
            panel,
            tail: quadratic_weights(omega, h, (0.0, h)),
            linear: linear_weights(omega, h),
            first,
            last,
            even: (first + last).re,
            odd: panel[1].re,
        }
    }
}

/// Where a sample's value enters a piece: a real sample, or the left limit
/// at a break, extrapolated from the samples before it.
#[derive(Debug, Clone, PartialEq)]
enum Point {
    Sample(usize),
    /// (sample, coefficient) pairs whose sum is the left limit.
    Limit(Vec<(usize, f64)>),
}

/// The left limit at break b of a piece that starts at s < b, extrapolated
/// from its last samples (quadratic, 3x_{b−1} − 3x_{b−2} + x_{b−3}; fewer
/// samples: linear or constant); the right piece starts at x_b. A quadratic
/// through a jump would smear it over a sample interval: a first-order
/// error that puts several per cent into the moment derivatives of a 3211
/// record. With the breaks a held control is exact, and a continuous signal
/// with a kink (the rates) keeps an O(h³) error at the break.
fn left_limit(s: usize, b: usize) -> Point {
    Point::Limit(match b - s {
        1 => vec![(b - 1, 1.0)],
        2 => vec![(b - 1, 2.0), (b - 2, -1.0)],
        _ => vec![(b - 1, 3.0), (b - 2, -3.0), (b - 3, 1.0)],
    })
}

/// Calls `add(i, w)` with the weight w of point i of a piece of `length`
/// consecutive points from sample `first` (the last may be a left limit),
/// given the rule's weights at one frequency and the samples' phasors:
/// whole panels, then the last interval alone when the count of intervals
/// is odd, or one linear interval. The whole panels' inner points, samples
/// all, are left to `inner(samples)`: their weights are the phasor times
/// `weights.odd` at an odd offset from `first` and `weights.even` at an
/// even one.
fn piece_weights(
    length: usize,
    first: usize,
    weights: &Weights,
    phasors: impl Fn(usize) -> C64,
    mut add: impl FnMut(usize, C64),
    mut inner: impl FnMut(std::ops::Range<usize>),
) {
    let n = length.saturating_sub(1);
    if n == 0 {
        return;
    }
    if n == 1 {
        let e = phasors(first);
        add(0, weights.linear[0] * e);
        add(1, weights.linear[1] * e);
        return;
    }
    let m = n - n % 2;
    add(0, weights.first * phasors(first));
    inner(first + 1..first + m);
    add(m, weights.last * phasors(first + m));
    if m < n {
        let e = phasors(first + n - 1);
        add(n - 2, weights.tail[0] * e);
        add(n - 1, weights.tail[1] * e);
        add(n, weights.tail[2] * e);
    }
}

/// The pieces between breaks: each a list of points, with its first sample.
fn pieces(count: usize, breaks: &[usize]) -> Vec<(usize, Vec<Point>)> {
    let mut inner: Vec<usize> = breaks
        .iter()
        .copied()
        .filter(|&b| b > 0 && b < count)
        .collect();
    inner.sort_unstable();
    inner.dedup();
    let mut pieces = Vec::new();
    let mut start = 0;
    for &b in &inner {
        let mut points: Vec<Point> = (start..b).map(Point::Sample).collect();
        points.push(left_limit(start, b));
        pieces.push((start, points));
        start = b;
    }
    pieces.push((start, (start..count).map(Point::Sample).collect()));
    pieces
}

/// The breaks of a grid `start + k·step` (k < count) for jumps at
/// `instants`: the first sample at or after each (a sample taken at the
/// instant of a held control's step already reads the new value).
pub fn breaks_at(start: f64, step: f64, count: usize, instants: &[f64]) -> Vec<usize> {
    let mut breaks: Vec<usize> = instants
        .iter()
        .filter_map(|&t| {
            let position = ((t - start) / step - 1e-6).ceil();
            (position >= 1.0 && position < count as f64).then_some(position as usize)
        })
        .collect();
    breaks.sort_unstable();
    breaks.dedup();
    breaks
}

fn check_grid(frequencies: &[f64], start: f64, step: f64, count: usize) -> Result<()> {
    if count < 2 {
        return Err(Error::Input {
            reason: format!("a finite Fourier transform needs at least 2 samples, has {count}"),
        });
    }
    if !(step > 0.0 && step.is_finite() && start.is_finite()) {
        return Err(Error::Input {
            reason: format!(
                "a finite Fourier transform needs a positive sample step, has {step} s from {start} s"
            ),
        });
    }
    if let Some(bad) = frequencies.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
        return Err(Error::Input {
            reason: format!(
                "a frequency of a finite Fourier transform must be finite and not negative, is {bad} rad/s"
            ),
        });
    }
    Ok(())
}

/// The finite Fourier transform of signals sampled on one uniform grid, at
/// chosen frequencies (rad/s), integrated piecewise between breaks.
#[derive(Debug, Clone, PartialEq)]
pub struct FourierTransform {
    pub frequencies: Vec<f64>,
    pub start: f64,
    pub step: f64,
    pub samples: usize,
    /// Each sample's weight at each frequency: real and imaginary parts,
    /// samples down, frequencies across.
    weights: [DMatrix<f64>; 2],
}

impl FourierTransform {
    /// The transform of `count` samples at `start + k·step` without breaks;
    /// an error when fewer than two samples, a step that is not positive or
    /// a frequency that is not finite and non-negative.
    pub fn new(
        frequencies: &[f64],
        start: f64,
        step: f64,
        count: usize,
    ) -> Result<FourierTransform> {
        FourierTransform::with_breaks(frequencies, start, step, count, &[])
    }

    /// The transform with the signals allowed to jump at the samples
    /// `breaks` (module documentation).
    // The transform's kernel: per group of LANES frequencies the phasor chains fill one buffer that the lanes' quadrature weights then read; split, each step would pass it and the lanes between calls.
    pub fn with_breaks(
        frequencies: &[f64],
        start: f64,
        step: f64,
        count: usize,
        breaks: &[usize],
    ) -> Result<FourierTransform> {
        check_grid(frequencies, start, step, count)?;
        let m = frequencies.len();
        let mut real = DMatrix::zeros(count, m);
        let mut imaginary = DMatrix::zeros(count, m);
        let pieces = pieces(count, breaks);
        // The phasors of LANES frequencies at a time: independent rotation
        // chains, which the processor overlaps.
        const LANES: usize = 4;
        let mut phasors = vec![[C64::new(0.0, 0.0); LANES]; count];
        for group in (0..m).step_by(LANES) {
            let lanes = LANES.min(m - group);
            let omegas = &frequencies[group..group + lanes];
            let rotations: Vec<C64> = omegas.iter().map(|&w| phasor(w, step)).collect();
            let mut e = [C64::new(0.0, 0.0); LANES];
            for (k, slot) in phasors.iter_mut().enumerate() {
                for lane in 0..lanes {
                    if k % ANCHOR_INTERVAL == 0 {
                        e[lane] = phasor(omegas[lane], start + k as f64 * step);
                    }
                    slot[lane] = e[lane];
                    e[lane] *= rotations[lane];
                }
            }
            for (lane, &omega) in omegas.iter().enumerate() {
                let weights = Weights::new(omega, step);
                let j = group + lane;
                let (mut re, mut im) = (real.column_mut(j), imaginary.column_mut(j));
                for (first, points) in &pieces {
                    // At most five: the ends and a last interval's three.
                    let mut boundary = [(0, C64::new(0.0, 0.0)); 5];
                    let mut count = 0;
                    piece_weights(
                        points.len(),
                        *first,
                        &weights,
                        |k| phasors[k][lane],
                        |i, w| {
                            boundary[count] = (i, w);
                            count += 1;
                        },
                        |samples| {
                            for k in samples {
                                let c = if (k - first) % 2 == 1 {
                                    weights.odd
                                } else {
                                    weights.even
                                };
                                let e = phasors[k][lane];
                                re[k] += e.re * c;
                                im[k] += e.im * c;
                            }
                        },
                    );
                    for &(i, w) in &boundary[..count] {
                        match &points[i] {
                            Point::Sample(k) => {
                                re[*k] += w.re;
                                im[*k] += w.im;
                            }
                            Point::Limit(terms) => {
                                for &(k, coefficient) in terms {
                                    re[k] += w.re * coefficient;
                                    im[k] += w.im * coefficient;
                                }
                            }
                        }
                    }
                }
            }
        }
        Ok(FourierTransform {
            frequencies: frequencies.to_vec(),
            start,
            step,
            samples: count,
            weights: [real, imaginary],
        })
    }

    /// The transforms of several signals at once: column i of `signals`
    /// ([`FourierTransform::samples`] rows) gives row i of the result, one
    /// complex value per frequency.
    pub fn transform_columns(&self, signals: &DMatrix<f64>) -> Result<Vec<Vec<C64>>> {
        if signals.nrows() != self.samples {
            return Err(Error::Input {
                reason: format!(
                    "a finite Fourier transform of {} samples was given {}",
                    self.samples,
                    signals.nrows()
                ),
            });
        }
        // Many signals: the general matrix product on a transposed copy
        // (blocked and vectorised); a few: one dot product per entry.
        let (real, imaginary) = if signals.ncols() >= 4 {
            let rows = signals.transpose();
            (&rows * &self.weights[0], &rows * &self.weights[1])
        } else {
            (
                signals.tr_mul(&self.weights[0]),
                signals.tr_mul(&self.weights[1]),
            )
        };
        Ok((0..signals.ncols())
            .map(|i| {
                (0..self.frequencies.len())
                    .map(|j| C64::new(real[(i, j)], imaginary[(i, j)]))
                    .collect()
            })
            .collect())
    }

    /// The transform of one signal.
    pub fn transform(&self, signal: &[f64]) -> Result<Vec<C64>> {
        let column = DMatrix::from_column_slice(signal.len(), 1, signal);
        Ok(self.transform_columns(&column)?.remove(0))
    }

    /// The transform of ẋ by (3) from x̃ and x's first and last samples
    /// (x continuous).
    pub fn derivative(&self, transform: &[C64], signal: &[f64]) -> Vec<C64> {
        let end = self.start + (self.samples - 1) as f64 * self.step;
        derivative_transform(
            &self.frequencies,
            transform,
            (self.start, signal[0]),
            (end, signal[self.samples - 1]),
        )
    }
}

/// (3): jω·x̃ + x(t_N)·e^{−jωt_N} − x(t₀)·e^{−jωt₀}.
pub fn derivative_transform(
    frequencies: &[f64],
    transform: &[C64],
    (t0, x0): (f64, f64),
    (tn, xn): (f64, f64),
) -> Vec<C64> {
    frequencies
        .iter()
        .zip(transform)
        .map(|(&omega, &x)| {
            C64::new(0.0, omega) * x + phasor(omega, tn) * xn - phasor(omega, t0) * x0
        })
        .collect()
}

/// The recursive form for several signals: one sample of every signal at
/// a time (after a break, if the signals may jump there), readable after
/// any sample. Each panel's contribution is added when its last sample
/// arrives, with the phasor e^{−jωt_k} advanced by the rotation e^{−jωh};
/// the open end (a last single interval) is added when the transform is
/// read. Simpson's weights agree with the sampled derivative's transform to
/// O(h⁴), where the rectangle sum of Morelli's real-time form is off by
/// half a sample of phase (first order in ω·h) and the trapezoid by
/// (ωh)²/12.
#[derive(Debug, Clone, PartialEq)]
pub struct RunningTransform {
    pub frequencies: Vec<f64>,
    pub start: f64,
    pub step: f64,
    signals: usize,
    weights: Vec<Weights>,
    rotations: Vec<C64>,
    /// e^{−jωt_k} of the latest sample (k = received − 1), per frequency.
    phasors: Vec<C64>,
    /// ... and of the two before it.
    earlier: [Vec<C64>; 2],
    /// Contributions of the closed pieces and whole panels, [signal][frequency].
    closed: Vec<Vec<C64>>,
    /// The current piece's last three values (oldest first), per signal.
    recent: Vec<[f64; 3]>,
    /// Samples in the current piece.
    piece: usize,
    received: usize,
    first: Vec<f64>,
    last: Vec<f64>,
}

impl RunningTransform {
    /// An empty transform of `signals` signals sampled at `start + k·step`.
    pub fn new(
        frequencies: &[f64],
        start: f64,
        step: f64,
        signals: usize,
    ) -> Result<RunningTransform> {
        check_grid(frequencies, start, step, 2)?;
        let zeros = vec![C64::new(0.0, 0.0); frequencies.len()];
        Ok(RunningTransform {
            frequencies: frequencies.to_vec(),
            start,
            step,
            signals,
            weights: frequencies.iter().map(|&w| Weights::new(w, step)).collect(),
            rotations: frequencies.iter().map(|&w| phasor(w, step)).collect(),
            phasors: zeros.clone(),
            earlier: [zeros.clone(), zeros.clone()],
            closed: vec![zeros; signals],
            recent: vec![[0.0; 3]; signals],
            piece: 0,
            received: 0,
            first: vec![0.0; signals],
            last: vec![0.0; signals],
        })
    }

    /// Samples received so far.
    pub fn received(&self) -> usize {
        self.received
    }

    /// Adds the next sample of every signal; `after_break`: the signals may
    /// jump between the previous sample and this one's instant.
    pub fn push(&mut self, values: &[f64], after_break: bool) -> Result<()> {
        if values.len() != self.signals {
            return Err(Error::Input {
                reason: format!(
                    "a running Fourier transform of {} signals was given {} values",
                    self.signals,
                    values.len()
                ),
            });
        }
        let k = self.received;
        // The phasor of sample k.
        self.earlier = [self.earlier[1].clone(), self.phasors.clone()];
        for (j, e) in self.phasors.iter_mut().enumerate() {
            *e = if k.is_multiple_of(ANCHOR_INTERVAL) {
                phasor(self.frequencies[j], self.start + k as f64 * self.step)
            } else {
                *e * self.rotations[j]
            };
        }
        if after_break && self.piece >= 1 {
            // Close the piece on its left limit at this instant.
            let limits: Vec<f64> = self
                .recent
                .iter()
                .map(|r| match self.piece {
                    1 => r[2],
                    2 => 2.0 * r[2] - r[1],
                    _ => 3.0 * r[2] - 3.0 * r[1] + r[0],
                })
                .collect();
            self.append(&limits);
            let open = self.open_end();
            for (closed, open) in self.closed.iter_mut().zip(open) {
                for (c, o) in closed.iter_mut().zip(open) {
                    *c += o;
                }
            }
            self.piece = 0;
        }
        self.append(values);
        if k == 0 {
            self.first.copy_from_slice(values);
        }
        self.last.copy_from_slice(values);
        self.received += 1;
        Ok(())
    }

    /// Appends a point at the current instant to the piece, closing a
    /// whole panel when it completes one.
    fn append(&mut self, values: &[f64]) {
        for (recent, &v) in self.recent.iter_mut().zip(values) {
            *recent = [recent[1], recent[2], v];
        }
        self.piece += 1;
        if self.piece >= 3 && self.piece % 2 == 1 {
            // A whole panel: centre one sample back.
            for (closed, recent) in self.closed.iter_mut().zip(&self.recent) {
                for (j, c) in closed.iter_mut().enumerate() {
                    let w = self.weights[j].panel;
                    *c += (w[0] * recent[0] + w[1] * recent[1] + w[2] * recent[2])
                        * self.earlier[1][j];
                }
            }
        }
    }

    /// The piece's open end: a last single interval, [signal][frequency].
    fn open_end(&self) -> Vec<Vec<C64>> {
        let zeros = vec![C64::new(0.0, 0.0); self.frequencies.len()];
        if self.piece < 2 || self.piece % 2 == 1 {
            return vec![zeros; self.signals];
        }
        self.recent
            .iter()
            .map(|r| {
                (0..self.frequencies.len())
                    .map(|j| {
                        let w = &self.weights[j];
                        if self.piece == 2 {
                            (w.linear[0] * r[1] + w.linear[1] * r[2]) * self.earlier[1][j]
                        } else {
                            (w.tail[0] * r[0] + w.tail[1] * r[1] + w.tail[2] * r[2])
                                * self.earlier[1][j]
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// The time of the latest sample.
    pub fn end(&self) -> f64 {
        self.start + (self.received.max(1) - 1) as f64 * self.step
    }

    /// The transform of signal `i` over the samples received; an error
    /// before two are in.
    pub fn transform(&self, i: usize) -> Result<Vec<C64>> {
        if self.received < 2 {
            return Err(Error::Input {
                reason: format!(
                    "a running Fourier transform is read after {} samples; it needs 2",
                    self.received
                ),
            });
        }
        let open = self.open_end();
        Ok(self.closed[i]
            .iter()
            .zip(&open[i])
            .map(|(c, o)| c + o)
            .collect())
    }

    /// The transform of signal i's derivative by (3).
    pub fn derivative(&self, i: usize) -> Result<Vec<C64>> {
        let transform = self.transform(i)?;
        Ok(derivative_transform(
            &self.frequencies,
            &transform,
            (self.start, self.first[i]),
            (self.end(), self.last[i]),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_{t0}^{t1} f(t)·e^{−jωt} dt for a polynomial f (coefficients in
    /// ascending powers) by repeated integration by parts: with a = −jω,
    /// ∫ f·e^{at} = e^{at}·Σ_n (−1)ⁿ f⁽ⁿ⁾/a^{n+1}.
    fn polynomial_transform(coefficients: &[f64], omega: f64, t0: f64, t1: f64) -> Complex<f64> {
        if omega == 0.0 {
            let integral: f64 = coefficients
                .iter()
                .enumerate()
                .map(|(i, c)| c * (t1.powi(i as i32 + 1) - t0.powi(i as i32 + 1)) / (i + 1) as f64)
                .sum();
            return Complex::new(integral, 0.0);
        }
        let a = Complex::new(0.0, -omega);
        let antiderivative = |t: f64| {
            let mut derivative = coefficients.to_vec();
            let mut sum = Complex::new(0.0, 0.0);
            let mut sign = 1.0;
            let mut power = a;
            while !derivative.is_empty() {
                let value: f64 = derivative
                    .iter()
                    .enumerate()
                    .map(|(i, c)| c * t.powi(i as i32))
                    .sum();
                sum += sign * value / power;
                derivative = derivative
                    .iter()
                    .enumerate()
                    .skip(1)
                    .map(|(i, c)| c * i as f64)
                    .collect();
                sign = -sign;
                power *= a;
            }
            (a * t).exp() * sum
        };
        antiderivative(t1) - antiderivative(t0)
    }

    /// Simpson's rule is exact for a quadratic, at every frequency: the
    /// transform of 1 + 2t − 0.5t² on [0.3, 4.3] s (and on [0.3, 4.26] s,
    /// an odd number of intervals, whose last is integrated alone) sampled
    /// at 0.04 s equals the analytic integral to rounding (1e-12
    /// relative), at ω·h below and above the series/closed-form switch.
    #[test]
    fn a_quadratic_is_transformed_exactly() {
        let f = [1.0, 2.0, -0.5];
        let (start, step) = (0.3, 0.04);
        for count in [101, 100, 2, 3] {
            let samples: Vec<f64> = (0..count)
                .map(|k| {
                    let t = start + k as f64 * step;
                    if count == 2 {
                        // One interval is integrated linearly: exact for a line.
                        f[0] + f[1] * t
                    } else {
                        f[0] + f[1] * t + f[2] * t * t
                    }
                })
                .collect();
            let poly: &[f64] = if count == 2 { &f[..2] } else { &f };
            let frequencies = [0.0, 0.7, 6.0, 24.9, 25.1, 60.0];
            let transform = FourierTransform::new(&frequencies, start, step, count).unwrap();
            let computed = transform.transform(&samples).unwrap();
            let end = start + (count - 1) as f64 * step;
            for (&omega, value) in frequencies.iter().zip(&computed) {
                let exact = polynomial_transform(poly, omega, start, end);
                assert!(
                    (value - exact).norm() <= 1e-12 * exact.norm().max(1.0),
                    "{count} samples, ω = {omega}: {value} against {exact}"
                );
            }
        }
    }

    /// A held control that steps at a sample is transformed exactly when
    /// the step is a break (the piecewise integral of a step function),
    /// and with an error of the order of the step times h without it.
    #[test]
    fn a_step_at_a_break_is_exact() {
        let (start, step, count) = (0.0, 0.04, 251);
        let jump = 40; // the value changes at t = 1.6 s
        let samples: Vec<f64> = (0..count)
            .map(|k| if k < jump { 0.5 } else { -1.0 })
            .collect();
        let frequencies = [0.0, 1.0, 4.0, 9.0];
        let end = (count - 1) as f64 * step;
        let at = jump as f64 * step;
        let exact = |omega: f64| {
            polynomial_transform(&[0.5], omega, start, at)
                + polynomial_transform(&[-1.0], omega, at, end)
        };
        let with =
            FourierTransform::with_breaks(&frequencies, start, step, count, &[jump]).unwrap();
        let without = FourierTransform::new(&frequencies, start, step, count).unwrap();
        let (a, b) = (
            with.transform(&samples).unwrap(),
            without.transform(&samples).unwrap(),
        );
        for (j, &omega) in frequencies.iter().enumerate() {
            let want = exact(omega);
            assert!(
                (a[j] - want).norm() < 1e-12 * want.norm().max(1.0),
                "ω = {omega}"
            );
            assert!(
                (b[j] - want).norm() > 0.1 * 1.5 * step,
                "ω = {omega}: the smeared step"
            );
        }
    }

    /// On a smooth signal the error is O(h⁴): the transform of cos(νt) +
    /// 0.3·sin(2.5νt) at 25 Hz over 20 s agrees with the analytic one to
    /// (νh)⁴/180-order, and halving h cuts the error about sixteenfold. The
    /// derivative by (3) agrees with the transform of the sampled
    /// derivative to the same order.
    #[test]
    fn smooth_signals_converge_at_fourth_order() {
        let nu = 2.0 * std::f64::consts::PI * 0.8;
        let x = |t: f64| (nu * t).cos() + 0.3 * (2.5 * nu * t).sin();
        let dx = |t: f64| -nu * (nu * t).sin() + 0.75 * nu * (2.5 * nu * t).cos();
        let frequencies: Vec<f64> = (1..=30).map(|m| 0.35 * m as f64).collect();
        let exact = |omega: f64, t1: f64| {
            // cos(νt) = (e^{jνt} + e^{−jνt})/2, sin = (e^{jνt} − e^{−jνt})/(2j).
            let piece = |rate: f64| {
                let b = Complex::new(0.0, rate - omega);
                if b.norm() == 0.0 {
                    Complex::new(t1, 0.0)
                } else {
                    ((b * t1).exp() - 1.0) / b
                }
            };
            (piece(nu) + piece(-nu)) * 0.5
                + (piece(2.5 * nu) - piece(-2.5 * nu)) * Complex::new(0.0, -0.15)
        };
        let mut errors = Vec::new();
        for step in [0.04, 0.02] {
            let count = (20.0 / step) as usize + 1;
            let samples: Vec<f64> = (0..count).map(|k| x(k as f64 * step)).collect();
            let rates: Vec<f64> = (0..count).map(|k| dx(k as f64 * step)).collect();
            let transform = FourierTransform::new(&frequencies, 0.0, step, count).unwrap();
            let computed = transform.transform(&samples).unwrap();
            let mut worst: f64 = 0.0;
            for (&omega, value) in frequencies.iter().zip(&computed) {
                worst = worst.max((value - exact(omega, 20.0)).norm());
            }
            errors.push(worst);
            // Both sides carry the rule's O(h⁴) error, of order
            // (ν_max·h)⁴/180 of the largest value (3.6e-4 at h = 0.04 s).
            let from_signal = transform.derivative(&computed, &samples);
            let of_derivative = transform.transform(&rates).unwrap();
            let largest = of_derivative.iter().map(|b| b.norm()).fold(0.0, f64::max);
            let bound = (2.5 * nu * step).powi(4) / 180.0 * largest;
            for (a, b) in from_signal.iter().zip(&of_derivative) {
                assert!((a - b).norm() < bound, "h = {step}: {a} against {b}");
            }
        }
        // |x̃| reaches T/2 = 10 where ω = ν; the rule's error is of order
        // (ν_max·h)⁴/180 of it.
        let bound = (2.5 * nu * 0.04_f64).powi(4) / 180.0 * 10.0;
        assert!(errors[0] < bound, "h = 0.04 s: {:e}", errors[0]);
        assert!(
            errors[0] / errors[1] > 12.0,
            "fourth order: {:e} then {:e}",
            errors[0],
            errors[1]
        );
    }

    /// The recursive form equals the batch transform after any sample
    /// count (to 1e-12 relative), with and without breaks, its derivative
    /// too.
    #[test]
    fn the_running_transform_is_the_batch_transform() {
        let frequencies = [0.0, 0.9, 3.3, 9.1];
        let (start, step) = (1.5, 0.04);
        let breaks = [5, 6, 40, 333, 334, 600];
        let signal = |k: usize| {
            ((k as f64) * 0.13).sin() + 0.01 * (k % 7) as f64 + if k >= 40 { 0.3 } else { 0.0 }
        };
        let mut running = RunningTransform::new(&frequencies, start, step, 2).unwrap();
        for k in 0..700 {
            running
                .push(&[signal(k), 2.0 * signal(k)], breaks.contains(&k))
                .unwrap();
            let received = k + 1;
            assert_eq!(running.received(), received);
            if received < 2 {
                assert!(running.transform(0).is_err());
                continue;
            }
            if received > 12 && received % 47 != 0 && !breaks.contains(&k) && received != 700 {
                continue;
            }
            let samples: Vec<f64> = (0..received).map(signal).collect();
            let batch = FourierTransform::with_breaks(&frequencies, start, step, received, &breaks)
                .unwrap();
            let expected = batch.transform(&samples).unwrap();
            let derivative = batch.derivative(&expected, &samples);
            for (i, scale) in [(0, 1.0), (1, 2.0)] {
                let got = running.transform(i).unwrap();
                let got_derivative = running.derivative(i).unwrap();
                for j in 0..frequencies.len() {
                    let want = expected[j] * scale;
                    assert!(
                        (got[j] - want).norm() <= 1e-12 * want.norm().max(1.0),
                        "{received} samples, ω = {}: {} against {want}",
                        frequencies[j],
                        got[j]
                    );
                    let want = derivative[j] * scale;
                    assert!((got_derivative[j] - want).norm() <= 1e-12 * want.norm().max(1.0));
                }
            }
        }
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(FourierTransform::new(&[1.0], 0.0, 0.1, 1).is_err());
        assert!(FourierTransform::new(&[1.0], 0.0, 0.0, 11).is_err());
        assert!(FourierTransform::new(&[-1.0], 0.0, 0.1, 11).is_err());
        assert!(FourierTransform::new(&[f64::NAN], 0.0, 0.1, 11).is_err());
        let transform = FourierTransform::new(&[1.0], 0.0, 0.1, 11).unwrap();
        assert!(transform.transform(&[0.0; 5]).is_err());
        let mut running = RunningTransform::new(&[1.0], 0.0, 0.1, 2).unwrap();
        assert!(running.push(&[1.0], false).is_err());
    }
}
