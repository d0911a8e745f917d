//! What `hamiltonian!` costs at compile time for a chain of `n` = 2..20 degrees of freedom
//! (the Toda chain between walls, `D = 2n`): the engine's work in the macro (parse,
//! differentiate, simplify, then lower the five programs the macro emits: value, gradient,
//! Hessian, Psi and the fused `derivatives`), timed in-process, and the emitted code size in
//! straight-line operations (one `let` each), against the number of nonzero entries of the
//! Hessian's upper triangle.
//!
//! Criterion groups `expand/toda_<n>`; the table printed first is what `docs/performance.md`
//! records. The bound "operations / Hessian nonzeros" is asserted by a test
//! (`tests/macro_systems.rs`), not here.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use dth_symbolic::sources::toda_fixed_ends;
use dth_symbolic::{compile, Method, Output, System};

/// The chain sizes measured.
const SIZES: [usize; 10] = [2, 4, 6, 8, 10, 12, 14, 16, 18, 20];

/// The one-point programs the macro lowers and emits; the two-point discrete-gradient program
/// is lowered once and emitted in two pruned halves (`discrete_gradient`, `energy_difference`).
const METHODS: [Method; 5] = [
    Method::Value,
    Method::Gradient,
    Method::Hessian,
    Method::Psi,
    Method::All,
];

/// What the macro asks of the engine: compile, then lower every program; the number of
/// operations emitted.
fn expand(src: &str) -> (System, usize) {
    let system = match compile(src, &[]) {
        Ok(s) => s,
        Err(e) => panic!("the chain Hamiltonian must compile: {e:?}"),
    };
    let pair = system.program(Method::DiscreteGradient);
    let halves = pair
        .prune(|o| matches!(o, Output::DiscreteGradient(_)))
        .ops
        .len()
        + pair.prune(|o| o == Output::EnergyDifference).ops.len();
    let ops = METHODS
        .iter()
        .map(|&m| system.program(m).ops.len())
        .sum::<usize>()
        + halves;
    (system, ops)
}

/// Nonzero entries of the Hessian's upper triangle (the ones the macro emits code for).
fn hessian_nonzeros(system: &System) -> usize {
    let d = system.dim();
    (0..d)
        .flat_map(|i| (i..d).map(move |j| (i, j)))
        .filter(|&(i, j)| !system.arena().is_zero(system.hessian_entry(i, j)))
        .count()
}

/// The table for `docs/performance.md`: median of 25 in-process expansions per size.
fn table() {
    println!("| n | D | Hessian nonzeros (upper) | ops, fused | ops, discrete gradient | ops, emitted in all | ops / nonzero | engine time (median) | time / nonzero |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in SIZES {
        let src = toda_fixed_ends(n);
        let mut times: Vec<Duration> = (0..25)
            .map(|_| {
                let t = Instant::now();
                black_box(expand(black_box(&src)));
                t.elapsed()
            })
            .collect();
        times.sort();
        let median = times[times.len() / 2];
        let (system, ops) = expand(&src);
        let nnz = hessian_nonzeros(&system);
        let fused = system.program(Method::All).ops.len();
        let pair = system.program(Method::DiscreteGradient).ops.len();
        println!(
            "| {n} | {} | {nnz} | {fused} | {pair} | {ops} | {:.2} | {:.1} us | {:.2} us |",
            system.dim(),
            ops as f64 / nnz as f64,
            median.as_secs_f64() * 1e6,
            median.as_secs_f64() * 1e6 / nnz as f64
        );
    }
}

fn expansion(c: &mut Criterion) {
    table();
    for n in SIZES {
        let src = toda_fixed_ends(n);
        c.bench_function(&format!("expand/toda_{n}"), |b| {
            b.iter(|| expand(black_box(&src)).1)
        });
    }
}

/// Short windows (2 shared cores): 20 samples over 1 s per size.
fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = expansion
}
criterion_main!(benches);
