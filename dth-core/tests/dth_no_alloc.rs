//! A DTH step allocates nothing on the heap (both solvers), checked with the counting global
//! allocator of `alloc_counter` (this test binary only, the test's own thread only).

mod alloc_counter;

use dth_core::dth::{Dth, DthOptions, Solver};
use dth_core::nalgebra::Vector4;
use dth_core::systems::Kepler;

#[test]
fn steps_do_not_allocate() {
    for solver in [Solver::Joint, Solver::Nested] {
        let options = DthOptions::thesis_kepler().with_solver(solver);
        let mut dth =
            Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options).expect("start");
        let (ok, allocations) = alloc_counter::count(|| dth.run(1_000, &mut ()).is_ok());
        assert!(ok);
        assert_eq!(
            allocations, 0,
            "{solver:?}: heap allocations during 1,000 steps"
        );
        // Control: storing a trajectory does allocate, so the counter is live.
        let (stored, allocations) = alloc_counter::count(|| dth.trajectory(10).is_ok());
        assert!(stored && allocations > 0);
    }
}
