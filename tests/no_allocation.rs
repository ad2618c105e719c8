//! The RK4 step of the 6-DOF allocates nothing on the heap: fixed-size
//! nalgebra types throughout. A counting global allocator proves it.

use aeroid::scenario::Scenario;
use aeroid::sim::Simulation;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct CountingAllocator;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn rk4_step_does_not_allocate() {
    let mut scenario = Scenario::load("attas-trim").unwrap();
    scenario.duration = 1.0;
    let simulation = Simulation::prepare(&scenario).unwrap();
    let mut x = simulation.trim.state;
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    for k in 0..100 {
        x = simulation.advance(&x, k);
    }
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    assert!(x.iter().all(|v| v.is_finite()));
    assert_eq!(after - before, 0, "heap allocations inside 100 RK4 steps");
}
