//! Levenberg–Marquardt training of the feed-forward network (the parent
//! module's header): JᵀJ accumulated from its blocks without a stored
//! Jacobian (`accumulate`), the damped step with the output weights
//! eliminated first (`damped_step`), and early stopping on the held-out
//! samples.

use super::{FeedForward, LevenbergMarquardt, Stop, Training, neuron};
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DMatrixView, DVector, Dyn};

/// Samples of a training: inputs and targets, row by row, in scaled units.
pub(super) struct Samples<'a> {
    pub(super) inputs: &'a [Vec<f64>],
    pub(super) targets: &'a [Vec<f64>],
    /// Indices of the samples trained on and of those held out.
    pub(super) training: Vec<usize>,
    pub(super) held_out: Vec<usize>,
}

/// Samples per block of the matrix products that accumulate JᵀJ (their
/// packing buffers are their only allocations inside an epoch).
pub const BLOCK: usize = 64;

/// Index of the pair (p, q) of 0..m in the packed upper triangle, column
/// by column: (q(q+1)/2 + p for p ≤ q), symmetric in its arguments.
#[inline]
fn packed(p: usize, q: usize) -> usize {
    let (p, q) = if p <= q { (p, q) } else { (q, p) };
    q * (q + 1) / 2 + p
}

/// The buffers of one training, allocated once.
pub(super) struct Workspace {
    output: Vec<f64>,
    error: Vec<f64>,
    /// Per hidden neuron of the current sample, d_j = 1 − h_j².
    slopes: Vec<f64>,
    /// Per sample of the current block (one column each): d_j·d_j' for
    /// j ≤ j' (packed), x̃_i·x̃_i' for i ≤ i' (packed), h̃, and w = [d ⊗ x̃, h̃].
    neuron_pairs: DMatrix<f64>,
    input_pairs: DMatrix<f64>,
    activations: DMatrix<f64>,
    block: DMatrix<f64>,
    /// Σ (d_j·d_j')(x̃_i·x̃_i'): the distinct entries of Σ z zᵀ.
    kronecker: DMatrix<f64>,
    /// Σ h̃ wᵀ = [Σ h̃ zᵀ, Σ h̃ h̃ᵀ].
    products: DMatrix<f64>,
    /// G = VᵀV.
    gram: DMatrix<f64>,
    /// Trial weights.
    trial: Vec<f64>,
    /// Per training sample, the hidden activations and outputs of the
    /// network's weights and of the trial weights (H + O each): the last
    /// pass over the training samples (its sum of squares) keeps them for
    /// the next accumulation.
    pub(super) kept: Vec<f64>,
    kept_trial: Vec<f64>,
}

impl Workspace {
    pub(super) fn new(inputs: usize, hidden: usize, outputs: usize, samples: usize) -> Workspace {
        let (n, h) = (inputs, hidden);
        let width = h * (n + 1) + h + 1;
        let neuron_pairs = h * (h + 1) / 2;
        let input_pairs = (n + 1) * (n + 2) / 2;
        Workspace {
            output: vec![0.0; outputs],
            error: vec![0.0; outputs],
            slopes: vec![0.0; h],
            neuron_pairs: DMatrix::zeros(neuron_pairs, BLOCK),
            input_pairs: DMatrix::zeros(input_pairs, BLOCK),
            activations: DMatrix::zeros(h + 1, BLOCK),
            block: DMatrix::zeros(width, BLOCK),
            kronecker: DMatrix::zeros(neuron_pairs, input_pairs),
            products: DMatrix::zeros(h + 1, width),
            gram: DMatrix::zeros(h, h),
            trial: vec![0.0; h * (n + 1) + outputs * (h + 1)],
            kept: vec![0.0; samples * (h + outputs)],
            kept_trial: vec![0.0; samples * (h + outputs)],
        }
    }

    /// Σ z zᵀ at hidden weights a, b (neuron a/(n+1), input a%(n+1)).
    #[inline]
    fn zz(&self, inputs: usize, a: usize, b: usize) -> f64 {
        let stride = inputs + 1;
        self.kronecker[(
            packed(a / stride, b / stride),
            packed(a % stride, b % stride),
        )]
    }
}

impl LevenbergMarquardt {
    /// Trains a network on `inputs` → `targets` (rows of equal length, in
    /// scaled units). Returns the network with the weights of the epoch of
    /// lowest held-out error (the last one without held-out samples) and
    /// the training's record.
    pub fn train(
        &self,
        inputs: &[Vec<f64>],
        targets: &[Vec<f64>],
    ) -> Result<(FeedForward, Training)> {
        let (n, outputs) = self.check(inputs, targets)?;
        let mut network = FeedForward::new(n, self.hidden, outputs, self.seed)?;
        let samples = self.samples(inputs, targets, outputs, network.weights.len())?;
        let mut work = Workspace::new(n, self.hidden, outputs, samples.training.len());
        let count = |set: &[usize]| (set.len() * outputs).max(1) as f64;
        let mut sse = training_sum_of_squares(&network, &samples, &mut work.kept);
        let mut training_mse = vec![sse / count(&samples.training)];
        let mut held_out_mse = Vec::new();
        let mut best = (f64::INFINITY, 0usize, network.weights.clone());
        if !samples.held_out.is_empty() {
            let held_out = sum_of_squares(&network, &samples, &samples.held_out, &mut work)
                / count(&samples.held_out);
            held_out_mse.push(held_out);
            best.0 = held_out;
        }
        let mut mu = self.damping;
        let mut epochs = 0;
        let mut rising = 0;
        let stop = loop {
            if epochs >= self.max_epochs {
                break Stop::EpochLimit;
            }
            let gradient = accumulate(&network, &samples, &mut work);
            if gradient.amax() < self.gradient_tolerance {
                break Stop::SmallGradient;
            }
            let Some(trial_sse) =
                self.accepted_step(&network, &samples, &mut work, &gradient, &mut mu, sse)
            else {
                break Stop::DampingLimit;
            };
            std::mem::swap(&mut network.weights, &mut work.trial);
            std::mem::swap(&mut work.kept, &mut work.kept_trial);
            sse = trial_sse;
            epochs += 1;
            training_mse.push(sse / count(&samples.training));
            if samples.held_out.is_empty() {
                continue;
            }
            let held_out = sum_of_squares(&network, &samples, &samples.held_out, &mut work)
                / count(&samples.held_out);
            held_out_mse.push(held_out);
            if held_out < best.0 {
                best.0 = held_out;
                best.1 = epochs;
                best.2.copy_from_slice(&network.weights);
                rising = 0;
            } else {
                rising += 1;
                if rising >= self.patience {
                    break Stop::HeldOutRose;
                }
            }
        };
        let best_epoch = if samples.held_out.is_empty() {
            epochs
        } else {
            network.weights.copy_from_slice(&best.2);
            best.1
        };
        Ok((
            network,
            Training {
                epochs,
                stop,
                best_epoch,
                training_mse,
                held_out_mse,
                training_samples: samples.training.len(),
                held_out_samples: samples.held_out.len(),
            },
        ))
    }

    /// The numbers of inputs and outputs; an error when the rows disagree
    /// or the damping settings are out of range.
    fn check(&self, inputs: &[Vec<f64>], targets: &[Vec<f64>]) -> Result<(usize, usize)> {
        let n = inputs.first().map_or(0, Vec::len);
        let outputs = targets.first().map_or(0, Vec::len);
        if inputs.len() != targets.len()
            || inputs.iter().any(|x| x.len() != n)
            || targets.iter().any(|t| t.len() != outputs)
        {
            return Err(Error::Network {
                reason:
                    "the network's inputs and targets have different numbers of samples or columns"
                        .into(),
            });
        }
        let damping_valid = self.damping > 0.0
            && self.damping_factor > 1.0
            && self.max_damping.is_finite()
            && self.damping.is_finite()
            && self.damping_factor.is_finite();
        if !damping_valid {
            return Err(Error::Network {
                reason: "Levenberg–Marquardt needs a damping above 0 and a damping factor above 1"
                    .into(),
            });
        }
        Ok((n, outputs))
    }

    /// The samples trained on and held out (every `held_out_every`-th); an
    /// error when the ones trained on cannot determine the `parameters`
    /// weights.
    fn samples<'a>(
        &self,
        inputs: &'a [Vec<f64>],
        targets: &'a [Vec<f64>],
        outputs: usize,
        parameters: usize,
    ) -> Result<Samples<'a>> {
        let held = |k: usize| {
            self.held_out_every > 1 && k % self.held_out_every == self.held_out_every - 1
        };
        let samples = Samples {
            inputs,
            targets,
            training: (0..inputs.len()).filter(|&k| !held(k)).collect(),
            held_out: (0..inputs.len()).filter(|&k| held(k)).collect(),
        };
        if samples.training.len() * outputs < parameters {
            return Err(Error::Network {
                reason: format!(
                    "{} training samples of {outputs} outputs cannot determine {parameters} weights",
                    samples.training.len()
                ),
            });
        }
        Ok(samples)
    }

    /// One epoch's step: the damping μ raised by β until a step lowers the
    /// training error below `sse`, then lowered by β. The trial weights
    /// and their kept activations are left in `work.trial` and
    /// `work.kept_trial`; their sum of squares, or None when no damping up
    /// to μ_max lowers it.
    fn accepted_step(
        &self,
        network: &FeedForward,
        samples: &Samples,
        work: &mut Workspace,
        gradient: &DVector<f64>,
        mu: &mut f64,
        sse: f64,
    ) -> Option<f64> {
        while *mu <= self.max_damping {
            let step = damped_step(network, work, gradient, *mu)
                .filter(|step| step.iter().all(|s| s.is_finite()));
            if let Some(step) = step {
                let mut trial = network.clone_shape();
                trial.weights = std::mem::take(&mut work.trial);
                for ((t, w), s) in trial
                    .weights
                    .iter_mut()
                    .zip(&network.weights)
                    .zip(step.iter())
                {
                    *t = w + s;
                }
                let trial_sse = training_sum_of_squares(&trial, samples, &mut work.kept_trial);
                work.trial = trial.weights;
                if trial_sse < sse {
                    *mu /= self.damping_factor;
                    return Some(trial_sse);
                }
            }
            *mu *= self.damping_factor;
        }
        None
    }
}

impl FeedForward {
    /// A network of the same sizes with no weights (a container for trial weights).
    fn clone_shape(&self) -> FeedForward {
        FeedForward {
            inputs: self.inputs,
            hidden: self.hidden,
            outputs: self.outputs,
            weights: Vec::new(),
        }
    }
}

/// Σ e² over the samples `set`.
fn sum_of_squares(
    network: &FeedForward,
    samples: &Samples,
    set: &[usize],
    work: &mut Workspace,
) -> f64 {
    let mut sum = 0.0;
    for &k in set {
        network.predict(&samples.inputs[k], &mut work.output);
        sum += work
            .output
            .iter()
            .zip(&samples.targets[k])
            .map(|(y, t)| (y - t) * (y - t))
            .sum::<f64>();
    }
    sum
}

/// Σ e² over the training samples, keeping each sample's hidden
/// activations and outputs in `kept` (the arithmetic of
/// [`FeedForward::predict`]).
pub(super) fn training_sum_of_squares(
    network: &FeedForward,
    samples: &Samples,
    kept: &mut [f64],
) -> f64 {
    let (n, h, outputs) = (network.inputs, network.hidden, network.outputs);
    let (hidden_layer, output_layer) = network.weights.split_at(network.hidden_weights());
    // The output weights neuron by neuron (the biases last), contiguous.
    let by_neuron: Vec<f64> = (0..=h)
        .flat_map(|j| (0..outputs).map(move |o| output_layer[o * (h + 1) + j]))
        .collect();
    let (by_neuron, biases) = by_neuron.split_at(h * outputs);
    let mut sum = 0.0;
    for (&k, row) in samples
        .training
        .iter()
        .zip(kept.chunks_exact_mut(h + outputs))
    {
        let input = &samples.inputs[k];
        let (activations, output) = row.split_at_mut(h);
        output.copy_from_slice(biases);
        for ((weights, activation), to_outputs) in hidden_layer
            .chunks_exact(n + 1)
            .zip(activations.iter_mut())
            .zip(by_neuron.chunks_exact(outputs))
        {
            *activation = neuron(weights, input);
            for (y, v) in output.iter_mut().zip(to_outputs) {
                *y += v * *activation;
            }
        }
        sum += output
            .iter()
            .zip(&samples.targets[k])
            .map(|(y, t)| (y - t) * (y - t))
            .sum::<f64>();
    }
    sum
}

/// Jᵀe of the training samples, e = y − t, and the sums JᵀJ is made of,
/// accumulated sample by sample from the activations and outputs the last
/// pass kept for the network's weights: G = VᵀV in
/// `work.gram`, the distinct entries of Σ z zᵀ in `work.kronecker` and
/// Σ h̃ [z, h̃]ᵀ in `work.products`.
///
/// JᵀJ is never formed from a stored Jacobian. With z = d ⊗ x̃ (d_j = 1 −
/// h_j², x̃ = [x, 1]) and h̃ = [h, 1] for one sample, the Jacobian row of
/// output o is [v_o ⊙ d ⊗ x̃ | 0 … h̃ … 0], so JᵀJ has the blocks
/// hidden–hidden G_jj'·Σ z zᵀ (G = VᵀV, fixed within an epoch),
/// hidden–output v_oj·Σ z h̃ᵀ and output–output Σ h̃ h̃ᵀ (equal for every
/// output). Σ z zᵀ has the Kronecker structure Σ (d_j·d_j')(x̃_i·x̃_i'):
/// only its H(H+1)/2 × (n+1)(n+2)/2 distinct sums are accumulated, with
/// Σ h̃ [z, h̃]ᵀ, sample by sample into buffers of a block of samples and
/// added by two matrix products per block (about a third of the products
/// of the full Σ w wᵀ, w = [z, h̃]); the training loop allocates nothing
/// per sample.
// The per-sample loop of an epoch: a sample's error, gradient and block columns are written together; split, each step would be a call per sample taking five of the workspace's buffers.
pub(super) fn accumulate(
    network: &FeedForward,
    samples: &Samples,
    work: &mut Workspace,
) -> DVector<f64> {
    let (n, h, outputs) = (network.inputs, network.hidden, network.outputs);
    let hidden_weights = network.hidden_weights();
    let parameters = network.weights.len();
    let output_layer = &network.weights[hidden_weights..];
    let v = |o: usize, j: usize| output_layer[o * (h + 1) + j];
    for j in 0..h {
        for k in 0..h {
            work.gram[(j, k)] = (0..outputs).map(|o| v(o, j) * v(o, k)).sum();
        }
    }
    work.kronecker.fill(0.0);
    work.products.fill(0.0);
    let width = hidden_weights + h + 1;
    let neuron_pairs = work.neuron_pairs.nrows();
    let input_pairs = work.input_pairs.nrows();
    // V by neuron: the weights of neuron j to every output, contiguous.
    let by_neuron: Vec<f64> = (0..h)
        .flat_map(|j| (0..outputs).map(move |o| v(o, j)))
        .collect();
    let mut gradient = vec![0.0; parameters];
    let (hidden_gradient, output_gradient) = gradient.split_at_mut(hidden_weights);
    let mut filled = 0;
    for (index, &k) in samples.training.iter().enumerate() {
        let input = &samples.inputs[k][..n];
        let kept = &work.kept[index * (h + outputs)..(index + 1) * (h + outputs)];
        let (activations, predicted) = kept.split_at(h);
        for ((e, y), t) in work
            .error
            .iter_mut()
            .zip(predicted)
            .zip(&samples.targets[k])
        {
            *e = y - t;
        }
        let column = &mut work.block.as_mut_slice()[filled * width..(filled + 1) * width];
        for (j, (&a, slope)) in activations.iter().zip(&mut work.slopes).enumerate() {
            let d = 1.0 - a * a;
            *slope = d;
            let delta = d * by_neuron[j * outputs..(j + 1) * outputs]
                .iter()
                .zip(&work.error)
                .map(|(v, e)| v * e)
                .sum::<f64>();
            let z = &mut column[j * (n + 1)..(j + 1) * (n + 1)];
            let g = &mut hidden_gradient[j * (n + 1)..(j + 1) * (n + 1)];
            for ((z, g), x) in z.iter_mut().zip(g.iter_mut()).zip(input) {
                *z = d * x;
                *g += delta * x;
            }
            z[n] = d;
            g[n] += delta;
        }
        column[hidden_weights..hidden_weights + h].copy_from_slice(activations);
        column[width - 1] = 1.0;
        let tilde = &mut work.activations.as_mut_slice()[filled * (h + 1)..(filled + 1) * (h + 1)];
        tilde[..h].copy_from_slice(activations);
        tilde[h] = 1.0;
        // d_p·d_q and x̃_p·x̃_q for p ≤ q, packed column by column.
        let pairs = &mut work.neuron_pairs.as_mut_slice()
            [filled * neuron_pairs..(filled + 1) * neuron_pairs];
        let mut slot = 0;
        for (q, &dq) in work.slopes.iter().enumerate() {
            for (pair, &dp) in pairs[slot..=slot + q].iter_mut().zip(&work.slopes) {
                *pair = dp * dq;
            }
            slot += q + 1;
        }
        let pairs =
            &mut work.input_pairs.as_mut_slice()[filled * input_pairs..(filled + 1) * input_pairs];
        let mut slot = 0;
        for q in 0..=n {
            let xq = if q < n { input[q] } else { 1.0 };
            for (pair, &xp) in pairs[slot..slot + q].iter_mut().zip(input) {
                *pair = xp * xq;
            }
            pairs[slot + q] = xq * xq;
            slot += q + 1;
        }
        for (e, g) in work
            .error
            .iter()
            .zip(output_gradient.chunks_exact_mut(h + 1))
        {
            for (g, a) in g.iter_mut().zip(activations) {
                *g += e * a;
            }
            g[h] += e;
        }
        filled += 1;
        if filled == BLOCK {
            add_block(work, BLOCK);
            filled = 0;
        }
    }
    if filled > 0 {
        add_block(work, filled);
    }
    DVector::from_vec(gradient)
}

/// JᵀJ assembled from the sums [`accumulate`] left in `work`.
#[cfg(test)]
pub(super) fn information(network: &FeedForward, work: &Workspace) -> DMatrix<f64> {
    let (n, h, outputs) = (network.inputs, network.hidden, network.outputs);
    let hidden_weights = network.hidden_weights();
    let parameters = network.weights.len();
    let output_layer = &network.weights[hidden_weights..];
    let v = |o: usize, j: usize| output_layer[o * (h + 1) + j];
    let s = &work.products;
    let mut information = DMatrix::zeros(parameters, parameters);
    for a in 0..hidden_weights {
        let ja = a / (n + 1);
        for b in 0..hidden_weights {
            information[(a, b)] = work.gram[(ja, b / (n + 1))] * work.zz(n, a, b);
        }
        for o in 0..outputs {
            let base = hidden_weights + o * (h + 1);
            for c in 0..=h {
                let value = v(o, ja) * s[(c, a)];
                information[(a, base + c)] = value;
                information[(base + c, a)] = value;
            }
        }
    }
    for o in 0..outputs {
        let base = hidden_weights + o * (h + 1);
        for c in 0..=h {
            for d in 0..=h {
                information[(base + c, base + d)] = s[(c, hidden_weights + d)];
            }
        }
    }
    information
}

/// The Levenberg–Marquardt step Δw = −(JᵀJ + μI)⁻¹·Jᵀe from the sums of
/// [`accumulate`], by eliminating the output weights first (block
/// Cholesky; None when a factor is not positive definite). With the
/// hidden weights first and the output layer's blocks after,
///
///   JᵀJ + μI = [B + μI, C; Cᵀ, I_O ⊗ (A + μI)],
///
/// B = G ∘ Σ z zᵀ (G expanded over each neuron's inputs), C_o =
/// diag(v_o)·Σ z h̃ᵀ, A = Σ h̃ h̃ᵀ: the output block is O copies of one
/// (H+1)-square matrix. The Schur complement of it is
/// K = G ∘ (Σ z zᵀ − M) + μI with M = (Σ z h̃ᵀ)·(A + μI)⁻¹·(Σ h̃ zᵀ), and
/// K·Δw_h = −g_h + Σ_o C_o·(A + μI)⁻¹·g_o, then
/// Δw_o = −(A + μI)⁻¹·(g_o + C_oᵀ·Δw_h): one Cholesky factor of the
/// H(n+1)-square K and one of the (H+1)-square A + μI instead of one of
/// all the weights'.
pub(super) fn damped_step(
    network: &FeedForward,
    work: &Workspace,
    gradient: &DVector<f64>,
    mu: f64,
) -> Option<DVector<f64>> {
    let (n, h, outputs) = (network.inputs, network.hidden, network.outputs);
    let hidden_weights = network.hidden_weights();
    let output_layer = &network.weights[hidden_weights..];
    let v = |o: usize, j: usize| output_layer[o * (h + 1) + j];
    let s = &work.products;
    let mut a = s.view((0, hidden_weights), (h + 1, h + 1)).into_owned();
    for c in 0..=h {
        a[(c, c)] += mu;
    }
    let a = a.cholesky()?;
    // W = L_A⁻¹·Σ h̃ zᵀ, so that M = WᵀW.
    let mut w = s.view((0, 0), (h + 1, hidden_weights)).into_owned();
    a.l_dirty()
        .solve_lower_triangular_mut(&mut w)
        .then_some(())?;
    let mut k = w.transpose() * &w;
    for b in 0..hidden_weights {
        for r in 0..hidden_weights {
            k[(r, b)] = work.gram[(r / (n + 1), b / (n + 1))] * (work.zz(n, r, b) - k[(r, b)]);
        }
        k[(b, b)] += mu;
    }
    // (A + μI)⁻¹·g_o of every output, column by column.
    let mut u = DMatrix::from_fn(h + 1, outputs, |c, o| {
        gradient[hidden_weights + o * (h + 1) + c]
    });
    a.solve_mut(&mut u);
    let hz = s.view((0, 0), (h + 1, hidden_weights));
    let pulled = hz.tr_mul(&u);
    let rhs = DVector::from_fn(hidden_weights, |r, _| {
        let j = r / (n + 1);
        -gradient[r] + (0..outputs).map(|o| v(o, j) * pulled[(r, o)]).sum::<f64>()
    });
    let hidden_step = k.cholesky()?.solve(&rhs);
    // g_o + C_oᵀ·Δw_h of every output, then (A + μI)⁻¹ of it, negated.
    let weighted = DMatrix::from_fn(hidden_weights, outputs, |r, o| {
        v(o, r / (n + 1)) * hidden_step[r]
    });
    let mut output_step = hz * &weighted;
    for o in 0..outputs {
        for c in 0..=h {
            output_step[(c, o)] += gradient[hidden_weights + o * (h + 1) + c];
        }
    }
    a.solve_mut(&mut output_step);
    let mut step = DVector::zeros(network.weights.len());
    step.rows_mut(0, hidden_weights).copy_from(&hidden_step);
    for o in 0..outputs {
        for c in 0..=h {
            step[hidden_weights + o * (h + 1) + c] = -output_step[(c, o)];
        }
    }
    Some(step)
}

/// Adds the first `filled` samples of the block to the sums, by two
/// matrix products.
fn add_block(work: &mut Workspace, filled: usize) {
    // A column block's transpose as a view: element (k, r) of it is (r, k).
    fn transposed(matrix: &DMatrix<f64>, filled: usize) -> DMatrixView<'_, f64, Dyn, Dyn> {
        let rows = matrix.nrows();
        DMatrixView::from_slice_with_strides(
            &matrix.as_slice()[..rows * filled],
            filled,
            rows,
            rows,
            1,
        )
    }
    work.kronecker.gemm(
        1.0,
        &work.neuron_pairs.columns(0, filled),
        &transposed(&work.input_pairs, filled),
        1.0,
    );
    work.products.gemm(
        1.0,
        &work.activations.columns(0, filled),
        &transposed(&work.block, filled),
        1.0,
    );
}
