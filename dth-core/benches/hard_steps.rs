//! Cost of the hard-cases machinery per step: plain vs cancellation-free energy residual on the
//! thesis Kepler orbit, and the robust mode on Kepler e = 0.9 (mostly fallback steps) against
//! plain DTH steps. Each group times 1,000 steps; compare within a group.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use dth_core::dth::{Dth, DthOptions, EnergyResidual};
use dth_core::nalgebra::Vector4;
use dth_core::systems::Kepler;
use std::hint::black_box;

fn residuals(c: &mut Criterion) {
    let mut g = c.benchmark_group("dth_1000_steps/kepler_thesis");
    for (name, residual) in [
        ("plain", EnergyResidual::Plain),
        ("cancellation_free", EnergyResidual::CancellationFree),
    ] {
        let options = DthOptions::thesis_kepler().with_energy_residual(residual);
        g.bench_function(name, |b| {
            b.iter_batched(
                || {
                    Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options)
                        .expect("start")
                },
                |mut dth| {
                    dth.advance(1_000).expect("run");
                    black_box(dth.zbar()[0])
                },
                BatchSize::SmallInput,
            )
        });
    }
    g.finish();
}

fn robust(c: &mut Criterion) {
    let mut g = c.benchmark_group("dth_1000_steps/kepler_e09_robust");
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt());
    let options = DthOptions::new(0.0157).expect("valid").with_robust(true);
    g.bench_function("robust", |b| {
        b.iter_batched(
            || Dth::new(Kepler::thesis(), z0, options).expect("start"),
            |mut dth| {
                dth.advance(1_000).expect("run");
                black_box(dth.zbar()[0])
            },
            BatchSize::SmallInput,
        )
    });
    g.finish();
}

criterion_group!(benches, residuals, robust);
criterion_main!(benches);
