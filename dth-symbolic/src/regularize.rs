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
//! In the compiled system the regularized coordinates take the grammar's names: `q1`, `q2`
//! are `u1`, `u2`, and `p1`, `p2` are `P1`, `P2`; the state is `z = (u1, u2, t, P1, P2, p_t)`.
//!
//! ```
//! use dth_symbolic::regularize::levi_civita;
//! let k = levi_civita("(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)", &["m", "k"]).unwrap();
//! assert_eq!(k.dim(), 6);
//! // r / |u|^2 cancelled: a harmonic oscillator in u at p_t = -E > 0.
//! assert_eq!(k.expr(k.value()).to_string(), "(1/8)*(p1^2 + p2^2)*m^(-1) - k + (q1^2 + q2^2)*p_t");
//! ```

use crate::arena::{Arena, Id, Node, Var};
use crate::error::{Error, ErrorKind, Errors};
use crate::number::{Fault, Num};
use crate::system::{derive_value, expression, System};
use std::collections::HashMap;

/// The Levi-Civita regularization of the planar Hamiltonian `src` (two degrees of freedom,
/// autonomous) with the parameters `params`: the compiled `K` of the [module docs](self), on
/// `z = (u1, u2, t, P1, P2, p_t)`.
///
/// # Errors
/// The expression's own errors (as [`crate::compile`]), and
/// [`ErrorKind::CannotRegularize`] for a Hamiltonian that is not planar (degrees of freedom
/// other than `q1, q2, p1, p2`) or uses `t`.
pub fn levi_civita(src: &str, params: &[&str]) -> Result<System, Errors> {
    let (mut arena, h, whole) = expression(src, params)?;
    let cannot = |reason| {
        Errors(vec![Error::new(
            ErrorKind::CannotRegularize {
                name: "levi-civita",
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
        .any(|v| matches!(v, Var::Q(i) | Var::P(i) if *i > 2))
    {
        return Err(cannot(
            "the Hamiltonian is not planar (Levi-Civita needs exactly two degrees of freedom, q1, q2, p1, p2)",
        ));
    }
    let fault = |f: Fault| Errors(vec![Error::new(ErrorKind::Fault(f), whole)]);
    let k = LeviCivita::new(&mut arena)
        .and_then(|mut lc| lc.regularized(&mut arena, h))
        .map_err(fault)?;
    let mut system = derive_value(arena, k, 2, true, whole).map_err(|e| Errors(vec![e]))?;
    system.regularized = true;
    Ok(system)
}

/// The substitution of the [module docs](self), node by node over the original `H` (its
/// nodes are read, never changed; the new ones join the same arena).
struct LeviCivita {
    /// `q1, q2, p1, p2` of the original `H` as expressions in `u`, `P`.
    q: [Id; 2],
    p: [Id; 2],
    /// `|u|^2`.
    s: Id,
    /// `|P|^2 / (4 |u|^2)`: `p1^2 + p2^2`.
    p_squared: Id,
    /// The original variables' nodes.
    q_vars: [Id; 2],
    p_vars: [Id; 2],
    /// Each original node's image.
    done: HashMap<Id, Id>,
}

impl LeviCivita {
    fn new(a: &mut Arena) -> Result<Self, Fault> {
        let (u1, u2) = (a.var(Var::Q(1)), a.var(Var::Q(2)));
        let (p1, p2) = (a.var(Var::P(1)), a.var(Var::P(2)));
        let sq = |a: &mut Arena, x| a.pow(x, Num::int(2));
        let (u1s, u2s) = (sq(a, u1)?, sq(a, u2)?);
        let s = a.add(&[u1s, u2s])?;
        let q1 = a.sub(u1s, u2s)?;
        let two = a.num(Num::int(2));
        let q2 = a.mul(&[two, u1, u2])?;
        // p = A(u) P / (2 |u|^2), A(u) = [[u1, -u2], [u2, u1]].
        let half_over_s = {
            let inv = a.pow(s, Num::int(-1))?;
            let half = a.num(Num::int(2).pow(Num::int(-1))?);
            a.mul(&[half, inv])?
        };
        let (u1p1, u2p2) = (a.mul(&[u1, p1])?, a.mul(&[u2, p2])?);
        let (u2p1, u1p2) = (a.mul(&[u2, p1])?, a.mul(&[u1, p2])?);
        let num1 = a.sub(u1p1, u2p2)?;
        let num2 = a.add(&[u2p1, u1p2])?;
        let p1_new = a.mul(&[num1, half_over_s])?;
        let p2_new = a.mul(&[num2, half_over_s])?;
        let (p1s, p2s) = (sq(a, p1)?, sq(a, p2)?);
        let pp = a.add(&[p1s, p2s])?;
        let quarter_over_s = {
            let inv = a.pow(s, Num::int(-1))?;
            let quarter = a.num(Num::int(4).pow(Num::int(-1))?);
            a.mul(&[quarter, inv])?
        };
        let p_squared = a.mul(&[pp, quarter_over_s])?;
        Ok(LeviCivita {
            q: [q1, q2],
            p: [p1_new, p2_new],
            s,
            p_squared,
            q_vars: [u1, u2],
            p_vars: [p1, p2],
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
            // (q1^2 + q2^2)^e = |u|^(4e): |u|^2 is not negative, so the powers merge.
            Node::Pow(base, e) if is_pair(a, base, self.q_vars) => {
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

    /// The image of a sum, with `c q1^2 + c q2^2` as `c |u|^4` and `c p1^2 + c p2^2` as
    /// `c |P|^2 / (4 |u|^2)`.
    fn sum(&mut self, a: &mut Arena, terms: &[Id]) -> Result<Id, Fault> {
        let mut rest: Vec<Id> = terms.to_vec();
        let mut out = Vec::with_capacity(terms.len());
        for (vars, whole) in [(self.q_vars, None), (self.p_vars, Some(self.p_squared))] {
            // Cofactors of x1^2 and x2^2 among the terms.
            let mut cofactors: Vec<(usize, Id, usize)> = Vec::new();
            for (k, &t) in rest.iter().enumerate() {
                if let Some((c, i)) = square_cofactor(a, t, vars) {
                    cofactors.push((k, c, i));
                }
            }
            let mut used = vec![false; rest.len()];
            for &(k1, c1, i1) in &cofactors {
                if used[k1] || i1 != 0 {
                    continue;
                }
                if let Some(&(k2, _, _)) = cofactors
                    .iter()
                    .find(|&&(k2, c2, i2)| i2 == 1 && c2 == c1 && !used[k2])
                {
                    used[k1] = true;
                    used[k2] = true;
                    let c = self.image(a, c1)?;
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

/// `true` when `id` is exactly `x1^2 + x2^2` (no factor, nothing else).
fn is_pair(a: &mut Arena, id: Id, vars: [Id; 2]) -> bool {
    let terms = match a.node(id) {
        Node::Add(ch) if ch.len() == 2 => [ch[0], ch[1]],
        _ => return false,
    };
    let one = a.num(Num::ONE);
    match (
        square_cofactor(a, terms[0], vars),
        square_cofactor(a, terms[1], vars),
    ) {
        (Some((c0, i0)), Some((c1, i1))) => c0 == one && c1 == one && i0 != i1,
        _ => false,
    }
}

/// `(c, i)` when the term `t` is `c * x_i^2` (`c` the product of its other factors, `1` for
/// `x_i^2` alone) for `x_i` one of `vars`.
fn square_cofactor(a: &mut Arena, t: Id, vars: [Id; 2]) -> Option<(Id, usize)> {
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
