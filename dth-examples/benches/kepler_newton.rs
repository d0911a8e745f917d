//! Small-`D` Newton cost, side by side in one process: the thesis Kepler orbit at the thesis
//! settings (`m = 1/2`, `k = 1`, `zbar_0 = (0.5, 0, 0, 1.2)`, `dtau = 0.06277`,
//! `lambda_0 = 1`: 25 points per orbit, mean `dt` 0.150), 1,000 steps (40 orbits) from
//! `zbar_0`, nothing stored:
//! - `dth`: the library's DTH stepper (joint Newton, cancellation-free energy residual,
//!   breakdown checks, projection);
//! - `midpoint`: the library's implicit midpoint rule at `dt = 0.15`;
//! - `naive_dth`: a plain joint-Newton DTH written here in a few lines: Euler predictor from
//!   the left vertex, the plain residual `(z - v - (h/2) lambda J grad H, H(z) - E)`, Kepler's
//!   derivatives by hand, a fresh dense 5 x 5 LU (nalgebra) per iteration, stop when the
//!   update is below `1e-12` relative or after 20 iterations. No breakdown check, no typed
//!   errors, `lambda` only to the plain residual's noise `eps / dtau^2`.
//!
//! Before benching, the Newton iterations and LU factorizations per step of each are printed.
//! Run with `cargo bench -p dth-examples --bench kepler_newton -- --noplot` (add `--quick` for
//! a smoke run); the ratios are the figures of `docs/performance.md` ("Step cost: DTH against
//! the implicit midpoint rule").

use dth::nalgebra::Const;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use dth::dth::{Dth, DthOptions};
use dth::methods::{ImplicitMidpoint, OneStepMethod};
use dth::nalgebra::{Matrix4, Matrix5, Vector4, Vector5};
use dth::systems::Kepler;
use dth::Hamiltonian;

const STEPS: usize = 1_000;
const MIDPOINT_DT: f64 = 0.15;
/// The naive solver's stop: relative updates below `1e-12`. (It cannot ask for `4 eps`: the
/// plain residual's roundoff moves `lambda` by about `eps / dtau^2 ~ 6e-14` relative, so its
/// updates never settle below that and a `4 eps` stop runs to the iteration limit.)
const TOLERANCE: f64 = 1e-12;

fn z0() -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, 1.2)
}

/// The naive joint-Newton DTH: hand-written Kepler (`H = |p|^2 - 1/|q|`).
struct Naive {
    zbar: Vector4<f64>,
    lambda: f64,
    energy: f64,
    h: f64,
    iterations: usize,
    factorizations: usize,
}

fn value(z: &Vector4<f64>) -> f64 {
    z[2] * z[2] + z[3] * z[3] - 1.0 / (z[0] * z[0] + z[1] * z[1]).sqrt()
}

fn gradient(z: &Vector4<f64>) -> Vector4<f64> {
    let r2 = z[0] * z[0] + z[1] * z[1];
    let r3 = r2 * r2.sqrt();
    Vector4::new(z[0] / r3, z[1] / r3, 2.0 * z[2], 2.0 * z[3])
}

fn hessian(z: &Vector4<f64>) -> Matrix4<f64> {
    let r2 = z[0] * z[0] + z[1] * z[1];
    let r3 = r2 * r2.sqrt();
    let r5 = r3 * r2;
    let mut m = Matrix4::zeros();
    m[(0, 0)] = 1.0 / r3 - 3.0 * z[0] * z[0] / r5;
    m[(1, 1)] = 1.0 / r3 - 3.0 * z[1] * z[1] / r5;
    m[(0, 1)] = -3.0 * z[0] * z[1] / r5;
    m[(1, 0)] = m[(0, 1)];
    m[(2, 2)] = 2.0;
    m[(3, 3)] = 2.0;
    m
}

fn j(v: &Vector4<f64>) -> Vector4<f64> {
    Vector4::new(v[2], v[3], -v[0], -v[1])
}

impl Naive {
    fn new(zbar: Vector4<f64>, h: f64) -> Self {
        Naive {
            zbar,
            lambda: 1.0,
            energy: value(&zbar),
            h,
            iterations: 0,
            factorizations: 0,
        }
    }

    fn step(&mut self) -> Option<()> {
        let half = 0.5 * self.h;
        let v = self.zbar + j(&gradient(&self.zbar)) * (half * self.lambda);
        // Euler predictor from the vertex, lambda from the last step.
        let mut z = v + j(&gradient(&v)) * (half * self.lambda);
        let mut lambda = self.lambda;
        for _ in 0..20 {
            let g = gradient(&z);
            let jg = j(&g);
            let f = z - v - jg * (half * lambda);
            let r = value(&z) - self.energy;
            let hess = hessian(&z);
            let mut a = Matrix5::zeros();
            for i in 0..4 {
                // Row i of J Hess.
                let row = if i < 2 { i + 2 } else { i - 2 };
                let sign = if i < 2 { 1.0 } else { -1.0 };
                for c in 0..4 {
                    a[(i, c)] = f64::from(u8::from(i == c)) - half * lambda * sign * hess[(row, c)];
                }
                a[(i, 4)] = -half * jg[i];
                a[(4, i)] = g[i];
            }
            let rhs = -Vector5::new(f[0], f[1], f[2], f[3], r);
            self.iterations += 1;
            self.factorizations += 1;
            let d = a.lu().solve(&rhs)?;
            let dz = Vector4::new(d[0], d[1], d[2], d[3]);
            z += dz;
            lambda += d[4];
            if dz.amax() <= TOLERANCE * z.amax() && d[4].abs() <= TOLERANCE * lambda {
                break;
            }
        }
        self.zbar = z;
        self.lambda = lambda;
        Some(())
    }
}

fn counts() {
    let mut dth = Dth::new(Kepler::thesis(), z0(), DthOptions::thesis_kepler()).expect("start");
    let (mut it, mut lu) = (0u64, 0u64);
    let mut worst = 0.0f64;
    let e0 = Kepler::thesis().value(&z0());
    for _ in 0..STEPS {
        let r = dth.step().expect("DTH step");
        it += u64::from(r.iterations);
        lu += u64::from(r.factorizations);
        worst = worst.max((Kepler::thesis().value(dth.zbar()) - e0).abs());
    }
    let mut naive = Naive::new(z0(), DthOptions::thesis_kepler().dtau());
    let mut naive_worst = 0.0f64;
    for _ in 0..STEPS {
        naive.step().expect("naive step");
        naive_worst = naive_worst.max((value(&naive.zbar) - e0).abs());
    }
    let mut midpoint = ImplicitMidpoint::new();
    let mut z = z0();
    for _ in 0..STEPS {
        z = midpoint
            .step(&Kepler::thesis(), &z, MIDPOINT_DT)
            .expect("midpoint step");
    }
    let n = STEPS as f64;
    println!(
        "kepler thesis, {STEPS} steps: dth {:.2} iterations, {:.2} LU factorizations per step \
         (energy error at the midpoints {worst:.1e}, mean dt {:.4}); naive_dth {:.2} iterations, {:.2} \
         LU factorizations per step (energy error {naive_worst:.1e}); midpoint {:.2} \
         iterations = LU factorizations per step",
        it as f64 / n,
        lu as f64 / n,
        dth.tbar() / n,
        naive.iterations as f64 / n,
        naive.factorizations as f64 / n,
        OneStepMethod::<Const<4>, Kepler>::newton_iterations(&midpoint) as f64 / n,
    );
}

fn kepler(c: &mut Criterion) {
    counts();
    let start = Dth::new(Kepler::thesis(), z0(), DthOptions::thesis_kepler()).expect("start");
    let mut g = c.benchmark_group("kepler_newton/thesis");
    g.bench_function("dth", |b| {
        b.iter_batched(
            || start.clone(),
            |mut d| {
                d.advance(STEPS).expect("DTH steps");
                black_box(d.lambda())
            },
            BatchSize::SmallInput,
        )
    });
    g.bench_function("midpoint", |b| {
        b.iter(|| {
            let mut m = ImplicitMidpoint::new();
            let mut z = black_box(z0());
            for _ in 0..STEPS {
                z = m
                    .step(&Kepler::thesis(), &z, MIDPOINT_DT)
                    .expect("midpoint step");
            }
            black_box(z[0])
        })
    });
    let dtau = DthOptions::thesis_kepler().dtau();
    g.bench_function("naive_dth", |b| {
        b.iter(|| {
            let mut n = Naive::new(black_box(z0()), dtau);
            for _ in 0..STEPS {
                n.step().expect("naive step");
            }
            black_box(n.lambda)
        })
    });
    g.finish();
}

/// Short windows (2 shared cores).
fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .sample_size(30)
}

criterion_group! {
    name = benches;
    config = config();
    targets = kepler
}
criterion_main!(benches);
