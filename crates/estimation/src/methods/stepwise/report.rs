//! What a stepwise regression reports: its steps (the term that entered or
//! left, its partial F, R², s², PRESS and PSE; Klein & Morelli, "Aircraft
//! System Identification", AIAA 2006, §5.4), the selected terms with their
//! bounds, the report as an estimate and as text.

use super::*;

/// What a step did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// The constant-only model.
    Start,
    Enter,
    Remove,
}

/// The model after one step.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub action: Action,
    /// The term that entered or left.
    pub term: Option<String>,
    /// Its partial F statistic.
    pub partial_f: f64,
    /// The terms in the model after the step (besides the constant).
    pub terms: Vec<String>,
    /// Coefficient of determination (fraction).
    pub r_squared: f64,
    pub residual_variance: f64,
    /// Overall F = (SSR/p)/s² (NaN for the constant-only model).
    pub f_statistic: f64,
    pub press: f64,
    /// Predicted square error.
    pub pse: f64,
}

/// A term of the selected model with its estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectedTerm {
    /// Parameter name, `{coefficient}_{term}`.
    pub parameter: String,
    pub value: f64,
    /// Classical bound s²(XᵀX)⁻¹.
    pub standard_error: f64,
    /// Bound corrected for coloured residuals (Morelli & Klein 1997).
    pub corrected_standard_error: f64,
}

/// The outcome of a stepwise regression.
#[derive(Debug, Clone, PartialEq)]
pub struct StepwiseReport {
    pub coefficient: String,
    pub model: String,
    pub record: String,
    pub samples: usize,
    pub options: StepwiseOptions,
    pub steps: Vec<Step>,
    /// The constant first, then the selected terms in order of entry.
    pub selected: Vec<SelectedTerm>,
    /// Corrected covariance of the selected terms' estimates.
    pub covariance: DMatrix<f64>,
    /// Candidates left out, with their partial F to enter the final model.
    pub excluded: Vec<(String, f64)>,
    pub stop_reason: String,
    pub fit: OutputFit,
    pub wall_time: f64,
    pub notes: Vec<String>,
}

impl StepwiseReport {
    /// The selected model as an estimate (method "swr"), standard errors corrected for coloured residuals.
    pub fn estimate(&self) -> Estimate {
        let n = self.selected.len();
        Estimate {
            method: METHOD.to_string(),
            model: self.model.clone(),
            record: self.record.clone(),
            diagnoses: Vec::new(),
            status: Status::Converged,
            parameters: self
                .selected
                .iter()
                .map(|t| ParameterEstimate {
                    name: t.parameter.clone(),
                    value: t.value,
                    standard_error: t.corrected_standard_error,
                    start: 0.0,
                })
                .collect(),
            covariance: (0..n)
                .map(|i| (0..n).map(|j| self.covariance[(i, j)]).collect())
                .collect(),
            fits: vec![self.fit.clone()],
            iterations: self.steps.len(),
            cost_history: self
                .steps
                .iter()
                .map(|s| 0.5 * s.residual_variance * (self.samples as f64 - s.terms.len() as f64 - 1.0))
                .collect(),
            wall_time: self.wall_time,
            notes: self
                .notes
                .iter()
                .cloned()
                .chain([
                    format!("stepwise regression of {}: {}", self.coefficient, self.stop_reason),
                    "standard errors: Cramér–Rao bounds corrected for coloured residuals (Morelli & Klein 1997)".to_string(),
                ])
                .collect(),
            details: String::new(),
            network: None,
            distributions: Vec::new(),
            histories: Vec::new(),
        }
    }
}

impl fmt::Display for StepwiseReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "stepwise regression of {} ({} samples; record {}, model {})",
            self.coefficient, self.samples, self.record, self.model
        )?;
        writeln!(
            f,
            "F-to-enter {}, F-to-remove {}, minimum R² gain {:e}",
            self.options.f_to_enter, self.options.f_to_remove, self.options.min_r_squared_gain
        )?;
        writeln!(
            f,
            "{:>4}  {:<7} {:<12} {:>11} {:>9} {:>11} {:>11} {:>11} {:>11}  terms",
            "step", "action", "term", "partial F", "R² [%]", "s²", "F", "PRESS", "PSE"
        )?;
        for (i, step) in self.steps.iter().enumerate() {
            writeln!(
                f,
                "{:>4}  {:<7} {:<12} {:>11} {:>9.4} {:>11.4e} {:>11} {:>11.4e} {:>11.4e}  {}",
                i,
                match step.action {
                    Action::Start => "start",
                    Action::Enter => "enter",
                    Action::Remove => "remove",
                },
                step.term.as_deref().unwrap_or("(constant)"),
                number(step.partial_f),
                100.0 * step.r_squared,
                step.residual_variance,
                number(step.f_statistic),
                step.press,
                step.pse,
                if step.terms.is_empty() {
                    "0".to_string()
                } else {
                    format!("0, {}", step.terms.join(", "))
                }
            )?;
        }
        writeln!(f, "stop: {}", self.stop_reason)?;
        writeln!(
            f,
            "{:<20} {:>13} {:>13} {:>13}",
            "parameter", "estimate", "s²(XᵀX)⁻¹ σ", "corrected σ"
        )?;
        for term in &self.selected {
            writeln!(
                f,
                "{:<20} {:>13.6e} {:>13.4e} {:>13.4e}",
                term.parameter, term.value, term.standard_error, term.corrected_standard_error
            )?;
        }
        let excluded: Vec<String> = self
            .excluded
            .iter()
            .map(|(name, partial_f)| format!("{name} (F = {})", number(*partial_f)))
            .collect();
        writeln!(f, "not selected: {}", excluded.join(", "))
    }
}

/// A statistic for the table: 4 significant digits, "-" when undefined.
fn number(value: f64) -> String {
    if value.is_finite() {
        format!("{value:.4e}")
    } else {
        "-".to_string()
    }
}
