//! Cost of one implicit-midpoint step and of one DTH step against the size of the system,
//! structured Newton against dense: the FPUT-alpha and Toda chains with fixed ends, written out through
//! `hamiltonian!` (`tests/chains/`), `N = 2, 4, 8, 12, 16, 32, 128, 512` particles (`D = 2N`),
//! and planar Kepler (`D = 4`, a full q-block: the smallest system, for the crossover).
//!
//! Groups `midpoint/<chain>_<N>`, each with up to two functions on the same 16 seeded states
//! and `dt = 0.1`:
//! - `structured`: the banded Newton of `dth_core::structured` (the generated type's
//!   pattern and fused nonzeros, forced on even below the generated crossover);
//! - `dense`: the fixed-size `D x D` LU (the same Hamiltonian with its structure hidden), up to
//!   `N = 128` (at `N = 512` the dense Newton matrix alone is 8 MB of stack);
//! - `dense_schur`, up to `N = 32`: the dense path with the type's flags and fused evaluation,
//!   so a separable chain is factored through its `N x N` Schur complement.
//!
//! Groups `dth/<chain>_<N>`, `N = 8, 32, 128, 512`: one DTH step (joint Newton,
//! cancellation-free, `dtau = 0.1`, `lambda_0 = 1`, so `dt ~ 0.1` as for the midpoint) of a
//! stepper running along its trajectory from the first seeded state, on the generated type
//! (structured from `D = 8`). With `DTH_LONG_RUN=1` in the environment, `dth_long_run` first
//! runs `10^4` DTH steps of the FPUT chain of 512 particles (`t ~ 10^3`) once and prints their
//! time and the largest energy error at the midpoints, which it checks to be at roundoff (the
//! release-profile run of the test `dth_keeps_the_energy_of_the_512_particle_chain_on_a_2mb_stack`).
//!
//! The crossover of `hamiltonian!` (`STRUCTURED_NEWTON` from `D = 8`) and the table of
//! `docs/performance.md` come from this bench. Run with
//! `cargo bench -p dth-examples --bench step_vs_size -- --noplot` (add `--quick` for a smoke run).

use dth::nalgebra::Const;
use dth::Flags;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use dth::dth::{Dth, DthOptions};
use dth::methods::{ImplicitMidpoint, OneStepMethod};
use dth::nalgebra::{SMatrix, SVector};
use dth::Hamiltonian;
use dth_examples::ensemble::sample::SplitMix64;

include!("../../tests/chains/fput_alpha_2.rs");
include!("../../tests/chains/fput_alpha_4.rs");
include!("../../tests/chains/fput_alpha_8.rs");
include!("../../tests/chains/fput_alpha_12.rs");
include!("../../tests/chains/fput_alpha_16.rs");
include!("../../tests/chains/fput_alpha_32.rs");
include!("../../tests/chains/fput_alpha_128.rs");
include!("../../tests/chains/fput_alpha_512.rs");
include!("../../tests/chains/toda_2.rs");
include!("../../tests/chains/toda_4.rs");
include!("../../tests/chains/toda_8.rs");
include!("../../tests/chains/toda_12.rs");
include!("../../tests/chains/toda_16.rs");
include!("../../tests/chains/toda_32.rs");
include!("../../tests/chains/toda_128.rs");
include!("../../tests/chains/toda_512.rs");

/// The Hamiltonian with its structure hidden: Newton takes the dense path.
#[derive(Clone, Copy)]
struct Dense<H>(H);

impl<const D: usize, H: Hamiltonian<Const<D>>> Hamiltonian<Const<D>> for Dense<H> {
    fn dim(&self) -> Const<D> {
        Const
    }
    fn value(&self, z: &SVector<f64, D>) -> f64 {
        self.0.value(z)
    }
    fn gradient_into(&self, z: &SVector<f64, D>, out: &mut SVector<f64, D>) {
        self.0.gradient_into(z, out)
    }
    fn hessian_into(&self, z: &SVector<f64, D>, out: &mut SMatrix<f64, D, D>) {
        self.0.hessian_into(z, out)
    }
}

/// The generated type on the dense path with everything else it declares: its flags
/// (`separable`, so the Schur-complement factorization of `dth_core`'s dense Newton matrix)
/// and its fused `derivatives_into`, the structured path switched off.
#[derive(Clone, Copy)]
struct DenseSchur<H>(H);

impl<const D: usize, H: Hamiltonian<Const<D>>> Hamiltonian<Const<D>> for DenseSchur<H> {
    fn dim(&self) -> Const<D> {
        Const
    }
    fn flags(&self) -> Flags {
        self.0.flags().with_structured_newton(false)
    }
    fn value(&self, z: &SVector<f64, D>) -> f64 {
        self.0.value(z)
    }
    fn gradient_into(&self, z: &SVector<f64, D>, out: &mut SVector<f64, D>) {
        self.0.gradient_into(z, out)
    }
    fn hessian_into(&self, z: &SVector<f64, D>, out: &mut SMatrix<f64, D, D>) {
        self.0.hessian_into(z, out)
    }
    fn derivatives_into(&self, z: &SVector<f64, D>, out: &mut dth::Derivatives<Const<D>>) {
        self.0.derivatives_into(z, out)
    }
}

/// The Hamiltonian with the structured path forced on, whatever its size.
#[derive(Clone, Copy)]
struct Structured<H>(H);

impl<const D: usize, H: Hamiltonian<Const<D>>> Hamiltonian<Const<D>> for Structured<H> {
    fn dim(&self) -> Const<D> {
        Const
    }
    fn flags(&self) -> Flags {
        Flags::new().with_structured_newton(true)
    }
    fn hessian_pattern(&self) -> Option<&[(usize, usize)]> {
        self.0.hessian_pattern()
    }
    fn value(&self, z: &SVector<f64, D>) -> f64 {
        self.0.value(z)
    }
    fn gradient_into(&self, z: &SVector<f64, D>, out: &mut SVector<f64, D>) {
        self.0.gradient_into(z, out)
    }
    fn hessian_into(&self, z: &SVector<f64, D>, out: &mut SMatrix<f64, D, D>) {
        self.0.hessian_into(z, out)
    }
    fn hessian_nonzeros(&self, z: &SVector<f64, D>, values: &mut [f64]) {
        self.0.hessian_nonzeros(z, values);
    }
}

/// 16 seeded chain states: displacements in `[-0.3, 0.3]`, momenta in `[-0.5, 0.5]`.
fn states<const D: usize>() -> Vec<SVector<f64, D>> {
    let mut rng = SplitMix64::new(0x5EED_0010);
    (0..16)
        .map(|_| {
            SVector::from_fn(|i, _| {
                let u = rng.unit() - 0.5;
                if i < D / 2 {
                    0.6 * u
                } else {
                    u
                }
            })
        })
        .collect()
}

const DT: f64 = 0.1;

fn bench_one<const D: usize, H: Hamiltonian<Const<D>>>(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    h: &H,
    zs: &[SVector<f64, D>],
) {
    let mut m = ImplicitMidpoint::new();
    // The first step analyses the pattern (structured path); not part of a step's cost.
    let _ = m.step(h, &zs[0], DT);
    let mut i = 0;
    g.bench_function(name, |b| {
        b.iter(|| {
            i = (i + 1) % zs.len();
            black_box(m.step(h, black_box(&zs[i]), DT).map(|z| z[0]))
        })
    });
}

fn chain<const D: usize, H: Hamiltonian<Const<D>> + Copy>(
    c: &mut Criterion,
    name: &str,
    h: H,
    dense: bool,
) {
    let zs = states::<D>();
    let mut g = c.benchmark_group(format!("midpoint/{name}"));
    if D >= 256 {
        g.sample_size(10).measurement_time(Duration::from_secs(2));
    }
    bench_one(&mut g, "structured", &Structured(h), &zs);
    if dense {
        bench_one(&mut g, "dense", &Dense(h), &zs);
    }
    if D <= 64 {
        bench_one(&mut g, "dense_schur", &DenseSchur(h), &zs);
    }
    g.finish();
}

/// One DTH step, `dtau = 0.1`, of a stepper running from `z0`.
fn dth_step<const D: usize, H: Hamiltonian<Const<D>> + Copy>(c: &mut Criterion, name: &str, h: H) {
    let z0 = states::<D>()[0];
    let options = DthOptions::new(DT).expect("dtau");
    let mut dth = Dth::new(h, z0, options).expect("start");
    let mut g = c.benchmark_group(format!("dth/{name}"));
    if D >= 256 {
        g.sample_size(10).measurement_time(Duration::from_secs(2));
    }
    g.bench_function("structured", |b| {
        b.iter(|| black_box(dth.step().expect("DTH step").iterations))
    });
    g.finish();
}

/// `10^4` DTH steps of the FPUT chain of 512 particles, timed once: the energy at every
/// midpoint stays at roundoff (a few `eps` of the size of the terms of `H`).
fn dth_long_run() {
    const STEPS: u32 = 10_000;
    let h = FputAlpha512;
    let z0 = states::<1024>()[0];
    let options = DthOptions::new(DT).expect("dtau");
    let mut dth = Dth::new(h, z0, options).expect("start");
    let e0 = h.value(&z0);
    let scale = e0.abs().max(z0.component_mul(&h.gradient(&z0)).abs().sum());
    let mut worst = 0.0f64;
    let (mut iterations, mut factorizations) = (0u64, 0u64);
    let start = std::time::Instant::now();
    for _ in 0..STEPS {
        let r = dth.step().expect("DTH step");
        iterations += u64::from(r.iterations);
        factorizations += u64::from(r.factorizations);
        worst = worst.max((h.value(dth.zbar()) - e0).abs());
    }
    let elapsed = start.elapsed();
    println!(
        "dth_long_run/fput_alpha_512: {STEPS} steps to t = {:.1} in {:.2} s ({:.0} us/step, \
         {:.2} iterations and {:.2} factorizations per step); largest energy error at the \
         midpoints {worst:.2e} = {:.1} eps of the terms of H ({scale:.2})",
        dth.tbar(),
        elapsed.as_secs_f64(),
        elapsed.as_secs_f64() * 1e6 / f64::from(STEPS),
        iterations as f64 / f64::from(STEPS),
        factorizations as f64 / f64::from(STEPS),
        worst / (f64::EPSILON * scale),
    );
    assert!(
        worst <= 16.0 * f64::EPSILON * scale,
        "energy error {worst:e} at the midpoints"
    );
}

fn dth(c: &mut Criterion) {
    dth_step::<16, _>(c, "fput_8", FputAlpha8);
    dth_step::<64, _>(c, "fput_32", FputAlpha32);
    dth_step::<256, _>(c, "fput_128", FputAlpha128);
    if std::env::var_os("DTH_LONG_RUN").is_some() {
        dth_long_run();
    }
    dth_step::<1024, _>(c, "fput_512", FputAlpha512);
    dth_step::<16, _>(c, "toda_8", Toda8);
    dth_step::<64, _>(c, "toda_32", Toda32);
    dth_step::<256, _>(c, "toda_128", Toda128);
    dth_step::<1024, _>(c, "toda_512", Toda512);
}

fn fput(c: &mut Criterion) {
    chain::<4, _>(c, "fput_2", FputAlpha2, true);
    chain::<8, _>(c, "fput_4", FputAlpha4, true);
    chain::<16, _>(c, "fput_8", FputAlpha8, true);
    chain::<24, _>(c, "fput_12", FputAlpha12, true);
    chain::<32, _>(c, "fput_16", FputAlpha16, true);
    chain::<64, _>(c, "fput_32", FputAlpha32, true);
    chain::<256, _>(c, "fput_128", FputAlpha128, true);
    chain::<1024, _>(c, "fput_512", FputAlpha512, false);
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Kepler = (p1^2 + p2^2)/2 - 1/sqrt(q1^2 + q2^2)
}

fn kepler(c: &mut Criterion) {
    // Eccentric orbits about the origin: the chain states shifted to q1 ~ 1.
    let zs: Vec<SVector<f64, 4>> = states::<4>()
        .into_iter()
        .map(|z| SVector::<f64, 4>::new(1.0 + z[0], z[1], z[2], 1.0 + z[3]))
        .collect();
    let mut g = c.benchmark_group("midpoint/kepler");
    bench_one(&mut g, "structured", &Structured(Kepler), &zs);
    bench_one(&mut g, "dense", &Dense(Kepler), &zs);
    bench_one(&mut g, "dense_schur", &DenseSchur(Kepler), &zs);
    g.finish();
}

fn toda(c: &mut Criterion) {
    chain::<4, _>(c, "toda_2", Toda2, true);
    chain::<8, _>(c, "toda_4", Toda4, true);
    chain::<16, _>(c, "toda_8", Toda8, true);
    chain::<24, _>(c, "toda_12", Toda12, true);
    chain::<32, _>(c, "toda_16", Toda16, true);
    chain::<64, _>(c, "toda_32", Toda32, true);
    chain::<256, _>(c, "toda_128", Toda128, true);
    chain::<1024, _>(c, "toda_512", Toda512, false);
}

/// Short windows (2 shared cores).
fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = kepler, fput, toda, dth
}
criterion_main!(benches);
