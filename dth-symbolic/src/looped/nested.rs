//! Sums over pairs, nested sums and strided sums, compiled once: `sum(1 <= i < j <= N, f)`,
//! `sum(i = 1..N, sum(j = i+1..N, f))` and `sum(i = 1..N, f)` whose accesses are
//! `q[a*i + c]` with `a > 1` (the coordinates of body `i` in 2-D or 3-D, `q[3*i - 2]`).
//!
//! The summand is built and differentiated once, in local coordinates (for a pair term: the
//! coordinates of body `i` and of body `j`), and evaluated in a loop over the index tuples,
//! its gradient and Hessian scattered as for a sum over sites ([`super`]). Every access is
//! `letter[a i + b j + c]` with `a, b >= 0` and reads a variable of the lattice: a nested
//! sum reads no boundary (one that would is written out, [`crate::compile`]).
//!
//! The Hessian of a sum over pairs couples every body with every other: its pattern is a
//! dense block of the lattice ([`super::diagonals::Block`]), which loops only in the shape
//! where that is exact: the inner index runs over `i+1..hi` (every pair once, none with
//! `i = j`), each access depends on one index, body `i` and body `j` read the same
//! coordinates (`q[3*i - 2..3*i]`, `q[3*j - 2..3*j]`) of one letter, which tile the lattice
//! without gaps, and the summand couples every pair of its local coordinates. Other nested
//! sums are written out.

use super::runs::Runs;
use crate::lower::Program;
use crate::span::Span;

/// One access of a nested sum: `letter[a i + b j + c]`, `coef = [a, b]`, `offset = c`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NestedSlot {
    /// `'q'` or `'p'`.
    pub letter: char,
    /// The coefficients of the outer and the inner index.
    pub coef: [i64; 2],
    /// The constant.
    pub offset: i64,
    /// Its position in the summand's local coordinates.
    pub local: usize,
}

impl NestedSlot {
    /// The index the slot reads at the indices `at = [i, j]`.
    pub fn index(&self, at: [i64; 2]) -> i64 {
        self.coef[0] * at[0] + self.coef[1] * at[1] + self.offset
    }

    /// Its position in `z` at `at`, for a lattice of `n` sites (the index checked inside it
    /// when compiling).
    pub fn position(&self, at: [i64; 2], n: usize) -> usize {
        let k = (self.index(at) - 1) as usize;
        if self.letter == 'q' {
            k
        } else {
            n + k
        }
    }

    /// Which index the slot depends on: `Some(0)` for the outer, `Some(1)` for the inner,
    /// `None` for both.
    pub fn depends_on(&self) -> Option<usize> {
        match self.coef {
            [_, 0] => Some(0),
            [0, _] => Some(1),
            _ => None,
        }
    }
}

/// The index tuples of a nested sum: `i = lo..hi` and, with two indices, `j = lo(i)..hi(i)`,
/// each bound `a i + b`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tuples {
    /// The outer index's range, both ends included.
    pub outer: (i64, i64),
    /// The inner index's bounds `[(a, b) of lo, (a, b) of hi]`; `None` for one index.
    pub inner: Option<[(i64, i64); 2]>,
}

impl Tuples {
    /// The inner index's range at outer index `i` (`(0, 0)` for one index).
    pub fn inner_at(&self, i: i64) -> (i64, i64) {
        match self.inner {
            Some([(a, b), (c, d)]) => (a * i + b, c * i + d),
            None => (0, 0),
        }
    }

    /// Every tuple `[i, j]` (`j = 0` for one index), in the order the loops run them.
    pub fn iter(&self) -> impl Iterator<Item = [i64; 2]> + '_ {
        let (lo, hi) = self.outer;
        (lo..=hi).flat_map(move |i| {
            let (jlo, jhi) = self.inner_at(i);
            (jlo..=jhi).map(move |j| [i, j])
        })
    }

    /// The smallest and largest value of each index over the tuples, `None` when there is
    /// none; a loop over the outer range.
    pub fn extent(&self) -> Option<[(i64, i64); 2]> {
        let mut out: Option<[(i64, i64); 2]> = None;
        for i in self.outer.0..=self.outer.1 {
            let (jlo, jhi) = self.inner_at(i);
            if jlo > jhi {
                continue;
            }
            let e = out.get_or_insert([(i, i), (jlo, jhi)]);
            e[0] = (e[0].0.min(i), e[0].1.max(i));
            e[1] = (e[1].0.min(jlo), e[1].1.max(jhi));
        }
        out
    }

    /// `true` when the tuples are every pair `i < j` of `vmin..=vmax` once, outer first, with
    /// no other: `vmin` and `vmax` from [`Tuples::extent`].
    pub fn all_pairs(&self) -> Option<(i64, i64)> {
        let [(imin, _), (_, jmax)] = self.extent()?;
        self.inner?;
        let (vmin, vmax) = (imin, jmax);
        let every = (self.outer.0..=self.outer.1).all(|i| {
            let (jlo, jhi) = self.inner_at(i);
            if (vmin..vmax).contains(&i) {
                (jlo, jhi) == (i + 1, vmax)
            } else {
                jlo > jhi
            }
        });
        every.then_some((vmin, vmax))
    }
}

/// A sum over pairs, nested or strided (see the module docs), compiled once.
#[derive(Clone, Debug)]
pub struct NestedSum {
    pub(crate) tuples: Tuples,
    pub(crate) slots: Vec<NestedSlot>,
    pub(crate) local_dim: usize,
    /// The summand's Hessian nonzeros, upper triangle, as pairs of slots.
    pub(crate) pattern: Vec<(usize, usize)>,
    /// Each slot's first access, in the order of `slots`.
    pub(crate) spans: Vec<Span>,
    pub(crate) system: crate::System,
    pub(crate) all: Program,
    pub(crate) pair: Program,
    pub(crate) defect: Program,
}

impl NestedSum {
    /// The summand as a system in local coordinates: `q<k>` (`p<k>`) is the `k`-th distinct
    /// `q[..]` (`p[..]`) access of the summand, in the order written.
    pub fn summand(&self) -> &crate::System {
        &self.system
    }

    /// The index tuples.
    pub fn tuples(&self) -> &Tuples {
        &self.tuples
    }

    /// The accesses, in the order first written.
    pub fn slots(&self) -> &[NestedSlot] {
        &self.slots
    }

    /// The summand's Hessian nonzeros, upper triangle, as pairs of indices into
    /// [`NestedSum::slots`].
    pub fn pattern(&self) -> &[(usize, usize)] {
        &self.pattern
    }

    /// The sites of `letter` the sum reads, and the span of its first access of that letter.
    pub(crate) fn reach(&self, letter: char) -> Option<(Runs, Span)> {
        let first = self.slots.iter().position(|s| s.letter == letter)?;
        let extent = self.tuples.extent()?;
        let mut sites = Vec::new();
        for s in self.slots.iter().filter(|s| s.letter == letter) {
            // Each slot depends on one index (checked when compiling).
            let k = s.depends_on().unwrap_or(0);
            let a = s.coef[k];
            sites.extend((extent[k].0..=extent[k].1).map(|v| a * v + s.offset));
        }
        Some((Runs::of(sites), self.spans[first]))
    }
}
