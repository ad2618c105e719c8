//! Several starts (`starts = N`): the fits from spread start values and the choice among them.

use super::*;

/// Two converged fits whose costs ½·Σ N_o·ln R_oo differ by less than
/// this reach minima the data cannot tell apart (a likelihood ratio
/// below e).
pub const EQUAL_COST: f64 = 1.0;

/// A distance in standard errors, three decimals or three digits.
pub(super) fn sigmas(distance: f64) -> String {
    if distance < 1e4 {
        format!("{distance:.3}")
    } else {
        format!("{distance:.2e}")
    }
}

/// `options.starts` fits of output error (module header, "Several
/// starts"). A refusal or an error of the first fit is returned as it is;
/// an extra start that fails is a line in the notes.
pub fn multi_start(
    records: &[&FlightRecord],
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    regression: Option<&Estimate>,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let single = OutputErrorOptions {
        starts: 1,
        ..options.clone()
    };
    let mut fits = vec![(
        "the usual start".to_string(),
        Ok(output_error_from(records, structure, &single, regression)?),
    )];
    let mut rng = aeroid_core::random::stream(
        options.start_seed,
        aeroid_core::random::streams::MULTI_START,
    );
    let from_model = OutputErrorOptions {
        start: Start::Model,
        ..single
    };
    for k in 1..options.starts {
        let moved = moved_start(structure, options, &mut rng);
        fits.push((
            format!("start {k}"),
            output_error_from(records, &moved, &from_model, None),
        ));
    }
    let best = fits
        .iter()
        .enumerate()
        .filter_map(|(i, (_, fit))| match fit {
            Ok(estimate) if estimate.status.is_success() && cost(estimate).is_finite() => {
                Some((i, cost(estimate)))
            }
            _ => None,
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    let comparison = compare(&fits, best);
    let converged = fits
        .iter()
        .filter(|(_, f)| f.as_ref().is_ok_and(|e| e.status.is_success()))
        .count();
    let (_, chosen) = fits.swap_remove(best.unwrap_or(0));
    let mut estimate = chosen?;
    estimate.notes.push(comparison.note(options, converged));
    if !comparison.apart.is_empty() && estimate.status.is_success() {
        estimate.status = Status::Unidentified(comparison.apart);
    }
    estimate.details = format!("{}\n{}", estimate.details, comparison.details);
    estimate.wall_time = started.elapsed().as_secs_f64();
    Ok(estimate)
}

/// The structure with each free parameter moved by up to
/// `start_spread`·max(|value|, 0.01) at random (one uniform draw per
/// parameter, free or not), within its bounds.
fn moved_start(
    structure: &ModelStructure,
    options: &OutputErrorOptions,
    rng: &mut ChaCha8Rng,
) -> ModelStructure {
    let mut moved = structure.clone();
    let values = moved.aircraft.aero.parameters.values_mut();
    for (i, value) in values.iter_mut().enumerate() {
        let u: f64 = rand::RngExt::random_range(rng, -1.0..=1.0);
        if structure.free[i] {
            let (low, high) = structure.bounds[i];
            *value = (*value + options.start_spread * value.abs().max(0.01) * u).clamp(low, high);
        }
    }
    moved
}

/// The maximum-likelihood cost with R estimated, ½·Σ N_o·ln R_oo, R_oo
/// the output's mean squared residual (the fits' rms²).
fn cost(estimate: &Estimate) -> f64 {
    if estimate.fits.is_empty() {
        return f64::NAN;
    }
    estimate
        .fits
        .iter()
        .map(|fit| fit.samples as f64 * fit.rms.ln())
        .sum::<f64>()
}

/// The starts' fits side by side: a line and a table row per fit, the
/// parameters where a minimum of equal cost lies more than 1σ from the
/// least-cost fit, and the converged fits within 1σ of it and at a worse
/// cost.
struct Comparison {
    lines: Vec<String>,
    details: String,
    apart: Vec<String>,
    agreeing: usize,
    worse: usize,
}

impl Comparison {
    /// The note on the starts: how many converged (of `options.starts`),
    /// whether they agree, and a line per fit.
    fn note(&self, options: &OutputErrorOptions, converged: usize) -> String {
        format!(
            "{} starts (spread {}, seed {}): {converged} converged; {}; {}",
            options.starts,
            options.start_spread,
            options.start_seed,
            if self.apart.is_empty() {
                match (self.agreeing == converged, self.worse) {
                    (true, _) => "the converged starts agree: each within 1σ of the least-cost fit"
                        .to_string(),
                    (false, worse) => format!(
                        "the converged starts disagree: {} within 1σ of the least-cost fit, {worse} in a worse minimum",
                        self.agreeing
                    ),
                }
            } else {
                format!(
                    "another converged minimum of equal cost (within {EQUAL_COST}) differs by more than 1σ in {}",
                    self.apart.join(", ")
                )
            },
            self.lines.join("; ")
        )
    }
}

/// Compares each of `fits` with the least-cost one (`best`).
fn compare(fits: &[(String, Result<Estimate>)], best: Option<usize>) -> Comparison {
    let mut lines = Vec::new();
    let mut details =
        String::from("start            status                   ½·Σ N·ln R     max |Δθ|/σ\n");
    let mut apart: Vec<String> = Vec::new();
    // Converged fits within 1σ of the least-cost fit, and at a worse cost.
    let (mut agreeing, mut worse) = (0, 0);
    for (i, (label, fit)) in fits.iter().enumerate() {
        let estimate = match fit {
            Ok(estimate) => estimate,
            Err(error) => {
                details += &format!("{label:<16} failed: {error}\n");
                lines.push(format!("{label}: failed: {error}"));
                continue;
            }
        };
        let distance = best.and_then(|b| {
            let Ok(best) = &fits[b].1 else { return None };
            Some(
                estimate
                    .parameters
                    .iter()
                    .zip(&best.parameters)
                    .map(|(p, q)| (p.value - q.value).abs() / q.standard_error)
                    .fold(0.0, f64::max),
            )
        });
        details += &format!(
            "{label:<16} {:<24} {:<14.7e} {}\n",
            estimate
                .status
                .to_string()
                .chars()
                .take(24)
                .collect::<String>(),
            cost(estimate),
            distance.map_or("-".into(), sigmas)
        );
        lines.push(format!(
            "{label}: {} at cost {:.7e}{}",
            estimate.status,
            cost(estimate),
            distance.map_or(String::new(), |d| format!(
                ", parameters within {}σ of the least-cost fit",
                sigmas(d)
            ))
        ));
        if estimate.status.is_success() {
            if distance.is_some_and(|d| d <= 1.0) {
                agreeing += 1;
            } else if best.is_some_and(|b| match &fits[b].1 {
                Ok(best_fit) => cost(estimate) > cost(best_fit) + EQUAL_COST,
                Err(_) => false,
            }) {
                worse += 1;
            }
        }
        if let Some(b) = best.filter(|&b| b != i)
            && let Ok(best_fit) = &fits[b].1
            && estimate.status.is_success()
            && (cost(estimate) - cost(best_fit)).abs() < EQUAL_COST
        {
            for (p, q) in estimate.parameters.iter().zip(&best_fit.parameters) {
                if (p.value - q.value).abs() > q.standard_error && !apart.contains(&q.name) {
                    apart.push(q.name.clone());
                }
            }
        }
    }
    Comparison {
        lines,
        details,
        apart,
        agreeing,
        worse,
    }
}
