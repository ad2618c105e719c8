//! Raw FFI to aeroid's `extern "C"` shim over JSBSim 1.3.3's `FGFDMExec`
//! (`shim/shim.cpp`). Every function returns 0 on success and 1 on failure,
//! with the message from [`aeroid_jsb_last_error`] on the same thread; no C++
//! exception crosses this boundary. The safe wrapper is `aeroid::jsbsim`.

use std::ffi::{c_char, c_int, c_void};

/// JSBSim's root directory in the source distribution the crate was built
/// from: it holds the `aircraft`, `engine` and `systems` folders.
pub const SOURCE_ROOT_DIR: &str = env!("JSBSIM_ROOT_DIR");

/// The JSBSim version compiled in.
pub const VERSION: &str = "1.3.3";

/// An opaque `FGFDMExec` with the output instances the shim detached.
#[repr(C)]
pub struct AeroidJsb {
    _private: [u8; 0],
}

unsafe extern "C" {
    /// The last error message of this thread (valid until the next call).
    pub fn aeroid_jsb_last_error() -> *const c_char;
    /// Fills JSBSim's static unit table and debug level once per process.
    pub fn aeroid_jsb_warm() -> c_int;
    pub fn aeroid_jsb_new(root_dir: *const c_char, out: *mut *mut AeroidJsb) -> c_int;
    pub fn aeroid_jsb_delete(handle: *mut AeroidJsb);
    /// `allow_io = 0` disables input sockets and output files and sockets.
    pub fn aeroid_jsb_load_model(
        handle: *mut AeroidJsb,
        aircraft_dir: *const c_char,
        engine_dir: *const c_char,
        systems_dir: *const c_char,
        model: *const c_char,
        allow_io: c_int,
    ) -> c_int;
    /// Replaces the loaded model's planet with a `<planet>` file.
    pub fn aeroid_jsb_load_planet(handle: *mut AeroidJsb, planet_file: *const c_char) -> c_int;
    pub fn aeroid_jsb_has_property(
        handle: *mut AeroidJsb,
        name: *const c_char,
        out: *mut c_int,
    ) -> c_int;
    /// A cached handle to an existing property node (owned by the executive).
    pub fn aeroid_jsb_property_node(
        handle: *mut AeroidJsb,
        name: *const c_char,
        out: *mut *mut c_void,
    ) -> c_int;
    pub fn aeroid_jsb_node_get(node: *mut c_void, out: *mut f64) -> c_int;
    pub fn aeroid_jsb_node_set(node: *mut c_void, value: f64) -> c_int;
    pub fn aeroid_jsb_get_property(
        handle: *mut AeroidJsb,
        name: *const c_char,
        out: *mut f64,
    ) -> c_int;
    pub fn aeroid_jsb_set_property(
        handle: *mut AeroidJsb,
        name: *const c_char,
        value: f64,
    ) -> c_int;
    pub fn aeroid_jsb_run_ic(handle: *mut AeroidJsb) -> c_int;
    pub fn aeroid_jsb_run(handle: *mut AeroidJsb) -> c_int;
    pub fn aeroid_jsb_set_dt(handle: *mut AeroidJsb, dt: f64) -> c_int;
    pub fn aeroid_jsb_get_dt(handle: *mut AeroidJsb, out: *mut f64) -> c_int;
    pub fn aeroid_jsb_sim_time(handle: *mut AeroidJsb, out: *mut f64) -> c_int;
    /// `FGFDMExec::DoTrim(mode)`: 0 longitudinal, 1 full, 2 ground.
    pub fn aeroid_jsb_trim(handle: *mut AeroidJsb, mode: c_int) -> c_int;
}
