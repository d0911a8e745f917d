//! The MEGNO observer carries its tangent vector without touching the heap: an ensemble
//! integrates it at every step of every member, so a per-step allocation would dominate a
//! large ensemble's cost. Counted with the core's counting global allocator (this test binary
//! only, the test's own thread only).

#[path = "../../dth-core/tests/alloc_counter/mod.rs"]
mod alloc_counter;

use dth::dth::{Dth, DthOptions};
use dth::nalgebra::Vector4;
use dth::systems::HenonHeiles;
use dth_examples::ensemble::chaos::Megno;

#[test]
fn megno_steps_do_not_allocate() {
    let system = HenonHeiles;
    let z0 = Vector4::new(0.0, 0.1, 0.35, 0.1);
    let mut dth =
        Dth::new(system, z0, DthOptions::new(0.06277).expect("valid dtau")).expect("start");
    // Both tangent steps: the implicit midpoint (order 2) and Magnus with Pade (order 4).
    let mut megno = (Megno::new(&system), Megno::new(&system).with_order(4));
    // The first step seeds the observer; every later one solves a variational step.
    dth.run(2, &mut megno).expect("warm-up");
    let (ok, allocations) = alloc_counter::count(|| dth.run(500, &mut megno).is_ok());
    assert!(ok);
    assert_eq!(allocations, 0, "heap allocations during 500 observed steps");
    for m in [&megno.0, &megno.1] {
        let indicators = m.indicators().expect("indicators after 502 steps");
        assert!(indicators.megno.is_finite() && indicators.lyapunov.is_finite());
    }
    // Control: the counter is live on this thread.
    let (v, control) = alloc_counter::count(|| std::hint::black_box(vec![1u8; 16]));
    assert!(!v.is_empty() && control > 0);
}
