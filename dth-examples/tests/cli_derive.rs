//! `dth derive "EXPR"`: what the engine derives, and malformed expressions as exit 2 with the
//! position of every error.

mod common;

use common::*;

#[test]
fn derive_prints_gradient_hessian_psi_and_flags() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(
        &[
            "derive",
            "p1^2/(2*m) - m*g*l*cos(q1)",
            "--param",
            "m,g",
            "-p",
            "l",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    for line in [
        "z = (q1, p1)",
        "parameters: m, g, l",
        "dH/dq1 = ",
        "dH/dp1 = p1*m^(-1)",
        "d2H/dp1dp1 = m^(-1)",
        "Psi = (J gradH)^T HessH (J gradH)",
        "separable: yes",
        "time-dependent: no",
        "Psi identically zero: no",
    ] {
        assert!(out.contains(line), "missing `{line}` in\n{out}");
    }
    // Nothing was written.
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn a_malformed_expression_is_exit_2_with_every_error_located() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["derive", "p1^2 + x1 + y"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    let err = stderr(&o);
    assert!(err.contains("unknown variable `x1`"), "{err}");
    assert!(
        err.contains("(column 8)\n  p1^2 + x1 + y\n         ^^"),
        "{err}"
    );
    assert!(err.contains("`y`"), "{err}");
    assert!(stdout(&o).is_empty());
}

/// `dth derive --rust` prints the expansion of `hamiltonian! { pub struct GeneratedHamiltonian
/// { pub m: f64, .. } = EXPR }`: the struct, then the implementation the macro seals in
/// `const _: () = { .. };`, which is `dth_symbolic::emit::hamiltonian_impl` (the function the
/// macro's `expand` calls). The expected text is those tokens, built here from the emitter,
/// through the same printer (prettyplease: besides whitespace it adds trailing commas and
/// writes `#[doc]` attributes as `///` comments, so the printed file's tokens are not the
/// emitter's token for token, but its syntax tree is).
#[test]
fn derive_rust_prints_the_tokens_the_macro_emits() {
    use proc_macro2::{Ident, Span};
    use quote::quote;

    let dir = tempfile::tempdir().unwrap();
    for (expr, params) in [
        (
            "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)",
            &["m", "k"][..],
        ),
        // Time-dependent (extended phase space, D = 4) with a divided-difference kernel.
        ("p1^2/2 + q1^2/2 + q1^4/4 - f*q1*cos(w*t)", &["f", "w"][..]),
        // No parameters: a unit struct.
        ("p1^2/2 + exp(q1)", &[][..]),
    ] {
        let mut args = vec!["derive", "--rust", expr];
        if !params.is_empty() {
            args.push("--param");
        }
        let joined = params.join(",");
        if !params.is_empty() {
            args.push(&joined);
        }
        let o = dth(&args, dir.path());
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let printed = stdout(&o);

        let system = dth_symbolic::compile(expr, params).unwrap();
        let name = Ident::new("GeneratedHamiltonian", Span::call_site());
        let fields: Vec<Ident> = params
            .iter()
            .map(|p| Ident::new(p, Span::call_site()))
            .collect();
        let imp = dth_symbolic::emit::hamiltonian_impl(&system, &name, &fields);
        let decl = if fields.is_empty() {
            quote!(pub struct #name;)
        } else {
            quote!(pub struct #name { #(pub #fields: f64),* })
        };
        let expected = quote!(#decl const _: () = { #imp };);
        let expected = prettyplease::unparse(&syn::parse2(expected).unwrap());
        assert_eq!(printed, expected, "{expr}");
        // Printing is stable: the printed file parses back to itself.
        let reparsed: syn::File = syn::parse_str(&printed).unwrap();
        assert_eq!(prettyplease::unparse(&reparsed), printed);
    }
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn derive_rust_refuses_a_parameter_that_cannot_name_a_field() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(
        &["derive", "--rust", "p1^2/(2*fn) + q1^2", "-p", "fn"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("parameter `fn` is not a Rust identifier"));
    assert!(stdout(&o).is_empty());
}

/// A lattice of sums prints as the loops the macro emits: the chain of 4096 particles (beyond
/// what the site-by-site engine builds) prints, and its code is the same size as the chain of
/// 64's (loops over the sites, not one line per site).
#[test]
fn derive_rust_prints_a_lattice_of_sums_as_loops() {
    let dir = tempfile::tempdir().unwrap();
    let chain = |n: usize| {
        format!(
            "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3) \
             where N = {n}, q[0] = q[N+1] = 0"
        )
    };
    let printed = |n: usize| {
        let src = chain(n);
        let o = dth(&["derive", "--rust", &src, "-p", "alpha"], dir.path());
        assert_eq!(o.status.code(), Some(0), "N = {n}: {}", stderr(&o));
        stdout(&o)
    };
    let (small, large) = (printed(64), printed(4096));
    assert!(large.contains("Const<8192usize>"), "{large}");
    // The two differ only in the numbers that carry N (the dimension, the loop bounds).
    let (a, b) = (small.len() as f64, large.len() as f64);
    assert!(
        (b - a).abs() <= 0.01 * a,
        "{a} bytes at N = 64, {b} at N = 4096"
    );
}

/// A lattice beyond the 512 sites the engine writes out site by site: derived once per summand
/// when its sums compile to loops, else one error at `N`'s value; never one error per site.
#[test]
fn derive_a_lattice_beyond_what_is_written_out() {
    let dir = tempfile::tempdir().unwrap();
    let chain = "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) \
                 where N = 1000, q[0] = q[N+1] = 0";
    let o = dth(&["derive", chain], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    for line in [
        "n = 1000 degrees of freedom, D = 2000",
        "separable: yes",
        "Psi identically zero: no",
        // The band of a chain: 1000 + 999 among the positions, 1000 momenta.
        "Hessian: 2999 nonzero entries",
        "sum 2 over i = 0..1000, summand S in q1 = q[i+1], q2 = q[i]",
        "dS/dq1 = q1 - q2",
    ] {
        assert!(out.contains(line), "missing `{line}` in\n{out}");
    }
    let errors = |src: &str| {
        let o = dth(&["derive", src], dir.path());
        assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
        let err = stderr(&o);
        // One diagnostic, each located by its column.
        assert_eq!(err.matches("(column ").count(), 1, "{err}");
        err
    };
    // A term outside the sums: written out site by site, which stops at 512.
    let src = "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) + q1^4 where N = 1000";
    let err = errors(src);
    assert!(
        err.contains("lattice too large: 1000 sites, at most 512 when the sums are written out"),
        "{err}"
    );
    // At `N`'s value.
    let at = src.rfind("1000").unwrap_or_default();
    assert!(
        err.contains(&format!("\n  {}^^^^\n", " ".repeat(at))),
        "{err}"
    );
    let err = errors("sum(i = 1..N, p[i]^2/2 + q[i]^2/2) where N = 1000000000000");
    assert!(
        err.contains("lattice too large: 1000000000000 sites, at most 16384 are supported"),
        "{err}"
    );
}

/// `-p 1x` was accepted and never matched (the error named the expression's `k`, not the
/// option), `-p ""` and `-p k,` declared an empty name silently, and `-p q1` was reported at
/// column 1 of the expression. Each is now clap's error naming `--param` and the value.
#[test]
fn a_malformed_parameter_name_is_an_error_naming_the_option() {
    let dir = tempfile::tempdir().unwrap();
    for (value, why) in [
        ("1x", "`1x` is not a parameter name"),
        ("k x", "`k x` is not a parameter name"),
        ("k,", "an empty parameter name"),
        ("", "an empty parameter name"),
        ("q1", "`q1` is a phase-space variable"),
        ("sin", "`sin` is a function of the grammar"),
    ] {
        let o = dth(&["derive", "p1^2/2 + k*q1^2", "-p", value], dir.path());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{value:?}: {err}");
        assert!(err.contains("'--param <PARAMS>'"), "{value:?}: {err}");
        assert!(err.contains(why), "{value:?}: {err}");
        assert!(stdout(&o).is_empty());
    }
}

/// `p1^2 + ... + p599^2` has 87 indices past the limit of 512: each was printed under the
/// whole 4,000-character expression (350 kB of output). Now the first 20 are shown, each under
/// a window of the line around it, then how many more there are.
#[test]
fn many_errors_in_a_long_expression_are_shown_briefly() {
    let dir = tempfile::tempdir().unwrap();
    let expr: Vec<String> = (1..600).map(|i| format!("p{i}^2")).collect();
    let o = dth(&["derive", &expr.join("+")], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.matches("error: index in `p").count(), 20, "{err}");
    assert!(
        err.contains("... and 67 more errors (the first 20 are shown)"),
        "{err}"
    );
    // The first: `p513` at column 3477, in a window of 40 characters on each side.
    assert!(
        err.contains(
            "(column 3477)\n  ...07^2+p508^2+p509^2+p510^2+p511^2+p512^2+p513^2+p514^2+p515^2+p516^2+p517^2+p518^2+p5...\n\
             \x20                                            ^^^^\n"
        ),
        "{err}"
    );
    assert!(err.len() < 5_000, "{} bytes", err.len());
}

/// `--regularize` prints the regularized `K` (the radius cancelled) with its Psi, and a
/// Hamiltonian the regularization does not fit is exit 2, underlined.
#[test]
fn derive_regularize_prints_k_and_refuses_what_does_not_fit() {
    let dir = tempfile::tempdir().unwrap();
    let kepler = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";
    let o = dth(
        &["derive", "--regularize", "levi-civita", kepler, "-p", "m,k"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    for line in [
        "regularized: K = |u|^2 (H + p_t)",
        "z = (q1, q2, t, p1, p2, p_t)",
        "simplified: (1/8)*(p1^2 + p2^2)*m^(-1) - k + (q1^2 + q2^2)*p_t",
        "Psi = (J gradH)^T HessH (J gradH)",
    ] {
        assert!(out.contains(line), "missing `{line}` in\n{out}");
    }
    let o = dth(
        &[
            "derive",
            "--regularize",
            "ks",
            "p1^2 + p2^2 + p3^2 + p4^2 - 1/q4",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("more than three degrees of freedom"),
        "{}",
        stderr(&o)
    );
    assert!(entries(dir.path()).is_empty());
}
