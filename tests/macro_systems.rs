//! `hamiltonian!` against the hand-written reference systems of `dth::systems`, which have
//! analytic derivatives (checked against num-dual in `dth-core`): value, gradient, Hessian,
//! Psi and the fused `derivatives`, at many seeded random points and parameter values, to
//! roundoff; and the flags `SEPARABLE`, `TIME_DEPENDENT`, `PSI_IDENTICALLY_ZERO`.
//!
//! # Tolerance
//! Both sides compute the same exact derivative in floating point, in different orders. An
//! entry evaluated in `k` roundings, each on a quantity bounded by `S` (the sum of the
//! absolute values of the terms involved: what cancellation cannot shrink), is off by at
//! most about `k eps/2 S` (the standard bound `gamma_k` for sums of products; `sin`, `cos`,
//! `exp` add at most an ulp of their value, a term of `S`). The two sides together: `|a - b| <=
//! ulps eps S`, `ulps` the number of roundings on both sides, counted per system below. `S`
//! is written out per system (`Scales`) from the formulas with absolute values. An entry
//! whose scale is 0 is structurally zero and must be exactly `0.0` on both sides.
//!
//! Psi = `w^T Hess w`, `w = J grad H`, inherits the entry errors, `sum_ij (dH_ij |w_i w_j| +
//! |H_ij| (dw_i |w_j| + |w_i| dw_j))`, and adds its own summation: the hand-written default
//! (`Hess w`, then a dot product) rounds about `2D` times, the generated sum about once per
//! nonzero upper-triangle entry (`nnz`), each relative to `sum |H_ij w_i w_j|`. So Psi gets
//! `(ulps + 2D + nnz) eps S_psi` with `S_psi` the first sum written with the scales.

use dth::nalgebra::Const;
mod systems;

use dth::nalgebra::{SMatrix, SVector};
use dth::systems as hand;
use dth::Hamiltonian;

/// The size of the terms each entry is computed from (see the module docs).
struct Scales<const D: usize> {
    value: f64,
    gradient: SVector<f64, D>,
    hessian: SMatrix<f64, D, D>,
}

/// A deterministic generator (splitmix64): seeded points, no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = self.0;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^ (x >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// A point with `z_i` uniform in `[-box_i, box_i)`.
    fn point<const D: usize>(&mut self, half_widths: [f64; D]) -> SVector<f64, D> {
        SVector::from_fn(|i, _| self.uniform(-half_widths[i], half_widths[i]))
    }
}

/// How many points each system is checked at (split over the parameter sets).
const POINTS: usize = 600;

/// The largest error seen, in units of `eps * scale`, so a failure says by how much.
fn ratio(a: f64, b: f64, scale: f64) -> f64 {
    if scale == 0.0 {
        return if a == 0.0 && b == 0.0 {
            0.0
        } else {
            f64::INFINITY
        };
    }
    (a - b).abs() / (f64::EPSILON * scale)
}

/// Compares every method of `generated` with `reference` at `z`; returns the largest error
/// seen in ulps of the scale (entries and Psi), for the caller's report.
fn compare<const D: usize, G: Hamiltonian<Const<D>>, R: Hamiltonian<Const<D>>>(
    name: &str,
    generated: &G,
    reference: &R,
    z: &SVector<f64, D>,
    s: &Scales<D>,
    ulps: f64,
) -> f64 {
    let (gen, refd) = (generated.derivatives(z), reference.derivatives(z));
    let separate = (
        generated.value(z),
        generated.gradient(z),
        generated.hessian(z),
        generated.psi(z),
    );
    let mut worst: f64 = 0.0;
    let mut check = |what: String, a: f64, b: f64, scale: f64, ulps: f64| {
        let r = ratio(a, b, scale);
        assert!(
            r <= ulps,
            "{name}: {what} at z = {z:?}: generated {a:e}, hand-written {b:e}, \
             difference {:e} = {r:.1} eps * scale {scale:e} (allowed {ulps})",
            (a - b).abs()
        );
        worst = worst.max(r);
    };
    for (label, v) in [("value", gen.value), ("value()", separate.0)] {
        check(label.into(), v, refd.value, s.value, ulps);
    }
    for i in 0..D {
        for (label, g) in [("gradient", gen.gradient[i]), ("gradient()", separate.1[i])] {
            check(
                format!("{label}[{i}]"),
                g,
                refd.gradient[i],
                s.gradient[i],
                ulps,
            );
        }
        for j in 0..D {
            for (label, h) in [
                ("hessian", gen.hessian[(i, j)]),
                ("hessian()", separate.2[(i, j)]),
            ] {
                let scale = s.hessian[(i, j)];
                check(
                    format!("{label}[{i},{j}]"),
                    h,
                    refd.hessian[(i, j)],
                    scale,
                    ulps,
                );
            }
        }
    }
    // Psi's scale from the entry scales and w = J grad H (module docs).
    let w = dth::j_times(&refd.gradient);
    let sw = dth::j_times(&s.gradient).abs();
    let mut s_psi = 0.0;
    let mut nnz = 0;
    for i in 0..D {
        for j in 0..D {
            let h = refd.hessian[(i, j)].abs();
            s_psi += s.hessian[(i, j)] * (w[i] * w[j]).abs()
                + h * (sw[i] * w[j].abs())
                + h * (w[i].abs() * sw[j]);
            if j >= i && s.hessian[(i, j)] != 0.0 {
                nnz += 1;
            }
        }
    }
    let psi_ulps = ulps + (2 * D + nnz) as f64;
    for (label, p) in [("psi", gen.psi), ("psi()", separate.3)] {
        check(label.into(), p, refd.psi, s_psi, psi_ulps);
    }
    worst
}

/// `(TIME_DEPENDENT, SEPARABLE, PSI_IDENTICALLY_ZERO)`.
fn flags<const D: usize, H: Hamiltonian<Const<D>>>(h: &H) -> (bool, bool, bool) {
    let f = h.flags();
    (f.time_dependent, f.separable, f.psi_identically_zero)
}

#[test]
fn kepler() {
    // Entries take at most ~6 roundings per side (r^2, 1/r^2, sqrt, k*, products, one sum).
    const ULPS: f64 = 16.0;
    let mut rng = Rng(1);
    let mut worst: f64 = 0.0;
    for _ in 0..4 {
        let (mass, k) = (rng.uniform(0.2, 3.0), rng.uniform(0.2, 3.0));
        let (gen, refh) = (
            systems::kepler::Kepler { mass, k },
            hand::Kepler { mass, k },
        );
        assert_eq!(flags(&gen), flags(&refh));
        for _ in 0..POINTS / 4 {
            let z = loop {
                let z = rng.point([1.5, 1.5, 2.0, 2.0]);
                if z[0].hypot(z[1]) > 0.05 {
                    break z;
                }
            };
            let (q, p) = ([z[0], z[1]], [z[2], z[3]]);
            let r2 = q[0] * q[0] + q[1] * q[1];
            let r = r2.sqrt();
            let kr3 = k / (r2 * r);
            let mut s = Scales {
                value: (p[0] * p[0] + p[1] * p[1]) / (2.0 * mass) + k / r,
                gradient: SVector::<f64, 4>::new(
                    kr3 * q[0].abs(),
                    kr3 * q[1].abs(),
                    p[0].abs() / mass,
                    p[1].abs() / mass,
                ),
                hessian: SMatrix::zeros(),
            };
            for i in 0..2 {
                for j in 0..2 {
                    s.hessian[(i, j)] = kr3 + 3.0 * kr3 * (q[i] * q[j]).abs() / r2;
                }
                s.hessian[(i + 2, i + 2)] = 1.0 / mass;
            }
            worst = worst.max(compare("kepler", &gen, &refh, &z, &s, ULPS));
        }
    }
    eprintln!("kepler: largest difference {worst:.2} eps * scale (allowed {ULPS})");
}

#[test]
fn harmonic_oscillator() {
    // Two or three roundings per entry and side (a product and a division or sum).
    const ULPS: f64 = 8.0;
    let mut rng = Rng(2);
    let mut worst: f64 = 0.0;
    for _ in 0..4 {
        let (mass, k) = (rng.uniform(0.2, 3.0), rng.uniform(0.2, 3.0));
        let gen = systems::oscillator::HarmonicOscillator { mass, k };
        let refh = hand::HarmonicOscillator { mass, k };
        assert_eq!(flags(&gen), flags(&refh));
        for _ in 0..POINTS / 4 {
            let z = rng.point([2.0, 2.0]);
            let s = Scales {
                value: z[1] * z[1] / (2.0 * mass) + k * z[0] * z[0] / 2.0,
                gradient: SVector::<f64, 2>::new(k * z[0].abs(), z[1].abs() / mass),
                hessian: SMatrix::<f64, 2, 2>::new(k, 0.0, 0.0, 1.0 / mass),
            };
            worst = worst.max(compare("harmonic oscillator", &gen, &refh, &z, &s, ULPS));
        }
    }
    eprintln!("harmonic_oscillator: largest difference {worst:.2} eps * scale (allowed {ULPS})");
}

#[test]
fn pendulum() {
    // m l^2, m g l (two roundings each, in another order on each side), a division or product,
    // `cos`/`sin` (one ulp), one sum.
    const ULPS: f64 = 12.0;
    let mut rng = Rng(3);
    let mut worst: f64 = 0.0;
    for _ in 0..4 {
        let (mass, length, gravity) = (
            rng.uniform(0.2, 3.0),
            rng.uniform(0.2, 3.0),
            rng.uniform(1.0, 10.0),
        );
        let gen = systems::pendulum::Pendulum {
            mass,
            length,
            gravity,
        };
        let refh = hand::Pendulum {
            mass,
            length,
            gravity,
        };
        assert_eq!(flags(&gen), flags(&refh));
        let (inertia, mgl) = (mass * length * length, mass * gravity * length);
        for _ in 0..POINTS / 4 {
            let z = rng.point([4.0, 3.0]);
            let (sin, cos) = z[0].sin_cos();
            let s = Scales {
                value: z[1] * z[1] / (2.0 * inertia) + mgl * cos.abs(),
                gradient: SVector::<f64, 2>::new(mgl * sin.abs(), z[1].abs() / inertia),
                hessian: SMatrix::<f64, 2, 2>::new(mgl * cos.abs(), 0.0, 0.0, 1.0 / inertia),
            };
            worst = worst.max(compare("pendulum", &gen, &refh, &z, &s, ULPS));
        }
    }
    eprintln!("pendulum: largest difference {worst:.2} eps * scale (allowed {ULPS})");
}

#[test]
fn henon_heiles() {
    // At most ~8 roundings per side for the value (squares, a cube, /3, four sums).
    const ULPS: f64 = 16.0;
    let (gen, refh) = (systems::henon_heiles::HenonHeiles, hand::HenonHeiles);
    assert_eq!(flags(&gen), flags(&refh));
    let mut rng = Rng(4);
    let mut worst: f64 = 0.0;
    for _ in 0..POINTS {
        let z = rng.point([1.5, 1.5, 1.5, 1.5]);
        let (q1, q2, p1, p2) = (z[0], z[1], z[2], z[3]);
        let mut s = Scales {
            value: (p1 * p1 + p2 * p2) / 2.0
                + (q1 * q1 + q2 * q2) / 2.0
                + q1 * q1 * q2.abs()
                + (q2 * q2 * q2).abs() / 3.0,
            gradient: SVector::<f64, 4>::new(
                q1.abs() + 2.0 * (q1 * q2).abs(),
                q2.abs() + q1 * q1 + q2 * q2,
                p1.abs(),
                p2.abs(),
            ),
            hessian: SMatrix::zeros(),
        };
        s.hessian[(0, 0)] = 1.0 + 2.0 * q2.abs();
        s.hessian[(1, 1)] = 1.0 + 2.0 * q2.abs();
        s.hessian[(0, 1)] = 2.0 * q1.abs();
        s.hessian[(1, 0)] = 2.0 * q1.abs();
        s.hessian[(2, 2)] = 1.0;
        s.hessian[(3, 3)] = 1.0;
        worst = worst.max(compare("henon-heiles", &gen, &refh, &z, &s, ULPS));
    }
    eprintln!("henon_heiles: largest difference {worst:.2} eps * scale (allowed {ULPS})");
}

#[test]
fn double_pendulum() {
    // The deepest formulas here: T = N / (K A) and its d-derivatives are quotients of sums of
    // products of parameters, momenta, sin d and cos d, up to ~20 roundings per side.
    const ULPS: f64 = 40.0;
    let mut rng = Rng(5);
    let mut worst: f64 = 0.0;
    for _ in 0..4 {
        let [m1, m2, l1, l2] = [0; 4].map(|_| rng.uniform(0.3, 2.0));
        let g = rng.uniform(1.0, 10.0);
        let gen = systems::double_pendulum::DoublePendulum { m1, m2, l1, l2, g };
        let refh = hand::DoublePendulum { m1, m2, l1, l2, g };
        assert_eq!(flags(&gen), flags(&refh));
        for _ in 0..POINTS / 4 {
            let z = rng.point([3.2, 3.2, 2.0, 2.0]);
            let (p1, p2) = (z[2].abs(), z[3].abs());
            let (sin, cos) = (z[0] - z[1]).sin_cos();
            let (b, k, a) = (
                m2 * l1 * l2,
                2.0 * m2 * l1 * l1 * l2 * l2,
                m1 + m2 * sin * sin,
            );
            let ka = k * a;
            // |N|, |N_d|, |N_dd| <= n; |dN/dp_i|, |d^2N/dp_i dd| <= np[i]; |A_d|/A, |A_dd|/A.
            let n = m2 * l2 * l2 * p1 * p1 + (m1 + m2) * l1 * l1 * p2 * p2 + 2.0 * b * p1 * p2;
            let np = [
                2.0 * m2 * l2 * l2 * p1 + 2.0 * b * p2,
                2.0 * (m1 + m2) * l1 * l1 * p2 + 2.0 * b * p1,
            ];
            let (ra, raa) = (2.0 * m2 * (sin * cos).abs() / a, 2.0 * m2 / a);
            let (v1, v2) = ((m1 + m2) * g * l1, m2 * g * l2);
            let (t_d, t_dd) = (
                n * (1.0 + ra) / ka,
                n * (1.0 + raa + 2.0 * ra * (1.0 + ra)) / ka,
            );
            let t_pd = [np[0] * (1.0 + ra) / ka, np[1] * (1.0 + ra) / ka];
            let (c1, c2) = (z[0].cos().abs(), z[1].cos().abs());
            let s = Scales {
                value: n / ka + v1 * c1 + v2 * c2,
                gradient: SVector::<f64, 4>::new(
                    t_d + v1 * z[0].sin().abs(),
                    t_d + v2 * z[1].sin().abs(),
                    np[0] / ka,
                    np[1] / ka,
                ),
                hessian: SMatrix::<f64, 4, 4>::new(
                    t_dd + v1 * c1,
                    t_dd,
                    t_pd[0],
                    t_pd[1],
                    t_dd,
                    t_dd + v2 * c2,
                    t_pd[0],
                    t_pd[1],
                    t_pd[0],
                    t_pd[0],
                    2.0 * m2 * l2 * l2 / ka,
                    2.0 * b * cos.abs() / ka,
                    t_pd[1],
                    t_pd[1],
                    2.0 * b * cos.abs() / ka,
                    2.0 * (m1 + m2) * l1 * l1 / ka,
                ),
            };
            worst = worst.max(compare("double pendulum", &gen, &refh, &z, &s, ULPS));
        }
    }
    eprintln!("double_pendulum: largest difference {worst:.2} eps * scale (allowed {ULPS})");
}

/// The Toda scales: `e_b = exp(q_i - q_j)` per bond (a wall is `None`), all positive.
fn toda_scales<const D: usize>(
    z: &SVector<f64, D>,
    bonds: &[(Option<usize>, Option<usize>)],
) -> Scales<D> {
    let n = D / 2;
    let q = |i: Option<usize>| i.map_or(0.0, |i| z[i]);
    let mut s = Scales {
        value: z.rows(n, n).norm_squared() / 2.0,
        gradient: SVector::zeros(),
        hessian: SMatrix::zeros(),
    };
    for &(i, j) in bonds {
        let e = (q(i) - q(j)).exp();
        s.value += e;
        for k in [i, j].into_iter().flatten() {
            s.gradient[k] += e;
            s.hessian[(k, k)] += e;
        }
        if let (Some(i), Some(j)) = (i, j) {
            s.hessian[(i, j)] += e;
            s.hessian[(j, i)] += e;
        }
    }
    for k in n..D {
        s.gradient[k] = z[k].abs();
        s.hessian[(k, k)] = 1.0;
    }
    s
}

#[test]
fn toda_chain_of_ten() {
    // Each q-entry sums at most 10 (value) or 2-3 (gradient, Hessian) exponentials of the same
    // differences on both sides; the value sums 20 terms: up to ~20 roundings per side.
    const ULPS: f64 = 40.0;
    let periodic = hand::TodaChain::<10>::new(hand::TodaBoundary::Periodic);
    let fixed = hand::TodaChain::<10>::new(hand::TodaBoundary::FixedEnds);
    assert_eq!(
        flags(&systems::toda::TodaPeriodic10),
        flags::<20, _>(&periodic)
    );
    assert_eq!(flags(&systems::toda::TodaFixed10), flags::<20, _>(&fixed));
    let periodic_bonds: Vec<_> = (0..10).map(|i| (Some(i), Some((i + 1) % 10))).collect();
    let mut fixed_bonds: Vec<_> = (0..9).map(|i| (Some(i), Some(i + 1))).collect();
    fixed_bonds.extend([(None, Some(0)), (Some(9), None)]);
    let mut rng = Rng(6);
    let mut worst: f64 = 0.0;
    for _ in 0..POINTS {
        let z = rng.point([1.5; 20]);
        let s = toda_scales(&z, &periodic_bonds);
        worst = worst.max(compare(
            "toda periodic",
            &systems::toda::TodaPeriodic10,
            &periodic,
            &z,
            &s,
            ULPS,
        ));
        let s = toda_scales(&z, &fixed_bonds);
        worst = worst.max(compare(
            "toda fixed ends",
            &systems::toda::TodaFixed10,
            &fixed,
            &z,
            &s,
            ULPS,
        ));
    }
    eprintln!("toda_chain_of_ten: largest difference {worst:.2} eps * scale (allowed {ULPS})");
}

#[test]
fn forced_oscillator_in_extended_phase_space() {
    // omega0^2 q (two roundings), F q cos(omega t) (omega t shared by both sides, `cos` one
    // ulp, two products), three sums with p_t: ~8 roundings per side.
    const ULPS: f64 = 16.0;
    let mut rng = Rng(7);
    let mut worst: f64 = 0.0;
    for _ in 0..4 {
        let (omega0, force, omega) = (
            rng.uniform(0.2, 3.0),
            rng.uniform(-2.0, 2.0),
            rng.uniform(0.2, 3.0),
        );
        let gen = systems::forced_oscillator::ForcedOscillator {
            omega0,
            force,
            omega,
        };
        let refh = hand::ForcedOscillator {
            omega0,
            force,
            omega,
        };
        assert_eq!(flags(&gen), flags(&refh));
        for _ in 0..POINTS / 4 {
            // z = (q, t, p, p_t)
            let z = rng.point([2.0, 20.0, 2.0, 2.0]);
            let (q, p, pt) = (z[0], z[2], z[3]);
            let (sin, cos) = (omega * z[1]).sin_cos();
            let (f, w2) = (force.abs(), omega0 * omega0);
            let mut s = Scales {
                value: pt.abs() + p * p / 2.0 + w2 * q * q / 2.0 + f * (q * cos).abs(),
                gradient: SVector::<f64, 4>::new(
                    w2 * q.abs() + f * cos.abs(),
                    f * omega * (q * sin).abs(),
                    p.abs(),
                    1.0,
                ),
                hessian: SMatrix::zeros(),
            };
            s.hessian[(0, 0)] = w2;
            s.hessian[(0, 1)] = f * omega * sin.abs();
            s.hessian[(1, 0)] = s.hessian[(0, 1)];
            s.hessian[(1, 1)] = f * omega * omega * (q * cos).abs();
            s.hessian[(2, 2)] = 1.0;
            worst = worst.max(compare("forced oscillator", &gen, &refh, &z, &s, ULPS));
        }
    }
    eprintln!("forced_oscillator_in_extended_phase_space: largest difference {worst:.2} eps * scale (allowed {ULPS})");
}

/// Emitted code size is linear in the Hessian's nonzeros, the quantity that blows up in
/// derivative compilers that expand the Hessian or Psi as trees.
///
/// Counted in straight-line operations (one `let` each in the macro's output) of the programs
/// the macro emits: value, gradient, Hessian, Psi, the fused `derivatives`, and the two-point
/// discrete gradient (emitted twice, in `discrete_gradient` and `energy_difference`). Per
/// nonzero Hessian entry the fused program needs a bounded amount of work: for a bond
/// `exp(q_i - q_j)` one subtraction and one `exp` shared by value, gradient and Hessian, an
/// addition into each of two gradient entries and two diagonal entries, a negation for the
/// off-diagonal one, and per nonzero `H_ij` one Psi term `H_ij w_i w_j` (at most three
/// multiplications and an addition); per momentum a load, a square, an addition. That is at
/// most 8 operations per nonzero for the fused program. Each of the other four one-point
/// programs computes a subset of the fused one's outputs from the same arena, so it emits at
/// most as many operations. The discrete gradient is a divided difference of `H`, so its size
/// follows the terms of `H` (`2n + 1` here, against `3n - 1` nonzeros): per term the
/// coordinates at both points (two loads, shared), the argument's difference and its value at
/// one point (two or three operations), one divided-difference kernel, a product, and an
/// accumulation into at most two components and the energy difference; per momentum two
/// loads, a difference, a sum, a product, a halving, an accumulation: at most 10 per term.
/// A quadratic term (Psi expanded as a product of sums, a dense Hessian for a banded H) would
/// make the operations per nonzero grow with `n`, so they must not grow from `n = 10` to
/// `n = 20`.
#[test]
fn emitted_code_grows_linearly_in_the_hessian_nonzeros() {
    use dth_symbolic::sources::toda_fixed_ends;
    use dth_symbolic::{compile, Method};
    let one_point = [
        Method::Value,
        Method::Gradient,
        Method::Hessian,
        Method::Psi,
    ];
    let mut per_nonzero = Vec::new();
    for n in 2..=20 {
        let system = compile(&toda_fixed_ends(n), &[]).unwrap();
        let d = system.dim();
        let nnz = (0..d)
            .flat_map(|i| (i..d).map(move |j| (i, j)))
            .filter(|&(i, j)| !system.arena().is_zero(system.hessian_entry(i, j)))
            .count();
        // Tridiagonal q-block plus the identity on p: 2n - 1 + n entries.
        assert_eq!(nnz, 3 * n - 1, "n = {n}");
        let fused = system.program(Method::All).ops.len();
        let pair = system.program(Method::DiscreteGradient).ops.len();
        assert!(
            fused <= 8 * nnz,
            "n = {n}: {fused} fused ops for {nnz} nonzeros"
        );
        let terms = 2 * n + 1;
        assert!(
            pair <= 10 * terms,
            "n = {n}: {pair} discrete-gradient ops for {terms} terms"
        );
        let mut total = fused + 2 * pair;
        for m in one_point {
            let ops = system.program(m).ops.len();
            assert!(
                ops <= fused,
                "n = {n}: {m:?} emits {ops} ops, the fused program {fused}"
            );
            total += ops;
        }
        per_nonzero.push(total as f64 / nnz as f64);
    }
    // per_nonzero[k] is n = k + 2.
    assert!(
        per_nonzero[18] <= per_nonzero[8],
        "operations per nonzero grow with n: {per_nonzero:?}"
    );
}
