//! Evaluating a model: the regressors at a flight condition, the sums
//! Σ C_term · regressor of the six coefficients (the Kirchhoff factor on the
//! lift-type `alpha` term, `CL2` = CL²), the induced drag, and the body-
//! and wind-axis coefficients; the response to a coefficient's offset.
//!
//! **Force axes**: "wind" gives CL, CD in stability axes and CY along body
//! y: `CX = −CD·cos α + CL·sin α`, `CZ = −CD·sin α − CL·cos α`; "body"
//! gives CX, CY, CZ. Moments are body-axis, about the centre of gravity.
//!
//! **Moment reference point**: moments given about r (body axes, from the
//! CG) are moved to the CG by `M_cg = M_ref + r × F` (Jategaonkar, "Flight
//! Vehicle System Identification", 2nd ed., ch. 3; Klein & Morelli 2006,
//! ch. 3): `Cl += (r_y·CZ − r_z·CY)/b`, `Cm += (r_z·CX − r_x·CZ)/c̄`,
//! `Cn += (r_x·CY − r_y·CX)/b` (for the pitching moment the textbook
//! `Cm_α,cg = Cm_α,ref + CL_α·(x̄_cg − x̄_ref)`, Etkin & Reid §2.3).

use super::model::{AeroCoefficients, AeroInput, AeroModel};
use super::spec::{InducedDragLift, RateNormalization, RateSpeed};
use super::terms::{Coefficient, ForceAxes, Monomial, REGRESSOR_COUNT, Regressor, TermRegressors};
use crate::state::{Control, SinCos};
use aeroid_numerics::dual::Real;
use nalgebra::Vector3;

impl AeroModel {
    /// Whether [`AeroModel::offset_response`] is the exact response of the
    /// coefficients to a coefficient's offset: not when the forces depend
    /// on α̇ (the equations are solved for it), nor when the induced drag
    /// squares the attached-flow lift (not in the coefficients it is given).
    pub fn offset_response_is_exact(&self) -> bool {
        let attached = self.stall.is_some()
            && self.stall_options.induced_drag_lift == InducedDragLift::Attached;
        !(self.forces_depend_on_alpha_dot() || attached)
    }

    /// Normalising speed for rates: the airspeed or V0, times 2 or 1.
    #[inline(always)]
    pub(super) fn rate_divisor<T: Real>(&self, airspeed: T) -> T {
        let speed = match self.rate_speed {
            RateSpeed::Airspeed => airspeed,
            RateSpeed::Reference => T::constant(self.reference_airspeed),
        };
        match self.rate_normalization {
            RateNormalization::TwiceSpeed => speed * 2.0,
            RateNormalization::Speed => speed,
        }
    }

    /// The value of every regressor (indexed by `Regressor as usize`) at a
    /// flight condition; `CL2` is left 0 (it needs the lift coefficient).
    #[inline(always)]
    pub fn regressors<T: Real>(&self, input: &AeroInput<T>, chi: T) -> [T; REGRESSOR_COUNT] {
        let per_speed = T::constant(1.0) / self.rate_divisor(input.airspeed);
        let (b, c) = (self.geometry.span, self.geometry.chord);
        let u = &input.controls;
        let control = |control: Control| T::constant(u[control.index()]);
        [
            T::constant(1.0),
            input.alpha,
            input.beta,
            input.rates.x * b * per_speed,
            input.rates.y * c * per_speed,
            input.rates.z * b * per_speed,
            input.alpha_dot * c * per_speed,
            control(Control::Elevator),
            control(Control::Aileron),
            control(Control::Rudder),
            control(Control::Flap),
            input.airspeed / self.reference_airspeed - 1.0,
            input.mach - self.reference_mach,
            T::constant(1.0) - chi,
            T::zero(),
        ]
    }

    #[inline(always)]
    fn sum<T: Real>(&self, coefficient: Coefficient, regressors: &[T; REGRESSOR_COUNT]) -> T {
        self.sum_scaled(coefficient, regressors, T::constant(1.0))
    }

    /// Σ C_term·regressor + offset of `coefficient`, with the `alpha`
    /// regressor times `alpha_factor` (the Kirchhoff factor on the
    /// lift-type coefficient; 1, which changes nothing, elsewhere).
    #[inline(always)]
    fn sum_scaled<T: Real>(
        &self,
        coefficient: Coefficient,
        regressors: &[T; REGRESSOR_COUNT],
        alpha_factor: T,
    ) -> T {
        let values = self.parameters.values();
        let mut sum = T::constant(-0.0);
        for t in &self.terms[coefficient as usize] {
            let regressor = match t.monomial.single() {
                Some(Regressor::Alpha) => regressors[Regressor::Alpha as usize] * alpha_factor,
                Some(r) => regressors[r as usize],
                None => t.monomial.value(regressors),
            };
            sum += regressor * t.coefficient(values);
        }
        sum + self.offsets[coefficient as usize]
    }

    /// The regressors of every coefficient but the lift-type one
    /// (`CL2` = CL² included) and the lift-type coefficient, at a flight
    /// condition; the lift-type `alpha` regressor is the `alpha` one times
    /// the Kirchhoff factor (also returned).
    #[inline(always)]
    fn regressors_and_lift<T: Real>(&self, input: &AeroInput<T>) -> ([T; REGRESSOR_COUNT], T, T) {
        let chi = self.effective_chi(input);
        let mut other = self.regressors(input, chi);
        let kirchhoff = self.kirchhoff(chi);
        let lift_type = self.sum_scaled(Coefficient::Lift, &other, kirchhoff);
        other[Regressor::LiftSquared as usize] = lift_type * lift_type;
        (other, lift_type, kirchhoff)
    }

    /// The regressors every term multiplies at a flight condition (the
    /// Kirchhoff factor on the lift-type `alpha` term, `CL2` = CL²).
    pub fn term_regressors(&self, input: &AeroInput) -> TermRegressors {
        let (other, _, kirchhoff) = self.regressors_and_lift(input);
        let mut regressors = TermRegressors::default();
        let (lift, rest) = regressors.values.split_at_mut(REGRESSOR_COUNT);
        lift.copy_from_slice(&other);
        lift[Regressor::Alpha as usize] *= kirchhoff;
        lift[Regressor::LiftSquared as usize] = 0.0;
        rest[..REGRESSOR_COUNT].copy_from_slice(&other);
        let products = &mut rest[REGRESSOR_COUNT + 1..];
        for (value, product) in products.iter_mut().zip(&self.products) {
            *value = product.value(&other);
        }
        regressors
    }

    /// The slot in [`TermRegressors`] of the value a term of `coefficient` multiplies.
    pub fn term_slot(&self, coefficient: Coefficient, monomial: Monomial) -> usize {
        match monomial.single() {
            Some(regressor) => TermRegressors::slot(coefficient == Coefficient::Lift, regressor),
            None => {
                let k = self.products.iter().position(|p| *p == monomial);
                TermRegressors::ONE + 1 + k.expect("every product of a term has a slot")
            }
        }
    }

    /// Evaluates all six coefficients. Allocation-free.
    pub fn coefficients(&self, input: &AeroInput) -> AeroCoefficients {
        self.coefficients_at(input, input.alpha.sin_cos())
    }

    /// As [`AeroModel::coefficients`], with sin α and cos α of `input.alpha` given.
    #[inline(always)]
    pub fn coefficients_at<T: Real>(
        &self,
        input: &AeroInput<T>,
        alpha_sin_cos: (T, T),
    ) -> AeroCoefficients<T> {
        let (regressors, lift_type, _) = self.regressors_and_lift(input);
        let mut drag_type = self.sum(Coefficient::Drag, &regressors);
        if let Some(e) = self.oswald {
            let induced = match (self.stall, self.stall_options.induced_drag_lift) {
                (Some(_), InducedDragLift::Attached) => self.sum(Coefficient::Lift, &regressors),
                _ => lift_type,
            };
            drag_type += induced * induced
                / (self.parameters.values()[e] * std::f64::consts::PI * self.geometry.aspect_ratio);
        }
        let side = self.sum(Coefficient::Side, &regressors);
        let moment = Vector3::new(
            self.sum(Coefficient::Roll, &regressors),
            self.sum(Coefficient::Pitch, &regressors),
            self.sum(Coefficient::Yaw, &regressors),
        );
        self.assemble(lift_type, side, drag_type, moment, alpha_sin_cos)
    }

    /// The coefficients from the lift-type, side, drag-type and moment
    /// coefficients at angle of attack α (its sine and cosine; linear in the four).
    #[inline(always)]
    fn assemble<T: Real>(
        &self,
        lift_type: T,
        side: T,
        drag_type: T,
        moment: Vector3<T>,
        (sin_alpha, cos_alpha): (T, T),
    ) -> AeroCoefficients<T> {
        let mut coefficients = match self.force_axes {
            ForceAxes::Wind => AeroCoefficients {
                force: Vector3::new(
                    -drag_type * cos_alpha + lift_type * sin_alpha,
                    side,
                    -drag_type * sin_alpha - lift_type * cos_alpha,
                ),
                moment,
                lift: lift_type,
                drag: drag_type,
            },
            ForceAxes::Body => AeroCoefficients {
                force: Vector3::new(drag_type, side, lift_type),
                moment,
                lift: -lift_type * cos_alpha + drag_type * sin_alpha,
                drag: -drag_type * cos_alpha - lift_type * sin_alpha,
            },
        };
        if self.moment_reference != Vector3::zeros() {
            coefficients.moment += self.moment_transfer(&coefficients.force);
        }
        coefficients
    }

    /// What the body-axis force coefficients `force` (CX, CY, CZ) add to
    /// the moment coefficients when these are taken about the reference
    /// point r (from the CG, [`AeroModel::moment_reference`]) and the
    /// moments about the CG are wanted: M_cg = M_ref + r × F, non-dimensional
    /// (r × C_F)/(b, c̄, b). Zero for r = 0.
    pub fn moment_transfer<T: Real>(&self, force: &Vector3<T>) -> Vector3<T> {
        let r = &self.moment_reference;
        let g = &self.geometry;
        Vector3::new(
            (force.z * r.y - force.y * r.z) / g.span,
            (force.x * r.z - force.z * r.x) / g.chord,
            (force.y * r.x - force.x * r.y) / g.span,
        )
    }

    /// Which body-axis force coefficients (CX, CY, CZ) the transfer of the
    /// moment `coefficient` to the CG uses ([`AeroModel::moment_transfer`]).
    pub fn transfer_uses(&self, coefficient: Coefficient) -> [bool; 3] {
        let r = self.moment_reference.map(|v| v != 0.0);
        match coefficient {
            Coefficient::Roll => [false, r.z, r.y],
            Coefficient::Pitch => [r.z, false, r.x],
            Coefficient::Yaw => [r.y, r.x, false],
            _ => [false; 3],
        }
    }

    /// ∂[`AeroModel::coefficients`]/∂(offset of `coefficient`) at a flight
    /// condition where the coefficients are `at` (sin α, cos α = `alpha_sin_cos`), exact:
    /// the offset adds to its coefficient, and a lift-type offset also moves
    /// the drag through CL² (its `CL2` terms and the Oswald term,
    /// ∂CD/∂CL = 2·CL·(Σ CD_CL2 + 1/(e·π·Λ))).
    pub fn offset_response(
        &self,
        coefficient: Coefficient,
        at: &AeroCoefficients,
        alpha_sin_cos: SinCos,
    ) -> AeroCoefficients {
        let mut unit = [0.0; 6];
        unit[coefficient as usize] = 1.0;
        if coefficient == Coefficient::Lift {
            let values = self.parameters.values();
            let mut slope: f64 = self.terms[Coefficient::Drag as usize]
                .iter()
                .filter(|t| t.monomial == Monomial::from(Regressor::LiftSquared))
                .map(|t| t.coefficient(values))
                .sum();
            if let Some(e) = self.oswald {
                slope += 1.0 / (values[e] * std::f64::consts::PI * self.geometry.aspect_ratio);
            }
            let lift_type = self.coefficient_values(at)[0];
            unit[Coefficient::Drag as usize] = 2.0 * lift_type * slope;
        }
        let [lift, side, drag, roll, pitch, yaw] = unit;
        self.assemble(
            lift,
            side,
            drag,
            Vector3::new(roll, pitch, yaw),
            alpha_sin_cos,
        )
    }

    /// The six coefficients in this model's naming order (CL/CZ, CY, CD/CX, Cl, Cm, Cn).
    pub fn coefficient_values(&self, c: &AeroCoefficients) -> [f64; 6] {
        let (lift, drag) = match self.force_axes {
            ForceAxes::Wind => (c.lift, c.drag),
            ForceAxes::Body => (c.force.z, c.force.x),
        };
        [lift, c.force.y, drag, c.moment.x, c.moment.y, c.moment.z]
    }
}
