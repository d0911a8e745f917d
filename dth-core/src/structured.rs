//! Structured linear algebra for Newton at large `D`: the Newton matrices
//! `I - sum_t a_st J Hess H(y_t)` of the implicit methods assembled from the Hessian's nonzero
//! entries only ([`NewtonMatrix`]), and a banded LU with partial pivoting after a
//! bandwidth-reducing ordering ([`BandedLu`]). No `D x D` matrix exists anywhere on this path.
//!
//! # Cost
//! [`BandedLu::analyse`] runs once per system (it allocates): the reverse Cuthill-McKee
//! ordering of the matrix's symmetrised graph and the lower and upper bandwidths `kl`, `ku`
//! after it. Each [`BandedLu::factor`] (no allocation) then costs `O(m kl (kl + ku))` for an
//! `m x m` matrix, each [`BandedLu::solve`] `O(m (2 kl + ku))`. For a chain (FPUT, Toda, any
//! nearest-neighbour lattice) `I - c J Hess` has `kl, ku <= 3` after the ordering (`q_i` and
//! `p_i` interleave), so a Newton iteration is linear in `D`. For a dense Hessian (all-pairs
//! N-body) the bandwidth is `D`: the dense fixed-size LU of `linalg` is then the faster path,
//! and generated types choose between the two ([`Flags::structured_newton`](crate::Flags::structured_newton)).
//! `docs/performance.md` records the measured crossover and the comparison with a general
//! sparse LU (faer).
//!
//! # Pivoting
//! Partial pivoting within the band (LAPACK's `dgbtf2`): the row interchanges can raise the
//! upper bandwidth to `kl + ku`, which the storage reserves. A pivot at or below
//! `m eps max|A_ij|` is [`Pivot::Singular`], as for the dense LU.
//!
//! [`Flags::structured_newton`]: crate::Flags::structured_newton
//!
//! ```
//! use dth_core::structured::BandedLu;
//! // The 4 x 4 matrix [[4, 1, 0, 0], [1, 4, 1, 0], [0, 1, 4, 1], [0, 0, 1, 4]], entry by entry.
//! let mut entries = Vec::new();
//! let mut values = Vec::new();
//! for i in 0..4usize {
//!     for j in 0..4 {
//!         if i.abs_diff(j) <= 1 {
//!             entries.push((i, j));
//!             values.push(if i == j { 4.0 } else { 1.0 });
//!         }
//!     }
//! }
//! let mut lu = BandedLu::analyse(4, &entries)?;
//! assert_eq!(lu.bandwidths(), (1, 1));
//! lu.factor(&values)?;
//! let mut b = [5.0, 6.0, 6.0, 5.0]; // A (1, 1, 1, 1)
//! lu.solve(&mut b);
//! assert!(b.iter().all(|x| (x - 1.0).abs() < 1e-15));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::VecDeque;

use crate::linalg::choose_pivot;
pub use crate::linalg::Pivot;

/// A sparsity pattern that cannot describe an `m x m` matrix.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PatternError {
    /// An entry lies outside the matrix.
    #[error("entry {index} at ({row}, {col}) lies outside the {m} x {m} matrix")]
    OutOfRange {
        /// Which entry.
        index: usize,
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
        /// The matrix dimension.
        m: usize,
    },
    /// A Hessian entry below the diagonal (patterns list the upper triangle, `i <= j`).
    #[error(
        "Hessian entry {index} at ({row}, {col}) lies below the diagonal: list the upper triangle"
    )]
    Lower {
        /// Which entry.
        index: usize,
        /// Its row.
        row: usize,
        /// Its column.
        col: usize,
    },
}

/// Banded LU with partial pivoting of a sparse `m x m` matrix, after a reverse Cuthill-McKee
/// ordering (see the [module docs](self)). Analysed once, factored and solved without
/// allocation.
#[derive(Clone, Debug, Default)]
pub struct BandedLu {
    m: usize,
    /// `order[k]`: the original index placed at position `k`.
    order: Vec<usize>,
    kl: usize,
    ku: usize,
    /// Rows of the band storage: `2 kl + ku + 1`.
    ldab: usize,
    /// Column-major band storage (LAPACK `AB`): `A[i, j]` at `kl + ku + i - j + j ldab`.
    ab: Vec<f64>,
    pivots: Vec<usize>,
    /// For each entry of the pattern, its place in `ab`.
    scatter: Vec<usize>,
    work: Vec<f64>,
}

impl BandedLu {
    /// Orders the matrix with the nonzero `entries` `(row, col)` (repeats allowed: their values
    /// add up) and reserves the band storage. The diagonal is taken as present.
    pub fn analyse(m: usize, entries: &[(usize, usize)]) -> Result<Self, PatternError> {
        for (index, &(row, col)) in entries.iter().enumerate() {
            if row >= m || col >= m {
                return Err(PatternError::OutOfRange { index, row, col, m });
            }
        }
        let order = reverse_cuthill_mckee(m, entries);
        let mut position = vec![0; m];
        for (k, &i) in order.iter().enumerate() {
            position[i] = k;
        }
        let (mut kl, mut ku) = (0, 0);
        for &(r, c) in entries {
            let (r, c) = (position[r], position[c]);
            kl = kl.max(r.saturating_sub(c));
            ku = ku.max(c.saturating_sub(r));
        }
        let ldab = 2 * kl + ku + 1;
        let kv = kl + ku;
        let scatter = entries
            .iter()
            .map(|&(r, c)| {
                let (r, c) = (position[r], position[c]);
                kv + r - c + c * ldab
            })
            .collect();
        Ok(BandedLu {
            m,
            order,
            kl,
            ku,
            ldab,
            ab: vec![0.0; ldab * m],
            pivots: vec![0; m],
            scatter,
            work: vec![0.0; m],
        })
    }

    /// The lower and upper bandwidths after the ordering (before pivoting's fill).
    pub fn bandwidths(&self) -> (usize, usize) {
        (self.kl, self.ku)
    }

    /// The matrix dimension `m`.
    pub fn dim(&self) -> usize {
        self.m
    }

    /// Factors the matrix whose entries (in the order given to [`analyse`](Self::analyse))
    /// have the `values`. Errors as the dense LU; the factorization is then meaningless until
    /// the next success.
    ///
    /// # Panics
    /// When `values` is not as long as the pattern (a programming error, not an input).
    pub fn factor(&mut self, values: &[f64]) -> Result<(), Pivot> {
        assert_eq!(
            values.len(),
            self.scatter.len(),
            "one value per entry of the analysed pattern"
        );
        self.ab.fill(0.0);
        let mut amax = 0.0f64;
        for (&s, &v) in self.scatter.iter().zip(values) {
            self.ab[s] += v;
        }
        for &s in &self.scatter {
            amax = amax.max(self.ab[s].abs());
        }
        if !amax.is_finite() {
            return Err(Pivot::NonFinite);
        }
        self.eliminate(self.m as f64 * f64::EPSILON * amax)
    }

    /// LAPACK `dgbtf2`: Gaussian elimination with partial pivoting in band storage.
    fn eliminate(&mut self, tiny: f64) -> Result<(), Pivot> {
        let (m, kl, ku, ld) = (self.m, self.kl, self.ku, self.ldab);
        let kv = kl + ku;
        let ab = &mut self.ab;
        let at = |i: usize, j: usize| kv + i - j + j * ld;
        // The last column touched by the interchanges so far.
        let mut ju = 0;
        for j in 0..m {
            let km = kl.min(m - 1 - j);
            // The column's band from the diagonal down is contiguous.
            let jp = choose_pivot(&ab[at(j, j)..=at(j + km, j)], tiny)?;
            self.pivots[j] = j + jp;
            ju = ju.max((j + ku + jp).min(m - 1));
            if jp != 0 {
                for c in j..=ju {
                    ab.swap(at(j + jp, c), at(j, c));
                }
            }
            if km > 0 {
                let inv = 1.0 / ab[at(j, j)];
                for r in 1..=km {
                    ab[at(j + r, j)] *= inv;
                }
                for c in j + 1..=ju {
                    let u = ab[at(j, c)];
                    if u != 0.0 {
                        for r in 1..=km {
                            ab[at(j + r, c)] -= ab[at(j + r, j)] * u;
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Solves `A x = b` in place with the last successful factorization.
    ///
    /// # Panics
    /// When `b` is not of length `m`.
    pub fn solve(&mut self, b: &mut [f64]) {
        // Taking the workspace out and back moves a pointer: no allocation.
        let mut work = std::mem::take(&mut self.work);
        self.solve_with(b, &mut work);
        self.work = work;
    }

    /// [`solve`](Self::solve) with caller-provided workspace (`work` of length `m`), for
    /// callers that hold the factorization by shared reference.
    ///
    /// # Panics
    /// When `b` or `work` is not of length `m`.
    pub fn solve_with(&self, b: &mut [f64], work: &mut [f64]) {
        assert_eq!(b.len(), self.m, "right-hand side of length m");
        assert_eq!(work.len(), self.m, "workspace of length m");
        let (m, kl, ld) = (self.m, self.kl, self.ldab);
        let kv = kl + self.ku;
        let at = |i: usize, j: usize| kv + i - j + j * ld;
        let x = work;
        for (k, &i) in self.order.iter().enumerate() {
            x[k] = b[i];
        }
        for j in 0..m {
            let p = self.pivots[j];
            if p != j {
                x.swap(p, j);
            }
            let xj = x[j];
            if xj != 0.0 {
                for r in 1..=kl.min(m - 1 - j) {
                    x[j + r] -= self.ab[at(j + r, j)] * xj;
                }
            }
        }
        for j in (0..m).rev() {
            let xj = x[j] / self.ab[at(j, j)];
            x[j] = xj;
            if xj != 0.0 {
                let top = j.saturating_sub(kv);
                for (i, xi) in x[top..j].iter_mut().enumerate() {
                    *xi -= self.ab[at(top + i, j)] * xj;
                }
            }
        }
        for (k, &i) in self.order.iter().enumerate() {
            b[i] = x[k];
        }
    }
}

/// The reverse Cuthill-McKee ordering of the symmetrised graph of `entries`: breadth-first
/// from a vertex of least degree (per connected component), neighbours by increasing degree,
/// reversed. `order[k]` is the vertex placed at `k`.
fn reverse_cuthill_mckee(m: usize, entries: &[(usize, usize)]) -> Vec<usize> {
    let mut adjacency: Vec<Vec<usize>> = vec![Vec::new(); m];
    for &(r, c) in entries {
        if r != c {
            adjacency[r].push(c);
            adjacency[c].push(r);
        }
    }
    for a in &mut adjacency {
        a.sort_unstable();
        a.dedup();
    }
    let degree: Vec<usize> = adjacency.iter().map(Vec::len).collect();
    let mut by_degree: Vec<usize> = (0..m).collect();
    by_degree.sort_by_key(|&i| (degree[i], i));
    let mut seen = vec![false; m];
    let mut order = Vec::with_capacity(m);
    let mut queue = VecDeque::new();
    for &start in &by_degree {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        queue.push_back(start);
        while let Some(v) = queue.pop_front() {
            order.push(v);
            let mut next: Vec<usize> = adjacency[v].iter().copied().filter(|&w| !seen[w]).collect();
            next.sort_by_key(|&w| (degree[w], w));
            for w in next {
                seen[w] = true;
                queue.push_back(w);
            }
        }
    }
    order.reverse();
    order
}

/// Where an entry of a [`NewtonMatrix`] takes its value from.
#[derive(Clone, Copy, Debug)]
enum Source {
    /// The identity's `1` on the diagonal.
    Identity,
    /// `-a_st sign Hess_k(y_t)`: the `k`-th Hessian nonzero of stage `t`, in block `(s, t)`.
    Hessian {
        s: usize,
        t: usize,
        k: usize,
        sign: f64,
    },
}

/// The Newton matrix of an `S`-stage implicit method in `m = S D` unknowns,
/// `delta_st I - a_st J Hess H(y_t)` in block `(s, t)`, assembled from the Hessian's nonzero
/// upper-triangle entries (`J = [[0, I], [-I, 0]]`: row `i < D/2` of `J Hess` is row
/// `i + D/2` of `Hess`, row `i >= D/2` is minus row `i - D/2`) and factored by [`BandedLu`].
/// Stage `t`'s Hessian values go in [`hessian_mut`](Self::hessian_mut)`(t)`.
#[derive(Clone, Debug, Default)]
pub struct NewtonMatrix {
    pattern: Vec<(usize, usize)>,
    d: usize,
    stages: usize,
    nonzeros: usize,
    sources: Vec<Source>,
    values: Vec<f64>,
    hessian: Vec<f64>,
    lu: BandedLu,
}

impl NewtonMatrix {
    /// The matrix of `stages` stages of dimension `d` (even) for the Hessian pattern `pattern`
    /// (upper triangle, `(i, j)` with `i <= j < d`).
    pub fn analyse(
        d: usize,
        stages: usize,
        pattern: &[(usize, usize)],
    ) -> Result<Self, PatternError> {
        let n = d / 2;
        let mut entries = Vec::new();
        let mut sources = Vec::new();
        for i in 0..stages * d {
            entries.push((i, i));
            sources.push(Source::Identity);
        }
        for (k, &(i, j)) in pattern.iter().enumerate() {
            if j >= d {
                return Err(PatternError::OutOfRange {
                    index: k,
                    row: i,
                    col: j,
                    m: d,
                });
            }
            if i > j {
                return Err(PatternError::Lower {
                    index: k,
                    row: i,
                    col: j,
                });
            }
            let mirror = if i == j { None } else { Some((j, i)) };
            for (r, c) in std::iter::once((i, j)).chain(mirror) {
                // Hess row r is J Hess row r - n (sign +) or r + n (sign -).
                let (row, sign) = if r >= n { (r - n, 1.0) } else { (r + n, -1.0) };
                for s in 0..stages {
                    for t in 0..stages {
                        entries.push((s * d + row, t * d + c));
                        sources.push(Source::Hessian { s, t, k, sign });
                    }
                }
            }
        }
        let lu = BandedLu::analyse(stages * d, &entries)?;
        Ok(NewtonMatrix {
            pattern: pattern.to_vec(),
            d,
            stages,
            nonzeros: pattern.len(),
            values: vec![0.0; sources.len()],
            sources,
            hessian: vec![0.0; stages * pattern.len()],
            lu,
        })
    }

    /// Whether this matrix was analysed for `d`, `stages` and a pattern of `nonzeros` entries.
    pub fn fits(&self, d: usize, stages: usize, nonzeros: usize) -> bool {
        self.d == d && self.stages == stages && self.nonzeros == nonzeros && d > 0
    }

    /// Storage for the Hessian nonzeros of stage `t`, in the pattern's order.
    pub fn hessian_mut(&mut self, t: usize) -> &mut [f64] {
        let n = self.nonzeros;
        &mut self.hessian[t * n..(t + 1) * n]
    }

    /// Assembles and factors the matrix with coefficients `a[s][t]` (`a[s * stages + t]`),
    /// from the Hessian values stored.
    pub fn factor(&mut self, a: &[f64]) -> Result<(), Pivot> {
        let n = self.nonzeros;
        for (v, src) in self.values.iter_mut().zip(&self.sources) {
            *v = match *src {
                Source::Identity => 1.0,
                Source::Hessian { s, t, k, sign } => {
                    -a[s * self.stages + t] * sign * self.hessian[t * n + k]
                }
            };
        }
        self.lu.factor(&self.values)
    }

    /// Solves with the last factorization, in place (`b` of length `stages * d`, stage by
    /// stage).
    pub fn solve(&mut self, b: &mut [f64]) {
        self.lu.solve(b);
    }

    /// [`solve`](Self::solve) with caller-provided workspace (`work` as long as `b`), by
    /// shared reference.
    pub fn solve_with(&self, b: &mut [f64], work: &mut [f64]) {
        self.lu.solve_with(b, work);
    }

    /// `out = Hess x` for stage `t`'s stored Hessian (symmetric, from its upper triangle):
    /// `O(nnz)`. The DTH solvers need it for `g_lambda = -(h lambda/2) (J g)^T Hess z_lambda`.
    ///
    /// # Panics
    /// When `x` or `out` is not of length `d`.
    pub fn hessian_times(&self, t: usize, x: &[f64], out: &mut [f64]) {
        assert!(
            x.len() == self.d && out.len() == self.d,
            "vectors of length d"
        );
        let values = &self.hessian[t * self.nonzeros..(t + 1) * self.nonzeros];
        out.fill(0.0);
        for (&(i, j), &v) in self.pattern.iter().zip(values) {
            out[i] += v * x[j];
            if i != j {
                out[j] += v * x[i];
            }
        }
    }

    /// `sum_ij |x_i H_ij x_j|` with the Hessian of term `t`: the size of the terms of the
    /// quadratic form `x^T H x`, which it equals where none of them cancel.
    pub fn hessian_abs_form(&self, t: usize, x: &[f64]) -> f64 {
        assert!(x.len() == self.d, "a vector of length d");
        let values = &self.hessian[t * self.nonzeros..(t + 1) * self.nonzeros];
        self.pattern
            .iter()
            .zip(values)
            .map(|(&(i, j), &v)| {
                let term = (x[i] * v * x[j]).abs();
                if i == j {
                    term
                } else {
                    2.0 * term
                }
            })
            .sum()
    }

    /// The banded LU (its bandwidths).
    pub fn lu(&self) -> &BandedLu {
        &self.lu
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::Lu;
    use nalgebra::{SMatrix, SVector};

    /// splitmix64 for seeded test matrices.
    fn rng(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = *seed;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((x ^ (x >> 31)) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }

    #[test]
    fn agrees_with_the_dense_lu_on_a_pivoting_scrambled_band() {
        // A random band matrix with weak diagonal (pivoting happens), its indices scrambled
        // so the ordering has to find the band again.
        const M: usize = 24;
        let scramble = |i: usize| (i * 7) % M;
        let mut seed = 7;
        let mut dense = SMatrix::<f64, M, M>::zeros();
        let mut entries = Vec::new();
        let mut values = Vec::new();
        for i in 0..M {
            for j in 0..M {
                if i.abs_diff(j) <= 2 {
                    let v = rng(&mut seed) + if i == j { 0.1 } else { 0.0 };
                    dense[(scramble(i), scramble(j))] = v;
                    entries.push((scramble(i), scramble(j)));
                    values.push(v);
                }
            }
        }
        let mut lu = BandedLu::analyse(M, &entries).unwrap();
        let (kl, ku) = lu.bandwidths();
        assert!(kl <= 4 && ku <= 4, "bandwidths {kl}, {ku}");
        lu.factor(&values).unwrap();
        let b = SVector::<f64, M>::from_fn(|_, _| rng(&mut seed));
        let mut x = b;
        lu.solve(x.as_mut_slice());
        let want = Lu::factor(&dense).unwrap().solve(&b);
        // Both backward stable; the difference is cond(A) eps |x| (cond of this random band
        // matrix is below 1e4).
        let err = (x - want).amax();
        assert!(err <= 1e4 * f64::EPSILON * want.amax(), "err {err}");
        assert!((dense * x - b).amax() <= 1e3 * f64::EPSILON * b.amax());
    }

    #[test]
    fn singular_and_non_finite_are_values_and_bad_patterns_errors() {
        let entries = [(0, 0), (0, 1), (1, 0), (1, 1)];
        let mut lu = BandedLu::analyse(2, &entries).unwrap();
        assert_eq!(lu.factor(&[1.0, 2.0, 2.0, 4.0]), Err(Pivot::Singular));
        assert_eq!(lu.factor(&[f64::NAN, 0.0, 0.0, 1.0]), Err(Pivot::NonFinite));
        assert!(matches!(
            BandedLu::analyse(2, &[(0, 2)]),
            Err(PatternError::OutOfRange {
                index: 0,
                col: 2,
                ..
            })
        ));
        assert!(matches!(
            NewtonMatrix::analyse(4, 1, &[(0, 0), (3, 1)]),
            Err(PatternError::Lower { index: 1, .. })
        ));
    }

    #[test]
    fn newton_matrix_of_a_chain_is_narrow_and_matches_the_dense_one() {
        // A tridiagonal q-block and the identity on p (a chain), 6 particles, two stages.
        const N: usize = 6;
        const D: usize = 2 * N;
        let mut pattern = Vec::new();
        for i in 0..N {
            pattern.push((i, i));
            if i + 1 < N {
                pattern.push((i, i + 1));
            }
        }
        for i in N..D {
            pattern.push((i, i));
        }
        let mut seed = 3;
        let mut hess = [SMatrix::<f64, D, D>::zeros(); 2];
        let mut m = NewtonMatrix::analyse(D, 2, &pattern).unwrap();
        for (t, h) in hess.iter_mut().enumerate() {
            for (k, &(i, j)) in pattern.iter().enumerate() {
                let v = 1.0 + rng(&mut seed);
                h[(i, j)] = v;
                h[(j, i)] = v;
                m.hessian_mut(t)[k] = v;
            }
        }
        let (kl, ku) = m.lu().bandwidths();
        assert!(
            kl + ku <= 12,
            "bandwidths {kl}, {ku} for 2 stages of a chain"
        );
        let a = [0.3, -0.1, 0.2, 0.25];
        m.factor(&a).unwrap();
        let jm = |h: &SMatrix<f64, D, D>| crate::methods::j_times_matrix(h);
        let mut dense = SMatrix::<f64, { 2 * D }, { 2 * D }>::identity();
        for s in 0..2 {
            for t in 0..2 {
                let block = jm(&hess[t]) * -a[2 * s + t];
                let mut view = dense.fixed_view_mut::<D, D>(s * D, t * D);
                view += block;
            }
        }
        let b = SVector::<f64, { 2 * D }>::from_fn(|i, _| (i as f64).sin());
        let mut x = b;
        m.solve(x.as_mut_slice());
        let want = Lu::factor(&dense).unwrap().solve(&b);
        // Well conditioned (identity plus a small perturbation): a few eps relative, times D.
        assert!((x - want).amax() <= 64.0 * f64::EPSILON * want.amax());
        // The sparse symmetric product against the dense one: the same terms in another
        // order, at most 3 per row here (a few eps of the row's absolute sum).
        let mut hx = SVector::<f64, D>::zeros();
        m.hessian_times(1, b.as_slice()[..D].as_ref(), hx.as_mut_slice());
        let want = hess[1] * b.fixed_rows::<D>(0);
        assert!(
            (hx - want).amax()
                <= 8.0 * f64::EPSILON * (hess[1].abs() * b.fixed_rows::<D>(0).abs()).amax()
        );
    }
}
