//! Air density derived from a Quick Access Recorder's pressure altitude,
//! total air temperature and Mach number (`aeroid derive`,
//! `prep::air_data`), against the simulator's density on the approach.

use aeroid::prep::derive::{Options, derive};
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;

/// The transport approach (5 822 → 3 949 m, 172.9 → 87.7 m/s) by
/// qar-seed000: pressure altitude at 1 Hz in 1-ft steps, total air
/// temperature at 1 Hz in 0.25-K steps, calibrated airspeed at 1 Hz in
/// 0.25-kt steps, Mach at 1/36 Hz in steps of 0.002. The derived density
/// against the true density (the ideal recorder's channel) at the derived
/// instants.
///
/// What the channels allow, from ρ = p/(R·T), T = TAT/(1 + 0.2·M²): half a
/// step of pressure altitude moves ln p by g/(R·T)·0.15 m ≈ 2e-5; half a
/// step of TAT moves ln T by 0.125/260 ≈ 5e-4; M from the calibrated
/// airspeed (half a step, 0.13 kt) moves ln T by 0.4·M·δM/(1 + 0.2·M²)
/// ≈ 5e-5: about 6e-4 at worst. Measured: RMS relative error 2.7e-4,
/// worst 7.1e-4. With M read from the 1/36-Hz Mach channel instead (the
/// record without its airspeed) the slow channel's interpolation on the
/// decelerating approach dominates: RMS 2.3e-3, worst 6.5e-3. Asserted:
/// RMS within 5e-4, worst within 1e-3, and the Mach channel's route worse.
#[test]
fn density_from_the_qar_follows_the_truth() {
    let scenario = Scenario::load("transport-approach").unwrap();
    let (qar, _) =
        record_scenario(&scenario, &Profile::load("qar-seed000", None).unwrap()).unwrap();
    let (ideal, _) = record_scenario(&scenario, &Profile::load("ideal", None).unwrap()).unwrap();
    let truth = ideal.channel("density").unwrap();
    let errors = |record: &aeroid::record::FlightRecord| {
        let derived = derive(record, &Options::default()).unwrap();
        assert!(
            derived
                .notes
                .iter()
                .any(|n| n.starts_with("density: added")),
            "{:?}",
            derived.notes
        );
        let density = derived.record.channel("density").unwrap().clone();
        let errors: Vec<f64> = density
            .times
            .iter()
            .zip(&density.values)
            .filter_map(|(t, value)| Some(value / truth.value_at(*t)? - 1.0))
            .collect();
        assert!(errors.len() > 100);
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        let worst = errors.iter().fold(0.0_f64, |a, e| a.max(e.abs()));
        (rms, worst, density.source)
    };
    let (rms, worst, source) = errors(&qar);
    assert!(source.contains("calibrated_airspeed"), "{source}");
    let mut without_airspeed = qar.clone();
    without_airspeed
        .channels
        .retain(|c| c.name != "calibrated_airspeed");
    let (slow_rms, slow_worst, slow_source) = errors(&without_airspeed);
    assert!(
        !slow_source.contains("calibrated_airspeed"),
        "{slow_source}"
    );
    println!(
        "density from the QAR: RMS relative error {rms:.2e}, worst {worst:.2e}; from the Mach channel: RMS {slow_rms:.2e}, worst {slow_worst:.2e}"
    );
    assert!(rms <= 5e-4, "RMS {rms:.2e}");
    assert!(worst <= 1e-3, "worst {worst:.2e}");
    assert!(slow_rms > rms, "{slow_rms:.2e}");
}
