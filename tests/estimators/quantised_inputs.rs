//! A quantised control channel that nothing moves (an unused flap at the
//! edge of a level, flipping by one LSB hundreds of times) is not a
//! sequence of control steps: the differentiator does not break at its
//! flips, and equation error's estimate from differentiated rates is the
//! same as with the flap held still.
//!
//! The flight: the bundled ATTAS elevator 3-2-1-1 recorded by the ideal
//! profile, without its angular-acceleration channels so that equation
//! error differentiates p, q and r.

use aeroid::estimation::methods::equation_error::{EquationErrorOptions, equation_error};
use aeroid::estimation::reconstruction::control_corners;
use aeroid::estimation::structure::ModelStructure;
use aeroid::record::FlightRecord;
use aeroid::record::recorder::{Profile, record_scenario};
use aeroid::sim::scenario::Scenario;
use aeroid::units::DEG;

/// The record with its flap channel's values from `flap(k)`.
fn with_flap(flap: impl Fn(usize) -> f64) -> FlightRecord {
    let scenario = Scenario::load("attas-elevator-3211").unwrap();
    let profile = Profile::load("ideal", None).unwrap();
    let mut record = record_scenario(&scenario, &profile).unwrap().0;
    record
        .channels
        .retain(|c| !matches!(c.name.as_str(), "p_dot" | "q_dot" | "r_dot"));
    let channel = record
        .channels
        .iter_mut()
        .find(|c| c.name == "flap")
        .unwrap();
    channel.values = (0..channel.values.len()).map(flap).collect();
    record
}

/// 1 LSB = 0.01°, flipped at pseudo-random samples (about one in eight).
#[test]
fn one_lsb_flips_of_an_unused_flap_move_no_estimate() {
    let lsb = 0.01 * DEG;
    let flip = |k: usize| (k.wrapping_mul(2_654_435_761) >> 7).is_multiple_of(8);
    let still = with_flap(|_| 0.0);
    let flipping = with_flap(|k| if flip(k) { lsb } else { 0.0 });
    let flips = flipping
        .channel("flap")
        .unwrap()
        .values
        .windows(2)
        .filter(|w| w[0] != w[1])
        .count();
    assert!(flips > 200, "{flips} flips");
    assert_eq!(control_corners(&flipping), control_corners(&still));
    let structure = ModelStructure::load("attas-longitudinal").unwrap();
    let options = EquationErrorOptions::default();
    let a = equation_error(&still, &structure, &options).unwrap();
    let b = equation_error(&flipping, &structure, &options).unwrap();
    assert!(!a.parameters.is_empty());
    for (x, y) in a.parameters.iter().zip(&b.parameters) {
        assert_eq!(x.name, y.name);
        assert!(
            (x.value - y.value).abs() <= 1e-9 * x.value.abs().max(1e-6),
            "{}: {} with the flap still, {} flipping",
            x.name,
            x.value,
            y.value
        );
    }
}
