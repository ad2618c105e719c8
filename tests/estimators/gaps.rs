//! A record with a gap (two manoeuvres joined in one file, nothing
//! recorded between them) is fitted as the two manoeuvres: no estimator
//! integrates or differentiates across time nobody recorded.
//!
//! The flight: the bundled ATTAS elevator 3-2-1-1 recorded by the ideal
//! profile (noise-free), with every sample from 25 s to 35 s removed: the
//! second piece starts mid-manoeuvre, in a state the first piece's end
//! does not determine.

use crate::common;
use aeroid::estimation::estimate::Estimate;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;

fn gapped() -> (FlightRecord, Scenario) {
    let scenario = Scenario::load("attas-elevator-3211").unwrap();
    let (mut record, _) =
        record_scenario(&scenario, &Profile::load("ideal", None).unwrap()).unwrap();
    for channel in &mut record.channels {
        let keep: Vec<bool> = channel
            .times
            .iter()
            .map(|t| !(25.0..35.0).contains(t))
            .collect();
        let mut k = keep.iter();
        channel.times.retain(|_| *k.next().unwrap());
        let mut k = keep.iter();
        channel.values.retain(|_| *k.next().unwrap());
    }
    (record, scenario)
}

fn fit(record: FlightRecord) -> Estimate {
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let problem = common::registry()
        .problem("oem", vec![record], structure, &[])
        .unwrap();
    common::registry().estimate(&problem, None).unwrap()
}

/// Split at its gap, the noise-free record gives the truth as a whole
/// record does (every aerodynamic estimate within 1e-4 relative: the ideal record is
/// exact to its rounding, and output error on it converges to the truth);
/// the note says where the record was split. Bridged on request, output
/// error integrates through the ten unrecorded seconds on interpolated
/// controls and states and lands off the truth.
#[test]
fn a_gap_splits_the_record_into_two_manoeuvres() {
    let (record, scenario) = gapped();
    assert_eq!(record.time_gaps().len(), 1, "{:?}", record.time_gaps());
    let split = fit(record.clone());
    assert!(
        split
            .notes
            .iter()
            .any(|n| n.contains("2 separate manoeuvres")),
        "{:?}",
        split.notes
    );
    let rows = common::against_truth(&split, &scenario);
    let table = common::truth_table(&rows);
    for (name, value, _, truth) in rows.iter().filter(|row| row.3.is_finite()) {
        assert!(
            (value - truth).abs() <= 1e-4 * truth.abs().max(0.01),
            "{name}: {value} against {truth}\n{table}"
        );
    }
    let bridged = fit(FlightRecord {
        bridge_gaps: true,
        ..record
    });
    assert!(
        !bridged
            .notes
            .iter()
            .any(|n| n.contains("separate manoeuvres"))
    );
    let worst = common::against_truth(&bridged, &scenario)
        .iter()
        .filter(|row| row.3.is_finite())
        .map(|(_, value, _, truth)| (value - truth).abs() / truth.abs().max(0.01))
        .fold(0.0, f64::max);
    assert!(
        worst > 1e-3,
        "bridging the gap left every estimate at the truth (worst {worst:.1e})"
    );
}

/// A method that fits one record at a time refuses the split record and
/// says that the two records are the pieces of one.
#[test]
fn a_one_record_method_says_the_record_was_split() {
    let (record, _) = gapped();
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let problem = common::registry()
        .problem("ekf", vec![record], structure, &[])
        .unwrap();
    let error = common::registry().estimate(&problem, None).unwrap_err();
    assert!(error.refusal().is_some(), "{error}");
    let message = error.to_string();
    assert!(
        message.contains("given 2") && message.contains("separate manoeuvres"),
        "{message}"
    );
}
