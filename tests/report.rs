//! The study report (`aeroid report`) drawn by a real browser: headless
//! Chromium loads the page from disk (no server), the page's script
//! measures every plot's drawn elements on screen, and the test reads the
//! rendered DOM back. Every plot must be drawn (elements with a size), carry
//! its axis labels and its series, and the page must hold the summary and
//! the study file. Skipped, with the reason printed, where Chromium is not
//! installed (CI installs Debian's `chromium`).

mod common;

use std::path::Path;
use std::process::Command;

const STUDY: &str = r#"
name = "report-test"
scenarios = ["attas-lateral-multistep"]
profile = "flight-test-25hz"
models = ["attas-lateral"]
methods = ["ee"]
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
    // 18 parameters, two plots each.
    let figures: Vec<&str> = dom.split("<figure class=\"plot\"").skip(1).collect();
    assert_eq!(figures.len(), 36);
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
        if title.contains("error against the sweep") {
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
