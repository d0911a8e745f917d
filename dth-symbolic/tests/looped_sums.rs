//! Lattices compiled once per summand and evaluated in loops (`dth_symbolic::looped`) against
//! the same Hamiltonians built site by site (`dth_symbolic::compile`): value, gradient, the
//! Hessian's nonzeros and pattern, Psi, the discrete gradient, the energy difference and the
//! defect agree to roundoff; the loop body does not grow with the number of sites.

mod lattice_support;

use dth_symbolic::{compile, looped, Method};
use lattice_support::{close, point};

/// The looped and the site-by-site compilations of `src` agree everywhere.
fn agree(src: &str, params: &[&str], values: &[f64]) {
    agree_at(src, params, values, point);
}

/// A point whose positions are `q[k] = k + u`, `|u| < 0.05`: bodies of a sum over pairs at
/// least about 0.9 apart in every coordinate, so each term of an inverse power (`r^-1`,
/// `r^-2` and their derivatives) is at most a few dozen and the results, sums of such
/// terms, agree to [`close`]'s `64 eps` of their size.
fn separated(d: usize, seed: u64) -> Vec<f64> {
    let mut z = point(d, seed);
    for (k, x) in z.iter_mut().take(d / 2).enumerate() {
        *x = k as f64 + 0.1 * *x;
    }
    z
}

/// [`agree`] at the points `at(d, seed)`.
fn agree_at(src: &str, params: &[&str], values: &[f64], at: fn(usize, u64) -> Vec<f64>) {
    let l = looped::compile(src, params).unwrap();
    let s = compile(src, params).unwrap();
    assert_eq!(l.dim(), s.dim());
    let d = l.dim();
    for seed in 0..4 {
        let (z0, z1) = (at(d, seed), at(d, seed + 7));
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
    assert_eq!(
        why("sum(1 <= i < j <= 3, p[i]*p[j])"),
        "a sum over pairs whose Hessian is not one dense block of the lattice"
    );
    assert_eq!(
        why("sum(i = 1..3, p[i*i]^2)"),
        "an index is not a sum's index times a positive integer plus a constant"
    );
    assert_eq!(
        why("sum(i = 1..3, sum(j = 1..3, p[i]^2*q[j]^2))"),
        "a nested sum that is not over every pair `i < j` once (write `sum(1 <= i < j <= N, f)`)"
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

/// The one error of a size beyond what compiles, as both paths report it: kind and the text
/// it points at.
fn too_large(src: &str) -> Vec<(dth_symbolic::ErrorKind, &str)> {
    let written = compile(src, &[]).expect_err("too large").0;
    written
        .iter()
        .map(|e| (e.kind.clone(), &src[e.span.range()]))
        .collect()
}

/// A huge size (`10^12`, `i64::MAX`, a huge negative start, a product) is one error at the
/// size's value, from both paths, at once: never one per site, never an overflow, never the
/// memory of counting the sites out.
#[test]
fn a_huge_lattice_is_one_error_at_its_size() {
    use dth_symbolic::{ErrorKind::LatticeTooLarge, MAX_INDEX, MAX_SITES};
    let loops = |sites: i128| LatticeTooLarge {
        sites,
        limit: MAX_SITES,
    };
    for (src, sites, at) in [
        (
            "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) \
             where N = 1000000000000, q[0] = q[N+1] = 0",
            1_000_000_000_000,
            "1000000000000",
        ),
        (
            "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) where N = 9223372036854775807",
            i128::from(i64::MAX),
            "9223372036854775807",
        ),
        (
            "sum(i = 1..2*N, p[i]^2/2 + q[i]^2/2) where N = 500000000000",
            1_000_000_000_000,
            "2*N",
        ),
        (
            "sum(i = -9223372036854775807..4, p[i]^2/2) + sum(i = 1..4, q[i]^2)",
            i128::from(i64::MAX) + 5,
            "-9223372036854775807",
        ),
        (
            "sum(i = 1..N, p[i]^2/2) + sum(1 <= i < j <= N, (q[i] - q[j])^2) where N = 100000",
            100_000,
            "100000",
        ),
    ] {
        assert_eq!(too_large(src), [(loops(sites), at)], "{src}");
        if let Err(looped::LoopError::Errors(e)) = looped::compile(src, &[]) {
            let kinds: Vec<_> = e.0.iter().map(|e| e.kind.clone()).collect();
            assert!(kinds.contains(&loops(sites)), "{src}: {kinds:?}");
        }
    }
    // At each cap exactly, a chain with fixed ends (its bond sum `0..N` has N + 1 terms on N
    // sites) is accepted: by the loops at `MAX_SITES`, written out at `MAX_INDEX`.
    let chain = |n: usize, extra: &str| {
        format!(
            "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2){extra} \
             where N = {n}, q[0] = q[N+1] = 0"
        )
    };
    assert_eq!(
        looped::compile(&chain(MAX_SITES, ""), &[]).map(|l| l.n()),
        Ok(MAX_SITES)
    );
    assert!(compile(&chain(MAX_INDEX, " + q1^4"), &[]).is_ok());
    assert_eq!(
        too_large(&chain(MAX_INDEX + 1, " + q1^4")),
        [(
            LatticeTooLarge {
                sites: (MAX_INDEX + 1) as i128,
                limit: MAX_INDEX
            },
            (MAX_INDEX + 1).to_string().as_str()
        )]
    );
    // Between the two bounds: the loops take it; written out site by site it is one error.
    let src = "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) where N = 600";
    assert_eq!(looped::compile(src, &[]).map(|l| l.n()), Ok(600));
    let not_looped = "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) + q1^4 where N = 600";
    assert_eq!(
        too_large(not_looped),
        [(
            LatticeTooLarge {
                sites: 600,
                limit: MAX_INDEX
            },
            "600"
        )]
    );
    assert!(compile(not_looped, &[]).unwrap_err().0[0]
        .to_string()
        .starts_with("lattice too large: 600 sites, at most 512 when the sums are written out"));
    // A sum before the large one reaches into its sites: no spurious out-of-range error.
    let before =
        "sum(i = 1..4, p[i]^2/2 + cos(q[i+1] - q[i])) + sum(i = 1..N, p[i]^2/2 + q[i]^2/2) \
                  + q1^4 where N = 1000";
    assert_eq!(compile(before, &[]).unwrap_err().0.len(), 1);
    // An offset past `i64`: one error, no overflow.
    let e = compile("sum(i = 1..4, p[i]^2 + q[i + 9223372036854775807])", &[]).unwrap_err();
    assert_eq!(e.0.len(), 1, "{e}");
    assert!(looped::compile("sum(i = 1..4, p[i]^2 + q[i + 9223372036854775806])", &[]).is_err());
}

/// Out of range at many sites: one error per access, at its farthest site.
#[test]
fn an_access_out_of_range_at_many_sites_is_one_error() {
    two_accesses_out_of_range(500);
}

/// `q[i-5]` and `q[i+100]` in a sum over `1..=n`: exactly two errors, each at its farthest
/// site, whatever `n` (site by site up to the written-out size, loops beyond it).
fn two_accesses_out_of_range(n: usize) {
    let source = format!("sum(i = 1..N, p[i]^2 + q[i-5]^2 + q[i+100]^2) where N = {n}");
    let e = compile(&source, &[]).unwrap_err().0;
    let messages: Vec<String> = e.iter().map(|e| e.to_string()).collect();
    assert_eq!(messages.len(), 2, "{messages:#?}");
    assert!(
        messages[0].contains("`q[i-5]` is `q[-4]` at `i = 1`"),
        "{messages:#?}"
    );
    let far = format!("`q[i+100]` is `q[{}]` at `i = {n}`", n + 100);
    assert!(messages[1].contains(&far), "{messages:#?}");
}

/// The looped path's warnings and numbering errors are the written-out path's, one per run of
/// sites, decided on the ranges (so a chain of 4096 has one warning, not 4092).
#[test]
fn looped_warnings_and_gaps_are_the_written_out_ones() {
    let warnings = |src: &str| -> Vec<(String, std::ops::Range<usize>)> {
        let l = looped::compile(src, &[]).unwrap();
        let looped: Vec<_> = l
            .warnings()
            .iter()
            .map(|w| (w.to_string(), w.span.range()))
            .collect();
        let s = compile(src, &[]).unwrap();
        let written: Vec<_> = s
            .warnings()
            .iter()
            .map(|w| (w.to_string(), w.span.range()))
            .collect();
        assert_eq!(looped, written, "{src}");
        looped
    };
    let w = warnings("sum(i = 1..4, p[i]^2/2) + sum(i = 1..N, q[i]^2/2) where N = 8");
    assert_eq!(w.len(), 1, "{w:#?}");
    assert!(w[0].0.starts_with("`q5`..`q8` appear without `p5`..`p8`"));
    let w = warnings("sum(i = 1..4, q[i]^2) + sum(i = 3..N, p[i]^2) where N = 8");
    let texts: Vec<&str> = w.iter().map(|(m, _)| m.as_str()).collect();
    assert_eq!(
        texts,
        [
            "`q1`..`q2` appear without `p1`..`p2`: they never move (dH/dp = 0) and their momenta only drift; constants are better declared as parameters",
            "`p5`..`p8` appear without `q5`..`q8` while `q1` appears without `p1`: is an index misnumbered?",
        ]
    );
    // One frozen site alone, the last, reached by a shift: `q[i+1]` first reaches `q9`.
    let w = warnings("sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) + sum(i = 1..9, q[i]^4) where N = 8, q[10] = 0");
    assert_eq!(w.len(), 1, "{w:#?}");
    assert!(w[0].0.starts_with("`q9` appears without `p9`"), "{w:#?}");
    // A periodic chain and a fixed one: no warning.
    assert!(
        warnings("sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = 8, q[N+1] = q[1]")
            .is_empty()
    );
    assert!(warnings(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) where N = 8, q[0] = q[N+1] = 0"
    )
    .is_empty());
    // Sites no variable reaches: the same one error from both paths.
    let gap = "sum(i = 1..3, p[i]^2 + q[i]^2) + sum(i = 7..N, p[i]^2 + q[i]^2) where N = 8";
    let Err(looped::LoopError::Errors(e)) = looped::compile(gap, &[]) else {
        panic!("sites 4..6 are reached by nothing");
    };
    assert_eq!(e, compile(gap, &[]).unwrap_err());
    assert_eq!(e.0.len(), 1);
    assert_eq!(&gap[e.0[0].span.range()], "p[i]");
    // At 4096 sites: one warning for the run, decided without the sites.
    let big = "sum(i = 1..4, p[i]^2/2) + sum(i = 1..N, q[i]^2/2) where N = 4096";
    assert_eq!(looped::compile(big, &[]).unwrap().warnings().len(), 1);
}

/// Every flag of a looped lattice is its written-out twin's at `N = 8`, Psi's symbolic zero
/// included: a chain with kinetic energy and a momentum-linear drift has a Hessian (the
/// `p`-diagonal) yet `Psi = 0`, since `w_p = -dH/dq = 0` everywhere.
#[test]
fn looped_flags_are_the_written_out_ones() {
    for src in [
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/3) \
         where N = 8, q[0] = q[N+1] = 0",
        "sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = 8, q[N+1] = q[1]",
        "sum(i = 1..N, p[i]^2/2) + sum(i = 1..N, 3*p[i]) where N = 8",
        "sum(i = 1..N, p[i] + 2*q[i]) where N = 8",
        "sum(i = 1..N, p[i]^2/2 + q[i]) where N = 8",
        "sum(i = 1..N, p[i]^2/2 + q[i]^2/2 + q[i]*p[i+1]) where N = 8, p[N+1] = 0",
        "sum(i = 1..N, p[i]^2/2 + q[i-1]*p[i]) where N = 8, q[0] = 0",
        "sum(i = 1..N, p[i]^2/2 + q[i+1]^2) where N = 8, q[N+1] = p[1]",
    ] {
        let l = looped::compile(src, &[]).unwrap();
        let s = compile(src, &[]).unwrap();
        let mut pattern = l.hessian_pattern();
        pattern.sort_unstable();
        let written: Vec<(usize, usize)> = s
            .hessian_nonzeros()
            .iter()
            .map(|&(i, j, _)| (i, j))
            .collect();
        assert_eq!(pattern, written, "{src}");
        assert_eq!(
            (l.dim(), l.separable(), l.psi_identically_zero(), false),
            (
                s.dim(),
                s.separable(),
                s.psi_identically_zero(),
                s.time_dependent()
            ),
            "{src}"
        );
    }
    let drift = looped::compile(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 1..N, 3*p[i]) where N = 8",
        &[],
    )
    .unwrap();
    assert!(drift.psi_identically_zero() && !drift.hessian_pattern().is_empty());
}

/// Terms that cancel between sums (shifted or not) or between the sites of one sum (a
/// telescoping ring) are seen by the looped flags as by the written-out path's simplifier:
/// the flags are the same. The looped pattern still holds the cancelled entries (their value
/// computes to 0): it is the written-out one or more.
#[test]
fn looped_flags_see_terms_that_cancel() {
    for (src, separable, psi_zero) in [
        (
            "sum(i = 1..N, p[i]^2/2 + q[i]) + sum(i = 1..N, -q[i]) where N = 8",
            true,
            true,
        ),
        (
            "sum(i = 1..N, p[i]^2/2 + q[i+1] - q[i]) where N = 8, q[N+1] = q[1]",
            true,
            true,
        ),
        (
            "sum(i = 0..N-1, p[i+1]^2/2 + q[i+1]^2) + sum(i = 1..N, -q[i]^2) where N = 8",
            true,
            true,
        ),
        (
            "sum(i = 1..N, p[i]^2/2 + q[i]*p[i]) + sum(i = 1..N, q[i]^2/2 - q[i]*p[i]) \
             where N = 8",
            true,
            false,
        ),
        (
            "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) + sum(i = 0..N, q[i]*q[i+1]) \
             + sum(i = 1..N, -q[i]*q[i+1]) where N = 8, q[0] = q[N+1] = 0",
            true,
            false,
        ),
        // Not everything cancels: a force is left at the last site.
        (
            "sum(i = 1..N, p[i]^2/2 + q[i]) + sum(i = 1..N-1, -q[i]) where N = 8",
            true,
            false,
        ),
    ] {
        let l = looped::compile(src, &[]).unwrap();
        let s = compile(src, &[]).unwrap();
        assert_eq!(
            (l.separable(), l.psi_identically_zero()),
            (s.separable(), s.psi_identically_zero()),
            "{src}: looped against written out"
        );
        assert_eq!(
            (s.separable(), s.psi_identically_zero()),
            (separable, psi_zero),
            "{src}"
        );
        // The same lattice at 4096 sites (beyond what is written out): decided on the same
        // classes of sites, the same flags.
        let large = looped::compile(&src.replace("N = 8", "N = 4096"), &[]).unwrap();
        assert_eq!(
            (large.n(), large.separable(), large.psi_identically_zero()),
            (4096, separable, psi_zero),
            "{src} at N = 4096"
        );
        let pattern: std::collections::HashSet<(usize, usize)> =
            l.hessian_pattern().into_iter().collect();
        assert!(
            s.hessian_nonzeros()
                .iter()
                .all(|&(i, j, _)| pattern.contains(&(i, j))),
            "{src}"
        );
    }
}

/// What the site-by-site path reports of a faulty source, as `(kind, text pointed at)`, the
/// kind's numbers left out (they name sites, which move with `N`).
fn faults(src: &str) -> Vec<(std::mem::Discriminant<dth_symbolic::ErrorKind>, &str)> {
    compile(src, &[])
        .expect_err("faulty")
        .0
        .iter()
        .map(|e| (std::mem::discriminant(&e.kind), &src[e.span.range()]))
        .collect()
}

/// A lattice that loops, too large to write out site by site (512 sites) but within the
/// loops' 16384, with a fault: the errors are the fault's, as for the same source at 8 sites,
/// not "too large to write out".
#[test]
fn a_fault_beyond_the_written_out_size_is_the_fault_not_the_size() {
    for template in [
        // No boundary where `q[i+1]` leaves the lattice.
        "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = {n}",
        "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2 + q[i-2]^2) where N = {n}, q[N+1] = 0, \
         q[0] = 0",
        // A boundary inside the lattice, a boundary defined by a boundary.
        "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = {n}, q[N+1] = 0, q[3] = 0",
        "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = {n}, q[N+1] = q[N+2], q[N+2] = 0",
        // A site no variable reaches.
        "sum(i = 1..N, p[i]^2/2) + sum(i = N+2..N+2, p[i]^2 + q[i]^2) where N = {n}",
        // No momentum.
        "sum(i = 1..N, (q[i+1] - q[i])^2/2) where N = {n}, q[N+1] = 0",
        // A divisor that is zero, an unknown name.
        "sum(i = 1..N, p[i]^2/2 + 1/(q[i] - q[i])) where N = {n}",
        "sum(i = 1..N, p[i]^2/2 + a*q[i]^2) where N = {n}",
        // A divisor that is 0 only where the summand reads a fixed end.
        "sum(i = 1..N, p[i]^2/2 + 1/q[i-1]^2) where N = {n}, q[0] = 0",
    ] {
        let small = template.replace("{n}", "8");
        let large = template.replace("{n}", "1000");
        // The same kinds at the same places (an error about the whole source points at its
        // size too).
        let large_faults: Vec<_> = faults(&large)
            .into_iter()
            .map(|(kind, text)| (kind, text.replace("N = 1000", "N = 8")))
            .collect();
        let small_faults: Vec<_> = faults(&small)
            .into_iter()
            .map(|(kind, text)| (kind, text.to_string()))
            .collect();
        assert_eq!(large_faults, small_faults, "{large}");
        let messages = compile(&large, &[]).unwrap_err().to_string();
        assert!(!messages.contains("too large"), "{large}: {messages}");
    }
    // The loops refuse it at any size, as the site-by-site path does: the generated code
    // would divide by 0 at the first site.
    let at_the_end = "sum(i = 1..N, p[i]^2/2 + 1/q[i-1]^2) where N = 8, q[0] = 0";
    assert!(matches!(
        looped::compile(at_the_end, &[]),
        Err(looped::LoopError::Errors(_))
    ));
    // The message names the site at the size written.
    two_accesses_out_of_range(1000);
    // A source that does not loop is too large whatever else is wrong with it: it cannot be
    // built at that size at all.
    let not_looped = "sum(i = 1..N, p[i]^2/2 + q[i+1]^2) + q1^4 where N = 1000";
    assert!(compile(not_looped, &[])
        .unwrap_err()
        .to_string()
        .starts_with("lattice too large: 1000 sites"));
}

/// 3-D gravity of `n` bodies from one line: the kinetic energy a strided sum, the potential a
/// sum over pairs.
fn gravity(n: usize) -> String {
    format!(
        "sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/(2*m)) - G*sum(1 <= i < j <= N, \
         ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 + (q[3*i] - q[3*j])^2)^(-1/2)) \
         where N = {n}"
    )
}

#[test]
fn sums_over_pairs_nested_and_strided_sums_loop_as_written_out() {
    // Calogero-Moser, 1-D: the pair sum's Hessian is the dense block of the positions.
    agree_at(
        "sum(i = 1..N, p[i]^2/2) + g^2*sum(1 <= i < j <= N, (q[i] - q[j])^(-2)) where N = 6",
        &["g"],
        &[0.8],
        separated,
    );
    agree_at(&gravity(5), &["m", "G"], &[1.3, 0.9], separated);
    // The same pairs as a nested sum, and 2-D bodies (the natural N-body text: its sites are
    // the indices its sums reach, `1..2N`), with a trap over sites.
    agree_at(
        "sum(i = 1..N, (p[2*i-1]^2 + p[2*i]^2)/2) + sum(i = 1..M, q[i]^2/2) \
         - g*sum(i = 1..N, sum(j = i+1..N, ((q[2*i-1]-q[2*j-1])^2 + (q[2*i]-q[2*j])^2)^(-1/2))) \
         where N = 4, M = 2*N",
        &["g"],
        &[0.5],
        separated,
    );
    // Strict bounds and a lower bound above 1.
    agree(
        "sum(i = 1..N, p[i]^2/2) + sum(0 < i < j < N + 1, exp(q[i] - q[j]) + (q[i] - q[j])^4) \
         where N = 5",
        &[],
        &[],
    );
}

#[test]
fn the_pair_sums_body_does_not_grow_with_the_number_of_bodies() {
    let (small, large) = (
        looped::compile(&gravity(8), &["m", "G"]).unwrap(),
        looped::compile(&gravity(1024), &["m", "G"]).unwrap(),
    );
    assert_eq!(small.ops(), large.ops());
    assert_eq!(large.dim(), 6 * 1024);
    // The pattern: the positions' dense block and the momenta's diagonal.
    let layout = looped::diagonals::layout(&large);
    let m = 3 * 1024;
    assert_eq!(layout.nnz, m * (m + 1) / 2 + m);
    assert!(large.separable());
}

/// The natural 2-D N-body text: its sites are the indices its sums reach (`p[2*i-1]`, `p[2*i]`
/// for `i = 1..N` reach `1..2N`), so both paths accept it; a boundary is still asked for
/// where an index falls outside them.
#[test]
fn the_natural_n_body_text_is_accepted_and_only_outside_indices_need_a_boundary() {
    let src = "sum(i = 1..N, (p[2*i-1]^2 + p[2*i]^2)/2) - g*sum(1 <= i < j <= N, \
               ((q[2*i-1]-q[2*j-1])^2 + (q[2*i]-q[2*j])^2)^(-1/2)) where N = 10";
    assert_eq!(compile(src, &["g"]).unwrap().dim(), 40);
    agree_at(src, &["g"], &[0.7], separated);
    let beyond = "sum(i = 1..N, p[2*i]^2 + p[2*i+1]^2 + q[2*i-1]^2 + q[2*i]^2) where N = 3";
    let e = compile(beyond, &[]).unwrap_err().0;
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(
        matches!(
            e[0].kind,
            dth_symbolic::ErrorKind::IndexOutOfRange { site: 7, .. }
        ),
        "{e:?}"
    );
    assert_eq!(&beyond[e[0].span.range()], "p[2*i+1]");
}
