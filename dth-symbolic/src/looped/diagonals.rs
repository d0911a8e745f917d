//! The Hessian pattern of a lattice compiled in loops ([`crate::looped`]), laid out in runs
//! along its diagonals, and the position each (sum, summand entry, site) writes to.
//!
//! Away from the boundaries a summand entry lands at `(a0 + i, b0 + i)` at site `i`: a run
//! along the diagonal `b - a = b0 - a0`, its position in the pattern `base + i`. Only the
//! sites whose slots reach a boundary (a number that depends on the summand's offsets and the
//! boundaries, not on `N`) are listed one by one. So the layout is computed, and emitted, in
//! time and size independent of `N`; the generated code expands the runs into the pattern in
//! one short loop of the constant evaluator, and finds positions by arithmetic.
//!
//! The pattern's order is by diagonal, then by row: each entry once, the upper triangle.

use std::collections::BTreeMap;

use crate::looped::nested::NestedSum;
use crate::looped::{Looped, Site};

/// Where one summand entry of one sum lands, site by site.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Place {
    /// `(lo, hi, base)`: sites `lo..=hi` land at `base + stride * i`.
    pub interior: Option<(i64, i64, i64)>,
    /// How far the position moves from one site to the next: 1 for a sum over sites, the
    /// stride for a strided sum (`q[2*i]`), 0 for a range of one site.
    pub stride: i64,
    /// The other sites that land in the lattice, and where (a site with a slot at a fixed
    /// boundary lands nowhere and is not listed).
    pub edges: Vec<(i64, usize)>,
    /// For an entry of a sum over pairs: the dense block ([`Layout::blocks`]) it lands in,
    /// at [`Block::position`] of its two coordinates.
    pub block: Option<usize>,
}

/// A dense block of the Hessian: every entry `(a, b)`, `a <= b`, with both in
/// `first..first + len`, laid out diagonal by diagonal (`b - a = 0, 1, ...`), each by row,
/// from `start` on in the pattern. What the pattern of a sum over all pairs is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// The first coordinate.
    pub first: usize,
    /// How many coordinates.
    pub len: usize,
    /// The position of its first entry in the pattern.
    pub start: usize,
}

impl Block {
    /// `true` when both `a` and `b` are coordinates of the block.
    pub fn holds(&self, (a, b): (usize, usize)) -> bool {
        let inside = |x: usize| (self.first..self.first + self.len).contains(&x);
        inside(a) && inside(b)
    }

    /// The position in the pattern of the entry `(a, b)` (either order) of the block: on the
    /// diagonal `o = |b - a|`, after the `o * len - o (o - 1) / 2` entries of the diagonals
    /// before it.
    pub fn position(&self, a: usize, b: usize) -> usize {
        let (lo, hi) = (a.min(b), a.max(b));
        let o = hi - lo;
        self.start + o * self.len - o * o.saturating_sub(1) / 2 + (lo - self.first)
    }

    /// The number of entries, `len (len + 1) / 2`.
    pub fn nnz(&self) -> usize {
        self.len * (self.len + 1) / 2
    }

    /// Its entries in the pattern's order.
    pub fn entries(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.len)
            .flat_map(move |o| (0..self.len - o).map(move |r| (self.first + r, self.first + r + o)))
    }
}

/// The pattern as runs, then dense blocks, and every entry's place.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layout {
    /// `(a, b, len)`: the entries `(a + k, b + k)`, `k < len`, one run after the other.
    pub runs: Vec<(usize, usize, usize)>,
    /// The dense blocks, after the runs.
    pub blocks: Vec<Block>,
    /// The number of entries, `sum len` over the runs and the blocks' entries.
    pub nnz: usize,
    /// How many of them are on the diagonal.
    pub diagonal: usize,
    /// Per sum over sites, per summand entry (the order of `LoopSum::pattern`).
    pub places: Vec<Vec<Place>>,
    /// Per nested sum ([`Looped::nested`]), per summand entry.
    pub nested: Vec<Vec<Place>>,
}

impl Layout {
    /// The pattern, the runs expanded, then the blocks' entries.
    pub fn pattern(&self) -> Vec<(usize, usize)> {
        let mut out: Vec<(usize, usize)> = self
            .runs
            .iter()
            .flat_map(|&(a, b, len)| (0..len).map(move |k| (a + k, b + k)))
            .collect();
        for block in &self.blocks {
            out.extend(block.entries());
        }
        out
    }
}

/// The entry `(a, b)`, `a <= b`, that summand entry `(r, t)` of sum `k` writes at site `i`, or
/// `None` when a slot is at a fixed boundary.
fn entry(looped: &Looped, k: usize, (r, t): (usize, usize), i: i64) -> Option<(usize, usize)> {
    let s = &looped.sums[k];
    let ((lr, cr, _), (lt, ct, _)) = (s.slots[r], s.slots[t]);
    match (looped.site(lr, i + cr), looped.site(lt, i + ct)) {
        (Site::Var(a), Site::Var(b)) => Some((a.min(b), a.max(b))),
        _ => None,
    }
}

/// The entry `(a, b)`, `a <= b`, that summand entry `(r, t)` of a nested sum writes at `at`.
fn nested_entry(s: &NestedSum, n: usize, (r, t): (usize, usize), at: [i64; 2]) -> (usize, usize) {
    let (a, b) = (s.slots[r].position(at, n), s.slots[t].position(at, n));
    (a.min(b), a.max(b))
}

/// The sites of sum `k` at which both slots of `(r, t)` are in the lattice (`1..=N`), as an
/// inclusive range, possibly empty.
fn interior(looped: &Looped, k: usize, (r, t): (usize, usize)) -> (i64, i64) {
    let s = &looped.sums[k];
    let (cr, ct) = (s.slots[r].1, s.slots[t].1);
    let n = looped.n as i64;
    (s.lo.max(1 - cr.min(ct)), s.hi.min(n - cr.max(ct)))
}

/// The sites of sum `k` outside `interior`.
fn edge_sites(looped: &Looped, k: usize, (lo, hi): (i64, i64)) -> Vec<i64> {
    let s = &looped.sums[k];
    if lo > hi {
        return (s.lo..=s.hi).collect();
    }
    (s.lo..lo).chain(hi + 1..=s.hi).collect()
}

/// The dense block `(first, len)` of a sum over pairs in a lattice of `n` sites, when its
/// pattern is exactly that block (the shape of the module docs of `looped::nested`).
fn dense_block(s: &NestedSum, n: usize) -> Result<(usize, usize), &'static str> {
    const SHAPE: &str = "a sum over pairs whose Hessian is not one dense block of the lattice";
    let (vmin, vmax) = s.tuples.all_pairs().ok_or(
        "a nested sum that is not over every pair `i < j` once (write `sum(1 <= i < j <= N, f)`)",
    )?;
    let mut shapes: [Vec<(char, i64, i64)>; 2] = Default::default();
    for slot in &s.slots {
        let k = slot
            .depends_on()
            .ok_or("an access depends on both indices of a pair")?;
        shapes[k].push((slot.letter, slot.coef[k], slot.offset));
    }
    for shape in &mut shapes {
        shape.sort_unstable();
    }
    if shapes[0] != shapes[1] || shapes[0].is_empty() {
        return Err(SHAPE);
    }
    let (letter, a, c0) = shapes[0][0];
    // One letter, one stride `a`, and `a` consecutive offsets: the bodies tile the lattice.
    let tiles = shapes[0].len() == a as usize
        && shapes[0]
            .iter()
            .enumerate()
            .all(|(m, &(l, b, c))| l == letter && b == a && c == c0 + m as i64);
    // Every pair of local coordinates coupled: the summand's Hessian is dense.
    let m = s.slots.len();
    let dense = s.pattern.len() == m * (m + 1) / 2;
    if !(tiles && dense) {
        return Err(SHAPE);
    }
    let first = a * vmin + c0 - 1;
    let len = a * (vmax - vmin + 1);
    let shift = if letter == 'q' { 0 } else { n as i64 };
    Ok(((first + shift) as usize, len as usize))
}

/// Lays out the pattern of `looped` (see the module docs): what `Looped` holds, computed
/// when compiling.
pub fn layout(looped: &Looped) -> Layout {
    looped.layout.clone()
}

/// Lays out the pattern of `looped`'s sums, or why it cannot be laid out in runs and blocks
/// with each entry's position affine in the site (the lattice is then written out).
pub(crate) fn try_layout(looped: &Looped) -> Result<Layout, &'static str> {
    let n = looped.n;
    // The dense blocks of the sums over pairs, each once.
    let mut blocks: Vec<(usize, usize)> = Vec::new();
    let mut block_of = Vec::with_capacity(looped.nested.len());
    for s in &looped.nested {
        if s.tuples.inner.is_none() {
            block_of.push(None);
            continue;
        }
        let (first, len) = dense_block(s, n)?;
        let k = match blocks.iter().position(|&b| b == (first, len)) {
            Some(k) => k,
            None if blocks
                .iter()
                .any(|&(f, l)| first < f + l && f < first + len) =>
            {
                return Err("sums over pairs couple overlapping, different blocks");
            }
            None => {
                blocks.push((first, len));
                blocks.len() - 1
            }
        };
        block_of.push(Some(k));
    }
    let in_block = |(a, b): (usize, usize)| {
        blocks.iter().position(|&(f, l)| {
            let inside = |x: usize| (f..f + l).contains(&x);
            inside(a) && inside(b)
        })
    };
    // Every entry outside the blocks as intervals of rows on its diagonal `b - a`.
    let mut diagonals: BTreeMap<usize, Vec<(usize, usize)>> = BTreeMap::new();
    let mut add = |(a, b): (usize, usize), len: usize| {
        if in_block((a, b)).is_none() {
            diagonals.entry(b - a).or_default().push((a, a + len - 1));
        }
    };
    for (k, s) in looped.sums.iter().enumerate() {
        for &pair in &s.pattern {
            let (lo, hi) = interior(looped, k, pair);
            if lo <= hi {
                if let (Some(first), Some(last)) =
                    (entry(looped, k, pair, lo), entry(looped, k, pair, hi))
                {
                    // Along the interior an entry is in a block at both ends or at neither.
                    if in_block(first).is_some() != in_block(last).is_some() {
                        return Err("a sum over sites crosses the edge of a dense block");
                    }
                    add(first, (hi - lo + 1) as usize);
                }
            }
            for i in edge_sites(looped, k, (lo, hi)) {
                if let Some(e) = entry(looped, k, pair, i) {
                    add(e, 1);
                }
            }
        }
    }
    for (s, block) in looped.nested.iter().zip(&block_of) {
        if block.is_some() {
            continue;
        }
        for &pair in &s.pattern {
            for at in s.tuples.iter() {
                add(nested_entry(s, n, pair, at), 1);
            }
        }
    }
    // Merge overlapping and adjacent intervals; each becomes a run.
    let mut runs = Vec::new();
    let mut starts: BTreeMap<usize, Vec<(usize, usize, usize)>> = BTreeMap::new();
    let mut nnz = 0;
    let mut diagonal = 0;
    for (offset, mut rows) in diagonals {
        rows.sort_unstable();
        let mut merged: Vec<(usize, usize)> = Vec::new();
        for (first, last) in rows {
            match merged.last_mut() {
                Some(m) if first <= m.1 + 1 => m.1 = m.1.max(last),
                _ => merged.push((first, last)),
            }
        }
        for (first, last) in merged {
            let len = last - first + 1;
            runs.push((first, first + offset, len));
            starts.entry(offset).or_default().push((first, last, nnz));
            nnz += len;
            if offset == 0 {
                diagonal += len;
            }
        }
    }
    let blocks: Vec<Block> = blocks
        .iter()
        .map(|&(first, len)| {
            let block = Block {
                first,
                len,
                start: nnz,
            };
            nnz += block.nnz();
            diagonal += len;
            block
        })
        .collect();
    // The position of `(a, b)`: in its block, or in the run of its diagonal that holds row `a`.
    let position = |(a, b): (usize, usize)| -> Option<usize> {
        if let Some(k) = in_block((a, b)) {
            return Some(blocks[k].position(a, b));
        }
        let (first, _, start) = starts
            .get(&(b - a))?
            .iter()
            .copied()
            .find(|&(first, last, _)| (first..=last).contains(&a))?;
        Some(start + (a - first))
    };
    const UNPLACED: &str = "an entry of the Hessian outside its layout";
    let mut places = Vec::with_capacity(looped.sums.len());
    for (k, s) in looped.sums.iter().enumerate() {
        let mut sum = Vec::with_capacity(s.pattern.len());
        for &pair in &s.pattern {
            let (lo, hi) = interior(looped, k, pair);
            let interior = match (lo <= hi).then(|| entry(looped, k, pair, lo)).flatten() {
                Some(e) => {
                    let base = position(e).ok_or(UNPLACED)? as i64 - lo;
                    let last = entry(looped, k, pair, hi).and_then(position);
                    if last != Some((base + hi) as usize) {
                        return Err(UNPLACED);
                    }
                    Some((lo, hi, base))
                }
                None => None,
            };
            let mut edges = Vec::new();
            for i in edge_sites(looped, k, (lo, hi)) {
                if let Some(e) = entry(looped, k, pair, i) {
                    edges.push((i, position(e).ok_or(UNPLACED)?));
                }
            }
            sum.push(Place {
                interior,
                stride: 1,
                edges,
                block: None,
            });
        }
        places.push(sum);
    }
    let mut nested = Vec::with_capacity(looped.nested.len());
    for (s, block) in looped.nested.iter().zip(&block_of) {
        let mut sum = Vec::with_capacity(s.pattern.len());
        for &pair in &s.pattern {
            if block.is_some() {
                sum.push(Place {
                    block: *block,
                    ..Place::default()
                });
                continue;
            }
            // A strided sum: the position must move by the same stride from site to site.
            let (lo, hi) = s.tuples.outer;
            let at = |i: i64| position(nested_entry(s, n, pair, [i, 0])).ok_or(UNPLACED);
            let base = at(lo)? as i64;
            let stride = if hi > lo {
                at(lo + 1)? as i64 - base
            } else {
                0
            };
            for i in lo..=hi {
                if at(i)? as i64 != base + stride * (i - lo) {
                    return Err("the Hessian entries of a strided sum are not evenly spaced");
                }
            }
            sum.push(Place {
                interior: Some((lo, hi, base - stride * lo)),
                stride,
                edges: Vec::new(),
                block: None,
            });
        }
        nested.push(sum);
    }
    Ok(Layout {
        runs,
        blocks,
        nnz,
        diagonal,
        places,
        nested,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The runs expanded, and every (sum, entry, site)'s place, against the engine's pattern
    /// (`Looped::hessian_pattern`, the entries each once in the order the loops reach them):
    /// the same set, each entry once, and every place holding the entry written there.
    fn check(src: &str) {
        let looped = crate::looped::compile(src, &[]).unwrap();
        let l = layout(&looped);
        let pattern = l.pattern();
        assert_eq!(pattern.len(), l.nnz, "{src}");
        let diagonal = pattern.iter().filter(|(a, b)| a == b).count();
        assert_eq!(diagonal, l.diagonal, "{src}");
        let (mut got, mut want) = (pattern.clone(), looped.hessian_pattern());
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want, "{src}");
        got.dedup();
        assert_eq!(got.len(), pattern.len(), "{src}: an entry twice");
        for (k, s) in looped.sums.iter().enumerate() {
            for (idx, &pair) in s.pattern.iter().enumerate() {
                let place = &l.places[k][idx];
                for i in s.lo..=s.hi {
                    let at = match place.interior {
                        Some((lo, hi, base)) if (lo..=hi).contains(&i) => {
                            Some((base + place.stride * i) as usize)
                        }
                        _ => place.edges.iter().find(|e| e.0 == i).map(|e| e.1),
                    };
                    assert_eq!(
                        at.map(|at| pattern[at]),
                        entry(&looped, k, pair, i),
                        "{src}: sum {k}, entry {idx}, site {i}"
                    );
                }
            }
        }
        for (k, s) in looped.nested.iter().enumerate() {
            for (idx, &pair) in s.pattern.iter().enumerate() {
                let place = &l.nested[k][idx];
                for at in s.tuples.iter() {
                    let (a, b) = nested_entry(s, looped.n, pair, at);
                    let position = match (place.block, place.interior) {
                        (Some(block), _) => l.blocks[block].position(a, b),
                        (None, Some((_, _, base))) => (base + place.stride * at[0]) as usize,
                        (None, None) => panic!("{src}: nested sum {k}, entry {idx}: no place"),
                    };
                    assert_eq!(pattern[position], (a, b), "{src}: nested sum {k} at {at:?}");
                }
            }
        }
    }

    #[test]
    fn the_runs_hold_the_engines_pattern_and_every_place_its_entry() {
        for src in [
            // Fixed ends, nearest neighbours.
            "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/3) \
             where N = 8, q[0] = q[N+1] = 0",
            // One and two particles: no interior for the bonds.
            "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^4) \
             where N = 1, q[0] = q[N+1] = 0",
            "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^4) \
             where N = 2, q[0] = q[N+1] = 0",
            // Periodic: the wrapped bond is an entry far from the band.
            "sum(i = 1..N, p[i]^2/2 + exp(q[i] - q[i+1])) where N = 8, q[N+1] = q[1]",
            // A ring of two: both bonds couple the same pair.
            "sum(i = 1..2, p[i]^2/2 + cos(q[i] - q[i+1])) where q[3] = q[1]",
            // Second neighbours, periodic, and a momentum coupled to positions.
            "sum(i = 1..N, p[i]^2/2 + p[i]*q[i+1] + (q[i+2] - q[i])^4) \
             where N = 6, q[N+1] = q[1], q[N+2] = q[2]",
            // Two sums writing the same diagonal over different rows.
            "sum(i = 1..N, p[i]^2/2) + sum(i = 1..3, q[i]^4) + sum(i = 2..N, q[i]^2*q[i-1]^2) \
             where N = 9, q[0] = 0",
            // Pairs in 3-D, strided momenta, and a trap over sites inside the pairs' block.
            "sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/2) + sum(i = 1..M, q[i]^4) \
             + sum(1 <= i < j <= N, ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 \
             + (q[3*i] - q[3*j])^2)^(-1/2)) where N = 4, M = 12",
            // Pairs as a nested sum, momenta strided and coupled along the lattice.
            "sum(i = 1..N, p[2*i-1]^2 + p[2*i]^2 + p[2*i-1]*p[2*i]) \
             + sum(i = 1..N, sum(j = i+1..N, exp(q[2*i-1] - q[2*j-1] + q[2*i] - q[2*j]))) \
             where N = 3",
        ] {
            check(src);
        }
    }

    /// The layout of a chain does not grow with it: the same number of runs and listed sites
    /// at 64 and 4096 particles.
    #[test]
    fn the_layout_does_not_grow_with_the_number_of_sites() {
        let size = |n: usize| {
            let src = format!(
                "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3) \
                 where N = {n}, q[0] = q[N+1] = 0"
            );
            let l = layout(&crate::looped::compile(&src, &[]).unwrap());
            let edges: usize = l.places.iter().flatten().map(|p| p.edges.len()).sum();
            (l.runs.len(), edges, l.nnz)
        };
        let (small, large) = (size(64), size(4096));
        assert_eq!((small.0, small.1), (large.0, large.1));
        assert_eq!((small.2, large.2), (3 * 64 - 1, 3 * 4096 - 1));
    }
}
