//! Tied parameters (a model file's `[parameters.NAME] tie`,
//! θ = factor·θ_master + offset) and the queries on a model's terms: which
//! parameter a term has, which term a parameter is, their names.

use super::model::AeroModel;
use super::terms::{Coefficient, Monomial, Tie};

impl AeroModel {
    /// Ties term parameter `tied` to term parameter `master` by
    /// θ_tied = factor·θ_master + offset, and sets θ_tied so. Errors: either
    /// is not a term's parameter, they are the same, the master is tied
    /// itself, the tied one is already tied or is another's master.
    pub fn tie(&mut self, tied: usize, tie: Tie) -> Result<(), crate::error::Error> {
        let fail = |reason: String| Err(crate::error::Error::Tie { reason });
        let names = self.parameters.names();
        let name = |i: usize| names[i].clone();
        if !(tie.factor.is_finite() && tie.offset.is_finite()) {
            return fail("the factor and offset must be finite numbers".into());
        }
        if tie.master == tied {
            return fail(format!("'{}' cannot be tied to itself", name(tied)));
        }
        let is_term = |i: usize| self.terms.iter().flatten().any(|t| t.parameter == i);
        for (i, role) in [(tied, "tied"), (tie.master, "a master")] {
            if !is_term(i) {
                return fail(format!(
                    "'{}' is not a term's parameter ({{coefficient}}_{{term}}): only those can be {role}",
                    name(i)
                ));
            }
        }
        if let Some(other) = self.tie_of(tie.master) {
            return fail(format!(
                "the master '{}' is tied itself (to '{}'): tie to a free or fixed parameter",
                name(tie.master),
                name(other.master)
            ));
        }
        if let Some(other) = self.tie_of(tied) {
            return fail(format!(
                "'{}' is tied already (to '{}')",
                name(tied),
                name(other.master)
            ));
        }
        if let Some(dependent) = self.dependents(tied).next() {
            return fail(format!(
                "'{}' is the master of '{}': a master cannot be tied itself",
                name(tied),
                name(dependent)
            ));
        }
        for term in self.terms.iter_mut().flatten() {
            if term.parameter == tied {
                term.tie = Some(tie);
            }
        }
        let value = tie.value(self.parameters.values());
        self.parameters.values_mut()[tied] = value;
        Ok(())
    }

    /// The relation a parameter is tied by; None when it is not tied.
    pub fn tie_of(&self, parameter: usize) -> Option<Tie> {
        self.terms
            .iter()
            .flatten()
            .find(|t| t.parameter == parameter)
            .and_then(|t| t.tie)
    }

    /// The parameters tied to `master`.
    pub fn dependents(&self, master: usize) -> impl Iterator<Item = usize> + '_ {
        self.terms
            .iter()
            .flatten()
            .filter(move |t| t.tie.is_some_and(|tie| tie.master == master))
            .map(|t| t.parameter)
    }

    /// Whether any parameter is tied to another.
    pub fn has_ties(&self) -> bool {
        self.terms.iter().flatten().any(|t| t.tie.is_some())
    }

    /// Sets every tied parameter's value from its master's (what the
    /// evaluation uses already), e.g. after the masters were estimated.
    pub fn update_tied_values(&mut self) {
        let ties: Vec<(usize, Tie)> = (self.terms.iter().flatten())
            .filter_map(|t| t.tie.map(|tie| (t.parameter, tie)))
            .collect();
        for (tied, tie) in ties {
            let value = tie.value(self.parameters.values());
            self.parameters.values_mut()[tied] = value;
        }
    }

    /// The coefficient and term of a parameter that enters linearly
    /// (`{coefficient}_{term}`) in exactly one term, its own: None for `e`,
    /// the stall parameters, a tied parameter and the master of one (whose
    /// value moves other terms too).
    pub fn term_of(&self, parameter: usize) -> Option<(Coefficient, Monomial)> {
        if self.tie_of(parameter).is_some() || self.dependents(parameter).next().is_some() {
            return None;
        }
        Coefficient::ALL.into_iter().find_map(|coefficient| {
            self.terms[coefficient as usize]
                .iter()
                .find(|t| t.parameter == parameter)
                .map(|t| (coefficient, t.monomial))
        })
    }

    /// The terms of one coefficient as (what the parameter multiplies,
    /// parameter index), in file order.
    pub fn terms(&self, coefficient: Coefficient) -> impl Iterator<Item = (Monomial, usize)> + '_ {
        self.terms[coefficient as usize]
            .iter()
            .map(|t| (t.monomial, t.parameter))
    }

    /// Names of the terms of one coefficient, in file order (for reports and model-structure code).
    pub fn term_names(&self, coefficient: Coefficient) -> Vec<String> {
        self.terms[coefficient as usize]
            .iter()
            .map(|t| self.parameters.names()[t.parameter].clone())
            .collect()
    }
}
