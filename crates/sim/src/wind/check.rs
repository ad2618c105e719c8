//! Field checks of the `[wind]` table: a quantity's SI value in its
//! dimension, and a condition on it, each failure recorded as a problem
//! under its field path so that all of them are reported at once.

use aeroid_core::error::FieldErrors;
use aeroid_core::units::{Dimension, Quantity};

/// The SI value of `quantity`, or `None` after recording why it has none.
pub(super) fn quantity_value(
    problems: &mut FieldErrors,
    field: &str,
    quantity: &Quantity,
    dimension: Dimension,
) -> Option<f64> {
    quantity
        .si(dimension)
        .map_err(|message| problems.push(field, message))
        .ok()
}

/// Checks `quantity` and that its value satisfies `condition`, else records `requirement`.
pub(super) fn require(
    problems: &mut FieldErrors,
    field: &str,
    quantity: &Quantity,
    dimension: Dimension,
    condition: fn(f64) -> bool,
    requirement: &str,
) {
    let value = quantity_value(problems, field, quantity, dimension);
    if value.is_some_and(|value| !condition(value)) {
        problems.push(field, format!("{quantity} {requirement}"));
    }
}

/// A field check for [`require`]: name, quantity, dimension, condition, requirement.
pub(super) type FieldCheck<'a> = (&'a str, &'a Quantity, Dimension, fn(f64) -> bool, &'a str);

pub(super) fn is_positive(value: f64) -> bool {
    value > 0.0
}

pub(super) fn is_not_negative(value: f64) -> bool {
    value >= 0.0
}
