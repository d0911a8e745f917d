//! The cancellation-free residual and the robust mode's fallback steps allocate nothing on the
//! heap (counting global allocator, this test binary only; only the test thread counts).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use dth_core::dth::{Dth, DthOptions};
use dth_core::nalgebra::Vector4;
use dth_core::observer::StepRecord;
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
fn robust_mode_and_cancellation_free_steps_do_not_allocate() {
    // Kepler e = 0.9: DTH steps (cancellation-free residual), breakdowns, fallback steps and
    // resumptions all happen within 3,000 steps.
    let options = DthOptions::default()
        .with_dtau(0.0157)
        .expect("valid")
        .with_robust(true);
    let mut dth = Dth::new(
        Kepler::thesis(),
        Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt()),
        options,
    )
    .expect("start");
    assert!(dth.cancellation_free());
    let mut kinds = [0usize; 2];
    let mut count =
        |r: &StepRecord<4>| kinds[usize::from(r.kind != dth_core::observer::StepKind::Dth)] += 1;
    COUNTING.with(|c| c.set(true));
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let ok = dth.run(3_000, &mut count).is_ok();
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    COUNTING.with(|c| c.set(false));
    assert!(ok);
    assert!(
        kinds[0] > 0 && kinds[1] > 0,
        "both kinds of step ran: {kinds:?}"
    );
    assert_eq!(
        after - before,
        0,
        "heap allocations during 3,000 robust steps"
    );
    // Control: the counter is live.
    COUNTING.with(|c| c.set(true));
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let stored = dth.trajectory(10).is_ok();
    assert!(stored && ALLOCATIONS.load(Ordering::SeqCst) > before);
    COUNTING.with(|c| c.set(false));
    dth.run(1, &mut ()).expect("step");
}
