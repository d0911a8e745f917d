//! A lattice read from text whose sums loop (`dth::runtime`, compiled by the JIT in loops)
//! against the `hamiltonian!` looped type of the same text: every method of the trait bit for
//! bit, the same Hessian pattern and flags, and DTH trajectories bit-identical.
//!
//! Why bits: both run the summand's same programs (the macro as Rust, the JIT through
//! Cranelift, which neither reassociates nor fuses float arithmetic), site after site in the
//! same order, adding each output where the macro's code adds it, in the same order
//! (`dth-runtime`'s `lattice` module).

#![cfg(feature = "runtime")]

use dth::dth::{integrate, DthOptions};
use dth::nalgebra::{Const, DVector, SVector};
use dth::runtime::{Backend, Fixed, RuntimeHamiltonian};
use dth::Hamiltonian;

/// FPUT-alpha-beta with fixed ends, as text; `{n}` is the size.
fn fput(n: usize) -> String {
    format!(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3 \
         + beta*(q[i+1] - q[i])^4/4) where N = {n}, q[0] = q[N+1] = 0"
    )
}

/// The periodic Toda ring, as text.
fn toda(n: usize) -> String {
    format!("sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = {n}, q[N+1] = q[1]")
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Fput4 { alpha: f64, beta: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3
        + beta*(q[i+1] - q[i])^4/4) where N = 4, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Fput64 { alpha: f64, beta: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3
        + beta*(q[i+1] - q[i])^4/4) where N = 64, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Fput512 { alpha: f64, beta: f64 } =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3
        + beta*(q[i+1] - q[i])^4/4) where N = 512, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Toda3 = sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = 3, q[N+1] = q[1]
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Toda64 = sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = 64, q[N+1] = q[1]
}

dth::hamiltonian! {
    /// A ring of two: both bonds couple the same pair (the mixed entry counted twice).
    #[derive(Clone, Copy)]
    struct Ring2 = sum(i = 1..2, p[i]^2/2 + cos(q[i] - q[i+1])) where q[3] = q[1]
}

/// Second neighbours on a ring, a momentum coupled to a position: not separable.
const COUPLED: &str = "sum(i = 1..N, p[i]^2/2 + p[i]*q[i+1]/8 + (q[i+2] - q[i])^4/4 + q[i]^2/2) \
                       where N = 6, q[N+1] = q[1], q[N+2] = q[2]";

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Coupled6 = sum(i = 1..N, p[i]^2/2 + p[i]*q[i+1]/8 + (q[i+2] - q[i])^4/4 + q[i]^2/2)
        where N = 6, q[N+1] = q[1], q[N+2] = q[2]
}

const FPUT_PARAMS: [(&str, f64); 2] = [("alpha", 0.25), ("beta", 0.5)];

/// A deterministic point in `[-0.4, 0.4)^D`.
fn point<const D: usize>(seed: u64) -> SVector<f64, D> {
    let mut s = seed;
    SVector::from_fn(|_, _| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        0.8 * ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.4
    })
}

fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// The text compiled in loops by `backend`, against the macro's type `m`: every method at a
/// few points, bit for bit; the dense Hessian and the fused derivatives when `dense`.
fn same_methods<const D: usize, M: Hamiltonian<Const<D>>>(
    m: &M,
    src: &str,
    params: &[(&str, f64)],
    backend: Backend,
    dense: bool,
) {
    let rt = RuntimeHamiltonian::with_backend(src, params, backend).unwrap();
    assert_eq!(rt.backend(), backend, "{src}");
    assert!(rt.looped().is_some() && rt.system().is_none(), "{src}");
    let pattern = m.hessian_pattern().unwrap();
    assert_eq!(rt.hessian_pattern(), Some(pattern), "{src}");
    assert_eq!(
        Hamiltonian::flags(&rt),
        m.flags(),
        "{src}: the flags (separable, structured Newton, ...)"
    );
    for seed in 1..4 {
        let z: SVector<f64, D> = point(seed);
        let z1: SVector<f64, D> = point(seed + 100);
        let (zd, z1d) = (
            DVector::from_column_slice(z.as_slice()),
            DVector::from_column_slice(z1.as_slice()),
        );
        assert_eq!(rt.value(&zd).to_bits(), m.value(&z).to_bits(), "{src}");
        assert_eq!(
            bits(rt.gradient(&zd).as_slice()),
            bits(m.gradient(&z).as_slice()),
            "{src}"
        );
        let (mut a, mut b) = (vec![0.0; pattern.len()], vec![0.0; pattern.len()]);
        rt.hessian_nonzeros(&zd, &mut a);
        m.hessian_nonzeros(&z, &mut b);
        assert_eq!(bits(&a), bits(&b), "{src}");
        assert_eq!(rt.psi(&zd).to_bits(), m.psi(&z).to_bits(), "{src}");
        assert_eq!(
            bits(rt.discrete_gradient(&zd, &z1d).as_slice()),
            bits(m.discrete_gradient(&z, &z1).as_slice()),
            "{src}"
        );
        assert_eq!(
            rt.energy_difference(&zd, &z1d).to_bits(),
            m.energy_difference(&z, &z1).to_bits(),
            "{src}"
        );
        let (gd, g) = (
            rt.discrete_gradient(&zd, &z1d),
            m.discrete_gradient(&z, &z1),
        );
        assert_eq!(
            bits(rt.discrete_gradient_defect(&zd, &z1d, &gd).as_slice()),
            bits(m.discrete_gradient_defect(&z, &z1, &g).as_slice()),
            "{src}"
        );
        if dense {
            assert_eq!(
                bits(rt.hessian(&zd).as_slice()),
                bits(m.hessian(&z).as_slice()),
                "{src}"
            );
            let (a, b) = (rt.derivatives(&zd), m.derivatives(&z));
            assert_eq!(a.value.to_bits(), b.value.to_bits(), "{src}");
            assert_eq!(bits(a.gradient.as_slice()), bits(b.gradient.as_slice()));
            assert_eq!(bits(a.hessian.as_slice()), bits(b.hessian.as_slice()));
            assert_eq!(a.psi.to_bits(), b.psi.to_bits(), "{src}");
        }
    }
}

/// `f` on a thread with room for the macro types' fixed-size Hessians (`D = 128`: 128 KB
/// each, several live at once in an unoptimised frame) and vectors of `D = 1024`.
fn on_a_large_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(256 << 20)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap();
}

#[test]
fn every_method_has_the_macros_bits_jit_and_interpreter() {
    on_a_large_stack(every_method);
}

fn every_method() {
    let p = (0.25, 0.5);
    for backend in [Backend::Jit, Backend::Interpreter] {
        same_methods::<8, _>(
            &Fput4 {
                alpha: p.0,
                beta: p.1,
            },
            &fput(4),
            &FPUT_PARAMS,
            backend,
            true,
        );
        same_methods::<128, _>(
            &Fput64 {
                alpha: p.0,
                beta: p.1,
            },
            &fput(64),
            &FPUT_PARAMS,
            backend,
            true,
        );
        same_methods::<6, _>(&Toda3, &toda(3), &[], backend, true);
        same_methods::<128, _>(&Toda64, &toda(64), &[], backend, true);
        same_methods::<4, _>(
            &Ring2,
            "sum(i = 1..2, p[i]^2/2 + cos(q[i] - q[i+1])) where q[3] = q[1]",
            &[],
            backend,
            true,
        );
        same_methods::<12, _>(&Coupled6, COUPLED, &[], backend, true);
    }
    // D = 1024: the dense Hessian (8 MB) is left out, the structured path's methods are not.
    same_methods::<1024, _>(
        &Fput512 {
            alpha: p.0,
            beta: p.1,
        },
        &fput(512),
        &FPUT_PARAMS,
        Backend::Jit,
        false,
    );
}

/// DTH on the text (at a fixed `D`, its flags the text's: the structured Newton) and on the
/// macro's type: the same midpoints and vertices, bit for bit.
fn same_dth<const D: usize, M: Hamiltonian<Const<D>>>(m: M, src: &str, params: &[(&str, f64)]) {
    let rt = Fixed::<D>::new(RuntimeHamiltonian::new(src, params).unwrap()).unwrap();
    assert!(rt.flags().structured_newton, "{src}");
    let zbar0: SVector<f64, D> = point(7);
    let options = DthOptions::new(0.05).unwrap().with_lambda0(1.0).unwrap();
    let steps = 20;
    let a = integrate(m, zbar0, options, steps).unwrap();
    let b = integrate(rt, zbar0, options, steps).unwrap();
    assert_eq!(a.midpoints().len(), steps + 1);
    let flat = |zs: &[SVector<f64, D>]| {
        zs.iter()
            .flat_map(|z| bits(z.as_slice()))
            .collect::<Vec<_>>()
    };
    assert_eq!(flat(a.midpoints()), flat(b.midpoints()), "{src}");
    assert_eq!(flat(a.vertices()), flat(b.vertices()), "{src}");
}

#[test]
fn dth_steps_have_the_macros_bits() {
    same_dth::<128, _>(
        Fput64 {
            alpha: 0.25,
            beta: 0.5,
        },
        &fput(64),
        &FPUT_PARAMS,
    );
    same_dth::<128, _>(Toda64, &toda(64), &[]);
}

/// A text that does not loop keeps the written-out path (no pattern, a system); an error in
/// a lattice's text is the same spanned error as before.
#[test]
fn other_texts_are_written_out_and_errors_are_unchanged() {
    let mixed = "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) + (q[1] - q[0])^2/2 \
                 where N = 8, q[0] = q[N+1] = 0";
    let h = RuntimeHamiltonian::new(mixed, &[]).unwrap();
    assert!(h.looped().is_none() && h.system().is_some() && h.hessian_pattern().is_none());
    assert!(!Hamiltonian::flags(&h).structured_newton);
    let bad = "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = 8";
    let e = RuntimeHamiltonian::new(bad, &[]).unwrap_err();
    let expected =
        dth::runtime::RuntimeError::Expression(dth_symbolic::compile(bad, &[]).unwrap_err());
    assert_eq!(e, expected);
}
