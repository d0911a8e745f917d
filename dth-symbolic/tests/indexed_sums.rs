//! Indexed variables and sums: a lattice written once (`sum(i = 1..N, ...)` with boundaries
//! after `where`) compiles to the same Hamiltonian as its written-out text (value, gradient,
//! Hessian and its pattern, Psi, discrete gradient, energy difference and defect, to roundoff),
//! its derivatives agree with num-dual on chains up to 64 particles, and every misuse is a
//! spanned error, all reported at once.

mod lattice_support;

use dth_symbolic::{compile, looped, sources, Method, System};
use lattice_support::{close, point};
use nalgebra::DVector;
use num_dual::{hessian, Dual2Vec64};
use proptest::prelude::*;

/// FPUT-alpha with fixed ends, `alpha = 1/4`, as one line: `sources::fput_alpha_fixed_ends`.
fn fput_alpha(n: usize) -> String {
    format!(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/12) \
         where N = {n}, q[0] = q[N+1] = 0"
    )
}

/// Every output of the two systems agrees at a few points.
fn same_hamiltonian(looped: &System, written: &System) {
    assert_eq!(looped.dim(), written.dim());
    let pattern = |s: &System| {
        let mut p: Vec<(usize, usize)> = s
            .hessian_nonzeros()
            .iter()
            .map(|&(i, j, _)| (i, j))
            .collect();
        p.sort_unstable();
        p
    };
    assert_eq!(pattern(looped), pattern(written));
    assert_eq!(looped.separable(), written.separable());
    let d = looped.dim();
    for seed in 0..4 {
        let (z0, z1) = (point(d, seed), point(d, seed + 100));
        let (a, b) = (
            looped.program(Method::All).eval(&z0, &[]).unwrap(),
            written.program(Method::All).eval(&z0, &[]).unwrap(),
        );
        close(a.value, b.value, "value");
        close(a.psi, b.psi, "psi");
        for k in 0..d {
            close(a.gradient[k], b.gradient[k], "gradient");
        }
        for k in 0..d * d {
            close(a.hessian[k], b.hessian[k], "hessian");
        }
        for method in [Method::DiscreteGradient, Method::DiscreteGradientDefect] {
            let (a, b) = (
                looped.program(method).eval_pair(&z0, &z1, &[]).unwrap(),
                written.program(method).eval_pair(&z0, &z1, &[]).unwrap(),
            );
            close(
                a.energy_difference,
                b.energy_difference,
                "energy difference",
            );
            for k in 0..d {
                close(a.discrete_gradient[k], b.discrete_gradient[k], "gbar");
                close(
                    a.discrete_gradient_defect[k],
                    b.discrete_gradient_defect[k],
                    "defect",
                );
            }
        }
    }
}

#[test]
fn fput_sum_with_fixed_ends_is_the_written_out_chain() {
    let looped = compile(&fput_alpha(8), &[]).unwrap();
    let written = compile(&sources::fput_alpha_fixed_ends(8), &[]).unwrap();
    assert_eq!(looped.dim(), 16);
    assert_eq!(looped.hessian_nonzeros().len(), 3 * 8 - 1);
    same_hamiltonian(&looped, &written);
}

#[test]
fn periodic_toda_and_kth_neighbours_are_their_written_out_texts() {
    // Periodic Toda: the bond from the last site closes on the first.
    let looped = compile(
        "sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = 8, q[N+1] = q[1]",
        &[],
    )
    .unwrap();
    let bonds: Vec<String> = (1..=8)
        .map(|i| format!("p{i}^2/2 + exp(q{i} - q{})", i % 8 + 1))
        .collect();
    let written = compile(&bonds.join(" + "), &[]).unwrap();
    same_hamiltonian(&looped, &written);

    // Nearest and third neighbours with fixed ends, the index an expression of `i` and `k`.
    let looped = compile(
        "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2 + (q[i+K] - q[i])^4/4) \
         where N = 6, K = 3, q[7] = q[8] = q[9] = 0",
        &[],
    )
    .unwrap();
    let q = |k: usize| {
        if k <= 6 {
            format!("q{k}")
        } else {
            "0".to_string()
        }
    };
    let terms: Vec<String> = (1..=6)
        .map(|i| {
            format!(
                "p{i}^2/2 + ({} - q{i})^2/2 + ({} - q{i})^4/4",
                q(i + 1),
                q(i + 3)
            )
        })
        .collect();
    let written = compile(&terms.join(" + "), &[]).unwrap();
    same_hamiltonian(&looped, &written);
}

#[test]
fn all_pairs_sum_is_every_pair_once() {
    let looped = compile(
        "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) + sum(1 <= i < j <= N, 1/(q[i] - q[j])^2) \
         where N = 5",
        &[],
    )
    .unwrap();
    let mut terms: Vec<String> = (1..=5).map(|i| format!("p{i}^2/2 + q{i}^2/2")).collect();
    for i in 1..=5 {
        for j in i + 1..=5 {
            terms.push(format!("1/(q{i} - q{j})^2"));
        }
    }
    let written = compile(&terms.join(" + "), &[]).unwrap();
    assert_eq!(looped.hessian_nonzeros().len(), 5 * 6 / 2 + 5);
    same_hamiltonian(&looped, &written);
    // The same pairs as nested sums with a bound that depends on the outer index; the empty
    // inner range at `i = N` is an empty sum, zero.
    let nested = compile(
        "sum(i = 1..N, p[i]^2/2 + q[i]^2/2 + sum(j = i+1..N, 1/(q[i] - q[j])^2)) where N = 5",
        &[],
    )
    .unwrap();
    same_hamiltonian(&nested, &written);
}

#[test]
fn indices_and_sizes_are_numbers_in_the_summand() {
    // A site-dependent spring `i*q_i^2` and a parameter beside the indices.
    let h = compile("sum(i = 1..3, p[i]^2/2 + k*i*q[i]^2)", &["k"]).unwrap();
    let written = compile(
        "p1^2/2 + k*q1^2 + p2^2/2 + 2*k*q2^2 + p3^2/2 + 3*k*q3^2",
        &["k"],
    )
    .unwrap();
    assert_eq!(
        h.expr(h.value()).to_string(),
        written.expr(written.value()).to_string()
    );
}

/// The messages and the text each error's span covers.
fn errors(src: &str) -> Vec<(String, &str)> {
    compile(src, &["k"])
        .unwrap_err()
        .0
        .into_iter()
        .map(|e| (e.to_string(), &src[e.span.range()]))
        .collect()
}

#[test]
fn every_misuse_is_a_spanned_error_all_at_once() {
    let src = "sum(i = 1..4, p[i]^2/2 + (q[i+1] - q[i])^2 + q[j] + x[i]) + sum(i = 5..4, p[i]) \
               + q9 + sum(i = 1..k, p[i])";
    let e = errors(src);
    let spans: Vec<&str> = e.iter().map(|(_, s)| *s).collect();
    assert_eq!(spans, ["q[i+1]", "j", "x", "i = 5..4", "q9", "k"], "{e:#?}");
    assert_eq!(
        e[0].0,
        "index out of range: `q[i+1]` is `q[5]` at `i = 4`, but the lattice's sites are 1..4 \
         (the sums' largest bound); declare a boundary after `where`: `q[5] = 0` (fixed end) or \
         `q[5] = q[1]` (periodic)"
    );
    assert_eq!(
        e[1].0,
        "unbound index `j`: the indices bound here are `i`, and no `where j = ...` declares it"
    );
    assert_eq!(
        e[2].0,
        "`x` cannot be indexed: the indexed variables are `q[i]` and `p[i]`"
    );
    assert_eq!(
        e[3].0,
        "sum over an empty range: `i = 5..4` has no terms (ranges include both ends)"
    );
    assert!(e[4]
        .0
        .starts_with("`q9` is beyond the lattice 1..4 of the sums"));
    assert!(e[5].0.starts_with("`k` is not an integer"));
}

#[test]
fn below_the_lattice_and_bad_declarations_are_errors() {
    let e = errors("sum(i = 1..N, p[i]^2 + q[i-1]^2) where N = 3");
    assert_eq!(e.len(), 1);
    assert_eq!(e[0].1, "q[i-1]");
    assert!(e[0].0.contains("`q[0]` at `i = 1`"), "{}", e[0].0);
    let e = errors("sum(i = 1..N, p[i]^2 + q[i+1]^2) where N = 3, q[2] = 0, q[4] = q[5], N = 2");
    let spans: Vec<&str> = e.iter().map(|(_, s)| *s).collect();
    assert_eq!(spans, ["q[2]", "q[5]", "N"], "{e:#?}");
    assert!(e[0]
        .0
        .starts_with("boundary `q[2]` is inside the lattice 1..3"));
    let e = errors("sum(sin = 1..3, p[sin]) + sum(i = 1..2.5, p[i]) + sum(i, p[i])");
    let spans: Vec<&str> = e.iter().map(|(_, s)| *s).collect();
    assert_eq!(spans, [","], "{e:#?}");
    let e = errors("sum(sin = 1..3, p[sin]) + sum(i = 1..2.5, p[i])");
    let spans: Vec<&str> = e.iter().map(|(_, s)| *s).collect();
    assert_eq!(spans, ["sin", "2.5"], "{e:#?}");
}

/// A dual number with derivatives up to second order in `D` directions, `D` at run time.
type Dual2 = Dual2Vec64<nalgebra::Dyn>;

/// FPUT-alpha with fixed ends evaluated on dual numbers: num-dual's oracle.
fn fput_dual(z: &[Dual2], n: usize) -> Dual2 {
    let zero = Dual2::from_re(0.0);
    let q = |k: usize| {
        if k == 0 || k == n + 1 {
            zero.clone()
        } else {
            z[k - 1].clone()
        }
    };
    let mut h = zero.clone();
    for p in &z[n..] {
        h += p.clone() * p.clone() * 0.5;
    }
    for i in 0..=n {
        let r = q(i + 1) - q(i);
        h += r.clone() * r.clone() * 0.5 + r.clone() * r.clone() * r * (0.25 / 3.0);
    }
    h
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// The sum's value, gradient, Hessian and Psi against num-dual for chains of up to 64
    /// particles (`D = 128`), at random points: built site by site (`compile`) and compiled
    /// once per summand and run in loops (`looped::compile`).
    #[test]
    fn fput_sum_matches_num_dual(n in 1usize..=64, seed in any::<u64>()) {
        let h = compile(&fput_alpha(n), &[]).unwrap();
        let d = 2 * n;
        let z = point(d, seed);
        let e = h.program(Method::All).eval(&z, &[]).unwrap();
        let (v, g, hess) = hessian(
            |x: DVector<Dual2>| fput_dual(x.as_slice(), n),
            &DVector::from_vec(z.clone()),
        );
        // Roundoff of sums of up to 3n + 1 terms of size below 1 (`|z| < 1/2`).
        let tol = 8.0 * (d as f64) * f64::EPSILON;
        prop_assert!((e.value - v).abs() <= tol * (1.0 + v.abs()));
        for i in 0..d {
            prop_assert!((e.gradient[i] - g[i]).abs() <= tol);
            for j in 0..d {
                prop_assert!((e.hessian[i * d + j] - hess[(i, j)]).abs() <= tol);
            }
        }
        // Psi = w^T Hess w, w = J grad.
        let w: Vec<f64> = (0..d).map(|i| if i < n { g[i + n] } else { -g[i - n] }).collect();
        let psi: f64 = (0..d).map(|i| (0..d).map(|j| w[i] * hess[(i, j)] * w[j]).sum::<f64>()).sum();
        prop_assert!((e.psi - psi).abs() <= tol * (1.0 + psi.abs()));
        let l = looped::compile(&fput_alpha(n), &[]).unwrap().eval(&z, &[]).unwrap();
        prop_assert!((l.value - v).abs() <= tol * (1.0 + v.abs()));
        prop_assert!((l.psi - psi).abs() <= tol * (1.0 + psi.abs()));
        for i in 0..d {
            prop_assert!((l.gradient[i] - g[i]).abs() <= tol);
        }
        let mut dense = vec![0.0; d * d];
        for &(i, j, h) in &l.hessian {
            dense[i * d + j] = h;
            dense[j * d + i] = h;
        }
        for i in 0..d {
            for j in 0..d {
                prop_assert!((dense[i * d + j] - hess[(i, j)]).abs() <= tol);
            }
        }
    }
}
