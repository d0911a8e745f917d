//! What the engine does for `hamiltonian!` on an FPUT-alpha chain written once as a sum
//! (`sum(i = 0..N, ...) where N = .., q[0] = q[N+1] = 0`), against `N`: compile (parse, build
//! the sum site by site, differentiate, simplify, Psi) and lower the programs the macro emits,
//! and the number of straight-line operations emitted. Sums are built site by site today, so
//! both grow with `N`. Beside it, what the macro does for the same source today: compile once
//! per summand (`dth_symbolic::looped::compile`: parse, differentiate the summands, lower their
//! programs) and emit the loops (`dth_symbolic::emit::lattice::looped_impl`), neither of which
//! grows with `N`. Needs the `emit` feature: `cargo bench -p dth-symbolic --features emit
//! --bench indexed_expand`. Criterion groups `indexed_expand/fput_<N>`
//! and `indexed_expand/looped_<N>`; the tables printed first are what `docs/performance.md`
//! records.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use dth_symbolic::emit::lattice::looped_impl;
use dth_symbolic::{compile, looped, Method, Output};
use proc_macro2::{Ident, Span};

/// The chain sizes measured (512 is the largest index the engine accepts).
const SIZES: [usize; 4] = [64, 128, 256, 512];

/// The one-line FPUT-alpha source of `n` particles.
fn fput(n: usize) -> String {
    format!(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3) \
         where N = {n}, q[0] = q[N+1] = 0"
    )
}

/// Compile and lower what the macro emits; the operations emitted in all.
fn expand(src: &str) -> usize {
    let system = match compile(src, &["alpha"]) {
        Ok(s) => s,
        Err(e) => panic!("the chain must compile: {e}"),
    };
    let one_point: usize = [
        Method::Value,
        Method::Gradient,
        Method::Hessian,
        Method::Psi,
        Method::All,
        Method::DiscreteGradientDefect,
    ]
    .iter()
    .map(|&m| system.program(m).ops.len())
    .sum();
    let pair = system.program(Method::DiscreteGradient);
    one_point
        + pair
            .prune(|o| matches!(o, Output::DiscreteGradient(_)))
            .ops
            .len()
        + pair.prune(|o| o == Output::EnergyDifference).ops.len()
}

/// The median of 9 runs of `f`.
fn median(mut f: impl FnMut()) -> Duration {
    let mut times: Vec<Duration> = (0..9)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2]
}

/// What `hamiltonian!` does for a lattice that loops: compile once per summand and emit the
/// implementation; the operations of the loop bodies and the bytes of the emitted code.
fn expand_looped(src: &str) -> (usize, usize) {
    let l = match looped::compile(src, &["alpha"]) {
        Ok(l) => l,
        Err(e) => panic!("the chain must loop: {e}"),
    };
    let name = Ident::new("Fput", Span::call_site());
    let params = [Ident::new("alpha", Span::call_site())];
    let code = match looped_impl(&l, &name, &params) {
        Some(code) => code.to_string(),
        None => panic!("the summands fit one loop body"),
    };
    (l.ops(), code.len())
}

fn bench(c: &mut Criterion) {
    println!("| N | D | loop-body ops | emitted code (bytes) | expansion time (median of 9) |");
    println!("|---|---|---|---|---|");
    for n in [64, 512, 4096] {
        let src = fput(n);
        let (ops, bytes) = expand_looped(&src);
        let t = median(|| {
            black_box(expand_looped(black_box(&src)));
        });
        println!(
            "| {n} | {} | {ops} | {bytes} | {:.2} ms |",
            2 * n,
            t.as_secs_f64() * 1e3
        );
    }
    println!();
    println!("| N | D | ops emitted in all | ops / N | engine time (median of 9) | time / N |");
    println!("|---|---|---|---|---|---|");
    for n in SIZES {
        let src = fput(n);
        let ops = expand(&src);
        let median = median(|| {
            black_box(expand(black_box(&src)));
        });
        println!(
            "| {n} | {} | {ops} | {:.1} | {:.1} ms | {:.1} us |",
            2 * n,
            ops as f64 / n as f64,
            median.as_secs_f64() * 1e3,
            median.as_secs_f64() * 1e6 / n as f64
        );
    }
    let mut group = c.benchmark_group("indexed_expand");
    group.sample_size(10);
    for n in [64, 512] {
        let src = fput(n);
        group.bench_function(format!("fput_{n}"), |b| b.iter(|| expand(black_box(&src))));
    }
    for n in [64, 4096] {
        let src = fput(n);
        group.bench_function(format!("looped_{n}"), |b| {
            b.iter(|| expand_looped(black_box(&src)))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
