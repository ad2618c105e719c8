//! The RK4 step of the 6-DOF allocates nothing on the heap: fixed-size
//! nalgebra types throughout. A counting global allocator proves it.

use aeroid::sim::Simulation;
use aeroid::sim::scenario::Scenario;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct CountingAllocator;

thread_local! {
    /// Allocations made by this thread (the test harness's own threads are not counted).
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|count| count.set(count.get() + 1));
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
    let before = ALLOCATIONS.with(Cell::get);
    for k in 0..100 {
        x = simulation.advance(&x, k);
    }
    let after = ALLOCATIONS.with(Cell::get);
    let probe = Box::new(std::hint::black_box(7u64));
    drop(probe);
    assert_eq!(
        ALLOCATIONS.with(Cell::get),
        after + 1,
        "the counter sees this thread's allocations"
    );
    assert!(x.iter().all(|v| v.is_finite()));
    assert_eq!(after - before, 0, "heap allocations inside 100 RK4 steps");
}
