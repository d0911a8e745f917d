//! Evaluating compiled code allocates nothing: a counting allocator sees no allocation over
//! many calls of every method (the buffers are the caller's, built before).

// The core's counting allocator counts only the calling thread's allocations inside `count`:
// a global counter would also see the other test's JIT compilation, which runs in parallel.
#[path = "../../dth-core/tests/alloc_counter/mod.rs"]
mod alloc_counter;

use dth_core::nalgebra::SVector;
use dth_core::Hamiltonian;
use dth_runtime::{Backend, RuntimeHamiltonian, Typed};

#[test]
fn compiled_evaluations_allocate_nothing() {
    // Time-dependent, with kernels in its two-point programs and a parameter.
    let h = RuntimeHamiltonian::new(
        "p1^2/(2*m) + p2^2/2 + exp(q1 - q2) + sin(q1)*cos(t) + (1 + q2^2)^(1/3)",
        &[("m", 1.5)],
    )
    .unwrap();
    assert_eq!(h.backend(), Backend::Jit);
    let d = h.dimension();
    let (mut v, mut m, mut all) = (vec![0.0; d], vec![0.0; d * d], h.derivatives_buffer());
    let z0: Vec<f64> = (0..d).map(|i| 0.1 * i as f64 - 0.2).collect();
    let z1: Vec<f64> = z0.iter().map(|x| x + 0.01).collect();
    let (acc, allocations) = alloc_counter::count(|| {
        let mut acc = 0.0;
        for _ in 0..100 {
            acc += h.value_slice(&z0).unwrap() + h.psi_slice(&z0).unwrap();
            h.gradient_slice(&z0, &mut v).unwrap();
            h.hessian_slice(&z0, &mut m).unwrap();
            h.derivatives_slice(&z0, &mut all).unwrap();
            h.discrete_gradient_slice(&z0, &z1, &mut v).unwrap();
            acc += h.energy_difference_slice(&z0, &z1).unwrap();
            h.discrete_gradient_defect_slice(&z0, &z1, &mut v).unwrap();
        }
        acc
    });
    assert!(acc.is_finite());
    assert_eq!(allocations, 0, "allocations during evaluation");
    // The counter does count: the interpreter allocates its results on every call.
    let reference =
        RuntimeHamiltonian::with_backend("p1^2/2 + q1^4", &[], Backend::Interpreter).unwrap();
    let (value, allocations) = alloc_counter::count(|| reference.value_slice(&[0.5, 1.0]));
    assert!(value.is_ok() && allocations > 0);
}

/// The trait's methods through [`Typed`] allocate nothing either: each is one call of compiled
/// code into nalgebra's fixed-size (stack) storage.
#[test]
fn trait_evaluations_allocate_nothing() {
    let h = RuntimeHamiltonian::new(
        "p1^2/(2*m) + p2^2/2 + exp(q1 - q2) + sin(q1)*cos(t) + (1 + q2^2)^(1/3)",
        &[("m", 1.5)],
    )
    .unwrap();
    let h = Typed::<6, true>::new(h).unwrap();
    let z0 = SVector::<f64, 6>::from_fn(|i, _| 0.1 * i as f64 - 0.2);
    let z1 = z0.add_scalar(0.01);
    // The fused evaluation's per-thread scratch is sized on a thread's first call (a stepper
    // makes it when built): after that, nothing.
    let _ = h.derivatives(&z0);
    let (acc, allocations) = alloc_counter::count(|| {
        let mut acc = 0.0;
        for _ in 0..100 {
            acc += h.value(&z0) + h.psi(&z0) + h.energy_difference(&z0, &z1);
            acc += h.gradient(&z0).sum() + h.hessian(&z0).sum();
            let d = h.derivatives(&z0);
            acc += d.value + d.gradient.sum() + d.hessian.sum() + d.psi;
            let gbar = h.discrete_gradient(&z0, &z1);
            acc += h.discrete_gradient_defect(&z0, &z1, &gbar).sum();
        }
        acc
    });
    assert!(acc.is_finite());
    assert_eq!(allocations, 0, "allocations during evaluation");
}

/// The runtime Hamiltonian as `Hamiltonian<Dyn>` writes into the caller's storage: the `_into`
/// methods allocate nothing once the buffers exist (and the fused evaluation's per-thread
/// scratch has been sized by a first call).
#[test]
fn dyn_trait_evaluations_allocate_nothing() {
    use dth_core::nalgebra::{DMatrix, DVector};
    use dth_core::Derivatives;
    let h = RuntimeHamiltonian::new(
        "p1^2/(2*m) + p2^2/2 + exp(q1 - q2) + sin(q1)*cos(t) + (1 + q2^2)^(1/3)",
        &[("m", 1.5)],
    )
    .unwrap();
    let d = h.dimension();
    let z0 = DVector::from_fn(d, |i, _| 0.1 * i as f64 - 0.2);
    let z1 = z0.add_scalar(0.01);
    let (mut v, mut w, mut m) = (DVector::zeros(d), DVector::zeros(d), DMatrix::zeros(d, d));
    let mut all = Derivatives::zeros(dth_core::nalgebra::Dyn(d));
    Hamiltonian::derivatives_into(&h, &z0, &mut all);
    let (acc, allocations) = alloc_counter::count(|| {
        let mut acc = 0.0;
        for _ in 0..100 {
            acc += Hamiltonian::value(&h, &z0) + Hamiltonian::psi(&h, &z0);
            acc += Hamiltonian::energy_difference(&h, &z0, &z1);
            Hamiltonian::gradient_into(&h, &z0, &mut v);
            Hamiltonian::hessian_into(&h, &z0, &mut m);
            Hamiltonian::derivatives_into(&h, &z0, &mut all);
            Hamiltonian::discrete_gradient_into(&h, &z0, &z1, &mut v);
            Hamiltonian::discrete_gradient_defect_into(&h, &z0, &z1, &v, &mut w);
            acc += v.sum() + w.sum() + m.sum() + all.value + all.psi;
        }
        acc
    });
    assert!(acc.is_finite());
    assert_eq!(allocations, 0, "allocations during evaluation");
}
