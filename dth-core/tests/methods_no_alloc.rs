//! No heap allocation per step: every peer, run through the driver with a no-op observer,
//! allocates nothing (counted on this thread by a wrapping global allocator).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use dth_core::methods::{
    run, DiscreteGradient, DiscreteMechanics, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Rk4,
    StormerVerlet, Trapezoidal,
};
use dth_core::nalgebra::{SVector, Vector4};
use dth_core::systems::{Kepler, TodaBoundary, TodaChain};
use dth_core::Hamiltonian;

struct Counting;

thread_local! {
    static ACTIVE: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ACTIVE.try_with(|a| {
            if a.get() {
                COUNT.with(|c| c.set(c.get() + 1));
            }
        });
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations<const D: usize, H: Hamiltonian<D>, M: OneStepMethod<D, H>>(
    mut method: M,
    h: &H,
    z0: &SVector<f64, D>,
) -> usize {
    COUNT.with(|c| c.set(0));
    ACTIVE.with(|a| a.set(true));
    let end = run(&mut method, h, z0, 0.0, 0.05, 200, &mut ());
    ACTIVE.with(|a| a.set(false));
    assert!(end.is_ok());
    COUNT.with(|c| c.get())
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
        ("rk4", allocations(Rk4, &h, &z0)),
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
    COUNT.with(|c| c.set(0));
    ACTIVE.with(|a| a.set(true));
    let v = std::hint::black_box(vec![1u8; 16]);
    ACTIVE.with(|a| a.set(false));
    assert_eq!(COUNT.with(|c| c.get()), 1);
    drop(v);
    for (name, n) in counts {
        assert_eq!(n, 0, "{name} allocated {n} times in 200 steps");
    }
    // A 20-dimensional system too.
    let toda = TodaChain::<10>::new(TodaBoundary::Periodic);
    let z = SVector::<f64, 20>::from_fn(|i, _| if i < 10 { 0.0 } else { (i as f64).sin() });
    assert_eq!(allocations(GaussLegendre2::new(), &toda, &z), 0);
}
