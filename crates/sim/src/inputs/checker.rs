//! Reading a spec's quantities: each in its dimension and range (a
//! control's amplitude within what the control can do, a start not before
//! 0 s, positive widths and periods), every bad one pushed as a problem
//! under `inputs[i].field` so that all of them are reported at once.

use crate::state::Control;
use aeroid_core::error::FieldErrors;
use aeroid_core::units::{Dimension, Quantity};

/// Reads a spec's quantities, pushing a problem under `prefix.field` for each bad one.
pub(super) struct Checker<'a> {
    pub(super) problems: &'a mut FieldErrors,
    pub(super) prefix: String,
}

impl Checker<'_> {
    pub(super) fn push(&mut self, field: &str, message: impl std::fmt::Display) {
        self.problems
            .push(format!("{}.{field}", self.prefix), message);
    }

    pub(super) fn quantity(
        &mut self,
        field: &str,
        quantity: &Quantity,
        dimension: Dimension,
    ) -> Option<f64> {
        quantity
            .si(dimension)
            .map_err(|message| self.push(field, message))
            .ok()
    }

    /// A value of the control's dimension (amplitude, level), within the
    /// control's range ([`aeroid_core::limits::MAX_DEFLECTION`], [`aeroid_core::limits::MAX_THROTTLE`]).
    pub(super) fn amplitude(
        &mut self,
        field: &str,
        quantity: &Quantity,
        control: Control,
    ) -> Option<f64> {
        let value = self.quantity(field, quantity, control.dimension())?;
        self.within_range(field, quantity, value, control)
    }

    pub(super) fn within_range(
        &mut self,
        field: &str,
        quantity: &Quantity,
        value: f64,
        control: Control,
    ) -> Option<f64> {
        let (limit, text) = match control {
            Control::Throttle => (
                aeroid_core::limits::MAX_THROTTLE,
                format!(
                    "{}, the whole range of thrust",
                    aeroid_core::limits::MAX_THROTTLE
                ),
            ),
            _ => (
                aeroid_core::limits::MAX_DEFLECTION,
                format!(
                    "{} deg (no control surface deflects further)",
                    aeroid_core::limits::MAX_DEFLECTION.to_degrees()
                ),
            ),
        };
        if value.abs() <= limit {
            Some(value)
        } else {
            self.push(
                field,
                format!(
                    "{} is beyond the {} input's largest magnitude {text}",
                    quantity.to_string().trim_matches('"'),
                    control.name()
                ),
            );
            None
        }
    }

    /// An input's start: not before the flight begins at 0 s.
    pub(super) fn time(&mut self, field: &str, quantity: &Quantity) -> Option<f64> {
        let value = self.quantity(field, quantity, Dimension::Time)?;
        if value >= 0.0 {
            Some(value)
        } else {
            self.push(
                field,
                format!(
                    "{} is before the flight begins at 0 s; an input starts at 0 s or later",
                    quantity.to_string().trim_matches('"')
                ),
            );
            None
        }
    }

    /// A strictly positive value (widths, periods, durations).
    pub(super) fn positive(
        &mut self,
        field: &str,
        quantity: &Quantity,
        dimension: Dimension,
    ) -> Option<f64> {
        let value = self.quantity(field, quantity, dimension)?;
        if value > 0.0 {
            Some(value)
        } else {
            self.push(field, format!("must be positive, got {quantity}"));
            None
        }
    }

    /// A step input's `transition`: 0 when absent, else not negative and
    /// at most `hold` (each level is held that long, so one change ends
    /// before the next begins).
    pub(super) fn transition(&mut self, quantity: Option<&Quantity>, hold: f64) -> Option<f64> {
        let Some(quantity) = quantity else {
            return Some(0.0);
        };
        let value = self.non_negative("transition", quantity, Dimension::Time)?;
        if value > hold {
            self.push(
                "transition",
                format!("{quantity} is longer than a level is held ({hold} s)"),
            );
            return None;
        }
        Some(value)
    }

    pub(super) fn non_negative(
        &mut self,
        field: &str,
        quantity: &Quantity,
        dimension: Dimension,
    ) -> Option<f64> {
        let value = self.quantity(field, quantity, dimension)?;
        if value >= 0.0 {
            Some(value)
        } else {
            self.push(field, format!("must not be negative, got {quantity}"));
            None
        }
    }
}

/// An optional field that failed validation is `None`; one absent or valid is `Some`.
pub(super) fn transpose(value: Option<Option<f64>>) -> Option<Option<f64>> {
    match value {
        Some(None) => None,
        Some(Some(value)) => Some(Some(value)),
        None => Some(None),
    }
}
