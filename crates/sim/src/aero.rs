//! Aerodynamic models: linear stability and control derivatives, and the
//! quasi-steady stall model with Kirchhoff flow separation. One
//! [`AeroModel`] evaluates both an aircraft file's truth and every
//! estimator's postulated model. The file vocabulary (regressors, products
//! such as `alpha^2`, ties, the `[stall]` variants, the moment reference
//! point) is in docs/files.md, "Aircraft (`aircraft/*.toml`)".
//!
//! **Coefficients**: each a sum of named terms `C_term · regressor`, the
//! parameter `{coefficient}_{term}` (`CL_alpha`, `Cm_q`, `CD_0`), rates
//! normalised p·b/(kV), q·c̄/(kV), r·b/(kV) (k = 2 or 1); products of
//! regressors ([`Monomial`]) and tied parameters ([`Tie`], θ = c·θ_master +
//! d) are evaluated by the same sum, so the simulator, the regressions'
//! columns and the state-space Jacobians all see them.
//!
//! **Quasi-steady stall** (Verma & Peyada 2020, Eqs. 2–4, after
//! Fischenberg): χ from `τ1·dχ/dt + χ = ½·(1 − tanh(a1·(α − τ2·α̇ − α*)))`,
//! the lift through the Kirchhoff factor ((1 + √χ)/2)², drag and pitching
//! moment through (1 − χ) terms; see `stall`.
//!
//! **Moment reference point**: moments given about r are moved to the CG
//! by `M_cg = M_ref + r × F` (Jategaonkar, "Flight Vehicle System
//! Identification", 2nd ed., ch. 3; Klein & Morelli 2006, ch. 3; Etkin &
//! Reid §2.3); see `evaluate`.
//!
//! The parts, each importing only those listed before it: `terms`
//! (regressors, products, coefficients, ties' relation), `spec` (the file
//! table), `model` (the model and its construction), `stall` (χ), `evaluate`
//! (the coefficients), `ties`, `local` (local linear derivatives).

mod evaluate;
mod local;
mod model;
mod spec;
mod stall;
mod terms;
mod ties;

#[cfg(test)]
mod tests;

pub use model::{AeroCoefficients, AeroInput, AeroModel};
pub use spec::{
    AeroSpec, InducedDragLift, ModelKind, MomentReferenceSpec, RateNormalization, RateSpeed,
    ReferenceGeometry, StallAlphaDot, StallSpec, StallTimeUnit,
};
pub use terms::{
    Coefficient, ForceAxes, MAX_DEGREE, MAX_PRODUCTS, Monomial, REGRESSOR_COUNT, Regressor,
    TermError, TermRegressors, Tie,
};
