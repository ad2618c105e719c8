//! Compiles JSBSim 1.3.3 (103 C++ files, 5 C files of expat and the MSIS
//! atmosphere) and aeroid's `extern "C"` shim with the `cc` crate.
//!
//! The source comes from PyPI's `jsbsim` source distribution, unpacked by
//! `scripts/fetch-jsbsim.sh` into `vendor/jsbsim-src/jsbsim-1.3.3`, or from the
//! folder named by the environment variable `JSBSIM_SRC_DIR`.

use std::path::{Path, PathBuf};

fn main() {
    println!("cargo:rerun-if-env-changed=JSBSIM_SRC_DIR");
    println!("cargo:rerun-if-changed=shim/shim.cpp");
    println!("cargo:rerun-if-changed=build.rs");

    let manifest = PathBuf::from(
        std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"),
    );
    let root = match std::env::var_os("JSBSIM_SRC_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => manifest.join("../../vendor/jsbsim-src/jsbsim-1.3.3"),
    };
    let src = root.join("src");
    if !src.join("FGFDMExec.cpp").is_file() {
        panic!(
            "JSBSim source not found at {}: run scripts/fetch-jsbsim.sh, or set JSBSIM_SRC_DIR \
             to an unpacked jsbsim-1.3.3 source distribution",
            root.display()
        );
    }
    let root = root
        .canonicalize()
        .expect("the JSBSim source folder exists");
    println!("cargo:rerun-if-changed={}", src.display());
    // The source distribution also carries JSBSim's aircraft, engine and
    // systems folders: the wrapper uses them as its default root directory.
    println!("cargo:rustc-env=JSBSIM_ROOT_DIR={}", root.display());

    let mut cpp_files = Vec::new();
    let mut c_files = Vec::new();
    collect(&src, &mut cpp_files, &mut c_files);
    cpp_files.sort();
    c_files.sort();

    // The shim, compiled for every build (one file).
    let out_dir = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    cxx_build(&src)
        .file(manifest.join("shim/shim.cpp"))
        .warnings(true)
        .extra_warnings(false)
        .cargo_metadata(false)
        .out_dir(&out_dir)
        .compile("aeroid_jsbsim_shim");

    // JSBSim itself takes minutes to compile: its two static libraries are
    // kept in target/jsbsim-cache/KEY, KEY a hash of the sources (paths,
    // sizes, modification times), the flags and the compiler, and shared by
    // every profile (the flags do not depend on it) and every rebuild of the
    // shim.
    let key = cache_key(&root, &cpp_files, &c_files);
    let cache = target_dir(&out_dir)
        .join("jsbsim-cache")
        .join(format!("{key:016x}"));
    if !cache.join("libjsbsim.a").is_file() || !cache.join("libjsbsim_c.a").is_file() {
        let staging = cache.with_extension(format!("tmp-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir_all(&staging).expect("the JSBSim cache folder can be created");
        let mut jsbsim = cxx_build(&src);
        jsbsim
            .files(&cpp_files)
            .flag("-w")
            .cargo_metadata(false)
            .out_dir(&staging);
        jsbsim.compile("jsbsim");
        c_build(&src)
            .files(&c_files)
            .cargo_metadata(false)
            .out_dir(&staging)
            .compile("jsbsim_c");
        // Another build may have finished the same key meanwhile: either copy will do.
        if std::fs::rename(&staging, &cache).is_err() {
            let _ = std::fs::remove_dir_all(&staging);
        }
    }

    // Static libraries link in the order named: the shim refers to JSBSim,
    // which refers to expat and MSIS (C) and to the C++ runtime.
    println!("cargo:rustc-link-search=native={}", out_dir.display());
    println!("cargo:rustc-link-search=native={}", cache.display());
    println!("cargo:rustc-link-lib=static=aeroid_jsbsim_shim");
    println!("cargo:rustc-link-lib=static=jsbsim");
    println!("cargo:rustc-link-lib=static=jsbsim_c");
    println!("cargo:rustc-link-lib=dylib=stdc++");
}

/// `target/` (or `target/TRIPLE/`): OUT_DIR is `<that>/<profile>/build/<package>/out`.
fn target_dir(out_dir: &Path) -> PathBuf {
    out_dir
        .ancestors()
        .nth(4)
        .map(Path::to_path_buf)
        .unwrap_or_else(|| out_dir.to_path_buf())
}

fn cache_key(root: &Path, cpp_files: &[PathBuf], c_files: &[PathBuf]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    root.hash(&mut hasher);
    for file in cpp_files.iter().chain(c_files) {
        file.hash(&mut hasher);
        if let Ok(metadata) = std::fs::metadata(file) {
            metadata.len().hash(&mut hasher);
            metadata.modified().ok().hash(&mut hasher);
        }
    }
    let src = root.join("src");
    for build in [cxx_build(&src), c_build(&src)] {
        let compiler = build.get_compiler();
        compiler.path().hash(&mut hasher);
        compiler.args().hash(&mut hasher);
    }
    for variable in ["CC", "CXX", "CFLAGS", "CXXFLAGS", "TARGET"] {
        println!("cargo:rerun-if-env-changed={variable}");
        std::env::var_os(variable).hash(&mut hasher);
    }
    hasher.finish()
}

fn c_build(src: &Path) -> cc::Build {
    let mut build = cc::Build::new();
    build
        .include(src)
        .include(src.join("simgear/xml"))
        .opt_level(2)
        .debug(false)
        .flag("-w");
    build
}

fn cxx_build(src: &Path) -> cc::Build {
    let mut build = cc::Build::new();
    build
        .cpp(true)
        .std("c++17")
        .include(src)
        .define("JSBSIM_VERSION", "\"1.3.3\"")
        .opt_level(2)
        .debug(false);
    build
}

/// Every C++ and C file of the library as JSBSim's CMake build lists it:
/// `.cpp` and `.cxx` sources except the two command-line programs and five
/// unused trim experiments, and the C sources except the files that expat
/// includes into others and the MSIS test program.
fn collect(dir: &Path, cpp: &mut Vec<PathBuf>, c: &mut Vec<PathBuf>) {
    const NOT_LIBRARY: [&str; 10] = [
        "JSBSim.cpp",
        "JSBSim.minimal.cpp",
        // In the source tree but not in JSBSim's CMake build.
        "FGNelderMead.cpp",
        "FGSimplexTrim.cpp",
        "FGTrimAnalysis.cpp",
        "FGTrimAnalysisControl.cpp",
        "FGTrimmer.cpp",
        "xmltok_impl.c",
        "xmltok_ns.c",
        "nrlmsise-00_test.c",
    ];
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .map(|entry| entry.expect("a readable directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_owned();
        if path.is_dir() {
            collect(&path, cpp, c);
        } else if NOT_LIBRARY.contains(&name.as_str()) {
            continue;
        } else if name.ends_with(".cpp") || name.ends_with(".cxx") {
            cpp.push(path);
        } else if name.ends_with(".c") {
            c.push(path);
        }
    }
}
