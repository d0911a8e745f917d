//! Regularizations: a Hamiltonian rewritten in coordinates where DTH does not break down at
//! a collision or close encounter.
//!
//! DTH needs `Psi = (J grad H)^T Hess H (J grad H)` to keep its sign along the orbit; on an
//! eccentric Kepler orbit it changes sign near pericentre, and no time transformation alone
//! mends it (for `K = g (H - E)` on `H = E`, `Psi_K = g^3 Psi_H`). A point transformation
//! with a time transformation does: **Levi-Civita** ([`levi_civita`]) maps the plane
//! `q = (u1^2 - u2^2, 2 u1 u2)`, with the momenta `p = A(u) P / (2 |u|^2)`,
//! `A(u) = [[u1, -u2], [u2, u1]]` (so that `p . dq = P . du`: the map is canonical), and
//! takes the fictitious time `s` with `dt = |u|^2 ds`, in the extended phase space:
//!
//! ```text
//! K(u, t, P, p_t) = |u|^2 (H(q(u), p(u, P)) + p_t),   on K = 0 (p_t = -E).
//! ```
//!
//! `t` is a coordinate of `K` (`dt/ds = dK/dp_t = |u|^2`), so a run carries physical time.
//! Kepler `H = |p|^2/(2m) - k/|q|` becomes `K = |P|^2/(8m) - k + p_t |u|^2`, a harmonic
//! oscillator for `E < 0`, whose `Psi` is positive everywhere, collision orbits included.
//!
//! The radius cancels symbolically, not numerically: `q1^2 + q2^2` is `|u|^4` and
//! `p1^2 + p2^2` is `|P|^2 / (4 |u|^2)` (recognised with any common factor, as in
//! `(p1^2 + p2^2)/(2*m)`), and `|u|^2` multiplies every term of `H` on its own, so
//! `|u|^2 (q1^2 + q2^2)^(-1/2)` is `1`. Other terms are substituted as they stand (`F q1`
//! becomes `F (u1^2 - u2^2)`).
//!
//! **Kustaanheimo-Stiefel** ([`kustaanheimo_stiefel`]) does the same in space with four `u`:
//! `q = (L(u) u)_{1..3}` and `p = (L(u) P)_{1..3} / (2 |u|^2)` with the KS matrix
//!
//! ```text
//! L(u) = [[u1, -u2, -u3,  u4],
//!         [u2,  u1, -u4, -u3],
//!         [u3,  u4,  u1,  u2],
//!         [u4, -u3,  u2, -u1]],   L^T L = |u|^2 I,
//! ```
//!
//! on the manifold where the bilinear invariant `u4 P1 - u3 P2 + u2 P3 - u1 P4` (the fourth
//! row of `L(u) P`) is zero: there `|p|^2 = |P|^2 / (4 |u|^2)`, which `K` uses, and off it `K`
//! differs by a multiple of the invariant's square, so the flow on the manifold is the same and
//! keeps it (a quadratic invariant: DTH keeps it at its vertices).
//!
//! In the compiled system the regularized coordinates take the grammar's names: `q1`, `q2`
//! (`.. q4`) are `u1`, `u2` (`.. u4`), and `p1`, `p2` (`.. p4`) are `P1`, `P2` (`.. P4`); the
//! state is `z = (u, t, P, p_t)`.
//!
//! ```
//! use dth_symbolic::regularize::levi_civita;
//! let k = levi_civita("(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)", &["m", "k"]).unwrap();
//! assert_eq!(k.dim(), 6);
//! // r / |u|^2 cancelled: a harmonic oscillator in u at p_t = -E > 0.
//! assert_eq!(k.expr(k.value()).to_string(), "(1/8)*(p1^2 + p2^2)*m^(-1) - k + (q1^2 + q2^2)*p_t");
//! ```

use crate::arena::{Arena, Id, Node, Var};
use crate::build::coordinates;
use crate::error::{Error, ErrorKind, Errors};
use crate::number::{Fault, Num};
use crate::system::{derive_value, expression, System};
use crate::{Output, Program};
use std::collections::HashMap;

/// A regularizing point transformation `q = (L(u) u)_i`, `p = (L(u) P)_i / (2 |u|^2)` for
/// `i = 1..physical`, by the rows of its matrix `L(u)`: entry `(sign, k)` is `sign * u_k`.
struct Map {
    /// Its name in errors.
    name: &'static str,
    /// The physical degrees of freedom it maps (`q1..q_physical`).
    physical: u32,
    /// What a Hamiltonian of more degrees of freedom is told.
    wrong_dimension: &'static str,
    /// `L(u)`, square, of the regularized degrees of freedom.
    rows: &'static [&'static [(i8, u32)]],
}

/// Levi-Civita: `A(u) = [[u1, -u2], [u2, u1]]`.
const LEVI_CIVITA: Map = Map {
    name: "levi-civita",
    physical: 2,
    wrong_dimension:
        "the Hamiltonian is not planar (Levi-Civita needs exactly two degrees of freedom, q1, q2, p1, p2)",
    rows: &[&[(1, 1), (-1, 2)], &[(1, 2), (1, 1)]],
};

/// Kustaanheimo-Stiefel (see the [module docs](self)).
const KUSTAANHEIMO_STIEFEL: Map = Map {
    name: "kustaanheimo-stiefel",
    physical: 3,
    wrong_dimension:
        "the Hamiltonian has more than three degrees of freedom (Kustaanheimo-Stiefel maps q1, q2, q3, p1, p2, p3)",
    rows: &[
        &[(1, 1), (-1, 2), (-1, 3), (1, 4)],
        &[(1, 2), (1, 1), (-1, 4), (-1, 3)],
        &[(1, 3), (1, 4), (1, 1), (1, 2)],
        &[(1, 4), (-1, 3), (1, 2), (-1, 1)],
    ],
};

/// The Levi-Civita regularization of the planar Hamiltonian `src` (two degrees of freedom,
/// autonomous) with the parameters `params`: the compiled `K` of the [module docs](self), on
/// `z = (u1, u2, t, P1, P2, p_t)`.
///
/// # Errors
/// The expression's own errors (as [`crate::compile`]), and
/// [`ErrorKind::CannotRegularize`] for a Hamiltonian that is not planar (degrees of freedom
/// other than `q1, q2, p1, p2`) or uses `t`.
pub fn levi_civita(src: &str, params: &[&str]) -> Result<System, Errors> {
    regularize(src, params, &LEVI_CIVITA)
}

/// The Kustaanheimo-Stiefel regularization of the spatial Hamiltonian `src` (at most three
/// degrees of freedom, autonomous): `K` on `z = (u1..u4, t, P1..P4, p_t)` (see the
/// [module docs](self)).
///
/// ```
/// use dth_symbolic::regularize::kustaanheimo_stiefel;
/// let k = kustaanheimo_stiefel("p1^2 + p2^2 + p3^2 - (q1^2 + q2^2 + q3^2)^(-1/2)", &[]).unwrap();
/// assert_eq!(k.dim(), 10);
/// assert_eq!(k.expr(k.value()).to_string(), "-1 + (1/4)*(p1^2 + p2^2 + p3^2 + p4^2) + (q1^2 + q2^2 + q3^2 + q4^2)*p_t");
/// ```
///
/// # Errors
/// As [`levi_civita`], for more than three degrees of freedom.
pub fn kustaanheimo_stiefel(src: &str, params: &[&str]) -> Result<System, Errors> {
    regularize(src, params, &KUSTAANHEIMO_STIEFEL)
}

/// `src` regularized by `map`.
fn regularize(src: &str, params: &[&str], map: &Map) -> Result<System, Errors> {
    let (mut arena, h, whole) = expression(src, params)?;
    let cannot = |reason| {
        Errors(vec![Error::new(
            ErrorKind::CannotRegularize {
                name: map.name,
                reason,
            },
            whole,
        )])
    };
    let vars = arena.vars(h);
    if vars.contains(&Var::T) {
        return Err(cannot(
            "the Hamiltonian uses t (regularize an autonomous H; the extended phase space carries the physical time)",
        ));
    }
    if vars
        .iter()
        .any(|v| matches!(v, Var::Q(i) | Var::P(i) if *i > map.physical))
    {
        return Err(cannot(map.wrong_dimension));
    }
    let fault = |f: Fault| Errors(vec![Error::new(ErrorKind::Fault(f), whole)]);
    // The physical H's value on (q, p), kept for a start's energy (`System::physical_value`).
    let physical = Program::lower(
        &arena,
        &coordinates(map.physical, false),
        &[(Output::Value, h)],
    );
    let k = Substitution::new(&mut arena, map)
        .and_then(|mut sub| sub.regularized(&mut arena, h))
        .map_err(fault)?;
    let n = map.rows.len();
    let mut system = derive_value(arena, k, n, true, whole).map_err(|e| Errors(vec![e]))?;
    system.regularized = true;
    system.physical = Some(physical);
    Ok(system)
}

/// The substitution of the [module docs](self), node by node over the original `H` (its
/// nodes are read, never changed; the new ones join the same arena).
struct Substitution {
    /// `q_i`, `p_i` of the original `H` as expressions in `u`, `P`.
    q: Vec<Id>,
    p: Vec<Id>,
    /// `|u|^2`.
    s: Id,
    /// `|P|^2 / (4 |u|^2)`: `p1^2 + .. + p_n^2` (on the bilinear invariant's zero for KS).
    p_squared: Id,
    /// The original variables' nodes, `q1..q_n` and `p1..p_n` (`n` physical).
    q_vars: Vec<Id>,
    p_vars: Vec<Id>,
    /// Each original node's image.
    done: HashMap<Id, Id>,
}

impl Substitution {
    fn new(a: &mut Arena, map: &Map) -> Result<Self, Fault> {
        let n = map.rows.len() as u32;
        let u: Vec<Id> = (1..=n).map(|i| a.var(Var::Q(i))).collect();
        let pp: Vec<Id> = (1..=n).map(|i| a.var(Var::P(i))).collect();
        let squares = |a: &mut Arena, x: &[Id]| -> Result<Id, Fault> {
            let sq = x
                .iter()
                .map(|&v| a.pow(v, Num::int(2)))
                .collect::<Result<Vec<_>, _>>()?;
            a.add(&sq)
        };
        let s = squares(a, &u)?;
        // Row i of L(x) applied to y: sum_j sign * x_k * y_j.
        let row = |a: &mut Arena, i: usize, y: &[Id]| -> Result<Id, Fault> {
            let terms = map.rows[i]
                .iter()
                .zip(y)
                .map(|(&(sign, k), &yj)| {
                    let c = a.num(Num::int(i128::from(sign)));
                    a.mul(&[c, u[k as usize - 1], yj])
                })
                .collect::<Result<Vec<_>, _>>()?;
            a.add(&terms)
        };
        let inverse = |a: &mut Arena, c: i128| -> Result<Id, Fault> {
            let inv = a.pow(s, Num::int(-1))?;
            let c = a.num(Num::int(c).pow(Num::int(-1))?);
            a.mul(&[c, inv])
        };
        let half_over_s = inverse(a, 2)?;
        let physical = map.physical as usize;
        let mut q = Vec::with_capacity(physical);
        let mut p = Vec::with_capacity(physical);
        for i in 0..physical {
            q.push(row(a, i, &u)?);
            let lp = row(a, i, &pp)?;
            p.push(a.mul(&[lp, half_over_s])?);
        }
        let quarter_over_s = inverse(a, 4)?;
        let all_p = squares(a, &pp)?;
        let p_squared = a.mul(&[all_p, quarter_over_s])?;
        Ok(Substitution {
            q,
            p,
            s,
            p_squared,
            q_vars: (1..=map.physical).map(|i| a.var(Var::Q(i))).collect(),
            p_vars: (1..=map.physical).map(|i| a.var(Var::P(i))).collect(),
            done: HashMap::new(),
        })
    }

    /// `K = |u|^2 (H' + p_t)`, `|u|^2` multiplied into each term of `H'` (the image of `H`,
    /// whose pairs of squares are found among all of `H`'s terms: `p1^2 + p2^2 - 1/r` has its
    /// kinetic pair at the top).
    fn regularized(&mut self, a: &mut Arena, h: Id) -> Result<Id, Fault> {
        let image = self.image(a, h)?;
        let terms: Vec<Id> = match a.node(image) {
            Node::Add(ch) => ch.to_vec(),
            _ => vec![image],
        };
        let mut out = Vec::with_capacity(terms.len() + 1);
        for t in terms {
            out.push(a.mul(&[self.s, t])?);
        }
        let pt = a.var(Var::Pt);
        out.push(a.mul(&[self.s, pt])?);
        a.add(&out)
    }

    /// The image of an original node.
    fn image(&mut self, a: &mut Arena, id: Id) -> Result<Id, Fault> {
        if let Some(&done) = self.done.get(&id) {
            return Ok(done);
        }
        let image = match a.node(id).clone() {
            Node::Num(_) => id,
            Node::Var(v) => match v {
                Var::Q(i) => self.q[i as usize - 1],
                Var::P(i) => self.p[i as usize - 1],
                _ => id,
            },
            Node::Add(ch) => self.sum(a, &ch)?,
            Node::Mul(ch) => {
                let f = ch
                    .iter()
                    .map(|&c| self.image(a, c))
                    .collect::<Result<Vec<_>, _>>()?;
                a.mul(&f)?
            }
            // |q|^(2e) = |u|^(4e): |u|^2 is not negative, so the powers merge.
            Node::Pow(base, e) if is_full_sum(a, base, &self.q_vars) => {
                a.pow(self.s, e.try_mul(Num::int(2))?)?
            }
            Node::Pow(base, e) => {
                let b = self.image(a, base)?;
                a.pow(b, e)?
            }
            Node::Func(f, x) => {
                let x = self.image(a, x)?;
                a.func(f, x)?
            }
        };
        self.done.insert(id, image);
        Ok(image)
    }

    /// The image of a sum, with `c (q1^2 + .. + qn^2)` as `c |u|^4` and `c (p1^2 + .. + pn^2)`
    /// as `c |P|^2 / (4 |u|^2)` (each square with the same cofactor `c`).
    fn sum(&mut self, a: &mut Arena, terms: &[Id]) -> Result<Id, Fault> {
        let mut rest: Vec<Id> = terms.to_vec();
        let mut out = Vec::with_capacity(terms.len());
        let groups = [
            (self.q_vars.clone(), None),
            (self.p_vars.clone(), Some(self.p_squared)),
        ];
        for (vars, whole) in groups {
            // Cofactors of x_i^2 among the terms.
            let mut cofactors: Vec<(usize, Id, usize)> = Vec::new();
            for (k, &t) in rest.iter().enumerate() {
                if let Some((c, i)) = square_cofactor(a, t, &vars) {
                    cofactors.push((k, c, i));
                }
            }
            let mut used = vec![false; rest.len()];
            for &(k0, c0, i0) in &cofactors {
                if used[k0] || i0 != 0 {
                    continue;
                }
                // The same cofactor on every other square of the group.
                let others: Option<Vec<usize>> = (1..vars.len())
                    .map(|i| {
                        cofactors
                            .iter()
                            .find(|&&(k, c, j)| j == i && c == c0 && !used[k])
                            .map(|&(k, _, _)| k)
                    })
                    .collect();
                if let Some(others) = others {
                    used[k0] = true;
                    for k in others {
                        used[k] = true;
                    }
                    let c = self.image(a, c0)?;
                    let square = match whole {
                        Some(pp) => pp,
                        None => a.pow(self.s, Num::int(2))?,
                    };
                    out.push(a.mul(&[c, square])?);
                }
            }
            rest = rest
                .into_iter()
                .zip(used)
                .filter_map(|(t, u)| (!u).then_some(t))
                .collect();
        }
        for t in rest {
            out.push(self.image(a, t)?);
        }
        a.add(&out)
    }
}

/// `true` when `id` is exactly `x1^2 + .. + xn^2` for `vars = x1..xn` (no factor, nothing
/// else).
fn is_full_sum(a: &mut Arena, id: Id, vars: &[Id]) -> bool {
    let terms = match a.node(id) {
        Node::Add(ch) if ch.len() == vars.len() => ch.to_vec(),
        _ => return false,
    };
    let one = a.num(Num::ONE);
    let mut seen = vec![false; vars.len()];
    for t in terms {
        match square_cofactor(a, t, vars) {
            Some((c, i)) if c == one && !seen[i] => seen[i] = true,
            _ => return false,
        }
    }
    true
}

/// `(c, i)` when the term `t` is `c * x_i^2` (`c` the product of its other factors, `1` for
/// `x_i^2` alone) for `x_i` one of `vars`.
fn square_cofactor(a: &mut Arena, t: Id, vars: &[Id]) -> Option<(Id, usize)> {
    let is_square = |a: &Arena, f: Id| match a.node(f) {
        Node::Pow(b, e) if *e == Num::int(2) => vars.iter().position(|v| v == b),
        _ => None,
    };
    if let Some(i) = is_square(a, t) {
        return Some((a.num(Num::ONE), i));
    }
    let factors = match a.node(t) {
        Node::Mul(ch) => ch.to_vec(),
        _ => return None,
    };
    let (k, i) = factors
        .iter()
        .enumerate()
        .find_map(|(k, &f)| is_square(a, f).map(|i| (k, i)))?;
    let others: Vec<Id> = factors
        .iter()
        .enumerate()
        .filter_map(|(j, &f)| (j != k).then_some(f))
        .collect();
    // The product of the others is what the arena interns for it: equal cofactors are the
    // same node.
    a.mul(&others).ok().map(|c| (c, i))
}
