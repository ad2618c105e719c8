//! Neural Gauss–Newton (`ngn`: a feed-forward network trained by
//! back-propagation with Levenberg–Marquardt as the restricted
//! flight-dynamic model, then Gauss–Newton on det(R) through it; the
//! reflex-wing UAV paper §3.3, Eqs. 29–30) on simulated records whose truth
//! is known, beside equation error (the same coefficients, regressed
//! directly) and output error.

mod common;

use aeroid::estimation::estimate::{Estimate, Status};
use aeroid::estimation::estimator::MethodTables;
use aeroid::estimation::estimator::RefusalKind;
use aeroid::estimation::problem::EstimationProblem;
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
    let problem =
        EstimationProblem::new(method, vec![record.clone()], structure, &[&tables]).unwrap();
    aeroid::estimation::methods::estimate(&problem, None).unwrap()
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
/// (CDRW, longitudinal 3211 + doublet and lateral multisteps) and of ATTAS
/// (lateral multistep), the bundled models and settings (CDRW: the
/// narrower differentiator of its model files). Every parameter within
/// 0.5 % of the truth. The floor is the network's: equation error on the
/// same reconstructed coefficients recovers every parameter to 1e-4 %, so
/// what ngn adds is its network's approximation of the one-step map
/// (training MSE 4.7e-8, 4.5e-9 and 1.6e-8 in scaled units, R² above
/// 0.99999). Measured worst errors: CDRW longitudinal 0.18 % (CL_de),
/// CDRW lateral 0.02 % (CY_r), ATTAS lateral 0.03 % (CY_da); the tolerance
/// is 2.8 times the worst.
#[test]
fn noise_free_records_are_recovered_to_the_network_floor() {
    for (scenario, model, measured) in [
        ("cdrw-longitudinal", "cdrw-longitudinal", 0.0018),
        ("cdrw-lateral", "cdrw-lateral", 0.0002),
        ("attas-lateral-multistep", "attas-lateral", 0.0003),
    ] {
        let (record, truth) = fly(scenario, "ideal");
        let estimate = run("ngn", &record, model, "");
        let rows = common::against_truth(&estimate, &truth);
        let text = common::truth_table(&rows);
        eprintln!("{scenario}:\n{text}{:?}", estimate.network);
        assert_eq!(estimate.status, Status::Converged, "{scenario}");
        let network = estimate.network.as_ref().unwrap();
        assert_eq!(
            (network.kind.as_str(), network.hidden, network.seed),
            ("feed-forward", 10, 1)
        );
        assert!(network.r_squared > 0.99999, "{scenario}: {network:?}");
        assert_eq!(
            network.outputs, network.inputs,
            "Eq. 30: the inputs' variables at k+1"
        );
        let (relative, _) = worst(&rows);
        assert!(relative < 0.005, "{scenario}:\n{text}");
        assert!(
            relative < 3.0 * measured,
            "{scenario}: worse than measured\n{text}"
        );
    }
}

/// The 25 Hz flight-test record of the ATTAS lateral multistep (sensor
/// noise, the bundled settings): ngn converges, but its network, trained
/// on noisy coefficients, stops early (held-out error rising after 13
/// epochs, R² 0.944) and its estimates are biased well beyond their
/// Cramér–Rao bounds: measured errors 0.1 % (CY_beta) to 55 % (Cn_da),
/// Cl_p +9.4 %, Cn_beta +12 %, largest 7.7σ (Cl_da). Output error on the
/// same record is within 2σ on every parameter. Asserted as the finding:
/// ngn's worst error beyond 5σ and beyond 20 %, output error's within 3σ.
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
    assert!(relative > 0.2 && sigmas > 5.0, "{text}");
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
/// 436 training pairs, and the network learns the one-step map only to
/// R² 0.72 before its held-out error rises (epoch 15). The Gauss–Newton fit
/// through it converges to a wrong model: measured CL_alpha −0.56 against
/// 2.98, CL_de −5.8 against 0.40, Cm_q −0.36 against −0.073, each beyond
/// 8σ of its bound. Output error recovers CL_alpha to 0.2 %. Asserted:
/// ngn's CL_alpha off by more than half of its value, oem's within 1 %.
#[test]
fn short_noisy_cdrw_record_is_beyond_the_network() {
    let (record, truth) = fly("cdrw-longitudinal", "flight-test-25hz");
    let estimate = run("ngn", &record, "cdrw-longitudinal", "");
    let rows = common::against_truth(&estimate, &truth);
    eprintln!("{}{:?}", common::truth_table(&rows), estimate.network);
    let network = estimate.network.as_ref().unwrap();
    assert!(network.r_squared < 0.8, "{network:?}");
    let cl_alpha = estimate.parameter("CL_alpha").unwrap().value;
    assert!((cl_alpha - 2.98).abs() > 0.5 * 2.98, "{cl_alpha}");
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
    let problem = EstimationProblem::new("ngn", vec![record.clone()], structure, &[]).unwrap();
    let error = aeroid::estimation::methods::estimate(&problem, None).unwrap_err();
    let aeroid::Error::Refused(refusal) = error else {
        panic!("{error}")
    };
    assert_eq!(refusal.kind(), RefusalKind::StructureKind);
    let mut without_rates = record.clone();
    without_rates
        .channels
        .retain(|c| !["p", "r"].contains(&c.name.as_str()));
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let problem = EstimationProblem::new("ngn", vec![without_rates], structure, &[]).unwrap();
    let error = aeroid::estimation::methods::estimate(&problem, None).unwrap_err();
    let aeroid::Error::Refused(refusal) = error else {
        panic!("{error}")
    };
    assert_eq!(refusal.kind(), RefusalKind::MissingChannels);
    let named = refusal.missing_channels();
    assert!(named.contains(&"p") && named.contains(&"r"), "{refusal}");
    let structure = ModelStructure::load("attas-lateral").unwrap();
    let mut tables = MethodTables::new();
    tables.insert("ngn".into(), toml::from_str("held_out_every = 1").unwrap());
    let error = EstimationProblem::new("ngn", vec![record], structure, &[&tables]).unwrap_err();
    assert!(error.to_string().contains("[methods.ngn]"), "{error}");
}

/// 20 flight-test records of the ATTAS lateral multistep (one flight,
/// recorder seeds 100–119), ngn with the bundled settings, beside the
/// Cramér–Rao bounds it reports. Measured: σ_MC/CRB 1.20 (Cn_beta) to
/// 3.56 (Cl_da), the bounds understate the scatter for every parameter;
/// the means are biased, beyond three standard errors of the mean
/// (3·σ_MC/√20 = 0.67 σ_MC) for 16 of 18 parameters: Cn_dr +40 %
/// (4.1 σ_MC), Cn_beta +14 % (3.3 σ_MC), Cl_beta +6.4 % (2.2 σ_MC); the
/// weak derivatives are lost: Cn_da −0.0064 estimated +0.0014 on average,
/// Cn_p −0.051 estimated −0.006, CY_da +84 %. Asserted: every σ_MC above
/// its mean bound, and Cn_dr and Cn_beta biased beyond three standard
/// errors of their mean.
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

/// Where ngn does not recover the parameters on noise-free data with its
/// default network (ideal profile, 10 hidden neurons): the longitudinal
/// records of ATTAS (3211) and Hansa-3 (multistep). The network fits the
/// one-step map to R² 0.9999999 and better, yet Gauss–Newton through it
/// stops at the iteration limit far from the truth: Hansa-3 CL_de −0.29
/// against 0.265, CD_de −0.023 against 0.026, while Cm_alpha, Cm_de and
/// Cm_q are within 3.4 %; ATTAS CL_de −0.66 against 0.105, Cm_alpha
/// −0.022 against −0.176. The cause is the network's size: its slopes with
/// respect to the coefficient inputs, which steer Gauss–Newton, are not
/// those of the flight; with 20 neurons both records converge and every
/// parameter is within 1e-4 of the truth (measured: ATTAS CL_de −7e-6
/// relative, Hansa-3 worst 3e-5 (Cm_alpha)). On their 25 Hz flight-test
/// records the default fits converge, Hansa-3 within 13 % except CD_de
/// (−38 %). Asserted as the finding: with 10 neurons not converged on the
/// ideal record, CL_de of the wrong sign; with 20 converged within 1e-4;
/// with 10 converged on the flight-test record with CL_alpha within 5 %.
#[test]
fn ideal_hansa3_and_attas_longitudinal_are_not_recovered() {
    for (scenario, model) in [
        ("hansa3-elevator-multistep", "hansa3-longitudinal"),
        ("attas-elevator-3211", "attas-longitudinal"),
    ] {
        let (record, truth) = fly(scenario, "ideal");
        let estimate = run("ngn", &record, model, "");
        let text = common::truth_table(&common::against_truth(&estimate, &truth));
        assert_ne!(estimate.status, Status::Converged, "{scenario}\n{text}");
        let cl_de = estimate.parameter("CL_de").unwrap().value;
        assert!(cl_de < 0.0, "{scenario}\n{text}");
        let larger = run("ngn", &record, model, "hidden = 20");
        let rows = common::against_truth(&larger, &truth);
        let text = common::truth_table(&rows);
        assert_eq!(larger.status, Status::Converged, "{scenario}\n{text}");
        for (name, value, _, truth) in &rows {
            assert!(
                (value - truth).abs() <= 1e-4 * truth.abs().max(1e-2),
                "{scenario} {name}\n{text}"
            );
        }
    }
    let (record, truth) = fly("hansa3-elevator-multistep", "flight-test-25hz");
    let estimate = run("ngn", &record, "hansa3-longitudinal", "");
    let text = common::truth_table(&common::against_truth(&estimate, &truth));
    assert_eq!(estimate.status, Status::Converged, "{text}");
    let cl_alpha = estimate.parameter("CL_alpha").unwrap().value;
    assert!((cl_alpha - 4.978).abs() < 0.05 * 4.978, "{text}");
}
