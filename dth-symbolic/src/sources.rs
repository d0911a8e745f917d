//! Hamiltonians as source text, for any size: the systems that the engine's tests, the
//! macro's tests and the compile-cost benchmark grow, defined once so all of them measure the
//! same Hamiltonian.

/// The Toda chain between walls with `n >= 1` degrees of freedom (`D = 2n`):
/// `H = sum p_i^2 / 2 + exp(-q1) + sum exp(q_i - q_{i+1}) + exp(q_n)`. The upper triangle of its
/// Hessian has `3n - 1` nonzero entries (tridiagonal q-block, identity on p).
///
/// ```
/// use dth_symbolic::sources::toda_fixed_ends;
/// assert_eq!(
///     toda_fixed_ends(2),
///     "(p1^2 + p2^2)/2 + exp(-q1) + exp(q1 - q2) + exp(q2)"
/// );
/// assert_eq!(dth_symbolic::compile(&toda_fixed_ends(3), &[]).unwrap().dim(), 6);
/// ```
pub fn toda_fixed_ends(n: usize) -> String {
    let kinetic: Vec<String> = (1..=n).map(|i| format!("p{i}^2")).collect();
    let mut src = format!("({})/2 + exp(-q1)", kinetic.join(" + "));
    for i in 1..n {
        src.push_str(&format!(" + exp(q{i} - q{})", i + 1));
    }
    src.push_str(&format!(" + exp(q{n})"));
    src
}

/// The FPUT-alpha chain (Fermi-Pasta-Ulam-Tsingou) with fixed ends, `n >= 1` particles
/// (`D = 2n`) and `alpha = 1/4`:
/// `H = sum p_i^2 / 2 + sum_{i=0}^{n} [(q_{i+1} - q_i)^2 / 2 + alpha (q_{i+1} - q_i)^3 / 3]`
/// with `q_0 = q_{n+1} = 0`. Like the Toda chain, the upper triangle of its Hessian has
/// `3n - 1` nonzero entries (tridiagonal q-block, identity on p).
///
/// ```
/// use dth_symbolic::sources::fput_alpha_fixed_ends;
/// assert_eq!(
///     fput_alpha_fixed_ends(2),
///     "(p1^2 + p2^2)/2 + q1^2/2 + q1^3/12 + (q2 - q1)^2/2 + (q2 - q1)^3/12 \
///      + q2^2/2 - q2^3/12"
/// );
/// let h = dth_symbolic::compile(&fput_alpha_fixed_ends(4), &[]).unwrap();
/// assert_eq!((h.dim(), h.hessian_nonzeros().len()), (8, 11));
/// ```
pub fn fput_alpha_fixed_ends(n: usize) -> String {
    let kinetic: Vec<String> = (1..=n).map(|i| format!("p{i}^2")).collect();
    // alpha / 3 = 1/12; the last bond is `0 - q_n`, whose cube changes sign.
    let mut src = format!("({})/2 + q1^2/2 + q1^3/12", kinetic.join(" + "));
    for i in 1..n {
        let d = format!("(q{} - q{i})", i + 1);
        src.push_str(&format!(" + {d}^2/2 + {d}^3/12"));
    }
    src.push_str(&format!(" + q{n}^2/2 - q{n}^3/12"));
    src
}

/// 3-D gravity of `n` bodies of unit mass, `G = 1`, in one line (`D = 6n`): body `i` at
/// `q[3i-2..3i]`, its momentum at `p[3i-2..3i]`; the kinetic energy a strided sum, the
/// potential a sum over pairs. Both compile once for all bodies ([`crate::looped`]).
///
/// ```
/// use dth_symbolic::{looped, sources::gravity_3d};
/// let h = looped::compile(&gravity_3d(1024), &[]).unwrap();
/// assert_eq!(h.dim(), 6 * 1024);
/// assert_eq!(h.ops(), looped::compile(&gravity_3d(8), &[]).unwrap().ops());
/// ```
pub fn gravity_3d(n: usize) -> String {
    format!(
        "sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/2) - sum(1 <= i < j <= N, \
         ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 + (q[3*i] - q[3*j])^2)^(-1/2)) \
         where N = {n}"
    )
}

/// The Calogero-Moser system of `n` particles on a line, in one line (`D = 2n`):
/// `H = sum p_i^2 / 2 + g^2 sum_{i<j} (q_i - q_j)^-2`, the coupling `g` a parameter.
///
/// ```
/// use dth_symbolic::{looped, sources::calogero_moser};
/// assert_eq!(looped::compile(&calogero_moser(256), &["g"]).unwrap().dim(), 512);
/// ```
pub fn calogero_moser(n: usize) -> String {
    format!("sum(i = 1..N, p[i]^2/2) + g^2*sum(1 <= i < j <= N, (q[i] - q[j])^(-2)) where N = {n}")
}
