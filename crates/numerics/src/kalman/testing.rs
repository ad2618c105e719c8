//! What the kernels' tests share: a relative comparison of matrices and a
//! small linear system.

use nalgebra::DMatrix;

pub(super) fn assert_close(a: &DMatrix<f64>, b: &DMatrix<f64>, tolerance: f64, what: &str) {
    let scale = b.norm().max(1e-300);
    let error = (a - b).norm() / scale;
    assert!(
        error <= tolerance,
        "{what}: relative error {error:e}\n{a}\n{b}"
    );
}

/// A damped oscillator (short period like) and a slow real mode.
pub(super) fn system() -> (DMatrix<f64>, DMatrix<f64>) {
    let a = DMatrix::from_row_slice(3, 3, &[-1.2, 1.0, 0.0, -8.0, -2.1, 0.3, 0.0, 0.5, -0.05]);
    let b = DMatrix::from_row_slice(3, 1, &[-0.1, -9.0, 0.0]);
    (a, b)
}
