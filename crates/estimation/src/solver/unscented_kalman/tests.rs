//! Tests of `unscented_kalman`.

use super::factors::solve_right_lower_any;
use super::*;
use crate::model::linear::LinearStateSpace;
use crate::solver::extended_kalman;

/// On a linear model the unscented transform is exact: the unscented
/// pass is the (extended = linear) Kalman filter's, to rounding without
/// process noise (a damped oscillator and a slow mode, two of three
/// states measured, a dropout every fifth point). With process noise
/// the unscented pass takes Q_d by the trapezoidal rule and the
/// extended one exactly (Van Loan): the rule's relative error is about
/// h²·‖2A‖²/12 ≈ 2e-3 at h = 0.01 (‖A‖ ≈ 8), the tolerance 5e-3. Both
/// for α = 1 (W₀ᶜ = 2: the zeroth point an update) and α = 0.5
/// (W₀ᶜ = −0.25: a downdate).
#[test]
fn on_a_linear_model_it_is_the_kalman_filter() {
    let a = DMatrix::from_row_slice(3, 3, &[-1.2, 1.0, 0.0, -8.0, -2.1, 0.3, 0.0, 0.5, -0.05]);
    against_the_kalman_filter(&a, &[0.05, -0.1, 0.02]);
}

/// The same with a fourth state that no step moves (A's last row zero,
/// so e^{A·h} leaves it exactly), driving the second: the time update
/// takes the form for unchanged states (module header), Φ's last row
/// exactly the identity's, and the pass is still the Kalman filter's.
#[test]
fn with_a_constant_state_it_is_the_kalman_filter() {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            -1.2, 1.0, 0.0, 0.0, -8.0, -2.1, 0.3, 0.5, 0.0, 0.5, -0.05, 0.0, 0.0, 0.0, 0.0, 0.0,
        ],
    );
    let transitions = against_the_kalman_filter(&a, &[0.05, -0.1, 0.02, 0.4]);
    for transition in &transitions {
        let last = transition.row(3).clone_owned();
        assert_eq!(last.as_slice(), &[0.0, 0.0, 0.0, 1.0]);
    }
}

/// The unscented and the extended pass over a model ẋ = A·x with the
/// first and last of the first three states measured (module test
/// above), for both α and with and without process noise; returns the
/// unscented passes' transitions.
fn against_the_kalman_filter(a: &DMatrix<f64>, mean: &[f64]) -> Vec<DMatrix<f64>> {
    let n = a.nrows();
    let mut transitions = Vec::new();
    for alpha in [1.0, 0.5] {
        for (process, step, tolerance) in [(0.0, 0.05, 1e-10), (0.2, 0.01, 5e-3)] {
            let len = (10.0 / step) as usize;
            let mut c = DMatrix::zeros(2, n);
            c[(0, 0)] = 1.0;
            c[(1, 2)] = 1.0;
            let model = LinearStateSpace::new(
                [a.clone(), DMatrix::zeros(n, 1), c, DMatrix::zeros(2, 1)],
                Vec::new(),
                0.0,
                step,
                vec![DVector::zeros(1); len],
            )
            .unwrap();
            let at = (0..len)
                .map(|k| {
                    let t = k as f64 * step;
                    let mut here = vec![(0, (3.0 * t).sin() * 0.1)];
                    if k % 5 != 4 {
                        here.push((1, (0.7 * t).cos() * 0.05));
                    }
                    here
                })
                .collect();
            let observations = Observations {
                names: vec!["a".into(), "b".into()],
                at,
                moved: 0,
            };
            let initial = Gaussian {
                mean: DVector::from_column_slice(mean),
                covariance: DMatrix::identity(n, n) * 0.3,
            };
            let noise = Noise {
                process: DMatrix::identity(n, n) * process,
                measurement: DVector::from_vec(vec![1e-3, 4e-4]),
            };
            let unscented = filter(
                &model,
                &[],
                initial.clone(),
                &noise,
                &observations,
                &Unscented {
                    alpha,
                    ..Unscented::default()
                },
            )
            .unwrap();
            let extended =
                extended_kalman::filter(&model, &[], initial.clone(), &noise, &observations)
                    .unwrap();
            for (u, e) in unscented.filtered.iter().zip(&extended.filtered) {
                let error = (&u.mean - &e.mean).norm() / e.mean.norm().max(1e-3);
                assert!(error < tolerance, "α {alpha}, Q {process}: mean {error:e}");
                let error = (&u.covariance - &e.covariance).norm() / e.covariance.norm();
                assert!(
                    error < tolerance,
                    "α {alpha}, Q {process}: covariance {error:e}"
                );
            }
            let error = (unscented.negative_log_likelihood - extended.negative_log_likelihood)
                .abs()
                / extended.negative_log_likelihood.abs();
            assert!(error < tolerance, "α {alpha}: −ln L {error:e}");
            transitions.extend(unscented.transitions);
        }
    }
    transitions
}

/// The rank-one update and downdate against the factor of the updated
/// matrix, and a downdate past definiteness refused.
#[test]
fn cholupdate_updates_and_refuses_a_downdate_past_definiteness() {
    let p = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 2.0]);
    let v = DVector::from_vec(vec![0.7, -0.3, 0.9]);
    for sign in [1.0, -1.0] {
        let mut l = Cholesky::new(p.clone()).unwrap().unpack();
        let mut x = v.clone();
        cholupdate(&mut l, x.as_mut_slice(), sign).unwrap();
        let expected = &p + &v * v.transpose() * sign;
        let error = (&l * l.transpose() - &expected).norm() / expected.norm();
        assert!(error < 1e-15, "sign {sign}: {error:e}");
        assert!(l.diagonal().iter().all(|&d| d > 0.0));
    }
    let mut l = Cholesky::new(p.clone()).unwrap().unpack();
    let mut x = DVector::from_vec(vec![2.5, 0.0, 0.0]);
    assert!(cholupdate(&mut l, x.as_mut_slice(), -1.0).is_err());
}

/// S·Sᵀ is the product, symmetric; for a factor of the augmented
/// filters' size (22, blocks of 4 rows and a tail) with a zero below
/// the diagonal each element is Σ_k S_ik·S_jk summed from zero in order
/// of k, bit for bit.
#[test]
fn covariance_is_the_factors_product() {
    let l = DMatrix::from_row_slice(3, 3, &[2.0, 0.0, 0.0, 0.5, 1.5, 0.0, -0.3, 0.7, 0.9]);
    let mut p = DMatrix::zeros(0, 0);
    covariance_into(&l, &mut p);
    let expected = &l * l.transpose();
    assert!((&p - &expected).norm() < 1e-15 * expected.norm());
    assert_eq!(p, p.transpose());
    let l = lower_factor(22);
    covariance_into(&l, &mut p);
    for j in 0..22 {
        for i in j..22 {
            let mut sum = 0.0;
            for k in 0..=j {
                if l[(j, k)] != 0.0 {
                    sum += l[(j, k)] * l[(i, k)];
                }
            }
            assert_eq!(p[(i, j)].to_bits(), sum.to_bits(), "({i}, {j})");
            assert_eq!(p[(j, i)].to_bits(), sum.to_bits(), "({j}, {i})");
        }
    }
}

/// A lower-triangular n × n factor with a positive diagonal and one zero
/// below it.
fn lower_factor(n: usize) -> DMatrix<f64> {
    let mut l = DMatrix::from_fn(n, n, |i, j| {
        if i < j {
            0.0
        } else if i == j {
            1.0 + 0.05 * i as f64
        } else {
            ((i * n + j) as f64 * 0.37).sin() * 0.3
        }
    });
    l[(n - 1, 1)] = 0.0;
    l
}

/// The kernels compiled for AVX2 where the CPU has it
/// ([`aeroid_numerics::simd::wide`]) give the build's own instruction set's
/// numbers bit for bit, at the augmented filters' sizes (22 states, the
/// time update's compound matrix of 26 rows, 5 outputs): S·Sᵀ, the
/// Householder triangularisation, the rank-one update and downdate,
/// L·B and the right triangular solve.
#[test]
fn wide_kernels_match_the_baseline() {
    let n = 22;
    let l = lower_factor(n);
    let compound = DMatrix::from_fn(26, n, |i, j| ((i * 31 + j * 7) as f64 * 0.11).cos());
    let b = DMatrix::from_fn(n, 5, |i, j| ((i + 3 * j) as f64 * 0.29).sin());
    let x = DVector::from_fn(n, |i, _| 0.1 * ((i as f64) * 0.7).sin());
    let run = || {
        let mut p = DMatrix::zeros(0, 0);
        covariance_into(&l, &mut p);
        let mut a = compound.clone();
        let mut factor = DMatrix::zeros(n, n);
        triangularise(&mut a, 26, n, &mut factor);
        let mut updated = l.clone();
        let mut v = x.clone();
        cholupdate(&mut updated, v.as_mut_slice(), 1.0).unwrap();
        let mut v = x.clone();
        cholupdate(&mut updated, v.as_mut_slice(), -1.0).unwrap();
        let mut product = DMatrix::zeros(0, 0);
        multiply_lower(&l, &b, &mut product);
        let mut solved = b.transpose();
        assert!(solve_right_lower(&l, &mut solved));
        [p, factor, updated, product, solved]
    };
    let wide = run();
    let baseline = aeroid_numerics::simd::baseline(run);
    for (w, b) in wide.iter().zip(&baseline) {
        assert!(
            w.iter()
                .zip(b.iter())
                .all(|(w, b)| w.to_bits() == b.to_bits())
        );
    }
}

/// L·B over L's lower triangle is the dense product bit for bit.
#[test]
fn multiply_lower_is_the_dense_product() {
    let l = DMatrix::from_fn(6, 6, |i, j| {
        if i < j {
            0.0
        } else {
            ((i * 6 + j) as f64 * 0.61).cos() + 0.3
        }
    });
    let b = DMatrix::from_fn(6, 3, |i, j| ((i + 5 * j) as f64 * 0.23).sin());
    let mut lower = DMatrix::zeros(0, 0);
    multiply_lower(&l, &b, &mut lower);
    let mut dense = DMatrix::zeros(0, 0);
    multiply(&l, &b, &mut dense);
    assert!(
        lower
            .iter()
            .zip(dense.iter())
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert!((&lower - &l * &b).norm() < 1e-15 * lower.norm());
}

/// X·L = B solved from the right against B·L⁻¹ by nalgebra's inverse,
/// for B of 1 to 10 rows; the forms unrolled for up to 8 rows give the
/// general form's numbers bit for bit.
#[test]
fn solve_right_lower_solves_from_the_right() {
    let l = DMatrix::from_fn(9, 9, |i, j| {
        if i < j {
            0.0
        } else if i == j {
            1.5 + 0.1 * i as f64
        } else {
            ((i * 9 + j) as f64 * 0.37).sin()
        }
    });
    for rows in 1..=10 {
        let b = DMatrix::from_fn(rows, 9, |i, j| (i as f64 - 1.3 * j as f64).cos());
        let mut x = b.clone();
        assert!(solve_right_lower(&l, &mut x));
        let expected = &b * l.clone().try_inverse().unwrap();
        assert!(
            (&x - &expected).norm() < 1e-13 * expected.norm(),
            "{rows} rows"
        );
        let mut general = b.clone();
        assert!(solve_right_lower_any(
            l.as_slice(),
            9,
            rows,
            general.as_mut_slice()
        ));
        assert!(
            x.iter()
                .zip(general.iter())
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{rows} rows"
        );
    }
    let mut singular = l.clone();
    singular[(1, 1)] = 0.0;
    let b = DMatrix::from_fn(4, 9, |i, j| (i + j) as f64);
    assert!(!solve_right_lower(&singular, &mut b.clone()));
}

/// The Householder triangularisation: S·Sᵀ = Aᵀ·A with a lower S of
/// non-negative diagonal, for a tall A.
#[test]
fn triangularise_gives_the_factor_of_the_gram_matrix() {
    let mut a = DMatrix::from_fn(7, 3, |i, j| ((i * 3 + j) as f64 * 0.7).sin() - 0.2);
    let gram = a.transpose() * &a;
    let mut factor = DMatrix::zeros(3, 3);
    triangularise(&mut a, 7, 3, &mut factor);
    let error = (&factor * factor.transpose() - &gram).norm() / gram.norm();
    assert!(error < 1e-15, "{error:e}");
    assert!(factor.diagonal().iter().all(|&d| d >= 0.0));
    assert!(factor.upper_triangle().norm() == factor.diagonal().norm());
}
