//! The feed-forward network of the neural Gauss–Newton method and its
//! training by back-propagation with Levenberg–Marquardt.
//!
//! - The network: the reflex-wing UAV paper, "Longitudinal and lateral
//!   aerodynamic characterisation of reflex wing Unmanned Aerial Vehicle
//!   from flight tests using Maximum Likelihood, Least Square and Neural
//!   Gauss Newton methods" (its authors are not in the seed text), §3.3
//!   (a feed-forward network
//!   that maps U(k) to Z(k+1), Eqs. 29–30); the same restricted model as
//!   Peyada & Ghosh's neural Gauss–Newton method, which the ELM paper
//!   ("Parameter estimation of aircraft using extreme learning machine and
//!   Gauss-Newton algorithm") states in its Eqs. 11–13.
//! - Its training: Hagan & Menhaj, "Training feedforward networks with the
//!   Marquardt algorithm", IEEE Trans. Neural Networks 5(6), 1994 (not
//!   among the project's seed papers; cited by what it states, not by
//!   equation number): the Jacobian of the network's outputs with respect
//!   to every weight by back-propagating the Marquardt sensitivities
//!   (for one hidden layer: ∂y_o/∂w_ji = v_oj·(1 − h_j²)·x_i), the step
//!   Δw = −(JᵀJ + μI)⁻¹·Jᵀe, and μ divided by β = 10 after a step that
//!   lowers the sum of squared errors and multiplied by β until one does.
//! - Early stopping on held-out samples (every `held_out_every`-th sample,
//!   the stopping rule of MATLAB's `trainlm`: validation error above its
//!   best for `patience` epochs in a row), so that the network does not
//!   over-train, which the reflex-wing paper warns of (§3.3).
//!
//! One hidden layer of tanh neurons and a linear output layer: tanh is
//! zero-centred on inputs scaled to [−1, 1] (tanh(s) = 2·σ(2s) − 1 with σ
//! the log-sigmoid of the ELM paper's Eq. 4), which keeps the columns of
//! JᵀJ for the hidden and output weights of similar size and the LM
//! system well conditioned; the linear output layer lets the outputs take
//! any value of the scaled range. Initial weights: Nguyen & Widrow
//! ("Improving the learning speed of 2-layer neural networks by choosing
//! initial values of the adaptive weights", IJCNN 1990;
//! [`FeedForward::new`]). JᵀJ is accumulated from its blocks without a
//! stored Jacobian (`accumulate`) and the damped system solved with the
//! output weights eliminated first (`damped_step`).

use crate::error::{Error, Result};
use crate::neural::elm::{SizeScores, choose_by_held_out};
use crate::neural::restricted::{Network, Trainer, TrainingSet};
use crate::neural::{NetworkReport, fit_metrics};
use aeroid_core::random::{stream, streams};
use nalgebra::DMatrix;
use rand::RngExt;
use rand_distr::StandardNormal;

mod levenberg_marquardt;

pub use levenberg_marquardt::BLOCK;

/// A network with one hidden layer of tanh neurons and a linear output
/// layer. Weights in one vector: for each hidden neuron j its input
/// weights and bias [w_j1 … w_jn, b_j], then for each output o its hidden
/// weights and bias [v_o1 … v_oH, c_o].
#[derive(Debug, Clone, PartialEq)]
pub struct FeedForward {
    inputs: usize,
    hidden: usize,
    outputs: usize,
    weights: Vec<f64>,
}

impl FeedForward {
    /// A network of the given sizes with Nguyen–Widrow initial weights
    /// drawn from the seed's network stream: each neuron's input-weight
    /// vector has a random direction (normalised standard-normal draws) and
    /// the length β = 0.7·H^(1/n), its bias is uniform in [−β, β]; output
    /// weights are normal with standard deviation 1/√H, output biases zero.
    /// All draws come from `random::stream(seed, NETWORK_WEIGHTS)`, so a
    /// seed gives the same network, bit for bit.
    pub fn new(inputs: usize, hidden: usize, outputs: usize, seed: u64) -> Result<FeedForward> {
        if inputs == 0 || hidden == 0 || outputs == 0 {
            return Err(Error::Network {
                reason: format!(
                    "a feed-forward network needs inputs, hidden neurons and outputs \
                 (given {inputs}, {hidden}, {outputs})"
                ),
            });
        }
        let mut rng = stream(seed, streams::NETWORK_WEIGHTS);
        let beta = 0.7 * (hidden as f64).powf(1.0 / inputs as f64);
        let mut weights = Vec::with_capacity(hidden * (inputs + 1) + outputs * (hidden + 1));
        for _ in 0..hidden {
            let start = weights.len();
            weights.extend((0..inputs).map(|_| rng.sample::<f64, _>(StandardNormal)));
            let norm = weights[start..].iter().map(|w| w * w).sum::<f64>().sqrt();
            let scale = if norm > 0.0 { beta / norm } else { 0.0 };
            weights[start..].iter_mut().for_each(|w| *w *= scale);
            weights.push(rng.random_range(-beta..=beta));
        }
        let spread = 1.0 / (hidden as f64).sqrt();
        for _ in 0..outputs {
            weights.extend((0..hidden).map(|_| spread * rng.sample::<f64, _>(StandardNormal)));
            weights.push(0.0);
        }
        Ok(FeedForward {
            inputs,
            hidden,
            outputs,
            weights,
        })
    }

    pub fn inputs(&self) -> usize {
        self.inputs
    }

    pub fn hidden(&self) -> usize {
        self.hidden
    }

    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// All weights, in the order of the type's documentation.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The number of hidden-layer weights and biases, H·(n + 1).
    fn hidden_weights(&self) -> usize {
        self.hidden * (self.inputs + 1)
    }

    /// The network's output for one input (no allocation).
    pub fn predict(&self, input: &[f64], output: &mut [f64]) {
        let (n, h) = (self.inputs, self.hidden);
        let (hidden_layer, output_layer) = self.weights.split_at(self.hidden_weights());
        for (o, y) in output.iter_mut().enumerate().take(self.outputs) {
            *y = output_layer[o * (h + 1) + h];
        }
        for (j, row) in hidden_layer.chunks_exact(n + 1).enumerate() {
            let activation = neuron(row, input);
            for (o, y) in output.iter_mut().enumerate().take(self.outputs) {
                *y += output_layer[o * (h + 1) + j] * activation;
            }
        }
    }

    /// ∂y/∂w for one input by back-propagation of the Marquardt
    /// sensitivities (Hagan & Menhaj): row o, column k is
    /// ∂y_o/∂w_k. `hidden` is a buffer of the hidden-layer size and
    /// `jacobian` is outputs × weights.
    pub fn jacobian(&self, input: &[f64], hidden: &mut [f64], jacobian: &mut DMatrix<f64>) {
        let (n, h) = (self.inputs, self.hidden);
        let offset = self.hidden_weights();
        self.forward_hidden(input, hidden);
        jacobian.fill(0.0);
        for o in 0..self.outputs {
            let v = &self.weights[offset + o * (h + 1)..offset + o * (h + 1) + h];
            for j in 0..h {
                // Sensitivity of output o to neuron j's net input: v_oj·(1 − h_j²).
                let sensitivity = v[j] * (1.0 - hidden[j] * hidden[j]);
                for (i, &x) in input.iter().enumerate().take(n) {
                    jacobian[(o, j * (n + 1) + i)] = sensitivity * x;
                }
                jacobian[(o, j * (n + 1) + n)] = sensitivity;
                jacobian[(o, offset + o * (h + 1) + j)] = hidden[j];
            }
            jacobian[(o, offset + o * (h + 1) + h)] = 1.0;
        }
    }

    fn forward_hidden(&self, input: &[f64], hidden: &mut [f64]) {
        let hidden_layer = &self.weights[..self.hidden_weights()];
        for (activation, row) in hidden
            .iter_mut()
            .zip(hidden_layer.chunks_exact(self.inputs + 1))
        {
            *activation = neuron(row, input);
        }
    }
}

impl Network for FeedForward {
    fn inputs(&self) -> usize {
        self.inputs
    }

    fn outputs(&self) -> usize {
        self.outputs
    }

    fn predict(&self, input: &[f64], output: &mut [f64]) {
        FeedForward::predict(self, input, output);
    }

    /// One sum per hidden neuron.
    fn partial_size(&self) -> usize {
        self.hidden
    }

    /// Each neuron's sum of weighted inputs over the leading inputs, in
    /// the order `neuron` adds them (its bias is added last).
    fn partial(&self, head: &[f64], state: &mut [f64]) {
        let hidden_layer = &self.weights[..self.hidden_weights()];
        for (sum, row) in state
            .iter_mut()
            .zip(hidden_layer.chunks_exact(self.inputs + 1))
        {
            *sum = row.iter().zip(head).map(|(w, x)| w * x).sum::<f64>();
        }
    }

    fn predict_from(&self, state: &[f64], from: usize, input: &[f64], output: &mut [f64]) {
        let (n, h) = (self.inputs, self.hidden);
        let (hidden_layer, output_layer) = self.weights.split_at(self.hidden_weights());
        for (o, y) in output.iter_mut().enumerate().take(self.outputs) {
            *y = output_layer[o * (h + 1) + h];
        }
        for (j, (row, &start)) in hidden_layer.chunks_exact(n + 1).zip(state).enumerate() {
            let sum = row[from..n]
                .iter()
                .zip(&input[from..])
                .fold(start, |sum, (w, x)| sum + w * x);
            let activation = tanh(row[n] + sum);
            for (o, y) in output.iter_mut().enumerate().take(self.outputs) {
                *y += output_layer[o * (h + 1) + j] * activation;
            }
        }
    }
}

/// The restricted model's trainer: the network trained on the set, its
/// report ([`report`]) with the seed and hidden size of these settings.
impl Trainer for LevenbergMarquardt {
    fn train(&self, set: &TrainingSet) -> Result<(Box<dyn Network>, NetworkReport)> {
        let (network, training) = LevenbergMarquardt::train(self, &set.inputs, &set.targets)?;
        let report = report(
            &network,
            &training,
            self.seed,
            &set.inputs,
            &set.targets,
            &set.input_names,
            &set.output_names,
        );
        Ok((Box::new(network), report))
    }
}

/// Training with the hidden-layer size chosen from the data: each of
/// `hidden_sizes` is trained by `training` (its `hidden` replaced) and
/// scored by its held-out mean square error at the epoch whose weights it
/// keeps; the size of the least is kept, by the ELM's held-out residual
/// criterion ([`choose_by_held_out`]; the held-out pairs are those of the
/// early stopping, every `held_out_every`-th). A network of the chosen size
/// is the one that criterion trained; nothing is trained again. Sizes
/// with more weights than the training pairs determine are skipped.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SizeSearch {
    pub training: LevenbergMarquardt,
    /// Candidate numbers of hidden neurons, ascending (ties go to the first).
    pub hidden_sizes: Vec<usize>,
}

impl SizeSearch {
    /// The network of the chosen size, its training and the held-out
    /// error of every size tried.
    pub fn train(
        &self,
        inputs: &[Vec<f64>],
        targets: &[Vec<f64>],
    ) -> Result<(FeedForward, Training, SizeScores)> {
        let every = self.training.held_out_every;
        if every < 2 {
            return Err(Error::Network { reason: "choosing the hidden-layer size needs held-out samples (held_out_every of 2 or more)"
                    .into(), });
        }
        let n = inputs.first().map_or(0, Vec::len);
        let outputs = targets.first().map_or(0, Vec::len);
        let trained_on = inputs.len() - inputs.len() / every;
        let chosen = choose_by_held_out(&self.hidden_sizes, |hidden| {
            if hidden == 0 || hidden * (n + 1) + outputs * (hidden + 1) > trained_on * outputs {
                return Ok(None);
            }
            let trainer = LevenbergMarquardt {
                hidden,
                ..self.training.clone()
            };
            let (network, training) = trainer.train(inputs, targets)?;
            // Not finite (never chosen) when no sample is held out.
            let held_out = training
                .held_out_mse
                .get(training.best_epoch)
                .copied()
                .unwrap_or(f64::NAN);
            Ok(Some(((network, training), held_out)))
        })?;
        let (_, (network, training), scores) = chosen.ok_or_else(|| Error::Network {
            reason: format!(
                "no hidden-layer size of {:?} can be trained on {trained_on} samples",
                self.hidden_sizes
            ),
        })?;
        Ok((network, training, scores))
    }
}

/// The restricted model's trainer: the network of the chosen size, its
/// report ([`report`]) with the held-out error of every size tried.
impl Trainer for SizeSearch {
    fn train(&self, set: &TrainingSet) -> Result<(Box<dyn Network>, NetworkReport)> {
        let (network, training, scores) = SizeSearch::train(self, &set.inputs, &set.targets)?;
        let mut report = report(
            &network,
            &training,
            self.training.seed,
            &set.inputs,
            &set.targets,
            &set.input_names,
            &set.output_names,
        );
        report.settings.extend(
            scores
                .iter()
                .map(|(size, mse)| (format!("held-out mse, {size} neurons"), *mse)),
        );
        Ok((Box::new(network), report))
    }
}

/// tanh(w·x + b) of one hidden neuron with weights and bias `row`.
#[inline]
fn neuron(row: &[f64], input: &[f64]) -> f64 {
    let (weights, bias) = row.split_at(row.len() - 1);
    tanh(bias[0] + weights.iter().zip(input).map(|(w, x)| w * x).sum::<f64>())
}

/// The hidden neurons' tanh, as sign(s)·(1 − 2/(e^(2|s|) + 1)): one
/// exponential instead of the library tanh's expm1 (a third of the
/// training's time), within 4·10⁻¹⁶ of it absolutely (what the weighted
/// sums see; its relative error grows below |s| ≈ 10⁻³, where the value is
/// itself below 10⁻³).
#[inline]
fn tanh(s: f64) -> f64 {
    (1.0 - 2.0 / ((2.0 * s.abs()).exp() + 1.0)).copysign(s)
}

/// Why training stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Stop {
    /// The held-out error stayed above its best for `patience` epochs; the
    /// weights of the best epoch are kept.
    HeldOutRose,
    /// The gradient ‖Jᵀe‖∞ fell below the tolerance (a minimum).
    SmallGradient,
    /// No damping up to μ_max lowered the error (a minimum to the
    /// precision of the arithmetic).
    DampingLimit,
    /// The epoch limit.
    EpochLimit,
}

/// The training's settings (defaults: those of Hagan & Menhaj and MATLAB's
/// `trainlm`, with every 5th sample held out).
#[derive(Debug, Clone, PartialEq)]
pub struct LevenbergMarquardt {
    /// Neurons in the hidden layer.
    pub hidden: usize,
    /// Seed of the initial weights.
    pub seed: u64,
    /// At most this many epochs (one epoch: one accepted step).
    pub max_epochs: usize,
    /// Every this-many-th sample is held out for early stopping; 0 trains
    /// on every sample without early stopping.
    pub held_out_every: usize,
    /// Epochs the held-out error may stay above its best before stopping.
    pub patience: usize,
    /// Initial damping μ, its factor β and its limit.
    pub damping: f64,
    pub damping_factor: f64,
    pub max_damping: f64,
    /// Stop when ‖Jᵀe‖∞ is below this (scaled units).
    pub gradient_tolerance: f64,
}

impl Default for LevenbergMarquardt {
    fn default() -> Self {
        LevenbergMarquardt {
            hidden: 10,
            seed: 1,
            max_epochs: 200,
            held_out_every: 5,
            patience: 6,
            damping: 1e-3,
            damping_factor: 10.0,
            max_damping: 1e10,
            gradient_tolerance: 1e-9,
        }
    }
}

/// What training did.
#[derive(Debug, Clone, PartialEq)]
pub struct Training {
    /// Accepted epochs.
    pub epochs: usize,
    pub stop: Stop,
    /// The epoch whose weights were kept (0: the initial weights).
    pub best_epoch: usize,
    /// Mean squared error per output on the training samples: at the start
    /// and after each accepted epoch. It never rises.
    pub training_mse: Vec<f64>,
    /// The same on the held-out samples (empty without held-out samples).
    pub held_out_mse: Vec<f64>,
    /// Samples trained on and held out.
    pub training_samples: usize,
    pub held_out_samples: usize,
}

/// The network's report: its sizes, seed, the samples it was trained on
/// and its MSE and R² over every sample (Verma & Peyada 2020, Eqs. 21–22),
/// in scaled units; the training's epochs, stop and held-out error in
/// `settings`.
pub fn report(
    network: &FeedForward,
    training: &Training,
    seed: u64,
    inputs: &[Vec<f64>],
    targets: &[Vec<f64>],
    input_names: &[String],
    output_names: &[String],
) -> NetworkReport {
    let predictions: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| {
            let mut y = vec![0.0; network.outputs];
            network.predict(x, &mut y);
            y
        })
        .collect();
    let (mse, r_squared) = fit_metrics(targets, &predictions);
    let held_out = training
        .held_out_mse
        .get(training.best_epoch)
        .copied()
        .unwrap_or(f64::NAN);
    NetworkReport {
        kind: "feed-forward".into(),
        inputs: input_names.to_vec(),
        outputs: output_names.to_vec(),
        hidden: network.hidden,
        seed,
        training_samples: training.training_samples,
        mse,
        r_squared,
        settings: vec![
            ("epochs".into(), training.epochs as f64),
            ("best epoch".into(), training.best_epoch as f64),
            ("held-out samples".into(), training.held_out_samples as f64),
            ("held-out mse".into(), held_out),
        ],
    }
}

#[cfg(test)]
mod tests;
