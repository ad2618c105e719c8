//! The extended Kalman filter's time update for the covariance: the
//! transition Φ and the discretised process noise Q_d of the model
//! linearised over one step, exactly (Φ = e^{A·h}, Van Loan's Q_d;
//! [`kalman::discretise`]) or to second order (Wang et al. 2012, Eq. 11b;
//! the parent module's header), the second-order form on the patterns of
//! A's non-zeros ([`SquarePlan`], [`NoisePlan`]).

use aeroid_numerics::kalman::{self, Exponential, ProcessNoise, SparseRows, resize};
use nalgebra::DMatrix;

/// How the time update discretises the linearised model for the covariance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Discretisation {
    /// Φ = e^{A·h} and Van Loan's Q_d ([`kalman::discretise`]).
    #[default]
    Exact,
    /// Φ = I + A·h + ½(A·h)² (Wang et al. 2012, Eq. 11b) and
    /// Q_d = Q_c·h + (A·Q_c + Q_c·Aᵀ)·h²/2 + A·Q_c·Aᵀ·h³/3 (module header).
    SecondOrder,
}

impl Discretisation {
    /// Φ and Q_d of ẋ = A·x + w, E[w·wᵀ] = `noise`·δ, over a step h.
    pub fn transition_and_noise(
        self,
        a: &DMatrix<f64>,
        noise: &DMatrix<f64>,
        h: f64,
    ) -> (DMatrix<f64>, DMatrix<f64>) {
        let mut time_update = TimeUpdate::default();
        let has_noise = noise.iter().any(|&v| v != 0.0);
        time_update.discretise(self, a, has_noise.then_some(noise), h);
        time_update.transition();
        let n = a.nrows();
        let process = if has_noise {
            time_update.process_noise();
            time_update.process_noise
        } else {
            DMatrix::zeros(n, n)
        };
        (time_update.transition, process)
    }
}

/// The buffers of a time update: Φ, Q_d, their makings and Φ's non-zeros
/// (and, for the second-order form, A's and A·h's on A's pattern: each
/// kept apart, so that Φ's and A's patterns are held from step to step,
/// [`SparseRows`]).
#[derive(Debug, Clone, Default)]
pub(super) struct TimeUpdate {
    /// Φ (for the second-order form written from `sparse` only when read:
    /// [`TimeUpdate::transition`]).
    transition: DMatrix<f64>,
    /// Whether `transition` is Φ's values in `sparse`.
    dense: bool,
    pub(super) process_noise: DMatrix<f64>,
    /// For the second-order form with a diagonal spectral density: Q_d on
    /// its pattern ([`NoisePlan`]), `process_noise` written from it only
    /// when read ([`TimeUpdate::process_noise`]).
    noise_plan: NoisePlan,
    /// Whether Q_d is `noise_plan`'s.
    pub(super) noise_on_plan: bool,
    pub(super) sparse: SparseRows,
    sparse_scaled: SparseRows,
    sparse_rates: SparseRows,
    square: SquarePlan,
    exponential: Exponential,
    pub(super) work: [DMatrix<f64>; 2],
    noise: ProcessNoise,
}

/// Where the second-order Φ = I + B + ½·B² (B = A·h) takes its values
/// from, on the pattern of I + B + B² built from B's: per entry of Φ's
/// pattern, row by row in increasing column, B_ij's position among B's
/// entries (None: off B's pattern), whether i = j, and the end of its
/// products in `products`: the pairs (B_ik, B_kj) of (B²)_ij in increasing
/// k, by their positions, where both are on B's pattern. The values are
/// those of B² summed over the dense B's k (a term off the pattern is
/// 0·x) bit for bit.
#[derive(Debug, Clone, Default)]
struct SquarePlan {
    /// The id of B's pattern it was built for ([`SparseRows::pattern`]).
    pattern: u64,
    entries: Vec<(Option<usize>, bool, usize)>,
    products: Vec<(usize, usize)>,
}

impl SquarePlan {
    /// Builds the plan and Φ's pattern (into `phi`) for B's pattern.
    fn build(&mut self, b: &SparseRows, phi: &mut SparseRows) {
        let n = b.rows();
        let entries = b.entries();
        let starts: Vec<usize> = (0..=n)
            .map(|i| (0..i).map(|r| b.row(r).len()).sum::<usize>())
            .collect();
        let position = |i: usize, j: usize| {
            b.row(i)
                .iter()
                .position(|&(c, _)| c == j)
                .map(|p| starts[i] + p)
        };
        debug_assert_eq!(starts[n], entries.len());
        let mut rows = Vec::with_capacity(n);
        self.entries.clear();
        self.products.clear();
        for i in 0..n {
            let mut columns = vec![i];
            for &(k, _) in b.row(i) {
                columns.push(k);
                columns.extend(b.row(k).iter().map(|&(j, _)| j));
            }
            columns.sort_unstable();
            columns.dedup();
            for &j in &columns {
                for &(k, _) in b.row(i) {
                    if let Some(kj) = position(k, j) {
                        let ik = position(i, k).expect("k on row i");
                        self.products.push((ik, kj));
                    }
                }
                self.entries
                    .push((position(i, j), i == j, self.products.len()));
            }
            rows.push(columns);
        }
        phi.set_pattern(b.columns(), rows);
        self.pattern = b.pattern();
    }

    /// Φ's values on its pattern (`phi`, built by [`SquarePlan::build`]).
    fn values(&self, b: &SparseRows, phi: &mut SparseRows) {
        let b = b.entries();
        let mut start = 0;
        for (entry, &(on_b, diagonal, end)) in phi.entries_mut().iter_mut().zip(&self.entries) {
            let mut squared = 0.0;
            for &(ik, kj) in &self.products[start..end] {
                squared += b[ik].1 * b[kj].1;
            }
            start = end;
            let mut value = squared * 0.5 + on_b.map_or(0.0, |p| b[p].1);
            if diagonal {
                value += 1.0;
            }
            entry.1 = value;
        }
    }
}

/// Where the second-order Q_d = Q_c·h + (A·Q_c + Q_c·Aᵀ)·h²/2 +
/// A·Q_c·Aᵀ·h³/3, made symmetric, takes its values from when Q_c is
/// diagonal (q on the diagonal, read once: a time update serves one pass),
/// on the pattern of its non-zeros built from A's: per entry (i, j), i ≤ j,
/// the makings of Q_ij and Q_ji before the symmetric mean
/// ½·(Q_ij + Q_ji) — (A·Q_c)_ij = A_ij·q_j and (A·Q_c)_ji by their
/// positions among A's entries, Q_c's q_i on the diagonal, and the terms
/// of (A·Q_c·Aᵀ)_ij = Σ_k A_jk·(A_ik·q_k) over k in increasing order where
/// both are on A's pattern and q_k ≠ 0 (`terms`). The values are the dense
/// form's bit for bit (a term off the pattern is 0·x).
#[derive(Debug, Clone, Default)]
struct NoisePlan {
    /// Whether the spectral density was read, and its diagonal if it is
    /// diagonal (None: the dense form).
    density: Option<Option<Vec<f64>>>,
    /// The id of A's pattern the plan was built for.
    pattern: u64,
    /// Per entry (i, j, Q_ij's makings, Q_ji's makings).
    entries: Vec<(usize, usize, Makings, Makings)>,
    /// (A_jk, A_ik, k) by their positions among A's entries.
    terms: Vec<(usize, usize, usize)>,
    /// Q_d's values at `entries`, symmetric mean taken.
    values: Vec<f64>,
}

/// What one entry of Q_d is made of before the symmetric mean: the range
/// of its terms in [`NoisePlan::terms`], (A·Q_c)_ij's and (A·Q_c)_ji's
/// positions among A's entries, and q_i on the diagonal.
#[derive(Debug, Clone, Copy, Default)]
struct Makings {
    terms: (usize, usize),
    forward: Option<usize>,
    backward: Option<usize>,
    diagonal: bool,
}

impl NoisePlan {
    /// The diagonal of `noise`, if it has no other non-zero.
    fn diagonal(noise: &DMatrix<f64>) -> Option<Vec<f64>> {
        let n = noise.nrows();
        let off = (0..n).any(|j| (0..n).any(|i| i != j && noise[(i, j)] != 0.0));
        (noise.is_square() && !off).then(|| noise.diagonal().iter().copied().collect())
    }

    /// Builds the plan for A's pattern (`a`) and the diagonal q.
    fn build(&mut self, a: &SparseRows) {
        let Some(Some(q)) = &self.density else {
            return;
        };
        let n = a.rows();
        let mut starts = Vec::with_capacity(n + 1);
        starts.push(0);
        for i in 0..n {
            starts.push(starts[i] + a.row(i).len());
        }
        let position = |i: usize, j: usize| {
            a.row(i)
                .iter()
                .position(|&(c, _)| c == j)
                .map(|p| starts[i] + p)
        };
        let (mut entries, mut terms) = (
            std::mem::take(&mut self.entries),
            std::mem::take(&mut self.terms),
        );
        entries.clear();
        terms.clear();
        let makings = |i: usize, j: usize, terms: &mut Vec<(usize, usize, usize)>| {
            let from = terms.len();
            for &(k, _) in a.row(j) {
                if let (true, Some(ik)) = (q[k] != 0.0, position(i, k)) {
                    terms.push((position(j, k).expect("k on row j"), ik, k));
                }
            }
            Makings {
                terms: (from, terms.len()),
                forward: position(i, j).filter(|_| q[j] != 0.0),
                backward: position(j, i).filter(|_| q[i] != 0.0),
                diagonal: i == j && q[i] != 0.0,
            }
        };
        for j in 0..n {
            for i in 0..=j {
                let (ij, ji) = (makings(i, j, &mut terms), makings(j, i, &mut terms));
                let empty = |m: &Makings| {
                    m.terms.0 == m.terms.1
                        && m.forward.is_none()
                        && m.backward.is_none()
                        && !m.diagonal
                };
                if empty(&ij) && empty(&ji) {
                    terms.truncate(ij.terms.0);
                } else {
                    entries.push((i, j, ij, ji));
                }
            }
        }
        (self.entries, self.terms) = (entries, terms);
        self.values.clear();
        self.values.resize(self.entries.len(), 0.0);
        self.pattern = a.pattern();
    }

    /// Q_d's values on the plan's pattern for A's values `a` and step h.
    fn evaluate(&mut self, a: &SparseRows, h: f64) {
        let NoisePlan {
            density: Some(Some(q)),
            entries,
            terms,
            values,
            ..
        } = self
        else {
            return;
        };
        let a = a.entries();
        let value = |m: &Makings, i: usize| {
            let mut outer = 0.0;
            for &(jk, ik, k) in &terms[m.terms.0..m.terms.1] {
                outer += a[jk].1 * (a[ik].1 * q[k]);
            }
            let forward = m.forward.map_or(0.0, |p| a[p].1 * q[a[p].0]);
            let backward = m.backward.map_or(0.0, |p| a[p].1 * q[a[p].0]);
            let density = if m.diagonal { q[i] } else { 0.0 };
            outer * (h * h * h / 3.0) + (forward + backward) * (h * h / 2.0) + density * h
        };
        for (into, (i, j, ij, ji)) in values.iter_mut().zip(entries.iter()) {
            *into = if i == j {
                value(ij, *i)
            } else {
                (value(ij, *i) + value(ji, *j)) * 0.5
            };
        }
    }

    /// Adds Q_d's values to the n × n `covariance` (column-major) on the
    /// plan's pattern (both triangles).
    fn add_to(&self, covariance: &mut [f64], n: usize) {
        for (&value, &(i, j, ..)) in self.values.iter().zip(&self.entries) {
            covariance[i + j * n] += value;
            if i != j {
                covariance[j + i * n] += value;
            }
        }
    }
}

impl TimeUpdate {
    /// Φ into `transition` and its non-zeros into `sparse`, Q_d of the
    /// spectral density `noise` into `process_noise` (None: no process
    /// noise, `process_noise` not written).
    fn discretise(
        &mut self,
        discretisation: Discretisation,
        a: &DMatrix<f64>,
        noise: Option<&DMatrix<f64>>,
        h: f64,
    ) {
        self.discretise_into(discretisation, a, noise, h, None);
    }

    /// [`TimeUpdate::discretise`] with Φ also written into `kept` when
    /// given (n × n, column-major: a pass's kept transition): the exact Φ
    /// there instead of into `transition`, the second-order one from its
    /// non-zeros.
    // The time update at every grid point of a pass: either form writes Φ and Q_d in place in the update's buffers; split, each step would be one more call per grid point taking them.
    pub(super) fn discretise_into(
        &mut self,
        discretisation: Discretisation,
        a: &DMatrix<f64>,
        noise: Option<&DMatrix<f64>>,
        h: f64,
        kept: Option<&mut [f64]>,
    ) {
        let n = a.nrows();
        match discretisation {
            Discretisation::Exact => {
                // Φ's rows past the last non-zero row of A are the
                // identity's (an augmented model's constant parameters).
                let into = match kept {
                    Some(kept) => {
                        // `transition` is not Φ: written from `sparse` if read.
                        self.dense = false;
                        kept
                    }
                    None => {
                        self.dense = true;
                        resize(&mut self.transition, n, n);
                        self.transition.as_mut_slice()
                    }
                };
                let leading = self.exponential.of_scaled_into(a, h, into);
                self.noise_on_plan = false;
                if let Some(noise) = noise {
                    self.noise.of(a, noise, h, &mut self.process_noise);
                }
                self.sparse.set_leading_values(into, n, n, leading);
            }
            Discretisation::SecondOrder => {
                // A·h by A's non-zeros; Φ = I + A·h + ½·(A·h)² on the
                // pattern of I + B + B², B = A·h ([`SquarePlan`]).
                self.sparse_rates.set(a);
                self.sparse_scaled.scaled_from(&self.sparse_rates, h);
                if self.square.pattern != self.sparse_scaled.pattern() || self.sparse.rows() != n {
                    self.square.build(&self.sparse_scaled, &mut self.sparse);
                }
                self.square.values(&self.sparse_scaled, &mut self.sparse);
                self.dense = false;
                if let Some(kept) = kept {
                    dense_from(&self.sparse, kept);
                }
                let Some(noise) = noise else {
                    return;
                };
                let density = self
                    .noise_plan
                    .density
                    .get_or_insert_with(|| NoisePlan::diagonal(noise));
                self.noise_on_plan = density.is_some();
                if self.noise_on_plan {
                    if self.noise_plan.pattern != self.sparse_rates.pattern() {
                        self.noise_plan.build(&self.sparse_rates);
                    }
                    self.noise_plan.evaluate(&self.sparse_rates, h);
                    return;
                }
                let [product, transposed] = &mut self.work;
                {
                    // A·Q_c = (Q_cᵀ·Aᵀ)ᵀ and A·Q_c·Aᵀ = (A·Q_c)·Aᵀ by A's
                    // non-zeros.
                    resize(transposed, n, n);
                    noise.transpose_to(transposed);
                    self.sparse_rates.times_transposed(transposed, product);
                    product.transpose_to(transposed);
                    self.sparse_rates.times_transposed(transposed, product);
                    // transposed = A·Q_c, product = A·Q_c·Aᵀ.
                    resize(&mut self.process_noise, n, n);
                    let (q, outer, aq, noise) = (
                        self.process_noise.as_mut_slice(),
                        product.as_slice(),
                        transposed.as_slice(),
                        noise.as_slice(),
                    );
                    for j in 0..n {
                        for i in 0..n {
                            q[i + j * n] = outer[i + j * n] * (h * h * h / 3.0)
                                + (aq[i + j * n] + aq[j + i * n]) * (h * h / 2.0)
                                + noise[i + j * n] * h;
                        }
                    }
                    kalman::symmetrise(&mut self.process_noise);
                }
            }
        }
    }

    /// Q_d as a dense matrix (after a [`TimeUpdate::discretise`] with
    /// process noise).
    fn process_noise(&mut self) -> &DMatrix<f64> {
        if self.noise_on_plan {
            let n = self.sparse_rates.rows();
            resize(&mut self.process_noise, n, n);
            self.process_noise.fill(0.0);
            self.noise_plan.add_to(self.process_noise.as_mut_slice(), n);
            self.noise_on_plan = false;
        }
        &self.process_noise
    }

    /// Adds Q_d to the n × n `covariance` (column-major) where it is kept
    /// on its pattern (else nothing: the dense Q_d goes with the
    /// prediction).
    pub(super) fn add_process_noise_on_pattern(&self, covariance: &mut [f64], n: usize) {
        if self.noise_on_plan {
            self.noise_plan.add_to(covariance, n);
        }
    }

    /// Φ as a dense matrix.
    fn transition(&mut self) -> &DMatrix<f64> {
        if !self.dense {
            let n = self.sparse.rows();
            resize(&mut self.transition, n, n);
            dense_from(&self.sparse, self.transition.as_mut_slice());
            self.dense = true;
        }
        &self.transition
    }
}

/// The n × n matrix of `sparse`'s non-zeros into `into` (column-major).
fn dense_from(sparse: &SparseRows, into: &mut [f64]) {
    let n = sparse.rows();
    into.fill(0.0);
    for i in 0..n {
        for &(j, value) in sparse.row(i) {
            into[i + j * n] = value;
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    /// The second-order discretisation agrees with the exact one to the
    /// order it claims: on a triple integrator fed by a damped oscillator
    /// (A nilpotent in part, oscillatory in part), halving h divides the
    /// error of Φ by about 8 (O(h³)) and the error of Q_d relative to
    /// ‖Q_d‖ ∝ h by about 4 (the h⁴ term missing from the O(h) noise);
    /// Q_d stays symmetric positive semi-definite.
    #[test]
    fn second_order_discretisation_converges_at_its_order() {
        let a = DMatrix::from_row_slice(
            5,
            5,
            &[
                0.0, 1.0, 0.0, 0.0, 0.0, //
                -4.0, -0.6, 0.0, 0.0, 1.0, //
                0.0, 0.0, 0.0, 1.0, 0.0, //
                0.0, 0.0, 0.0, 0.0, 1.0, //
                0.0, 0.0, 0.0, 0.0, 0.0,
            ],
        );
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.1, 0.2, 0.0, 0.0, 3.0]));
        let errors = |h: f64| {
            let (phi, q) = Discretisation::Exact.transition_and_noise(&a, &noise, h);
            let (phi2, q2) = Discretisation::SecondOrder.transition_and_noise(&a, &noise, h);
            assert!((&q2 - q2.transpose()).amax() == 0.0);
            assert!(q2.clone().symmetric_eigenvalues().min() >= -1e-15 * q2.amax());
            ((phi - phi2).amax(), (&q - q2).amax() / q.amax())
        };
        let (phi_coarse, q_coarse) = errors(0.02);
        let (phi_fine, q_fine) = errors(0.01);
        let phi_order = (phi_coarse / phi_fine).log2();
        let q_order = (q_coarse / q_fine).log2();
        assert!((2.8..3.2).contains(&phi_order), "Φ order {phi_order}");
        assert!((1.8..2.2).contains(&q_order), "Q_d order {q_order}");
        // The truncation bound (‖A‖·h)³/6 with ‖A‖ ≈ 4, h = 0.02: 8.5e-5.
        assert!(
            phi_coarse < 8.5e-5 && q_coarse < 1e-3,
            "{phi_coarse} {q_coarse}"
        );
    }

    /// The second-order Φ computed on the pattern of I + B + B²
    /// (`SquarePlan`) is the dense series I + B + ½·B², B² summed over
    /// every k in increasing order, bit for bit, and so is Q_d: on its
    /// pattern for a diagonal spectral density (`NoisePlan`), by dense
    /// products for another; for a first A, for one with an entry gone to
    /// zero (the pattern held: that entry's terms are 0·x) and for one
    /// with a new non-zero (the pattern rebuilt).
    #[test]
    fn second_order_transition_on_its_pattern_is_the_dense_series() {
        let first = DMatrix::from_row_slice(
            5,
            5,
            &[
                0.0, 1.0, 0.0, 0.0, 0.3, //
                -4.0, -0.6, 0.0, 0.0, 1.0, //
                0.0, 0.0, 0.0, 1.0, 0.0, //
                0.0, 0.0, 0.0, 0.0, 1.0, //
                0.0, 0.0, 0.0, 0.0, 0.0,
            ],
        );
        let mut zeroed = first.clone();
        zeroed[(1, 0)] = 0.0;
        let mut wider = first.clone();
        wider[(4, 2)] = 0.7;
        let h = 0.04;
        let dense = |a: &DMatrix<f64>| {
            let b = a * h;
            DMatrix::from_fn(5, 5, |i, j| {
                let mut squared = 0.0;
                for k in 0..5 {
                    squared += b[(i, k)] * b[(k, j)];
                }
                let value = squared * 0.5 + b[(i, j)];
                if i == j { value + 1.0 } else { value }
            })
        };
        // Q_d as the dense form sums it: A·Q_c, A·Q_c·Aᵀ over every k.
        let dense_noise = |a: &DMatrix<f64>, noise: &DMatrix<f64>| {
            let sum = |f: &dyn Fn(usize) -> f64| (0..5).fold(0.0, |sum, k| sum + f(k));
            let aq = DMatrix::from_fn(5, 5, |i, r| sum(&|k| a[(i, k)] * noise[(k, r)]));
            let outer = DMatrix::from_fn(5, 5, |r, i| sum(&|k| a[(i, k)] * aq[(r, k)]));
            let q = DMatrix::from_fn(5, 5, |i, j| {
                outer[(i, j)] * (h * h * h / 3.0)
                    + (aq[(i, j)] + aq[(j, i)]) * (h * h / 2.0)
                    + noise[(i, j)] * h
            });
            DMatrix::from_fn(5, 5, |i, j| {
                if i == j {
                    q[(i, j)]
                } else {
                    (q[(i, j)] + q[(j, i)]) * 0.5
                }
            })
        };
        let diagonal = DMatrix::from_diagonal(&DVector::from_vec(vec![0.1, 0.2, 0.0, 0.0, 3.0]));
        let mut full = diagonal.clone();
        (full[(0, 1)], full[(1, 0)]) = (0.05, 0.05);
        for noise in [&diagonal, &full] {
            let mut time_update = TimeUpdate::default();
            let mut patterns = Vec::new();
            for a in [&first, &zeroed, &wider] {
                time_update.discretise(Discretisation::SecondOrder, a, Some(noise), h);
                patterns.push(time_update.sparse.pattern());
                assert_eq!(time_update.transition(), &dense(a));
                assert_eq!(time_update.noise_on_plan, noise == &diagonal);
                assert_eq!(time_update.process_noise(), &dense_noise(a, noise));
            }
            assert_eq!(patterns[0], patterns[1], "the pattern held");
            assert_ne!(patterns[1], patterns[2], "the pattern rebuilt");
        }
    }
}
