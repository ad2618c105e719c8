//! Neural Gauss–Newton (`ngn`: a feed-forward network trained by
//! back-propagation with Levenberg–Marquardt as the restricted
//! flight-dynamic model, then Gauss–Newton on det(R) through it; the
//! reflex-wing UAV paper §3.3, Eqs. 29–30) on simulated records whose truth
//! is known, beside equation error (the same coefficients, regressed
//! directly) and output error.

use crate::common;
use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::estimator::MethodTables;
use aeroid::estimation::estimator::RefusalKind;
use aeroid::estimation::structure::{ModelStructure, Structure};
use aeroid::record::FlightRecord;
use aeroid::record::recorder::Profile;
use aeroid::sim::scenario::Scenario;

/// The scenario flown and recorded with `profile`.
fn fly(scenario: &str, profile: &str) -> (FlightRecord, Scenario) {
    let scenario = Scenario::load(scenario).unwrap();
    let profile = Profile::load(profile, None).unwrap();
    let (record, _) = common::fly_and_record(&scenario, &profile);
    (record, scenario)
}

/// `method` on the record with the model and `[methods.METHOD]` settings.
fn run(method: &str, record: &FlightRecord, model: &str, settings: &str) -> Estimate {
    let structure = ModelStructure::load(model).unwrap();
    let mut tables = MethodTables::new();
    tables.insert(method.to_string(), toml::from_str(settings).unwrap());
    let problem = crate::common::registry()
        .problem(method, vec![record.clone()], structure, &[&tables])
        .unwrap();
    crate::common::registry().estimate(&problem, None).unwrap()
}

/// Relative errors of the rows, and the largest |error|/σ.
fn worst(rows: &[(String, f64, f64, f64)]) -> (f64, f64) {
    rows.iter().fold(
        (0.0, 0.0),
        |(relative, sigmas), (_, value, sigma, truth)| {
            (
                f64::max(relative, ((value - truth) / truth).abs()),
                f64::max(sigmas, ((value - truth) / sigma).abs()),
            )
        },
    )
}

/// Noise-free records (the ideal recorder, 100 Hz) of the paper's aircraft
/// (CDRW, longitudinal 3211 + doublet and lateral multisteps), of ATTAS
/// (elevator 3211, lateral multistep) and of HANSA-3 (elevator multistep),
/// the bundled models and settings (CDRW: the narrower differentiator of
/// its model files; the hidden-layer size chosen from the data). The
/// held-out error chooses 20 neurons on every record (measured held-out
/// MSE 10 → 20 neurons: ATTAS 3211 1.2e-10 → 1.0e-12, HANSA-3 4.6e-9 →
/// 5.7e-10, ATTAS lateral 1.6e-8 → 5.5e-11, CDRW longitudinal 6.0e-8 →
/// 7.8e-10, CDRW lateral 4.5e-9 → 2.8e-12, in scaled units), and every
/// parameter is within 1e-4 of its truth (relative; |truth| floored at
/// 0.01 for the offsets near zero). The truth is the scenario's model; the
/// tolerance is the network's approximation floor: equation error on the
/// same reconstructed coefficients recovers every parameter to 1e-6, so
/// what ngn adds is its network's one-step error. Measured worst: CDRW
/// longitudinal 5.3e-5 (Cm_q), HANSA-3 3.0e-5 (Cm_alpha), CDRW lateral
/// 1.9e-5 (Cl_dr), ATTAS lateral 1.1e-5 (CY_da), ATTAS 3211 6.6e-6
/// (CL_de); the tolerance is about twice the worst.
#[test]
fn noise_free_records_are_recovered_to_the_network_floor() {
    for (scenario, model) in [
        ("cdrw-longitudinal", "cdrw-longitudinal"),
        ("cdrw-lateral", "cdrw-lateral"),
        ("attas-lateral-multistep", "attas-lateral"),
        ("attas-elevator-3211", "attas-longitudinal"),
        ("hansa3-elevator-multistep", "hansa3-longitudinal"),
    ] {
        let (record, truth) = fly(scenario, "ideal");
        let estimate = run("ngn", &record, model, "");
        let rows = common::against_truth(&estimate, &truth);
        let text = common::truth_table(&rows);
        eprintln!("{scenario}:\n{text}{:?}", estimate.network);
        assert_eq!(estimate.status, Status::Converged, "{scenario}\n{text}");
        let network = estimate.network.as_ref().unwrap();
        assert_eq!(
            (network.kind.as_str(), network.hidden, network.seed),
            ("feed-forward", 20, 1),
            "{scenario}: {network:?}"
        );
        let scores: Vec<&str> = network
            .settings
            .iter()
            .filter(|(name, _)| name.starts_with("held-out mse,"))
            .map(|(name, _)| name.as_str())
            .collect();
        assert_eq!(
            scores,
            ["held-out mse, 10 neurons", "held-out mse, 20 neurons"],
            "{scenario}: every candidate size is scored in the report"
        );
        assert!(network.r_squared > 0.99999, "{scenario}: {network:?}");
        assert_eq!(
            network.outputs, network.inputs,
            "Eq. 30: the inputs' variables at k+1"
        );
        for (name, value, _, truth) in &rows {
            assert!(
                (value - truth).abs() <= 1e-4 * truth.abs().max(1e-2),
                "{scenario} {name}\n{text}"
            );
        }
    }
}

/// The 25 Hz flight-test record of the ATTAS lateral multistep (sensor
/// noise, the bundled settings): the held-out error chooses 20 neurons
/// (held-out MSE 0.003334 against 0.003349 for 10), the network, trained
/// on noisy coefficients, stops early (held-out error rising after 14
/// epochs, R² 0.953) and ngn converges, but its estimates are biased
/// beyond their Cramér–Rao bounds: measured errors 0.09 % (CY_beta) to
/// 91 % (Cn_da), Cn_p +65 %, Cl_r +22 % (3.9σ, the largest), Cl_beta
/// +5.4 % (3.1σ). Output error on the same record is within 2σ on every
/// parameter. Asserted as the finding: ngn's worst error beyond 3σ and
/// beyond 20 %, output error's within 3σ.
#[test]
fn flight_test_noise_biases_the_estimates_beyond_their_bounds() {
    let (record, truth) = fly("attas-lateral-multistep", "flight-test-25hz");
    let estimate = run("ngn", &record, "attas-lateral", "");
    let rows = common::against_truth(&estimate, &truth);
    let text = common::truth_table(&rows);
    eprintln!("ngn:\n{text}{:?}", estimate.network);
    assert_eq!(estimate.status, Status::Converged);
    assert!(rows.iter().all(|r| r.2.is_finite() && r.2 > 0.0), "{text}");
    let (relative, sigmas) = worst(&rows);
    assert!(relative > 0.2 && sigmas > 3.0, "{text}");
    let network = estimate.network.as_ref().unwrap();
    assert!(network.r_squared < 0.99, "{network:?}");
    let reference = run("oem", &record, "attas-lateral", "");
    let reference_rows = common::against_truth(&reference, &truth);
    assert!(
        worst(&reference_rows).1 < 3.0,
        "{}",
        common::truth_table(&reference_rows)
    );
}

/// The CDRW longitudinal record at 25 Hz with flight-test noise: 20 s give
/// 436 training pairs; the held-out error chooses 20 neurons (0.0226
/// against 0.0239 for 10), and the network learns the one-step map only
/// to R² 0.72 before its held-out error rises (epoch 6). The Gauss–Newton
/// fit through it converges to a wrong model: measured CL_alpha 1.75
/// against 2.98 (−41 %, 6.3σ), Cm_alpha −1.42 against −0.241, Cm_q +0.87
/// against −0.073 (the wrong sign, 16σ). Output error recovers CL_alpha to
/// 0.2 %. Asserted: ngn's CL_alpha off by more than a quarter of its
/// value and its Cm_q of the wrong sign, oem's CL_alpha within 1 %.
#[test]
fn short_noisy_cdrw_record_is_beyond_the_network() {
    let (record, truth) = fly("cdrw-longitudinal", "flight-test-25hz");
    let estimate = run("ngn", &record, "cdrw-longitudinal", "");
    let rows = common::against_truth(&estimate, &truth);
    eprintln!("{}{:?}", common::truth_table(&rows), estimate.network);
    let network = estimate.network.as_ref().unwrap();
    assert!(network.r_squared < 0.8, "{network:?}");
    let cl_alpha = estimate.parameter("CL_alpha").unwrap().value;
    assert!((cl_alpha - 2.98).abs() > 0.25 * 2.98, "{cl_alpha}");
    let cm_q = estimate.parameter("Cm_q").unwrap().value;
    assert!(cm_q > 0.0, "{cm_q}");
    let reference = run("oem", &record, "cdrw-longitudinal", "");
    let cl_alpha = reference.parameter("CL_alpha").unwrap().value;
    assert!((cl_alpha - 2.98).abs() < 0.01 * 2.98, "{cl_alpha}");
}

/// The same seed gives the same estimate, bit for bit, in a rayon pool of
/// one thread and of two; another seed gives another network.
#[test]
fn same_seed_same_estimate_whatever_the_thread_count() {
    let (record, _) = fly("cdrw-lateral", "flight-test-25hz");
    let in_pool = |threads: usize, settings: &str| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run("ngn", &record, "cdrw-lateral", settings))
    };
    let bits = |estimate: &Estimate| -> Vec<u64> {
        estimate
            .parameters
            .iter()
            .flat_map(|p| [p.value.to_bits(), p.standard_error.to_bits()])
            .collect()
    };
    let one = in_pool(1, "seed = 7");
    let two = in_pool(2, "seed = 7");
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(one.network, two.network);
    let other = in_pool(2, "seed = 8");
    assert_ne!(bits(&one), bits(&other));
    assert_eq!(other.network.as_ref().unwrap().seed, 8);
}

/// A linear structure is refused as the wrong kind; a record without the
/// roll and yaw rates (motion variables and the moment coefficients'
/// angular accelerations) is refused naming them; a setting out of range
/// is an error naming the table.
#[test]
fn refusals_name_what_is_missing() {
    let (record, _) = fly("attas-lateral-multistep", "flight-test-25hz");
    let structure = Structure::load("linear-lateral-attas").unwrap();
    let problem = crate::common::registry()
        .problem("ngn", vec![record.clone()], structure, &[])
        .unwrap();
    let error = crate::common::registry()
        .estimate(&problem, None)
        .unwrap_err();
    let aeroid::estimation::Error::Refused(refusal) = error else {
        panic!("{error}")
    };
    assert_eq!(refusal.kind(), RefusalKind::StructureKind);
    let mut without_rates = record.clone();
    without_rates
        .channels
        .retain(|c| !["p", "r"].contains(&c.name.as_str()));
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let problem = crate::common::registry()
        .problem("ngn", vec![without_rates], structure, &[])
        .unwrap();
    let error = crate::common::registry()
        .estimate(&problem, None)
        .unwrap_err();
    let aeroid::estimation::Error::Refused(refusal) = error else {
        panic!("{error}")
    };
    assert_eq!(refusal.kind(), RefusalKind::MissingChannels);
    let named = refusal.missing_channels();
    assert!(named.contains(&"p") && named.contains(&"r"), "{refusal}");
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let mut tables = MethodTables::new();
    tables.insert("ngn".into(), toml::from_str("held_out_every = 1").unwrap());
    let error = crate::common::registry()
        .problem("ngn", vec![record], structure, &[&tables])
        .unwrap_err();
    assert!(error.to_string().contains("[methods.ngn]"), "{error}");
}

/// 20 flight-test records of the ATTAS lateral multistep (one flight,
/// recorder seeds 100–119), ngn with the bundled settings, beside the
/// Cramér–Rao bounds it reports. Measured: σ_MC/CRB 1.15 (Cn_da) to 3.85
/// (Cl_da), the bounds understate the scatter for every parameter; the
/// means are biased beyond three standard errors of the mean
/// (3·σ_MC/√20 = 0.67 σ_MC) for 13 of 18 parameters: Cn_beta +10 %
/// (2.0 σ_MC), Cn_dr +28 % (1.7 σ_MC), CY_dr +7 % (1.6 σ_MC), Cl_beta
/// +4 % (1.0 σ_MC); the weak derivatives are lost: Cn_da −0.0064
/// estimated −0.0016 on average, Cn_p −0.051 estimated −0.027, CY_da
/// +62 %, Cn_r +61 %. Asserted: every σ_MC above its mean bound, and Cn_dr
/// and Cn_beta biased beyond three standard errors of their mean.
#[test]
fn flight_test_monte_carlo_scatter_exceeds_the_bounds_and_the_mean_is_biased() {
    let runs = 20;
    let scenario = Scenario::load("attas-lateral-multistep").unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    let (trace, _) = aeroid::sim::fly(&scenario).unwrap();
    let all: Vec<Vec<(String, f64, f64, f64)>> = (0..runs)
        .map(|run_index| {
            let record = profile
                .record(&trace, &scenario.aircraft, 100 + run_index)
                .unwrap();
            let estimate = run("ngn", &record, "attas-lateral", "");
            assert_eq!(estimate.status, Status::Converged);
            common::against_truth(&estimate, &scenario)
        })
        .collect();
    let n = runs as f64;
    let mut text = String::new();
    for p in 0..all[0].len() {
        let (name, truth) = (&all[0][p].0, all[0][p].3);
        let mean = all.iter().map(|r| r[p].1).sum::<f64>() / n;
        let scatter = (all.iter().map(|r| (r[p].1 - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let bound = all.iter().map(|r| r[p].2).sum::<f64>() / n;
        text += &format!(
            "{name}: truth {truth:.5} mean {mean:.5} ({:+.1} %, {:+.2} σ_MC) σ_MC {scatter:.5} σ_MC/CRB {:.2}\n",
            100.0 * (mean - truth) / truth,
            (mean - truth) / scatter,
            scatter / bound
        );
        assert!(scatter > bound, "{name}: {text}");
        if ["Cn_dr", "Cn_beta"].contains(&name.as_str()) {
            assert!(
                (mean - truth).abs() > 3.0 * scatter / n.sqrt(),
                "{name}: {text}"
            );
        }
    }
    eprintln!("{text}");
}

/// What the size search is for: with 10 hidden neurons (`hidden = 10`) ngn
/// does not recover the noise-free longitudinal records of ATTAS (3211)
/// and HANSA-3 (multistep). The network fits the one-step map to R²
/// 0.9999999 and better, yet Gauss–Newton through it stops at the
/// iteration limit far from the truth: HANSA-3 CL_de −0.29 against 0.265,
/// CD_de −0.023 against 0.026, while Cm_alpha, Cm_de and Cm_q are within
/// 3.4 %; ATTAS CL_de −0.66 against 0.105, Cm_alpha −0.022 against
/// −0.176. The network's slopes with respect to the coefficient inputs,
/// which steer Gauss–Newton, are not those of the flight; with 20 neurons,
/// which the held-out error chooses, both are recovered within 1e-4
/// (`noise_free_records_are_recovered_to_the_network_floor`). On HANSA-3's
/// 25 Hz flight-test record the held-out error chooses 10 neurons
/// (measured held-out MSE 0.0124 against 0.0130 for 20) and the fit
/// converges, within 13 % except CD_de (−38 %). Asserted as the finding:
/// with 10 neurons not converged on the ideal records, CL_de of the wrong
/// sign; on the flight-test record the default converged with CL_alpha
/// within 5 %.
#[test]
fn ten_neurons_do_not_recover_ideal_hansa3_and_attas_longitudinal() {
    for (scenario, model) in [
        ("hansa3-elevator-multistep", "hansa3-longitudinal"),
        ("attas-elevator-3211", "attas-longitudinal"),
    ] {
        let (record, truth) = fly(scenario, "ideal");
        let estimate = run("ngn", &record, model, "hidden = 10");
        let text = common::truth_table(&common::against_truth(&estimate, &truth));
        assert_ne!(estimate.status, Status::Converged, "{scenario}\n{text}");
        let cl_de = estimate.parameter("CL_de").unwrap().value;
        assert!(cl_de < 0.0, "{scenario}\n{text}");
    }
    let (record, truth) = fly("hansa3-elevator-multistep", "flight-test-25hz");
    let estimate = run("ngn", &record, "hansa3-longitudinal", "");
    let text = common::truth_table(&common::against_truth(&estimate, &truth));
    eprintln!("{text}{:?}", estimate.network);
    assert_eq!(estimate.status, Status::Converged, "{text}");
    assert_eq!(estimate.network.as_ref().unwrap().hidden, 10);
    let cl_alpha = estimate.parameter("CL_alpha").unwrap().value;
    assert!((cl_alpha - 4.978).abs() < 0.05 * 4.978, "{text}");
}

/// With the motion variables alone as the network's outputs (the ELM
/// paper's form, `coefficient_outputs = false`, instead of the reflex-wing
/// UAV paper's Eq. 30) the noise-free CDRW longitudinal record is
/// recovered too: the network fits the one-step map (R² above 0.99999)
/// and every parameter is within 1e-3 of its truth (relative, |truth|
/// floored at 0.01; measured worst 0.02 %, Cm_q). The tolerance is ten
/// times the default form's network floor
/// (`noise_free_records_are_recovered_to_the_network_floor`): what is
/// asserted is that the form does not mislead the fit on this record,
/// not a floor of its own.
#[test]
fn motion_variables_alone_as_outputs_recover_the_cdrw() {
    let (record, truth) = fly("cdrw-longitudinal", "ideal");
    let estimate = run(
        "ngn",
        &record,
        "cdrw-longitudinal",
        "coefficient_outputs = false",
    );
    let rows = common::against_truth(&estimate, &truth);
    let text = common::truth_table(&rows);
    eprintln!("{text}{:?}", estimate.network);
    assert_eq!(estimate.status, Status::Converged, "{text}");
    let network = estimate.network.as_ref().unwrap();
    assert!(network.r_squared > 0.99999, "{network:?}");
    assert_ne!(network.outputs, network.inputs, "motion variables only");
    for (name, value, _, truth) in &rows {
        assert!(
            (value - truth).abs() <= 1e-3 * truth.abs().max(1e-2),
            "{name}\n{text}"
        );
    }
}
