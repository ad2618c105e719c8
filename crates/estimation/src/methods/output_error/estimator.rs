//! Output error behind the estimator interface: settings, refusals and the call.

use super::*;

/// Output error as a registered method.
pub(crate) struct OutputError;

impl Method for OutputError {
    const NAME: &'static str = METHOD;
    type Settings = OutputErrorOptions;

    fn describe() -> Description {
        Description {
            title: "output error: maximum likelihood, Gauss–Newton on det(R) with the sensitivity equations",
            paper: "Maine & Iliff, \"Application of parameter estimation to aircraft stability and control: the output-error approach\" (NASA RP-1168); Jategaonkar, \"Flight Vehicle System Identification\", ch. 4; Verma & Peyada 2020",
            equations: "cost det(R), R = (1/N)·Σ e·eᵀ, Gauss–Newton steps (Verma & Peyada 2020, Eqs. 5–10); sensitivity equations Ṡ = (∂f/∂x)S + ∂f/∂θ (Jategaonkar §4.6); Cramér–Rao bounds from M = Σ (∂y/∂θ)ᵀR⁻¹(∂y/∂θ)",
            needs: "the compared outputs, the controls, and every flight-path state the model does not integrate (pseudo-controls)",
            settings: vec![
                (
                    "start",
                    "\"ee\": equation error's estimates where they fit better than the model file's values; \"model\": the model file's values, initial states first held",
                ),
                ("max_iterations", "Gauss–Newton iterations at most"),
                (
                    "step",
                    "integration step, e.g. \"0.04 s\"; none: the fastest compared channel's period, divided into RK4 sub-steps of h·|λ| ≤ 0.5 for the model's fastest mode, re-chosen as the parameters move (said in the notes)",
                ),
                (
                    "interpolation",
                    "inputs inside an integration step: \"auto\" (each input held where its samples are piecewise constant, linear where it ramps or moves; said in the notes), \"zoh\" (hold), \"linear\", or a table by channel, e.g. { aileron = \"linear\" }",
                ),
                (
                    "estimate_initial_state",
                    "initial values of the integrated states as unknowns, per manoeuvre (a linear model's states, per record)",
                ),
                (
                    "output_biases",
                    "outputs with a constant bias as an unknown",
                ),
                (
                    "starts",
                    "fits from this many starts: the usual one and N − 1 from the model file's values moved at random; the least-cost converged fit is the estimate, and another converged minimum of equal cost with other parameters makes it unidentified",
                ),
                (
                    "start_spread",
                    "the extra starts move each free parameter by up to this fraction of max(|value|, 0.01)",
                ),
                ("start_seed", "seed of the extra starts"),
                (
                    "segment",
                    "split each record into pieces of about this length, e.g. \"20 s\", each simulated from its own initial state (multiple shooting; with estimate_initial_state, per piece; on a linear model always estimated): stabilised output error for an unstable model, pieces shorter than its time to double; none: one piece per record",
                ),
                (
                    "correlation_lag",
                    "lag, e.g. \"20 s\", to which the residuals' autocorrelation is summed in the Cramér–Rao bounds (Morelli & Klein 1997, for coloured residuals); 0: white residuals assumed",
                ),
                (
                    "input_noise",
                    "the recorded inputs' noise by channel, e.g. { elevator = \"0.01 deg\" }: the Cramér–Rao bounds then include its effect on the estimates (errors in the inputs, which output error takes as exact), measured by simulated draws of it; none: exact inputs",
                ),
                (
                    "input_noise_draws",
                    "simulated draws of the inputs' noise for those bounds (their share's σ within about 1/√(2·draws))",
                ),
                ("input_noise_seed", "seed of those draws"),
            ],
        }
    }

    fn capabilities() -> Capabilities {
        Capabilities {
            linear: true,
            several_records: true,
            tied_parameters: true,
            starts_from: Some(EQUATION_ERROR),
            ..Capabilities::default()
        }
    }

    fn validate(settings: &OutputErrorOptions) -> Result<()> {
        settings.check()
    }

    fn fit(
        &self,
        problem: &EstimationProblem,
        options: &OutputErrorOptions,
        start: Option<&Estimate>,
    ) -> Result<Estimate> {
        let structure = match &problem.structure {
            Structure::SixDof(structure) => structure,
            Structure::Linear(linear) => {
                return linear_output_error(problem, linear, options)
                    .map(Estimate::assess_residuals);
            }
        };
        let records: Vec<&FlightRecord> = problem.records.iter().collect();
        if options.starts > 1 {
            return multi_start(&records, structure, options, start);
        }
        output_error_from(&records, structure, options, start)
    }
}
