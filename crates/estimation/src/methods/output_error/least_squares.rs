//! The Gauss–Newton problem: residuals, normal equations, the held and refined Jacobians, the estimate's bounds.

use super::*;

impl LeastSquaresObjective for Objective<'_> {
    type Error = crate::Error;

    fn unknown_name(&self, index: usize) -> Option<String> {
        self.unknowns.get(index).map(|&unknown| self.name(unknown))
    }

    /// In the last stage, switches the iterations from the grid-point to
    /// the exact (stage) linearisation.
    fn refine(&mut self) -> bool {
        let refine = self.refinable && self.linearise != Linearise::Stages;
        if refine {
            self.linearise = Linearise::Stages;
            self.held = None;
        }
        refine
    }

    /// Holds the Jacobian of the last simulation (the solver asks right
    /// after computing it): later simulations are plain, and the Jacobian
    /// is that simulation's sensitivities weighted with the current R. A
    /// grid-point Jacobian is held to steer by; the exact one only within
    /// HOLD_DECREASE of the optimum, because a fit may stop on it.
    fn hold(&mut self, predicted: f64) -> bool {
        if let Some(Simulated {
            grids: Some((_, mode)),
            ..
        }) = self.simulated
            && (mode == Linearise::GridPoints || predicted <= HOLD_DECREASE)
        {
            self.held = self.simulated.take();
        }
        self.held.is_some()
    }

    /// The held simulation becomes the last one again: if the solver
    /// releases at the θ it held (its step failed), its Jacobian is at hand.
    fn release(&mut self) {
        if let Some(held) = self.held.take() {
            self.simulated = Some(held);
        }
    }

    fn residuals(&mut self, theta: &DVector<f64>) -> crate::Result<DVector<f64>> {
        let errors = self.errors(theta)?;
        let weighted = errors
            .iter()
            .zip(&self.weights)
            .flat_map(|(e, w)| e.iter().map(move |v| v * w));
        Ok(DVector::from_iterator(
            errors.iter().map(Vec::len).sum(),
            weighted,
        ))
    }

    /// R = diag(mean square residual per output) at θ (Verma & Peyada 2020, Eq. 8), with a
    /// floor of 10⁻¹² of the output's RMS so that a noise-free fit stays finite.
    /// It first re-chooses the integration sub-steps for the model at θ
    /// ([`Objective::resolve_steps`]): a fit whose parameters speed up a mode
    /// (τ1 of the stall model's χ falling) integrates it as the model asks.
    fn reweight(&mut self, theta: &DVector<f64>) -> crate::Result<bool> {
        self.resolve_steps(theta)?;
        let errors = self.errors(theta)?;
        let measured: Vec<Vec<f64>> = (0..self.outputs.len())
            .map(|o| {
                self.segments
                    .iter()
                    .flat_map(|s| s.outputs[o].values.iter().copied())
                    .collect()
            })
            .collect();
        self.weights = diagonal_weights(&errors, &measured);
        Ok(true)
    }

    /// ∂r/∂θ = −R^{-1/2}·∂y/∂θ from the sensitivity equations (one simulation
    /// with sensitivities per segment; see [`DrivenSimulation::simulate`]),
    /// interpolated to the samples as y is; ∂y/∂bias = 1. ∂y/∂θ is assembled
    /// once per simulation ([`Assembled`]): a held Jacobian is re-weighted.
    fn jacobian(
        &mut self,
        theta: &DVector<f64>,
        _options: &Options,
    ) -> crate::Result<DMatrix<f64>> {
        let (weights, assembled) = self.sensitivities_at(theta)?;
        let mut jacobian = DMatrix::zeros(
            assembled.rows.last().map_or(0, |rows| rows.end),
            assembled.unknowns.len(),
        );
        for (rows, weight) in assembled.rows.iter().zip(&weights) {
            for i in rows.clone() {
                for (j, value) in assembled.row(i).iter().enumerate() {
                    jacobian[(i, j)] = -weight * value;
                }
            }
        }
        Ok(jacobian)
    }

    /// With J = −diag(1/σ_o)·Y (Y = ∂y/∂θ at the samples, its rows
    /// grouped by output o): JᵀJ = Σ_o G_o/σ_o² from the per-output Gram
    /// matrices G_o = Y_oᵀY_o of the Jacobian's simulation, computed once
    /// (a held Jacobian's are reused), and Jᵀr = −Σ_o Y_oᵀr_o/σ_o. No
    /// weighted copy of Y is made.
    fn normal_equations(
        &mut self,
        theta: &DVector<f64>,
        residuals: &DVector<f64>,
        _options: &Options,
    ) -> crate::Result<NormalEquations> {
        let (weights, assembled) = self.sensitivities_at(theta)?;
        let columns = assembled.unknowns.len();
        let mut gradient = DVector::zeros(columns);
        let mut information = DMatrix::zeros(columns, columns);
        for ((rows, weight), gram) in assembled.rows.iter().zip(&weights).zip(&assembled.grams) {
            debug_assert!(rows.end <= residuals.len());
            let mut product = vec![0.0; columns];
            for i in rows.clone() {
                let r = residuals[i];
                for (sum, value) in product.iter_mut().zip(assembled.row(i)) {
                    *sum += value * r;
                }
            }
            for (gradient, product) in gradient.iter_mut().zip(&product) {
                *gradient -= weight * product;
            }
            information += gram * (weight * weight);
        }
        Ok(NormalEquations {
            gradient,
            information,
        })
    }
}

impl Objective<'_> {
    /// Replaces the estimate's white Cramér–Rao bounds by the bounds
    /// corrected for coloured residuals (Morelli & Klein 1997, Eq. 19 for
    /// output error: Cov = M⁻¹·[Σᵢ Σⱼ Jᵢᵀ·R_rr(i − j)·Jⱼ]·M⁻¹, J the
    /// whitened residuals' Jacobian at the solution, M = JᵀJ, R_rr each
    /// output's autocorrelation of its whitened residuals, pooled over the
    /// pieces, summed to `lag` seconds within each piece, a pair never
    /// spanning two; the truncated sum by the rectangular window, or the
    /// Bartlett one where that is not positive, as the regressions do).
    /// Returns the note that says so, or why the bounds stay white.
    pub(super) fn coloured_bounds(
        &mut self,
        solution: &gauss_newton::Solution,
        lag: f64,
        estimate: &mut Estimate,
    ) -> String {
        // The white bound the estimate already holds, M⁻¹.
        let m = estimate.covariance.len();
        let white = DMatrix::from_fn(m, m, |i, j| estimate.covariance[i][j]);
        if (0..m).any(|j| !white[(j, j)].is_finite()) {
            return "Cramér–Rao bounds left white: a parameter is unidentifiable".to_string();
        }
        let (counts, lags) = self.pieces_and_lags(lag);
        let residuals = solution.residuals.clone();
        let Ok((weights, assembled)) = self.sensitivities_at(&solution.theta) else {
            return "Cramér–Rao bounds left white: no Jacobian at the solution".to_string();
        };
        if residuals.len() != assembled.rows.last().map_or(0, |r| r.end)
            || m != assembled.unknowns.len()
        {
            return "Cramér–Rao bounds left white: the residuals do not match the Jacobian"
                .to_string();
        }
        let blocks = whitened_blocks(assembled, &weights, &counts);
        let middle = |window| {
            let mut middle = DMatrix::zeros(m, m);
            for (output, lag) in blocks.iter().zip(&lags) {
                let views: Vec<regression::Block> = output
                    .iter()
                    .map(|(x, range)| (x.as_view(), residuals.rows(range.start, range.len())))
                    .collect();
                middle += regression::coloured_middle(&views, *lag, window);
            }
            regression::sandwich(&white, &middle)
        };
        let mut window = regression::LagWindow::Rectangular;
        let mut covariance = middle(window);
        if !covariance.diagonal().iter().all(|v| *v > 0.0) {
            window = regression::LagWindow::Bartlett;
            covariance = middle(window);
        }
        let largest = replace_covariance(estimate, &covariance, |_| true);
        format!(
            "Cramér–Rao bounds corrected for coloured residuals (Morelli & Klein 1997), autocorrelation summed to {lag} s ({} window): up to {:.2} times the white bounds ({})",
            match window {
                regression::LagWindow::Rectangular => "rectangular",
                regression::LagWindow::Bartlett => "Bartlett",
            },
            largest.0,
            largest.1
        )
    }

    /// Each output's pieces (its rows per segment) and `lag` seconds in
    /// samples at its mean interval (at least one; 0 without intervals).
    fn pieces_and_lags(&self, lag: f64) -> (Vec<Vec<usize>>, Vec<usize>) {
        let counts = (0..self.outputs.len())
            .map(|o| {
                self.segments
                    .iter()
                    .map(|s| s.outputs[o].times.len())
                    .collect()
            })
            .collect();
        let lags = (0..self.outputs.len())
            .map(|o| {
                let (span, intervals) = self
                    .segments
                    .iter()
                    .map(|s| &s.outputs[o].times)
                    .filter(|t| t.len() > 1)
                    .fold((0.0, 0usize), |(span, n), t| {
                        (span + (t[t.len() - 1] - t[0]), n + t.len() - 1)
                    });
                if intervals == 0 {
                    0
                } else {
                    ((lag * intervals as f64 / span).round() as usize).max(1)
                }
            })
            .collect();
        (counts, lags)
    }

    /// Adds to the estimate's covariance the share of the recorded inputs'
    /// noise (errors in the inputs). Output error takes the inputs u as
    /// exact; recorded with white noise w of standard deviation σ_u, the
    /// simulation driven by u + w departs from the one driven by u by
    /// δy ≈ T·w (T the model's response to its inputs, linearised at θ̂),
    /// and a Gauss–Newton step moves θ̂ by δθ = M⁻¹·Σ (∂y/∂θ)ᵀ·R⁻¹·δy
    /// (M the information matrix, `white` its inverse): Cov(δθ) =
    /// M⁻¹·Σ(∂y/∂θ)ᵀR⁻¹·Cov(T·w)·R⁻¹(∂y/∂θ)·M⁻¹, which the Cramér–Rao
    /// bound, by its assumptions, does not hold. It is measured here by
    /// `draws` draws of w (`seed`, a stream per draw: the same numbers for
    /// any thread count), each a plain simulation at θ̂ with the noised
    /// inputs: Cov(δθ) ≈ (1/draws)·Σ δθ·δθᵀ (w has zero mean), its
    /// standard deviations within about 1/√(2·draws). Fast modes excited
    /// through an input's direct effect (the stall's χ through α̇) make this
    /// share large: 0.01° of elevator noise triples the bound of τ1 in c̄/V
    /// (docs/findings.md). Returns the note that says what was added, or
    /// why nothing was.
    pub(super) fn input_noise_bounds(
        &mut self,
        records: &[&FlightRecord],
        solution: &gauss_newton::Solution,
        white: &[Vec<f64>],
        (noise, draws, seed): (&[(String, f64)], usize, u64),
        estimate: &mut Estimate,
    ) -> String {
        let m = white.len();
        // An unidentifiable unknown (infinite bound) keeps its bound and
        // takes no share; the others' shares come from the finite block.
        let finite: Vec<bool> = (0..m).map(|j| white[j][j].is_finite()).collect();
        let inverse = DMatrix::from_fn(m, m, |i, j| {
            if finite[i] && finite[j] {
                white[i][j]
            } else {
                0.0
            }
        });
        if !finite.iter().any(|f| *f) {
            return "Cramér–Rao bounds without the inputs' noise: no parameter is identifiable"
                .to_string();
        }
        let (weights, sensitivities, rows) = match self.sensitivities_at(&solution.theta) {
            Ok((weights, assembled)) if assembled.unknowns.len() == m => (
                weights,
                assembled.sensitivities.clone(),
                assembled.rows.clone(),
            ),
            _ => {
                return "Cramér–Rao bounds without the inputs' noise: no Jacobian at the solution"
                    .to_string();
            }
        };
        self.apply(&solution.theta);
        let record_of: Vec<usize> = self
            .segments
            .iter()
            .map(|segment| {
                records
                    .iter()
                    .position(|r| std::ptr::eq(*r, segment.record))
                    .unwrap_or(0)
            })
            .collect();
        let exact: Vec<FlightRecord> = records.iter().map(|r| (*r).clone()).collect();
        let nominal = match self.outputs_driven_by(&exact, &record_of) {
            Ok(nominal) if nominal.len() == rows.last().map_or(0, |r| r.end) => nominal,
            _ => {
                return "Cramér–Rao bounds without the inputs' noise: the recorded inputs' simulation failed"
                    .to_string();
            }
        };
        let shifts: Vec<Option<DVector<f64>>> = (0..draws)
            .into_par_iter()
            .map(|draw| {
                let noised = with_input_noise(&exact, noise, seed, draw);
                let moved = self.outputs_driven_by(&noised, &record_of).ok()?;
                let gradient =
                    weighted_gradient(&moved, &nominal, &rows, &weights, (&sensitivities, m));
                Some(&inverse * gradient)
            })
            .collect();
        let valid: Vec<&DVector<f64>> = shifts.iter().flatten().collect();
        if 2 * valid.len() < draws {
            return format!(
                "Cramér–Rao bounds without the inputs' noise: {} of {draws} noised simulations departed",
                draws - valid.len()
            );
        }
        let share = valid.iter().fold(DMatrix::zeros(m, m), |share, shift| {
            share + *shift * shift.transpose()
        }) / valid.len() as f64;
        let held = DMatrix::from_fn(m, m, |i, j| estimate.covariance[i][j]);
        let covariance = held + share;
        let largest = replace_covariance(estimate, &covariance, |j| finite[j]);
        let channels: Vec<String> = noise
            .iter()
            .map(|(name, sigma)| format!("{name} {sigma:.3e}"))
            .collect();
        format!(
            "Cramér–Rao bounds with the recorded inputs' noise (σ in SI: {}), its share from {} simulated draws: up to {:.2} times the bounds without it ({})",
            channels.join(", "),
            valid.len(),
            largest.0,
            largest.1
        )
    }

    /// The outputs at the samples, output after output and segment after
    /// segment (the Jacobian's rows), each segment driven by
    /// `records[record_of[segment]]`, at the θ last applied.
    fn outputs_driven_by(
        &self,
        records: &[FlightRecord],
        record_of: &[usize],
    ) -> crate::Result<Vec<f64>> {
        let mut by_output = vec![Vec::new(); self.outputs.len()];
        for (segment, &r) in self.segments.iter().zip(record_of) {
            let simulation = DrivenSimulation::from_record(
                &records[r],
                &self.integrate,
                // The choice made on the recorded inputs, not remade on
                // each draw of their noise.
                &segment.simulation.fixed_interpolation(),
                segment.simulation.step,
                segment.window,
                self.alpha_dot,
            )?;
            let mut grid = vec![Vec::with_capacity(simulation.len()); self.outputs.len()];
            simulation.simulate(
                &self.model,
                &segment.initial,
                &self.observables,
                &[],
                self.linearise,
                |_, y, _| grid.iter_mut().zip(y).for_each(|(g, y)| g.push(*y)),
            )?;
            for ((into, measured), values) in by_output.iter_mut().zip(&segment.outputs).zip(&grid)
            {
                into.extend(measured.brackets.iter().map(|&at| on_grid(values, at)));
            }
        }
        Ok(by_output.concat())
    }

    /// The weights 1/σ and ∂y/∂θ at the samples ([`Objective::assembled`])
    /// for the Jacobian at θ: the held simulation's, else θ's (simulated
    /// with sensitivities if it was not).
    pub(super) fn sensitivities_at(
        &mut self,
        theta: &DVector<f64>,
    ) -> crate::Result<(Vec<f64>, &Assembled)> {
        if self.held.is_none() && !self.is_simulated(theta, Some(self.linearise)) {
            self.simulate(theta, true)?;
        }
        let weights = self.weights.clone();
        Ok((weights, self.assembled()))
    }

    /// ∂y/∂θ at the samples of the simulation whose Jacobian is asked for
    /// (the held one, else the last), assembled for the solver's unknowns if
    /// not yet.
    pub(super) fn assembled(&mut self) -> &mut Assembled {
        let simulated = match self.held.as_mut() {
            Some(held) => held,
            None => self
                .simulated
                .as_mut()
                .expect("simulated with sensitivities"),
        };
        let Simulated {
            grids: Some((grids, _)),
            assembled,
            ..
        } = simulated
        else {
            unreachable!("a Jacobian is asked for after a simulation with sensitivities")
        };
        if assembled
            .as_ref()
            .is_none_or(|assembled| assembled.unknowns != self.unknowns)
        {
            *assembled = Some(assemble(
                &self.segments,
                grids,
                &self.all,
                &self.unknowns,
                self.outputs.len(),
            ));
        }
        assembled.as_mut().expect("assembled above")
    }
}

/// Sets the estimate's covariance to `covariance` and the standard errors
/// of the parameters `changed` selects to its diagonal's roots; returns
/// the largest ratio of a new standard error to the old one, and whose.
pub(super) fn replace_covariance(
    estimate: &mut Estimate,
    covariance: &DMatrix<f64>,
    changed: impl Fn(usize) -> bool,
) -> (f64, String) {
    let mut largest = (1.0, String::new());
    for (j, parameter) in estimate.parameters.iter_mut().enumerate() {
        if !changed(j) {
            continue;
        }
        let new = covariance[(j, j)].max(0.0).sqrt();
        let ratio = new / parameter.standard_error;
        if ratio > largest.0 || largest.1.is_empty() {
            largest = (ratio, parameter.name.clone());
        }
        parameter.standard_error = new;
    }
    estimate.covariance = (0..covariance.nrows())
        .map(|i| covariance.row(i).iter().copied().collect())
        .collect();
    largest
}

/// ∂y/∂θ at the samples for `unknowns` from the grids' sensitivities to
/// `all` ([`Assembled`]), row after row (output after output and segment
/// after segment, as the residuals): a row reads the blocks of the two
/// grid points around its sample, which lie together in memory; then each
/// output's Gram matrix.
pub(super) fn assemble(
    segments: &[Segment],
    grids: &[Grid],
    all: &[Unknown],
    unknowns: &[Unknown],
    outputs: usize,
) -> Assembled {
    let m = unknowns.len();
    let mut rows = Vec::with_capacity(outputs);
    let mut start = 0;
    for o in 0..outputs {
        let count: usize = segments.iter().map(|s| s.outputs[o].times.len()).sum();
        rows.push(start..start + count);
        start += count;
    }
    let mut sensitivities = vec![0.0; start * m];
    // ∂y/∂bias = 1 on its output's rows; the simulated unknowns' places
    // among the solver's and among all.
    let mut simulated = Vec::with_capacity(m);
    for (j, unknown) in unknowns.iter().enumerate() {
        match *unknown {
            Unknown::Bias { output } => {
                for i in rows[output].clone() {
                    sensitivities[i * m + j] = 1.0;
                }
            }
            _ => simulated.push((
                j,
                all.iter()
                    .position(|a| a == unknown)
                    .expect("a simulated unknown"),
            )),
        }
    }
    let block = outputs * all.len();
    // The simulated unknowns in the order of all, from the first: a row
    // is then a slice of the grid's blocks (the usual case; otherwise one
    // value at a time).
    let in_order = simulated
        .iter()
        .enumerate()
        .all(|(i, &(j, c))| i == j && i == c);
    let count = simulated.len();
    let mut grams = Vec::with_capacity(outputs);
    let mut data = sensitivities.chunks_exact_mut(m.max(1));
    for o in 0..outputs {
        for (segment, grid) in segments.iter().zip(grids) {
            let at = |k: usize| &grid.sensitivities[k * block + o * all.len()..][..all.len()];
            for &(k, fraction) in &segment.outputs[o].brackets {
                let row = data.next().expect("a row per sample");
                if in_order {
                    let start = &at(k)[..count];
                    if fraction == 0.0 {
                        row[..count].copy_from_slice(start);
                    } else {
                        let end = &at(k + 1)[..count];
                        for ((value, start), end) in row.iter_mut().zip(start).zip(end) {
                            *value = start + fraction * (end - start);
                        }
                    }
                } else {
                    for &(j, c) in &simulated {
                        row[j] = at_bracket((k, fraction), |k| at(k)[c]);
                    }
                }
            }
        }
    }
    for rows in &rows {
        // The output's rows, row-major, are Y_oᵀ column-major.
        let transposed =
            DMatrixView::from_slice(&sensitivities[rows.start * m..rows.end * m], m, rows.len());
        grams.push(transposed * transposed.transpose());
    }
    Assembled {
        unknowns: unknowns.to_vec(),
        sensitivities,
        rows,
        grams,
    }
}

/// The whitened Jacobian's rows per output and piece (`counts`), each with
/// its rows' range (the sign of J drops out of the products).
fn whitened_blocks(
    assembled: &Assembled,
    weights: &[f64],
    counts: &[Vec<usize>],
) -> Vec<Vec<(DMatrix<f64>, std::ops::Range<usize>)>> {
    let m = assembled.unknowns.len();
    assembled
        .rows
        .iter()
        .zip(weights)
        .zip(counts)
        .map(|((rows, weight), counts)| {
            let mut start = rows.start;
            counts
                .iter()
                .map(|&count| {
                    let range = start..start + count;
                    start += count;
                    let x = DMatrix::from_fn(count, m, |i, j| {
                        weight * assembled.row(range.start + i)[j]
                    });
                    (x, range)
                })
                .collect()
        })
        .collect()
}

/// Σ (∂y/∂θ)ᵀ·R⁻¹·δy over the samples: δy = `moved` − `nominal`, R⁻¹ the
/// weights squared per output's `rows`, ∂y/∂θ the rows of `sensitivities`
/// (row-major, a row of the m unknowns per sample).
fn weighted_gradient(
    moved: &[f64],
    nominal: &[f64],
    rows: &[std::ops::Range<usize>],
    weights: &[f64],
    (sensitivities, m): (&[f64], usize),
) -> DVector<f64> {
    let mut gradient = DVector::zeros(m);
    for (range, weight) in rows.iter().zip(weights) {
        let w2 = weight * weight;
        for i in range.clone() {
            let dy = (moved[i] - nominal[i]) * w2;
            for (g, s) in gradient.iter_mut().zip(&sensitivities[i * m..(i + 1) * m]) {
                *g += s * dy;
            }
        }
    }
    gradient
}

/// The records with white noise of `noise`'s σ added to each named
/// channel: draw `draw` of the stream `seed` (a stream per draw, so the
/// numbers do not depend on the thread count).
fn with_input_noise(
    exact: &[FlightRecord],
    noise: &[(String, f64)],
    seed: u64,
    draw: usize,
) -> Vec<FlightRecord> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(draw as u64);
    let mut noised = exact.to_vec();
    for record in &mut noised {
        for (name, sigma) in noise {
            if let Some(channel) = record.channels.iter_mut().find(|c| &c.name == name) {
                for value in &mut channel.values {
                    *value += sigma * rng.sample::<f64, _>(StandardNormal);
                }
            }
        }
    }
    noised
}
