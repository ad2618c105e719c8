//! The study report (`aeroid report`) drawn by a real browser: headless
//! Chromium loads the page from disk (no server), the page's script
//! measures every plot's drawn elements on screen, and the test reads the
//! rendered DOM back. Every plot must be drawn (elements with a size), carry
//! its axis labels and its series, and the page must hold the summary and
//! the study file. Skipped, with the reason printed, where Chromium is not
//! installed (CI installs Debian's `chromium`).

use crate::common;
use std::path::Path;
use std::process::Command;

const STUDY: &str = r#"
name = "report-test"
scenarios = ["attas-lateral-multistep"]
profile = "flight-test-25hz"
models = ["attas-lateral"]
methods = ["ee", "ebm"]
runs = 2
seed = 5
[sweep]
sample_rate = ["12.5 Hz", "25 Hz"]
"#;

fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|name| Command::new(name).arg("--version").output().is_ok())
}

#[test]
fn every_plot_of_the_report_is_drawn_in_a_browser() {
    let Some(browser) = chromium() else {
        println!("SKIPPED: no Chromium (apt-get install chromium) to render the report");
        return;
    };
    let folder = common::temp_folder("report_chromium");
    let study = common::write(&folder, "report-test.toml", STUDY);
    let out = folder.join("out");
    let aeroid = env!("CARGO_BIN_EXE_aeroid");
    let run = |args: &[&str]| {
        let output = Command::new(aeroid).args(args).output().unwrap();
        assert!(
            output.status.success(),
            "aeroid {args:?}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
    };
    run(&[
        "study",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    run(&["report", out.to_str().unwrap()]);
    let page = out.join("report.html");
    let dom = render(browser, &page);
    assert!(
        dom.contains("data-checked=\"yes\""),
        "the page's script did not run"
    );
    // 18 parameters, two plots each; per sweep point a proof of match and
    // estimation before modelling's smoothed coefficients.
    let figures: Vec<&str> = dom.split("<figure class=\"plot\"").skip(1).collect();
    assert_eq!(figures.len(), 40);
    for figure in &figures {
        let drawn: usize = figure
            .split("data-drawn=\"")
            .nth(1)
            .and_then(|rest| rest.split('"').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or(0);
        let title = figure.split('"').nth(1).unwrap_or("");
        // Axes, grid and labels alone are some tens of elements; the
        // series add their points.
        assert!(drawn >= 40, "{title}: {drawn} elements drawn");
        assert!(
            figure.contains("<polyline") || figure.contains("<circle"),
            "{title}: no series"
        );
        if title.contains("proof of match") {
            for label in ["time (s)", "measured", "ee", "ebm", "beta", "ny"] {
                assert!(figure.contains(label), "{title}: no '{label}'");
            }
        } else if title.contains("smoothed coefficients") {
            for label in ["time (s)", "truth", "ebm smoothed", "±1.96σ", "Cl", "Cn"] {
                assert!(figure.contains(label), "{title}: no '{label}'");
            }
        } else if title.contains("error against the sweep") {
            assert!(
                figure.contains("sample rate (Hz)") && figure.contains("mean − truth"),
                "{title}"
            );
            assert!(
                figure.contains("ee attas-lateral-multistep"),
                "{title}: no legend"
            );
        } else {
            assert!(
                figure.contains(">\ncase\n<") || figure.contains(">case<"),
                "{title}: no x label"
            );
            assert!(figure.contains("truth"), "{title}: no truth line");
        }
    }
    assert!(dom.contains("<h2>Summary</h2>") && dom.contains("Cl_p"));
    assert!(
        dom.contains("report-test") && dom.contains("sample_rate"),
        "no study file"
    );
}

/// The DOM after the page loaded and its script ran.
fn render(browser: &str, page: &Path) -> String {
    let output = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{browser}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).to_string()
}

/// One sweep point, output error and estimation before modelling: what the
/// report's history plots are drawn from.
const HISTORY_STUDY: &str = r#"
name = "history-test"
scenarios = ["attas-lateral-multistep"]
profile = "flight-test-25hz"
models = ["attas-lateral"]
methods = ["oem", "ebm"]
runs = 2
seed = 7
"#;

/// The histories a study keeps of a point's first run are the record and
/// what the estimates make of it: output error's model, simulated on the
/// record from its first samples with nothing adjusted, reproduces every
/// output about as well as output error's own fit (which also estimates the
/// initial state), and the smoothed coefficients of estimation before
/// modelling lie on the simulator's true coefficients within their own σ.
/// Only the first run keeps histories.
#[test]
fn the_first_run_keeps_the_proof_of_match_and_smoothed_histories() {
    use aeroid::estimation::estimate::History;
    use aeroid::eval::histories::CaseHistories;
    use aeroid::eval::study::{Case, Study};
    let folder = common::temp_folder("report_histories");
    let path = common::write(&folder, "history-test.toml", HISTORY_STUDY);
    let study = Study::load(crate::common::registry(), path.to_str().unwrap()).unwrap();
    assert!(
        study
            .run_case_with_histories(Case { point: 0, run: 1 }, false)
            .1
            .is_none()
    );
    let (rows, kept) = study.run_case_with_histories(Case { point: 0, run: 0 }, true);
    let histories = kept.expect("the first run keeps its histories");
    let names: Vec<&str> = histories.measured.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["beta", "p", "r", "roll", "ny"]);
    let method = |name: &str| histories.methods.iter().find(|m| m.method == name).unwrap();
    let oem = method("oem");
    assert!(oem.note.is_empty(), "{}", oem.note);
    assert!(
        rows.iter()
            .any(|r| r.method == "oem" && r.status == aeroid::eval::row::RowStatus::Converged)
    );
    let rms = |a: &[f64], b: &[f64]| {
        (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
    };
    let fit = study.run_case(Case { point: 0, run: 0 });
    assert_eq!(fit.len(), rows.len(), "keeping histories changes no row");
    for predicted in &oem.predicted {
        let measured: &History = histories
            .measured
            .iter()
            .find(|s| s.name == predicted.name)
            .unwrap();
        // The proof of match is at the measured samples of the fitting
        // window, which starts at the record's first sample.
        let values: Vec<f64> = predicted
            .times
            .iter()
            .map(|t| {
                let k = measured.times.iter().position(|m| m == t).unwrap();
                measured.values[k]
            })
            .collect();
        let residual = rms(&values, &predicted.values);
        let spread = rms(&values, &vec![0.0; values.len()]);
        println!(
            "{}: residual rms {residual:.3e}, signal rms {spread:.3e}",
            predicted.name
        );
        // The residual is the sensor noise (σ ≈ 2e-3 in the angles and
        // rates) and, in roll, the drift of a slightly different initial
        // rate integrated over 60 s (16 % of the signal): anything much
        // beyond is a misaligned or wrongly simulated history.
        assert!(
            residual < 0.2 * spread,
            "{}: {residual} of {spread}",
            predicted.name
        );
    }
    let ebm = method("ebm");
    assert_eq!(ebm.estimated.len(), 6);
    assert_eq!(
        histories.truth.len(),
        6,
        "the true coefficients are kept beside them"
    );
    for smoothed in &ebm.estimated {
        let truth = histories
            .truth
            .iter()
            .find(|s| s.name == smoothed.name)
            .unwrap();
        let at = interpolated(truth, &smoothed.times);
        let error = rms(&at, &smoothed.values);
        let sigma = rms(&smoothed.sigma, &vec![0.0; smoothed.sigma.len()]);
        println!(
            "{}: rms error {error:.3e}, rms σ {sigma:.3e}",
            smoothed.name
        );
        // A consistent smoother's RMS error is its RMS σ (measured: 0.66
        // to 1.0 of it); a shifted or misaligned truth is many σ off.
        assert!(
            error < 1.5 * sigma,
            "{}: rms error {error} against rms σ {sigma}",
            smoothed.name
        );
    }
    // Written and read back whole.
    histories.write(&folder).unwrap();
    assert_eq!(CaseHistories::read_all(&folder).unwrap(), vec![histories]);
}

/// A series' values interpolated linearly at `times`.
fn interpolated(series: &aeroid::estimation::estimate::History, times: &[f64]) -> Vec<f64> {
    times
        .iter()
        .map(|&t| {
            let k = series
                .times
                .partition_point(|&s| s <= t)
                .clamp(1, series.times.len() - 1);
            let (t0, t1) = (series.times[k - 1], series.times[k]);
            let w = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
            series.values[k - 1] * (1.0 - w) + series.values[k] * w
        })
        .collect()
}

/// A report reads the rows of the first `SHOWN_RUNS` runs of each point
/// only: the page and its memory stay bounded however many runs a study
/// has, while the summary it prints is over every run.
#[test]
fn the_report_plots_a_bounded_share_of_the_runs() {
    use aeroid::eval::journal::Shard;
    use aeroid::eval::report::{SHOWN_RUNS, StudyFolder};
    use aeroid::eval::study::{self, Study};
    let folder = common::temp_folder("report_bounded");
    let mut study = Study::load(crate::common::registry(), "attas-lateral-acceptance").unwrap();
    study.methods = vec!["ee".into()];
    study.set_runs(SHOWN_RUNS + 1, "runs").unwrap();
    study
        .run_journaled(&folder, Shard::default(), false, 2, &|_| {})
        .unwrap();
    study::assemble(std::slice::from_ref(&folder), &folder).unwrap();
    let read = StudyFolder::read(&folder).unwrap();
    assert!(read.result.summary.iter().all(|s| s.runs == SHOWN_RUNS + 1));
    assert!(read.rows.iter().all(|r| r.run < SHOWN_RUNS));
    let per_case = read.rows.iter().filter(|r| r.run == 0).count();
    assert!(per_case > 0);
    assert_eq!(read.rows.len(), SHOWN_RUNS * per_case);
    // A runs.csv cut after its last full row, or emptied, is refused: it
    // no longer holds the rows study.json summarises.
    let runs = folder.join("runs.csv");
    let text = std::fs::read_to_string(&runs).unwrap();
    let cut = &text[..text[..text.len() - 1].rfind('\n').unwrap() + 1];
    for (what, content) in [("cut", cut), ("empty", "")] {
        std::fs::write(&runs, content).unwrap();
        let error = StudyFolder::read(&folder).err().map(|e| e.to_string());
        let error = error.unwrap_or_else(|| panic!("a {what} runs.csv was read"));
        assert!(
            error.contains("runs.csv") && error.contains("study.json summarises"),
            "{what}: {error}"
        );
    }
}
