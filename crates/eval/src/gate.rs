//! Accuracy gates (`golden/gates.toml`, `aeroid gate`): each case flies a
//! scenario, records it with a profile, runs one estimator on one model and
//! checks every estimated term against the truth. A tolerance comes from
//! the truth or from the bound, never from today's error:
//!
//! - noise-free cases gate the relative error, |θ̂ − θ| ≤ tol·|θ| (an
//!   absolute floor for near-zero truths);
//! - noisy cases gate the error in σ units, |θ̂ − θ| ≤ k·σ, σ the
//!   estimate's Cramér–Rao bound, or `sigma_scale`·CRB where a method's
//!   bound is known to be off (the scale measured by a bundled Monte Carlo
//!   study, cited in the file).
//!
//! Whatever the tolerance, a row is `ok` only when its error is below half
//! its truth, so a wrong sign never passes. A parameter whose σ is too
//! large for that (σ ≥ `identifiable_below`·|θ|, by default 0.5/k: k·σ
//! would reach half the truth) is reported "not identifiable", never
//! `ok`. A term the truth lacks (stepwise regression's extra terms) is
//! gated against zero: |θ̂| ≤ `spurious_sigma`·σ (by default k). Initial
//! states and output biases have no truth and are not gated.
//!
//! A case where a method is known to fail declares it: `[case.known]`
//! gives, per parameter, the measured range of its relative error (σ units
//! for a zero truth) and the reason. The gate prints the row as a known
//! failure, fails when the error leaves the range away from the truth
//! (worse), says when it improves, and fails when the row would pass its
//! tolerance (the declaration is to be removed). A per-parameter override
//! carries its reason and fails the gate when the parameter passes the
//! default without it. The estimate's diagnoses must be exactly the case's
//! `diagnoses`. A case may instead require the estimator to refuse the
//! record with a given refusal.

use crate::error::{Error, Result};
use crate::run::{self, Outcome};
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_estimation::estimate::{DiagnosisKind, Estimate};
use aeroid_estimation::estimator::{MethodTables, Refusal, RefusalKind};
use aeroid_estimation::registry::Registry;
use aeroid_estimation::structure::Structure;
use aeroid_record::recorder::Profile;
use aeroid_sim::scenario::Scenario;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The gate file bundled with aeroid, relative to the data folder.
pub use aeroid_core::catalog::GATE_FILE;

/// A gate file as written (`golden/gates.toml`): its `[[case]]` tables,
/// read by [`load`].
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GateFile {
    #[serde(rename = "case", default)]
    pub cases: Vec<GateCase>,
}

/// A tolerance of one parameter in place of the case's default, with why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Override {
    /// In the case's unit (relative, or σ).
    pub value: f64,
    /// Why the default does not fit this parameter: a mechanism and its
    /// measurement, or the study that measured it.
    pub reason: String,
}

/// A failure of the method on this case, declared with its measured range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnownFailure {
    /// The measured range of the error: (θ̂ − θ)/|θ|, or θ̂/σ for a term
    /// whose truth is zero.
    pub error: [f64; 2],
    /// Why the method fails here (the mechanism, the finding).
    pub reason: String,
}

/// One `[[case]]` of a gate file: the scenario, recorder profile, model and
/// method it runs, and the tolerances its estimate is checked against.
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
    /// (times `sigma_scale`).
    #[serde(default)]
    pub sigma_tolerance: Option<f64>,
    /// The σ a σ gate uses, as a multiple of the Cramér–Rao bound: the
    /// Monte Carlo σ_MC/CRB of a method whose bound is known to be off.
    #[serde(default)]
    pub sigma_scale: Option<Override>,
    /// Absolute tolerance used instead when the relative one is smaller (near-zero truths).
    #[serde(default)]
    pub absolute_floor: f64,
    /// Per-parameter tolerances overriding the default, in its unit (relative or σ).
    #[serde(default)]
    pub tolerance: BTreeMap<String, Override>,
    /// Identifiability threshold on the relative bound σ/|truth|:
    /// parameters at or above it are reported as not identifiable and not
    /// gated. Default for σ gates: 0.5/k.
    #[serde(default)]
    pub identifiable_below: Option<f64>,
    /// Terms whose truth is zero or that the truth model lacks:
    /// |estimate| ≤ k·σ (default: `sigma_tolerance`), never below the
    /// absolute floor.
    #[serde(default)]
    pub spurious_sigma: Option<f64>,
    /// Failures of the method on this case, by parameter.
    #[serde(default)]
    pub known: BTreeMap<String, KnownFailure>,
    /// The diagnoses the estimate carries (`coloured_residuals`, …):
    /// exactly these, or the case fails.
    #[serde(default)]
    pub diagnoses: Vec<DiagnosisKind>,
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
    pub derive: Option<aeroid_record::prep::derive::DeriveTable>,
}

/// An error beyond this share of its truth never passes, whatever the
/// tolerance: a wrong sign is an error beyond 100 %.
pub const HALF_THE_TRUTH: f64 = 0.5;

/// A truth below this magnitude is zero: the term is gated against zero.
const ZERO_TRUTH: f64 = 1e-12;

impl GateCase {
    /// The default tolerance, in the case's unit.
    fn default_tolerance(&self) -> f64 {
        self.sigma_tolerance
            .or(self.relative_tolerance)
            .unwrap_or(f64::NAN)
    }

    /// The σ a σ gate counts in: the Cramér–Rao bound times `sigma_scale`.
    fn gate_sigma(&self, crb: f64) -> f64 {
        crb * self.sigma_scale.as_ref().map_or(1.0, |s| s.value)
    }

    /// The allowance of a tolerance `tolerance` for a non-zero truth.
    fn allowance(&self, tolerance: f64, truth: f64, crb: f64) -> f64 {
        if self.sigma_tolerance.is_some() {
            tolerance * self.gate_sigma(crb)
        } else {
            (tolerance * truth.abs()).max(self.absolute_floor)
        }
    }

    /// σ/|truth| at or above which a parameter is not identifiable.
    fn identifiable_below(&self) -> Option<f64> {
        self.identifiable_below
            .or(self.sigma_tolerance.map(|k| HALF_THE_TRUTH / k))
    }
}

/// How a row came out.
#[derive(Debug, Clone, PartialEq)]
pub enum Check {
    /// Within its tolerance and below half its truth.
    Ok,
    /// σ too large against the truth for a check (reported, not gated).
    NotIdentifiable,
    /// A declared failure within its declared range.
    Known,
    /// A declared failure closer to the truth than its range.
    KnownImproved,
    /// Failed, and why.
    Fail(String),
}

impl Check {
    pub fn passed(&self) -> bool {
        !matches!(self, Check::Fail(_))
    }
}

impl std::fmt::Display for Check {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Check::Ok => f.write_str("ok"),
            Check::NotIdentifiable => f.write_str("not identifiable"),
            Check::Known => f.write_str("known failure"),
            Check::KnownImproved => {
                f.write_str("known failure, better than declared: re-measure its range")
            }
            Check::Fail(why) => write!(f, "FAIL: {why}"),
        }
    }
}

/// One parameter's check.
#[derive(Debug, Clone, PartialEq)]
pub struct GateRow {
    pub parameter: String,
    pub estimate: f64,
    /// Cramér–Rao standard error of the estimate.
    pub sigma: f64,
    /// The truth; 0 for a term the truth model lacks.
    pub truth: f64,
    pub error: f64,
    pub allowed: f64,
    pub check: Check,
}

impl GateRow {
    pub fn passed(&self) -> bool {
        self.check.passed()
    }

    /// Whether the row is reported, not gated.
    pub fn identifiable(&self) -> bool {
        self.check != Check::NotIdentifiable
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
    /// What fails the case as a whole: a status other than converged,
    /// diagnoses other than the declared ones, no gated row.
    pub problems: Vec<String>,
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
            (None, None) => self.problems.is_empty() && self.rows.iter().all(GateRow::passed),
        }
    }

    /// The largest |error|/allowed over the rows checked against their
    /// tolerance.
    pub fn worst(&self) -> f64 {
        self.rows
            .iter()
            .filter(|r| r.check == Check::Ok)
            .map(|r| r.error.abs() / r.allowed)
            .fold(0.0, f64::max)
    }

    /// How many rows came out each way: (ok, not identifiable, known failures).
    pub fn counts(&self) -> (usize, usize, usize) {
        let count = |f: &dyn Fn(&Check) -> bool| self.rows.iter().filter(|r| f(&r.check)).count();
        (
            count(&|c| *c == Check::Ok),
            count(&|c| *c == Check::NotIdentifiable),
            count(&|c| matches!(c, Check::Known | Check::KnownImproved)),
        )
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
            for diagnosis in &estimate.diagnoses {
                text += &format!("diagnosis: {diagnosis}\n");
            }
        }
        for problem in &self.problems {
            text += &format!("FAIL: {problem}\n");
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
            text += &format!(
                "{:<14} {:>13.6} {:>10.3e} {:>13.6} {:>11.3e} {:>9.2e} {:>8.2} {:>10.3e}  {}\n",
                row.parameter,
                row.estimate,
                row.sigma,
                row.truth,
                row.error,
                row.error.abs() / row.truth.abs(),
                row.error / row.sigma,
                row.allowed,
                row.check,
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
        for diagnosis in &estimate.diagnoses {
            text += &format!(
                "diagnosis {}: {}\n",
                diagnosis.kind,
                diagnosis.about.join(", ")
            );
        }
        for p in &estimate.parameters {
            let identifiable = self
                .rows
                .iter()
                .find(|r| r.parameter == p.name)
                .is_none_or(GateRow::identifiable);
            text += &format!(
                "{} = {} ± {}{}\n",
                p.name,
                aeroid_record::rounded(p.value),
                aeroid_record::significant(p.standard_error, 2),
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
pub fn load(registry: &Registry, path: &Path) -> Result<GateFile> {
    let file: GateFile = parse_toml(path, &read_text(path)?)?;
    let mut problems = FieldErrors::default();
    for (i, case) in file.cases.iter().enumerate() {
        let field = format!("case[{i}] ({})", case.name);
        if let Err(error) = registry.find(&case.method) {
            problems.push(format!("{field}.method"), error.to_string());
        }
        for (key, reference) in [
            ("scenario", &case.scenario),
            ("profile", &case.profile),
            ("model", &case.model),
        ] {
            if !aeroid_core::paths::stays_inside(reference) {
                problems.push(
                    format!("{field}.{key}"),
                    format!("'{reference}' is an absolute path or leaves the folder with '..'; name a bundled file"),
                );
            }
        }
        let mut tables = FieldErrors::default();
        registry.check_tables(&case.methods, &mut tables);
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
        check_tolerances(case, &field, &mut problems);
    }
    if file.cases.is_empty() {
        problems.push(
            "case",
            "the file holds no [[case]]: a gate file gates at least one case",
        );
    }
    Ok(problems.finish(path, file)?)
}

/// The tolerances, overrides, thresholds and declarations of a case: finite
/// and positive, each with its reason, none that would let an error of half
/// the truth pass.
fn check_tolerances(case: &GateCase, field: &str, problems: &mut FieldErrors) {
    let positive = |t: f64| t.is_finite() && t > 0.0;
    let numbers = [
        case.relative_tolerance,
        case.sigma_tolerance,
        case.identifiable_below,
        case.spurious_sigma,
        case.sigma_scale.as_ref().map(|s| s.value),
    ];
    if numbers.iter().flatten().any(|t| !positive(*t))
        || case.tolerance.values().any(|o| !positive(o.value))
    {
        problems.push(
            field,
            "tolerances and thresholds must be positive finite numbers",
        );
    }
    let relative = case.sigma_tolerance.is_none();
    for (name, tolerance) in case
        .relative_tolerance
        .iter()
        .map(|t| ("relative_tolerance".to_string(), *t))
        .chain(
            case.tolerance
                .iter()
                .filter(|_| relative)
                .map(|(name, o)| (format!("tolerance.{name}"), o.value)),
        )
    {
        if tolerance >= HALF_THE_TRUTH {
            problems.push(
                format!("{field}.{name}"),
                format!("{tolerance} would pass an error of half the truth; a method that cannot do better is a known failure ([case.known])"),
            );
        }
    }
    for (name, o) in &case.tolerance {
        if o.reason.trim().is_empty() {
            problems.push(
                format!("{field}.tolerance.{name}.reason"),
                "an override says why the default does not fit this parameter",
            );
        }
        if case.known.contains_key(name) {
            problems.push(
                format!("{field}.tolerance.{name}"),
                "is also declared a known failure: give one of the two",
            );
        }
    }
    if let Some(scale) = &case.sigma_scale {
        if relative {
            problems.push(format!("{field}.sigma_scale"), "goes with sigma_tolerance");
        }
        if scale.reason.trim().is_empty() {
            problems.push(
                format!("{field}.sigma_scale.reason"),
                "cite the study that measured σ_MC/CRB",
            );
        }
    }
    for (name, known) in &case.known {
        let [low, high] = known.error;
        if !(low.is_finite() && high.is_finite() && low <= high) {
            problems.push(
                format!("{field}.known.{name}.error"),
                "a range [low, high] of finite numbers, low ≤ high",
            );
        }
        if known.reason.trim().is_empty() {
            problems.push(
                format!("{field}.known.{name}.reason"),
                "a known failure says why the method fails here",
            );
        }
    }
}

/// What a case's flight and estimator gave: the estimate or the refusal,
/// and the truth of each estimated parameter (None: no truth, a term the
/// truth model lacks or a nuisance unknown).
#[derive(Debug, Clone)]
pub struct Flown {
    pub refusal: Option<Refusal>,
    pub estimate: Option<Estimate>,
    pub truths: BTreeMap<String, f64>,
}

/// Runs one case: [`fly_case`], then [`judge`]. Errors are for a case
/// that cannot be set up (unknown scenario, profile or model, a departing
/// simulation) or an estimator that failed; an estimator's refusal is the
/// case's `refusal`.
pub fn run_case(registry: &Registry, case: &GateCase) -> Result<GateResult> {
    Ok(judge(case, fly_case(registry, case)?))
}

/// Flies, records and estimates a case.
pub fn fly_case(registry: &Registry, case: &GateCase) -> Result<Flown> {
    let scenario = Scenario::load(&case.scenario)?;
    registry.validate_tables(&scenario.methods, &scenario.path)?;
    let profile = Profile::load(&case.profile, None)?;
    let structure = Structure::load(&case.model)?;
    let (record, truth) = crate::linear_flight::record_flight(&scenario, &profile, scenario.seed)?;
    let record = match &case.derive {
        Some(derive) => aeroid_record::prep::derive::derive(&record, &derive.options())?.record,
        None => record,
    };
    match run::estimate_scored(
        registry,
        &case.method,
        &record,
        &truth,
        &structure,
        &[&scenario.methods, &case.methods],
        None,
    ) {
        Outcome::Estimated { estimate, .. } => {
            let truths = estimate
                .parameters
                .iter()
                .filter_map(|p| {
                    let (value, _) = truth.value_for(&p.name, structure.score_kind())?;
                    Some((p.name.clone(), value))
                })
                .collect();
            Ok(Flown {
                refusal: None,
                estimate: Some(*estimate),
                truths,
            })
        }
        Outcome::Refused(refusal) => Ok(Flown {
            refusal: Some(refusal),
            estimate: None,
            truths: BTreeMap::new(),
        }),
        Outcome::Failed(reason) => Err(Error::Failed {
            method: case.method.clone(),
            reason,
        }),
    }
}

/// Whether an unknown is a nuisance of the fit (an initial state, an
/// output bias): it has no truth and is not gated.
fn is_nuisance(name: &str) -> bool {
    name.starts_with("x0[") || name.starts_with("bias.")
}

/// Checks a flown case against its tolerances and declarations (module
/// header).
pub fn judge(case: &GateCase, flown: Flown) -> GateResult {
    let Flown {
        refusal,
        estimate,
        truths,
    } = flown;
    let mut problems = Vec::new();
    let mut rows = Vec::new();
    if let Some(estimate) = &estimate {
        if !estimate.status.is_success() {
            problems.push(format!(
                "status {}: only a converged fit is gated",
                estimate.status
            ));
        }
        let mut found: Vec<DiagnosisKind> = estimate.diagnoses.iter().map(|d| d.kind).collect();
        found.sort();
        let mut declared = case.diagnoses.clone();
        declared.sort();
        if found != declared {
            problems.push(format!(
                "diagnoses [{}], the case declares [{}]",
                kinds_text(&found),
                kinds_text(&declared)
            ));
        }
        rows = estimate
            .parameters
            .iter()
            .filter(|p| truths.contains_key(&p.name) || !is_nuisance(&p.name))
            .map(|p| judge_row(case, p, truths.get(&p.name).copied()))
            .collect();
        if rows.is_empty() {
            problems.push("no estimated parameter has a truth".into());
        }
        for name in case.known.keys().chain(case.tolerance.keys()) {
            if !rows.iter().any(|r| &r.parameter == name) {
                problems.push(format!(
                    "'{name}' is declared but not estimated: remove its declaration"
                ));
            }
        }
    }
    GateResult {
        case: case.clone(),
        refusal,
        estimate,
        rows,
        problems,
    }
}

fn kinds_text(kinds: &[DiagnosisKind]) -> String {
    kinds
        .iter()
        .map(|k| k.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// A declared failure's row: `measure` its error in the declaration's
/// unit, `passes` whether it meets the case's default tolerance.
fn judge_known(known: &KnownFailure, measure: f64, passes: bool) -> Check {
    let [low, high] = known.error;
    if passes {
        Check::Fail(
            "declared a known failure, but within its tolerance now: remove the declaration".into(),
        )
    } else if (low..=high).contains(&measure) {
        Check::Known
    } else if (measure > 0.0 && measure < low) || (measure < 0.0 && measure > high) {
        Check::KnownImproved
    } else {
        Check::Fail(format!(
            "error {} beyond its declared range [{low}, {high}]",
            aeroid_record::significant(measure, 3)
        ))
    }
}

/// One parameter's row (module header).
// One verdict: its cases (not identifiable, a known failure, within, near, beyond) read the same error, allowance and measure; split, each case would take them all.
fn judge_row(
    case: &GateCase,
    p: &aeroid_estimation::estimate::ParameterEstimate,
    truth: Option<f64>,
) -> GateRow {
    let truth = truth.unwrap_or(0.0);
    let error = p.value - truth;
    let zero = truth.abs() < ZERO_TRUTH;
    let sigma = case.gate_sigma(p.standard_error);
    let default = case.default_tolerance();
    let allowed = if zero {
        let k = case.spurious_sigma.or(case.sigma_tolerance).unwrap_or(0.0);
        (k * sigma).max(case.absolute_floor)
    } else {
        let tolerance = case.tolerance.get(&p.name).map_or(default, |o| o.value);
        case.allowance(tolerance, truth, p.standard_error)
    };
    // The error in the unit of a known failure's range.
    let measure = if zero {
        p.value / p.standard_error
    } else {
        error / truth.abs()
    };
    let within = |allowed: f64| {
        allowed.is_finite()
            && error.abs() <= allowed
            && (zero || error.abs() < HALF_THE_TRUTH * truth.abs())
    };
    let identifiable = zero
        || case
            .identifiable_below()
            .is_none_or(|limit| sigma < limit * truth.abs());
    let check = if !identifiable {
        match case.known.contains_key(&p.name) {
            true => Check::Fail(
                "declared a known failure, but not identifiable here: remove the declaration"
                    .into(),
            ),
            false => Check::NotIdentifiable,
        }
    } else if let Some(known) = case.known.get(&p.name) {
        let default_allowed = if zero {
            allowed
        } else {
            case.allowance(default, truth, p.standard_error)
        };
        judge_known(known, measure, within(default_allowed))
    } else if within(allowed) {
        let loosened = case.tolerance.get(&p.name).is_some_and(|o| {
            o.value > default && within(case.allowance(default, truth, p.standard_error))
        });
        if loosened {
            Check::Fail(
                "its override loosens a parameter that passes the default: remove it".into(),
            )
        } else {
            Check::Ok
        }
    } else if error.abs() <= allowed {
        Check::Fail(format!(
            "within its tolerance but beyond {} of its truth",
            if error * truth < 0.0 && error.abs() > truth.abs() {
                "the sign"
            } else {
                "half"
            }
        ))
    } else if zero {
        Check::Fail("a term whose truth is zero, beyond its bound".into())
    } else {
        Check::Fail("beyond its tolerance".into())
    };
    GateRow {
        parameter: p.name.clone(),
        estimate: p.value,
        sigma: p.standard_error,
        truth,
        error,
        allowed,
        check,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aeroid_estimation::estimate::{Diagnosis, ParameterEstimate, Status};

    /// A case over one parameter `a` (truth 1), σ gate k = 4 unless
    /// `relative` is given.
    fn case(relative: Option<f64>) -> GateCase {
        let text = format!(
            "name = \"t\"\nscenario = \"s\"\nprofile = \"p\"\nmodel = \"m\"\nmethod = \"oem\"\n{}",
            match relative {
                Some(tol) => format!("relative_tolerance = {tol}"),
                None => "sigma_tolerance = 4.0".into(),
            }
        );
        toml::from_str(&text).unwrap()
    }

    /// A converged estimate of `a` (truth 1) and of `extra` (no truth),
    /// each `value ± sigma`.
    fn flown(a: (f64, f64), extra: Option<(f64, f64)>) -> Flown {
        let parameter = |name: &str, (value, sigma): (f64, f64)| ParameterEstimate {
            name: name.into(),
            value,
            standard_error: sigma,
            start: 0.0,
        };
        let mut parameters = vec![parameter("a", a)];
        parameters.extend(extra.map(|e| parameter("CL_extra", e)));
        parameters.push(parameter("x0[0].q", (5.0, 1.0)));
        let estimate = Estimate {
            parameters,
            ..Estimate::empty("oem", "m", "r", Status::Converged)
        };
        Flown {
            refusal: None,
            estimate: Some(estimate),
            truths: [("a".to_string(), 1.0)].into(),
        }
    }

    fn check(case: &GateCase, a: (f64, f64)) -> Check {
        judge(case, flown(a, None)).rows[0].check.clone()
    }

    /// Within k·σ and below half the truth is ok; beyond k·σ fails; a σ
    /// of 1/(2k) of the truth or more is not identifiable, whatever the
    /// error; a relative gate passes within tol·|truth|. The nuisance
    /// initial state is not a row.
    #[test]
    fn rows_are_checked_against_the_truth_and_the_bound() {
        let sigma = case(None);
        assert_eq!(check(&sigma, (1.03, 0.01)), Check::Ok);
        assert!(matches!(check(&sigma, (1.05, 0.01)), Check::Fail(_)));
        assert_eq!(check(&sigma, (-0.9, 0.2)), Check::NotIdentifiable);
        assert_eq!(check(&sigma, (1.0, 0.125)), Check::NotIdentifiable);
        let relative = case(Some(0.1));
        assert_eq!(check(&relative, (1.09, 0.0)), Check::Ok);
        assert!(matches!(check(&relative, (1.11, 0.0)), Check::Fail(_)));
        assert_eq!(judge(&relative, flown((1.0, 0.0), None)).rows.len(), 1);
    }

    /// An override that lets half the truth pass is refused at load; one
    /// with a cited reason applies, and fails the row when the parameter
    /// passes the default without it. A wrong sign never passes, even
    /// through a σ gate whose threshold was raised.
    #[test]
    fn overrides_carry_reasons_and_only_loosen_what_needs_it() {
        let mut loose = case(None);
        loose.identifiable_below = Some(10.0);
        let wrong = check(&loose, (-0.5, 0.5));
        assert!(
            matches!(&wrong, Check::Fail(why) if why.contains("sign")),
            "{wrong:?}"
        );

        let mut overridden = case(None);
        overridden.tolerance.insert(
            "a".into(),
            Override {
                value: 8.0,
                reason: "measured".into(),
            },
        );
        assert_eq!(check(&overridden, (1.06, 0.01)), Check::Ok);
        let needless = check(&overridden, (1.02, 0.01));
        assert!(
            matches!(&needless, Check::Fail(why) if why.contains("override")),
            "{needless:?}"
        );

        let mut problems = FieldErrors::default();
        let mut half = case(Some(0.5));
        half.tolerance.insert(
            "a".into(),
            Override {
                value: 0.2,
                reason: " ".into(),
            },
        );
        check_tolerances(&half, "case", &mut problems);
        let text = format!("{:?}", problems.0);
        assert!(
            text.contains("relative_tolerance") && text.contains("reason"),
            "{text}"
        );
    }

    /// A known failure within its range is reported as known; further from
    /// the truth it fails; closer, it is reported improved; within its
    /// tolerance it fails until the declaration is removed.
    #[test]
    fn known_failures_are_declared_not_passed() {
        let mut known = case(None);
        known.known.insert(
            "a".into(),
            KnownFailure {
                error: [0.45, 0.55],
                reason: "biased".into(),
            },
        );
        assert_eq!(check(&known, (1.5, 0.01)), Check::Known);
        assert!(matches!(check(&known, (1.6, 0.01)), Check::Fail(_)));
        assert!(matches!(check(&known, (0.5, 0.01)), Check::Fail(_)));
        assert_eq!(check(&known, (1.3, 0.01)), Check::KnownImproved);
        let fixed = check(&known, (1.01, 0.01));
        assert!(
            matches!(&fixed, Check::Fail(why) if why.contains("remove")),
            "{fixed:?}"
        );
    }

    /// A term the truth lacks is gated against zero at k·σ; diagnoses must
    /// be the declared ones; a case that is not converged fails.
    #[test]
    fn extra_terms_diagnoses_and_status_are_gated() {
        let sigma = case(None);
        let rows = judge(&sigma, flown((1.0, 0.01), Some((0.03, 0.01)))).rows;
        assert_eq!(rows[1].check, Check::Ok);
        let rows = judge(&sigma, flown((1.0, 0.01), Some((0.05, 0.01)))).rows;
        assert!(matches!(rows[1].check, Check::Fail(_)));

        let mut diagnosed = flown((1.0, 0.01), None);
        diagnosed
            .estimate
            .as_mut()
            .unwrap()
            .diagnoses
            .push(Diagnosis {
                kind: DiagnosisKind::ColouredResiduals,
                about: vec!["q".into()],
                measures: vec![0.2],
                advice: String::new(),
            });
        assert!(!judge(&sigma, diagnosed.clone()).passed());
        let mut declared = case(None);
        declared.diagnoses = vec![DiagnosisKind::ColouredResiduals];
        assert!(judge(&declared, diagnosed).passed());
        assert!(!judge(&declared, flown((1.0, 0.01), None)).passed());

        let mut limited = flown((1.0, 0.01), None);
        limited.estimate.as_mut().unwrap().status = Status::IterationLimit;
        assert!(!judge(&sigma, limited).passed());
    }

    /// An empty gate file is an error, not "all 0 gates pass".
    #[test]
    fn an_empty_gate_file_is_refused() {
        let folder = std::env::temp_dir().join(format!("aeroid-gate-{}", std::process::id()));
        std::fs::create_dir_all(&folder).unwrap();
        for text in ["", "case = []\n"] {
            let path = folder.join("gates.toml");
            std::fs::write(&path, text).unwrap();
            let error = load(&Registry::built_in(), &path).unwrap_err().to_string();
            assert!(error.contains("no [[case]]"), "{error}");
        }
        std::fs::remove_dir_all(&folder).unwrap();
    }
}
