//! Tests of the Dryden turbulence: the closed-form discretisation against
//! Van Loan's method, the stationary start, and the spectrum and variance
//! of long records against the analytic Dryden spectra.

use super::FlightConditions;
use super::dryden::{transverse_process_noise, transverse_transition};
use super::tests::{CRUISE, assert_close, explicit_turbulence};
use nalgebra::{Complex, Matrix2, Matrix4};
use std::f64::consts::{PI, TAU};

/// Φ and Qd by Van Loan's method: expm([[−A, BBᵀ], [0, Aᵀ]]·dt) = [[·, Φ⁻¹Qd], [0, Φᵀ]].
fn van_loan(theta: f64) -> (Matrix2<f64>, Matrix2<f64>) {
    // Time in units of L/V: A = [[0, 1], [−1, −2]], B = [0, 2]ᵀ, dt = θ.
    let system = Matrix2::new(0.0, 1.0, -1.0, -2.0);
    let noise = Matrix2::new(0.0, 0.0, 0.0, 4.0);
    let mut block = Matrix4::zeros();
    block
        .fixed_view_mut::<2, 2>(0, 0)
        .copy_from(&(-system * theta));
    block
        .fixed_view_mut::<2, 2>(0, 2)
        .copy_from(&(noise * theta));
    block
        .fixed_view_mut::<2, 2>(2, 2)
        .copy_from(&(system.transpose() * theta));
    let exponential = block.exp();
    let transition: Matrix2<f64> = exponential.fixed_view::<2, 2>(2, 2).transpose();
    let covariance = transition * exponential.fixed_view::<2, 2>(0, 2);
    (transition, covariance)
}

#[test]
fn closed_form_discretisation_matches_van_loan_and_stationarity() {
    for theta in [1e-3, 0.02, 0.3, 0.99, 1.01, 3.0] {
        let (transition, covariance) = van_loan(theta);
        let closed = transverse_process_noise(theta);
        assert!(
            (transverse_transition(theta) - transition).amax() < 1e-12,
            "Φ at θ = {theta}"
        );
        for (row, column) in [(0, 0), (0, 1), (1, 1)] {
            let scale = (closed[(row, row)] * closed[(column, column)]).sqrt();
            let difference = (closed[(row, column)] - covariance[(row, column)]).abs();
            assert!(
                difference < 1e-8 * scale,
                "Qd[{row}{column}] at θ = {theta}: {closed} vs {covariance}"
            );
        }
    }
    // A stationary identity covariance is kept: Qd = I − ΦΦᵀ.
    for theta in [0.5, 5.0, 50.0] {
        let transition = transverse_transition(theta);
        let residual = Matrix2::identity() - transition * transition.transpose();
        assert!(
            (residual - transverse_process_noise(theta)).amax() < 1e-13,
            "θ = {theta}"
        );
    }
}

/// MIL-F-8785C Dryden spatial spectrum Φ(Ω) of `axis` (0 = u, 1 = v, 2 = w), one-sided.
fn spatial_spectrum(axis: usize, sigma: f64, length: f64, frequency: f64) -> f64 {
    let scaled = (length * frequency).powi(2);
    if axis == 0 {
        sigma * sigma * 2.0 * length / PI / (1.0 + scaled)
    } else {
        sigma * sigma * length / PI * (1.0 + 3.0 * scaled) / (1.0 + scaled).powi(2)
    }
}

/// One-sided PSD in Hz of the continuous process seen at airspeed V.
/// With Ω = 2πf/V, dΩ = (2π/V)·df and σ² = ∫₀^∞ Φ(Ω) dΩ = ∫₀^∞ (2π/V)·Φ(2πf/V) df,
/// so S(f) = (2π/V)·Φ(2πf/V) (Φ is already one-sided: no further factor 2).
fn time_spectrum(axis: usize, sigma: f64, length: f64, airspeed: f64, frequency: f64) -> f64 {
    TAU / airspeed * spatial_spectrum(axis, sigma, length, TAU * frequency / airspeed)
}

/// One-sided PSD of the sampled sequence: the aliased sum Σₖ S(|f + k·fs|).
fn sampled_spectrum(
    axis: usize,
    sigma: f64,
    length: f64,
    airspeed: f64,
    step: f64,
    frequency: f64,
) -> f64 {
    (-4000..=4000_i32)
        .map(|k| (frequency + f64::from(k) / step).abs())
        .map(|alias| time_spectrum(axis, sigma, length, airspeed, alias))
        .sum()
}

/// ∫₀^∞ g(f) df by the midpoint rule on [0, 4000·fc], fc = V/(2πL); integrands fall as f⁻².
fn integrate_spectrum(corner: f64, integrand: impl Fn(f64) -> f64) -> f64 {
    let width = corner / 400.0;
    (0..1_600_000)
        .map(|i| integrand((i as f64 + 0.5) * width) * width)
        .sum()
}

#[test]
fn analytic_spectra_integrate_to_the_variance() {
    for axis in 0..3 {
        let (sigma, length, airspeed) = (1.7, 40.0, 60.0);
        let corner = airspeed / (TAU * length);
        let variance =
            integrate_spectrum(corner, |f| time_spectrum(axis, sigma, length, airspeed, f));
        assert_close(
            variance,
            sigma * sigma,
            2e-3 * sigma * sigma,
            &format!("axis {axis}"),
        );
    }
}

#[test]
fn filters_start_from_their_stationary_distribution() {
    let sigma = [2.0, 1.5, 1.0];
    let spec = explicit_turbulence(sigma, [500.0, 400.0, 300.0]);
    let runs = 4000;
    let mut squares = [0.0; 3];
    for seed in 0..runs {
        let first = spec.generate(&CRUISE, 0.01, 1, seed).unwrap()[0].body;
        for axis in 0..3 {
            squares[axis] += first[axis].powi(2) / runs as f64;
        }
    }
    // The mean of n squared normals has relative standard error √(2/n) = 2.2 %; allow 5 of them.
    let tolerance = 5.0 * (2.0 / runs as f64).sqrt();
    for axis in 0..3 {
        let ratio = squares[axis] / sigma[axis].powi(2);
        assert!(
            (ratio - 1.0).abs() < tolerance,
            "axis {axis}: first-sample variance ratio {ratio}"
        );
    }
}

/// In-place iterative radix-2 FFT, X[k] = Σ x[n]·e^{−2πikn/N}.
fn fft(buffer: &mut [Complex<f64>]) {
    let size = buffer.len();
    assert!(size.is_power_of_two());
    let mut reversed = 0;
    for index in 1..size {
        let mut bit = size >> 1;
        while reversed & bit != 0 {
            reversed ^= bit;
            bit >>= 1;
        }
        reversed |= bit;
        if index < reversed {
            buffer.swap(index, reversed);
        }
    }
    let mut span = 2;
    while span <= size {
        let root = Complex::from_polar(1.0, -TAU / span as f64);
        for chunk in buffer.chunks_exact_mut(span) {
            let mut twiddle = Complex::new(1.0, 0.0);
            let (lower, upper) = chunk.split_at_mut(span / 2);
            for (even, odd) in lower.iter_mut().zip(upper.iter_mut()) {
                let product = *odd * twiddle;
                *odd = *even - product;
                *even += product;
                twiddle *= root;
            }
        }
        span *= 2;
    }
}

fn hann(size: usize) -> Vec<f64> {
    (0..size)
        .map(|n| 0.5 - 0.5 * (TAU * n as f64 / size as f64).cos())
        .collect()
}

/// Welch one-sided PSD (non-overlapping Hann segments, no detrending):
/// P[k] = 2·dt/(K·Σw²)·Σ_segments |X_k|², valid for 0 < k < M/2.
fn welch(signal: &[f64], segment: usize, step: f64) -> Vec<f64> {
    let window = hann(segment);
    let window_power: f64 = window.iter().map(|w| w * w).sum();
    let mut power = vec![0.0; segment / 2 + 1];
    let mut buffer = vec![Complex::new(0.0, 0.0); segment];
    let segments = signal.len() / segment;
    for chunk in signal.chunks_exact(segment) {
        for ((slot, value), weight) in buffer.iter_mut().zip(chunk).zip(&window) {
            *slot = Complex::new(value * weight, 0.0);
        }
        fft(&mut buffer);
        for (bin, accumulated) in power.iter_mut().enumerate() {
            *accumulated += buffer[bin].norm_sqr();
        }
    }
    let scale = 2.0 * step / (segments as f64 * window_power);
    power.iter().map(|p| p * scale).collect()
}

/// Variance of a band mean of `band` adjacent Welch bins of one segment, relative to the
/// squared spectrum: for a locally flat Gaussian spectrum Cov(|X_i|², |X_j|²) ∝ |c_{i−j}|²
/// with c_m = Σ w²·e^{−2πimn/M} / Σ w² (Hann: c₀ = 1, c±₁ = −2/3, c±₂ = 1/6), so the
/// variance is (1/B²)·Σ_{i,j} |c_{i−j}|² (≈ 1.94/B). Over K independent segments divide by K.
fn band_variance_factor(segment: usize, band: usize) -> f64 {
    let squares: Vec<f64> = hann(segment).iter().map(|w| w * w).collect();
    let total: f64 = squares.iter().sum();
    let correlation = |lag: usize| -> f64 {
        let sum: Complex<f64> = squares
            .iter()
            .enumerate()
            .map(|(n, s)| Complex::from_polar(*s, -TAU * (lag * n) as f64 / segment as f64))
            .sum();
        sum.norm_sqr() / (total * total)
    };
    let mut factor = 0.0;
    for i in 0..band {
        for j in 0..band {
            factor += correlation(i.abs_diff(j));
        }
    }
    factor / (band * band) as f64
}

#[test]
fn fft_matches_a_plain_dft() {
    let signal: Vec<Complex<f64>> = (0..16)
        .map(|n| Complex::new((n as f64 * 0.7).sin() + 0.1 * n as f64, 0.0))
        .collect();
    let mut transformed = signal.clone();
    fft(&mut transformed);
    for (k, value) in transformed.iter().enumerate() {
        let direct: Complex<f64> = signal
            .iter()
            .enumerate()
            .map(|(n, x)| x * Complex::from_polar(1.0, -TAU * (k * n) as f64 / 16.0))
            .sum();
        assert!((value - direct).norm() < 1e-12, "bin {k}");
    }
}

/// A 2^18-sample record (0.02 s, V = 100 m/s) against the analytic Dryden spectra.
///
/// Welch: 128 independent Hann segments of 2048 samples (Δf = 0.0244 Hz). A band mean of
/// B = 10 bins has relative standard error √(band_variance_factor/K) ≈ 3.9 %; each band
/// up to a quarter of Nyquist (6.25 Hz) must lie within 4 standard errors of the aliased
/// analytic spectrum (window leakage bias is ≈ S''/(6S) bin² < 0.3 % here).
///
/// Variance: for a Gaussian process the mean square over T has variance
/// (1/T)·∫₀^∞ S(f)² df (Parseval on 2∫R(τ)²dτ); the estimate must lie within 5 of its
/// standard errors (≈ 1.4 % for u).
#[test]
fn welch_spectrum_and_variance_match_dryden() {
    const SAMPLES: usize = 1 << 18;
    const SEGMENT: usize = 2048;
    const BAND: usize = 10;
    let (step, airspeed) = (0.02, 100.0);
    let sigma = [2.0, 1.5, 1.0];
    let length = [50.0, 30.0, 20.0];
    let conditions = FlightConditions {
        airspeed,
        altitude: 300.0,
    };
    let spec = explicit_turbulence(sigma, length);
    let samples = spec.generate(&conditions, step, SAMPLES, 7).unwrap();
    let segments = SAMPLES / SEGMENT;
    let relative_error = (band_variance_factor(SEGMENT, BAND) / segments as f64).sqrt();
    let resolution = 1.0 / (SEGMENT as f64 * step);
    let last_bin = (0.25 * 0.5 / step / resolution).round() as usize;
    let duration = SAMPLES as f64 * step;
    for axis in 0..3 {
        let signal: Vec<f64> = samples.iter().map(|sample| sample.body[axis]).collect();
        let estimate = welch(&signal, SEGMENT, step);
        let mut worst: f64 = 0.0;
        for first in (1..=last_bin + 1 - BAND).step_by(BAND) {
            let bins = first..first + BAND;
            let measured = bins.clone().map(|bin| estimate[bin]).sum::<f64>() / BAND as f64;
            let expected = bins
                .map(|bin| {
                    sampled_spectrum(
                        axis,
                        sigma[axis],
                        length[axis],
                        airspeed,
                        step,
                        bin as f64 * resolution,
                    )
                })
                .sum::<f64>()
                / BAND as f64;
            let deviation = (measured / expected - 1.0) / relative_error;
            worst = worst.max(deviation.abs());
            assert!(
                deviation.abs() < 4.0,
                "axis {axis}, bins {first}..{}: {measured} vs {expected} ({deviation:.2} standard errors)",
                first + BAND
            );
        }
        let variance = signal.iter().map(|v| v * v).sum::<f64>() / SAMPLES as f64;
        let corner = airspeed / (TAU * length[axis]);
        let squared_spectrum = integrate_spectrum(corner, |f| {
            time_spectrum(axis, sigma[axis], length[axis], airspeed, f).powi(2)
        });
        let standard_error = (squared_spectrum / duration).sqrt();
        let variance_deviation = (variance - sigma[axis].powi(2)) / standard_error;
        eprintln!(
            "axis {axis}: worst band {worst:.2} SE (SE {:.1} %), variance {variance:.4} vs {:.4} ({variance_deviation:.2} SE)",
            100.0 * relative_error,
            sigma[axis].powi(2)
        );
        assert!(
            variance_deviation.abs() < 5.0,
            "axis {axis}: variance {variance} vs {}",
            sigma[axis].powi(2)
        );
    }
}
