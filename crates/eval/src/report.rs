//! Pictures and a report of a study's output folder (`aeroid report DIR`):
//! SVG plots drawn with plotters' SVG backend (no font library: the text is
//! SVG text the browser sets) and one self-contained HTML page — plots
//! inlined, the summary and endings as tables, the study file, aeroid's
//! version, the seed and the fingerprint — that opens in a browser with no
//! server.
//!
//! Plots, per model and parameter:
//! - **error against the sweep**: each method's bias (mean − truth over
//!   its converged fits) at every sweep point, x the sample rate where the
//!   study sweeps it (else the point's index), one series per method,
//!   scenario and noise scale (a colour each), with the ±1.96·(mean CRB)
//!   band of that series as dashed lines: where the bias leaves its band the estimator
//!   is biased beyond its own stated accuracy;
//! - **estimates**: every converged estimate of the first [`SHOWN_RUNS`]
//!   runs of each point by case, one colour per method, the truth as a
//!   line.
//!
//! Per sweep point, from the histories of its first run
//! ([`crate::histories`]):
//! - **proof of match**, per model: one panel per output, the measured
//!   samples in black and each converged method's model simulated on the
//!   same record with nothing adjusted, a colour each;
//! - **smoothed coefficients**, per method that estimates coefficient
//!   histories (estimation before modelling): one panel per coefficient,
//!   the smoothed history with its ±1.96σ band dashed and the simulator's
//!   true coefficient in black.
//!
//! A short script in the page marks every plot with the number of its
//! drawn elements that have a size on screen (`data-drawn`), which a
//! headless browser can read back to check that the page was drawn.

use crate::error::{Error, Result};
use crate::histories::CaseHistories;
use crate::journal::{self, JOURNAL_FILE};
use crate::row::{Row, RowStatus};
use crate::study::StudyResult;
use crate::summary::SummaryRow;
use aeroid_core::error::read_text;
use aeroid_estimation::estimate::History;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The copy of the study file a study writes beside its results.
pub const STUDY_COPY: &str = "study.toml";
/// The report's default file name inside the study's folder.
pub(crate) const REPORT_FILE: &str = "report.html";

/// Runs per sweep point whose estimates the report plots one by one: the
/// page and the memory it takes stay bounded whatever the number of runs
/// (the summary's statistics are over every run).
pub const SHOWN_RUNS: usize = 200;

const WIDTH: u32 = 720;
const HEIGHT: u32 = 420;

/// Colours of the series, in order (Tableau's 20 colours, dark shades
/// first): a study rarely has more methods or series than these.
const PALETTE: [RGBColor; 16] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
    RGBColor(188, 189, 34),
    RGBColor(127, 127, 127),
    RGBColor(174, 199, 232),
    RGBColor(255, 152, 150),
    RGBColor(152, 223, 138),
    RGBColor(197, 176, 213),
    RGBColor(255, 187, 120),
    RGBColor(196, 156, 148),
];
/// One plot: its title and SVG text.
#[derive(Debug, Clone, PartialEq)]
pub struct Plot {
    pub title: String,
    pub svg: String,
}

/// A study folder read back: its result, its rows and what it was run from.
#[derive(Debug, Clone)]
pub struct StudyFolder {
    pub result: StudyResult,
    /// The rows of the first [`SHOWN_RUNS`] runs of each sweep point (the
    /// summary holds every run).
    pub rows: Vec<Row>,
    /// The study file's text, if the folder has its copy.
    pub study_file: Option<String>,
    /// The journal's fingerprint, if the folder has a journal.
    pub fingerprint: Option<String>,
    /// The histories of each sweep point's first run, in point order.
    pub histories: Vec<CaseHistories>,
}

impl StudyFolder {
    /// Reads `study.json`, `runs.csv`, and if present `study.toml` and the
    /// journal's header from `folder`.
    pub fn read(folder: &Path) -> Result<StudyFolder> {
        let path = folder.join("study.json");
        let result: StudyResult =
            serde_json::from_str(&read_text(&path)?).map_err(|e| Error::Json {
                path: path.clone(),
                reason: e.to_string(),
            })?;
        let path = folder.join("runs.csv");
        let mut reader = csv::Reader::from_path(&path).map_err(|e| csv_error(&path, e))?;
        let mut rows = Vec::new();
        let mut count = 0;
        for row in reader.deserialize::<Row>() {
            let row = row.map_err(|e| csv_error(&path, e))?;
            count += 1;
            if row.run < SHOWN_RUNS {
                rows.push(row);
            }
        }
        // An empty or cut runs.csv, or one from another run of the study,
        // does not hold the rows study.json summarises.
        if count != result.rows {
            return Err(Error::Table {
                path,
                line: None,
                reason: format!(
                    "holds {count} rows where study.json summarises {}: the file is cut short or is not this result's; run `aeroid merge` again",
                    result.rows
                ),
            });
        }
        let copy = folder.join(STUDY_COPY);
        let study_file = copy.exists().then(|| read_text(&copy)).transpose()?;
        let fingerprint = folder
            .join(JOURNAL_FILE)
            .exists()
            .then(|| journal::read(folder).map(|(header, _)| header.fingerprint))
            .transpose()?;
        Ok(StudyFolder {
            result,
            rows,
            study_file,
            fingerprint,
            histories: CaseHistories::read_all(folder)?,
        })
    }
}

fn csv_error(path: &Path, error: csv::Error) -> Error {
    Error::Table {
        path: path.to_path_buf(),
        line: error.position().map(|p| p.line()),
        reason: error.to_string(),
    }
}

fn plot_error(error: impl std::fmt::Display) -> Error {
    Error::Plot {
        reason: error.to_string(),
    }
}

/// A series key: method, scenario with its recorder profile, noise scale.
type SeriesKey = (String, String, String);

/// The error-against-sweep plot of one model's parameter.
pub(crate) fn error_plot(model: &str, parameter: &str, summary: &[&SummaryRow]) -> Result<Plot> {
    let by_rate = summary.iter().all(|s| s.sample_rate.is_some());
    let x_of = |s: &SummaryRow| s.sample_rate.unwrap_or(s.point as f64);
    let mut series: BTreeMap<SeriesKey, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for s in summary {
        if s.converged == 0 || !s.bias.is_finite() {
            continue;
        }
        let key = (
            s.method.clone(),
            format!("{} ({})", s.scenario, s.profile),
            format!("noise×{}", s.noise_scale),
        );
        let band = if s.mean_crb.is_finite() {
            1.96 * s.mean_crb
        } else {
            0.0
        };
        series.entry(key).or_default().push((x_of(s), s.bias, band));
    }
    let points = series.values().flatten();
    let (x_min, x_max) = range(points.clone().map(|p| p.0));
    let (y_min, y_max) = range(points.flat_map(|p| [p.1, p.1.abs().max(p.2), -p.2]));
    let title = format!("{model}: {parameter}, error against the sweep");
    let x_label = if by_rate {
        "sample rate (Hz)"
    } else {
        "sweep point"
    };
    let frame = Frame {
        title: &title,
        x: (x_min, x_max),
        y: (y_min, y_max),
        x_label,
        y_label: "mean − truth",
    };
    let svg = frame.draw(|chart| {
        for (number, (key, mut values)) in series.into_iter().enumerate() {
            values.sort_by(|a, b| a.0.total_cmp(&b.0));
            let colour = PALETTE[number % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(
                    values.iter().map(|v| (v.0, v.1)),
                    colour.stroke_width(2),
                ))
                .map_err(plot_error)?
                .label(format!("{} {} {}", key.0, key.1, key.2))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour));
            chart
                .draw_series(
                    values
                        .iter()
                        .map(|v| Circle::new((v.0, v.1), 3, colour.filled())),
                )
                .map_err(plot_error)?;
            for sign in [1.0, -1.0] {
                chart
                    .draw_series(DashedLineSeries::new(
                        values.iter().map(|v| (v.0, sign * v.2)),
                        4,
                        3,
                        colour.stroke_width(1),
                    ))
                    .map_err(plot_error)?;
            }
        }
        Ok(())
    })?;
    Ok(Plot { title, svg })
}

/// The scatter of one model's parameter estimates by case and method.
pub(crate) fn estimates_plot(
    model: &str,
    parameter: &str,
    rows: &[&Row],
    runs: usize,
) -> Result<Plot> {
    let case = |r: &Row| (r.point * runs + r.run) as f64;
    let used: Vec<&&Row> = rows
        .iter()
        .filter(|r| r.status == RowStatus::Converged && r.estimate.is_finite())
        .collect();
    let truth = rows.iter().find_map(|r| r.truth);
    let (x_min, x_max) = range(used.iter().map(|r| case(r)));
    let (y_min, y_max) = range(used.iter().map(|r| r.estimate).chain(truth));
    let title = format!("{model}: {parameter}, estimates");
    let frame = Frame {
        title: &title,
        x: (x_min, x_max),
        y: (y_min, y_max),
        x_label: "case",
        y_label: parameter,
    };
    let svg = frame.draw(|chart| {
        if let Some(truth) = truth {
            chart
                .draw_series(LineSeries::new(
                    [(x_min, truth), (x_max, truth)],
                    BLACK.stroke_width(1),
                ))
                .map_err(plot_error)?
                .label("truth")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK));
        }
        let methods = method_colours(used.iter().map(|r| r.method.as_str()));
        for (method, colour) in &methods {
            let colour = *colour;
            chart
                .draw_series(
                    used.iter()
                        .filter(|r| r.method == *method)
                        .map(|r| Circle::new((case(r), r.estimate), 2, colour.filled())),
                )
                .map_err(plot_error)?
                .label(method.to_string())
                .legend(move |(x, y)| Circle::new((x + 9, y), 3, colour.filled()));
        }
        Ok(())
    })?;
    Ok(Plot { title, svg })
}

/// The most points a line of a history plot is drawn with: longer
/// histories are thinned to every k-th sample.
const MAX_LINE_POINTS: usize = 800;

/// One line of a panel.
struct Line {
    label: String,
    colour: RGBColor,
    points: Vec<(f64, f64)>,
    dashed: bool,
    /// Whether the panel's y range holds the line (else it is cut at the
    /// frame: a prediction that runs away, a σ band that grows at the
    /// record's ends).
    frames: bool,
}

impl Line {
    /// A series' values (offset by `sigma_scale` times its σ when not 0),
    /// thinned to at most [`MAX_LINE_POINTS`].
    fn of(series: &History, label: String, colour: RGBColor, sigma_scale: f64) -> Line {
        let stride = series.values.len().div_ceil(MAX_LINE_POINTS).max(1);
        let points = (0..series.values.len())
            .step_by(stride)
            .map(|k| {
                let offset = if sigma_scale == 0.0 {
                    0.0
                } else {
                    sigma_scale * series.sigma.get(k).copied().unwrap_or(f64::NAN)
                };
                (series.times[k], series.values[k] + offset)
            })
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .collect();
        Line {
            label,
            colour,
            points,
            dashed: sigma_scale != 0.0,
            frames: sigma_scale == 0.0,
        }
    }

    /// The line, not framing the panel's y range.
    fn unframed(self) -> Line {
        Line {
            frames: false,
            ..self
        }
    }
}

/// One panel of a history plot: a quantity against time.
struct Panel {
    name: String,
    lines: Vec<Line>,
}

/// Height of one panel of a history plot.
const PANEL_HEIGHT: u32 = 190;

/// Width of the legend column beside the panels of a history plot.
const LEGEND_WIDTH: u32 = 130;

/// The legend beside the panels: `panel`'s lines with a label, one a row.
fn draw_legend(
    legend: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    panel: &Panel,
) -> Result<()> {
    for (row, line) in panel
        .lines
        .iter()
        .filter(|l| !l.label.is_empty())
        .enumerate()
    {
        let y = 20 + 18 * row as i32;
        legend
            .draw(&PathElement::new(
                vec![(4, y), (24, y)],
                line.colour.stroke_width(2),
            ))
            .map_err(plot_error)?;
        legend
            .draw(&Text::new(
                line.label.clone(),
                (30, y - 7),
                ("sans-serif", 12),
            ))
            .map_err(plot_error)?;
    }
    Ok(())
}

/// The SVG of panels stacked under one title, each a quantity against
/// time with its lines, and beside them the legend (the first panel's
/// lines with a label).
fn panels_svg(title: &str, panels: &[Panel]) -> Result<String> {
    let mut svg = String::new();
    {
        let height = 40 + PANEL_HEIGHT * panels.len().max(1) as u32;
        let root =
            SVGBackend::with_string(&mut svg, (WIDTH + LEGEND_WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let root = root.titled(title, ("sans-serif", 16)).map_err(plot_error)?;
        let (plots, legend) = root.split_horizontally(WIDTH);
        if let Some(first) = panels.first() {
            draw_legend(&legend, first)?;
        }
        let areas = plots.split_evenly((panels.len().max(1), 1));
        for (panel, area) in panels.iter().zip(&areas) {
            let (x_min, x_max) = range(
                panel
                    .lines
                    .iter()
                    .flat_map(|l| l.points.iter().map(|p| p.0)),
            );
            let framing = panel.lines.iter().filter(|l| l.frames);
            let (y_min, y_max) = range(framing.flat_map(|l| l.points.iter().map(|p| p.1)));
            let mut chart = ChartBuilder::on(area)
                .margin(6)
                .x_label_area_size(34)
                .y_label_area_size(70)
                .build_cartesian_2d(x_min..x_max, y_min..y_max)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc("time (s)")
                .y_desc(panel.name.as_str())
                .draw()
                .map_err(plot_error)?;
            for line in &panel.lines {
                let colour = line.colour;
                // Drawn in the runs of points inside the frame: a line
                // that leaves it is broken there, not pinned to its edge.
                let inside = |p: &&(f64, f64)| p.1 >= y_min && p.1 <= y_max;
                for run in line.points.split(|p| !inside(&p)) {
                    let drawn = if line.dashed {
                        chart.draw_series(DashedLineSeries::new(
                            run.iter().copied(),
                            4,
                            3,
                            colour.stroke_width(1),
                        ))
                    } else {
                        chart.draw_series(LineSeries::new(
                            run.iter().copied(),
                            colour.stroke_width(1),
                        ))
                    };
                    drawn.map_err(plot_error)?;
                }
            }
        }
        root.present().map_err(plot_error)?;
    }
    Ok(svg)
}

/// The proof of match of one model at one sweep point: per output, the
/// measured samples and each method's prediction; none when no method
/// has one.
pub(crate) fn match_plot(histories: &CaseHistories, model: &str) -> Result<Option<Plot>> {
    let methods: Vec<_> = histories
        .methods
        .iter()
        .filter(|m| m.model == model && !m.predicted.is_empty())
        .collect();
    let Some(first) = methods.first() else {
        return Ok(None);
    };
    let colours = method_colours(methods.iter().map(|m| m.method.as_str()));
    let panels: Vec<Panel> = first
        .predicted
        .iter()
        .map(|output| {
            let mut lines = Vec::new();
            if let Some(measured) = histories.measured.iter().find(|s| s.name == output.name) {
                lines.push(Line::of(measured, "measured".into(), BLACK, 0.0));
            }
            for m in &methods {
                if let Some(predicted) = m.predicted.iter().find(|s| s.name == output.name) {
                    let line = Line::of(predicted, m.method.clone(), colours[&m.method], 0.0);
                    // The measured samples frame the panel: a prediction
                    // that runs away leaves it.
                    lines.push(if lines.is_empty() {
                        line
                    } else {
                        line.unframed()
                    });
                }
            }
            Panel {
                name: output.name.clone(),
                lines,
            }
        })
        .collect();
    let title = format!(
        "{}: {model}, proof of match (run {})",
        histories.label, histories.run
    );
    let svg = panels_svg(&title, &panels)?;
    Ok(Some(Plot { title, svg }))
}

/// The coefficient histories one method estimated at one sweep point,
/// with ±1.96σ and the simulator's true coefficients.
pub(crate) fn smoothed_plot(histories: &CaseHistories, index: usize) -> Result<Option<Plot>> {
    let method = &histories.methods[index];
    if method.estimated.is_empty() {
        return Ok(None);
    }
    let colour = PALETTE[0];
    let panels: Vec<Panel> = method
        .estimated
        .iter()
        .map(|series| {
            let mut lines = vec![Line::of(
                series,
                format!("{} smoothed", method.method),
                colour,
                0.0,
            )];
            if !series.sigma.is_empty() {
                lines.push(Line::of(series, "±1.96σ".into(), colour, 1.96));
                lines.push(Line::of(series, String::new(), colour, -1.96));
            }
            if let Some(truth) = histories.truth.iter().find(|s| s.name == series.name) {
                lines.push(Line::of(truth, "truth".into(), BLACK, 0.0));
            }
            Panel {
                name: series.name.clone(),
                lines,
            }
        })
        .collect();
    let title = format!(
        "{}: {} on {}, smoothed coefficients (run {})",
        histories.label, method.method, method.model, histories.run
    );
    let svg = panels_svg(&title, &panels)?;
    Ok(Some(Plot { title, svg }))
}

/// A plot's frame: title, axis ranges and labels.
struct Frame<'a> {
    title: &'a str,
    x: (f64, f64),
    y: (f64, f64),
    x_label: &'a str,
    y_label: &'a str,
}

/// The chart a plot's series are drawn on.
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

impl Frame<'_> {
    /// The SVG of the frame (white ground, caption, mesh, axis labels)
    /// with `series` drawn on it, and the legend.
    fn draw(&self, series: impl FnOnce(&mut Chart) -> Result<()>) -> Result<String> {
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_error)?;
            let mut chart = ChartBuilder::on(&root)
                .caption(self.title, ("sans-serif", 16))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(self.x.0..self.x.1, self.y.0..self.y.1)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc(self.x_label)
                .y_desc(self.y_label)
                .draw()
                .map_err(plot_error)?;
            series(&mut chart)?;
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(plot_error)?;
            root.present().map_err(plot_error)?;
        }
        Ok(svg)
    }
}

/// Each method's colour, in order of first appearance.
fn method_colours<'a>(methods: impl Iterator<Item = &'a str>) -> BTreeMap<String, RGBColor> {
    let mut colours = BTreeMap::new();
    for method in methods {
        let next = PALETTE[colours.len() % PALETTE.len()];
        colours.entry(method.to_string()).or_insert(next);
    }
    colours
}

/// A padded axis range of finite values (a unit range about 0 when none).
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (low, high) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if !low.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = if high > low {
        0.05 * (high - low)
    } else {
        0.5 * low.abs().max(1e-12)
    };
    (low - pad, high + pad)
}

/// Every plot of a study folder's histories: per sweep point, each
/// model's proof of match and each method's smoothed coefficients.
pub(crate) fn history_plots(folder: &StudyFolder) -> Result<Vec<Plot>> {
    let mut plots = Vec::new();
    for histories in &folder.histories {
        let mut models: Vec<&str> = Vec::new();
        for m in &histories.methods {
            if !models.contains(&m.model.as_str()) {
                models.push(&m.model);
            }
        }
        for model in models {
            plots.extend(match_plot(histories, model)?);
        }
        for index in 0..histories.methods.len() {
            plots.extend(smoothed_plot(histories, index)?);
        }
    }
    Ok(plots)
}

/// Every plot of a study folder: per model and parameter, the error plot
/// and the estimates.
pub fn plots(folder: &StudyFolder) -> Result<Vec<Plot>> {
    let mut groups: BTreeMap<(String, String), Vec<&SummaryRow>> = BTreeMap::new();
    for s in &folder.result.summary {
        groups
            .entry((s.model.clone(), s.parameter.clone()))
            .or_default()
            .push(s);
    }
    let mut rows: BTreeMap<(String, String), Vec<&Row>> = BTreeMap::new();
    for r in &folder.rows {
        if r.truth.is_some() {
            rows.entry((r.model.clone(), r.parameter.clone()))
                .or_default()
                .push(r);
        }
    }
    let mut plots = Vec::new();
    for ((model, parameter), summary) in &groups {
        plots.push(error_plot(model, parameter, summary)?);
        if let Some(rows) = rows.get(&(model.clone(), parameter.clone())) {
            let shown = folder.result.runs.min(SHOWN_RUNS);
            plots.push(estimates_plot(model, parameter, rows, shown)?);
        }
    }
    Ok(plots)
}

/// Escapes text for HTML.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Marks every plot with the number of its drawn elements that have a size.
const CHECK_SCRIPT: &str = r#"<script>
for (const figure of document.querySelectorAll('figure.plot')) {
  let drawn = 0;
  for (const element of figure.querySelectorAll('svg polyline, svg path, svg circle, svg line, svg text')) {
    const box = element.getBBox();
    if (box.width > 0 || box.height > 0) drawn += 1;
  }
  figure.dataset.drawn = String(drawn);
}
document.body.dataset.checked = 'yes';
</script>"#;

/// Appends each plot to the page as a figure.
fn figures(page: &mut String, plots: &[Plot]) {
    for plot in plots {
        let _ = writeln!(
            page,
            "<figure class=\"plot\" data-title=\"{}\">{}</figure>",
            escape(&plot.title),
            plot.svg
        );
    }
}

/// The table of how the fits ended: per status, the count and the first
/// fit's reason (its table left open).
fn endings_table(page: &mut String, result: &StudyResult) {
    *page += "<h2>How the fits ended</h2>\n<table><tr><th class=\"text\">status</th><th>fits</th><th class=\"text\">first (point, run, model, method): reason</th></tr>\n";
    for ending in &result.endings {
        let first = &ending.first;
        let _ = writeln!(
            page,
            "<tr><td class=\"text\">{}</td><td>{}</td><td class=\"text\">{}, {}, {}, {}: {}</td></tr>",
            escape(ending.status.name()),
            ending.count,
            first.point,
            first.run,
            escape(&first.model),
            escape(&first.method),
            escape(&first.reason)
        );
    }
}

/// The summary table, a row per sweep point, model, method and parameter
/// (its table left open).
fn summary_table(page: &mut String, result: &StudyResult) {
    *page += "<h2>Summary</h2>\n<table><tr>";
    for header in [
        "point",
        "scenario",
        "profile",
        "rate (Hz)",
        "noise×",
        "model",
        "method",
        "parameter",
        "truth",
        "mean",
        "bias %",
        "bias/σ",
        "bias/CRB",
        "σ/CRB",
        "cov95",
        "RMSE",
        "conv/runs",
        "refused",
        "CRB/|truth|",
        "|ρ| > 0.9",
        "identifiability",
    ] {
        let _ = write!(page, "<th>{header}</th>");
    }
    *page += "</tr>\n";
    for s in &result.summary {
        let _ = writeln!(
            page,
            "<tr><td>{}</td><td class=\"text\">{}</td><td class=\"text\">{}</td><td>{}</td><td>{}</td><td class=\"text\">{}</td><td class=\"text\">{}</td><td class=\"text\">{}</td><td>{:.5}</td><td>{:.5}</td><td>{:.2}</td><td>{:.2}</td><td>{:.2}</td><td>{:.2}</td><td>{:.0} %</td><td>{:.3e}</td><td>{}/{}</td><td>{:.0} %</td><td>{:.3}</td><td>{:.0} % {}</td><td class=\"text\">{}</td></tr>",
            s.point,
            escape(&s.scenario),
            escape(&s.profile),
            s.sample_rate.map_or("profile".into(), |r| r.to_string()),
            s.noise_scale,
            escape(&s.model),
            escape(&s.method),
            escape(&s.parameter),
            s.truth,
            s.mean,
            100.0 * s.relative_bias,
            s.bias_over_std,
            s.bias_over_crb,
            s.std_over_crb,
            100.0 * s.coverage,
            s.rmse,
            s.converged,
            s.runs,
            100.0 * s.refusal_rate,
            s.relative_crb,
            100.0 * s.correlated_share,
            escape(&s.correlated_with),
            escape(&s.identifiability)
        );
    }
}

/// The report page of a study folder.
pub fn html(folder: &StudyFolder) -> Result<String> {
    let result = &folder.result;
    let plots = plots(folder)?;
    let mut page = String::new();
    let title = format!("aeroid study {}", escape(&result.study));
    let _ = write!(
        page,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>body{{font-family:sans-serif;margin:2em;}}table{{border-collapse:collapse;font-size:90%;}}td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right;}}td.text,th.text{{text-align:left;}}figure{{display:inline-block;margin:0.5em;}}pre{{background:#f6f6f6;padding:1em;}}</style></head><body>\n<h1>{title}</h1>\n"
    );
    let _ = writeln!(
        page,
        "<p>aeroid {}; seed {}; {} runs per sweep point; {} cases; {} rows{}.</p>",
        env!("CARGO_PKG_VERSION"),
        result.seed,
        result.runs,
        result.cases,
        result.rows,
        folder
            .fingerprint
            .as_ref()
            .map_or(String::new(), |f| format!("; fingerprint {}", escape(f)))
    );
    endings_table(&mut page, result);
    page += "</table>\n<h2>Plots</h2>\n";
    figures(&mut page, &plots);
    let histories = history_plots(folder)?;
    if !histories.is_empty() {
        page += "<h2>Time histories of each sweep point's first run</h2>\n";
        figures(&mut page, &histories);
    }
    for h in &folder.histories {
        for m in h.methods.iter().filter(|m| !m.note.is_empty()) {
            let _ = writeln!(
                page,
                "<p>{}: {} on {}: {}</p>",
                escape(&h.label),
                escape(&m.method),
                escape(&m.model),
                escape(&m.note)
            );
        }
    }
    summary_table(&mut page, result);
    page += "</table>\n";
    if let Some(text) = &folder.study_file {
        let _ = writeln!(page, "<h2>Study file</h2>\n<pre>{}</pre>", escape(text));
    }
    page += CHECK_SCRIPT;
    page += "\n</body></html>\n";
    Ok(page)
}

/// Writes the report of the study folder `folder` to `out` (default
/// `folder/report.html`); returns the path written.
pub fn write_report(folder: &Path, out: Option<&Path>) -> Result<PathBuf> {
    let study = StudyFolder::read(folder)?;
    let page = html(&study)?;
    let path = out.map_or_else(|| folder.join(REPORT_FILE), Path::to_path_buf);
    aeroid_core::atomic::write_text(&path, &page)?;
    Ok(path)
}
