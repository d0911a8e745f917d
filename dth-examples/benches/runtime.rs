//! Hamiltonians compiled at run time (`dth_runtime`) against the catalogue's
//! `hamiltonian!` types: the fused derivatives (`derivatives`: value, gradient, Hessian, Psi)
//! three ways, and the JIT's compile time against the size of the expression.
//!
//! Groups `runtime/<system>`, functions `macro` (the catalogue type's
//! `Hamiltonian::derivatives`), `jit` (`RuntimeHamiltonian::derivatives_slice` into a reused buffer)
//! and `interpreter` (the same with `Backend::Interpreter`); each iteration evaluates the same
//! 16 seeded points. Before timing, the JIT's results are checked equal to the macro's, bit
//! for bit. Group `runtime_compile/toda_<N>`: `RuntimeHamiltonian::new` on the engine's Toda
//! chain of `N` particles (`dth_symbolic::sources::toda_fixed_ends`), function `engine`
//! (parse, differentiate, lower the eight programs: `Backend::Interpreter`) and `engine+jit`
//! (the same and compiling them: `Backend::Jit`); the JIT's own cost is the difference.
//!
//! Ratios go into `docs/performance.md` from one run of
//! `cargo bench -p dth-examples --bench runtime -- --noplot`.

use dth::nalgebra::Const;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use dth::nalgebra::SVector;
use dth::Hamiltonian;
use dth_examples::systems;
use dth_runtime::{Backend, RuntimeHamiltonian};

#[path = "../../dth-runtime/tests/catalogue/mod.rs"]
mod catalogue;

use catalogue::{Entry, Rng, CATALOGUE};

/// Evaluations per iteration.
const BATCH: usize = 16;

fn entry(name: &str) -> &'static Entry {
    CATALOGUE
        .iter()
        .find(|e| e.name == name)
        .unwrap_or_else(|| panic!("no catalogue entry {name}"))
}

/// One group: the macro type, the JIT and the interpreter on the same points.
fn group<const D: usize>(c: &mut Criterion, name: &str, typed: &impl Hamiltonian<Const<D>>) {
    let e = entry(name);
    let jit = RuntimeHamiltonian::new(e.src, e.params).expect("catalogue source compiles");
    assert_eq!(jit.backend(), Backend::Jit, "{:?}", jit.fallback_reason());
    let interpreter = RuntimeHamiltonian::with_backend(e.src, e.params, Backend::Interpreter)
        .expect("catalogue source compiles");
    let mut rng = Rng(0xbe4c_0000 + D as u64);
    let zs: Vec<SVector<f64, D>> = (0..BATCH)
        .map(|_| SVector::from_vec(rng.point(D)))
        .collect();
    let mut buffer = jit.derivatives_buffer();
    for z in &zs {
        // A benchmark of different arithmetic would mean nothing: same bits first.
        let d = typed.derivatives(z);
        jit.derivatives_slice(z.as_slice(), &mut buffer)
            .expect("finite");
        assert_eq!(d.value.to_bits(), buffer.value().to_bits(), "{name} at {z}");
        assert_eq!(d.psi.to_bits(), buffer.psi().to_bits(), "{name} at {z}");
        assert_eq!(d.gradient.as_slice(), buffer.gradient(), "{name} at {z}");
    }
    let mut g = c.benchmark_group(format!("runtime/{name}"));
    g.bench_function("macro", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for z in &zs {
                acc += black_box(typed.derivatives(black_box(z))).psi;
            }
            acc
        })
    });
    for (label, h) in [("jit", &jit), ("interpreter", &interpreter)] {
        g.bench_function(label, |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for z in &zs {
                    h.derivatives_slice(black_box(z.as_slice()), &mut buffer)
                        .expect("finite");
                    acc += black_box(&buffer).psi();
                }
                acc
            })
        });
    }
    g.finish();
}

/// Parameter `name` of catalogue entry `system`.
fn param(system: &str, name: &str) -> f64 {
    entry(system)
        .params
        .iter()
        .find(|p| p.0 == name)
        .map(|p| p.1)
        .unwrap_or_else(|| panic!("{system} has no parameter {name}"))
}

fn derivatives(c: &mut Criterion) {
    let p = |name| move |k| param(name, k);
    let kepler = p("kepler");
    group(
        c,
        "kepler",
        &systems::Kepler {
            m: kepler("m"),
            k: kepler("k"),
        },
    );
    let osc = p("harmonic_oscillator");
    group(
        c,
        "harmonic_oscillator",
        &systems::HarmonicOscillator {
            m: osc("m"),
            k: osc("k"),
        },
    );
    let pen = p("pendulum");
    group(
        c,
        "pendulum",
        &systems::Pendulum {
            m: pen("m"),
            l: pen("l"),
            g: pen("g"),
        },
    );
    group(c, "henon_heiles", &systems::HenonHeiles);
    let dp = p("double_pendulum");
    group(
        c,
        "double_pendulum",
        &systems::DoublePendulum {
            m1: dp("m1"),
            m2: dp("m2"),
            l1: dp("l1"),
            l2: dp("l2"),
            g: dp("g"),
        },
    );
    group(c, "toda_chain_10", &systems::TodaChain10);
    let fo = p("forced_oscillator");
    group(
        c,
        "forced_oscillator",
        &systems::ForcedOscillator {
            omega0: fo("omega0"),
            f: fo("f"),
            omega: fo("omega"),
        },
    );
}

fn compile_time(c: &mut Criterion) {
    for n in [2, 4, 8, 16, 32, 64] {
        let src = dth_symbolic::sources::toda_fixed_ends(n);
        let system = dth_symbolic::compile(&src, &[]).expect("Toda compiles");
        let ops: usize = dth_runtime::Function::ALL
            .iter()
            .map(|f| f.program(&system).map_or(0, |p| p.ops.len()))
            .sum();
        eprintln!("runtime_compile/toda_{n}: {ops} operations in the eight programs");
        let mut g = c.benchmark_group(format!("runtime_compile/toda_{n}"));
        for (label, backend) in [
            ("engine", Backend::Interpreter),
            ("engine+jit", Backend::Jit),
        ] {
            g.bench_function(label, |b| {
                b.iter(|| {
                    RuntimeHamiltonian::with_backend(black_box(&src), &[], backend)
                        .expect("Toda compiles")
                })
            });
        }
        g.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(20);
    targets = derivatives, compile_time
}
criterion_main!(benches);
