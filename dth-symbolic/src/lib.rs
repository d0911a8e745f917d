//! The symbolic engine behind `dth::hamiltonian!`, in plain Rust so it is tested without a
//! compiler and can serve a run-time path.
//!
//! # Layers
//!
//! One module per stage; each imports only from the modules listed before it:
//!
//! 1. [`span`], [`number`], [`error`], [`double_double`]: byte ranges, exact numbers, the
//!    errors, double-double arithmetic.
//! 2. [`lexer`] -> [`parser`]: `&str` to a syntax tree with byte spans.
//! 3. [`arena`] -> [`simplify`] -> [`check`] -> `build`: the hash-consed expression arena,
//!    its simplifying constructors (the only way nodes enter it), name resolution, and the
//!    syntax tree built into the arena.
//! 4. [`diff`], [`display`]: symbolic derivatives; expressions printed.
//! 5. [`kernel`]: the divided-difference kernels, each formula written once for the
//!    interpreter and for the macro's generated code, and the per-function rules they serve.
//! 6. [`lower`]: straight-line programs, one per trait method.
//! 7. [`divided`] -> [`defect`]: the exact, cancellation-free discrete gradient by divided
//!    differences, and its trapezoid defect `g0 + g1 - 2 gbar`, also without cancellation,
//!    lowered to two-point programs.
//! 8. [`eval`]: an interpreter for programs (in doubles, and a program's value in
//!    double-double).
//! 9. [`system`]: [`compile`], the whole pipeline (gradient, Hessian upper triangle, Psi, and
//!    the programs).
//! 10. [`looped`]: lattices (`sum(i = 1..N, ...)`) compiled once per summand and evaluated in
//!     loops over the sites, so the work does not grow with `N`.
//! 11. `emit` (feature `emit`): a compiled system as the Rust code `hamiltonian!` emits, so
//!     the macro and other tools (`dth derive --rust`) produce the same tokens.
//!
//! 12. [`regularize`]: a Hamiltonian rewritten in regularizing coordinates (Levi-Civita in the
//!     plane, Kustaanheimo-Stiefel in space), then compiled as in 9; [`solver`]: which Newton
//!     solver a compiled system's size calls for (the rule `hamiltonian!` and the JIT share).
//!
//! [`sources`] (Hamiltonians as text, for tests and benchmarks) stands apart and imports
//! nothing.
//!
//! ```
//! use dth_symbolic::{compile, Method};
//!
//! let kepler = compile("p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap();
//! assert_eq!((kepler.dim(), kepler.separable(), kepler.time_dependent()), (4, true, false));
//! assert_eq!(kepler.expr(kepler.gradient()[2]).to_string(), "2*p1");
//! let e = kepler.program(Method::All).eval(&[0.5, 0.0, 0.0, 1.2], &[]).unwrap();
//! assert!((e.value - (1.44 - 2.0)).abs() < 1e-15);
//! ```
//!
//! Errors come all at once, each with the byte range of the smallest offending piece:
//!
//! ```
//! let errors = dth_symbolic::compile("x1 + p1^2 + q0", &[]).unwrap_err();
//! assert_eq!(errors.0.len(), 2);
//! assert_eq!(errors.0[0].to_string(),
//!     "unknown variable `x1`: expected q1..qN, p1..pN, t, or a declared parameter");
//! assert_eq!(errors.0[1].span.range(), 12..14);
//! ```
#![warn(missing_docs)]

pub mod arena;
mod build;
pub mod check;
pub mod defect;
pub mod diff;
pub mod display;
pub mod divided;
pub mod double_double;
#[cfg(feature = "emit")]
pub mod emit;
pub mod error;
pub mod eval;
pub mod kernel;
mod lattice;
pub mod lexer;
pub mod looped;
pub mod lower;
pub mod number;
pub mod parser;
pub mod regularize;
pub mod simplify;
pub mod solver;
pub mod sources;
pub mod span;
pub mod system;

pub use arena::{Arena, Func, Id, Node, Var, VarSet};
pub use check::reserved_name;
pub use error::{Error, ErrorKind, Errors, EvalError, Warning, WarningKind};
pub use eval::{Evaluation, PairEvaluation};
pub use kernel::Kernel;
pub use lower::{Op, Output, Program, Slot, Stats};
pub use number::{Num, Rational};
pub use span::Span;
pub use system::{expression, Method, System};

/// Parses, checks and differentiates `src`, a Hamiltonian in the grammar, with the declared
/// parameter names `params`. Every independent error is returned, in source order.
///
/// Sums are written out site by site, at most [`MAX_INDEX`] sites ([`looped`] compiles the
/// lattices that loop, up to [`MAX_SITES`]). A lattice beyond that whose sums loop but hold a
/// fault (an index out of range, a site no variable reaches, no momentum, ...) gets the
/// fault's errors, as the same source at a smaller size does, not "too large": they are what
/// the user must mend first.
///
/// ```
/// let h = dth_symbolic::compile("p1^2/2 + q1^2/2", &[]).unwrap();
/// assert_eq!(h.dim(), 2);
/// assert_eq!(h.expr(h.gradient()[0]).to_string(), "q1");
/// assert!(h.separable() && !h.psi_identically_zero());
///
/// // 1000 sites is too many to write out; the missing boundary `q[N+1]` is what is wrong.
/// let chain = "sum(i = 1..N, p[i]^2/2 + (q[i+1] - q[i])^2/2) where N = 1000";
/// let errors = dth_symbolic::compile(chain, &[]).unwrap_err().to_string();
/// assert!(errors.starts_with("index out of range: `q[i+1]` is `q[1001]` at `i = 1000`"), "{errors}");
/// ```
pub fn compile(src: &str, params: &[&str]) -> Result<System, Errors> {
    system::written_out(src, params).map_err(|errors| {
        let too_large = errors.0.iter().any(
            |e| matches!(e.kind, ErrorKind::LatticeTooLarge { limit, .. } if limit == MAX_INDEX),
        );
        if !too_large {
            return errors;
        }
        match looped::compile(src, params) {
            Err(looped::LoopError::Errors(faults)) => faults,
            _ => errors,
        }
    })
}

/// The largest coordinate index accepted (`q512`, a chain of 512 particles): a typo like `q1000` would otherwise
/// silently produce a 2000-dimensional system.
pub const MAX_INDEX: usize = 512;

/// The most sites a lattice compiled to loops ([`looped`]) may have: `sum(i = 1..N, ...)`
/// with `N` up to this, `D = 2N`. What bounds it is the generated type, not the engine (whose
/// work does not grow with `N`):
///
/// - when this bound was chosen, the generated code wrote the Hessian's pattern out in the
///   compiler's constant evaluator in every build of the user's crate (`cargo check` of the
///   FPUT-alpha chain took 4.1 s at `N = 8192`, 7.0 s at 16384, 14 s at 32768 and 54 s at
///   65536, 2-core machine under load, 2026-11-26); the pattern is now expanded at run time
///   from its diagonal runs (see `emit::lattice`), and these sizes are not re-measured;
/// - every phase-space vector of the generated type is an `SVector<f64, D>` on the stack, 16
///   bytes per site: 256 KB at this bound, and a step of the stepper holds some of them, on
///   the 8 MB main thread or the 2 MB threads `cargo test` runs tests on; `psi` and the dense
///   `hessian_into` keep the Hessian's nonzeros (3 per site for a chain) on the stack too.
///
/// Beyond it (`N = 10^12`, `N = 9223372036854775807`) compiling is one error at `N`'s value,
/// [`ErrorKind::LatticeTooLarge`], checked before anything is counted out per site; the
/// site-by-site path ([`compile`]) reports the same error there, and its own bound,
/// [`MAX_INDEX`], below.
pub const MAX_SITES: usize = 16384;

/// The largest arena [`compile`] builds ([`Arena::size`]: nodes plus operands, summed), value,
/// gradient, Hessian and Psi together: about 60,000 for 20 bodies in 3D with all pairwise
/// forces; 570,000, just beyond, for `exp` of the product of 64 variables, which took a
/// minute of `cargo build` (most of it compiling the generated code); 4 million for 128
/// variables (whose Hessian alone has 8,000 dense products of 126 factors: minutes in the
/// macro, a million lines of code). Beyond it, compiling is an error, so no input exhausts
/// the machine.
pub const MAX_SIZE: usize = 500_000;

#[cfg(test)]
mod tests;
