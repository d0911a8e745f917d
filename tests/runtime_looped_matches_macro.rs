//! A lattice read from text whose sums loop (`dth::runtime`, compiled by the JIT in loops)
//! against the `hamiltonian!` looped type of the same text: every method of the trait bit for
//! bit, the same Hessian pattern and flags, and DTH trajectories bit-identical; for sums over
//! pairs, nested and strided sums also against the same text written out term by term, to
//! roundoff.
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
use dth_symbolic::sources::{calogero_moser, gravity_3d};

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

/// 2-D bodies in a trap, the pairs as a nested sum.
fn trapped(n: usize) -> String {
    format!(
        "sum(i = 1..N, (p[2*i-1]^2 + p[2*i]^2)/2) + sum(i = 1..M, q[i]^2/2) \
         + g*sum(i = 1..N, sum(j = i+1..N, exp(-(q[2*i-1] - q[2*j-1])^2 - (q[2*i] - q[2*j])^2))) \
         where N = {n}, M = 2*N"
    )
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Calogero6 { g: f64 } =
        sum(i = 1..N, p[i]^2/2) + g^2*sum(1 <= i < j <= N, (q[i] - q[j])^(-2)) where N = 6
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Gravity4 =
        sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/2) - sum(1 <= i < j <= N,
        ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 + (q[3*i] - q[3*j])^2)^(-1/2))
        where N = 4
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Trapped5 { g: f64 } =
        sum(i = 1..N, (p[2*i-1]^2 + p[2*i]^2)/2) + sum(i = 1..M, q[i]^2/2)
        + g*sum(i = 1..N, sum(j = i+1..N, exp(-(q[2*i-1] - q[2*j-1])^2 - (q[2*i] - q[2*j])^2)))
        where N = 5, M = 2*N
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
        // Pairs (1-D, 3-D), and pairs as a nested sum beside a strided sum and a trap.
        let g = [("g", 0.7)];
        same_methods::<12, _>(&Calogero6 { g: 0.7 }, &calogero_moser(6), &g, backend, true);
        same_methods::<24, _>(&Gravity4, &gravity_3d(4), &[], backend, true);
        let g = [("g", 0.3)];
        same_methods::<20, _>(&Trapped5 { g: 0.3 }, &trapped(5), &g, backend, true);
    }
    // The pattern is what it is: the positions' dense block and the momenta's diagonal, so
    // the Newton iterations take the dense path.
    let m = 3 * 4;
    assert_eq!(
        Gravity4.hessian_pattern().unwrap().len(),
        m * (m + 1) / 2 + m
    );
    assert!(!Gravity4.flags().structured_newton && Gravity4.flags().separable);
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

/// DTH from `zbar0` on the text (at a fixed `D`, its flags the text's) and on the macro's
/// type: the same midpoints and vertices, bit for bit.
fn same_dth<const D: usize, M: Hamiltonian<Const<D>>>(
    m: M,
    src: &str,
    params: &[(&str, f64)],
    zbar0: SVector<f64, D>,
) {
    let rt = Fixed::<D>::new(RuntimeHamiltonian::new(src, params).unwrap()).unwrap();
    assert_eq!(rt.flags(), m.flags(), "{src}");
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
    assert!(Toda64.flags().structured_newton);
    same_dth::<128, _>(
        Fput64 {
            alpha: 0.25,
            beta: 0.5,
        },
        &fput(64),
        &FPUT_PARAMS,
        point(7),
    );
    same_dth::<128, _>(Toda64, &toda(64), &[], point(7));
    // Pairs, on the dense path, from bodies apart.
    let start = |d: usize| spread(d, 7);
    same_dth::<24, _>(Gravity4, &gravity_3d(4), &[], SVector::from_vec(start(24)));
    let g = [("g", 0.3)];
    same_dth::<20, _>(
        Trapped5 { g: 0.3 },
        &trapped(5),
        &g,
        SVector::from_vec(start(20)),
    );
}

/// A point of dimension `d` whose positions are `q[k] = k + u/4` and momenta `u`, `u` seeded
/// in `[-0.4, 0.4)`: neighbouring coordinates at least 0.8 apart, so bodies are.
fn spread(d: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..d)
        .map(|k| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = 0.8 * ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.4;
            if k < d / 2 {
                k as f64 + 0.25 * u
            } else {
                u
            }
        })
        .collect()
}

/// Pairs, nested and strided sums: the text in loops against the same text written out term by term, up to 64 bodies: value,
/// gradient, Hessian, Psi, discrete gradient and defect agree to roundoff. Both add the same
/// terms in different orders (pair by pair against one sum of all terms), so they differ by a
/// few `eps` times the sum of the terms' magnitudes; with the bodies at least 0.8 apart each
/// term of `r^-1`, `r^-2` and their first two derivatives is at most `6 / 0.8^4 < 100`, and
/// the sums have at most a few thousand terms: the tolerance is `eps` times the number of
/// pairs times that bound, per entry (results of a few units lose no more).
#[test]
fn looped_text_equals_the_written_out_text_to_roundoff() {
    for (src, params) in [
        (calogero_moser(64), vec![("g", 0.7)]),
        (gravity_3d(24), vec![]),
        (trapped(16), vec![("g", 0.3)]),
    ] {
        let names: Vec<&str> = params.iter().map(|p| p.0).collect();
        let values: Vec<f64> = params.iter().map(|p| p.1).collect();
        let rt = RuntimeHamiltonian::new(&src, &params).unwrap();
        assert!(rt.looped().is_some(), "{src}");
        let written = dth_symbolic::compile(&src, &names).unwrap();
        let d = written.dim();
        let pairs = (d / 2) * (d / 2) / 2;
        let tol = f64::EPSILON * pairs as f64 * 100.0;
        let (z0, z1) = (spread(d, 1), spread(d, 2));
        let (zd, z1d) = (DVector::from_vec(z0.clone()), DVector::from_vec(z1.clone()));
        let e = written
            .program(dth_symbolic::Method::All)
            .eval(&z0, &values)
            .unwrap();
        let close = |a: f64, b: f64, what: &str| {
            assert!(
                (a - b).abs() <= tol,
                "{src}: {what}: {a} vs {b} (tolerance {tol:e})"
            )
        };
        close(rt.value(&zd), e.value, "value");
        close(rt.psi(&zd), e.psi, "psi");
        let (g, h) = (rt.gradient(&zd), rt.hessian(&zd));
        for k in 0..d {
            close(g[k], e.gradient[k], "gradient");
            for l in 0..d {
                close(h[(k, l)], e.hessian[k * d + l], "hessian");
            }
        }
        let pair = written
            .program(dth_symbolic::Method::DiscreteGradient)
            .eval_pair(&z0, &z1, &values)
            .unwrap();
        let defect = written
            .program(dth_symbolic::Method::DiscreteGradientDefect)
            .eval_pair(&z0, &z1, &values)
            .unwrap();
        close(
            rt.energy_difference(&zd, &z1d),
            pair.energy_difference,
            "energy difference",
        );
        let gbar = rt.discrete_gradient(&zd, &z1d);
        let t = rt.discrete_gradient_defect(&zd, &z1d, &gbar);
        for k in 0..d {
            close(gbar[k], pair.discrete_gradient[k], "gbar");
            close(t[k], defect.discrete_gradient_defect[k], "defect");
        }
    }
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
