//! Tests of `state_space`.

use super::*;
use crate::model::driven::{Column, Linearise};
use crate::structure::{ModelStructure, stall_test_structure};
use InputInterpolation as Setting;
use aeroid_record::recorder::{Profile, record_scenario};
use aeroid_sim::integrator::Interpolation;
use aeroid_sim::scenario::Scenario;

/// A bundled scenario recorded by the 25 Hz flight-test profile (noisy
/// measured pseudo-controls, as output error sees them).
fn recorded(scenario: &str) -> aeroid_record::FlightRecord {
    let scenario = Scenario::load(scenario).unwrap();
    let profile = Profile::load("flight-test-25hz", None).unwrap();
    record_scenario(&scenario, &profile).unwrap().0
}

/// The model file's `[methods.oem]` step and input interpolation, read
/// as output error reads them.
#[derive(serde::Deserialize)]
struct OemTable {
    #[serde(default, deserialize_with = "aeroid_core::units::optional_seconds")]
    step: Option<f64>,
    #[serde(default)]
    interpolation: InputInterpolation,
}

fn model_options(structure: &ModelStructure) -> OemTable {
    let settings = crate::settings::merge_settings("oem", &[&structure.methods]);
    serde_json::from_value(serde_json::Value::Object(settings)).unwrap()
}

/// The view of `structure` on `record` as output error builds its
/// simulation: the model's output-error step (else 25 Hz), the window
/// where every output has samples, the record's initial state (χ from α).
fn view(
    record: &aeroid_record::FlightRecord,
    structure: &ModelStructure,
    interpolation: Setting,
) -> (DrivenStateSpace, FlightPathState) {
    let mut window = (f64::NEG_INFINITY, f64::INFINITY);
    for name in &structure.outputs {
        let times = &record.channel(name).unwrap().times;
        window = (window.0.max(times[0]), window.1.min(*times.last().unwrap()));
    }
    let step = model_options(structure).step.unwrap_or(0.04);
    let simulation = DrivenSimulation::from_record(
        record,
        &structure.integrate,
        &interpolation,
        step,
        window,
        structure.aircraft.aero.takes_measured_alpha_dot(),
    )
    .unwrap();
    let mut initial = simulation.measured()[0];
    for &i in &structure.integrate {
        initial[i] = record
            .channel(FLIGHT_PATH_STATES[i])
            .unwrap()
            .value_at(window.0)
            .unwrap();
    }
    initial[10] = structure.aircraft.aero.steady_separation(initial[1]);
    let model = FlightModel::new(structure.aircraft.clone(), Default::default());
    let outputs = structure
        .outputs
        .iter()
        .map(|name| Observable::parse(name).unwrap())
        .collect();
    (
        DrivenStateSpace::new(simulation, model, outputs).unwrap(),
        initial,
    )
}

/// The ATTAS lateral model on its multistep, and the stall model (χ a
/// state, fed back from α; nonlinear parameters) on the stall manoeuvre.
fn cases() -> [(aeroid_record::FlightRecord, ModelStructure); 2] {
    [
        (
            recorded("attas-lateral-multistep"),
            ModelStructure::load("attas-lateral").unwrap(),
        ),
        (recorded("attas-stall"), stall_test_structure(0.2)),
    ]
}

/// The states x_k of the whole-trajectory simulation at every grid
/// point, simulated plainly or with sensitivities to every parameter.
fn trajectory(
    view: &DrivenStateSpace,
    initial: &FlightPathState,
    sensitivities: Option<Linearise>,
) -> Vec<DVector<f64>> {
    let aero = &view.model.aircraft.aero;
    let columns: Vec<Column> = match sensitivities {
        None => Vec::new(),
        Some(_) => (0..view.parameter_count())
            .map(|i| match aero.term_of(i) {
                Some(_) => Column::Term(i),
                None => Column::Nonlinear(i),
            })
            .collect(),
    };
    let outputs: Vec<Observable> = view.states.iter().map(|&i| Observable::State(i)).collect();
    let mut states = Vec::new();
    view.simulation
        .simulate(
            &view.model,
            initial,
            &outputs,
            &columns,
            sensitivities.unwrap_or(Linearise::GridPoints),
            |_, y, _| states.push(DVector::from_column_slice(y)),
        )
        .unwrap();
    states
}

/// One step of the view from the simulation's state x_k is the
/// simulation's x_{k+1}, bit for bit, at every grid point of the ATTAS
/// lateral multistep and the stall manoeuvre, for a plain simulation
/// and for simulations with sensitivities linearised at the grid points
/// and at every stage (their stage rates are the dual numbers' values).
#[test]
fn step_is_the_simulations_step_bit_for_bit() {
    for (record, structure) in cases() {
        let (view, initial) = view(&record, &structure, model_options(&structure).interpolation);
        let theta = view.parameters();
        for sensitivities in [None, Some(Linearise::GridPoints), Some(Linearise::Stages)] {
            let states = trajectory(&view, &initial, sensitivities);
            assert_eq!(states.len(), view.len());
            for k in 0..view.len() - 1 {
                let next = view
                    .step(k, states[k].as_slice(), theta.as_slice())
                    .unwrap();
                assert!(
                    next.iter()
                        .zip(states[k + 1].iter())
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{} {sensitivities:?}: step {k}: {next} vs {}",
                    structure.name,
                    states[k + 1]
                );
            }
        }
    }
}

/// A step from states the simulation never visited (every state moved
/// by 2 % of its value plus 0.01 in SI units, θ moved by 3 %) is RK4
/// assembled from the view's own f at the stage times, to 1e-12
/// relative (the step takes the angles' sines and cosines by the
/// addition theorems inside a step, within an ulp or two of f's); the
/// inputs are interpolated linearly, so that the last stage's inputs
/// are f's at t_{k+1}. Wrong lengths, a departed state and a step off
/// the grid are errors.
#[test]
fn step_from_an_unvisited_state_is_rk4_of_the_rates() {
    for (record, structure) in cases() {
        let (view, initial) = view(&record, &structure, Interpolation::Linear.into());
        let theta = view.parameters() * 1.03;
        let states = trajectory(&view, &initial, None);
        let h = view.simulation.step;
        for k in (0..view.len() - 1).step_by(37) {
            let x = states[k].map(|v| v * 1.02 + 0.01);
            let next = view.step(k, x.as_slice(), theta.as_slice()).unwrap();
            let t = view.time(k);
            let f =
                |t: f64, x: &DVector<f64>| view.rates(t, x.as_slice(), theta.as_slice()).unwrap();
            let k1 = f(t, &x);
            let k2 = f(t + 0.5 * h, &(&x + &k1 * (0.5 * h)));
            let k3 = f(t + 0.5 * h, &(&x + &k2 * (0.5 * h)));
            let k4 = f(view.time(k + 1), &(&x + &k3 * h));
            let expected = &x + (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0);
            let scale = expected.amax().max(1.0);
            assert!(
                (&next - &expected).amax() <= 1e-12 * scale,
                "{}: step {k}: {next} vs {expected}",
                structure.name
            );
            assert!(next != states[k + 1], "the perturbation moved nothing");
        }
        let x = states[0].clone();
        let n = x.len();
        assert!(
            view.step(0, &x.as_slice()[..n - 1], theta.as_slice())
                .is_err()
        );
        assert!(view.step(0, x.as_slice(), &theta.as_slice()[1..]).is_err());
        assert!(
            view.step(view.len() - 1, x.as_slice(), theta.as_slice())
                .is_err()
        );
        let mut departed = x.clone();
        departed[0] = f64::NAN;
        assert!(view.step(0, departed.as_slice(), theta.as_slice()).is_err());
        assert!(
            view.rates(
                view.time(view.len() - 1) + 1.0,
                x.as_slice(),
                theta.as_slice()
            )
            .is_err()
        );
    }
}

/// Central-difference Jacobian of `g` at `point`: column j is
/// (g(point + δ_j e_j) − g(point − δ_j e_j))/(2δ_j), δ_j = `step(point_j)`.
fn central_differences(
    point: &DVector<f64>,
    step: impl Fn(f64) -> f64,
    g: impl Fn(&DVector<f64>) -> DVector<f64>,
) -> DMatrix<f64> {
    let columns: Vec<DVector<f64>> = (0..point.len())
        .map(|j| {
            let delta = step(point[j]);
            let moved = |sign: f64| {
                let mut moved = point.clone();
                moved[j] += sign * delta;
                g(&moved)
            };
            (moved(1.0) - moved(-1.0)) / (2.0 * delta)
        })
        .collect();
    DMatrix::from_columns(&columns)
}

/// Every column of `exact` within 1e-6 of the largest entry of the
/// column (of either matrix) of `numeric`; a column 0 in both is 0.
fn assert_columns_agree(exact: &DMatrix<f64>, numeric: &DMatrix<f64>, what: &str) {
    assert_eq!(exact.shape(), numeric.shape(), "{what}");
    for j in 0..exact.ncols() {
        let scale = exact.column(j).amax().max(numeric.column(j).amax());
        let error = (exact.column(j) - numeric.column(j)).amax();
        assert!(
            error <= 1e-6 * scale,
            "{what}: column {j}: error {error:.3e} of {scale:.3e}\n{}\nvs\n{}",
            exact.column(j),
            numeric.column(j)
        );
    }
}

/// ∂f/∂x, ∂f/∂θ, ∂h/∂x, ∂h/∂θ against central differences of the
/// view's f and h, to 1e-6 relative per column, at states and
/// parameters (θ moved by 3 %) away from the simulation's, at grid
/// points and at step midpoints (inputs interpolated), on the linear
/// ATTAS lateral model and on the stall model (nonlinear parameters by
/// the view's own central differences of step 10⁻⁵·max(|θ|, 10⁻²)).
/// The test's central-difference steps: 10⁻⁵·max(|x|, 1) for the
/// states, 4·10⁻⁶·max(|θ|, 10⁻²) for the parameters (not the view's,
/// so the comparison is not of one quotient with itself): truncation
/// error ~step²·f‴/6 ≲ 10⁻⁸ relative even through the stall break
/// (f‴ ~ a1³ there), rounding ~ε·|f|/step ≲ 10⁻⁷ relative.
#[test]
fn jacobians_match_central_differences() {
    for (record, structure) in cases() {
        let (view, initial) = view(&record, &structure, model_options(&structure).interpolation);
        let theta = view.parameters() * 1.03;
        let states = trajectory(&view, &initial, None);
        let state_step = |v: f64| 1e-5 * v.abs().max(1.0);
        let parameter_step = |v: f64| 4e-6 * v.abs().max(1e-2);
        for k in [view.len() / 5, view.len() / 2, 4 * view.len() / 5] {
            let x = states[k].map(|v| v * 1.01);
            for t in [view.time(k), view.time(k) + 0.5 * view.simulation.step] {
                let what = |name: &str| format!("{}: t = {t}: {name}", structure.name);
                let jacobians = view.jacobians(t, x.as_slice(), theta.as_slice()).unwrap();
                let rates_of_x =
                    |x: &DVector<f64>| view.rates(t, x.as_slice(), theta.as_slice()).unwrap();
                let outputs_of_x =
                    |x: &DVector<f64>| view.outputs(t, x.as_slice(), theta.as_slice()).unwrap();
                let rates_of_theta =
                    |theta: &DVector<f64>| view.rates(t, x.as_slice(), theta.as_slice()).unwrap();
                let outputs_of_theta =
                    |theta: &DVector<f64>| view.outputs(t, x.as_slice(), theta.as_slice()).unwrap();
                assert_columns_agree(
                    &jacobians.rates_by_state,
                    &central_differences(&x, state_step, rates_of_x),
                    &what("∂f/∂x"),
                );
                assert_columns_agree(
                    &jacobians.outputs_by_state,
                    &central_differences(&x, state_step, outputs_of_x),
                    &what("∂h/∂x"),
                );
                assert_columns_agree(
                    &jacobians.rates_by_parameter,
                    &central_differences(&theta, parameter_step, rates_of_theta),
                    &what("∂f/∂θ"),
                );
                assert_columns_agree(
                    &jacobians.outputs_by_parameter,
                    &central_differences(&theta, parameter_step, outputs_of_theta),
                    &what("∂h/∂θ"),
                );
            }
        }
    }
}
