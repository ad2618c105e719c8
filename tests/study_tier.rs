//! The study tier: tests that run whole bundled studies (minutes of CPU)
//! and assert the numbers docs/findings.md gives from them. They are
//! `#[ignore]`d in the default run and run with
//! `cargo test --release --test study_tier -- --ignored`.

/// The bundled study `name` with its `methods` line replaced by
/// `methods = METHODS` (a TOML list), written to a scratch folder and loaded.
fn with_methods(name: &str, methods: &str) -> aeroid::eval::study::Study {
    let bundled = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("studies/{name}.toml")),
    )
    .unwrap();
    let text: String = bundled
        .lines()
        .map(|line| {
            if line.starts_with("methods = ") {
                format!("methods = {methods}")
            } else {
                line.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let folder = std::env::temp_dir().join(format!("aeroid-study-tier-{name}"));
    std::fs::create_dir_all(&folder).unwrap();
    let path = folder.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    aeroid::eval::study::Study::load(
        &aeroid::estimation::registry::Registry::built_in(),
        path.to_str().unwrap(),
    )
    .unwrap()
}

mod sample_rate {
    //! The sample-rate sweeps of docs/findings.md ("Sample rate, every
    //! estimator" and "The sampling rule"): output error and the filters on
    //! the ATTAS (`studies/attas-longitudinal-rates.toml` and
    //! `attas-lateral-rates.toml`, their seed, runs and rates, these four
    //! methods alone), the HANSA-3 and the CDRW (`studies/hansa3-rates.toml`,
    //! `cdrw-longitudinal-rates.toml`, `cdrw-lateral-rates.toml` as bundled).
    //!
    //! A derivative is held at a rate when at least half the fits converged
    //! and the mean's |bias| lies inside 1.96 times the mean Cramér–Rao bound
    //! (with 20 runs the mean's own scatter is σ_MC/√20, a fifth of one bound
    //! where the bounds are honest). Each cell is the lowest swept rate from
    //! which on, at every higher swept rate too, it is held ("never": not at
    //! the highest). The studies are seeded, so the cells are asserted as
    //! they are: the margin is the rule's 1.96 bounds, and a change to a
    //! method or to the recorder that moves a cell shows.
    //!
    //! Study tier (minutes of CPU): `cargo test --release --test
    //! study_tier -- --ignored`.

    use aeroid::eval::study::{Study, StudyResult};

    /// The bundled study `name` with output error and the filters alone
    /// (same seed, runs and rates, so the same flights).
    fn filters_of(name: &str) -> Study {
        super::with_methods(name, r#"["oem", "fem", "ekf", "ukf"]"#)
    }

    fn rate_text(rate: f64) -> String {
        format!("{rate}")
    }

    /// Per method, each derivative's lowest held rate ("never" when not held
    /// at the highest), in the summary's parameter order: `method: name rate,
    /// name rate, …`.
    fn lowest_held_rates(result: &StudyResult) -> Vec<String> {
        let mut methods: Vec<String> = Vec::new();
        for s in &result.summary {
            if !methods.contains(&s.method) {
                methods.push(s.method.clone());
            }
        }
        let mut lines = Vec::new();
        for method in &methods {
            let rows: Vec<_> = result
                .summary
                .iter()
                .filter(|s| &s.method == method && s.truth.is_finite())
                .collect();
            let mut parameters: Vec<String> = Vec::new();
            for s in &rows {
                if !parameters.contains(&s.parameter) {
                    parameters.push(s.parameter.clone());
                }
            }
            let cells: Vec<String> = parameters
                .iter()
                .map(|name| {
                    let mut points: Vec<_> = rows.iter().filter(|s| &s.parameter == name).collect();
                    points.sort_by(|a, b| a.sample_rate.partial_cmp(&b.sample_rate).unwrap());
                    let mut lowest = None;
                    for s in points.iter().rev() {
                        let held = 2 * s.converged >= s.runs && s.bias.abs() <= 1.96 * s.mean_crb;
                        if !held {
                            break;
                        }
                        lowest = s.sample_rate;
                    }
                    let cell = lowest.map_or("never".to_string(), rate_text);
                    format!("{name} {cell}")
                })
                .collect();
            lines.push(format!("{method}: {}", cells.join(", ")));
        }
        lines
    }

    /// Per method, the lowest rate from which every derivative is held and
    /// the highest swept rate below it ("never" when none), as `method from
    /// (not below)`.
    fn every_derivative_held(result: &StudyResult) -> Vec<String> {
        lowest_held_rates(result)
            .iter()
            .map(|line| {
                let (method, cells) = line.split_once(": ").unwrap();
                let mut highest = Some(0.0_f64);
                for cell in cells.split(", ") {
                    let rate = cell.rsplit(' ').next().unwrap();
                    highest = match (highest, rate.parse::<f64>()) {
                        (Some(h), Ok(r)) => Some(h.max(r)),
                        _ => None,
                    };
                }
                format!(
                    "{method} {}",
                    highest.map_or("never".to_string(), rate_text)
                )
            })
            .collect()
    }

    fn assert_cells(result: &StudyResult, expected: &[&str]) {
        let measured = lowest_held_rates(result);
        assert_eq!(measured, expected, "\n{}", result.table());
    }

    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn attas_longitudinal_rates_output_error_and_the_filters() {
        let result = filters_of("attas-longitudinal-rates")
            .run(0, &|_| {})
            .unwrap();
        println!("{}", lowest_held_rates(&result).join("\n"));
        assert_cells(
            &result,
            &[
                "oem: CD_0 5, CL_0 5, CL_alpha 5, CL_de 1, CL_q 5, Cm_0 0.5, Cm_alpha 0.5, Cm_de 5, Cm_q 1, e 5",
                "fem: CD_0 2, CL_0 2, CL_alpha 2, CL_de 2, CL_q 2, Cm_0 2, Cm_alpha 2, Cm_de 2, Cm_q 2, e 2",
                "ekf: CD_0 5, CL_0 5, CL_alpha 5, CL_de 5, CL_q 5, Cm_0 5, Cm_alpha 5, Cm_de 5, Cm_q 5, e 5",
                "ukf: CD_0 never, CL_0 never, CL_alpha never, CL_de 5, CL_q never, Cm_0 never, Cm_alpha never, Cm_de 5, Cm_q 5, e never",
            ],
        );
    }

    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn attas_lateral_rates_output_error_and_the_filters() {
        let result = filters_of("attas-lateral-rates").run(0, &|_| {}).unwrap();
        println!("{}", lowest_held_rates(&result).join("\n"));
        assert_cells(
            &result,
            &[
                "oem: CY_0 1, CY_beta 1, CY_da 1, CY_dr 1, CY_p 2, CY_r 5, Cl_0 1, Cl_beta 1, Cl_da 1, Cl_dr 1, Cl_p 1, Cl_r 5, Cn_0 1, Cn_beta 5, Cn_da 5, Cn_dr 5, Cn_p 5, Cn_r 5",
                "fem: CY_0 2, CY_beta 2, CY_da 2, CY_dr 2, CY_p 2, CY_r 2, Cl_0 2, Cl_beta 2, Cl_da 2, Cl_dr 2, Cl_p 2, Cl_r 2, Cn_0 2, Cn_beta 5, Cn_da 2, Cn_dr 2, Cn_p 2, Cn_r 2",
                "ekf: CY_0 2, CY_beta 2, CY_da 2, CY_dr 2, CY_p 2, CY_r 5, Cl_0 2, Cl_beta 2, Cl_da 2, Cl_dr 5, Cl_p 2, Cl_r 2, Cn_0 2, Cn_beta 5, Cn_da 5, Cn_dr 2, Cn_p 5, Cn_r 2",
                "ukf: CY_0 2, CY_beta 2, CY_da 2, CY_dr 2, CY_p 2, CY_r 5, Cl_0 2, Cl_beta 2, Cl_da 2, Cl_dr 2, Cl_p 2, Cl_r 2, Cn_0 2, Cn_beta 5, Cn_da 2, Cn_dr 2, Cn_p 5, Cn_r 2",
            ],
        );
    }

    /// The sampling rule's table: per method, the lowest rate from which
    /// every derivative is held.
    fn assert_every_derivative(name: &str, expected: &[&str]) {
        let result = Study::load(&aeroid::estimation::registry::Registry::built_in(), name)
            .unwrap()
            .run(0, &|_| {})
            .unwrap();
        println!("{name}\n{}", lowest_held_rates(&result).join("\n"));
        assert_eq!(
            every_derivative_held(&result),
            expected,
            "{name}\n{}\n{}",
            lowest_held_rates(&result).join("\n"),
            result.table()
        );
    }

    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn hansa3_rates_against_the_sampling_rule() {
        assert_every_derivative("hansa3-rates", &["oem 25", "fem 25", "ekf 25", "ukf 25"]);
    }

    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn cdrw_longitudinal_rates_against_the_sampling_rule() {
        assert_every_derivative(
            "cdrw-longitudinal-rates",
            &["oem 25", "fem 25", "ekf 25", "ukf 25"],
        );
    }

    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn cdrw_lateral_rates_against_the_sampling_rule() {
        assert_every_derivative(
            "cdrw-lateral-rates",
            &["oem 25", "fem 25", "ekf 50", "ukf 25"],
        );
    }

    /// The modes the sampling rule is read against: the eigenvalues of the
    /// linearisation at each swept scenario's trim (`aeroid linearise`), as
    /// docs/findings.md ("The sampling rule") gives them, to the digits given
    /// (half a unit of the last one).
    #[test]
    fn the_swept_scenarios_modes() {
        use aeroid::analysis::linearize::{ModeKind, linearize, natural_frequency};
        for (scenario, kind, stated, half_unit) in [
            ("attas-elevator-3211", ModeKind::ShortPeriod, 0.91, 0.005),
            ("attas-lateral-multistep", ModeKind::DutchRoll, 1.50, 0.005),
            ("attas-lateral-multistep", ModeKind::Roll, 1.60, 0.005),
            (
                "hansa3-elevator-multistep",
                ModeKind::ShortPeriod,
                3.20,
                0.005,
            ),
            ("cdrw-longitudinal", ModeKind::ShortPeriod, 18.0, 0.05),
            ("cdrw-lateral", ModeKind::Roll, 23.0, 0.05),
            ("cdrw-lateral", ModeKind::DutchRoll, 3.8, 0.05),
        ] {
            let loaded = aeroid::sim::scenario::Scenario::load(scenario).unwrap();
            let simulation = aeroid::sim::Simulation::prepare(&loaded).unwrap();
            let modes =
                linearize(&simulation.model, &simulation.trim, &simulation.winds[0]).modes();
            let mode = modes
                .iter()
                .find(|m| m.kind == kind)
                .unwrap_or_else(|| panic!("{scenario}: no {kind:?} in {modes:?}"));
            let omega = natural_frequency(mode.eigenvalue);
            println!("{scenario} {kind:?}: {omega:.3} rad/s");
            assert!(
                (omega - stated).abs() <= half_unit,
                "{scenario} {kind:?}: {omega:.4} rad/s, stated {stated}"
            );
        }
    }
}

mod qar_resolution {
    //! QAR studies, Fourier-transform regression's rows (study tier). The
    //! QAR's resolution and noise (docs/findings.md, "QAR resolution and
    //! noise"): `studies/qar-resolution-noise.toml` with its seed, runs and
    //! sweep (every channel's resolution ×0, 1, 2, 4 and its noise ×0, 1, 2,
    //! 10 runs a point, each record derived), Fourier-transform regression
    //! alone, the method that converges in every run.
    //!
    //! A parameter is held at a point when the mean's |bias| lies inside 1.96
    //! times the mean Cramér–Rao bound (the rule of the sample-rate studies).
    //! Asserted at every one of the 12 points, the noise-free unquantized
    //! record included: every fit converges; CD_0, CD_δf, CL_0, CL_δf, Cm_0,
    //! Cm_δe, Cm_δf, Cm_q and e are held; Cn_β and Cl_p are lost far beyond
    //! their bounds, both too small in magnitude (Cn_β's relative bias below
    //! −50 % and beyond 20 bounds, Cl_p's above +30 %, Cl_p being negative,
    //! and beyond 5 bounds): the 1 Hz frame and the geometric sideslip, not
    //! the words' resolution nor the sensors' noise.
    //!
    //! Study tier: `cargo test --release --test study_tier --
    //! --ignored`.

    use aeroid::eval::study::Study;

    /// The bundled study `name` with `fdee` alone (same seed, runs and
    /// sweep, so the same flights).
    fn fdee_of(name: &str) -> Study {
        super::with_methods(name, r#"["fdee"]"#)
    }

    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn qar_resolution_and_noise_do_not_decide_what_is_held() {
        let study = fdee_of("qar-resolution-noise");
        let result = study.run(0, &|_| {}).unwrap();
        let table = result.table();
        let points: std::collections::BTreeSet<usize> =
            result.summary.iter().map(|s| s.point).collect();
        assert_eq!(points.len(), 12, "{table}");
        for point in points {
            let row = |name: &str| {
                result
                    .summary
                    .iter()
                    .find(|s| s.point == point && s.parameter == name)
                    .unwrap_or_else(|| panic!("point {point} {name}\n{table}"))
            };
            for s in result.summary.iter().filter(|s| s.point == point) {
                assert_eq!(
                    s.converged, s.runs,
                    "point {point} {}\n{table}",
                    s.parameter
                );
            }
            for name in [
                "CD_0", "CD_df", "CL_0", "CL_df", "Cm_0", "Cm_de", "Cm_df", "Cm_q", "e",
            ] {
                let s = row(name);
                assert!(
                    s.bias.abs() <= 1.96 * s.mean_crb,
                    "point {point} {name} held: {:.2} CRB\n{table}",
                    s.bias / s.mean_crb
                );
            }
            let s = row("Cn_beta");
            assert!(
                s.relative_bias < -0.5 && s.bias.abs() > 20.0 * s.mean_crb,
                "point {point} Cn_beta: {:+.0} %, {:.1} CRB\n{table}",
                100.0 * s.relative_bias,
                s.bias / s.mean_crb
            );
            let s = row("Cl_p");
            assert!(
                s.relative_bias > 0.3 && s.bias.abs() > 5.0 * s.mean_crb,
                "point {point} Cl_p: {:+.0} %, {:.1} CRB\n{table}",
                100.0 * s.relative_bias,
                s.bias / s.mean_crb
            );
            println!(
                "point {point} (noise ×{}, resolution ×{}): Cn_beta {:+.0} % ({:.0} CRB), Cl_p {:+.0} % ({:.0} CRB)",
                s.noise_scale,
                s.resolution_scale,
                100.0 * row("Cn_beta").relative_bias,
                row("Cn_beta").bias.abs() / row("Cn_beta").mean_crb,
                100.0 * s.relative_bias,
                s.bias.abs() / s.mean_crb
            );
        }
    }

    /// The twenty turbulence seeds of `studies/transport-approach-qar.toml`
    /// (its seed and runs) recorded by `flight-test-25hz`, Fourier-transform
    /// regression alone: it converges in every run and holds every one of the
    /// 20 parameters the a-priori analysis calls identifiable on the QAR
    /// (|mean bias| ≤ 1.96 mean CRB), where on the derived QAR it holds 10
    /// (`the_qar_approach_over_turbulence_seeds` in tests/simulation/angular_rates.rs).
    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn the_approach_at_25_hz_is_held_by_fourier_transform_regression() {
        let result = fdee_of("transport-approach-qar").run(0, &|_| {}).unwrap();
        let table = result.table();
        let rows: Vec<_> = result
            .summary
            .iter()
            .filter(|s| s.profile == "flight-test-25hz")
            .collect();
        for name in [
            "CD_0", "CD_df", "CL_0", "CL_alpha", "CL_df", "CY_beta", "CY_p", "CY_r", "Cl_beta",
            "Cl_da", "Cl_p", "Cl_r", "Cm_0", "Cm_alpha", "Cm_de", "Cm_df", "Cm_q", "Cn_beta",
            "Cn_r", "e",
        ] {
            let s = rows
                .iter()
                .find(|s| s.parameter == name)
                .unwrap_or_else(|| panic!("{name}\n{table}"));
            assert_eq!(s.converged, s.runs, "{name}\n{table}");
            assert!(
                s.bias.abs() <= 1.96 * s.mean_crb,
                "{name} at 25 Hz: {:.2} CRB, {:+.2} %\n{table}",
                s.bias / s.mean_crb,
                100.0 * s.relative_bias
            );
            println!(
                "{name}: {:+.2} CRB, {:+.2} %",
                s.bias / s.mean_crb,
                100.0 * s.relative_bias
            );
        }
    }
}

mod turbulence {
    //! The turbulence sweep (docs/findings.md, "Turbulence: output error,
    //! filter error and the augmented filters"): `studies/turbulence-sweep.toml`
    //! as bundled, the ATTAS lateral multistep on flight-test-25hz in still
    //! air and in light, moderate and severe Dryden turbulence, 20 runs
    //! each, output error, filter error, the EKF and the UKF.
    //!
    //! Per intensity and method over the 18 derivatives: the converged
    //! fits, the median of |bias|/|truth| and the range of σ_MC/CRB and of
    //! the 95 % coverage. With 20 runs σ_MC itself scatters by about
    //! 1/√38 ≈ 16 %, so bounds that are honest or conservative give
    //! σ_MC/CRB below 1.5 on every one of 18 derivatives (three of its
    //! standard deviations above 1), and a coverage of 95 % ± 5 % per
    //! derivative, at least 75 % on all 18.

    use aeroid::eval::summary::SummaryRow;

    fn rows<'a>(summary: &'a [SummaryRow], turbulence: &str, method: &str) -> Vec<&'a SummaryRow> {
        let rows: Vec<_> = summary
            .iter()
            .filter(|s| s.turbulence == turbulence && s.method == method)
            .collect();
        assert_eq!(rows.len(), 18, "{turbulence} {method}");
        rows
    }

    fn median_relative_bias(rows: &[&SummaryRow]) -> f64 {
        let mut values: Vec<f64> = rows.iter().map(|s| s.relative_bias.abs()).collect();
        values.sort_by(f64::total_cmp);
        (values[8] + values[9]) / 2.0
    }

    fn largest(rows: &[&SummaryRow], f: impl Fn(&SummaryRow) -> f64) -> f64 {
        rows.iter().map(|s| f(s)).fold(f64::NEG_INFINITY, f64::max)
    }

    fn smallest(rows: &[&SummaryRow], f: impl Fn(&SummaryRow) -> f64) -> f64 {
        rows.iter().map(|s| f(s)).fold(f64::INFINITY, f64::min)
    }

    fn count(row: &SummaryRow, kind: &str) -> usize {
        row.diagnosed
            .split_whitespace()
            .find_map(|item| item.strip_prefix(&format!("{kind}:")))
            .map_or(0, |n| n.trim_end_matches(',').parse().unwrap())
    }

    /// Filter error, the EKF and the UKF hold up to moderate turbulence:
    /// every fit converged, the median bias below 0.5 % of the truth,
    /// σ_MC/CRB below 1.5 (never optimistic) and coverage at least 75 % on
    /// every derivative. Filter error holds in severe turbulence too (every fit
    /// converged, median bias below 1 %); the augmented filters do not: in
    /// severe turbulence fewer than 20 of their fits converge (a known
    /// failure: this test says when it is mended). Output error in still
    /// air is unbiased (median below 0.5 %); in every turbulence each
    /// converged fit is diagnosed with coloured residuals and process
    /// noise, its median bias above 1 % and σ_MC/CRB above 10 on some
    /// derivative: the gusts' bias shows in the statistics.
    #[test]
    #[ignore = "study tier: cargo test --release -- --ignored"]
    fn filters_hold_through_moderate_turbulence_where_output_error_does_not() {
        let study = aeroid::eval::study::Study::load(
            &aeroid::estimation::registry::Registry::built_in(),
            "turbulence-sweep",
        )
        .unwrap();
        let result = study.run(0, &|_| {}).unwrap();
        let table = result.table();
        let summary = &result.summary;
        for turbulence in ["none", "light", "moderate", "severe"] {
            for method in ["fem", "ekf", "ukf"] {
                let rows = rows(summary, turbulence, method);
                let converged = smallest(&rows, |s| s.converged as f64);
                let bias = median_relative_bias(&rows);
                if turbulence == "severe" {
                    if method == "fem" {
                        assert!(converged == 20.0 && bias < 0.01, "{method} severe\n{table}");
                    } else {
                        assert!(
                            converged < 20.0,
                            "{method} now holds in severe turbulence\n{table}"
                        );
                    }
                    continue;
                }
                let scatter = largest(&rows, |s| s.std_over_crb);
                let coverage = smallest(&rows, |s| s.coverage);
                assert!(
                    converged == 20.0 && bias < 0.005 && scatter < 1.5 && coverage >= 0.75,
                    "{turbulence} {method}: converged {converged}, bias {bias:.4}, σ_MC/CRB up to {scatter:.2}, coverage {coverage}\n{table}"
                );
            }
            let rows = rows(summary, turbulence, "oem");
            let bias = median_relative_bias(&rows);
            if turbulence == "none" {
                assert!(bias < 0.005, "oem none: {bias}\n{table}");
                continue;
            }
            for row in &rows {
                assert!(
                    count(row, "coloured_residuals") >= row.converged
                        && count(row, "process_noise") >= row.converged,
                    "oem {turbulence} {}: {}\n{table}",
                    row.parameter,
                    row.diagnosed
                );
            }
            assert!(
                bias > 0.01 && largest(&rows, |s| s.std_over_crb) > 10.0,
                "oem {turbulence}: bias {bias}\n{table}"
            );
        }
    }
}
