//! Cost of one step: DTH (joint and nested Newton) against one implicit-midpoint step and one
//! fused derivative evaluation (`Hamiltonian::derivatives`, the floor: every Newton iteration
//! evaluates it once), on the thesis Kepler orbit and on a 10-particle Toda chain (10 DOF).
//!
//! Groups `step/<system>`; each group benches the four on the same 64 states, taken at seeded
//! pseudo-random steps along a DTH run (so pericenter and apocenter both count), and the
//! midpoint step uses DTH's mean time step there (25 points per orbit on Kepler). Both Newton
//! solvers iterate to roundoff: DTH to a scaled residual of 64 eps, the midpoint rule until
//! its updates stop shrinking below 1024 eps; neither has a looser user tolerance.
//!
//! Where the default energy residual is the cancellation-free one (Kepler: exact divided
//! differences), `dth_joint_plain` is the same step with the plain residual.
//!
//! Before benching, the mean Newton iterations per step on those states are printed.
//!
//! Run with `cargo bench -p dth-examples --bench step_cost -- --noplot` (one process, so the
//! ratios come from one machine state; add `--quick` for a smoke run).

use dth::nalgebra::Const;
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use dth::dth::{Dth, DthOptions, EnergyResidual, Solver};
use dth::methods::{ImplicitMidpoint, OneStepMethod};
use dth::nalgebra::{SVector, Vector4};
use dth::systems::{Kepler, TodaBoundary, TodaChain};
use dth::Hamiltonian;
use dth_examples::ensemble::sample::SplitMix64;

const STATES: usize = 64;

/// 64 DTH steppers at seeded steps among the first `span` steps from `z0`, and the mean time
/// step `dtau * mean lambda` over those `span` steps.
fn states<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    h: &H,
    z0: SVector<f64, D>,
    options: DthOptions,
    span: usize,
    seed: u64,
) -> (Vec<Dth<H, Const<D>>>, f64) {
    let mut rng = SplitMix64::new(seed);
    let mut at: Vec<usize> = (0..STATES)
        .map(|_| (rng.next_u64() % span as u64) as usize)
        .collect();
    at.sort_unstable();
    let mut dth = Dth::new(h.clone(), z0, options).expect("valid initial state");
    let mut out = Vec::with_capacity(STATES);
    for k in at {
        while dth.k() < k {
            dth.step().expect("DTH step on the benchmark orbit");
        }
        out.push(dth.clone());
    }
    while dth.k() < span {
        dth.step().expect("DTH step on the benchmark orbit");
    }
    let mean_dt = dth.tbar() / span as f64;
    (out, mean_dt)
}

/// Mean Newton iterations per step from each state (joint: iterations; nested: LU
/// factorizations, inner and outer).
fn mean_iterations<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    states: &[Dth<H, Const<D>>],
) -> f64 {
    let total: u32 = states
        .iter()
        .map(|d| d.clone().step().map_or(0, |r| r.factorizations))
        .sum();
    f64::from(total) / states.len() as f64
}

fn group<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    c: &mut Criterion,
    system: &str,
    states: &[Dth<H, Const<D>>],
    dt: f64,
) {
    let nested: Vec<Dth<H, Const<D>>> = states
        .iter()
        .map(|d| with_solver(d, Solver::Nested))
        .collect();
    // Where the default residual is the cancellation-free one (exact divided differences), also
    // the plain residual: what the cancellation-free form costs.
    let plain: Vec<Dth<H, Const<D>>> = if states[0].cancellation_free() {
        states
            .iter()
            .map(|d| with_options(d, d.options().with_energy_residual(EnergyResidual::Plain)))
            .collect()
    } else {
        Vec::new()
    };
    let h = states[0].hamiltonian().clone();
    let zs: Vec<SVector<f64, D>> = states.iter().map(|d| *d.zbar()).collect();

    let mut midpoint = ImplicitMidpoint::new();
    for z in &zs {
        let _ = midpoint.step(&h, z, dt);
    }
    let midpoint_iterations =
        OneStepMethod::<Const<D>, H>::newton_iterations(&midpoint) as f64 / zs.len() as f64;
    eprintln!(
        "{system}: Newton iterations per step over {} states: dth_joint {:.2}{}, dth_nested {:.2} \
         (LU factorizations), midpoint {:.2}; mean dt {dt:.4}",
        zs.len(),
        mean_iterations(states),
        if plain.is_empty() {
            String::new()
        } else {
            format!(" (plain residual {:.2})", mean_iterations(&plain))
        },
        mean_iterations(&nested),
        midpoint_iterations,
    );

    let mut g = c.benchmark_group(format!("step/{system}"));
    for (name, set) in [
        ("dth_joint", states),
        ("dth_nested", &nested[..]),
        ("dth_joint_plain", &plain[..]),
    ] {
        if set.is_empty() {
            continue;
        }
        let mut i = 0;
        g.bench_function(name, |b| {
            b.iter_batched(
                || {
                    i = (i + 1) % set.len();
                    set[i].clone()
                },
                |mut d| black_box(d.step().map(|r| r.dth.map(|s| s.lambda))),
                BatchSize::SmallInput,
            )
        });
    }
    let mut i = 0;
    g.bench_function("midpoint", |b| {
        let mut m = ImplicitMidpoint::new();
        b.iter(|| {
            i = (i + 1) % zs.len();
            black_box(m.step(&h, black_box(&zs[i]), dt).map(|z| z[0]))
        })
    });
    let mut i = 0;
    g.bench_function("derivatives", |b| {
        b.iter(|| {
            i = (i + 1) % zs.len();
            black_box(h.derivatives(black_box(&zs[i])).psi)
        })
    });
    g.finish();
}

/// The same stepper state with another solver.
fn with_solver<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    d: &Dth<H, Const<D>>,
    solver: Solver,
) -> Dth<H, Const<D>> {
    with_options(d, d.options().with_solver(solver))
}

/// The same stepper state (midpoint, lambda, time) with other options.
fn with_options<H: Hamiltonian<Const<D>> + Clone, const D: usize>(
    d: &Dth<H, Const<D>>,
    options: DthOptions,
) -> Dth<H, Const<D>> {
    let options = options
        .with_lambda0(d.lambda())
        .expect("lambda of a DTH run is positive");
    Dth::new(d.hamiltonian().clone(), *d.zbar(), options)
        .and_then(|s| s.with_tbar0(d.tbar()))
        .expect("state from a DTH run")
}

fn kepler(c: &mut Criterion) {
    // Thesis settings: dtau = 0.06277, lambda_0 = 1, 25 points per orbit; 100 steps = 4 orbits.
    let (states, dt) = states(
        &Kepler::thesis(),
        Vector4::new(0.5, 0.0, 0.0, 1.2),
        DthOptions::thesis_kepler(),
        100,
        0x5EED_0001,
    );
    group(c, "kepler", &states, dt);
}

fn toda(c: &mut Criterion) {
    // 10 particles between fixed walls (10 DOF, D = 20), seeded displacements and momenta.
    let toda = TodaChain::<10>::new(TodaBoundary::FixedEnds);
    let mut rng = SplitMix64::new(0x5EED_0002);
    let z0 = SVector::<f64, 20>::from_fn(|i, _| {
        if i < 10 {
            rng.unit() - 0.5
        } else {
            2.0 * rng.unit() - 1.0
        }
    });
    let options = DthOptions::new(0.05).expect("positive step");
    let (states, dt) = states(&toda, z0, options, 400, 0x5EED_0003);
    group(c, "toda10", &states, dt);
}

criterion_group!(benches, kepler, toda);
criterion_main!(benches);
