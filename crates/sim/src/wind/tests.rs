//! Tests of the wind: steady wind, gusts, the checks of the table, the
//! intensity and altitude rules, and the seeds.

use super::*;
use aeroid_core::error::FieldErrors;
use aeroid_core::units::{FOOT, KNOT};
use nalgebra::Vector3;
use serde::Deserialize;

/// Parses a scenario fragment holding a `[wind]` table.
fn parse(text: &str) -> WindSpec {
    #[derive(Deserialize)]
    struct Scenario {
        wind: WindSpec,
    }
    toml::from_str::<Scenario>(text).expect("valid TOML").wind
}

pub(super) const CRUISE: FlightConditions = FlightConditions {
    airspeed: 100.0,
    altitude: 300.0,
};

pub(super) fn explicit_turbulence(sigma: [f64; 3], length: [f64; 3]) -> WindSpec {
    WindSpec {
        turbulence: Some(TurbulenceSpec {
            sigma_u: Some(sigma[0].into()),
            sigma_v: Some(sigma[1].into()),
            sigma_w: Some(sigma[2].into()),
            length_u: Some(length[0].into()),
            length_v: Some(length[1].into()),
            length_w: Some(length[2].into()),
            ..TurbulenceSpec::default()
        }),
        ..WindSpec::default()
    }
}

pub(super) fn assert_close(actual: f64, expected: f64, tolerance: f64, what: &str) {
    assert!(
        (actual - expected).abs() <= tolerance,
        "{what}: {actual} vs {expected}"
    );
}

#[test]
fn steady_wind_from_west_blows_towards_east() {
    let spec = parse("[wind]\nspeed = \"10 kt\"\nfrom_direction = \"270 deg\"\n");
    let samples = spec.generate(&CRUISE, 0.01, 3, 1).unwrap();
    let expected = Vector3::new(0.0, 10.0 * KNOT, 0.0);
    for sample in samples {
        assert!((sample.ned - expected).norm() < 1e-12, "{:?}", sample.ned);
        assert_eq!(sample.body, Vector3::zeros());
    }
    let from_north = parse("[wind]\nspeed = 4.0\nfrom_direction = 0.0\n");
    let sample = from_north.generate(&CRUISE, 0.01, 1, 1).unwrap()[0];
    assert!((sample.ned - Vector3::new(-4.0, 0.0, 0.0)).norm() < 1e-12);
}

#[test]
fn gust_has_one_minus_cosine_shape_on_top_of_steady_wind() {
    let spec = parse(
        r#"
        [wind]
        speed = 2.0
        from_direction = "180 deg"
        [[wind.gusts]]
        start = "1 s"
        duration = "2 s"
        amplitude = 6.0
        direction = "up"
        "#,
    );
    let samples = spec.generate(&CRUISE, 0.5, 9, 1).unwrap();
    let down: Vec<f64> = samples.iter().map(|sample| sample.ned.z).collect();
    let expected = [0.0, 0.0, 0.0, -3.0, -6.0, -3.0, 0.0, 0.0, 0.0];
    for (time_index, (actual, expected)) in down.iter().zip(expected).enumerate() {
        assert_close(
            *actual,
            expected,
            1e-12,
            &format!("down at sample {time_index}"),
        );
    }
    for sample in &samples {
        assert_close(sample.ned.x, 2.0, 1e-12, "wind from south blows north");
    }
}

#[test]
fn documented_example_is_valid() {
    let documentation = include_str!("../../../../docs/files.md");
    let example: String = documentation
        .split("```toml\n")
        .find(|block| block.starts_with("[wind]"))
        .and_then(|rest| rest.split("```").next())
        .expect("docs/files.md holds a [wind] example")
        .to_string();
    let spec = parse(&example);
    let mut problems = FieldErrors::default();
    spec.validate(&mut problems);
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(spec.gusts.len(), 1);
    let samples = spec.generate(&CRUISE, 0.01, 1000, 3).unwrap();
    assert_close(samples[600].ned.z, -4.0, 1e-9, "gust peak at 6 s");
    assert_close(samples[0].ned.y, 15.0 * KNOT, 1e-9, "steady east wind");
}

#[test]
fn validation_collects_every_problem_at_once() {
    let spec = parse(
        r#"
        [wind]
        speed = "5 deg"
        [[wind.gusts]]
        duration = 3.0
        amplitude = 1.0
        direction = "up"
        [[wind.gusts]]
        duration = -1.0
        amplitude = 1.0
        direction = "sideways"
        [wind.turbulence]
        intensity = "moderate"
        sigma_u = 1.0
        length_w = 0.0
        "#,
    );
    let mut problems = FieldErrors::default();
    spec.validate(&mut problems);
    let fields: Vec<&str> = problems
        .0
        .iter()
        .map(|problem| problem.field.as_str())
        .collect();
    assert_eq!(
        fields,
        [
            "wind.speed",
            "wind.gusts[1].duration",
            "wind.gusts[1].direction",
            "wind.turbulence",
            "wind.turbulence.length_w",
        ],
        "{problems:?}"
    );
    let error = spec.generate(&CRUISE, 0.01, 10, 1).unwrap_err().to_string();
    assert!(
        error.contains("wind.gusts[1].direction") && error.contains("sideways"),
        "{error}"
    );
}

#[test]
fn partial_explicit_sigmas_and_unknown_fields_are_rejected() {
    let spec = parse("[wind.turbulence]\nsigma_u = 1.0\n");
    let mut problems = FieldErrors::default();
    spec.validate(&mut problems);
    let fields: Vec<&str> = problems
        .0
        .iter()
        .map(|problem| problem.field.as_str())
        .collect();
    assert_eq!(
        fields,
        ["wind.turbulence.sigma_v", "wind.turbulence.sigma_w"]
    );
    assert!(toml::from_str::<WindSpec>("speeed = 3.0").is_err());
    assert!(WindSpec::default().generate(&CRUISE, 0.0, 1, 1).is_err());
}

#[test]
fn intensity_rules_at_500_ft() {
    let parameters = |intensity: &str| {
        let spec = TurbulenceSpec {
            intensity: Some(intensity.into()),
            ..Default::default()
        };
        spec.parameters(500.0 * FOOT).unwrap()
    };
    // σw = 0.1·W20; σu = σv = σw/(0.177 + 0.000823·500)^0.4 = σw/0.80888.
    let expected_sigmas = [
        ("light", 0.953_962_172_090_088_3, 0.771_666_666_666_666_7),
        ("moderate", 1.907_924_344_180_176_5, 1.543_333_333_333_333_4),
        ("severe", 2.861_886_516_270_265, 2.315_000_000_000_000_4),
    ];
    for (intensity, sigma_u, sigma_w) in expected_sigmas {
        let TurbulenceParameters { sigma, length } = parameters(intensity);
        let tolerance = 1e-12;
        assert_close(sigma[0], sigma_u, tolerance, intensity);
        assert_close(sigma[1], sigma_u, tolerance, intensity);
        assert_close(sigma[2], sigma_w, 1e-12, intensity);
        // Lw = h = 152.4 m; Lu = Lv = 500 ft/0.5885^1.2 = 944.65 ft.
        assert_close(length[0], 287.931_517_669_529, 1e-9, "Lu");
        assert_close(length[1], 287.931_517_669_529, 1e-9, "Lv");
        assert_close(length[2], 152.4, 1e-9, "Lw");
    }
}

#[test]
fn intensity_rules_above_and_between_the_low_altitude_model() {
    let moderate = TurbulenceSpec {
        intensity: Some("Moderate".into()),
        ..Default::default()
    };
    // 5000 ft: 10.6 + (10.1 − 10.6)·1250/3750 ft/s, L = 1750 ft.
    let high = moderate.parameters(5000.0 * FOOT).unwrap();
    assert_eq!(high.sigma.map(|s| (s * 1e9).round()), [3.180_08e9; 3]);
    assert_eq!(high.length.map(|l| (l * 1e9).round()), [533.4e9; 3]);
    // 1500 ft: half-way between 0.1·30 kt (1000 ft) and 9.725 ft/s (2000 ft); L half-way
    // between 1000 ft and 1750 ft.
    let between = moderate.parameters(1500.0 * FOOT).unwrap();
    for axis in 0..3 {
        assert_close(
            between.sigma[axis],
            2.253_756_666_666_667,
            1e-9,
            "σ at 1500 ft",
        );
        assert_close(between.length[axis], 419.1, 1e-9, "L at 1500 ft");
    }
    // Explicit lengths override the altitude rules; missing ones follow them.
    let mut explicit = explicit_turbulence([1.0, 2.0, 3.0], [10.0, 20.0, 30.0])
        .turbulence
        .unwrap();
    explicit.length_v = None;
    let parameters = explicit.parameters(500.0 * FOOT).unwrap();
    assert_eq!(parameters.sigma, [1.0, 2.0, 3.0]);
    assert_close(
        parameters.length[1],
        287.931_517_669_529,
        1e-9,
        "default Lv",
    );
    assert_eq!([parameters.length[0], parameters.length[2]], [10.0, 30.0]);
}

#[test]
fn same_seed_is_bit_identical_and_different_seed_differs() {
    let mut spec = explicit_turbulence([1.0, 2.0, 3.0], [100.0, 80.0, 60.0]);
    spec.speed = 5.0.into();
    let bits = |samples: &[WindSample]| -> Vec<u64> {
        samples
            .iter()
            .flat_map(|s| s.ned.iter().chain(s.body.iter()).map(|v| v.to_bits()))
            .collect()
    };
    let first = spec.generate(&CRUISE, 0.01, 500, 42).unwrap();
    let again = spec.generate(&CRUISE, 0.01, 500, 42).unwrap();
    let shorter = spec.generate(&CRUISE, 0.01, 200, 42).unwrap();
    let other = spec.generate(&CRUISE, 0.01, 500, 43).unwrap();
    assert_eq!(bits(&first), bits(&again));
    assert_eq!(
        bits(&first[..200]),
        bits(&shorter),
        "a shorter run is a prefix"
    );
    let differing = first
        .iter()
        .zip(&other)
        .filter(|(a, b)| a.body != b.body)
        .count();
    assert_eq!(differing, 500, "another seed gives other turbulence");
}
