//! Steps 4–5 of estimation before modelling: the smoothed coefficients
//! (Wang et al. 2012, Eq. 9) and the regressors from the smoothed states
//! (α, β, V, p̂, q̂, r̂, α̇, Mach) and the recorded controls, points near a
//! control step left out, regressed on the structure's terms by equation
//! error's least squares (Klein & Morelli 2006, ch. 5) with its
//! coloured-residual Cramér–Rao bounds.

use super::METHOD;
use super::inputs::thrust_input;
use super::settings::SmoothedRegressionSettings;
use super::smoothed::{Smoothed, speed, wind_axes};
use super::smoother::smooth_with;
use crate::error::Result;
use crate::estimate::Estimate;
use crate::methods::common::regression::{self, Plan};
use crate::model::coefficient_states::{self, CoefficientStates, H, P, U};
use crate::model::state_space::StateSpaceModel;
use crate::reconstruction::{Reconstruction, Request};
use crate::solver::extended_kalman::Keep;
use crate::structure::ModelStructure;
use aeroid_record::FlightRecord;
use aeroid_sim::aero::{AeroInput, ForceAxes, REGRESSOR_COUNT, Regressor};
use aeroid_sim::atmosphere::Atmosphere;
use aeroid_sim::state::{Control, Controls};
use nalgebra::Vector3;

/// The smoothed coefficients and regressors as the regression's data:
/// every grid point, the coefficients in the structure's axes, the
/// regressors from the smoothed states and the recorded controls.
pub(crate) fn regression_data(
    record: &FlightRecord,
    structure: &ModelStructure,
    smoothed: &Smoothed,
    plans: &[Plan],
    step_margin: f64,
) -> Result<Reconstruction> {
    let steps = crate::reconstruction::control_steps(record);
    let near_step = |t: f64| {
        let i = steps.partition_point(|&s| s < t - step_margin);
        steps.get(i).is_some_and(|&s| s <= t + step_margin)
    };
    let request = regression::request(plans);
    let mut controls: Vec<Vec<f64>> = vec![vec![0.0; smoothed.times.len()]; Control::ALL.len()];
    for control in Control::ALL {
        if let Ok(channel) = record.channel(control.name()) {
            controls[control.index()] = channel.values_at(&smoothed.times)?;
        }
    }
    let (thrust, thrust_measured) = thrust_input(record, structure, &smoothed.times)?;
    let mut model = CoefficientStates::new(
        structure.aircraft.clone(),
        smoothed.times[0],
        smoothed.times[1] - smoothed.times[0],
        thrust,
        Vec::new(),
    )?;
    if thrust_measured {
        model = model.with_measured_thrust();
    }
    let atmosphere = Atmosphere::default();
    let mut data = Reconstruction {
        times: Vec::new(),
        coefficients: Default::default(),
        regressors: Vec::new(),
        reference_channel: "ebm grid".into(),
        dynamic_pressure: Vec::new(),
        rate: 1.0 / (smoothed.times[1] - smoothed.times[0]),
        notes: Vec::new(),
    };
    for &coefficient in &request.coefficients {
        data.coefficients[coefficient as usize] = Some(Vec::new());
    }
    let (mut dropped, mut at_steps) = (0, 0);
    for (k, (&t, x)) in smoothed.times.iter().zip(&smoothed.states).enumerate() {
        if near_step(t) {
            at_steps += 1;
            continue;
        }
        let controls = Controls::from_fn(|i, _| controls[i][k]);
        let at = (t, x.as_slice(), controls);
        let Some((regressors, all)) = point_data(structure, &model, &request, &atmosphere, at)?
        else {
            dropped += 1;
            continue;
        };
        data.times.push(t);
        data.regressors.push(regressors);
        for (series, value) in data.coefficients.iter_mut().zip(all) {
            if let Some(series) = series {
                series.push(value);
            }
        }
    }
    data.notes.push(format!(
        "regression on the smoothed coefficients at {} grid points (regressors α, β, V, rates, α̇ from the smoothed states, controls from the record); {at_steps} points within {step_margin} s of a control step left out{}",
        data.times.len(),
        if dropped > 0 {
            format!("; {dropped} points left out (a control not finite)")
        } else {
            String::new()
        }
    ));
    Ok(data)
}

/// The regressors and the six coefficients (lift or CZ, CY, drag or CX,
/// Cl, Cm, Cn) at one smoothed state x at time t with the recorded
/// `controls`: α, β, V, the rates and Mach from x, α̇ from its rates
/// (α̇ = (u·ẇ − w·u̇)/(u² + w²)); None where a requested one is not finite.
fn point_data(
    structure: &ModelStructure,
    model: &CoefficientStates,
    request: &Request,
    atmosphere: &Atmosphere,
    (t, x, controls): (f64, &[f64], Controls),
) -> Result<Option<([f64; REGRESSOR_COUNT], [f64; 6])>> {
    let aero = &structure.aircraft.aero;
    let airspeed = speed(x);
    let (u, w) = (x[U], x[U + 2]);
    let rates = model.rates(t, x, &[])?;
    let alpha_dot = (u * rates[U + 2] - w * rates[U]) / (u * u + w * w);
    let input = AeroInput {
        alpha: w.atan2(u),
        beta: (x[U + 1] / airspeed).clamp(-1.0, 1.0).asin(),
        airspeed,
        mach: airspeed / atmosphere.at(x[H]).speed_of_sound,
        rates: Vector3::new(x[P], x[P + 1], x[P + 2]),
        alpha_dot,
        measured_alpha_dot: None,
        controls,
        chi: 1.0,
    };
    let (lift, drag) = match aero.force_axes {
        ForceAxes::Wind => wind_axes(x),
        ForceAxes::Body => (
            x[coefficient_states::coefficient(2)],
            x[coefficient_states::coefficient(0)],
        ),
    };
    let all = [
        lift,
        x[coefficient_states::coefficient(1)],
        drag,
        x[coefficient_states::coefficient(3)],
        x[coefficient_states::coefficient(4)],
        x[coefficient_states::coefficient(5)],
    ];
    let mut regressors: [f64; REGRESSOR_COUNT] = aero.regressors(&input, 1.0);
    regressors[Regressor::LiftSquared as usize] = lift * lift;
    let finite = request
        .regressors
        .iter()
        .all(|&r| regressors[r as usize].is_finite())
        && request
            .coefficients
            .iter()
            .all(|&c| all[c as usize].is_finite());
    Ok(finite.then_some((regressors, all)))
}

/// Steps 1–5 of `smoothed_regression`'s header: the smoothed histories
/// and the estimate.
pub fn smooth_and_regress(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
) -> Result<(Smoothed, Estimate)> {
    let plans = regression::plans(structure, METHOD)?;
    let smoothed = smooth_with(
        record,
        structure,
        settings,
        &plans,
        Keep::SEQUENTIAL_SMOOTHER,
    )?;
    let estimate = regress_smoothed(record, structure, settings, plans, &smoothed)?;
    Ok((smoothed, estimate))
}

/// Step 5 of `smoothed_regression`'s header: the regression of the smoothed histories.
pub(super) fn regress_smoothed(
    record: &FlightRecord,
    structure: &ModelStructure,
    settings: &SmoothedRegressionSettings,
    plans: Vec<Plan>,
    smoothed: &Smoothed,
) -> Result<Estimate> {
    let data = regression_data(record, structure, smoothed, &plans, settings.step_margin)?;
    Ok(regression::regress(
        record,
        structure,
        METHOD,
        &[(plans, data)],
        settings.correlation_lag,
    ))
}
