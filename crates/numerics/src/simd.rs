//! Wider vector instructions for the estimators' kernels, chosen at run
//! time.
//!
//! The default build targets generic x86-64 (SSE2), so that one binary
//! runs anywhere and the simulator keeps its tuning: built for this host's
//! CPU (`target-cpu=native`) the output-error fit was 1.13× faster but the
//! 6-DOF simulator 0.91× as fast. [`wide`] runs a closure compiled with
//! AVX2 enabled where the CPU has it: the dual-number evaluation's four
//! tangent lanes and the sensitivity products then take one 256-bit
//! instruction instead of two. Rust does not contract `a*b + c` into fused
//! multiply-adds on its own, so the numbers are bit for bit those of the
//! SSE2 code (`output_error`'s test `wide_kernels_match_the_baseline`
//! compares whole simulations with sensitivities both ways).

#[cfg(any(test, feature = "test-baseline"))]
thread_local! {
    static BASELINE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with every [`wide`] closure on this thread taking the
/// build's own instruction set, for tests that compare both.
#[cfg(any(test, feature = "test-baseline"))]
pub fn baseline<R>(f: impl FnOnce() -> R) -> R {
    BASELINE.set(true);
    let result = f();
    BASELINE.set(false);
    result
}

/// Whether [`wide`] takes its AVX2 version: the CPU has AVX2 (the
/// standard library checks once and caches the answer).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn avx2() -> bool {
    #[cfg(any(test, feature = "test-baseline"))]
    if BASELINE.get() {
        return false;
    }
    std::arch::is_x86_feature_detected!("avx2")
}

/// Runs `f` compiled for AVX2 when this CPU has it (`avx2`), else as
/// built. `f` must be an `#[inline(always)]` closure, and whatever it calls
/// that should be compiled the same way `#[inline(always)]` too: code that
/// is not inlined into the AVX2 copy keeps the build's instruction set.
#[inline(always)]
pub fn wide<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if avx2() {
        // SAFETY: the CPU has AVX2, checked just above.
        return unsafe { with_avx2(f) };
    }
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// `fixed_rows!(rows, kernel, fallback, (a, b))`: `kernel::<R>(a, b)` with
/// R = `rows` known at compile time for 1 to 12 rows (the small matrices of
/// the sensitivity equations: the compiler unrolls and vectorises loops
/// over R), `fallback(a, b)` for other counts.
#[doc(hidden)]
#[macro_export]
macro_rules! __fixed_rows {
    ($rows:expr, $kernel:ident, $fallback:expr, ($($arg:expr),* $(,)?)) => {
        match $rows {
            1 => $kernel::<1>($($arg),*),
            2 => $kernel::<2>($($arg),*),
            3 => $kernel::<3>($($arg),*),
            4 => $kernel::<4>($($arg),*),
            5 => $kernel::<5>($($arg),*),
            6 => $kernel::<6>($($arg),*),
            7 => $kernel::<7>($($arg),*),
            8 => $kernel::<8>($($arg),*),
            9 => $kernel::<9>($($arg),*),
            10 => $kernel::<10>($($arg),*),
            11 => $kernel::<11>($($arg),*),
            12 => $kernel::<12>($($arg),*),
            _ => $fallback($($arg),*),
        }
    };
}
pub use __fixed_rows as fixed_rows;
