//! The data-quality report (crates/record/src/quality.rs) on simulated records.

use aeroid::record::quality::{Stuck, assess};
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use aeroid::units::DEG;

/// The QAR of Wang et al. 2012 on the transport approach (gusts and
/// turbulence): the angle-of-attack channel, which reads only 109.70° or
/// 108.30°, is stuck at those levels; no other channel is flagged (the
/// rudder that never moves, the constant gross weight, the flaps that hold
/// between steps and the aileron pulses included). Every quantized
/// channel's inferred resolution is a whole multiple of its declared one
/// (a multiple when the signal skips steps, as a slow 1/64 Hz channel does).
#[test]
fn qar_record_flags_only_the_stuck_angle_of_attack() {
    let scenario = Scenario::load("transport-approach").unwrap();
    let profile = Profile::load("qar-seed000", None).unwrap();
    let (record, _) = record_scenario(&scenario, &profile).unwrap();
    let report = assess(&record);
    println!("{}", report.table());
    assert_eq!(report.flagged(), ["alpha"]);
    let alpha = report.channel("alpha").unwrap();
    let Some(Stuck::Levels { values }) = &alpha.stuck else {
        panic!("{:?}", alpha.stuck);
    };
    assert_eq!(values.len(), 2);
    assert!((values[0] - 108.3 * DEG).abs() < 1e-12 && (values[1] - 109.7 * DEG).abs() < 1e-12);
    for channel in &report.channels {
        if let (Some(declared), Some(inferred)) =
            (channel.declared_resolution, channel.inferred_resolution)
        {
            let multiple = inferred / declared;
            assert!(
                multiple >= 0.999 && (multiple - multiple.round()).abs() < 1e-3,
                "{}: {inferred} vs {declared}",
                channel.name
            );
        }
    }
}

/// The 25 Hz flight-test profile (white noise, no quantization) on the same
/// flight, and on the ATTAS lateral multistep: no channel flagged.
#[test]
fn flight_test_records_have_no_false_alarms() {
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    for name in ["transport-approach", "attas-lateral-multistep"] {
        let scenario = Scenario::load(name).unwrap();
        let (record, _) = record_scenario(&scenario, &profile).unwrap();
        let report = assess(&record);
        assert!(report.flagged().is_empty(), "{name}\n{}", report.table());
    }
}
