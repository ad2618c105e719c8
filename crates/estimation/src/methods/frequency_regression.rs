//! Equation error in the frequency domain (Fourier-transform regression):
//! least squares on the finite Fourier transforms of the force and moment
//! equations over the band the manoeuvre excites.
//!
//! Klein & Morelli, "Aircraft System Identification" (AIAA 2006), §7.2
//! (finite Fourier transform) and §7.3 (equation error in the frequency
//! domain); E. A. Morelli, "Real-time parameter estimation in the frequency
//! domain", J. Guidance, Control, and Dynamics 23(5):812–818, 2000 (the
//! recursive transform and the complex least-squares estimate). The
//! transform is [`aeroid_numerics::fourier`] (Filon–Simpson quadrature,
//! its Eqs. 1–3). Method `fdee`, settings `[methods.fdee]`
//! ([`FrequencyRegressionSettings`]); the user reference, with the band,
//! the settings and what is measured, is docs/methods.md,
//! "Fourier-transform regression".
//!
//! 1. **The equations, dimensional**, so that a varying q̄ stays inside the
//!    time signals: force `q̄S·C_meas(t) = Σ θ_i·q̄S·x_i(t)` with C_meas
//!    from the load factors (reflex-wing UAV paper, Eqs. 17–22); moment
//!    `(I·ω̇)_row + (ω×Iω − M_T)_row = Σ θ_i·q̄Sl·x_i(t)`. Fixed terms move
//!    to the measured side, as in equation error.
//! 2. **Transforms** at the band's frequencies ω_m; the angular
//!    accelerations are NOT differentiated:
//!    `(ω̇)~ = jω·ω̃ + ω(t_N)e^{−jωt_N} − ω(t₀)e^{−jωt₀}` (fourier Eq. 3,
//!    K&M §7.2), giving per coefficient `z̃ = X̃·θ + ṽ`.
//! 3. **Complex least squares** (K&M §7.3; Morelli 2000): the cost
//!    `J = ½·Σ_m |z̃_m − X̃_m·θ|²` is minimised by
//!    `θ̂ = [Re(X̃*X̃)]⁻¹·Re(X̃*z̃)`, real least squares on the stacked real
//!    and imaginary parts. The bound is the sandwich
//!    `[Re(X̃*X̃)]⁻¹·Re(X̃*·V·X̃)·[Re(X̃*X̃)]⁻¹` (White 1980), V the residual
//!    power averaged over the ±8 neighbouring frequencies (the rates' noise
//!    enters the moment equations as jω·ñ, growing with ω); the plain
//!    `s²·[Re(X̃*X̃)]⁻¹` (K&M §7.3) is in the notes.
//! 4. **Recursive form** (`recursive = true`, Morelli 2000): the transforms
//!    grow sample by sample ([`RunningTransform`]); at the end of the record
//!    the estimate equals the batch one.
//!
//! Limitations (`tests/estimators/frequency_domain.rs`): measured regressors
//! bias the estimates towards zero (errors in variables), which a band where
//! the signals dominate the noise reduces but does not remove; the samples
//! must be uniformly spaced; α̇ terms need α differentiated in the time domain.

use crate::error::{Error, Result};
use crate::estimate::{Estimate, Status};
use crate::estimator::{Capabilities, Description, Method, Settings, parse_settings};
pub use crate::methods::common::frequency_band::BandOptions;
use crate::methods::common::frequency_band::{BAND_SETTINGS, model_controls};
use crate::methods::common::regression::{
    self, Bound, CoefficientResult, Plan, assemble, failed_coefficient, fit_regression,
    outside_bounds_notes, regression_problem, white_bound_notes,
};
use crate::problem::EstimationProblem;
use crate::reconstruction::{
    Reconstruction, ReconstructionOptions, check_channels, control_steps, reconstruct,
};
use crate::structure::{ModelStructure, Structure};
use aeroid_core::units::Quantity;
use aeroid_numerics::fourier::{FourierTransform, RunningTransform, breaks_at};
use aeroid_record::FlightRecord;
use aeroid_sim::aero::{Coefficient, Regressor};
use nalgebra::{Complex, DMatrix, DVector};
use serde::{Deserialize, Serialize};

mod linear;

pub use linear::linear_frequency_regression;

/// Method name in estimates.
pub const METHOD: &str = "fdee";

/// The `[methods.fdee]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrequencyRegressionSettings {
    /// The band [low, high], e.g. ["0.1 Hz", "1.5 Hz"]; none: from the inputs' spectra.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band: Option<[Quantity; 2]>,
    /// Frequency spacing; none: 1/T, the record's Fourier resolution.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resolution: Option<Quantity>,
    /// The automatic band ends where every control's amplitude spectrum
    /// has fallen below this fraction of its peak.
    pub input_threshold: f64,
    /// Include ω = 0; none: when a free term has the constant regressor.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zero_frequency: Option<bool>,
    /// Build the transforms sample by sample (the real-time form).
    pub recursive: bool,
}

impl Default for FrequencyRegressionSettings {
    fn default() -> Self {
        FrequencyRegressionSettings {
            band: None,
            resolution: None,
            input_threshold: 0.1,
            zero_frequency: None,
            recursive: false,
        }
    }
}

/// [`FrequencyRegressionSettings`] in SI.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrequencyRegressionOptions {
    pub band: BandOptions,
    pub zero_frequency: Option<bool>,
    pub recursive: bool,
}

impl FrequencyRegressionSettings {
    /// Reads and checks a `[methods.fdee]` table.
    pub fn read(settings: &Settings) -> Result<FrequencyRegressionOptions> {
        parse_settings::<FrequencyRegressionSettings>(METHOD, settings)?.options()
    }

    /// The settings in SI, checked.
    pub fn options(&self) -> Result<FrequencyRegressionOptions> {
        Ok(FrequencyRegressionOptions {
            band: BandOptions::read(
                METHOD,
                self.band.as_ref(),
                self.resolution.as_ref(),
                self.input_threshold,
            )?,
            zero_frequency: self.zero_frequency,
            recursive: self.recursive,
        })
    }
}

/// Fourier-transform regression as a registered method.
pub(crate) struct FrequencyRegression;

impl Method for FrequencyRegression {
    const NAME: &'static str = METHOD;
    type Settings = FrequencyRegressionSettings;

    fn describe() -> Description {
        Description {
            title: "Fourier-transform regression: equation error on the finite Fourier transforms of the force and moment equations over the excited band",
            paper: "Klein & Morelli, \"Aircraft System Identification\" (AIAA 2006), §7.2–7.3; Morelli, \"Real-time parameter estimation in the frequency domain\", J. Guidance 23(5), 2000",
            equations: "x̃(ω) = ∫x·e^{−jωt}dt by Filon–Simpson quadrature; (ω̇)~ = jω·ω̃ + end terms; θ = [Re(X̃*X̃)]⁻¹Re(X̃*z̃), Cov = [Re(X̃*X̃)]⁻¹Re(X̃*VX̃)[Re(X̃*X̃)]⁻¹ with V the local residual power",
            needs: "as equation error (load factors, angular rates, airspeed, α, β, controls, dynamic pressure or altitude), uniformly sampled; a model linear in its parameters; a linear structure: every state measured",
            settings: vec![
                BAND_SETTINGS[0],
                BAND_SETTINGS[1],
                BAND_SETTINGS[2],
                (
                    "zero_frequency",
                    "include ω = 0 (the means; estimates bias terms); none: when a free term has the constant regressor",
                ),
                (
                    "recursive",
                    "build the transforms sample by sample (Morelli's real-time form); same estimate at the end of the record",
                ),
            ],
        }
    }

    /// Its moment equations are about the CG, in its own form.
    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            moment_reference: false,
            ..Capabilities::default()
        }
    }

    fn validate(settings: &FrequencyRegressionSettings) -> Result<()> {
        settings.options().map(|_| ())
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        settings: &FrequencyRegressionSettings,
        _start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let options = settings.options()?;
        match &problem.structure {
            Structure::SixDof(structure) => {
                frequency_regression(problem.record(), structure, &options)
            }
            Structure::Linear(structure) => {
                linear_frequency_regression(problem.record(), structure, &options)
            }
        }
    }
}

/// One regression's transforms: z̃ and one X̃ column per regression column.
type Regression = (Vec<Complex<f64>>, Vec<Vec<Complex<f64>>>);

/// The transformed data: per plan the measured side and its regressors.
struct Transformed {
    /// Angular frequencies (rad/s).
    frequencies: Vec<f64>,
    /// Per plan: z̃ and one X̃ column per regression column.
    plans: Vec<Regression>,
    samples: usize,
}

/// The time signals of the regressions on the common time base: per plan
/// the dimensional measured side (without I·ω̇) and regressors, then p, q, r.
struct Signals {
    /// N × S, column by column.
    matrix: DMatrix<f64>,
    /// Per plan: the column of z, and per regression column the column of
    /// its q̄S·x and the factor (the reference length l) it takes. A
    /// regressor the plans share is transformed once.
    layout: Vec<(usize, Vec<(usize, f64)>)>,
    /// Column of p (then q, r) when a moment is regressed.
    rates: Option<usize>,
    /// The plans' coefficients.
    coefficients: Vec<Coefficient>,
    /// The aircraft's inertia matrix (kg·m²).
    inertia: nalgebra::Matrix3<f64>,
}

impl Signals {
    fn new(
        record: &FlightRecord,
        structure: &ModelStructure,
        plans: &[Plan],
        data: &Reconstruction,
    ) -> Result<Signals> {
        let aircraft = &structure.aircraft;
        let count = data.times.len();
        let mut columns: Vec<Vec<f64>> = Vec::new();
        let mut layout = Vec::new();
        // The columns that hold a regressor's q̄S·x.
        let mut shared: Vec<usize> = Vec::new();
        for plan in plans {
            let length = match plan.coefficient {
                Coefficient::Roll | Coefficient::Yaw => aircraft.geometry.span,
                Coefficient::Pitch => aircraft.geometry.chord,
                _ => 1.0,
            };
            let scale: Vec<f64> = data
                .dynamic_pressure
                .iter()
                .map(|q| q * aircraft.wing_area)
                .collect();
            let free = plan.columns(structure);
            let values = structure.aircraft.aero.parameters.values();
            let (x, z) = regression_problem(plan, structure, data, &free, values);
            let z_column = columns.len();
            columns.push((0..count).map(|k| z[k] * scale[k] * length).collect());
            let mut regressors = Vec::with_capacity(free.len());
            for j in 0..free.len() {
                let series: Vec<f64> = (0..count).map(|k| x[(k, j)] * scale[k]).collect();
                let column = match shared.iter().find(|&&c| columns[c] == series) {
                    Some(&c) => c,
                    None => {
                        shared.push(columns.len());
                        columns.push(series);
                        columns.len() - 1
                    }
                };
                regressors.push((column, length));
            }
            layout.push((z_column, regressors));
        }
        let rates = if plans.iter().any(|p| !p.coefficient.is_force()) {
            let first = columns.len();
            for name in ["p", "q", "r"] {
                columns.push(record.channel(name)?.values_at(&data.times)?);
            }
            Some(first)
        } else {
            None
        };
        let matrix = DMatrix::from_fn(count, columns.len(), |k, i| columns[i][k]);
        Ok(Signals {
            matrix,
            layout,
            rates,
            coefficients: plans.iter().map(|p| p.coefficient).collect(),
            inertia: aircraft.mass.inertia,
        })
    }
}

/// The uniform grid of the common time base: (start, step); an error
/// naming the first gap.
fn uniform_grid(data: &Reconstruction, record: &FlightRecord) -> Result<(f64, f64)> {
    let times = &data.times;
    if times.len() < 3 {
        return Err(Error::Data {
            reason: format!(
                "{METHOD}: {} usable instants in the record ({}); a finite Fourier transform needs at least 3",
                times.len(),
                regression::record_name(record)
            ),
        });
    }
    let step = 1.0 / data.rate;
    for (k, pair) in times.windows(2).enumerate() {
        if ((pair[1] - pair[0]) - step).abs() > 1e-6 * step.max(1.0) {
            return Err(Error::Numerical {
                reason: format!(
                    "{METHOD}: the instants of channel '{}' are not uniformly spaced: {:.4} s to {:.4} s after instant {k} (a dropout, or a value not finite); the finite Fourier transform needs uniform samples — use a window without it",
                    data.reference_channel, pair[0], pair[1]
                ),
            });
        }
    }
    Ok((times[0], step))
}

/// Estimates the free parameters of `structure` from `record` by
/// Fourier-transform regression. Errors: a channel the structure needs is
/// missing, the structure is not linear in its parameters, the samples are
/// not uniformly spaced.
pub fn frequency_regression(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &FrequencyRegressionOptions,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let plans = regression::plans(structure, METHOD)?;
    let request = regression::request(&plans);
    check_channels(record, &structure.aircraft, &request, METHOD)?;
    let data = reconstruct(
        record,
        &structure.aircraft,
        &request,
        &ReconstructionOptions {
            omit_angular_accelerations: true,
            ..Default::default()
        },
        METHOD,
    )?;
    let (start, step) = uniform_grid(&data, record)?;
    let signals = Signals::new(record, structure, &plans, &data)?;
    let count = data.times.len();
    let controls: Vec<(&str, Vec<f64>)> = model_controls(structure)
        .into_iter()
        .map(|r| (r.key(), data.regressor(r)))
        .collect();
    let constant_free = plans.iter().any(|p| {
        p.terms
            .iter()
            .any(|&(r, i)| r.single() == Some(Regressor::Constant) && structure.free[i])
    });
    let zero = options.zero_frequency.unwrap_or(constant_free);
    let (omegas, band_note) =
        options
            .band
            .frequencies(METHOD, &controls, (start, step, count), zero)?;
    let grid = Grid {
        start,
        step,
        breaks: breaks_at(start, step, count, &control_steps(record)),
    };
    let transformed = if options.recursive {
        transform_recursively(&signals, &omegas, &grid)?
    } else {
        transform_batch(&signals, &omegas, &grid)?
    };
    let results: Vec<CoefficientResult> = plans
        .iter()
        .zip(&transformed.plans)
        .map(|(plan, data)| fit_plan(plan, structure, data, &transformed.frequencies))
        .collect();
    let mut estimate = assemble(record, structure, METHOD, &results);
    estimate.notes.extend(data.notes.iter().cloned());
    estimate.notes.push(transforms_note(
        transformed.samples,
        grid.breaks.len(),
        &band_note,
    ));
    if options.recursive {
        estimate
            .notes
            .push("recursive form: transforms built sample by sample (Morelli 2000)".to_string());
    }
    estimate.notes.push(format!(
        "standard errors: [Re(X̃*X̃)]⁻¹·Re(X̃*·V·X̃)·[Re(X̃*X̃)]⁻¹ with V the residual power averaged over ±{VARIANCE_HALF_WIDTH} neighbouring frequencies (the equation error's spectrum is not flat)"
    ));
    estimate
        .notes
        .extend(white_bound_notes(structure, &results));
    estimate
        .notes
        .extend(outside_bounds_notes(structure, &results));
    if estimate.status == Status::Converged && estimate.parameters.is_empty() {
        estimate.status = Status::Degenerate("no parameter was estimated".into());
    }
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate)
}

/// Adds (I·ω̇)_row of each moment plan to its z̃ from the rates' transforms.
fn add_angular_accelerations(
    plans: &mut [Regression],
    signals: &Signals,
    rate_derivatives: &[Vec<Complex<f64>>],
) {
    let inertia = &signals.inertia;
    for ((z, _), coefficient) in plans.iter_mut().zip(&signals.coefficients) {
        let row = match coefficient {
            Coefficient::Roll => 0,
            Coefficient::Pitch => 1,
            Coefficient::Yaw => 2,
            _ => continue,
        };
        for (j, derivative) in rate_derivatives.iter().enumerate() {
            let moment = inertia[(row, j)];
            if moment != 0.0 {
                for (value, d) in z.iter_mut().zip(derivative) {
                    *value += d * moment;
                }
            }
        }
    }
}

/// The plans' transformed data from all columns' transforms.
fn split(signals: &Signals, columns: &[Vec<Complex<f64>>]) -> Vec<Regression> {
    signals
        .layout
        .iter()
        .map(|(z, regressors)| {
            (
                columns[*z].clone(),
                regressors
                    .iter()
                    .map(|&(c, factor)| columns[c].iter().map(|v| v * factor).collect())
                    .collect(),
            )
        })
        .collect()
}

/// The common time base as the transforms take it.
struct Grid {
    start: f64,
    step: f64,
    /// Samples where the signals may jump (the control steps).
    breaks: Vec<usize>,
}

fn transform_batch(signals: &Signals, omegas: &[f64], grid: &Grid) -> Result<Transformed> {
    let transform = FourierTransform::with_breaks(
        omegas,
        grid.start,
        grid.step,
        signals.matrix.nrows(),
        &grid.breaks,
    )?;
    let columns = transform.transform_columns(&signals.matrix)?;
    let mut plans = split(signals, &columns);
    if let Some(first) = signals.rates {
        let derivatives: Vec<Vec<Complex<f64>>> = (first..first + 3)
            .map(|i| {
                let series: Vec<f64> = signals.matrix.column(i).iter().copied().collect();
                transform.derivative(&columns[i], &series)
            })
            .collect();
        add_angular_accelerations(&mut plans, signals, &derivatives);
    }
    Ok(Transformed {
        frequencies: omegas.to_vec(),
        plans,
        samples: transform.samples,
    })
}

fn transform_recursively(signals: &Signals, omegas: &[f64], grid: &Grid) -> Result<Transformed> {
    let matrix = &signals.matrix;
    let mut running = RunningTransform::new(omegas, grid.start, grid.step, matrix.ncols())?;
    let mut row = vec![0.0; matrix.ncols()];
    for k in 0..matrix.nrows() {
        for (i, value) in row.iter_mut().enumerate() {
            *value = matrix[(k, i)];
        }
        running.push(&row, grid.breaks.binary_search(&k).is_ok())?;
    }
    let columns: Vec<Vec<Complex<f64>>> = (0..matrix.ncols())
        .map(|i| running.transform(i))
        .collect::<aeroid_numerics::Result<_>>()?;
    let mut plans = split(signals, &columns);
    if let Some(first) = signals.rates {
        let derivatives: Vec<Vec<Complex<f64>>> = (first..first + 3)
            .map(|i| running.derivative(i))
            .collect::<aeroid_numerics::Result<_>>()?;
        add_angular_accelerations(&mut plans, signals, &derivatives);
    }
    Ok(Transformed {
        frequencies: omegas.to_vec(),
        plans,
        samples: running.received(),
    })
}

/// The complex least squares of one coefficient, as real least squares on
/// the stacked real and imaginary parts (ω = 0 gives a real row only).
fn fit_plan(
    plan: &Plan,
    structure: &ModelStructure,
    (z, x): &Regression,
    omegas: &[f64],
) -> CoefficientResult {
    let name = plan.coefficient.name(structure.aircraft.aero.force_axes);
    let columns = plan.columns(structure);
    let mut rows: Vec<(usize, bool)> = Vec::new();
    for (m, &omega) in omegas.iter().enumerate() {
        rows.push((m, false));
        if omega > 0.0 {
            rows.push((m, true));
        }
    }
    if rows.len() <= columns.len() {
        let reason = format!(
            "{name}: {} real equations in the band for {} parameters; widen the band or refine the resolution",
            rows.len(),
            columns.len()
        );
        return failed_coefficient(name, &columns, reason);
    }
    let part = |c: Complex<f64>, imaginary: bool| if imaginary { c.im } else { c.re };
    let xs = DMatrix::from_fn(rows.len(), columns.len(), |r, j| {
        let (m, imaginary) = rows[r];
        part(x[j][m], imaginary)
    });
    let zs = DVector::from_fn(rows.len(), |r, _| {
        let (m, imaginary) = rows[r];
        part(z[m], imaginary)
    });
    // The equation error's power varies across the band (the rates'
    // noise enters the moments as jω·ñ): each frequency's variance is the
    // residual power averaged over the neighbouring frequencies.
    let variances =
        |residuals: &DVector<f64>| local_variances(&rows, residuals, omegas.len(), columns.len());
    fit_regression(
        plan,
        structure,
        &columns,
        (&xs, &zs),
        zs.as_slice(),
        Bound::RowVariances(&variances),
    )
}

/// The note on the transforms: the samples, the control steps
/// integrated across (`breaks`) and the band.
fn transforms_note(samples: usize, breaks: usize, band_note: &str) -> String {
    format!(
        "finite Fourier transforms by Filon–Simpson quadrature over {samples} samples{}: {band_note}",
        match breaks {
            0 => String::new(),
            n => format!(", integrated piecewise across {n} control steps"),
        }
    )
}

/// Frequencies on each side whose residual power is averaged into one
/// frequency's variance.
const VARIANCE_HALF_WIDTH: usize = 8;

/// Each stacked row's residual variance: the power |ṽ_m|² averaged over
/// the frequencies within [`VARIANCE_HALF_WIDTH`] of its own, scaled by
/// (equations)/(equations − parameters) for the fitted degrees of freedom;
/// half of it for a real or imaginary part (circular residuals), all of
/// it for the one real row of ω = 0.
fn local_variances(
    rows: &[(usize, bool)],
    residuals: &DVector<f64>,
    frequencies: usize,
    parameters: usize,
) -> Vec<f64> {
    let mut power = vec![0.0; frequencies];
    let mut parts = vec![0usize; frequencies];
    for (&(m, _), r) in rows.iter().zip(residuals.iter()) {
        power[m] += r * r;
        parts[m] += 1;
    }
    let dof = rows.len() as f64 / (rows.len() as f64 - parameters as f64).max(1.0);
    let local: Vec<f64> = (0..frequencies)
        .map(|m| {
            let (low, high) = (
                m.saturating_sub(VARIANCE_HALF_WIDTH),
                (m + VARIANCE_HALF_WIDTH).min(frequencies - 1),
            );
            // Per real equation, then per complex value (two parts).
            let (sum, count): (f64, usize) = (low..=high)
                .map(|f| (power[f], parts[f]))
                .fold((0.0, 0), |(s, c), (p, n)| (s + p, c + n));
            dof * sum / count.max(1) as f64
        })
        .collect();
    rows.iter()
        .map(|&(m, _)| {
            if parts[m] == 1 {
                2.0 * local[m]
            } else {
                local[m]
            }
        })
        .collect()
}
