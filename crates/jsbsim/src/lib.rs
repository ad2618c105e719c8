//! JSBSim 1.3.3 through FFI (cargo feature `jsbsim`): a safe wrapper over the
//! `extern "C"` shim of the `jsbsim-sys` crate.
//!
//! One [`Exec`] is one `JSBSim::FGFDMExec`. The traps of driving JSBSim from a
//! library are handled here, each with a test in `tests/jsbsim.rs`:
//! - a C++ exception never crosses the boundary: the shim catches it and every
//!   method returns [`Error::Jsbsim`] with JSBSim's own log messages;
//! - aircraft files may open input/output sockets and write CSV files; by
//!   default input and output are disabled before loading and the output
//!   instances are detached, so loading is side-effect free;
//! - the initial-condition order matters (JSBSim keeps the speed type that was
//!   set last and re-derives it when the altitude changes; α set after the
//!   attitude turns the attitude): [`Exec::set_initial_conditions`] sets
//!   position, then speed, then attitude;
//! - an unknown property reads 0.0 in JSBSim; here reading, writing or caching
//!   an unknown property is an error naming it;
//! - JSBSim's static unit table is filled by the first XML element ever built,
//!   unguarded: the shim warms it once per process (`std::call_once`) before
//!   any executive exists, so threads may load models at once;
//! - an `FGFDMExec` is not thread-safe: [`Exec`] is neither `Send` nor `Sync`,
//!   so each thread builds its own.

pub mod crosscheck;
pub mod derivatives;
pub mod error;
pub mod export;
pub mod flight;
pub mod own;

/// JSBSim as the simulator of the scenarios that name its own aircraft.
struct Jsbsim;

impl aeroid_sim::source::ForeignSimulator for Jsbsim {
    fn fly(
        &self,
        scenario: &aeroid_sim::scenario::Scenario,
    ) -> aeroid_sim::Result<aeroid_sim::Flight> {
        own::fly(scenario).map_err(Error::into_sim)
    }
}

impl aeroid_sim::foreign::AircraftCatalog for Jsbsim {
    fn check_model(&self, model: &str) -> std::result::Result<(), aeroid_sim::error::Error> {
        own::check_model(model).map_err(|error| aeroid_sim::error::Error::Foreign(Box::new(error)))
    }
}

/// Registers JSBSim as the simulator of `"jsbsim:NAME"` scenarios
/// ([`aeroid_sim::source::register_jsbsim`]); call it once before loading
/// or flying one.
pub fn register() {
    aeroid_sim::source::register_jsbsim(&Jsbsim);
}

pub use error::{Error, Result};
use jsbsim_sys as sys;
use std::ffi::{CStr, CString, c_int, c_void};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;
use std::sync::atomic::{AtomicU64, Ordering};

/// Feet per metre's inverse: JSBSim works in feet, aeroid in metres.
pub const FT: f64 = 0.3048;
/// Pounds (force) in newtons.
pub const LBF: f64 = 4.448_221_615_260_5;
/// Slugs in kilograms.
pub const SLUG: f64 = 14.593_902_937_206_4;

/// The JSBSim version compiled in.
pub const VERSION: &str = sys::VERSION;

/// JSBSim's root directory (with `aircraft/`, `engine/`, `systems/`): the
/// environment variable `JSBSIM_ROOT` when set, else the source distribution
/// the crate was built from.
pub fn default_root() -> PathBuf {
    std::env::var_os("JSBSIM_ROOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(sys::SOURCE_ROOT_DIR))
}

fn last_error() -> String {
    // SAFETY: the shim returns a pointer to a thread-local std::string that
    // stays valid until the next shim call on this thread; it is copied at once.
    unsafe { CStr::from_ptr(sys::aeroid_jsb_last_error()) }
        .to_string_lossy()
        .into_owned()
}

fn check(status: c_int, context: impl FnOnce() -> String) -> Result<()> {
    if status == 0 {
        Ok(())
    } else {
        Err(Error::Jsbsim {
            context: context(),
            message: last_error(),
        })
    }
}

fn c_string(text: &str, what: &str) -> Result<CString> {
    CString::new(text).map_err(|_| Error::Jsbsim {
        context: format!("{what} '{}'", text.escape_debug()),
        message: "contains a NUL byte".into(),
    })
}

fn c_path(path: &Path, what: &str) -> Result<CString> {
    let text = path.to_str().ok_or_else(|| Error::Jsbsim {
        context: format!("{what} {}", path.display()),
        message: "the path is not valid UTF-8".into(),
    })?;
    c_string(text, what)
}

/// `FGFDMExec::DoTrim` modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrimMode {
    /// w-dot with α, u-dot with thrust, q-dot with elevator.
    Longitudinal = 0,
    /// Longitudinal plus v-dot with φ, p-dot with aileron, r-dot with rudder.
    Full = 1,
    /// On the ground.
    Ground = 2,
}

/// How the initial speed is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InitialSpeed {
    /// Body-axis velocity relative to the air mass (m/s).
    Body([f64; 3]),
    /// True airspeed (m/s) with angle of attack and sideslip (rad).
    TrueAirspeed { speed: f64, alpha: f64, beta: f64 },
    /// Calibrated airspeed (m/s) with angle of attack and sideslip (rad).
    CalibratedAirspeed { speed: f64, alpha: f64, beta: f64 },
}

/// Initial conditions in SI units and radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialConditions {
    /// Geodetic latitude and longitude (rad).
    pub latitude: f64,
    pub longitude: f64,
    /// Altitude above sea level (m).
    pub altitude: f64,
    /// Euler angles φ, θ, ψ (rad).
    pub attitude: [f64; 3],
    pub speed: InitialSpeed,
    /// Body rates p, q, r (rad/s).
    pub rates: [f64; 3],
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// A cached handle to one property of one [`Exec`]: reading or writing through
/// it skips the name lookup. It is only valid with the executive that made it,
/// which is checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Property {
    node: NonNull<c_void>,
    exec: u64,
}

/// One JSBSim flight-dynamics executive. Not `Send`: one per thread.
#[derive(Debug)]
pub struct Exec {
    raw: NonNull<sys::AeroidJsb>,
    id: u64,
    root: PathBuf,
    model: Option<String>,
    // A raw pointer already makes the type !Send and !Sync; this states it.
    _one_per_thread: PhantomData<*mut ()>,
}

impl Drop for Exec {
    fn drop(&mut self) {
        // SAFETY: `raw` came from aeroid_jsb_new and is deleted exactly once.
        unsafe { sys::aeroid_jsb_delete(self.raw.as_ptr()) }
    }
}

impl Exec {
    /// An executive rooted at [`default_root`].
    pub fn new() -> Result<Exec> {
        Exec::with_root(&default_root())
    }

    /// An executive whose `aircraft`, `engine` and `systems` folders are under `root`.
    pub fn with_root(root: &Path) -> Result<Exec> {
        if !root.is_dir() {
            return Err(Error::Jsbsim {
                context: format!("root directory {}", root.display()),
                message: "not a directory".into(),
            });
        }
        let root_c = c_path(root, "root directory")?;
        let mut raw = std::ptr::null_mut();
        // SAFETY: valid C string and out-pointer.
        let status = unsafe { sys::aeroid_jsb_new(root_c.as_ptr(), &mut raw) };
        check(status, || {
            format!("creating an FGFDMExec rooted at {}", root.display())
        })?;
        let raw = NonNull::new(raw).ok_or_else(|| Error::Jsbsim {
            context: "creating an FGFDMExec".into(),
            message: "the shim returned no executive".into(),
        })?;
        Ok(Exec {
            raw,
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            root: root.to_path_buf(),
            model: None,
            _one_per_thread: PhantomData,
        })
    }

    fn context(&self, what: impl std::fmt::Display) -> String {
        match &self.model {
            Some(model) => format!("{model}: {what}"),
            None => what.to_string(),
        }
    }

    /// The root directory (with `aircraft/`, `engine/`, `systems/`).
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Loads `model` from the root's `aircraft/MODEL/MODEL.xml`, with input
    /// and output disabled.
    pub fn load_model(&mut self, model: &str) -> Result<()> {
        let aircraft = self.root.join("aircraft");
        self.load_model_in(&aircraft, model, false)
    }

    /// Loads `aircraft_dir/MODEL/MODEL.xml` with the root's engine and
    /// systems folders (see [`Exec::load_model_from`] for `allow_io`).
    pub fn load_model_in(
        &mut self,
        aircraft_dir: &Path,
        model: &str,
        allow_io: bool,
    ) -> Result<()> {
        let (engine, systems) = (self.root.join("engine"), self.root.join("systems"));
        self.load_model_from(aircraft_dir, &engine, &systems, model, allow_io)
    }

    /// Loads `aircraft_dir/MODEL/MODEL.xml` with the given engine and systems
    /// folders. `allow_io = false` disables input sockets and detaches the
    /// output instances (CSV files, sockets) the file declares.
    pub fn load_model_from(
        &mut self,
        aircraft_dir: &Path,
        engine_dir: &Path,
        systems_dir: &Path,
        model: &str,
        allow_io: bool,
    ) -> Result<()> {
        let file = aircraft_dir.join(model).join(format!("{model}.xml"));
        if !file.is_file() {
            return Err(Error::Jsbsim {
                context: format!("aircraft '{model}'"),
                message: format!("no file {}", file.display()),
            });
        }
        let aircraft = c_path(aircraft_dir, "aircraft folder")?;
        let engine = c_path(engine_dir, "engine folder")?;
        let systems = c_path(systems_dir, "systems folder")?;
        let name = c_string(model, "aircraft")?;
        // SAFETY: valid handle and C strings.
        let status = unsafe {
            sys::aeroid_jsb_load_model(
                self.raw.as_ptr(),
                aircraft.as_ptr(),
                engine.as_ptr(),
                systems.as_ptr(),
                name.as_ptr(),
                c_int::from(allow_io),
            )
        };
        check(status, || format!("loading aircraft {}", file.display()))?;
        self.model = Some(model.to_owned());
        Ok(())
    }

    /// Replaces the loaded model's planet (radius, rotation, gravity) with the
    /// `<planet>` document in `file` (`FGFDMExec::LoadPlanet`, which
    /// re-initialises the models): call it after loading, before the initial
    /// conditions.
    pub fn load_planet(&mut self, file: &Path) -> Result<()> {
        let file_c = c_path(file, "planet file")?;
        // SAFETY: valid handle and C string.
        let status = unsafe { sys::aeroid_jsb_load_planet(self.raw.as_ptr(), file_c.as_ptr()) };
        check(status, || {
            self.context(format_args!("loading the planet {}", file.display()))
        })
    }

    /// Whether a property of this name exists.
    pub fn has_property(&self, name: &str) -> Result<bool> {
        let name_c = c_string(name, "property")?;
        let mut out = 0;
        // SAFETY: valid handle, C string and out-pointer.
        let status =
            unsafe { sys::aeroid_jsb_has_property(self.raw.as_ptr(), name_c.as_ptr(), &mut out) };
        check(status, || self.context(format_args!("property '{name}'")))?;
        Ok(out != 0)
    }

    /// A cached handle to an existing property; an unknown name is an error.
    pub fn property(&self, name: &str) -> Result<Property> {
        let name_c = c_string(name, "property")?;
        let mut node = std::ptr::null_mut();
        // SAFETY: valid handle, C string and out-pointer.
        let status =
            unsafe { sys::aeroid_jsb_property_node(self.raw.as_ptr(), name_c.as_ptr(), &mut node) };
        check(status, || self.context(format_args!("property '{name}'")))?;
        let node = NonNull::new(node).ok_or_else(|| Error::Jsbsim {
            context: self.context(format_args!("property '{name}'")),
            message: "no node".into(),
        })?;
        Ok(Property {
            node,
            exec: self.id,
        })
    }

    fn own(&self, property: Property) -> Result<NonNull<c_void>> {
        if property.exec == self.id {
            Ok(property.node)
        } else {
            Err(Error::Jsbsim {
                context: self.context("property handle"),
                message: "the handle belongs to another executive".into(),
            })
        }
    }

    /// Reads a property through its cached handle.
    pub fn get_cached(&self, property: Property) -> Result<f64> {
        let node = self.own(property)?;
        let mut value = 0.0;
        // SAFETY: the node belongs to this live executive's property tree.
        let status = unsafe { sys::aeroid_jsb_node_get(node.as_ptr(), &mut value) };
        check(status, || self.context("reading a cached property"))?;
        Ok(value)
    }

    /// Writes a property through its cached handle.
    pub fn set_cached(&mut self, property: Property, value: f64) -> Result<()> {
        let node = self.own(property)?;
        // SAFETY: the node belongs to this live executive's property tree.
        let status = unsafe { sys::aeroid_jsb_node_set(node.as_ptr(), value) };
        check(status, || self.context("writing a cached property"))
    }

    /// Reads a property by name; an unknown name is an error (JSBSim itself
    /// would read 0.0).
    pub fn get(&self, name: &str) -> Result<f64> {
        let name_c = c_string(name, "property")?;
        let mut value = 0.0;
        // SAFETY: valid handle, C string and out-pointer.
        let status =
            unsafe { sys::aeroid_jsb_get_property(self.raw.as_ptr(), name_c.as_ptr(), &mut value) };
        check(status, || self.context(format_args!("reading '{name}'")))?;
        Ok(value)
    }

    /// Writes a property by name; an unknown name is an error (JSBSim itself
    /// would create it, and nothing would read it).
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        let name_c = c_string(name, "property")?;
        // SAFETY: valid handle and C string.
        let status =
            unsafe { sys::aeroid_jsb_set_property(self.raw.as_ptr(), name_c.as_ptr(), value) };
        check(status, || {
            self.context(format_args!("writing '{name}' = {value}"))
        })
    }

    /// Sets the initial conditions in the order JSBSim needs: position
    /// (latitude, longitude, altitude), then speed, then attitude, then rates.
    /// Setting the speed before the altitude would have JSBSim re-derive it
    /// at the new altitude from the speed type set last. Setting α or β keeps
    /// the flight-path direction JSBSim holds (from whatever was set before)
    /// and turns the attitude, while setting an Euler angle keeps the
    /// body-axis velocity: so the attitude comes after the speed, and the
    /// state set is the one asked for whatever the previous one was.
    pub fn set_initial_conditions(&mut self, ic: &InitialConditions) -> Result<()> {
        self.set("ic/lat-geod-rad", ic.latitude)?;
        self.set("ic/long-gc-rad", ic.longitude)?;
        self.set("ic/h-sl-ft", ic.altitude / FT)?;
        match ic.speed {
            InitialSpeed::Body([u, v, w]) => {
                self.set("ic/u-fps", u / FT)?;
                self.set("ic/v-fps", v / FT)?;
                self.set("ic/w-fps", w / FT)?;
            }
            InitialSpeed::TrueAirspeed { speed, alpha, beta } => {
                self.set("ic/alpha-rad", alpha)?;
                self.set("ic/beta-rad", beta)?;
                self.set("ic/vt-fps", speed / FT)?;
            }
            InitialSpeed::CalibratedAirspeed { speed, alpha, beta } => {
                self.set("ic/alpha-rad", alpha)?;
                self.set("ic/beta-rad", beta)?;
                self.set("ic/vc-kts", speed / (1852.0 / 3600.0))?;
            }
        }
        self.set("ic/phi-rad", ic.attitude[0])?;
        self.set("ic/theta-rad", ic.attitude[1])?;
        self.set("ic/psi-true-rad", ic.attitude[2])?;
        self.set("ic/p-rad_sec", ic.rates[0])?;
        self.set("ic/q-rad_sec", ic.rates[1])?;
        self.set("ic/r-rad_sec", ic.rates[2])
    }

    /// Applies the initial conditions (`FGFDMExec::RunIC`).
    pub fn run_ic(&mut self) -> Result<()> {
        // SAFETY: valid handle.
        let status = unsafe { sys::aeroid_jsb_run_ic(self.raw.as_ptr()) };
        check(status, || self.context("RunIC"))
    }

    /// One time step (`FGFDMExec::Run`).
    pub fn step(&mut self) -> Result<()> {
        // SAFETY: valid handle.
        let status = unsafe { sys::aeroid_jsb_run(self.raw.as_ptr()) };
        check(status, || self.context("Run"))
    }

    /// Sets the integration time step (s).
    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::Jsbsim {
                context: self.context("time step"),
                message: format!("dt must be positive and finite, got {dt}"),
            });
        }
        // SAFETY: valid handle.
        let status = unsafe { sys::aeroid_jsb_set_dt(self.raw.as_ptr(), dt) };
        check(status, || self.context("Setdt"))
    }

    /// The integration time step (s).
    pub fn dt(&self) -> Result<f64> {
        let mut dt = 0.0;
        // SAFETY: valid handle and out-pointer.
        let status = unsafe { sys::aeroid_jsb_get_dt(self.raw.as_ptr(), &mut dt) };
        check(status, || self.context("GetDeltaT"))?;
        Ok(dt)
    }

    /// Simulation time (s).
    pub fn time(&self) -> Result<f64> {
        let mut t = 0.0;
        // SAFETY: valid handle and out-pointer.
        let status = unsafe { sys::aeroid_jsb_sim_time(self.raw.as_ptr(), &mut t) };
        check(status, || self.context("GetSimTime"))?;
        Ok(t)
    }

    /// Trims with JSBSim's own trim routine; a failed trim is an error.
    pub fn trim(&mut self, mode: TrimMode) -> Result<()> {
        // SAFETY: valid handle.
        let status = unsafe { sys::aeroid_jsb_trim(self.raw.as_ptr(), mode as c_int) };
        check(status, || self.context(format_args!("trim ({mode:?})")))
    }
}
