//! Accuracy gates (`golden/gates.toml`, `aeroid gate`): each case flies a
//! scenario, records it with a profile, runs one estimator on one model and
//! checks every estimated parameter against the truth. Noise-free cases gate
//! the relative error (|estimate − truth| ≤ tol·|truth|, or an absolute
//! floor for near-zero truths); noisy cases of estimators with valid
//! Cramér–Rao bounds gate the error in σ units (|estimate − truth| ≤ k·σ).
//! A case may set an identifiability threshold on σ/|truth| (the QAR case):
//! parameters above it are listed as not identifiable instead of gated. A
//! case may also require the estimator to refuse the record with a given
//! error (an estimator that cannot run on a record must say so, not crash).
//! A regression of any estimator's accuracy fails the gate with a table of
//! what moved. Tolerances are set from the accuracy measured when a case was
//! added, with the reason in the file.

use crate::error::{Error, Problems, Result, parse_toml, read_text};
use crate::estimation::estimate::Estimate;
use crate::estimation::estimator::{
    MethodTables, Refusal, RefusalKind, check_method_tables, validate_method_tables,
};
use crate::estimation::methods;
use crate::estimation::structure::Structure;
use crate::eval::run::{self, Outcome};
use crate::record::recorder::Profile;
use crate::sim::scenario::Scenario;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The gate file bundled with aeroid, relative to the data folder.
pub use crate::catalog::GATE_FILE;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateFile {
    #[serde(rename = "case")]
    pub cases: Vec<GateCase>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateCase {
    pub name: String,
    pub scenario: String,
    pub profile: String,
    pub model: String,
    pub method: String,
    /// Relative gate: |estimate − truth| ≤ tolerance·|truth| (noise-free data).
    #[serde(default)]
    pub relative_tolerance: Option<f64>,
    /// σ gate: |estimate − truth| ≤ k·σ, σ the estimate's Cramér–Rao bound
    /// (noisy data, for estimators whose bounds are valid).
    #[serde(default)]
    pub sigma_tolerance: Option<f64>,
    /// Absolute tolerance used instead when the relative one is smaller (near-zero truths).
    #[serde(default)]
    pub absolute_floor: f64,
    /// Per-parameter tolerances overriding the default, in its unit (relative or σ).
    #[serde(default)]
    pub tolerance: BTreeMap<String, f64>,
    /// Identifiability threshold on the relative bound σ/|truth|: parameters
    /// at or above it are reported as not identifiable and not gated.
    #[serde(default)]
    pub identifiable_below: Option<f64>,
    /// For terms the estimator adds that the truth model lacks (|truth| < 1e-12, as
    /// stepwise regression may select): |estimate| ≤ k·σ, i.e. the spurious
    /// term must stay statistically indistinguishable from zero. Without it
    /// such terms fall under the absolute floor.
    #[serde(default)]
    pub spurious_sigma: Option<f64>,
    /// The estimator must refuse this record with a refusal of this kind
    /// (`missing-channels`, `not-linear-in-parameters`, `nothing-to-estimate`).
    #[serde(default)]
    pub expect_refusal: Option<RefusalKind>,
    /// With `expect_refusal = "missing-channels"`: channels the refusal must name.
    #[serde(default)]
    pub expect_missing: Vec<String>,
    /// Settings per method for this case, overriding the model's and the scenario's.
    #[serde(default)]
    pub methods: MethodTables,
    /// Run the derive step (`aeroid derive` with its defaults) on the
    /// record before the estimator: for recorders that lack channels the
    /// estimators need (the QAR).
    #[serde(default)]
    pub derive: Option<crate::prep::derive::DeriveTable>,
}

impl GateCase {
    fn tolerance_for(&self, parameter: &str) -> f64 {
        let default = self.sigma_tolerance.or(self.relative_tolerance);
        self.tolerance
            .get(parameter)
            .copied()
            .or(default)
            .unwrap_or(f64::NAN)
    }
}

/// One parameter's check.
#[derive(Debug, Clone, PartialEq)]
pub struct GateRow {
    pub parameter: String,
    pub estimate: f64,
    /// Cramér–Rao standard error of the estimate.
    pub sigma: f64,
    pub truth: f64,
    pub error: f64,
    pub allowed: f64,
    /// Relative bound below the case's identifiability threshold (always true without one).
    pub identifiable: bool,
}

impl GateRow {
    /// A parameter that is not identifiable is reported, not gated; an
    /// identifiable one passes when its error is within a finite allowance.
    pub fn passed(&self) -> bool {
        !self.identifiable || (self.allowed.is_finite() && self.error.abs() <= self.allowed)
    }

    /// σ/|truth|.
    pub fn relative_sigma(&self) -> f64 {
        self.sigma / self.truth.abs()
    }
}

/// The outcome of one case.
#[derive(Debug, Clone)]
pub struct GateResult {
    pub case: GateCase,
    /// The estimator's refusal, when it refused.
    pub refusal: Option<Refusal>,
    pub estimate: Option<Estimate>,
    pub rows: Vec<GateRow>,
}

impl GateResult {
    pub fn passed(&self) -> bool {
        match (self.case.expect_refusal, &self.refusal) {
            (Some(expected), Some(refusal)) => {
                let named = refusal.missing_channels();
                refusal.kind() == expected
                    && self
                        .case
                        .expect_missing
                        .iter()
                        .all(|channel| named.contains(&channel.as_str()))
            }
            (Some(_), None) | (None, Some(_)) => false,
            (None, None) => {
                let converged = self
                    .estimate
                    .as_ref()
                    .is_some_and(|e| e.status.is_success());
                converged && !self.rows.is_empty() && self.rows.iter().all(GateRow::passed)
            }
        }
    }

    /// The largest |error|/allowed over the gated rows.
    pub fn worst(&self) -> f64 {
        self.rows
            .iter()
            .filter(|r| r.identifiable)
            .map(|r| r.error.abs() / r.allowed)
            .fold(0.0, f64::max)
    }

    /// Every row (or only the failed ones) as a readable table.
    pub fn table(&self, only_failures: bool) -> String {
        if let Some(refusal) = &self.refusal {
            return match &self.case.expect_refusal {
                Some(expected) => format!(
                    "refused ({}): {refusal}\n(expected a refusal '{expected}'{})\n",
                    refusal.kind(),
                    if self.case.expect_missing.is_empty() {
                        String::new()
                    } else {
                        format!(" naming {}", self.case.expect_missing.join(", "))
                    }
                ),
                None => format!("refused: {refusal}\n"),
            };
        }
        let mut text = String::new();
        if let Some(estimate) = &self.estimate {
            text += &format!("status: {}\n", estimate.status);
        }
        text += &format!(
            "{:<14} {:>13} {:>10} {:>13} {:>11} {:>9} {:>8} {:>10}  {}\n",
            "parameter",
            "estimate",
            "σ",
            "truth",
            "error",
            "error/|t|",
            "error/σ",
            "allowed",
            "check"
        );
        for row in self.rows.iter().filter(|r| !only_failures || !r.passed()) {
            let check = match (row.identifiable, row.passed()) {
                (false, _) => "not identifiable",
                (true, true) => "ok",
                (true, false) => "FAIL",
            };
            text += &format!(
                "{:<14} {:>13.6} {:>10.3e} {:>13.6} {:>11.3e} {:>9.2e} {:>8.2} {:>10.3e}  {check}\n",
                row.parameter,
                row.estimate,
                row.sigma,
                row.truth,
                row.error,
                row.error.abs() / row.truth.abs(),
                row.error / row.sigma,
                row.allowed,
            );
        }
        text
    }

    /// The failed rows as a table.
    pub fn failures(&self) -> String {
        self.table(true)
    }

    /// The estimates rounded to 4 significant digits with their bounds to 2,
    /// one per line, for snapshots; a refusal as its message.
    pub fn snapshot(&self) -> String {
        let mut text = format!(
            "{} / {} / {} / {}",
            self.case.scenario, self.case.profile, self.case.model, self.case.method,
        );
        if let Some(refusal) = &self.refusal {
            return text + &format!(": refused ({}): {refusal}\n", refusal.kind());
        }
        let Some(estimate) = &self.estimate else {
            return text;
        };
        text += &format!(": {:?}\n", estimate.status);
        for p in &estimate.parameters {
            let identifiable = self
                .rows
                .iter()
                .find(|r| r.parameter == p.name)
                .is_none_or(|r| r.identifiable);
            text += &format!(
                "{} = {} ± {}{}\n",
                p.name,
                crate::record::rounded(p.value),
                crate::record::significant(p.standard_error, 2),
                if identifiable {
                    ""
                } else {
                    "  (not identifiable)"
                }
            );
        }
        text
    }
}

/// Loads and validates a gate file.
pub fn load(path: &Path) -> Result<GateFile> {
    let file: GateFile = parse_toml(path, &read_text(path)?)?;
    let mut problems = Problems::default();
    for (i, case) in file.cases.iter().enumerate() {
        let field = format!("case[{i}] ({})", case.name);
        if let Err(error) = methods::find(&case.method) {
            problems.push(format!("{field}.method"), error.to_string());
        }
        for (key, reference) in [
            ("scenario", &case.scenario),
            ("profile", &case.profile),
            ("model", &case.model),
        ] {
            if !crate::paths::stays_inside(reference) {
                problems.push(
                    format!("{field}.{key}"),
                    format!("'{reference}' is an absolute path or leaves the folder with '..'; name a bundled file"),
                );
            }
        }
        let mut tables = Problems::default();
        check_method_tables(&case.methods, &mut tables);
        for problem in tables.0 {
            problems.push(format!("{field}.{}", problem.field), problem.message);
        }
        let defaults = [case.relative_tolerance, case.sigma_tolerance];
        match (defaults.iter().flatten().count(), &case.expect_refusal) {
            (1, None) | (0, Some(_)) => {}
            _ => problems.push(
                field.clone(),
                "give exactly one of relative_tolerance and sigma_tolerance, or expect_refusal alone",
            ),
        }
        if case.derive.as_ref().is_some_and(|d| !d.profiles.is_empty()) {
            problems.push(
                format!("{field}.derive.profiles"),
                "is for studies: a gate case records with its one profile",
            );
        }
        if !case.expect_missing.is_empty()
            && case.expect_refusal != Some(RefusalKind::MissingChannels)
        {
            problems.push(
                format!("{field}.expect_missing"),
                "goes with expect_refusal = \"missing-channels\"",
            );
        }
        if defaults
            .iter()
            .flatten()
            .chain(case.tolerance.values())
            .chain(case.identifiable_below.iter())
            .chain(case.spurious_sigma.iter())
            .any(|t| !(t.is_finite() && *t > 0.0))
        {
            problems.push(
                field,
                "tolerances and thresholds must be positive finite numbers",
            );
        }
    }
    problems.finish(path, file)
}

/// Runs one case. Errors are for a case that cannot be set up (unknown
/// scenario, profile or model, a departing simulation) or an estimator
/// that failed; an estimator's refusal is the case's `refusal`.
pub fn run_case(case: &GateCase) -> Result<GateResult> {
    let scenario = Scenario::load(&case.scenario)?;
    validate_method_tables(&scenario.methods, &scenario.path)?;
    let profile = Profile::load(&case.profile, None)?;
    let structure = Structure::load(&case.model)?;
    let (record, truth) =
        crate::eval::linear_flight::record_flight(&scenario, &profile, scenario.seed)?;
    let record = match &case.derive {
        Some(derive) => crate::prep::derive::derive(&record, &derive.options())?.record,
        None => record,
    };
    let (estimate, _) = match run::estimate_scored(
        &case.method,
        &record,
        &truth,
        &structure,
        &[&scenario.methods, &case.methods],
        None,
    ) {
        Outcome::Estimated { estimate, scores } => (*estimate, scores),
        Outcome::Refused(refusal) => {
            return Ok(GateResult {
                case: case.clone(),
                refusal: Some(refusal),
                estimate: None,
                rows: Vec::new(),
            });
        }
        Outcome::Failed(message) => {
            return Err(Error::Other(format!("{}: {message}", case.method)));
        }
    };
    let rows = estimate
        .parameters
        .iter()
        .filter_map(|p| {
            let (truth, _) = truth.value_for(&p.name, structure.score_kind())?;
            let tolerance = case.tolerance_for(&p.name);
            let spurious = truth.abs() < 1e-12;
            let allowed = if let (true, Some(k)) = (spurious, case.spurious_sigma) {
                k * p.standard_error
            } else if case.sigma_tolerance.is_some() {
                tolerance * p.standard_error
            } else {
                (tolerance * truth.abs()).max(case.absolute_floor)
            };
            let identifiable = case
                .identifiable_below
                .is_none_or(|limit| p.standard_error < limit * truth.abs());
            Some(GateRow {
                parameter: p.name.clone(),
                estimate: p.value,
                sigma: p.standard_error,
                truth,
                error: p.value - truth,
                allowed,
                identifiable,
            })
        })
        .collect::<Vec<_>>();
    if rows.is_empty() {
        return Err(Error::Other(format!(
            "gate '{}': no estimated parameter has a truth",
            case.name
        )));
    }
    Ok(GateResult {
        case: case.clone(),
        refusal: None,
        estimate: Some(estimate),
        rows,
    })
}
