//! Named parameters. Every model (truth or postulated) exposes its parameters
//! by name (`CL_alpha`, `Cm_q`, `a1`, `alpha_star`, …) so that estimators can
//! set and read them by index in their inner loop and report them by name.

use serde::{Deserialize, Serialize};

/// A model's parameters by name and index: estimators set and read them by
/// index in their inner loop and report them by name.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ParameterSet {
    names: Vec<String>,
    values: Vec<f64>,
}

impl ParameterSet {
    /// Adds a parameter, returning its index; a repeated name is an error.
    pub fn add(&mut self, name: &str, value: f64) -> Result<usize, crate::error::Error> {
        if self.index(name).is_some() {
            return Err(crate::error::Error::DefinedTwice { name: name.into() });
        }
        self.names.push(name.to_string());
        self.values.push(value);
        Ok(self.values.len() - 1)
    }

    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    pub fn get(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.values[i])
    }

    /// Sets a parameter by name; an unknown name is an error listing the known ones.
    pub fn set(&mut self, name: &str, value: f64) -> aeroid_core::Result<()> {
        match self.index(name) {
            Some(i) => {
                self.values[i] = value;
                Ok(())
            }
            None => Err(aeroid_core::Error::Unknown {
                kind: "parameter",
                name: name.to_string(),
                known: self.names.clone(),
            }),
        }
    }

    pub fn names(&self) -> &[String] {
        &self.names
    }

    pub fn values(&self) -> &[f64] {
        &self.values
    }

    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.names
            .iter()
            .map(String::as_str)
            .zip(self.values.iter().copied())
    }
}
