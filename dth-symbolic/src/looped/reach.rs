//! What a looped lattice's diagnostics are, decided on the summands and the ranges,
//! never site by site: each slot `q[i + c]` of a sum over `lo..hi` reaches the run of sites
//! `lo + c..hi + c` inside the lattice and a few boundaries, so the questions the written-out
//! path asks of every coordinate are asked of a few runs ([`Runs`]).
//!
//! - [`Looped::numbering`]: the written-out path's numbering rules ([`crate::check::indices`])
//!   on the sites each letter reaches: sites reached by neither letter are an error, a `q`
//!   without its `p` a warning, and a `p` without its `q` one too beside such a `q`; each for a
//!   run of sites, at the access that first reaches it, as the written-out path reports them.
//!   A nested sum ([`super::nested`]) reaches its sites from its first access of each letter.

use super::runs::Runs;
use super::{half, LoopSum, Looped, Site};
use crate::error::{Error, ErrorKind, Warning, WarningKind};
use crate::span::Span;

/// An in-lattice reach of one slot: the sum's number, the slot's offset and number, the run
/// of sites, and the slot's first access.
struct Reach {
    sum: usize,
    offset: i64,
    slot: usize,
    run: (i64, i64),
    span: Span,
}

/// A site reached through a boundary that is a site: the site, the key `(sum, i, slot)` that
/// orders first occurrences, and the boundary's value as written.
struct Through {
    site: i64,
    key: (usize, i64, usize),
    span: Span,
}

impl Looped {
    /// The letter and site of position `a` of `z`.
    pub(super) fn letter_site(&self, a: usize) -> (char, i64) {
        if a < self.n {
            ('q', a as i64 + 1)
        } else {
            ('p', (a - self.n) as i64 + 1)
        }
    }

    /// The sites `letter[i + c]` leaves the lattice at, for `i` in the sum's range: few, each
    /// a declared boundary (checked when compiling).
    fn outside(&self, s: &LoopSum, c: i64) -> impl Iterator<Item = i64> {
        let n = self.n as i64;
        let (from, to) = (s.lo.saturating_add(c), s.hi.saturating_add(c));
        (from..=to.min(0)).chain(from.max(n.saturating_add(1))..=to)
    }

    /// Where the slots kept by `keep` reach, inside the lattice (runs of sites) and through
    /// boundaries that are sites, per letter (`q` first).
    fn reaches(&self, keep: impl Fn(&LoopSum, usize) -> bool) -> [(Vec<Reach>, Vec<Through>); 2] {
        let n = self.n as i64;
        let mut out: [(Vec<Reach>, Vec<Through>); 2] = Default::default();
        for (k, s) in self.sums.iter().enumerate() {
            for (r, &(letter, c, _)) in s.slots.iter().enumerate() {
                if !keep(s, r) {
                    continue;
                }
                let run = (s.lo.saturating_add(c).max(1), s.hi.saturating_add(c).min(n));
                if run.0 <= run.1 {
                    out[half(letter)].0.push(Reach {
                        sum: k,
                        offset: c,
                        slot: r,
                        run,
                        span: s.spans[r],
                    });
                }
                for site in self.outside(s, c) {
                    let Site::Var(a) = self.site(letter, site) else {
                        continue;
                    };
                    let (l, at) = self.letter_site(a);
                    let span = self
                        .boundaries
                        .iter()
                        .position(|&(bl, bk, _)| bl == letter && bk == site)
                        .map_or(s.spans[r], |b| self.boundary_spans[b]);
                    out[half(l)].1.push(Through {
                        site: at,
                        key: (k, site - c, r),
                        span,
                    });
                }
            }
        }
        // A nested sum's sites, per letter, at its first access of that letter; after the
        // sums over sites (as it is computed after them).
        for (k, s) in self.nested.iter().enumerate() {
            for letter in ['q', 'p'] {
                let Some((runs, span)) = s.reach(letter) else {
                    continue;
                };
                for run in runs.iter() {
                    out[half(letter)].0.push(Reach {
                        sum: self.sums.len() + k,
                        offset: 0,
                        slot: 0,
                        run,
                        span,
                    });
                }
            }
        }
        out
    }

    /// The sites each letter's reaches cover.
    fn cover(reaches: &[(Vec<Reach>, Vec<Through>); 2]) -> [Runs; 2] {
        reaches.each_ref().map(|(inside, through)| {
            let mut runs = Runs::default();
            for r in inside {
                runs.insert(r.run.0, r.run.1);
            }
            for t in through {
                runs.insert(t.site, t.site);
            }
            runs
        })
    }

    /// The runs of `target` (sites of one letter, `reaches` that letter's) with the span of
    /// the access that first reaches each site, in the order the written-out path builds
    /// them (sum by sum, site by site, slot by slot); consecutive sites with the same span
    /// make one run.
    fn first_reached(
        target: &Runs,
        (inside, through): &(Vec<Reach>, Vec<Through>),
    ) -> Vec<(i64, i64, Span)> {
        let mut out: Vec<(i64, i64, Span)> = Vec::new();
        // Sites reached through a boundary: asked one by one.
        let mut singles = Runs::default();
        for t in through {
            singles.insert(t.site, t.site);
        }
        for (k, _) in target.intersect(&singles).iter() {
            let mut best: Option<((usize, i64, usize), Span)> = None;
            let candidates = inside
                .iter()
                .filter(|r| r.run.0 <= k && k <= r.run.1)
                .map(|r| ((r.sum, k - r.offset, r.slot), r.span))
                .chain(
                    through
                        .iter()
                        .filter(|t| t.site == k)
                        .map(|t| (t.key, t.span)),
                );
            for (key, span) in candidates {
                if best.is_none_or(|(b, _)| key < b) {
                    best = Some((key, span));
                }
            }
            if let Some((_, span)) = best {
                out.push((k, k, span));
            }
        }
        // Elsewhere the first reach of site `k` in a sum is at `i = k - c`, earliest for the
        // largest `c`: the order of the reaches does not depend on `k`.
        let mut order: Vec<&Reach> = inside.iter().collect();
        order.sort_by_key(|r| (r.sum, std::cmp::Reverse(r.offset), r.slot));
        let mut left = target.difference(&singles);
        for r in order {
            let claimed = left.intersect(&Runs::run(r.run.0, r.run.1));
            for (a, b) in claimed.iter() {
                out.push((a, b, r.span));
            }
            left = left.difference(&claimed);
        }
        out.sort_by_key(|&(a, _, _)| a);
        let mut merged: Vec<(i64, i64, Span)> = Vec::with_capacity(out.len());
        for (a, b, span) in out {
            match merged.last_mut() {
                Some(last) if last.1 + 1 == a && last.2 == span => last.1 = b,
                _ => merged.push((a, b, span)),
            }
        }
        merged
    }

    /// The written-out path's numbering rules on the lattice (see the module docs): the
    /// errors (runs of sites no variable reaches) and the warnings, or `None` when the last
    /// site is reached by no variable (the written-out system would then be smaller than
    /// the lattice).
    pub(crate) fn numbering(&self) -> Option<(Vec<Error>, Vec<Warning>)> {
        let reaches = self.reaches(|_, _| true);
        let [q, p] = Self::cover(&reaches);
        let n = self.n as i64;
        // The variable that sets `n`: of `q[n]` and `p[n]`, the one written first.
        let top = [('q', &q, &reaches[0]), ('p', &p, &reaches[1])]
            .into_iter()
            .filter(|(_, cover, _)| cover.contains(n))
            .filter_map(|(letter, _, reach)| {
                let first = Self::first_reached(&Runs::run(n, n), reach);
                first.first().map(|&(_, _, span)| (letter, span))
            })
            .min_by_key(|&(_, span)| span.start)?;
        let index = |k: i64| u32::try_from(k).unwrap_or(u32::MAX);
        let n32 = index(n);
        let both = {
            let mut both = q.clone();
            for (a, b) in p.iter() {
                both.insert(a, b);
            }
            both
        };
        let errors = Runs::run(1, n)
            .difference(&both)
            .iter()
            .map(|(a, b)| {
                let kind = if a == b {
                    ErrorKind::SkippedIndex {
                        missing: index(a),
                        largest: top.0,
                        n: n32,
                    }
                } else {
                    ErrorKind::SkippedIndices {
                        first: index(a),
                        last: index(b),
                        largest: top.0,
                        n: n32,
                    }
                };
                Error::new(kind, top.1)
            })
            .collect();
        let frozen = Self::first_reached(&q.difference(&p), &reaches[0]);
        let mut warnings: Vec<Warning> = frozen
            .iter()
            .map(|&(a, b, span)| Warning {
                kind: if a == b {
                    WarningKind::FrozenCoordinate { index: index(a) }
                } else {
                    WarningKind::FrozenCoordinates {
                        first: index(a),
                        last: index(b),
                    }
                },
                span,
            })
            .collect();
        if let Some(&(position, _, _)) = frozen.first() {
            let position = index(position);
            let cyclic = Self::first_reached(&p.difference(&q), &reaches[1]);
            warnings.extend(cyclic.iter().map(|&(a, b, span)| Warning {
                kind: if a == b {
                    WarningKind::Misnumbered {
                        momentum: index(a),
                        position,
                    }
                } else {
                    WarningKind::MisnumberedMomenta {
                        first: index(a),
                        last: index(b),
                        position,
                    }
                },
                span,
            }));
        }
        warnings.sort_by_key(|w| w.span.start);
        Some((errors, warnings))
    }
}
