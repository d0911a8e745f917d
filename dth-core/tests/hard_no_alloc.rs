//! The cancellation-free residual and the robust mode's fallback steps allocate nothing on the
//! heap (the counting global allocator of `alloc_counter`: this test binary only, the test's
//! own thread only).

use dth_core::nalgebra::Const;
mod alloc_counter;
mod hard_support;

use dth_core::dth::{Dth, DthOptions};
use dth_core::nalgebra::Vector4;
use dth_core::observer::{StepKind, StepRecord};
use dth_core::systems::Kepler;

#[test]
fn robust_mode_and_cancellation_free_steps_do_not_allocate() {
    // Kepler e = 0.9: DTH steps (cancellation-free residual), breakdowns, fallback steps and
    // resumptions all happen within 3,000 steps.
    let options = DthOptions::new(0.0157).expect("valid").with_robust(true);
    let mut dth = Dth::new(
        Kepler::thesis(),
        Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt()),
        options,
    )
    .expect("start");
    assert!(dth.cancellation_free());
    let mut kinds = [0usize; 2];
    let mut count = |r: &StepRecord<Const<4>>| kinds[usize::from(r.kind != StepKind::Dth)] += 1;
    let (ok, allocations) = alloc_counter::count(|| dth.run(3_000, &mut count).is_ok());
    assert!(ok);
    assert!(
        kinds[0] > 0 && kinds[1] > 0,
        "both kinds of step ran: {kinds:?}"
    );
    assert_eq!(allocations, 0, "heap allocations during 3,000 robust steps");
    // Control: the counter is live.
    let (stored, allocations) = alloc_counter::count(|| dth.trajectory(10).is_ok());
    assert!(stored && allocations > 0);
    dth.run(1, &mut ()).expect("step");
}

#[test]
fn fallback_steps_through_a_close_encounter_do_not_allocate() {
    // A close pair far from the origin (hard_support::pair): the fallback's residual check
    // meets residuals amplified by (dt/2) Hess H and takes its Newton correction, and the
    // projection moves the momenta.
    use hard_support::pair::Pair;
    let options = DthOptions::new(0.002)
        .expect("valid")
        .with_lambda0(1e-5)
        .expect("valid")
        .with_robust(true);
    let mut dth = Dth::new(Pair, Pair::at_pericentre(1e-3, 0.99), options).expect("start");
    let mut fallback = 0usize;
    let mut count =
        |r: &StepRecord<Const<8>>| fallback += usize::from(r.kind == StepKind::Fallback);
    let (ok, allocations) = alloc_counter::count(|| dth.run(400, &mut count).is_ok());
    assert!(ok);
    assert!(fallback > 0, "fallback steps ran");
    assert_eq!(allocations, 0, "heap allocations during 400 robust steps");
}
