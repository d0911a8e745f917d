//! The fused value + gradient + Hessian + Psi (`Hamiltonian::derivatives`) of the reference
//! systems: `hamiltonian!`-generated vs hand-written (`dth::systems`) vs num-dual's `hessian`
//! on a closure (Psi then from its gradient and Hessian, as `psi_from` does).
//!
//! Groups are `derivatives/<system>`, functions `generated`, `hand-written` (the
//! `dth::systems` type's `derivatives`: the trait's default, which calls `value`, `gradient`
//! and `hessian` and assembles Psi), `hand-fused` (a careful fused version written here, with
//! Psi in closed form) and `num-dual`. Each
//! iteration evaluates the same 16 seeded points (inputs and outputs through `black_box`), so
//! the time per evaluation is the reported time / 16. Ratios go into `docs/performance.md`
//! from one run of `cargo bench -p dth-examples --bench derivatives -- --noplot`.

use dth::nalgebra::Const;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use dth::nalgebra::SVector;
use dth::nalgebra::{Matrix2, Matrix4, SMatrix, Vector2, Vector4};
use dth::systems as hand;
use dth::{psi_from, Derivatives, Hamiltonian};
use num_dual::{Dual2SVec64, DualNum};

// The generated systems, defined once for these benches and `tests/macro_systems.rs`.
#[path = "../../tests/systems/mod.rs"]
#[allow(dead_code)]
mod systems;

/// Evaluations per iteration.
const BATCH: usize = 16;

type X<const D: usize> = SVector<Dual2SVec64<D>, D>;

/// `BATCH` seeded points with `z_i` uniform in `[-half_widths_i, half_widths_i)` (splitmix64).
fn points<const D: usize>(seed: u64, half_widths: [f64; D]) -> Vec<SVector<f64, D>> {
    let mut s = seed;
    let mut uniform = move || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = s;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^= x >> 31;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..BATCH)
        .map(|_| SVector::from_fn(|i, _| half_widths[i] * (2.0 * uniform() - 1.0)))
        .collect()
}

/// One group: the three ways to the same four outputs. The sum of the Psi values is
/// black-boxed so no evaluation can be skipped.
fn group<const D: usize>(
    c: &mut Criterion,
    system: &str,
    zs: &[SVector<f64, D>],
    generated: &impl Hamiltonian<Const<D>>,
    hand_written: &impl Hamiltonian<Const<D>>,
    fused: Option<impl Fn(&SVector<f64, D>) -> Derivatives<Const<D>>>,
    closure: impl Fn(X<D>) -> Dual2SVec64<D>,
) {
    let mut g = c.benchmark_group(format!("derivatives/{system}"));
    if let Some(fused) = &fused {
        // A benchmark of wrong code would mean nothing: the fused version must agree with the
        // reference (to far below any error a wrong term would make).
        for z in zs {
            let (a, b) = (fused(z), hand_written.derivatives(z));
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * (1.0 + y.abs());
            assert!(
                close(a.value, b.value)
                    && close(a.psi, b.psi)
                    && a.gradient
                        .iter()
                        .zip(b.gradient.iter())
                        .all(|(x, y)| close(*x, *y))
                    && a.hessian
                        .iter()
                        .zip(b.hessian.iter())
                        .all(|(x, y)| close(*x, *y)),
                "{system}: the hand-fused derivatives disagree with dth::systems at {z}"
            );
        }
        g.bench_function("hand-fused", |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for z in zs {
                    let d = fused(black_box(z));
                    acc += black_box(d).psi;
                }
                acc
            })
        });
    }
    g.bench_function("generated", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for z in zs {
                let d = generated.derivatives(black_box(z));
                acc += black_box(d).psi;
            }
            acc
        })
    });
    g.bench_function("hand-written", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for z in zs {
                let d = hand_written.derivatives(black_box(z));
                acc += black_box(d).psi;
            }
            acc
        })
    });
    g.bench_function("num-dual", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for z in zs {
                let (value, gradient, hessian) = num_dual::hessian(&closure, black_box(z));
                let psi = psi_from(&gradient, &hessian);
                acc += black_box((value, gradient, hessian, psi)).3;
            }
            acc
        })
    });
    g.finish();
}

// Parameters of each system, shared by all three implementations.
const KEPLER: (f64, f64) = (0.7, 1.3);
const OSCILLATOR: (f64, f64) = (2.0, 3.0);
const PENDULUM: (f64, f64, f64) = (1.3, 0.7, 9.81);
const FORCED: (f64, f64, f64) = (1.3, 0.4, 0.7);

fn kepler(c: &mut Criterion) {
    let (mass, k) = KEPLER;
    group(
        c,
        "kepler",
        &points(1, [1.5, 1.5, 2.0, 2.0]),
        &systems::kepler::Kepler { mass, k },
        &hand::Kepler { mass, k },
        Some(kepler_fused),
        |z: X<4>| {
            (z[2] * z[2] + z[3] * z[3]) / (2.0 * mass)
                - (z[0] * z[0] + z[1] * z[1]).sqrt().recip() * k
        },
    );
}

fn harmonic_oscillator(c: &mut Criterion) {
    let (mass, k) = OSCILLATOR;
    group(
        c,
        "harmonic_oscillator",
        &points(2, [2.0, 2.0]),
        &systems::oscillator::HarmonicOscillator { mass, k },
        &hand::HarmonicOscillator { mass, k },
        Some(oscillator_fused),
        |z: X<2>| z[1] * z[1] / (2.0 * mass) + z[0] * z[0] * (k / 2.0),
    );
}

fn pendulum(c: &mut Criterion) {
    let (mass, length, gravity) = PENDULUM;
    group(
        c,
        "pendulum",
        &points(3, [3.0, 3.0]),
        &systems::pendulum::Pendulum {
            mass,
            length,
            gravity,
        },
        &hand::Pendulum {
            mass,
            length,
            gravity,
        },
        Some(pendulum_fused),
        |z: X<2>| {
            z[1] * z[1] / (2.0 * mass * length * length) - z[0].cos() * (mass * gravity * length)
        },
    );
}

fn henon_heiles(c: &mut Criterion) {
    group(
        c,
        "henon_heiles",
        &points(4, [0.5; 4]),
        &systems::henon_heiles::HenonHeiles,
        &hand::HenonHeiles,
        Some(henon_heiles_fused),
        |z: X<4>| {
            (z[2] * z[2] + z[3] * z[3]) * 0.5
                + (z[0] * z[0] + z[1] * z[1]) * 0.5
                + z[0] * z[0] * z[1]
                - z[1].powi(3) / 3.0
        },
    );
}

fn double_pendulum(c: &mut Criterion) {
    let (m1, m2, l1, l2, g) = (1.2, 0.8, 1.1, 0.9, 9.81);
    group(
        c,
        "double_pendulum",
        &points(5, [3.0, 3.0, 2.0, 2.0]),
        &systems::double_pendulum::DoublePendulum { m1, m2, l1, l2, g },
        &hand::DoublePendulum { m1, m2, l1, l2, g },
        None::<fn(&SVector<f64, 4>) -> Derivatives<Const<4>>>,
        |z: X<4>| {
            let d = z[0] - z[1];
            let num = z[2] * z[2] * (m2 * l2 * l2) + z[3] * z[3] * ((m1 + m2) * l1 * l1)
                - z[2] * z[3] * d.cos() * (2.0 * m2 * l1 * l2);
            let den = (d.sin() * d.sin() * m2 + m1) * (2.0 * m2 * l1 * l1 * l2 * l2);
            num / den - z[0].cos() * ((m1 + m2) * g * l1) - z[1].cos() * (m2 * g * l2)
        },
    );
}

fn toda_chain(c: &mut Criterion) {
    group(
        c,
        "toda_periodic_10",
        &points(6, [1.0; 20]),
        &systems::toda::TodaPeriodic10,
        &hand::TodaChain::<10>::new(hand::TodaBoundary::Periodic),
        Some(toda_fused),
        |z: X<20>| {
            let mut v = z[10] * z[10] * 0.5;
            for i in 11..20 {
                v += z[i] * z[i] * 0.5;
            }
            for i in 0..10 {
                v += (z[i] - z[(i + 1) % 10]).exp();
            }
            v
        },
    );
}

fn forced_oscillator(c: &mut Criterion) {
    let (omega0, force, omega) = FORCED;
    group(
        c,
        "forced_oscillator",
        &points(7, [2.0, 20.0, 2.0, 2.0]),
        &systems::forced_oscillator::ForcedOscillator {
            omega0,
            force,
            omega,
        },
        &hand::ForcedOscillator {
            omega0,
            force,
            omega,
        },
        Some(forced_fused),
        |z: X<4>| {
            z[3] + z[2] * z[2] * 0.5 + z[0] * z[0] * (0.5 * omega0 * omega0)
                - z[0] * (z[1] * omega).cos() * force
        },
    );
}

// Careful hand-written fused versions: each shared quantity (`sin_cos`, `1/r^3`, the Toda
// exponentials) computed once, Psi in closed form from the structure of the Hessian. The
// double pendulum has none: `dth::systems::DoublePendulum` is the careful version there.

fn kepler_fused(z: &SVector<f64, 4>) -> Derivatives<Const<4>> {
    let (mass, k) = KEPLER;
    let (x, y, px, py) = (z[0], z[1], z[2], z[3]);
    let im = 1.0 / mass;
    let r2 = x * x + y * y;
    let r = r2.sqrt();
    let kr3 = k / (r2 * r);
    let kr5 = 3.0 * kr3 / r2;
    let (hxx, hxy, hyy) = (kr3 - kr5 * x * x, -kr5 * x * y, kr3 - kr5 * y * y);
    let (vx, vy, fx, fy) = (px * im, py * im, kr3 * x, kr3 * y);
    Derivatives {
        value: 0.5 * im * (px * px + py * py) - k / r,
        gradient: Vector4::new(fx, fy, vx, vy),
        hessian: Matrix4::new(
            hxx, hxy, 0.0, 0.0, hxy, hyy, 0.0, 0.0, 0.0, 0.0, im, 0.0, 0.0, 0.0, 0.0, im,
        ),
        psi: hxx * vx * vx + 2.0 * hxy * vx * vy + hyy * vy * vy + im * (fx * fx + fy * fy),
    }
}

fn oscillator_fused(z: &SVector<f64, 2>) -> Derivatives<Const<2>> {
    let (mass, k) = OSCILLATOR;
    let im = 1.0 / mass;
    let (v, f) = (z[1] * im, k * z[0]);
    Derivatives {
        value: 0.5 * (z[1] * v + f * z[0]),
        gradient: Vector2::new(f, v),
        hessian: Matrix2::new(k, 0.0, 0.0, im),
        psi: k * v * v + im * f * f,
    }
}

fn pendulum_fused(z: &SVector<f64, 2>) -> Derivatives<Const<2>> {
    let (mass, length, gravity) = PENDULUM;
    let (ii, mgl) = (1.0 / (mass * length * length), mass * gravity * length);
    let (s, c) = z[0].sin_cos();
    let (v, f, hqq) = (z[1] * ii, mgl * s, mgl * c);
    Derivatives {
        value: 0.5 * z[1] * v - hqq,
        gradient: Vector2::new(f, v),
        hessian: Matrix2::new(hqq, 0.0, 0.0, ii),
        psi: hqq * v * v + ii * f * f,
    }
}

fn henon_heiles_fused(z: &SVector<f64, 4>) -> Derivatives<Const<4>> {
    let (q1, q2, p1, p2) = (z[0], z[1], z[2], z[3]);
    let (g0, g1) = (q1 + 2.0 * q1 * q2, q2 + q1 * q1 - q2 * q2);
    let (h00, h01, h11) = (1.0 + 2.0 * q2, 2.0 * q1, 1.0 - 2.0 * q2);
    Derivatives {
        value: 0.5 * (p1 * p1 + p2 * p2 + q1 * q1 + q2 * q2) + q1 * q1 * q2 - q2 * q2 * q2 / 3.0,
        gradient: Vector4::new(g0, g1, p1, p2),
        hessian: Matrix4::new(
            h00, h01, 0.0, 0.0, h01, h11, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ),
        psi: h00 * p1 * p1 + 2.0 * h01 * p1 * p2 + h11 * p2 * p2 + g0 * g0 + g1 * g1,
    }
}

fn toda_fused(z: &SVector<f64, 20>) -> Derivatives<Const<20>> {
    const N: usize = 10;
    // e[i] = exp(q_i - q_{i+1}), periodic.
    let e: [f64; N] = std::array::from_fn(|i| (z[i] - z[(i + 1) % N]).exp());
    let mut gradient = SVector::<f64, 20>::zeros();
    let mut hessian = SMatrix::<f64, 20, 20>::zeros();
    let (mut value, mut psi) = (0.0, 0.0);
    for i in 0..N {
        let (j, prev) = ((i + 1) % N, (i + N - 1) % N);
        let p = z[N + i];
        value += 0.5 * p * p + e[i];
        gradient[i] = e[i] - e[prev];
        gradient[N + i] = p;
        hessian[(i, i)] = e[i] + e[prev];
        hessian[(i, j)] = -e[i];
        hessian[(j, i)] = -e[i];
        hessian[(N + i, N + i)] = 1.0;
        // w = (p, -g_q): Psi = sum H_ii p_i^2 + 2 sum H_{i,i+1} p_i p_{i+1} + |g_q|^2.
        psi += hessian[(i, i)] * p * p - 2.0 * e[i] * p * z[N + j] + gradient[i] * gradient[i];
    }
    Derivatives {
        value,
        gradient,
        hessian,
        psi,
    }
}

fn forced_fused(z: &SVector<f64, 4>) -> Derivatives<Const<4>> {
    let (omega0, force, omega) = FORCED;
    let (q, t, p, pt) = (z[0], z[1], z[2], z[3]);
    let (s, c) = (omega * t).sin_cos();
    let w2 = omega0 * omega0;
    let fc = force * c;
    let (g0, qt, tt) = (
        w2 * q - fc,
        force * omega * s,
        force * omega * omega * q * c,
    );
    Derivatives {
        value: pt + 0.5 * (p * p + w2 * q * q) - fc * q,
        gradient: Vector4::new(g0, qt * q, p, 1.0),
        hessian: Matrix4::new(
            w2, qt, 0.0, 0.0, qt, tt, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ),
        // w = J g = (p, 1, -g0, -g_t).
        psi: w2 * p * p + 2.0 * qt * p + tt + g0 * g0,
    }
}

/// Short windows: the machine has 2 cores shared with other builds; 20 samples over 4 s per
/// function keep the whole run near two minutes while each estimate covers ~10^6-10^8
/// evaluations (long enough to average over the load of the shared machine).
fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(4))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = kepler, harmonic_oscillator, pendulum, henon_heiles, double_pendulum,
        toda_chain, forced_oscillator
}
criterion_main!(benches);
