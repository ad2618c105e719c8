//! Discretisation (Van Loan, "Computing integrals involving the matrix
//! exponential", IEEE TAC 23(3), 1978, §4): with ẋ = A·x + B·u + G·w,
//! E[w·wᵀ] = Q_c, the step h transition Φ = e^{A·h}, the input matrix
//! Γ = ∫₀ʰ e^{A·s} ds·B and the discrete process noise
//! Q_d = ∫₀ʰ e^{A·s}·G·Q_c·Gᵀ·e^{Aᵀ·s} ds come from the exponentials of
//! the block matrices [[A, B], [0, 0]]·h and [[−A, GQ_cGᵀ], [0, Aᵀ]]·h;
//! Q_d, the second's top-right block times Φ, is summed as that block's
//! series on n × n matrices with doubling ([`ProcessNoise`]). The
//! first-order hold's input matrices come from one exponential of a
//! larger block matrix (Franklin, Powell & Workman, "Digital Control of
//! Dynamic Systems", §6.3.2).

use super::dense::{multiply, resize, symmetrise};
use super::exp::{Exponential, exponential, squarings_for};
use super::sparse::SparseRows;
use nalgebra::DMatrix;

/// The most terms of [`ProcessNoise`]'s series.
const NOISE_TERMS: usize = 24;

/// The discrete process noise Q_d = ∫₀ʰ e^{A·s}·Q_c·e^{Aᵀ·s} ds of
/// ẋ = A·x + w, E[w·wᵀ] = Q_c·δ, by its Taylor series and doubling: the
/// integrand's derivatives at 0 are L_j = A·L_{j−1} + L_{j−1}·Aᵀ, L_0 = Q_c,
/// so Q_d(τ) = Σ_j τ^{j+1}/(j + 1)!·L_j, taken for τ = h·2⁻ˢ with A·τ
/// scaled as [`Exponential`] scales it (‖A·τ‖ ≤ ½: the j-th term below
/// ‖Q_c‖·τ/(j + 1)!; ended where n times a term's largest entry falls
/// below 2⁻⁶⁰ of Q_c's, at most 24 terms); then s doublings
/// Q_d(2τ) = Q_d(τ) + Φ(τ)·Q_d(τ)·Φ(τ)ᵀ,
/// Φ(2τ) = Φ(τ)². The same matrix as Van Loan's block exponential (module
/// header) to rounding, from products of n × n matrices over A's non-zeros
/// instead of the series of a 2n × 2n one. The buffers are kept between
/// calls, so that a filter's step takes it without allocating.
#[derive(Debug, Clone, Default)]
pub struct ProcessNoise {
    scaled: DMatrix<f64>,
    sparse: SparseRows,
    term: DMatrix<f64>,
    product: DMatrix<f64>,
    transition: DMatrix<f64>,
    exponential: Exponential,
    work: [DMatrix<f64>; 2],
}

impl ProcessNoise {
    /// Q_d of A = `a`, Q_c = `noise` (symmetric) over a step h into `into`,
    /// symmetric.
    pub fn of(&mut self, a: &DMatrix<f64>, noise: &DMatrix<f64>, h: f64, into: &mut DMatrix<f64>) {
        let n = a.nrows();
        let squarings =
            squarings_for(a.iter().map(|v| (v * h).abs()).fold(0.0, f64::max) * n as f64);
        let tau = h * 2f64.powi(-squarings);
        resize(&mut self.scaled, n, n);
        for (into, &a) in self.scaled.iter_mut().zip(a.iter()) {
            *into = a * tau;
        }
        self.sparse.set(&self.scaled);
        // The sum Σ_j L_j·τʲ/(j + 1)! (times τ at the end), its term
        // M_j = L_j·τʲ = X·M_{j−1} + (X·M_{j−1})ᵀ, X·M = (M·Xᵀ)ᵀ (M symmetric).
        resize(into, n, n);
        into.copy_from(noise);
        resize(&mut self.term, n, n);
        self.term.copy_from(noise);
        let largest = noise.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut factor = 1.0;
        for j in 1..=NOISE_TERMS {
            self.sparse.times_transposed(&self.term, &mut self.product);
            factor /= (j + 1) as f64;
            let (term, product, sum) = (
                self.term.as_mut_slice(),
                self.product.as_slice(),
                into.as_mut_slice(),
            );
            let mut size = 0.0f64;
            for c in 0..n {
                for r in 0..n {
                    let value = product[r + c * n] + product[c + r * n];
                    term[r + c * n] = value;
                    sum[r + c * n] += factor * value;
                    size = size.max(value.abs());
                }
            }
            if size * factor * n as f64 <= 2f64.powi(-60) * largest {
                break;
            }
        }
        *into *= tau;
        if squarings > 0 {
            self.exponential.of(&self.scaled, &mut self.transition);
            let [product, outer] = &mut self.work;
            for _ in 0..squarings {
                // Q ← Q + Φ·Q·Φᵀ, Φ ← Φ².
                resize(product, n, n);
                product.gemm(1.0, into, &self.transition.transpose(), 0.0);
                resize(outer, n, n);
                outer.gemm(1.0, &self.transition, product, 0.0);
                *into += &*outer;
                multiply(&self.transition, &self.transition, product);
                std::mem::swap(&mut self.transition, product);
            }
        }
        symmetrise(into);
    }
}

/// A linear system over one step: x_{k+1} = Φ·x_k + Γ·u_k + w_k,
/// E[w·wᵀ] = Q_d.
#[derive(Debug, Clone, PartialEq)]
pub struct Discrete {
    /// Φ = e^{A·h}.
    pub transition: DMatrix<f64>,
    /// Γ = ∫₀ʰ e^{A·s} ds·B (a held input).
    pub input: DMatrix<f64>,
    /// Q_d (zero without process noise).
    pub process_noise: DMatrix<f64>,
}

/// Φ, Γ and Q_d of ẋ = A·x + B·u + G·w over a step h, with `noise` the
/// continuous spectral density G·Q_c·Gᵀ (None: no process noise). Van
/// Loan's method (module header).
pub fn discretise(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    noise: Option<&DMatrix<f64>>,
    h: f64,
) -> Discrete {
    let n = a.nrows();
    let m = b.ncols();
    let mut block = DMatrix::zeros(n + m, n + m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    block.view_mut((0, n), (n, m)).copy_from(&(b * h));
    let exp = exponential(&block);
    let transition = exp.view((0, 0), (n, n)).into_owned();
    let input = exp.view((0, n), (n, m)).into_owned();
    let process_noise = match noise {
        None => DMatrix::zeros(n, n),
        Some(noise) => {
            let mut process_noise = DMatrix::zeros(n, n);
            ProcessNoise::default().of(a, noise, h, &mut process_noise);
            process_noise
        }
    };
    Discrete {
        transition,
        input,
        process_noise,
    }
}

/// The input matrices of one step under a first-order hold, u linear from
/// u_k to u_{k+1} over the step: x_{k+1} = Φ·x_k + Γ₀·u_k + Γ₁·(u_{k+1} − u_k)
/// with Γ₀ = ∫₀ʰ e^{A·s} ds·B (the zero-order hold's Γ) and
/// Γ₁ = ∫₀ʰ e^{A·(h−s)}·B·s/h ds, both from one exponential of the block
/// matrix [[A·h, B·h, 0], [0, 0, I], [0, 0, 0]] (Van Loan; Franklin, Powell
/// & Workman, "Digital Control of Dynamic Systems", §6.3.2). Returns
/// (Φ, Γ₀, Γ₁).
pub fn discretise_first_order_hold(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    h: f64,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let (n, m) = (a.nrows(), b.ncols());
    let mut block = DMatrix::zeros(n + 2 * m, n + 2 * m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    block.view_mut((0, n), (n, m)).copy_from(&(b * h));
    block
        .view_mut((n, n + m), (m, m))
        .copy_from(&DMatrix::identity(m, m));
    let exp = exponential(&block);
    (
        exp.view((0, 0), (n, n)).into_owned(),
        exp.view((0, n), (n, m)).into_owned(),
        exp.view((0, n + m), (n, m)).into_owned(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::testing::{assert_close, system};
    use nalgebra::DVector;

    #[test]
    fn van_loan_matches_fine_quadrature() {
        // Γ and Q_d against the integrals by the trapezoidal rule over 20 000
        // sub-steps of e^{A·s} (error ~h²/12·max|f″| ≈ 1e-10 relative).
        let (a, b) = system();
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let h = 0.2;
        let discrete = discretise(&a, &b, Some(&noise), h);
        let steps = 20_000;
        let ds = h / steps as f64;
        let (mut gamma, mut q) = (DMatrix::zeros(3, 1), DMatrix::zeros(3, 3));
        for i in 0..=steps {
            let w = if i == 0 || i == steps { 0.5 } else { 1.0 };
            let e = exponential(&(&a * (i as f64 * ds)));
            gamma += &e * &b * (w * ds);
            q += &e * &noise * e.transpose() * (w * ds);
        }
        assert_close(&discrete.transition, &exponential(&(&a * h)), 1e-14, "Φ");
        assert_close(&discrete.input, &gamma, 1e-9, "Γ");
        assert_close(&discrete.process_noise, &q, 1e-9, "Q_d");
    }

    /// The series with doubling against Van Loan's block exponential
    /// itself, Q_d = Φ·F with e^{[[−A, Q_c], [0, Aᵀ]]·h} = [[·, F], [0, ·]]:
    /// within 10⁻¹⁴ relative (Frobenius norm) for a step inside the series'
    /// radius (no doubling), one of 5 doublings, and an augmented model's A
    /// (trailing zero rows, noise on a constant state too); exactly
    /// symmetric.
    #[test]
    fn process_noise_series_is_van_loans_block_exponential() {
        let van_loan = |a: &DMatrix<f64>, noise: &DMatrix<f64>, h: f64| {
            let n = a.nrows();
            let mut block = DMatrix::zeros(2 * n, 2 * n);
            block.view_mut((0, 0), (n, n)).copy_from(&(-a * h));
            block.view_mut((0, n), (n, n)).copy_from(&(noise * h));
            block
                .view_mut((n, n), (n, n))
                .copy_from(&(a.transpose() * h));
            exponential(&(a * h)) * exponential(&block).view((0, n), (n, n))
        };
        let (a, b) = system();
        let mut augmented = DMatrix::zeros(4, 4);
        augmented.view_mut((0, 0), (3, 3)).copy_from(&a);
        augmented.view_mut((0, 3), (3, 1)).copy_from(&b);
        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01]));
        let augmented_noise =
            DMatrix::from_diagonal(&DVector::from_vec(vec![0.3, 2.0, 0.01, 1e-4]));
        let mut series = ProcessNoise::default();
        for (a, noise, h) in [
            (&a, &noise, 0.01),
            (&a, &noise, 0.5),
            (&augmented, &augmented_noise, 0.04),
        ] {
            let mut q = DMatrix::zeros(0, 0);
            series.of(a, noise, h, &mut q);
            let expected = van_loan(a, noise, h);
            assert_close(&q, &expected, 1e-14, &format!("h = {h}"));
            assert_eq!(q, q.transpose());
        }
    }
}
