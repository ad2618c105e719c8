//! The registered method and the fit of a 6-DOF structure: the states
//! driven by process noise, the start, the fit and the estimate.

use super::*;

/// States that are not driven by process noise by default: attitude,
/// heading and altitude are kinematic integrals, χ is internal.
pub(super) const NOISELESS_STATES: [&str; 5] = ["roll", "pitch", "yaw", "altitude", "chi"];

/// Filter error as a registered method.
pub(crate) struct FilterError;

impl Method for FilterError {
    const NAME: &'static str = METHOD;
    type Settings = FilterErrorOptions;

    fn describe() -> Description {
        Description {
            title: "filter error: maximum likelihood with a steady-state extended Kalman filter in the loop, for flights with turbulence",
            paper: "Maine & Iliff, \"Identification of dynamic systems\" (NASA RP-1138, 1985); Jategaonkar, \"Flight Vehicle System Identification\", 2nd ed., ch. 5",
            equations: "innovations ν = z − ỹ of x̃_k = step(x̂_{k−1}), x̂ = x̃ + K·ν, K = P·Cᵀ·R⁻¹ (Jategaonkar §5.5, Eq. 5.48), P from the discrete Riccati equation of the model linearised at the first point; cost ½·Σ(νᵀR⁻¹ν + ln det R), R = (1/N)·Σ ν·νᵀ (whole where the outputs share one time base, fitted from the diagonal R's estimate; diagonal with innovation_covariance = \"diagonal\" or on a multi-rate record), Gauss–Newton on θ and F with R fixed, F compensated after each R update (Eq. 5.41), diag(K·C) ≤ 1 (§5.3); Cramér–Rao bounds from M = Σ (∂ν/∂θ)ᵀR⁻¹(∂ν/∂θ). gain = \"time_varying\": the EKF in the loop (Jategaonkar §7.2, Eqs. 7.11–7.19), P̃_k = Φ_k·P̂_{k−1}·Φ_kᵀ + Q_d, K_k = P̃_k·C_kᵀ·(C_k·P̃_k·C_kᵀ + G·Gᵀ)⁻¹, cost ½·Σ(νᵀS_k⁻¹ν + ln det S_k), θ, F and G by Fisher scoring",
            needs: "the compared outputs, the controls, and every flight-path state the model does not integrate (pseudo-controls)",
            settings: vec![
                (
                    "start",
                    "\"ee\": equation error's estimates where they converge; \"model\": the model file's values",
                ),
                ("max_iterations", "Gauss–Newton iterations at most"),
                (
                    "step",
                    "integration step, e.g. \"0.04 s\"; none: the fastest compared channel's period",
                ),
                (
                    "interpolation",
                    "inputs inside an integration step: \"auto\" (each input held where its samples are piecewise constant, linear where it ramps or moves; said in the notes), \"zoh\" (hold), \"linear\", or a table by channel, e.g. { aileron = \"linear\" }",
                ),
                (
                    "process_noise",
                    "the integrated states driven by process noise, one F entry each; none: all but roll, pitch, yaw, altitude and chi",
                ),
                (
                    "gain",
                    "\"steady\": the steady-state gain of the model linearised at the first point, R by relaxation; \"time_varying\": the extended Kalman filter, covariance propagated at every point, G·Gᵀ by relaxation",
                ),
                (
                    "initial_variance",
                    "with gain = \"time_varying\": the initial state's error variance per state, e.g. { z1 = 5.8 }; states not named start known",
                ),
                (
                    "innovation_covariance",
                    "with gain = \"steady\": \"full\" (the default; R = (1/N)·Σ ν·νᵀ whole where every output shares one time base, fitted from the diagonal R's estimate: honest bounds where outputs share a state's prediction error, e.g. β and n_y) or \"diagonal\" (one variance per output)",
                ),
            ],
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            tied_parameters: true,
            starts_from: Some(EQUATION_ERROR),
            ..Capabilities::default()
        }
    }

    fn validate(settings: &FilterErrorOptions) -> Result<()> {
        settings.check()
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        options: &FilterErrorOptions,
        start: Option<&Estimate>,
    ) -> Result<Estimate> {
        match &problem.structure {
            Structure::SixDof(structure) => {
                filter_error_from(problem.record(), structure, options, start)
            }
            Structure::Linear(structure) => {
                crate::estimator::refuse_for_linear(
                    METHOD,
                    &problem.settings,
                    &structure.name,
                    &[
                        (
                            "start",
                            "a linear model's fit starts from its file's values: only \"model\"",
                        ),
                        (
                            "interpolation",
                            "a linear model states its inputs' interpolation in its file",
                        ),
                    ],
                )?;
                linear_fit(
                    METHOD,
                    problem.record(),
                    structure,
                    &LinearFitOptions {
                        max_iterations: options.max_iterations,
                        step: options.step,
                        window: options.window,
                        gain: options.gain,
                        initial_variance: options.initial_variance.clone(),
                        innovation_covariance: options.innovation_form(),
                        process_noise: Some(
                            options
                                .process_noise
                                .clone()
                                .unwrap_or_else(|| structure.states.clone()),
                        ),
                    },
                )
            }
        }
    }
}

/// Fits `structure` to `record` by filter error.
pub fn filter_error(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &FilterErrorOptions,
) -> Result<Estimate> {
    filter_error_from(record, structure, options, None)
}

/// The integrated states driven by process noise (indices into x).
pub(super) fn noisy_states(
    view: &DrivenStateSpace,
    options: &FilterErrorOptions,
) -> Result<Vec<usize>> {
    let names = view.state_names();
    match &options.process_noise {
        None => Ok((0..names.len())
            .filter(|&i| !NOISELESS_STATES.contains(&names[i]))
            .collect()),
        Some(chosen) => {
            chosen
                .iter()
                .map(|name| {
                    names.iter().position(|n| n == name).ok_or_else(|| {
                    Error::Setting { method: METHOD.to_string(), reason: format!(
                        "process_noise: '{name}' is not an integrated state of the model ({})",
                        names.join(", ")
                    ) }
                })
                })
                .collect()
        }
    }
}

/// Filter error with equation error's estimate on the record given (else
/// computed when the start asks for it).
pub(crate) fn filter_error_from(
    record: &FlightRecord,
    structure: &ModelStructure,
    options: &FilterErrorOptions,
    regression: Option<&Estimate>,
) -> Result<Estimate> {
    let started = std::time::Instant::now();
    let free = free_parameters(
        METHOD,
        record,
        missing_channels(record, structure),
        &structure.name,
        &structure.free,
    )?;
    unsuitable(METHOD, structure)?;
    let (view, initial) = DrivenStateSpace::for_record(
        record,
        structure,
        &options.interpolation,
        options.step,
        options.window,
    )?;
    let noisy = noisy_states(&view, options)?;
    let step = view.time(1) - view.time(0);
    let observations =
        Observations::from_record(record, &structure.outputs, view.time(0), step, view.len())?;
    enough_data(METHOD, &[&observations], free.len() + noisy.len())?;
    let mut notes: Vec<String> = observations.note(step).into_iter().collect();
    notes.extend(view.simulation().notes.iter().cloned());
    let file = view.parameters();
    let state_names = view.state_names();
    let parameter_names = structure.aircraft.aero.parameters.names();
    let names = Names {
        parameters: free.iter().map(|&i| parameter_names[i].clone()).collect(),
        noise: noise_names(
            noisy.iter().map(|&i| state_names[i]),
            &structure.outputs,
            options.gain,
        ),
        states: state_names.iter().map(|s| s.to_string()).collect(),
    };
    let mut fit = FilterErrorFit::new(
        &view,
        &observations,
        initial,
        file.clone(),
        free.clone(),
        noisy.clone(),
    )?
    .with_names(names.unknowns());
    if options.gain == Gain::TimeVarying {
        let covariance =
            initial_covariance(METHOD, &view.state_names(), &options.initial_variance)?;
        fit = fit.with_time_varying_gain(covariance)?;
    }
    let mut fit = fit.with_innovation_form(options.innovation_form(), &mut notes);
    let solver = Options::maximum_likelihood(
        &free,
        &structure.bounds,
        options.max_iterations,
        CONVERGED_DECREASE,
    );
    let regression = match options.start {
        Start::EquationError => regression_start(record, structure, regression, &file, &mut notes),
        Start::Model => None,
    };
    let result = fit_from_start(&mut fit, regression, &file, solver, &mut notes)?;
    Ok(assemble(
        (METHOD, &structure.name, &structure.outputs),
        record,
        &fit,
        &result,
        &names,
        notes,
        started.elapsed().as_secs_f64(),
    ))
}

/// The fit from equation error's estimate `regression` where there is one
/// and a filter exists there, else from the model file's values `file`;
/// a note says which.
fn fit_from_start<M: StateSpaceModel + ?Sized>(
    fit: &mut FilterErrorFit<'_, M>,
    regression: Option<DVector<f64>>,
    file: &DVector<f64>,
    solver: Options,
    notes: &mut Vec<String>,
) -> Result<FitResult> {
    match regression {
        Some(theta) => match fit.fit(&theta, solver.clone()) {
            Ok(result) => {
                notes.push("started from equation error's estimates".into());
                Ok(result)
            }
            Err(error) => {
                notes.push(format!(
                    "started from the model file's values: no filter from equation error's estimates ({error})"
                ));
                fit.fit(file, solver)
            }
        },
        None => fit.fit(file, solver),
    }
}
