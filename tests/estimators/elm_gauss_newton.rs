//! ELM + Gauss–Newton (`elm-gn`) and recurrent ELM + Gauss–Newton
//! (`relm-gn`) on simulated records where the answer is known: noise-free
//! records of the matching structure (the method's own floor), the
//! flight-test profile (a 20-seed Monte Carlo), beside filter error (the
//! ELM paper's comparison) and beside output error on the stall flight
//! (Verma & Peyada 2020's claim). Every number quoted is measured by the
//! test that quotes it (`cargo test --test estimators -- --nocapture`
//! prints them).

use crate::common;
use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::estimator::MethodTables;
use aeroid::estimation::methods::elm_gauss_newton::ElmSettings;
use aeroid::estimation::neural::restricted;
use aeroid::estimation::problem::EstimationProblem;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::recorder::Profile;
use aeroid::sim::scenario::Scenario;

/// The problem of `method` on `scenario` (its seed replaced by `seed`)
/// recorded with `profile`, fitting `model` with the `[methods.NAME]`
/// settings `settings`; and the truth of every aerodynamic parameter.
fn problem(
    method: &str,
    (scenario, seed): (&str, Option<u64>),
    profile: &str,
    model: &str,
    settings: &str,
) -> (EstimationProblem, Scenario) {
    let mut scenario = Scenario::load(scenario).unwrap();
    if let Some(seed) = seed {
        scenario.seed = seed;
    }
    let profile = Profile::load(profile, None).unwrap();
    let (record, _) = common::fly_and_record(&scenario, &profile);
    let structure = ModelStructure::load(model).unwrap();
    let mut tables = MethodTables::new();
    tables.insert(method.to_string(), toml::from_str(settings).unwrap());
    let problem = crate::common::registry()
        .problem(method, vec![record], structure, &[&tables])
        .unwrap();
    (problem, scenario)
}

/// The estimate of `method` and the truth of each of its parameters (NaN
/// for an unknown that is not an aerodynamic parameter).
fn run(
    method: &str,
    scenario: (&str, Option<u64>),
    profile: &str,
    model: &str,
) -> (Estimate, Vec<f64>) {
    let (problem, scenario) = problem(method, scenario, profile, model, "");
    let estimate = crate::common::registry().estimate(&problem, None).unwrap();
    let truth = truths(&estimate, &scenario);
    (estimate, truth)
}

fn truths(estimate: &Estimate, scenario: &Scenario) -> Vec<f64> {
    estimate
        .parameters
        .iter()
        .map(|p| {
            scenario
                .aircraft
                .aero
                .parameters
                .get(&p.name)
                .unwrap_or(f64::NAN)
        })
        .collect()
}

/// Prints an estimate beside the truth (error in σ of its Cramér–Rao bound).
fn print(estimate: &Estimate, truth: &[f64]) {
    println!(
        "{} on {}: {}, {} iterations, {:.3} s",
        estimate.method, estimate.record, estimate.status, estimate.iterations, estimate.wall_time
    );
    if let Some(network) = &estimate.network {
        println!(
            "  network: {} hidden, MSE {:.3e}, R² {:.6}",
            network.hidden, network.mse, network.r_squared
        );
    }
    for (p, t) in estimate.parameters.iter().zip(truth) {
        println!(
            "  {:12} {:12.6} truth {:12.6} σ {:9.2e} error {:7.2} %, {:7.2} σ",
            p.name,
            p.value,
            t,
            p.standard_error,
            100.0 * (p.value - t) / t,
            (p.value - t) / p.standard_error
        );
    }
}

/// On the noise-free lateral record (100 Hz) ELM-GN with the default
/// settings converges within the network's floor: 4 % of the truth plus
/// 4e-4. Measured: median error 1.0 %, worst 3.4 % (Cn_da), 2.9 % (Cn_r),
/// absolute worst 5.9e-4 (CY_da, truth 0.0103), 5.5e-3 on CY_r. The floor
/// is the network's, not the start's: started from the truth itself the
/// fit lands on the same estimate (within 0.01 of the Cramér–Rao bound),
/// because with Θ = truth the residual is not zero — the network's
/// one-step error (MSE 7.8e-7 with 60 neurons, the largest default size,
/// the held-out residual still falling there). With 120 neurons it is
/// gone (`lateral_ideal_with_a_larger_network`). The noise-free HANSA-3
/// and stall records, whose networks fit 100 times better with 60 neurons
/// (MSE 8e-9 and 1.4e-8), are recovered within 2e-4 (below).
#[test]
fn lateral_ideal_within_the_restricted_model_floor() {
    let (problem, scenario) = problem(
        "elm-gn",
        ("attas-lateral-multistep", None),
        "ideal",
        "attas-lateral",
        "",
    );
    let estimate = crate::common::registry().estimate(&problem, None).unwrap();
    let truth = truths(&estimate, &scenario);
    print(&estimate, &truth);
    assert!(estimate.status.is_success(), "{}", estimate.status);
    let network = estimate.network.as_ref().unwrap();
    assert!(network.r_squared > 0.9999, "{network:?}");
    for (p, &t) in estimate.parameters.iter().zip(&truth) {
        let allowed = 0.04 * t.abs() + 4e-4;
        assert!(
            (p.value - t).abs() <= allowed,
            "{}: {} vs {t}",
            p.name,
            p.value
        );
    }
    let mut from_truth = estimate.clone();
    for (p, &t) in from_truth.parameters.iter_mut().zip(&truth) {
        p.value = t;
    }
    let settings = ElmSettings::read("elm-gn", &problem.settings).unwrap();
    let again = restricted::estimate(
        "elm-gn",
        &problem,
        Some(&from_truth),
        &settings.trainer("elm"),
        &settings.options(),
    )
    .unwrap();
    for (a, b) in estimate.parameters.iter().zip(&again.parameters) {
        assert!(
            (a.value - b.value).abs() <= 0.01 * a.standard_error,
            "{}: {} from ee, {} from the truth",
            a.name,
            a.value,
            b.value
        );
    }
}

/// Noise-free HANSA-3 longitudinal record (the ELM paper's first case) and
/// the ATTAS stall flight with RELM-GN (Verma & Peyada's case): every
/// parameter within 2e-4 of the truth (absolute floor 1e-6). Measured worst:
/// HANSA-3 2.6e-6 (Cm_de); stall 4.2e-5 (Cm_q), a1 2.5e-6, α* 1e-6, τ2
/// 1e-6, the χ derivatives 2e-6 — output error is exact on both (to 1e-9).
#[test]
fn longitudinal_and_stall_ideal_are_recovered() {
    for (method, scenario, model) in [
        ("elm-gn", "hansa3-elevator-multistep", "hansa3-longitudinal"),
        ("relm-gn", "attas-stall", "attas-stall"),
    ] {
        let (estimate, truth) = run(method, (scenario, None), "ideal", model);
        print(&estimate, &truth);
        assert!(estimate.status.is_success(), "{}", estimate.status);
        for (p, &t) in estimate.parameters.iter().zip(&truth) {
            assert!(
                (p.value - t).abs() <= (2e-4 * t.abs()).max(1e-6),
                "{method} {}: {} vs {t}",
                p.name,
                p.value
            );
        }
    }
}

/// Per parameter over `seeds` flight-test records of a scenario: truth,
/// mean estimate, sample standard deviation and mean Cramér–Rao bound.
struct MonteCarlo {
    names: Vec<String>,
    truth: Vec<f64>,
    mean: Vec<f64>,
    spread: Vec<f64>,
    bound: Vec<f64>,
}

fn monte_carlo(scenario: &str, model: &str, seeds: u64) -> MonteCarlo {
    let mut runs: Vec<Estimate> = Vec::new();
    let mut truth = Vec::new();
    for seed in 1..=seeds {
        let (estimate, t) = run("elm-gn", (scenario, Some(seed)), "flight-test-25hz", model);
        assert!(
            estimate.status.is_success(),
            "seed {seed}: {}",
            estimate.status
        );
        runs.push(estimate);
        truth = t;
    }
    let n = runs.len() as f64;
    let column = |j: usize| runs.iter().map(move |e| &e.parameters[j]);
    let count = truth.len();
    let mean: Vec<f64> = (0..count)
        .map(|j| column(j).map(|p| p.value).sum::<f64>() / n)
        .collect();
    let spread = (0..count)
        .map(|j| (column(j).map(|p| (p.value - mean[j]).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
        .collect();
    let bound = (0..count)
        .map(|j| column(j).map(|p| p.standard_error).sum::<f64>() / n)
        .collect();
    let result = MonteCarlo {
        names: runs[0].parameters.iter().map(|p| p.name.clone()).collect(),
        truth,
        mean,
        spread,
        bound,
    };
    for j in 0..count {
        println!(
            "{scenario} {:10} truth {:10.5} mean {:10.5} bias {:7.1} % = {:6.2} σ_MC, σ_MC {:9.2e}, σ_MC/CRB {:5.2}",
            result.names[j],
            result.truth[j],
            result.mean[j],
            100.0 * (result.mean[j] - result.truth[j]) / result.truth[j],
            result.bias(j),
            result.spread[j],
            result.spread[j] / result.bound[j]
        );
    }
    result
}

impl MonteCarlo {
    /// Bias of the mean in units of the Monte Carlo standard deviation.
    fn bias(&self, j: usize) -> f64 {
        (self.mean[j] - self.truth[j]) / self.spread[j]
    }
}

/// 20 flight-test records (seeds 1–20) of the HANSA-3 multistep: every
/// mean within 2.5 σ_MC of the truth (measured worst: CL_alpha −3.3 %,
/// −2.1 σ_MC — significant over 20 runs, a bias of the network fitted to
/// noisy data, like equation error's errors in variables; CL_0 +1.8 %,
/// 1.4 σ_MC); the Cramér–Rao bounds within a factor 2 of the spread
/// (σ_MC/CRB 0.60 (Cm_alpha) to 1.66 (CD_0)).
#[test]
fn hansa_flight_test_monte_carlo() {
    let mc = monte_carlo("hansa3-elevator-multistep", "hansa3-longitudinal", 20);
    for j in 0..mc.names.len() {
        assert!(
            mc.bias(j).abs() < 2.5,
            "{}: {:.2} σ_MC",
            mc.names[j],
            mc.bias(j)
        );
        let ratio = mc.spread[j] / mc.bound[j];
        assert!(
            (0.5..2.0).contains(&ratio),
            "{}: σ_MC/CRB {ratio:.2}",
            mc.names[j]
        );
    }
}

/// 20 flight-test records of the ATTAS lateral multistep. The rolling and
/// yawing moment derivatives: every mean within 2.5 σ_MC of the truth
/// (measured worst Cl_0 −2.1, Cl_p −1.8 σ_MC; Cn_r −25 % but 1.1 σ_MC, its
/// spread 23 % of the truth). The side-force derivatives are NOT recovered
/// (finding): CY_beta −3.8 % (−8.6 σ_MC), CY_dr −27 % (−9.4 σ_MC), CY_r
/// −24 % (−5.2 σ_MC), CY_p +37 %, CY_da +170 % — the side force moves β
/// little against β's noise, and the network trained on noisy β and ny
/// carries that into the fit (on noise-free data the same derivatives are
/// within 1 %). The Cramér–Rao bounds are pessimistic here: σ_MC/CRB 0.40
/// to 0.60, from the network's residuals, which are not white sensor noise.
#[test]
fn lateral_flight_test_monte_carlo() {
    let mc = monte_carlo("attas-lateral-multistep", "attas-lateral", 20);
    for j in 0..mc.names.len() {
        let name = &mc.names[j];
        let ratio = mc.spread[j] / mc.bound[j];
        assert!((0.3..0.7).contains(&ratio), "{name}: σ_MC/CRB {ratio:.2}");
        if name.starts_with("CY") {
            continue;
        }
        assert!(mc.bias(j).abs() < 2.5, "{name}: {:.2} σ_MC", mc.bias(j));
    }
    for name in ["CY_beta", "CY_dr", "CY_r"] {
        let j = mc.names.iter().position(|n| n == name).unwrap();
        assert!(
            mc.bias(j).abs() > 4.0,
            "{name} is now recovered: {:.2} σ_MC",
            mc.bias(j)
        );
    }
}

/// The ELM paper's comparison: ELM-GN beside filter error (`fem`) on the
/// flight-test records of ATTAS lateral and HANSA-3 (the scenarios' own
/// seeds). The paper finds ELM-GN's estimates close to FEM's. Measured, as
/// the RMS over the parameters of error/truth: ATTAS lateral ELM-GN 0.31,
/// filter error 0.038; HANSA-3 ELM-GN 0.25, filter error 0.036 (filter
/// error at its iteration limit of 30 there, ELM-GN converged in 4: the
/// paper's remark that FEM needs more iterations holds). ELM-GN's
/// Cramér–Rao bounds are 4–46 times filter error's on the lateral record
/// and 2–19 times on HANSA-3 (filter error uses the equations of motion;
/// the network only one-step pairs), and its estimates lie within 5.2 of
/// its own σ of filter error's (lateral CY_dr; HANSA-3 worst CL_alpha 2.3 σ):
/// close in ELM-GN's own bounds, far in filter error's.
#[test]
fn beside_filter_error() {
    for (scenario, model) in [
        ("attas-lateral-multistep", "attas-lateral"),
        ("hansa3-elevator-multistep", "hansa3-longitudinal"),
    ] {
        let (elm, truth) = run("elm-gn", (scenario, None), "flight-test-25hz", model);
        let (fem, _) = run("fem", (scenario, None), "flight-test-25hz", model);
        print(&elm, &truth);
        print(&fem, &truth);
        assert!(elm.status.is_success(), "{}", elm.status);
        let relative = |e: &Estimate| {
            let sum: f64 = e
                .parameters
                .iter()
                .zip(&truth)
                .map(|(p, t)| ((p.value - t) / t).powi(2))
                .sum();
            (sum / truth.len() as f64).sqrt()
        };
        println!(
            "{scenario}: RMS relative error elm-gn {:.4}, fem {:.4}",
            relative(&elm),
            relative(&fem)
        );
        for (e, f) in elm.parameters.iter().zip(&fem.parameters) {
            assert_eq!(e.name, f.name);
            let apart = (e.value - f.value) / e.standard_error;
            println!(
                "  {:10} elm-gn − fem = {apart:6.2} σ_elm, σ_elm/σ_fem {:6.1}",
                e.name,
                e.standard_error / f.standard_error
            );
            assert!(apart.abs() < 6.0, "{}: {apart:.2} σ", e.name);
        }
        assert!(
            relative(&fem) < relative(&elm),
            "{scenario}: elm-gn is now better than fem"
        );
    }
}

/// Verma & Peyada's claim, RELM-GN estimates close to maximum likelihood's,
/// on the flight-test record of the ATTAS stall flight. Output error is
/// within 2.3 σ on every parameter. RELM-GN (measured): the lift and drag
/// and the stall break close — a1 +2.2 % (1.0 σ), α* +1.0 % (5.2 σ),
/// τ2 −7.3 % (−6.5 σ), ∂CD/∂χ −1.3 % (−1.3 σ), e −4.4 %, CL_alpha −1.6 %;
/// the pitching moment is not recovered (finding): ∂Cm/∂χ −35 % (6.9 σ),
/// Cm_alpha −0.44 against −0.176, Cm_q +0.67 against −6.15: the pitch
/// rate's one-step change carries q̇ ∝ Cm, whose reconstruction
/// differentiates the noisy rate, and the network fitted to it does not
/// separate Cm's terms that the stall flight excites little (its elevator
/// is a slow ramp).
#[test]
fn stall_beside_output_error() {
    let (relm, truth) = run(
        "relm-gn",
        ("attas-stall", None),
        "flight-test-25hz",
        "attas-stall",
    );
    let (oem, oem_truth) = run(
        "oem",
        ("attas-stall", None),
        "flight-test-25hz",
        "attas-stall",
    );
    print(&relm, &truth);
    print(&oem, &oem_truth);
    assert!(relm.status.is_success() && oem.status.is_success());
    let get = |e: &Estimate, name: &str| e.parameter(name).unwrap().clone();
    for (p, t) in oem
        .parameters
        .iter()
        .zip(&oem_truth)
        .filter(|(_, t)| t.is_finite())
    {
        assert!(
            ((p.value - t) / p.standard_error).abs() < 3.0,
            "oem {}",
            p.name
        );
    }
    let index = |name: &str| relm.parameters.iter().position(|p| p.name == name).unwrap();
    let relative = |name: &str| (get(&relm, name).value - truth[index(name)]) / truth[index(name)];
    for (name, within) in [
        ("a1", 0.05),
        ("alpha_star", 0.02),
        ("tau2", 0.10),
        ("CD_chi", 0.05),
        ("e", 0.08),
    ] {
        assert!(
            relative(name).abs() < within,
            "{name}: {:.3}",
            relative(name)
        );
    }
    assert!(
        relative("Cm_chi").abs() > 0.2,
        "Cm_chi is now recovered: {:.3}",
        relative("Cm_chi")
    );
    assert!(get(&relm, "Cm_q").value > -3.0, "Cm_q is now recovered");
}

/// A seed gives the same estimate, bit for bit, on a rayon pool of 1 and
/// of 2 threads; another seed another network and estimate.
#[test]
fn same_seed_same_estimate_whatever_the_thread_count() {
    let estimate_on = |threads: usize, settings: &str| {
        let (problem, _) = problem(
            "elm-gn",
            ("attas-lateral-multistep", None),
            "flight-test-25hz",
            "attas-lateral",
            settings,
        );
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let estimate = pool.install(|| crate::common::registry().estimate(&problem, None).unwrap());
        let values: Vec<(f64, f64)> = estimate
            .parameters
            .iter()
            .map(|p| (p.value, p.standard_error))
            .collect();
        (values, estimate.network.unwrap())
    };
    let (one, network) = estimate_on(1, "");
    let (two, again) = estimate_on(2, "");
    assert_eq!(one, two);
    assert_eq!(network, again);
    assert_eq!(network.seed, 1);
    let (other, other_network) = estimate_on(1, "seed = 7");
    assert_ne!(one, other);
    assert_eq!(other_network.seed, 7);
}

/// `feedback = "predicted"` (a free-running simulation through the network
/// trained one step ahead) is worse than the papers' measured feedback on
/// the flight-test records (finding): on HANSA-3 it stops at the iteration
/// limit with Cm_alpha −0.60 (truth −0.496) and Cm_q −2.0 (truth −5.5); the
/// network's one-step errors accumulate along the simulation.
#[test]
fn predicted_feedback_is_worse_than_measured() {
    let (problem, scenario) = problem(
        "elm-gn",
        ("hansa3-elevator-multistep", None),
        "flight-test-25hz",
        "hansa3-longitudinal",
        "feedback = \"predicted\"",
    );
    let predicted = crate::common::registry().estimate(&problem, None).unwrap();
    let truth = truths(&predicted, &scenario);
    print(&predicted, &truth);
    let (measured, _) = run(
        "elm-gn",
        ("hansa3-elevator-multistep", None),
        "flight-test-25hz",
        "hansa3-longitudinal",
    );
    let error = |e: &Estimate, name: &str| {
        let j = e.parameters.iter().position(|p| p.name == name).unwrap();
        ((e.parameters[j].value - truth[j]) / truth[j]).abs()
    };
    for name in ["Cm_alpha", "Cm_q"] {
        assert!(
            error(&predicted, name) > 2.0 * error(&measured, name),
            "{name}"
        );
    }
}

/// The stall model with χ a state (τ1 = 0.1 s in the truth and held at it
/// in the model): RELM-GN integrates Eq. 2 along the record with the
/// model's separation rate. Noise-free, every parameter within 1e-3 of the
/// truth (measured worst 8.5e-5, Cm_alpha; a1 1.1e-5, τ2 3e-6).
#[test]
fn stall_with_a_separation_lag_ideal() {
    let mut scenario = Scenario::load("attas-stall").unwrap();
    scenario.aircraft.aero.parameters.set("tau1", 0.1).unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    let (record, _) = common::fly_and_record(&scenario, &profile);
    let mut structure = ModelStructure::load("attas-stall").unwrap();
    structure.aircraft.aero.parameters.set("tau1", 0.1).unwrap();
    assert!(structure.aircraft.aero.chi_is_state());
    let problem = crate::common::registry()
        .problem("relm-gn", vec![record], structure, &[])
        .unwrap();
    let estimate = crate::common::registry().estimate(&problem, None).unwrap();
    let truth = truths(&estimate, &scenario);
    print(&estimate, &truth);
    assert!(estimate.status.is_success(), "{}", estimate.status);
    for (p, &t) in estimate.parameters.iter().zip(&truth) {
        assert!(
            (p.value - t).abs() <= 1e-3 * t.abs(),
            "{}: {} vs {t}",
            p.name,
            p.value
        );
    }
}

/// With the coefficients at i+1 also among the network's outputs (the
/// reflex-wing UAV paper's Eq. 30, as the neural Gauss–Newton method asks),
/// the noise-free HANSA-3 record is recovered as without them: every
/// parameter within 2e-4 (measured worst 2.4e-5, Cm_alpha).
#[test]
fn coefficient_outputs_ideal() {
    let (problem, scenario) = problem(
        "elm-gn",
        ("hansa3-elevator-multistep", None),
        "ideal",
        "hansa3-longitudinal",
        "",
    );
    let settings = ElmSettings::read("elm-gn", &problem.settings).unwrap();
    let options = restricted::RestrictedOptions {
        coefficient_outputs: true,
        ..settings.options()
    };
    let estimate =
        restricted::estimate("elm-gn", &problem, None, &settings.trainer("elm"), &options)
            .unwrap()
            .assess();
    let truth = truths(&estimate, &scenario);
    print(&estimate, &truth);
    assert!(estimate.status.is_success(), "{}", estimate.status);
    assert_eq!(estimate.network.as_ref().unwrap().outputs.len(), 7);
    assert_eq!(estimate.fits.len(), 7);
    for (p, &t) in estimate.parameters.iter().zip(&truth) {
        assert!(
            (p.value - t).abs() <= 2e-4 * t.abs(),
            "{}: {} vs {t}",
            p.name,
            p.value
        );
    }
}

/// The lateral floor is the network's size: with 120 hidden neurons (the
/// default search stops at 60, where the held-out residual is still
/// falling) the network fits the one-step map to an MSE of 1.5e-10 and the
/// noise-free lateral record is recovered within 1e-4 of the truth
/// (absolute floor 1e-6; measured worst 3.1e-6 relative, CY_r) — the
/// β, p, r, φ inputs suffice on this flight: the cross-coupling the
/// restricted model leaves out does not limit it.
#[test]
fn lateral_ideal_with_a_larger_network() {
    let (problem, scenario) = problem(
        "elm-gn",
        ("attas-lateral-multistep", None),
        "ideal",
        "attas-lateral",
        "hidden_sizes = [120]",
    );
    let estimate = crate::common::registry().estimate(&problem, None).unwrap();
    let truth = truths(&estimate, &scenario);
    print(&estimate, &truth);
    assert!(estimate.status.is_success(), "{}", estimate.status);
    assert_eq!(estimate.network.as_ref().unwrap().hidden, 120);
    for (p, &t) in estimate.parameters.iter().zip(&truth) {
        assert!(
            (p.value - t).abs() <= (1e-4 * t.abs()).max(1e-6),
            "{}: {} vs {t}",
            p.name,
            p.value
        );
    }
}
