//! A DTH step allocates nothing on the heap (both solvers), checked with a counting global
//! allocator (this test binary only). Only allocations made by the test's own thread are
//! counted: the test harness allocates on its threads at times of its own choosing.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use dth_core::dth::{Dth, DthOptions, Solver};
use dth_core::nalgebra::Vector4;
use dth_core::systems::Kepler;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steps_do_not_allocate() {
    COUNTING.with(|c| c.set(true));
    for solver in [Solver::Joint, Solver::Nested] {
        let options = DthOptions::default().with_solver(solver);
        let mut dth =
            Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options).expect("start");
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        let ok = dth.run(1_000, &mut ()).is_ok();
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        assert!(ok);
        assert_eq!(
            after - before,
            0,
            "{solver:?}: heap allocations during 1,000 steps"
        );
        // Control: storing a trajectory does allocate, so the counter is live.
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        let stored = dth.trajectory(10).is_ok();
        assert!(stored && ALLOCATIONS.load(Ordering::SeqCst) > before);
    }
}
