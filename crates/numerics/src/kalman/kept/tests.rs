//! The kept buffers give back what was pushed or written in place:
//! matrices (dense and by their entries), Gaussian estimates, updates and
//! sequences of scalar updates.

use super::*;
use crate::kalman::update::Update;

fn gaussian(seed: f64, n: usize) -> Gaussian {
    Gaussian {
        mean: DVector::from_fn(n, |i, _| seed + i as f64),
        covariance: DMatrix::from_fn(n, n, |i, j| seed * 10.0 + (i * n + j) as f64),
    }
}

/// Every estimate and covariance comes back as pushed; one taken out by
/// `last_mut` and changed is read changed, and stays so once the next
/// push puts it back.
#[test]
fn gaussians_keep_what_is_pushed_and_what_last_mut_writes() {
    let mut kept = Gaussians::with_capacity(2, true);
    let pushed: Vec<Gaussian> = (0..3).map(|k| gaussian(k as f64, 3)).collect();
    kept.push(&pushed[0]);
    kept.push_parts(&pushed[1].mean, None);
    let changed = gaussian(7.0, 3);
    kept.last_mut().unwrap().covariance = changed.covariance.clone();
    assert_eq!(kept.get(1).unwrap().covariance, changed.covariance);
    kept.push(pushed[2].clone());
    assert_eq!(kept.len(), 3);
    assert_eq!(kept.to_vec()[0], pushed[0]);
    assert_eq!(kept.get(1).unwrap().mean, pushed[1].mean);
    assert_eq!(kept.get(1).unwrap().covariance, changed.covariance);
    assert_eq!(kept.last().unwrap().to_gaussian(), pushed[2]);
    assert!(kept.get(3).is_none());
}

/// Without every covariance only the last one given is kept; the other
/// estimates read an empty (0 × 0) covariance.
#[test]
fn gaussians_without_every_covariance_keep_the_last_given() {
    let mut kept = Gaussians::with_capacity(3, false);
    let pushed: Vec<Gaussian> = (0..3).map(|k| gaussian(k as f64, 2)).collect();
    kept.push_parts(&pushed[0].mean, None);
    kept.push_parts(&pushed[1].mean, None);
    kept.push(&pushed[2]);
    for (k, pushed) in pushed.iter().enumerate().take(2) {
        let estimate = kept.get(k).unwrap();
        assert_eq!(estimate.mean, pushed.mean);
        assert_eq!(estimate.covariance.shape(), (0, 0));
    }
    assert_eq!(kept.get(2).unwrap().to_gaussian(), pushed[2]);
}

/// An estimate written in place is kept as one pushed, between pushed
/// ones, with every covariance and with the last one given only.
#[test]
fn gaussians_written_in_place_are_kept_as_pushed() {
    let pushed: Vec<Gaussian> = (0..4).map(|k| gaussian(k as f64, 3)).collect();
    for every in [true, false] {
        let mut kept = Gaussians::with_capacity(4, every);
        kept.push(&pushed[0]);
        for estimate in &pushed[1..3] {
            let (mean, covariance) = kept.push_for_writing(3);
            assert_eq!((&*mean, covariance.len()), (&[0.0; 3][..], 9));
            mean.copy_from_slice(estimate.mean.as_slice());
            covariance.copy_from_slice(estimate.covariance.as_slice());
        }
        assert_eq!(kept.get(2).unwrap().to_gaussian(), pushed[2]);
        kept.push_parts(&pushed[3].mean, None);
        assert_eq!(kept.len(), 4);
        for (k, estimate) in pushed.iter().enumerate() {
            let view = kept.get(k).unwrap();
            assert_eq!(view.mean, estimate.mean);
            match (every, k) {
                (true, 3) => assert_eq!(view.covariance, DMatrix::zeros(3, 3)),
                (true, _) | (false, 2) => assert_eq!(view.covariance, estimate.covariance),
                (false, _) => assert_eq!(view.covariance.shape(), (0, 0), "{k}"),
            }
        }
    }
}

/// Updates of different numbers of outputs, and grid points without
/// one, come back part by part as pushed.
#[test]
fn updates_keep_each_part_of_each_update() {
    let n = 3;
    let update = |m: usize, seed: f64| Measured {
        observation: DMatrix::from_fn(m, n, |i, j| seed + (i * n + j) as f64),
        update: Update {
            innovation: DVector::from_fn(m, |i, _| -seed - i as f64),
            innovation_covariance: DMatrix::from_fn(m, m, |i, j| seed * 2.0 + (i + j) as f64),
            innovation_inverse: DMatrix::from_fn(m, m, |i, j| seed * 3.0 - (i * j) as f64),
            gain: DMatrix::from_fn(n, m, |i, j| seed * 5.0 + (i * m + j) as f64),
        },
    };
    let pushed = [None, Some(update(2, 1.0)), Some(update(1, 4.0)), None];
    let mut kept = Updates::with_capacity(4, 2);
    for measured in pushed.iter().cloned() {
        kept.push(measured);
    }
    assert_eq!(kept.len(), 4);
    for (k, measured) in pushed.iter().enumerate() {
        let got = kept.get(k);
        assert_eq!(got.is_some(), measured.is_some());
        if let (Some(got), Some(measured)) = (got, measured) {
            let update = &measured.update;
            assert_eq!(got.observation, measured.observation);
            assert_eq!(got.innovation, update.innovation);
            assert_eq!(got.innovation_covariance, update.innovation_covariance);
            assert_eq!(got.innovation_inverse, update.innovation_inverse);
            assert_eq!(got.gain, update.gain);
            assert_eq!(
                kept.observation_values(k).unwrap(),
                measured.observation.as_slice()
            );
        }
    }
}

/// Matrices come back as pushed, as views and as their own.
#[test]
fn matrices_keep_each_matrix() {
    let pushed: Vec<DMatrix<f64>> = (0..3)
        .map(|k| DMatrix::from_fn(2, 3, |i, j| (k * 6 + i * 3 + j) as f64))
        .collect();
    let mut kept = Matrices::with_capacity(3);
    for matrix in &pushed {
        kept.push(matrix);
    }
    assert_eq!(kept.get(1).unwrap(), pushed[1]);
    assert!(kept.get(3).is_none());
    assert_eq!(kept.clone().into_iter().collect::<Vec<_>>(), pushed);
    // Written in place after pushed ones: the same.
    let written = DMatrix::from_fn(2, 3, |i, j| (i * 10 + j) as f64);
    let into = kept.push_for_writing(2, 3);
    assert_eq!(into, &[0.0; 6]);
    into.copy_from_slice(written.as_slice());
    assert_eq!(kept.get(3).unwrap(), written);
    assert_eq!(kept.len(), 4);
}

/// Sequences of scalar updates, and grid points without one, come
/// back output by output as pushed: H's rows by their non-zeros (an
/// entry holding a zero dropped), the gains' columns, ν, s.
#[test]
fn scalar_updates_keep_each_output_of_each_sequence() {
    let n = 3;
    let mut kept = ScalarUpdates::with_capacity(3, 2);
    let h = DMatrix::from_row_slice(2, n, &[0.5, 0.0, 2.5, 0.0, 4.5, 0.0]);
    let gains: Vec<f64> = (0..2 * n).map(|v| -(v as f64)).collect();
    kept.push_none();
    kept.push_sequence(&SparseRows::of(&h), &gains, &[1.0, 2.0], &[3.0, 4.0]);
    let one = DMatrix::from_row_slice(1, n, &[7.0, 8.0, 9.0]);
    let mut held = SparseRows::of(&one);
    // The held pattern keeps an entry that is zero at this step.
    held.set(&DMatrix::from_row_slice(1, n, &[7.0, 0.0, 9.0]));
    kept.push_sequence(&held, &[1.0, 1.5, 2.0], &[5.0], &[6.0]);
    assert_eq!(kept.len(), 3);
    assert_eq!((kept.count(0), kept.count(1), kept.count(2)), (0, 2, 1));
    assert!(kept.get(0, 0).is_none() && kept.get(1, 2).is_none());
    let expected: [(&[usize], &[f64]); 2] = [(&[0, 2], &[0.5, 2.5]), (&[1], &[4.5])];
    let mut row = vec![f64::NAN; n];
    for (i, (columns, values)) in expected.into_iter().enumerate() {
        let got = kept.get(1, i).unwrap();
        assert_eq!((got.columns, got.observation), (columns, values));
        got.observation_into(&mut row);
        assert_eq!(row, h.row(i).iter().copied().collect::<Vec<_>>());
        assert_eq!(got.gain, &gains[i * n..(i + 1) * n]);
        assert_eq!(
            (got.innovation, got.variance),
            (1.0 + i as f64, 3.0 + i as f64)
        );
    }
    let got = kept.get(2, 0).unwrap();
    assert_eq!(
        (got.columns, got.observation),
        (&[0, 2][..], &[7.0, 9.0][..])
    );
    assert_eq!(got.gain, &[1.0, 1.5, 2.0]);
    assert_eq!((got.innovation, got.variance), (5.0, 6.0));
}

/// Sparse matrices come back with their values on their patterns, a
/// pattern kept once for the matrices that hold it.
#[test]
fn sparse_matrices_keep_each_matrix_on_its_pattern() {
    let first = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 2.0, 0.0, 3.0, 0.0]);
    let mut held = SparseRows::of(&first);
    let mut kept = SparseMatrices::with_capacity(3);
    kept.push(&held);
    held.set(&DMatrix::from_row_slice(
        2,
        3,
        &[4.0, 0.0, 0.0, 0.0, 5.0, 0.0],
    ));
    kept.push(&held);
    let other = SparseRows::of(&DMatrix::from_row_slice(
        2,
        3,
        &[0.0, 6.0, 0.0, 7.0, 0.0, 0.0],
    ));
    kept.push(&other);
    assert_eq!((kept.len(), kept.patterns.len()), (3, 2));
    let values: Vec<&[f64]> = (0..3).map(|k| kept.get(k).unwrap().1).collect();
    assert_eq!(
        values,
        [&[1.0, 2.0, 3.0][..], &[4.0, 0.0, 5.0], &[6.0, 7.0]]
    );
    let (pattern, _) = kept.get(2).unwrap();
    assert_eq!(
        (pattern.row(0), pattern.row(1)),
        (&[(1, 6.0)][..], &[(0, 7.0)][..])
    );
    assert!(kept.get(3).is_none());
}
