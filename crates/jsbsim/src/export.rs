//! `aeroid export-jsbsim`: writes an aeroid aircraft as a JSBSim aircraft
//! (`DIR/NAME/NAME.xml`) with the same mass, inertia, geometry, thrust and
//! linear aerodynamics, the aerodynamics as JSBSim `<function>`s.
//!
//! Conventions of the exported file (each one a difference between the two
//! simulators that the export bridges; docs/jsbsim.md lists them):
//! - Units: the file is in JSBSim's own units (ft, ft², lbs, slug·ft²),
//!   converted with exact factors: JSBSim's unit table converts kg·m² to
//!   slug·ft² with 1/1.35594 (exactly 1/1.3558179), 9e-5 off. Functions give
//!   forces in lbf and moments in lbf·ft, from `aero/qbar-psf`,
//!   `metrics/Sw-sqft`, `metrics/bw-ft` and `metrics/cbarw-ft`.
//! - Frames: JSBSim locations are in the structural frame (x aft, y right,
//!   z up) with the centre of gravity, the aerodynamic reference point and the
//!   eye point all at the origin, so aeroid's moments about the centre of
//!   gravity are JSBSim's moments about AERORP. The thrust point (body axes,
//!   relative to the CG) becomes (−x, y, −z).
//! - Inertia: `negated_crossproduct_inertia="false"` so that `ixz` is aeroid's
//!   Ixz = ∫xz dm (JSBSim's default expects −Ixz).
//! - Forces: aeroid's wind-axis CL and CD are in stability axes (rotated by α
//!   only) while JSBSim's LIFT/DRAG/SIDE axes also rotate by β; the export
//!   therefore writes body-axis X, Y, Z functions,
//!   CX = −CD·cos α + CL·sin α, CZ = −CD·sin α − CL·cos α.
//! - Controls: aeroid's deflections, in aeroid's sign convention, are read
//!   from `fcs/elevator-pos-rad`, `fcs/left-aileron-pos-rad`,
//!   `fcs/rudder-pos-rad` and `fcs/flap-pos-rad`; the throttle fraction from
//!   `aeroid/throttle`. The file has no flight-control system.
//! - Thrust: an external force T = δT·Tmax·(ρ/ρ0)^n along the thrust line
//!   (inclination positive nose-up), ρ0 aeroid's sea-level density.
//! - Earth: aeroid flies over a flat, non-rotating earth with constant
//!   gravity; the export declares a spherical, non-rotating planet of radius
//!   [`FLAT_EARTH_RADIUS`] with GM = g·R², which leaves a curvature drop of
//!   d²/2R (2 cm after 6 km) and a gravity change of 2h/R (1e-5 at 5 km).
//! - Atmosphere: JSBSim's standard atmosphere uses geopotential altitude;
//!   aeroid takes geometric altitude for geopotential. With
//!   [`ExportOptions::aeroid_atmosphere`] the file overrides JSBSim's
//!   temperature, pressure and density with aeroid's ISA (and its
//!   temperature offset) as functions of `position/h-sl-meters`.

use super::{FT, LBF, SLUG};

/// The avoirdupois pound (kg): JSBSim's weight unit, exact in its unit table.
const POUND: f64 = 0.453_592_37;
use crate::error::{Error, Result};
use aeroid_sim::aero::{ForceAxes, ModelKind, RateNormalization, RateSpeed};
use aeroid_sim::aircraft::Aircraft;
use aeroid_sim::atmosphere::{
    GAS_CONSTANT, SEA_LEVEL_DENSITY, SEA_LEVEL_PRESSURE, SEA_LEVEL_TEMPERATURE,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Radius (m) of the spherical stand-in for aeroid's flat earth.
pub const FLAT_EARTH_RADIUS: f64 = 1.0e9;

/// Property of the throttle fraction in an exported aircraft.
pub const THROTTLE_PROPERTY: &str = "aeroid/throttle";

/// The JSBSim properties that carry aeroid's controls in an exported aircraft,
/// in the order of [`aeroid_sim::state::Control::ALL`].
pub const CONTROL_PROPERTIES: [&str; aeroid_sim::state::CONTROL_COUNT] = [
    "fcs/elevator-pos-rad",
    "fcs/left-aileron-pos-rad",
    "fcs/rudder-pos-rad",
    "fcs/flap-pos-rad",
    THROTTLE_PROPERTY,
];

/// What the exported file carries besides the aircraft.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExportOptions {
    /// Gravitational acceleration (m/s²) of the flat-earth planet.
    pub gravity: f64,
    /// Override JSBSim's atmosphere with aeroid's ISA.
    pub aeroid_atmosphere: bool,
    /// aeroid's ISA temperature offset (K), used with `aeroid_atmosphere`.
    pub temperature_offset: f64,
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            gravity: aeroid_core::units::STANDARD_GRAVITY,
            aeroid_atmosphere: true,
            temperature_offset: 0.0,
        }
    }
}

/// A model name JSBSim can load: lower-case letters, digits, `-` and `_`.
pub fn model_name(aircraft: &Aircraft) -> String {
    let name: String = aircraft
        .name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect();
    if name.is_empty() {
        "aircraft".into()
    } else {
        name
    }
}

/// Writes `dir/MODEL/MODEL.xml` and returns its path.
pub fn export(aircraft: &Aircraft, options: &ExportOptions, dir: &Path) -> Result<PathBuf> {
    let xml = aircraft_xml(aircraft, options)?;
    let model = model_name(aircraft);
    let folder = dir.join(&model);
    std::fs::create_dir_all(&folder).map_err(|e| aeroid_core::error::write_error(&folder, e))?;
    let file = folder.join(format!("{model}.xml"));
    aeroid_core::atomic::write_text(&file, &xml)?;
    Ok(file)
}

fn unsupported(aircraft: &Aircraft, message: impl Into<String>) -> Error {
    Error::Jsbsim {
        context: format!("exporting aircraft '{}'", aircraft.name),
        message: message.into(),
    }
}

/// The JSBSim aircraft file of an aeroid aircraft.
pub fn aircraft_xml(aircraft: &Aircraft, options: &ExportOptions) -> Result<String> {
    let aero = &aircraft.aero;
    if aero.kind != ModelKind::Linear {
        return Err(unsupported(
            aircraft,
            "only linear aerodynamic models can be exported (the stall model's separation state has no JSBSim counterpart)",
        ));
    }
    if !(options.gravity.is_finite() && options.gravity > 0.0) {
        return Err(unsupported(
            aircraft,
            format!("gravity must be positive, got {}", options.gravity),
        ));
    }
    let mass = &aircraft.mass;
    let inertia = &mass.inertia;
    let propulsion = &aircraft.propulsion;
    let mut x = String::new();
    let w = &mut x;
    // Writing into a String cannot fail.
    let _ = writeln!(w, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        w,
        "<!-- Written by aeroid export-jsbsim from aircraft '{}'. Forces and moments are aeroid's linear model;\n     \
         controls are aeroid's deflections (rad, aeroid's signs) and {THROTTLE_PROPERTY} the thrust fraction. -->",
        escape(&aircraft.name)
    );
    let _ = writeln!(
        w,
        "<fdm_config name=\"{}\" version=\"2.0\" release=\"BETA\">",
        escape(&aircraft.name)
    );
    let _ = writeln!(
        w,
        "  <fileheader><author>aeroid export-jsbsim</author><description>{}</description></fileheader>",
        escape(&aircraft.name)
    );
    let _ = writeln!(w, "  <metrics>");
    let _ = writeln!(
        w,
        "    <wingarea unit=\"FT2\">{}</wingarea>",
        aircraft.wing_area / (FT * FT)
    );
    let _ = writeln!(
        w,
        "    <wingspan unit=\"FT\">{}</wingspan>",
        aircraft.geometry.span / FT
    );
    let _ = writeln!(
        w,
        "    <chord unit=\"FT\">{}</chord>",
        aircraft.geometry.chord / FT
    );
    for point in ["AERORP", "EYEPOINT", "VRP"] {
        let _ = writeln!(
            w,
            "    <location name=\"{point}\" unit=\"M\"><x>0</x><y>0</y><z>0</z></location>"
        );
    }
    let _ = writeln!(w, "  </metrics>");
    let _ = writeln!(w, "  <mass_balance negated_crossproduct_inertia=\"false\">");
    let slug_ft2 = SLUG * FT * FT;
    let _ = writeln!(
        w,
        "    <ixx unit=\"SLUG*FT2\">{}</ixx>",
        inertia[(0, 0)] / slug_ft2
    );
    let _ = writeln!(
        w,
        "    <iyy unit=\"SLUG*FT2\">{}</iyy>",
        inertia[(1, 1)] / slug_ft2
    );
    let _ = writeln!(
        w,
        "    <izz unit=\"SLUG*FT2\">{}</izz>",
        inertia[(2, 2)] / slug_ft2
    );
    let _ = writeln!(
        w,
        "    <ixz unit=\"SLUG*FT2\">{}</ixz>",
        -inertia[(0, 2)] / slug_ft2
    );
    let _ = writeln!(
        w,
        "    <emptywt unit=\"LBS\">{}</emptywt>",
        mass.mass / POUND
    );
    let _ = writeln!(
        w,
        "    <location name=\"CG\" unit=\"M\"><x>0</x><y>0</y><z>0</z></location>"
    );
    let _ = writeln!(w, "  </mass_balance>");
    // JSBSim requires the element; aeroid's aircraft never touch the ground.
    let _ = writeln!(w, "  <ground_reactions/>");
    write_planet(w, options.gravity);
    let _ = writeln!(w, "  <external_reactions>");
    let _ = writeln!(
        w,
        "    <property value=\"0\">{THROTTLE_PROPERTY}</property>"
    );
    let _ = writeln!(w, "    <force name=\"aeroid-thrust\" frame=\"BODY\">");
    let _ = writeln!(
        w,
        "      <function><product><property>{THROTTLE_PROPERTY}</property><value>{}</value>\
         <pow><quotient><property>atmosphere/rho-slugs_ft3</property><value>{}</value></quotient><value>{}</value></pow></product></function>",
        propulsion.max_thrust / LBF,
        SEA_LEVEL_DENSITY * FT.powi(3) / SLUG,
        propulsion.density_exponent
    );
    let p = propulsion.position;
    let inch = FT / 12.0;
    let _ = writeln!(
        w,
        "      <location unit=\"IN\"><x>{}</x><y>{}</y><z>{}</z></location>",
        -p.x / inch,
        p.y / inch,
        -p.z / inch
    );
    let d = propulsion.direction;
    let _ = writeln!(
        w,
        "      <direction><x>{}</x><y>{}</y><z>{}</z></direction>",
        d.x, d.y, d.z
    );
    let _ = writeln!(w, "    </force>");
    let _ = writeln!(w, "  </external_reactions>");
    if options.aeroid_atmosphere {
        atmosphere(w, options.temperature_offset);
    }
    aerodynamics(w, aircraft)?;
    let _ = writeln!(w, "</fdm_config>");
    Ok(x)
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Writes aeroid's flat earth as a JSBSim `<planet>` element (see the module
/// documentation): also loaded on its own for JSBSim's own aircraft.
pub fn write_planet(w: &mut String, gravity: f64) {
    let radius_ft = FLAT_EARTH_RADIUS / FT;
    let _ = writeln!(w, "  <planet name=\"aeroid flat earth\">");
    let _ = writeln!(
        w,
        "    <equatorial_radius unit=\"FT\">{radius_ft}</equatorial_radius>"
    );
    let _ = writeln!(
        w,
        "    <polar_radius unit=\"FT\">{radius_ft}</polar_radius>"
    );
    let _ = writeln!(w, "    <rotation_rate unit=\"RAD/SEC\">0</rotation_rate>");
    let _ = writeln!(w, "    <GM>{}</GM>", gravity / FT * radius_ft * radius_ft);
    let _ = writeln!(w, "    <J2>0</J2>");
    let _ = writeln!(w, "  </planet>");
}

/// aeroid's ISA (troposphere and lower stratosphere) as JSBSim's atmosphere
/// override, in Rankine, psf and slug/ft³.
fn atmosphere(w: &mut String, temperature_offset: f64) {
    const LAPSE: f64 = 0.0065;
    const TROPOPAUSE: f64 = 11_000.0;
    let g = aeroid_core::units::STANDARD_GRAVITY;
    let exponent = g / (GAS_CONSTANT * LAPSE);
    let t11 = SEA_LEVEL_TEMPERATURE - LAPSE * TROPOPAUSE;
    let h = "<property>position/h-sl-meters</property>";
    // Standard temperature (K): T0 − L·min(h, 11 km).
    let standard = format!(
        "<difference><value>{SEA_LEVEL_TEMPERATURE}</value><product><value>{LAPSE}</value><min>{h}<value>{TROPOPAUSE}</value></min></product></difference>"
    );
    // p/p0 = (T/T0)^(g/RL) · exp(−g·max(h − 11 km, 0)/(R·T11)).
    let pressure_ratio = format!(
        "<product><pow><quotient>{standard}<value>{SEA_LEVEL_TEMPERATURE}</value></quotient><value>{exponent}</value></pow>\
         <exp><product><value>{}</value><max><difference>{h}<value>{TROPOPAUSE}</value></difference><value>0</value></max></product></exp></product>",
        -g / (GAS_CONSTANT * t11)
    );
    let rankine = 1.8;
    let psf = SEA_LEVEL_PRESSURE * FT * FT / LBF;
    let slug_ft3 = FT.powi(3) / SLUG;
    let _ = writeln!(w, "  <system name=\"aeroid-atmosphere\">");
    let _ = writeln!(w, "    <channel name=\"isa\">");
    let _ = writeln!(
        w,
        "      <fcs_function name=\"atmosphere/override/temperature\"><function><product><value>{rankine}</value>\
         <sum>{standard}<value>{temperature_offset}</value></sum></product></function></fcs_function>"
    );
    let _ = writeln!(
        w,
        "      <fcs_function name=\"atmosphere/override/pressure\"><function><product><value>{psf}</value>{pressure_ratio}</product></function></fcs_function>"
    );
    let _ = writeln!(
        w,
        "      <fcs_function name=\"atmosphere/override/density\"><function><product><value>{}</value>{pressure_ratio}\
         <quotient><value>1</value><sum>{standard}<value>{temperature_offset}</value></sum></quotient></product></function></fcs_function>",
        SEA_LEVEL_PRESSURE / GAS_CONSTANT * slug_ft3
    );
    let _ = writeln!(w, "    </channel>");
    let _ = writeln!(w, "  </system>");
}

/// The JSBSim expression of one regressor of an aeroid model.
fn regressor(aircraft: &Aircraft, key: &str, coefficient_names: &[&str; 6]) -> Result<String> {
    let aero = &aircraft.aero;
    let geometry = &aircraft.geometry;
    let k = match aero.rate_normalization {
        RateNormalization::TwiceSpeed => 2.0,
        RateNormalization::Speed => 1.0,
    };
    // length/(kV): JSBSim's aero/bi2vel and aero/ci2vel are b/(2V) and c̄/(2V).
    let scale = |length: f64, half_over_v: &str| match aero.rate_speed {
        RateSpeed::Airspeed => format!(
            "<value>{}</value><property>{half_over_v}</property>",
            2.0 / k
        ),
        RateSpeed::Reference => {
            format!("<value>{}</value>", length / (k * aero.reference_airspeed))
        }
    };
    let span = scale(geometry.span, "aero/bi2vel");
    let chord = scale(geometry.chord, "aero/ci2vel");
    Ok(match key {
        "alpha" => "<property>aero/alpha-rad</property>".into(),
        "beta" => "<property>aero/beta-rad</property>".into(),
        "p" => format!("<property>velocities/p-aero-rad_sec</property>{span}"),
        "q" => format!("<property>velocities/q-aero-rad_sec</property>{chord}"),
        "r" => format!("<property>velocities/r-aero-rad_sec</property>{span}"),
        "alpha_dot" => format!("<property>aero/alphadot-rad_sec</property>{chord}"),
        "de" => format!("<property>{}</property>", CONTROL_PROPERTIES[0]),
        "da" => format!("<property>{}</property>", CONTROL_PROPERTIES[1]),
        "dr" => format!("<property>{}</property>", CONTROL_PROPERTIES[2]),
        "df" => format!("<property>{}</property>", CONTROL_PROPERTIES[3]),
        "dV" => format!(
            "<difference><quotient><property>velocities/vt-fps</property><value>{}</value></quotient><value>1</value></difference>",
            aero.reference_airspeed / FT
        ),
        "dMach" => format!(
            "<difference><property>velocities/mach</property><value>{}</value></difference>",
            aero.reference_mach
        ),
        "CL2" => {
            let cl = coefficient_property(coefficient_names[0]);
            format!("<property>{cl}</property><property>{cl}</property>")
        }
        other => {
            return Err(unsupported(
                aircraft,
                format!("term '{other}' has no JSBSim export"),
            ));
        }
    })
}

fn coefficient_property(name: &str) -> String {
    format!("aeroid/coefficient/{name}")
}

fn aerodynamics(w: &mut String, aircraft: &Aircraft) -> Result<()> {
    let aero = &aircraft.aero;
    let axes = aero.force_axes;
    // Lift-type first, so that drag can use CL².
    let names: [&str; 6] = aeroid_sim::aero::Coefficient::ALL.map(|c| c.name(axes));
    let mut sums: Vec<Vec<String>> = vec![Vec::new(); 6];
    for (parameter, value) in aero.parameters.iter() {
        if parameter == "e" {
            continue;
        }
        let Some((coefficient, key)) = parameter.split_once('_') else {
            return Err(unsupported(
                aircraft,
                format!("parameter '{parameter}' is not a coefficient term"),
            ));
        };
        let Some(index) = names.iter().position(|n| *n == coefficient) else {
            return Err(unsupported(
                aircraft,
                format!("parameter '{parameter}' names no coefficient"),
            ));
        };
        sums[index].push(if key == "0" {
            format!("<value>{value}</value>")
        } else {
            format!(
                "<product><value>{value}</value>{}</product>",
                regressor(aircraft, key, &names)?
            )
        });
    }
    if let Some(e) = aero.parameters.get("e") {
        let aspect_ratio = aircraft.geometry.aspect_ratio;
        let cl = coefficient_property(names[0]);
        sums[2].push(format!(
            "<product><value>{}</value><property>{cl}</property><property>{cl}</property></product>",
            1.0 / (e * std::f64::consts::PI * aspect_ratio)
        ));
    }
    let _ = writeln!(w, "  <aerodynamics>");
    for (name, terms) in names.iter().zip(&sums) {
        let _ = writeln!(
            w,
            "    <function name=\"{}\"><sum><value>0</value>{}</sum></function>",
            coefficient_property(name),
            terms.concat()
        );
    }
    let property = |i: usize| format!("<property>{}</property>", coefficient_property(names[i]));
    let qs = "<property>aero/qbar-psf</property><property>metrics/Sw-sqft</property>";
    let (cx, cz) = match axes {
        ForceAxes::Body => (property(2), property(0)),
        ForceAxes::Wind => {
            let (cl, cd) = (property(0), property(2));
            let (cos, sin) = (
                "<cos><property>aero/alpha-rad</property></cos>",
                "<sin><property>aero/alpha-rad</property></sin>",
            );
            (
                format!(
                    "<sum><product><value>-1</value>{cd}{cos}</product><product>{cl}{sin}</product></sum>"
                ),
                format!(
                    "<sum><product><value>-1</value>{cd}{sin}</product><product><value>-1</value>{cl}{cos}</product></sum>"
                ),
            )
        }
    };
    let axis = |w: &mut String, axis: &str, body: String| {
        let _ = writeln!(
            w,
            "    <axis name=\"{axis}\"><function name=\"aeroid/force-moment/{axis}\"><product>{body}</product></function></axis>"
        );
    };
    axis(w, "X", format!("{qs}{cx}"));
    axis(w, "Y", format!("{qs}{}", property(1)));
    axis(w, "Z", format!("{qs}{cz}"));
    axis(
        w,
        "ROLL",
        format!("{qs}<property>metrics/bw-ft</property>{}", property(3)),
    );
    axis(
        w,
        "PITCH",
        format!("{qs}<property>metrics/cbarw-ft</property>{}", property(4)),
    );
    axis(
        w,
        "YAW",
        format!("{qs}<property>metrics/bw-ft</property>{}", property(5)),
    );
    let _ = writeln!(w, "  </aerodynamics>");
    Ok(())
}
