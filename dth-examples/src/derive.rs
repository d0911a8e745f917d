//! `dth derive`: what the symbolic engine derives from a Hamiltonian written as text — the
//! simplified gradient, the Hessian's nonzero entries, `Psi = (J gradH)^T HessH (J gradH)` and
//! the flags the integrators use — so a user can see what the compiled code computes.
//!
//! ```
//! let text = dth_examples::derive::derive("p1^2/(2*m) + k*q1^2/2", &["m", "k"])?;
//! assert!(text.contains("dH/dq1 = k*q1"));
//! assert!(text.contains("separable: yes"));
//! # Ok::<(), dth_examples::Error>(())
//! ```
//!
//! With `--rust`, [`rust`] prints the code `hamiltonian!` emits for the same expression: the
//! type and its `impl Hamiltonian<D>`, written by the engine's emitter
//! ([`dth_symbolic::emit::hamiltonian_impl`], or [`dth_symbolic::emit::looped_source_impl`] for a lattice of sums: the functions the macro calls) and formatted
//! by prettyplease.
//!
//! ```
//! let code = dth_examples::derive::rust("p1^2/(2*m) + k*q1^2/2", &["m", "k"])?;
//! assert!(code.starts_with("pub struct GeneratedHamiltonian {\n    pub m: f64,"));
//! assert!(code.contains(
//!     "impl ::dth::__private::dth_core::Hamiltonian<\n        \
//!      ::dth::__private::nalgebra::Const<2usize>,\n    > for GeneratedHamiltonian {"
//! ));
//! # Ok::<(), dth_examples::Error>(())
//! ```

use std::fmt::Write as _;

use dth_symbolic::emit::{hamiltonian_impl, looped_source_impl};
use dth_symbolic::looped::{self, Looped};
use dth_symbolic::{compile, ErrorKind, Errors, System, Var, MAX_INDEX};
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;

use crate::error::Error;

/// The report of what the engine derives from `source` (the `hamiltonian!` grammar) with the
/// declared parameter names `params`.
///
/// # Errors
/// [`Error::Hamiltonian`] with every independent error of the expression, each shown under
/// the expression with a caret line at its position.
///
/// A lattice beyond the [`dth_symbolic::MAX_INDEX`] sites the engine writes out site by site
/// whose sums compile to loops (as `hamiltonian!` compiles it) is reported once per summand,
/// in the summand's local coordinates, its flags and warnings those of
/// the whole lattice.
///
/// ```
/// let chain = "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) \
///              where N = 4096, q[0] = q[N+1] = 0";
/// let text = dth_examples::derive::derive(chain, &[])?;
/// assert!(text.contains("n = 4096 degrees of freedom, D = 8192"));
/// assert!(text.contains("dS/dq1 = q1 - q2"));
/// # Ok::<(), dth_examples::Error>(())
/// ```
pub fn derive(source: &str, params: &[&str]) -> Result<String, Error> {
    match compile(source, params) {
        Ok(system) => Ok(report(source, &system)),
        Err(errors) => {
            let written_out_only = errors.0.iter().all(|e| {
                matches!(e.kind, ErrorKind::LatticeTooLarge { limit, .. } if limit == MAX_INDEX)
            });
            if written_out_only {
                if let Ok(lattice) = looped::compile(source, params) {
                    if lattice.has_momentum() {
                        return Ok(report_looped(source, &lattice));
                    }
                }
            }
            Err(Error::Hamiltonian {
                diagnostics: render_errors(source, &errors),
            })
        }
    }
}

/// A regularization `dth derive --regularize` applies (`dth_symbolic::regularize`): the maps
/// a scene's `[system] regularize` names.
pub use crate::scene::RegularizeMap as Regularization;

/// [`derive()`] of the regularized `K` of `source`: what the engine compiles for
/// `#[regularize(..)]` (the radius cancelled, `K`'s gradient, Hessian and Psi).
///
/// ```
/// use dth_examples::derive::{derive_regularized, Regularization};
/// let text = derive_regularized("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[], Regularization::LeviCivita)?;
/// assert!(text.contains("simplified: -1 + (1/4)*(p1^2 + p2^2) + (q1^2 + q2^2)*p_t"), "{text}");
/// # Ok::<(), dth_examples::Error>(())
/// ```
///
/// # Errors
/// [`Error::Hamiltonian`] with every error under the expression (a Hamiltonian that is not
/// planar, or not spatial for KS, or uses `t`, is one).
pub fn derive_regularized(
    source: &str,
    params: &[&str],
    regularization: Regularization,
) -> Result<String, Error> {
    regularization.symbolic()(source, params)
        .map(|system| report(source, &system))
        .map_err(|errors| Error::Hamiltonian {
            diagnostics: render_errors(source, &errors),
        })
}

/// A parameter name as `dth derive --param` takes it (a clap value parser): an identifier as
/// the grammar reads one (an ASCII letter or `_`, then ASCII letters, digits or `_`) that is
/// not a name of the grammar itself (`q1`, `t`, `pi`, `sin`, ...). A malformed name would
/// otherwise be declared but never match the expression, and the error would name the
/// expression's variable instead of the option.
///
/// ```
/// use dth_examples::derive::param_name;
/// assert_eq!(param_name("omega_0").as_deref(), Ok("omega_0"));
/// assert!(param_name("1x").unwrap_err().contains("not a parameter name"));
/// assert!(param_name("q1").unwrap_err().contains("phase-space variable"));
/// ```
pub fn param_name(name: &str) -> Result<String, String> {
    let mut chars = name.chars();
    let identifier = matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_');
    if name.is_empty() {
        return Err(
            "an empty parameter name (a stray comma?): expected a name such as `m` or `k2`".into(),
        );
    }
    if !identifier {
        return Err(format!(
            "`{name}` is not a parameter name: expected an ASCII letter or `_` followed by letters, digits or `_` (e.g. `m`, `k2`, `omega_0`)"
        ));
    }
    if let Some(why) = dth_symbolic::reserved_name(name) {
        return Err(format!(
            "`{name}` {why}: a parameter needs a name of its own"
        ));
    }
    Ok(name.to_string())
}

/// The name of the type [`rust`] declares: the one the macro's expression form declares.
pub const TYPE_NAME: &str = "GeneratedHamiltonian";

/// The code `hamiltonian! { pub struct GeneratedHamiltonian { pub a: f64, .. } = SOURCE }`
/// emits for `source` with the parameters `params` (each a `pub f64` field, in this order),
/// formatted as a Rust file: the struct, and `const _: () = { impl Hamiltonian<D> .. };`.
/// The macro's warnings (spanned on the user's tokens) are left out; [`derive()`] shows them.
///
/// # Errors
/// [`Error::Hamiltonian`] for a malformed expression (as [`derive()`]) or a parameter that is
/// not a Rust identifier (a keyword, say), which cannot name a field.
pub fn rust(source: &str, params: &[&str]) -> Result<String, Error> {
    let tokens = rust_tokens(source, params)?;
    let file: syn::File = syn::parse2(tokens).map_err(|e| Error::Hamiltonian {
        diagnostics: format!("the emitted code does not parse (an emitter bug): {e}\n"),
    })?;
    Ok(prettyplease::unparse(&file))
}

/// The tokens [`rust`] formats: the declaration, and the emitter's implementation in
/// `const _: () = { .. };` as the macro's item form seals it.
///
/// # Errors
/// As [`rust`].
pub fn rust_tokens(source: &str, params: &[&str]) -> Result<TokenStream, Error> {
    let fields = params
        .iter()
        .map(|p| {
            syn::parse_str::<Ident>(p).map_err(|_| Error::Hamiltonian {
                diagnostics: format!(
                    "error: parameter `{p}` is not a Rust identifier, so it cannot name a field of the emitted type\n"
                ),
            })
        })
        .collect::<Result<Vec<Ident>, Error>>()?;
    let name = Ident::new(TYPE_NAME, Span::call_site());
    // As the macro decides: loops for a lattice of sums, else the site-by-site programs.
    let imp = match looped_source_impl(source, &name, &fields) {
        Some(imp) => imp,
        None => {
            let system = compile(source, params).map_err(|errors| Error::Hamiltonian {
                diagnostics: render_errors(source, &errors),
            })?;
            hamiltonian_impl(&system, &name, &fields)
        }
    };
    let decl = if fields.is_empty() {
        quote!(pub struct #name;)
    } else {
        quote!(pub struct #name { #(pub #fields: f64),* })
    };
    Ok(quote! {
        #decl
        const _: () = { #imp };
    })
}

/// The name of a phase-space coordinate.
fn name(v: Var) -> String {
    match v {
        Var::Q(i) => format!("q{i}"),
        Var::P(i) => format!("p{i}"),
        Var::T => "t".into(),
        Var::Pt => "p_t".into(),
        Var::Param(k) => format!("param{k}"),
    }
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

fn report(source: &str, s: &System) -> String {
    let names: Vec<String> = s.coordinates().iter().map(|&v| name(v)).collect();
    let mut out = String::new();
    let _ = writeln!(out, "H = {}", source.trim());
    if s.regularized() {
        let _ = writeln!(
            out,
            "regularized: K = |u|^2 (H + p_t) on K = 0 (p_t = -E), its q and p are u and P, t the physical time: z = ({})",
            names.join(", ")
        );
    } else if s.time_dependent() {
        let _ = writeln!(
            out,
            "extended phase space (H uses t): calH = p_t + H, z = ({})",
            names.join(", ")
        );
    } else {
        let _ = writeln!(out, "z = ({})", names.join(", "));
    }
    let _ = writeln!(
        out,
        "n = {} degrees of freedom, D = {}, parameters: {}",
        s.n(),
        s.dim(),
        if s.params().is_empty() {
            "none".to_string()
        } else {
            s.params().join(", ")
        }
    );
    let _ = writeln!(out, "simplified: {}", s.expr(s.value()));
    for w in s.warnings() {
        let _ = write!(
            out,
            "{}",
            render("warning", source, &w.to_string(), w.span.range())
        );
    }
    let _ = writeln!(out, "\nflags");
    let _ = writeln!(out, "  separable: {} (H = T(p) + V(q))", yes(s.separable()));
    let _ = writeln!(out, "  time-dependent: {}", yes(s.time_dependent()));
    let _ = writeln!(
        out,
        "  Psi identically zero: {}{}",
        yes(s.psi_identically_zero()),
        if s.psi_identically_zero() {
            " (DTH cannot run on it: the energy condition does not determine lambda)"
        } else {
            ""
        }
    );
    let _ = writeln!(out, "\ngradient");
    for (i, &g) in s.gradient().iter().enumerate() {
        let _ = writeln!(out, "  dH/d{} = {}", names[i], s.expr(g));
    }
    let _ = writeln!(
        out,
        "\nHessian: {} nonzero entries in the upper triangle (of {})",
        s.hessian_nonzeros().len(),
        s.dim() * (s.dim() + 1) / 2
    );
    for &(i, j, h) in s.hessian_nonzeros() {
        let _ = writeln!(out, "  d2H/d{}d{} = {}", names[i], names[j], s.expr(h));
    }
    let _ = writeln!(
        out,
        "\nPsi = (J gradH)^T HessH (J gradH)\n  = {}",
        s.expr(s.psi())
    );
    out
}

/// The report of a lattice compiled to loops: the whole lattice's size, flags and warnings,
/// then each sum's summand differentiated once, in its local coordinates (`q1 = q[i-1]`,
/// ...: the summand's `dS/dq1` is what each site `i` adds to `dH/dq[i-1]`).
fn report_looped(source: &str, l: &Looped) -> String {
    let mut out = String::new();
    let (n, d) = (l.n(), l.dim());
    let _ = writeln!(out, "H = {}", source.trim());
    let _ = writeln!(
        out,
        "a lattice of {n} sites, each summand differentiated once and run in loops over the sites (beyond the {MAX_INDEX} written out site by site)"
    );
    let _ = writeln!(out, "z = (q[1]..q[{n}], p[1]..p[{n}])");
    let params = l
        .sums()
        .first()
        .map(|s| s.summand().params().to_vec())
        .unwrap_or_default();
    let _ = writeln!(
        out,
        "n = {n} degrees of freedom, D = {d}, parameters: {}",
        if params.is_empty() {
            "none".to_string()
        } else {
            params.join(", ")
        }
    );
    for w in l.warnings() {
        let _ = write!(
            out,
            "{}",
            render("warning", source, &w.to_string(), w.span.range())
        );
    }
    let psi0 = l.psi_identically_zero();
    let _ = writeln!(out, "\nflags");
    let _ = writeln!(out, "  separable: {} (H = T(p) + V(q))", yes(l.separable()));
    let _ = writeln!(out, "  time-dependent: no");
    let _ = writeln!(
        out,
        "  Psi identically zero: {}{}",
        yes(psi0),
        if psi0 {
            " (DTH cannot run on it: the energy condition does not determine lambda)"
        } else {
            ""
        }
    );
    let _ = writeln!(
        out,
        "\nHessian: {} nonzero entries in the upper triangle (of {})",
        l.hessian_pattern().len(),
        d * (d + 1) / 2
    );
    for (k, sum) in l.sums().iter().enumerate() {
        let s = sum.summand();
        let (lo, hi) = sum.range();
        // The local coordinates' names in the summand's printed expressions, and what each is.
        let local: Vec<String> = s.coordinates().iter().map(|&v| name(v)).collect();
        let mut slots: Vec<String> = sum
            .slots()
            .iter()
            .map(|&(letter, c, at)| {
                let site = match c {
                    0 => "i".to_string(),
                    c if c > 0 => format!("i+{c}"),
                    c => format!("i{c}"),
                };
                format!("{} = {letter}[{site}]", local[at])
            })
            .collect();
        slots.sort();
        let _ = writeln!(
            out,
            "\nsum {} over i = {lo}..{hi}, summand S in {}",
            k + 1,
            slots.join(", ")
        );
        let _ = writeln!(out, "  S = {}", s.expr(s.value()));
        for (i, &g) in s.gradient().iter().enumerate() {
            if s.constant(g).is_none_or(|c| !c.is_zero()) {
                let _ = writeln!(out, "  dS/d{} = {}", local[i], s.expr(g));
            }
        }
        for &(i, j, h) in s.hessian_nonzeros() {
            let _ = writeln!(out, "  d2S/d{}d{} = {}", local[i], local[j], s.expr(h));
        }
    }
    out
}

/// Each error of `errors` as `error: MESSAGE (column C)` (with the line for a multi-line
/// source), then the source line and a caret line under the offending characters.
///
/// At most [`MAX_SHOWN`] errors are shown, then how many more there are: an expression with
/// thousands of the same mistake (`p1^2 + ... + p3000^2`, every index past the limit) printed
/// every one of them, each under the whole expression.
pub fn render_errors(source: &str, errors: &Errors) -> String {
    let mut text: String = errors
        .0
        .iter()
        .take(MAX_SHOWN)
        .map(|e| render("error", source, &e.to_string(), e.span.range()))
        .collect();
    if errors.0.len() > MAX_SHOWN {
        let _ = writeln!(
            text,
            "... and {} more errors (the first {MAX_SHOWN} are shown)",
            errors.0.len() - MAX_SHOWN
        );
    }
    // Names that could be parameters: `dth derive` declares parameters with `-p`, which a
    // reader of "unknown variable `m`" may not know.
    let mut undeclared: Vec<&str> = Vec::new();
    for e in &errors.0 {
        if let ErrorKind::UnknownVariable { name } = &e.kind {
            if param_name(name).is_ok() && !undeclared.contains(&name.as_str()) {
                undeclared.push(name);
            }
        }
    }
    if !undeclared.is_empty() {
        let _ = writeln!(
            text,
            "hint: if {} {} parameter{}, declare {} with `-p {}` (names only: derivation needs no values)",
            undeclared
                .iter()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", "),
            if undeclared.len() == 1 { "is a" } else { "are" },
            if undeclared.len() == 1 { "" } else { "s" },
            if undeclared.len() == 1 { "it" } else { "them" },
            undeclared.join(",")
        );
    }
    text
}

/// The most errors [`render_errors`] shows.
pub const MAX_SHOWN: usize = 20;

/// The characters of a long source line shown on each side of a diagnostic's span.
const CONTEXT: usize = 40;

/// A source line longer than this many characters is shown cut around the span.
const LONG: usize = 120;

/// One diagnostic: `LABEL: MESSAGE (column C)`, the source line, and carets under `range`.
/// A line longer than [`LONG`] characters is cut to the span and [`CONTEXT`] characters on
/// each side, with `...` where it was cut.
fn render(label: &str, source: &str, message: &str, range: std::ops::Range<usize>) -> String {
    let start = range.start.min(source.len());
    let line_start = source[..start].rfind('\n').map_or(0, |i| i + 1);
    let line_end = source[start..]
        .find('\n')
        .map_or(source.len(), |i| start + i);
    let line: Vec<char> = source[line_start..line_end].chars().collect();
    let column = source[line_start..start].chars().count();
    let width = source
        .get(start..range.end.min(line_end))
        .map_or(1, |s| s.chars().count().max(1));
    let line_no = source[..line_start].matches('\n').count() + 1;
    let at = if line_start == 0 && line_end == source.len() {
        format!("column {}", column + 1)
    } else {
        format!("line {line_no}, column {}", column + 1)
    };
    let (from, to) = if line.len() <= LONG {
        (0, line.len())
    } else {
        (
            column.saturating_sub(CONTEXT),
            (column + width + CONTEXT).min(line.len()),
        )
    };
    let (before, after) = (
        if from > 0 { "..." } else { "" },
        if to < line.len() { "..." } else { "" },
    );
    let shown: String = line[from..to].iter().collect();
    format!(
        "{label}: {message} ({at})\n  {before}{shown}{after}\n  {}{}\n",
        " ".repeat(column - from + before.len()),
        "^".repeat(width)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_shows_gradient_hessian_psi_and_flags() {
        let text = derive("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap_or_default();
        assert!(text.contains("dH/dp1 = 2*p1"), "{text}");
        assert!(text.contains("Hessian: "), "{text}");
        assert!(text.contains("Psi = "), "{text}");
        assert!(text.contains("separable: yes"), "{text}");
        assert!(text.contains("time-dependent: no"), "{text}");
        assert!(text.contains("Psi identically zero: no"), "{text}");
    }

    #[test]
    fn time_dependent_and_degenerate_systems_are_flagged() {
        let forced = derive("p1^2/2 - f*q1*cos(w*t)", &["f", "w"]).unwrap_or_default();
        assert!(forced.contains("time-dependent: yes"), "{forced}");
        assert!(forced.contains("z = (q1, t, p1, p_t)"), "{forced}");
        let free = derive("p1^2/2 + p2^2/2", &[]).unwrap_or_default();
        assert!(
            free.contains("Psi identically zero: yes (DTH cannot run"),
            "{free}"
        );
    }

    #[test]
    fn warnings_point_at_the_coordinate_without_its_conjugate() {
        let frozen = derive("p1^2/2 + q1^2/2 + eps*q1*q2", &["eps"]).unwrap_or_default();
        assert!(
            frozen.contains("warning: `q2` appears without `p2`: `q2` never moves (dH/dp2 = 0) and `p2` only drifts; a constant is better declared as a parameter (column 26)\n  p1^2/2 + q1^2/2 + eps*q1*q2\n                           ^^\n"),
            "{frozen}"
        );
        let kepler = derive("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap_or_default();
        assert!(!kepler.contains("warning"), "{kepler}");
    }

    #[test]
    fn errors_point_at_the_offending_token() {
        let Err(Error::Hamiltonian { diagnostics }) = derive("p1^2 + x1", &[]) else {
            panic!("`x1` is not a variable");
        };
        assert!(
            diagnostics.contains("unknown variable `x1`"),
            "{diagnostics}"
        );
        assert!(
            diagnostics.contains("(column 8)\n  p1^2 + x1\n         ^^"),
            "{diagnostics}"
        );
        let Err(Error::Hamiltonian { diagnostics }) = derive("p1^2\n + x1", &[]) else {
            panic!("`x1` is not a variable");
        };
        assert!(
            diagnostics.contains("(line 2, column 4)\n   + x1\n     ^^"),
            "{diagnostics}"
        );
    }
}
