//! Aircraft files (`aircraft/*.toml`): geometry, mass and inertia,
//! propulsion, control limits, and the aerodynamic model with its TRUE
//! parameters. Every quantity may carry a unit (`"64 m2"`, `"32 kN"`); a
//! plain number is SI. Validation reports every problem at once.

use crate::aero::{AeroModel, AeroSpec, ReferenceGeometry};
use crate::error::Result;
use crate::state::{CONTROL_COUNT, Control};
use aeroid_core::error::{FieldErrors, parse_toml, read_text};
use aeroid_core::units::{Dimension, Quantity};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// An aircraft file (`aircraft/*.toml`) as written, before its units are
/// converted and it is checked ([`Aircraft::from_file`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AircraftFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub geometry: GeometrySpec,
    pub mass: MassSpec,
    #[serde(default)]
    pub propulsion: PropulsionSpec,
    /// Control deflection limits `[min, max]` per control name; controls are saturated to them.
    #[serde(default)]
    pub limits: BTreeMap<String, [Quantity; 2]>,
    pub aero: AeroSpec,
}

/// The `[geometry]` table of an aircraft file: the reference wing area,
/// span and chord.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeometrySpec {
    pub wing_area: Quantity,
    pub span: Quantity,
    pub chord: Quantity,
}

/// The `[mass]` table of an aircraft file: mass and moments of inertia in
/// body axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MassSpec {
    pub mass: Quantity,
    pub ixx: Quantity,
    pub iyy: Quantity,
    pub izz: Quantity,
    #[serde(default)]
    pub ixz: Quantity,
    /// Why moments of inertia that no rigid body can have (the principal
    /// moments violate the triangle inequality) are flown as they are, e.g.
    /// a paper's published values; without it such moments are an error.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub impossible_inertia: Option<String>,
}

/// The `[propulsion]` table of an aircraft file: the thrust at full throttle
/// and where and how it acts.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PropulsionSpec {
    /// Thrust at full throttle at sea level.
    #[serde(default)]
    pub max_thrust: Quantity,
    /// Thrust line inclination, positive nose-up (thrust gets a −z body component).
    #[serde(default)]
    pub inclination: Quantity,
    /// Point of application relative to the centre of gravity, body axes (m).
    #[serde(default)]
    pub position: [Quantity; 3],
    /// Thrust lapse T = δT·Tmax·(ρ/ρ0)^n.
    #[serde(default)]
    pub density_exponent: Option<f64>,
}

/// Propulsion as used by the equations of motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Propulsion {
    pub max_thrust: f64,
    pub inclination: f64,
    pub position: Vector3<f64>,
    pub density_exponent: f64,
    /// Unit thrust direction in body axes.
    pub direction: Vector3<f64>,
}

impl Propulsion {
    /// Thrust magnitude (N) for a throttle fraction at ln(σ), σ = ρ/ρ0:
    /// T = δT·Tmax·σ^n, evaluated as exp(n·ln σ).
    pub fn thrust(&self, throttle: f64, log_density_ratio: f64) -> f64 {
        throttle * self.max_thrust * (self.density_exponent * log_density_ratio).exp()
    }
}

/// The largest mass an aircraft file may give (kg, with its unit): fifteen
/// times the heaviest aircraft flown (640 t); a larger one is a unit slip.
const LARGEST_MASS: (f64, &str) = (1e7, "kg");
/// The largest wing area (m²): twenty times the largest wing built.
const LARGEST_AREA: (f64, &str) = (1e4, "m²");
/// The largest span or chord (m).
const LARGEST_LENGTH: (f64, &str) = (1e3, "m");
/// The largest moment or product of inertia (kg·m²): a hundred times the
/// largest aircraft's yaw inertia.
const LARGEST_INERTIA: (f64, &str) = (1e10, "kg·m²");

/// Reference geometry and mass properties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    pub mass: f64,
    pub inertia: Matrix3<f64>,
    pub inertia_inverse: Matrix3<f64>,
}

/// A validated aircraft.
#[derive(Debug, Clone, PartialEq)]
pub struct Aircraft {
    pub name: String,
    pub wing_area: f64,
    pub geometry: ReferenceGeometry,
    pub mass: MassProperties,
    pub propulsion: Propulsion,
    /// Lower and upper limit of each control (throttle is always within [0, 1]).
    pub limits: [(f64, f64); CONTROL_COUNT],
    pub aero: AeroModel,
}

impl Aircraft {
    /// Loads and validates an aircraft file.
    pub fn load(path: &Path) -> Result<Aircraft> {
        let text = read_text(path)?;
        let file: AircraftFile = parse_toml(path, &text)?;
        Aircraft::from_file(&file, path)
    }

    /// Validates a parsed file; `path` is named in errors.
    pub fn from_file(file: &AircraftFile, path: &Path) -> Result<Aircraft> {
        let mut problems = FieldErrors::default();
        let mut read = |field: &str, q: &Quantity, dimension: Dimension| {
            q.si(dimension).unwrap_or_else(|message| {
                problems.push(field, message);
                f64::NAN
            })
        };
        let wing_area = read(
            "geometry.wing_area",
            &file.geometry.wing_area,
            Dimension::Area,
        );
        let span = read("geometry.span", &file.geometry.span, Dimension::Length);
        let chord = read("geometry.chord", &file.geometry.chord, Dimension::Length);
        let mass = read("mass.mass", &file.mass.mass, Dimension::Mass);
        let moments = [
            read("mass.ixx", &file.mass.ixx, Dimension::Inertia),
            read("mass.iyy", &file.mass.iyy, Dimension::Inertia),
            read("mass.izz", &file.mass.izz, Dimension::Inertia),
            read("mass.ixz", &file.mass.ixz, Dimension::Inertia),
        ];
        let propulsion = read_propulsion(&file.propulsion, &mut read);
        let limits = read_limits(&file.limits, &mut problems);
        for (field, value, (largest, unit)) in [
            ("geometry.wing_area", wing_area, LARGEST_AREA),
            ("geometry.span", span, LARGEST_LENGTH),
            ("geometry.chord", chord, LARGEST_LENGTH),
            ("mass.mass", mass, LARGEST_MASS),
        ] {
            if value <= 0.0 || value > largest {
                problems.push(
                    field,
                    format!("must be positive and at most {largest:e} {unit}, is {value:e} {unit}"),
                );
            }
        }
        for (field, value) in ["mass.ixx", "mass.iyy", "mass.izz", "mass.ixz"]
            .into_iter()
            .zip(moments)
        {
            let (largest, unit) = LARGEST_INERTIA;
            if value.abs() > largest {
                problems.push(
                    field,
                    format!("must be at most {largest:e} {unit} in magnitude, is {value:e} {unit}"),
                );
            }
        }
        let inertia = inertia_matrix(moments, &file.mass.impossible_inertia, &mut problems);
        if propulsion.max_thrust < 0.0 {
            problems.push("propulsion.max_thrust", "must not be negative");
        }
        let geometry = ReferenceGeometry {
            span,
            chord,
            aspect_ratio: span * span / wing_area,
        };
        let aero = AeroModel::from_spec(&file.aero, geometry, "aero", &mut problems);
        let aircraft = Aircraft {
            name: file.name.clone(),
            wing_area,
            geometry,
            mass: MassProperties {
                mass,
                inertia,
                inertia_inverse: inertia.try_inverse().unwrap_or(Matrix3::zeros()),
            },
            propulsion,
            limits,
            aero,
        };
        Ok(problems.finish(path, aircraft)?)
    }

    /// Saturates controls to the aircraft's limits.
    pub fn saturate(&self, controls: &mut crate::state::Controls) {
        for (value, (low, high)) in controls.iter_mut().zip(self.limits) {
            *value = value.clamp(low, high);
        }
    }
}

fn read_propulsion(
    spec: &PropulsionSpec,
    read: &mut impl FnMut(&str, &Quantity, Dimension) -> f64,
) -> Propulsion {
    let inclination = read(
        "propulsion.inclination",
        &spec.inclination,
        Dimension::Angle,
    );
    let position = Vector3::new(
        read(
            "propulsion.position[0]",
            &spec.position[0],
            Dimension::Length,
        ),
        read(
            "propulsion.position[1]",
            &spec.position[1],
            Dimension::Length,
        ),
        read(
            "propulsion.position[2]",
            &spec.position[2],
            Dimension::Length,
        ),
    );
    Propulsion {
        max_thrust: read("propulsion.max_thrust", &spec.max_thrust, Dimension::Force),
        inclination,
        position,
        density_exponent: spec.density_exponent.unwrap_or(1.0),
        direction: Vector3::new(inclination.cos(), 0.0, -inclination.sin()),
    }
}

fn read_limits(
    spec: &BTreeMap<String, [Quantity; 2]>,
    problems: &mut FieldErrors,
) -> [(f64, f64); CONTROL_COUNT] {
    let mut limits = [(f64::NEG_INFINITY, f64::INFINITY); CONTROL_COUNT];
    limits[Control::Throttle.index()] = (0.0, 1.0);
    for (name, [low, high]) in spec {
        let field = format!("limits.{name}");
        let Some(control) = Control::ALL.into_iter().find(|c| c.name() == name) else {
            let known: Vec<_> = Control::ALL.map(Control::name).into();
            problems.push(
                field,
                format!("unknown control; known: {}", known.join(", ")),
            );
            continue;
        };
        match (low.si(control.dimension()), high.si(control.dimension())) {
            (Ok(low), Ok(high)) if low < high => limits[control.index()] = (low, high),
            (Ok(_), Ok(_)) => problems.push(field, "the lower limit must be below the upper limit"),
            (Err(message), _) | (_, Err(message)) => problems.push(field, message),
        }
    }
    limits
}

/// The inertia tensor with the product of inertia Ixz (Ixy = Iyz = 0 for a
/// symmetric aircraft), checked to be one a rigid body can have: positive
/// definite, and its principal moments satisfy the triangle inequality
/// (each at most the sum of the other two, since I₁ + I₂ − I₃ = 2∫r₃² dm ≥ 0)
/// unless the file gives `impossible_inertia`, a non-empty reason.
fn inertia_matrix(
    [ixx, iyy, izz, ixz]: [f64; 4],
    accepted: &Option<String>,
    problems: &mut FieldErrors,
) -> Matrix3<f64> {
    let inertia = Matrix3::new(ixx, 0.0, -ixz, 0.0, iyy, 0.0, -ixz, 0.0, izz);
    if ![ixx, iyy, izz, ixz].iter().all(|v| v.is_finite()) {
        return inertia;
    }
    let positive_definite = ixx > 0.0 && iyy > 0.0 && izz > 0.0 && ixx * izz - ixz * ixz > 0.0;
    if !positive_definite {
        problems.push(
            "mass",
            format!(
                "the inertia tensor is not positive definite (needs Ixx, Iyy, Izz > 0 and Ixx·Izz > Ixz²; \
                 Ixx = {ixx}, Iyy = {iyy}, Izz = {izz}, Ixz = {ixz})"
            ),
        );
        return inertia;
    }
    let mean = 0.5 * (ixx + izz);
    let radius = (0.25 * (ixx - izz).powi(2) + ixz * ixz).sqrt();
    let principal = [mean + radius, iyy, mean - radius];
    let total: f64 = principal.iter().sum();
    let largest = principal.iter().copied().fold(f64::MIN, f64::max);
    let accepted = accepted
        .as_ref()
        .is_some_and(|reason| !reason.trim().is_empty());
    if largest > 0.5 * total * (1.0 + 1e-9) && !accepted {
        // The largest diagonal moment names the field (with a product of
        // inertia, the principal moments are near the diagonal ones).
        let field = if izz >= ixx && izz >= iyy {
            "mass.izz"
        } else if iyy >= ixx {
            "mass.iyy"
        } else {
            "mass.ixx"
        };
        problems.push(
            field,
            format!(
                "no rigid body has these moments of inertia: the principal moments {:.6e}, {:.6e}, {:.6e} kg·m² \
                 violate the triangle inequality (each must be at most the sum of the other two; \
                 Ixx = {ixx}, Iyy = {iyy}, Izz = {izz}, Ixz = {ixz}); \
                 to fly published values as they are, give the reason in mass.impossible_inertia",
                principal[0], principal[1], principal[2]
            ),
        );
    }
    inertia
}
