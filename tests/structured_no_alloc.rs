//! No heap allocation per step on the structured Newton path: after the first step (which
//! analyses the Hessian pattern and allocates the banded factorization once), every implicit
//! peer steps a generated 32-particle chain (`D = 64`, beyond the crossover) without
//! allocating (counted on this thread by the global allocator of `alloc_counter`); so does the
//! DTH stepper, which analyses the pattern once in `Dth::new`.

use dth::nalgebra::Const;
#[path = "../dth-core/tests/alloc_counter/mod.rs"]
mod alloc_counter;

use dth::dth::{Dth, DthOptions, Solver};
use dth::methods::{
    run, DiscreteGradient, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Trapezoidal,
};
use dth::nalgebra::SVector;
use dth::Hamiltonian;

include!("chains/fput_alpha_32.rs");

fn allocations_after_the_first_step<M: OneStepMethod<Const<64>, FputAlpha32>>(
    mut method: M,
) -> usize {
    let h = FputAlpha32;
    let z0 = SVector::<f64, 64>::from_fn(|i, _| if i < 32 { 0.1 * (i as f64).sin() } else { 0.2 });
    let z1 = method.step(&h, &z0, 0.05).expect("first step");
    let (ok, allocations) =
        alloc_counter::count(|| run(&mut method, &h, &z1, 0.0, 0.05, 200, &mut ()).is_ok());
    assert!(ok);
    allocations
}

#[test]
fn structured_peers_allocate_nothing_per_step() {
    assert!(FputAlpha32.flags().structured_newton);
    // Control: the counter sees allocations at all, and the first structured step allocates.
    let (v, control) = alloc_counter::count(|| std::hint::black_box(vec![1u8; 16]));
    assert_eq!(control, 1);
    drop(v);
    let (_, first) = alloc_counter::count(|| {
        ImplicitMidpoint::new().step(&FputAlpha32, &SVector::zeros(), 0.05)
    });
    assert!(first > 0, "the first structured step analyses the pattern");
    let counts = [
        (
            "midpoint",
            allocations_after_the_first_step(ImplicitMidpoint::new()),
        ),
        (
            "trapezoidal",
            allocations_after_the_first_step(Trapezoidal::new()),
        ),
        (
            "discrete_gradient",
            allocations_after_the_first_step(DiscreteGradient::new()),
        ),
        (
            "gauss_legendre2",
            allocations_after_the_first_step(GaussLegendre2::new()),
        ),
    ];
    for (name, n) in counts {
        assert_eq!(n, 0, "{name} allocated {n} times in 200 steps");
    }
}

#[test]
fn structured_dth_allocates_nothing_per_step() {
    let h = FputAlpha32;
    let z0 = SVector::<f64, 64>::from_fn(|i, _| if i < 32 { 0.1 * (i as f64).sin() } else { 0.2 });
    let base = DthOptions::new(0.05).expect("dtau");
    for (name, options) in [
        ("joint", base),
        ("nested", base.with_solver(Solver::Nested)),
        ("joint order 4", base.with_order(4).expect("order")),
    ] {
        // The analysis of the pattern happens once, when the stepper is made.
        let (dth, setup) = alloc_counter::count(|| Dth::new(h, z0, options));
        let mut dth = dth.expect("start");
        assert!(
            setup > 0,
            "{name}: the structured stepper analyses its pattern"
        );
        let (ok, allocations) = alloc_counter::count(|| dth.advance(200).is_ok());
        assert!(ok, "{name}: steps");
        assert_eq!(
            allocations, 0,
            "{name} allocated {allocations} times in 200 steps"
        );
    }
}
