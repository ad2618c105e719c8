//! The parameters' histories over the last pass: θ and σ at every grid point, written as CSV on request.

use super::*;

/// The parameter states at every grid point of a pass.
#[derive(Debug, Clone, PartialEq)]
pub struct History {
    pub names: Vec<String>,
    pub times: Vec<f64>,
    /// \[k\]\[j\]: θ_j at grid point k (filtered).
    pub values: Vec<Vec<f64>>,
    /// \[k\]\[j\]: its σ.
    pub sigmas: Vec<Vec<f64>>,
}

impl History {
    /// A history of the parameters `names` with no grid point (a
    /// diverged run's).
    pub(super) fn empty(names: &[String]) -> History {
        History {
            names: names.to_vec(),
            times: Vec::new(),
            values: Vec::new(),
            sigmas: Vec::new(),
        }
    }

    /// The history of the parameter states (after the `states` kinematic
    /// ones) of a pass.
    pub(super) fn of(pass: &Pass, names: &[String], times: Vec<f64>, states: usize) -> History {
        let m = names.len();
        let values = pass
            .filtered
            .views()
            .map(|g| (0..m).map(|j| g.mean[states + j]).collect())
            .collect();
        let sigmas = pass
            .filtered
            .views()
            .map(|g| {
                (0..m)
                    .map(|j| g.covariance[(states + j, states + j)].max(0.0).sqrt())
                    .collect()
            })
            .collect();
        History {
            names: names.to_vec(),
            times,
            values,
            sigmas,
        }
    }

    /// θ_j and σ_j at the grid point nearest t.
    pub fn at(&self, name: &str, t: f64) -> Option<(f64, f64)> {
        let j = self.names.iter().position(|n| n == name)?;
        let k = self
            .times
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - t).abs().total_cmp(&(b.1 - t).abs()))?
            .0;
        Some((self.values[k][j], self.sigmas[k][j]))
    }

    /// The history as CSV: `time`, then `NAME` and `sigma_NAME` per parameter.
    pub fn to_csv(&self) -> String {
        let mut text = String::from("time");
        for name in &self.names {
            text += &format!(",{name},sigma_{name}");
        }
        text.push('\n');
        for (k, t) in self.times.iter().enumerate() {
            text += &format!("{t}");
            for (value, sigma) in self.values[k].iter().zip(&self.sigmas[k]) {
                text += &format!(",{value:e},{sigma:e}");
            }
            text.push('\n');
        }
        text
    }

    pub fn write_csv(&self, path: &Path) -> Result<()> {
        Ok(
            std::fs::write(path, self.to_csv()).map_err(|source| aeroid_core::Error::Io {
                path: path.to_path_buf(),
                source,
            })?,
        )
    }
}
