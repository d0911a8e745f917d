//! Sets of lattice sites as sorted runs of consecutive integers: what a slot `q[i + c]` of a
//! sum over `lo..hi` reaches is one run, so the lattice's questions (which sites have a
//! momentum, where the gradient can be nonzero) are answered on a few runs, never site by
//! site.

/// A set of integers: sorted, disjoint, non-adjacent inclusive runs `(first, last)`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Runs(Vec<(i64, i64)>);

impl Runs {
    /// The run `first..=last` (empty when `first > last`).
    pub fn run(first: i64, last: i64) -> Self {
        let mut r = Runs::default();
        r.insert(first, last);
        r
    }

    /// The set of `sites` (in any order, repeats allowed), in one pass after sorting: for
    /// the many short runs of a strided access (`q[2*i]`), where inserting one by one would
    /// merge quadratically.
    pub fn of(mut sites: Vec<i64>) -> Self {
        sites.sort_unstable();
        sites.dedup();
        let mut runs: Vec<(i64, i64)> = Vec::new();
        for k in sites {
            match runs.last_mut() {
                Some(last) if last.1.saturating_add(1) == k => last.1 = k,
                _ => runs.push((k, k)),
            }
        }
        Runs(runs)
    }

    /// The runs, in order.
    pub fn iter(&self) -> impl Iterator<Item = (i64, i64)> + '_ {
        self.0.iter().copied()
    }

    /// `true` when the set holds nothing.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Adds `first..=last`, merging what it touches.
    pub fn insert(&mut self, first: i64, last: i64) {
        if first > last {
            return;
        }
        let (mut a, mut b) = (first, last);
        let mut kept = Vec::with_capacity(self.0.len() + 1);
        for &(x, y) in &self.0 {
            // Disjoint and not adjacent: kept apart (`saturating`: runs may end at `i64`'s ends).
            if y.saturating_add(1) < a || b.saturating_add(1) < x {
                kept.push((x, y));
            } else {
                a = a.min(x);
                b = b.max(y);
            }
        }
        kept.push((a, b));
        kept.sort_unstable();
        self.0 = kept;
    }

    /// `true` when `k` is in the set.
    pub fn contains(&self, k: i64) -> bool {
        self.0.iter().any(|&(a, b)| a <= k && k <= b)
    }

    /// The set moved by `-shift`: `{k - shift}`.
    pub fn minus(&self, shift: i64) -> Runs {
        Runs(
            self.0
                .iter()
                .map(|&(a, b)| (a.saturating_sub(shift), b.saturating_sub(shift)))
                .collect(),
        )
    }

    /// The elements in both sets.
    pub fn intersect(&self, other: &Runs) -> Runs {
        let mut out = Runs::default();
        for &(a, b) in &self.0 {
            for &(x, y) in &other.0 {
                out.insert(a.max(x), b.min(y));
            }
        }
        out
    }

    /// The elements of `self` not in `other`.
    pub fn difference(&self, other: &Runs) -> Runs {
        let mut out = Runs::default();
        for &(a, b) in &self.0 {
            // The first element of `a..=b` not yet covered, `None` past `i64::MAX`.
            let mut from = Some(a);
            for &(x, y) in &other.0 {
                let Some(f) = from else { break };
                if y < f || x > b {
                    continue;
                }
                if x > f {
                    out.insert(f, x - 1);
                }
                from = y.checked_add(1);
            }
            if let Some(f) = from {
                out.insert(f, b);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::Runs;

    #[test]
    fn runs_merge_intersect_and_subtract() {
        let mut r = Runs::run(1, 4);
        r.insert(8, 9);
        r.insert(5, 5);
        assert_eq!(r.iter().collect::<Vec<_>>(), [(1, 5), (8, 9)]);
        assert!(r.contains(9) && !r.contains(6));
        let s = Runs::run(3, 8);
        assert_eq!(r.intersect(&s).iter().collect::<Vec<_>>(), [(3, 5), (8, 8)]);
        assert_eq!(
            r.difference(&s).iter().collect::<Vec<_>>(),
            [(1, 2), (9, 9)]
        );
        assert_eq!(s.difference(&r).iter().collect::<Vec<_>>(), [(6, 7)]);
        assert_eq!(r.minus(2).iter().collect::<Vec<_>>(), [(-1, 3), (6, 7)]);
        assert!(Runs::run(2, 1).is_empty());
        let all = Runs::run(i64::MIN, i64::MAX);
        assert!(all.difference(&all).is_empty());
    }
}
