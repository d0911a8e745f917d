//! No heap allocation per step: every peer, run through the driver with a no-op observer,
//! allocates nothing (counted on this thread by the global allocator of `alloc_counter`).

use dth_core::nalgebra::Const;
mod alloc_counter;

use dth_core::methods::{
    run, DiscreteGradient, DiscreteMechanics, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Rk4,
    StormerVerlet, Trapezoidal,
};
use dth_core::nalgebra::{SVector, Vector4};
use dth_core::systems::{Kepler, TodaBoundary, TodaChain};
use dth_core::Hamiltonian;

fn allocations<const D: usize, H: Hamiltonian<Const<D>>, M: OneStepMethod<Const<D>, H>>(
    mut method: M,
    h: &H,
    z0: &SVector<f64, D>,
) -> usize {
    let (end, allocations) =
        alloc_counter::count(|| run(&mut method, h, z0, 0.0, 0.05, 200, &mut ()));
    assert!(end.is_ok());
    allocations
}

#[test]
fn peers_allocate_nothing_per_step() {
    let h = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let counts = [
        ("trapezoidal", allocations(Trapezoidal::new(), &h, &z0)),
        ("midpoint", allocations(ImplicitMidpoint::new(), &h, &z0)),
        (
            "discrete_mechanics",
            allocations(DiscreteMechanics::new(), &h, &z0),
        ),
        ("verlet", allocations(StormerVerlet::new(), &h, &z0)),
        ("rk4", allocations(Rk4::new(), &h, &z0)),
        (
            "gauss_legendre2",
            allocations(GaussLegendre2::new(), &h, &z0),
        ),
        (
            "discrete_gradient",
            allocations(DiscreteGradient::new(), &h, &z0),
        ),
    ];
    // Control: the counter sees allocations at all.
    let (v, control) = alloc_counter::count(|| std::hint::black_box(vec![1u8; 16]));
    assert_eq!(control, 1);
    drop(v);
    for (name, n) in counts {
        assert_eq!(n, 0, "{name} allocated {n} times in 200 steps");
    }
    // A 20-dimensional system too.
    let toda = TodaChain::<10>::new(TodaBoundary::Periodic);
    let z = SVector::<f64, 20>::from_fn(|i, _| if i < 10 { 0.0 } else { (i as f64).sin() });
    assert_eq!(allocations(GaussLegendre2::new(), &toda, &z), 0);
}
