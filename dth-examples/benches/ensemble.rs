//! Ensemble scenes on 1 and 2 threads, side by side in one run: the speed-up of rayon over the
//! members (`docs/performance.md`, "Ensembles: threads and MPI ranks").
//!
//! Groups `ensemble/<members>` for 64 and 1,024 members: Henon-Heiles at E = 1/8, a square grid
//! of starts on the shell (all feasible), DTH with `dtau = 0.1` to t = 200 with MEGNO alongside
//! (the layout of `scenes/henon-heiles-chaos.toml`), each iteration a full `run_scene` into a
//! temporary folder (files written, as `dth run` does).
//!
//! Run with `cargo bench -p dth-examples --bench ensemble -- --noplot` (add `--quick` for a
//! smoke run).

use criterion::{criterion_group, criterion_main, Criterion};
use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::RunOptions;

fn scene(side: usize) -> String {
    format!(
        "[system]\nname = \"henon_heiles\"\n[initial]\nq = [0.0, 0.0]\np = [0.0, 0.0]\n\
         [ensemble]\nkind = \"grid\"\nx = \"q2\"\nx_range = [-0.3, 0.4]\nx_count = {side}\n\
         y = \"p2\"\ny_range = [-0.3, 0.3]\ny_count = {side}\nenergy = 0.125\nsolve = \"p1\"\n\
         chaos = \"megno\"\n[[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\ntime = 200.0\n"
    )
}

fn bench(c: &mut Criterion) {
    let catalogue = Catalogue::builtin();
    let dir = tempfile::tempdir().expect("a temporary folder");
    for side in [8, 32] {
        let text = scene(side);
        let mut group = c.benchmark_group(format!("ensemble/{}", side * side));
        group.sample_size(10);
        for threads in [1, 2] {
            let options = RunOptions::default()
                .with_progress(false)
                .with_threads(threads);
            let out = dir.path().join(format!("{side}-{threads}"));
            group.bench_function(format!("threads_{threads}"), |b| {
                b.iter(|| {
                    dth_examples::run_scene(&text, "bench.toml", &catalogue, &out, &options)
                        .expect("the ensemble runs")
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
