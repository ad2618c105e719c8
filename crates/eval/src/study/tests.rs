use super::*;

fn row(run: usize, status: RowStatus, estimate: f64, standard_error: f64) -> Row {
    Row {
        point: 0,
        scenario: "s".into(),
        profile: "p".into(),
        turbulence: String::new(),
        input_scale: 1.0,
        sample_rate: None,
        noise_scale: 1.0,
        resolution_scale: 1.0,
        missing: String::new(),
        channel_rates: String::new(),
        settings: String::new(),
        run,
        turbulence_seed: 0,
        recorder_seed: 0,
        model: "m".into(),
        method: "oem".into(),
        status,
        reason: String::new(),
        diagnoses: String::new(),
        parameter: "Cl_p".into(),
        estimate,
        standard_error,
        truth: Some(-0.4),
        error: Some(estimate + 0.4),
        inside_95: Some((estimate + 0.4).abs() <= 1.96 * standard_error),
        correlated_with: String::new(),
        max_correlation: None,
        condition_number: None,
    }
}

/// Fits are counted once each, whatever their parameter rows: two
/// converged fits of two parameters each, one unidentified fit and one
/// refused (a single row) give 2, 1 and 1, each with its first row.
#[test]
fn endings_count_fits_by_status() {
    let mut rows = Vec::new();
    for run in 0..2 {
        rows.push(row(run, RowStatus::Converged, -0.4, 0.01));
        rows.push(Row {
            parameter: "Cl_r".into(),
            ..row(run, RowStatus::Converged, 0.1, 0.01)
        });
    }
    rows.push(Row {
        reason: "Cl_r".into(),
        ..row(2, RowStatus::Unidentified, -0.4, f64::INFINITY)
    });
    rows.push(Row {
        reason: "oem needs channels 'p'".into(),
        parameter: String::new(),
        ..row(3, RowStatus::Refused, f64::NAN, f64::NAN)
    });
    let mut summariser = Summariser::default();
    summariser.add(&rows);
    let result = StudyResult::of("s", 1, 4, 4, &summariser);
    assert_eq!(result.rows, rows.len());
    let endings: Vec<(RowStatus, usize, usize)> = result
        .endings
        .iter()
        .map(|e| (e.status, e.count, e.first.run))
        .collect();
    assert_eq!(
        endings,
        [
            (RowStatus::Converged, 2, 0),
            (RowStatus::Unidentified, 1, 2),
            (RowStatus::Refused, 1, 3)
        ]
    );
}

/// Three converged estimates −0.41, −0.40, −0.36 (mean −0.39, bias
/// +0.01, sample std √(0.0014/2) = 0.0264575), CRBs 0.01, 0.02, 0.03 (mean 0.02, so the
/// first run's interval misses the truth: coverage 2/3), two of them
/// diagnosed and counted all the same; a diverged fit (wild value, left
/// out of the statistics) and a failed one (no parameter row) are
/// counted, the diverged one's diagnosis too.
#[test]
fn summary_statistics_use_converged_fits_and_count_the_rest() {
    let mut rows = vec![
        row(0, RowStatus::Converged, -0.41, 0.001),
        row(1, RowStatus::Converged, -0.40, 0.02),
        row(2, RowStatus::Converged, -0.36, 0.03),
        row(3, RowStatus::Diverged, 99.0, 1.0),
    ];
    rows[1].diagnoses = "coloured_residuals process_noise".into();
    rows[2].diagnoses = "coloured_residuals".into();
    rows[3].diagnoses = "poor_fit".into();
    rows[0].standard_error = 0.01;
    rows[0].inside_95 = Some(false);
    let mut failed = row(4, RowStatus::Failed, f64::NAN, f64::NAN);
    (failed.parameter, failed.truth) = (String::new(), None);
    rows.push(failed);
    let summary = summarise(&rows);
    assert_eq!(summary.len(), 1);
    let s = &summary[0];
    assert_eq!(
        (s.diagnosed.as_str(), s.diagnosed_fits),
        ("coloured_residuals:2 poor_fit:1 process_noise:1", 3)
    );
    assert_eq!(
        (s.runs, s.converged, s.diverged, s.failed, s.iteration_limit),
        (5, 3, 1, 1, 0)
    );
    let std = 0.0007_f64.sqrt();
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    assert!(close(s.mean, -0.39) && close(s.bias, 0.01), "{s:?}");
    assert!(close(s.std, std) && close(s.bias_over_std, 0.01 / std));
    assert!(close(s.mean_crb, 0.02) && close(s.std_over_crb, std / 0.02));
    assert!(close(s.bias_over_crb, 0.5) && close(s.relative_bias, 0.025));
    assert!(close(s.bias_standard_error, std / 3f64.sqrt()));
    assert!(close(s.coverage, 2.0 / 3.0));
    // Errors −0.01, 0, +0.04; two of five runs failed to converge.
    assert!(close(s.rmse, (0.0017_f64 / 3.0).sqrt()), "{}", s.rmse);
    assert!(close(s.failure_rate, 0.4) && close(s.refusal_rate, 0.0));
    assert!(close(s.relative_crb, 0.05));
    assert_eq!(s.identifiability, "identifiable");
}

/// The verdict: a CRB above the parameter's size, none converged, a
/// CRB over 20 % or mostly entangled with another parameter.
#[test]
fn identifiability_verdicts() {
    use crate::summary::verdict;
    assert_eq!(verdict(10, 0.05, 0.0), "identifiable");
    assert_eq!(verdict(10, 0.3, 0.0), "weak");
    assert_eq!(verdict(10, 0.05, 0.8), "weak");
    assert_eq!(verdict(10, 1.5, 0.0), "not identifiable");
    assert_eq!(verdict(0, f64::NAN, f64::NAN), "not identifiable");
    // Truth 0: the relative CRB is infinite; correlations decide.
    assert_eq!(verdict(10, f64::INFINITY, 0.0), "identifiable");
}

/// A model name longer than the header (as a path to a model file is)
/// widens its column instead of pushing the numbers out of line: the
/// header and every row have the same width.
#[test]
fn table_columns_fit_long_model_names() {
    let mut long = row(0, RowStatus::Converged, -0.41, 0.01);
    long.model = "models/attas-lateral-with-long-name.toml".into();
    let rows = vec![long, row(0, RowStatus::Converged, -0.40, 0.01)];
    let mut summariser = Summariser::default();
    summariser.add(&rows);
    let result = StudyResult::of("s", 0, 1, 1, &summariser);
    let table = result.table();
    let widths: Vec<usize> = table
        .lines()
        .filter(|line| !line.starts_with("point "))
        .map(|line| line.chars().count())
        .collect();
    assert_eq!(widths.len(), 3, "{table}");
    assert!(widths.iter().all(|w| *w == widths[0]), "{table}");
}

#[test]
fn case_streams_are_distinct_per_point_and_run() {
    let stream = |point, run| Case { point, run }.stream();
    assert_eq!(stream(0, 7), 7);
    assert_eq!(stream(1, 0), 1 << 32);
    assert_ne!(stream(1, 0), stream(0, 1));
}

/// The header of `rows` written as CSV, split at its commas.
fn csv_header<T: serde::Serialize>(rows: &[T]) -> Vec<String> {
    let mut writer = csv::Writer::from_writer(Vec::new());
    for row in rows {
        writer.serialize(row).unwrap();
    }
    let text = String::from_utf8(writer.into_inner().unwrap()).unwrap();
    let header = text.lines().next().unwrap().to_string();
    header.split(',').map(str::to_string).collect()
}

/// `runs.csv` and `summary.csv` write the axes' columns right after
/// `point`, in [`Axis::COLUMNS`] order, under their [`Axis::column`] names;
/// both orders hold every axis, [`Axis::index`] its place in the product.
#[test]
fn axis_columns_follow_the_axis_order() {
    for (i, axis) in Axis::PRODUCT.iter().enumerate() {
        assert_eq!(axis.index(), i);
        assert!(Axis::COLUMNS.contains(axis));
    }
    let columns: Vec<&str> = Axis::COLUMNS.iter().map(|a| a.column()).collect();
    let rows = vec![row(0, RowStatus::Converged, -0.41, 0.01)];
    for header in [csv_header(&rows), csv_header(&summarise(&rows))] {
        assert_eq!(header[0], "point");
        assert_eq!(header[1..=columns.len()], columns);
    }
}

/// A row made from a point's axis values gives them back, and the label
/// names every axis off its default.
#[test]
fn rows_carry_a_points_axis_values() {
    let axes = AxisValues {
        scenario: "s".into(),
        profile: "p".into(),
        turbulence: "light".into(),
        input_scale: 0.5,
        sample_rate: Some(10.0),
        noise_scale: 2.0,
        resolution_scale: 4.0,
        missing: "alpha".into(),
        channel_rates: "beta:2 Hz".into(),
        settings: "oem.max_iterations=3".into(),
    };
    let row = Row::template(3, axes.clone(), 7, 1, 2);
    assert_eq!((row.point, row.run, row.status), (3, 7, RowStatus::Failed));
    assert_eq!(row.axes(), axes);
    assert_eq!(summarise(&[row]).len(), 0);
    assert_eq!(
        axes.label(),
        "s recorded by p turbulence light inputs×0.5 @10 Hz noise×2 lsb×4 without alpha rates beta:2 Hz settings oem.max_iterations=3"
    );
}
