//! Flight path reconstruction / data compatibility check (reflex-wing UAV paper, §5,
//! Eqs. 31–32; the kinematic model of Jategaonkar, "Flight Vehicle System
//! Identification", ch. 10, and Mulder et al.): the measured accelerations
//! and angular rates drive the rigid-body kinematics, and the systematic
//! errors of the sensors are estimated by output error so that the
//! integrated flight path matches the measured air data and attitude:
//!
//! `u̇ = (a_x,m − Δa_x) − q·w + r·v − g·sin θ`
//! `v̇ = (a_y,m − Δa_y) − r·u + p·w + g·cos θ·sin φ`
//! `ẇ = (a_z,m − Δa_z) − p·v + q·u + g·cos θ·cos φ`
//! with p, q, r = measured − (Δp, Δq, Δr), and φ̇, θ̇, ψ̇ from the Euler
//! kinematics. Outputs: `V = |(u, v, w)|`, `α_m = K_α·atan(w/u) + Δα`,
//! `β_m = K_β·asin(v/V) + Δβ`, φ, θ, ψ. Unknowns: Θ = [Δa_x Δa_y Δa_z Δp Δq
//! Δr K_α Δα K_β Δβ] (Eqs. 31 and 32 together; the α or β pair is left out
//! when the record has no such channel) and the initial u, v, w, φ, θ, ψ.
//! Still air is assumed (the check is flown in calm air), the accelerometer
//! at the centre of gravity, and a_z = −g0·nz (nz positive up). The fit is
//! output error with R re-estimated each iteration on the shared core, and
//! the result includes a corrected record: nx, ny, nz, p, q, r, α and β with
//! the estimated errors removed. A calibration whose estimate correlates
//! beyond 0.95 with another unknown's is diagnosed
//! ([`DiagnosisKind::Inseparable`]): the manoeuvre does not separate them
//! (a vane's scale factor from its offset without an excursion of the
//! angle), and each bound is then at least 3.2 times what it would be with
//! the other known.

use crate::diagnosis::{Diagnosis, DiagnosisKind};
use crate::error::{Error, Result};
use crate::estimate::{Estimate, OutputFit};
use crate::estimator::Refusal;
use crate::methods::output_error::{diagonal_weights, interpolate};
use aeroid_core::units::STANDARD_GRAVITY;
use aeroid_numerics::gauss_newton::{self, LeastSquaresObjective, Options};
use aeroid_record::{Channel, FlightRecord};
use aeroid_sim::integrator::rk4_step;
use aeroid_sim::state;
use nalgebra::{DVector, SVector, Vector3};

type Kinematic = SVector<f64, 6>;

/// Names of the error parameters (Eqs. 31–32), in unknown order.
const ERRORS: [&str; 10] = [
    "delta_ax",
    "delta_ay",
    "delta_az",
    "delta_p",
    "delta_q",
    "delta_r",
    "K_alpha",
    "delta_alpha",
    "K_beta",
    "delta_beta",
];
const INITIAL: [&str; 6] = ["x0.u", "x0.v", "x0.w", "x0.roll", "x0.pitch", "x0.yaw"];
const INPUTS: [&str; 6] = ["nx", "ny", "nz", "p", "q", "r"];
const OUTPUTS: [&str; 6] = ["airspeed", "alpha", "beta", "roll", "pitch", "yaw"];

/// The estimate of the sensor errors and the record with them removed.
#[derive(Debug, Clone)]
pub struct Compatibility {
    pub estimate: Estimate,
    pub corrected: FlightRecord,
}

struct PathObjective {
    start: f64,
    step: f64,
    /// Measured accelerations (m/s²) and rates on the grid.
    inputs: Vec<Kinematic>,
    /// Which of the ten error parameters are unknown.
    unknown_errors: Vec<usize>,
    outputs: Vec<usize>,
    measured: Vec<(Vec<f64>, Vec<f64>)>,
    weights: Vec<f64>,
}

/// Runs the compatibility check on a record with load factors, rates, airspeed and attitude.
pub fn flight_path_reconstruction(
    record: &FlightRecord,
    max_iterations: usize,
) -> Result<Compatibility> {
    let started = std::time::Instant::now();
    let mut problem = PathObjective::new(record)?;
    let start = problem.start_values(record)?;
    let data = problem.residuals(&start).map_or(0, |r| r.len());
    if data < start.len() {
        return Err(Error::Refused(Refusal::TooFewData {
            method: "flight path reconstruction".into(),
            data,
            unknowns: start.len(),
        }));
    }
    let mut options = Options::new(start.len());
    options.max_iterations = max_iterations;
    let solution = gauss_newton::solve(&mut problem, &start, &options);
    let errors = problem.full_errors(&solution.theta);
    let label = (
        "fpr",
        "kinematic compatibility".to_string(),
        record.scenario.clone(),
    );
    let mut estimate = Estimate {
        fits: problem.fits(&solution.theta),
        wall_time: started.elapsed().as_secs_f64(),
        notes: vec!["still air, accelerometer at the centre of gravity, R diagonal".into()],
        ..Estimate::from_solution(label, &problem.names(), &start, &solution)
    }
    .assess();
    if let Some(diagnosis) = inseparable_calibrations(&estimate) {
        estimate.diagnose(diagnosis);
    }
    Ok(Compatibility {
        corrected: corrected_record(record, &errors),
        estimate,
    })
}

/// The |correlation| beyond which two estimates are not separated by the
/// data: each one's bound is then at least 1/√(1 − 0.95²) ≈ 3.2 times
/// what it would be with the other known.
pub const INSEPARABLE: f64 = 0.95;

/// The calibrations (sensor errors) whose estimate correlates beyond
/// [`INSEPARABLE`] with another unknown's, each named with that one.
fn inseparable_calibrations(estimate: &Estimate) -> Option<Diagnosis> {
    let (about, measures): (Vec<String>, Vec<f64>) = (estimate.parameters.iter().enumerate())
        .filter(|(_, p)| ERRORS.contains(&p.name.as_str()))
        .filter_map(|(i, p)| {
            let (other, correlation) = estimate.strongest_correlation(i)?;
            (correlation > INSEPARABLE).then(|| (format!("{} (with {other})", p.name), correlation))
        })
        .unzip();
    (!about.is_empty()).then(|| Diagnosis {
        kind: DiagnosisKind::Inseparable,
        about,
        measures,
        advice: "the manoeuvre does not separate these calibrations from another unknown: a \
                 vane's scale factor needs an excursion of its angle, a bias a change of what \
                 it drives; fly a manoeuvre that excites them, or hold one of the pair"
            .into(),
    })
}

impl PathObjective {
    fn new(record: &FlightRecord) -> Result<PathObjective> {
        let reference = record.channel("nx")?;
        let outputs: Vec<usize> = (0..OUTPUTS.len())
            .filter(|&o| record.channel(OUTPUTS[o]).is_ok())
            .collect();
        for required in [0, 3, 4] {
            if !outputs.contains(&required) {
                return Err(Error::Data {
                    reason: format!(
                        "flight path reconstruction needs the '{}' channel",
                        OUTPUTS[required]
                    ),
                });
            }
        }
        let (start, end) = (
            reference.times[0],
            *reference.times.last().unwrap_or(&reference.times[0]),
        );
        let step = 1.0 / reference.rate;
        let count = ((end - start) / step + 1e-9).floor() as usize + 1;
        let times: Vec<f64> = (0..count).map(|k| start + k as f64 * step).collect();
        let mut inputs = vec![Kinematic::zeros(); count];
        for (i, name) in INPUTS.iter().enumerate() {
            let scale = match i {
                0 | 1 => STANDARD_GRAVITY,
                2 => -STANDARD_GRAVITY,
                _ => 1.0,
            };
            for (input, value) in inputs
                .iter_mut()
                .zip(record.channel(name)?.values_at(&times)?)
            {
                input[i] = scale * value;
            }
        }
        let unknown_errors = (0..ERRORS.len())
            .filter(|&e| match e {
                6 | 7 => outputs.contains(&1),
                8 | 9 => outputs.contains(&2),
                _ => true,
            })
            .collect();
        let measured = outputs
            .iter()
            .map(|&o| {
                let channel = record.channel(OUTPUTS[o])?;
                Ok(channel
                    .times
                    .iter()
                    .zip(&channel.values)
                    .filter(|(t, v)| **t >= start && **t <= times[count - 1] && v.is_finite())
                    .map(|(t, v)| (*t, *v))
                    .unzip())
            })
            .collect::<Result<Vec<_>>>()?;
        let weights = vec![1.0; outputs.len()];
        Ok(PathObjective {
            start,
            step,
            inputs,
            unknown_errors,
            outputs,
            measured,
            weights,
        })
    }

    fn names(&self) -> Vec<String> {
        self.unknown_errors
            .iter()
            .map(|&e| ERRORS[e].to_string())
            .chain(INITIAL.iter().map(|s| s.to_string()))
            .collect()
    }

    /// Zero biases, unit scale factors, initial state from the first measured samples.
    fn start_values(&self, record: &FlightRecord) -> Result<DVector<f64>> {
        let at = |name: &str| {
            record
                .channel(name)
                .ok()
                .and_then(|c| c.value_at(self.start))
                .unwrap_or(0.0)
        };
        let (airspeed, alpha, beta) = (at("airspeed"), at("alpha"), at("beta"));
        let velocity = Vector3::new(
            alpha.cos() * beta.cos(),
            beta.sin(),
            alpha.sin() * beta.cos(),
        ) * airspeed;
        let errors = self
            .unknown_errors
            .iter()
            .map(|&e| if e == 6 || e == 8 { 1.0 } else { 0.0 });
        let initial = [
            velocity.x,
            velocity.y,
            velocity.z,
            at("roll"),
            at("pitch"),
            at("yaw"),
        ];
        Ok(DVector::from_iterator(
            self.unknown_errors.len() + 6,
            errors.chain(initial),
        ))
    }

    /// All ten error parameters (unknown ones from θ, the others at 0 or 1).
    fn full_errors(&self, theta: &DVector<f64>) -> [f64; 10] {
        let mut errors = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0];
        for (j, &e) in self.unknown_errors.iter().enumerate() {
            errors[e] = theta[j];
        }
        errors
    }

    /// Predicted outputs (in measured form) on the grid: [output][k].
    fn simulate(&self, theta: &DVector<f64>) -> crate::Result<Vec<Vec<f64>>> {
        let errors = self.full_errors(theta);
        let corrections = Kinematic::from_column_slice(&errors[..6]);
        let n = self.unknown_errors.len();
        let mut x = Kinematic::from_iterator(theta.iter().skip(n).copied());
        let mut grid = vec![Vec::with_capacity(self.inputs.len()); self.outputs.len()];
        for k in 0..self.inputs.len() {
            if !x.iter().all(|v| v.is_finite()) || x[0] <= 0.0 {
                return Err(Error::PathDiverged {
                    time: self.start + k as f64 * self.step,
                });
            }
            for (values, &o) in grid.iter_mut().zip(&self.outputs) {
                values.push(output(o, &x, &errors));
            }
            if k + 1 < self.inputs.len() {
                let (here, next) = (
                    self.inputs[k] - corrections,
                    self.inputs[k + 1] - corrections,
                );
                x = rk4_step(&x, self.step, |x, theta| {
                    kinematics(x, &(here + (next - here) * theta))
                });
            }
        }
        Ok(grid)
    }

    fn errors(&self, theta: &DVector<f64>) -> crate::Result<Vec<Vec<f64>>> {
        let grid = self.simulate(theta)?;
        Ok(self
            .measured
            .iter()
            .zip(&grid)
            .zip(&self.outputs)
            .map(|(((times, values), grid), &o)| {
                times
                    .iter()
                    .zip(values)
                    .map(|(&t, &z)| residual(o, z, interpolate(grid, self.start, self.step, t)))
                    .collect()
            })
            .collect())
    }

    fn fits(&self, theta: &DVector<f64>) -> Vec<OutputFit> {
        let Ok(errors) = self.errors(theta) else {
            return Vec::new();
        };
        self.outputs
            .iter()
            .zip(&self.measured)
            .zip(&errors)
            .map(|((&o, (_, values)), error)| {
                let predicted: Vec<f64> = values.iter().zip(error).map(|(z, e)| z - e).collect();
                OutputFit::new(OUTPUTS[o], values, &predicted)
            })
            .collect()
    }
}

/// Rigid-body kinematics driven by corrected accelerations and rates.
fn kinematics(x: &Kinematic, input: &Kinematic) -> Kinematic {
    let (u, v, w, roll, pitch) = (x[0], x[1], x[2], x[3], x[4]);
    let (p, q, r) = (input[3], input[4], input[5]);
    let g = STANDARD_GRAVITY;
    let euler = state::euler_rates(roll, pitch, &Vector3::new(p, q, r));
    Kinematic::new(
        input[0] - q * w + r * v - g * pitch.sin(),
        input[1] - r * u + p * w + g * pitch.cos() * roll.sin(),
        input[2] - p * v + q * u + g * pitch.cos() * roll.cos(),
        euler.x,
        euler.y,
        euler.z,
    )
}

/// Output `o` as the sensor reads it.
fn output(o: usize, x: &Kinematic, errors: &[f64; 10]) -> f64 {
    let speed = x.fixed_rows::<3>(0).norm();
    match o {
        0 => speed,
        1 => errors[6] * x[2].atan2(x[0]) + errors[7],
        2 => errors[8] * (x[1] / speed).asin() + errors[9],
        _ => x[o],
    }
}

/// Measured − predicted; heading differences wrapped to ±π (recorders wrap heading).
fn residual(o: usize, measured: f64, predicted: f64) -> f64 {
    let difference = measured - predicted;
    if o == 5 {
        (difference + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    } else {
        difference
    }
}

/// The record with the estimated sensor errors removed from nx, ny, nz, p,
/// q, r, α and β: each corrected value is (measured − offset)/scale.
fn corrected_record(record: &FlightRecord, errors: &[f64; 10]) -> FlightRecord {
    let g = STANDARD_GRAVITY;
    let mut corrected = record.clone();
    for channel in &mut corrected.channels {
        let (offset, scale) = match channel.name.as_str() {
            "nx" => (errors[0] / g, 1.0),
            "ny" => (errors[1] / g, 1.0),
            "nz" => (-errors[2] / g, 1.0),
            "p" => (errors[3], 1.0),
            "q" => (errors[4], 1.0),
            "r" => (errors[5], 1.0),
            "alpha" => (errors[7], errors[6]),
            "beta" => (errors[9], errors[8]),
            _ => continue,
        };
        correct(channel, offset, scale);
    }
    corrected.profile = format!(
        "{} (corrected by flight path reconstruction)",
        record.profile
    );
    corrected
}

fn correct(channel: &mut Channel, offset: f64, scale: f64) {
    channel
        .values
        .iter_mut()
        .for_each(|v| *v = (*v - offset) / scale);
    channel.source = format!(
        "{}; corrected by flight path reconstruction",
        channel.source
    );
}

impl LeastSquaresObjective for PathObjective {
    type Error = crate::Error;

    fn residuals(&mut self, theta: &DVector<f64>) -> crate::Result<DVector<f64>> {
        let errors = self.errors(theta)?;
        let total = errors.iter().map(Vec::len).sum();
        Ok(DVector::from_iterator(
            total,
            errors
                .iter()
                .zip(&self.weights)
                .flat_map(|(e, w)| e.iter().map(move |v| v * w)),
        ))
    }

    fn reweight(&mut self, theta: &DVector<f64>) -> crate::Result<bool> {
        let errors = self.errors(theta)?;
        let measured: Vec<Vec<f64>> = self
            .measured
            .iter()
            .map(|(_, values)| values.clone())
            .collect();
        self.weights = diagonal_weights(&errors, &measured);
        Ok(true)
    }
}
