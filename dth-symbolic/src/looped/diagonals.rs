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

use crate::looped::{Looped, Site};

/// Where one summand entry of one sum lands, site by site.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Place {
    /// `(lo, hi, base)`: sites `lo..=hi` land at `base + i`.
    pub interior: Option<(i64, i64, i64)>,
    /// The other sites that land in the lattice, and where (a site with a slot at a fixed
    /// boundary lands nowhere and is not listed).
    pub edges: Vec<(i64, usize)>,
}

/// The pattern as runs, and every entry's place.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// `(a, b, len)`: the entries `(a + k, b + k)`, `k < len`, one run after the other.
    pub runs: Vec<(usize, usize, usize)>,
    /// The number of entries, `sum len`.
    pub nnz: usize,
    /// How many of them are on the diagonal.
    pub diagonal: usize,
    /// Per sum, per summand entry (the order of `LoopSum::pattern`).
    pub places: Vec<Vec<Place>>,
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

/// Lays out the pattern of `looped` (see the module docs).
pub fn layout(looped: &Looped) -> Layout {
    // Every entry as intervals of rows on its diagonal `b - a`: `(first row, last row)`.
    let mut diagonals: BTreeMap<usize, Vec<(usize, usize)>> = BTreeMap::new();
    let mut add = |(a, b): (usize, usize), len: usize| {
        diagonals.entry(b - a).or_default().push((a, a + len - 1));
    };
    for (k, s) in looped.sums.iter().enumerate() {
        for &pair in &s.pattern {
            let (lo, hi) = interior(looped, k, pair);
            if lo <= hi {
                if let Some(e) = entry(looped, k, pair, lo) {
                    add(e, (hi - lo + 1) as usize);
                }
            }
            for i in edge_sites(looped, k, (lo, hi)) {
                if let Some(e) = entry(looped, k, pair, i) {
                    add(e, 1);
                }
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
    // The position of `(a, b)`: in the run of its diagonal that holds row `a`.
    let position = |(a, b): (usize, usize)| -> usize {
        let (first, _, start) = starts[&(b - a)]
            .iter()
            .copied()
            .find(|&(first, last, _)| (first..=last).contains(&a))
            .expect("every entry is in a run");
        start + (a - first)
    };
    let places = looped
        .sums
        .iter()
        .enumerate()
        .map(|(k, s)| {
            s.pattern
                .iter()
                .map(|&pair| {
                    let (lo, hi) = interior(looped, k, pair);
                    let interior = if lo <= hi {
                        entry(looped, k, pair, lo).map(|e| (lo, hi, position(e) as i64 - lo))
                    } else {
                        None
                    };
                    let edges = edge_sites(looped, k, (lo, hi))
                        .into_iter()
                        .filter_map(|i| Some((i, position(entry(looped, k, pair, i)?))))
                        .collect();
                    Place { interior, edges }
                })
                .collect()
        })
        .collect();
    Layout {
        runs,
        nnz,
        diagonal,
        places,
    }
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
        let pattern: Vec<(usize, usize)> = l
            .runs
            .iter()
            .flat_map(|&(a, b, len)| (0..len).map(move |k| (a + k, b + k)))
            .collect();
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
                        Some((lo, hi, base)) if (lo..=hi).contains(&i) => Some((base + i) as usize),
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
