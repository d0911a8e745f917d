//! Lattices compiled once per summand and evaluated in loops (`dth_symbolic::looped`) against
//! the same Hamiltonians built site by site (`dth_symbolic::compile`): value, gradient, the
//! Hessian's nonzeros and pattern, Psi, the discrete gradient, the energy difference and the
//! defect agree to roundoff; the loop body does not grow with the number of sites.

mod lattice_support;

use dth_symbolic::{compile, looped, Method};
use lattice_support::{close, point};

/// The looped and the site-by-site compilations of `src` agree everywhere.
fn agree(src: &str, params: &[&str], values: &[f64]) {
    let l = looped::compile(src, params).unwrap();
    let s = compile(src, params).unwrap();
    assert_eq!(l.dim(), s.dim());
    let d = l.dim();
    for seed in 0..4 {
        let (z0, z1) = (point(d, seed), point(d, seed + 7));
        let a = l.eval(&z0, values).unwrap();
        let b = s.program(Method::All).eval(&z0, values).unwrap();
        close(a.value, b.value, "value");
        close(a.psi, b.psi, "psi");
        for k in 0..d {
            close(a.gradient[k], b.gradient[k], "gradient");
        }
        let pattern: Vec<(usize, usize)> = a.hessian.iter().map(|&(i, j, _)| (i, j)).collect();
        let mut expected: Vec<(usize, usize)> = s
            .hessian_nonzeros()
            .iter()
            .map(|&(i, j, _)| (i, j))
            .collect();
        expected.sort_unstable();
        assert_eq!(pattern, expected, "{src}");
        for &(i, j, v) in &a.hessian {
            close(v, b.hessian[i * d + j], "hessian");
        }
        let (gbar, delta, defect) = l.eval_pair(&z0, &z1, values).unwrap();
        let p = s
            .program(Method::DiscreteGradient)
            .eval_pair(&z0, &z1, values)
            .unwrap();
        let t = s
            .program(Method::DiscreteGradientDefect)
            .eval_pair(&z0, &z1, values)
            .unwrap();
        close(delta, p.energy_difference, "energy difference");
        for k in 0..d {
            close(gbar[k], p.discrete_gradient[k], "gbar");
            close(defect[k], t.discrete_gradient_defect[k], "defect");
        }
    }
}

#[test]
fn fput_alpha_fixed_ends_n8_loops_as_written_out() {
    agree(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3) \
         where N = 8, q[0] = q[N+1] = 0",
        &["alpha"],
        &[0.25],
    );
    // The written-out source of the same chain, term by term.
    let written = compile(&dth_symbolic::sources::fput_alpha_fixed_ends(8), &[]).unwrap();
    let l = looped::compile(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/12) \
         where N = 8, q[0] = q[N+1] = 0",
        &[],
    )
    .unwrap();
    let z = point(16, 3);
    let (a, b) = (
        l.eval(&z, &[]).unwrap(),
        written.program(Method::All).eval(&z, &[]).unwrap(),
    );
    close(a.value, b.value, "value");
    close(a.psi, b.psi, "psi");
}

#[test]
fn periodic_toda_beta_chain_and_kth_neighbours_loop_as_written_out() {
    agree(
        "sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = 8, q[N+1] = q[1]",
        &[],
        &[],
    );
    agree(
        "sum(i = 1..N, p[i]^2/(2*m) + (q[i+1] - q[i])^2/2 + beta*(q[i+1] - q[i])^4/4) \
         where N = 8, q[N+1] = q[1]",
        &["m", "beta"],
        &[1.5, 0.7],
    );
    agree(
        "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2 + (q[i+3] - q[i])^4/4) \
         where N = 8, K = 3, q[9] = q[10] = q[11] = 0",
        &[],
        &[],
    );
    // A ring of two: both neighbours of a site are the same particle.
    agree(
        "sum(i = 1..2, p[i]^2/2 + cos(q[i] - q[i+1])) where q[3] = q[1]",
        &[],
        &[],
    );
}

#[test]
fn the_loop_body_does_not_grow_with_the_number_of_sites() {
    let fput = |n: usize| {
        looped::compile(
            &format!(
                "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/12) \
                 where N = {n}, q[0] = q[N+1] = 0"
            ),
            &[],
        )
        .unwrap()
    };
    let (small, large) = (fput(64), fput(4096));
    assert_eq!(large.dim(), 8192);
    assert_eq!(small.ops(), large.ops());
    // The looped chain of 4096 evaluates (the site-by-site engine stops at 512 indices).
    let z = point(8192, 1);
    let e = large.eval(&z, &[]).unwrap();
    assert_eq!(e.hessian.len(), 3 * 4096 - 1);
}

#[test]
fn what_does_not_loop_says_why() {
    let why = |src: &str| match looped::compile(src, &[]) {
        Err(looped::LoopError::NotLoopable(why)) => why,
        other => panic!("{src}: {other:?}"),
    };
    assert_eq!(why("sum(i = 1..3, p[i]^2) + q1^2"), "a term outside a sum");
    assert_eq!(why("sum(1 <= i < j <= 3, p[i]*p[j])"), "a sum over pairs");
    assert_eq!(
        why("sum(i = 1..3, p[2*i]^2)"),
        "an index is not the sum's index plus a constant"
    );
    assert_eq!(
        why("sum(i = 1..3, i*p[i]^2)"),
        "the sum's index is used as a number"
    );
}

/// A shift of two reaches two sites past the end: with only the outer one declared, the
/// summand reaches an undeclared `q[9]`, which must be an error at it (from the site-by-site
/// check), never read as a zero by the loops.
#[test]
fn every_site_a_shift_reaches_outside_the_lattice_must_be_declared() {
    let src = "sum(i = 1..N, p[i]^2/2 + (q[i+2] - q[i])^2/2) where N = 8, q[10] = 0";
    assert!(
        looped::compile(src, &[]).is_err(),
        "the loops took an undeclared site"
    );
    let errors = compile(src, &[])
        .expect_err("q[9] is neither a site nor a boundary")
        .0;
    assert!(
        errors
            .iter()
            .any(|e| e.to_string().contains("q[9]") || e.to_string().contains("q9")),
        "{errors:?}"
    );
    // Both sites declared: the loops run it, and agree with the site-by-site build.
    let src = "sum(i = 1..N, p[i]^2/2 + (q[i+2] - q[i])^2/2) where N = 8, q[9] = q[10] = 0";
    assert!(looped::compile(src, &[]).is_ok());
    assert!(compile(src, &[]).is_ok());
}
