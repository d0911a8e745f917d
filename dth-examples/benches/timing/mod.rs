//! Wall-clock helpers of the plain-table benches (`pair_sums`, `text_lattices`): rows that
//! take seconds, timed by hand instead of by criterion.

use std::time::{Duration, Instant};

/// The median of `t` (the upper one of an even count).
pub fn median(mut t: Vec<Duration>) -> Duration {
    t.sort_unstable();
    t[t.len() / 2]
}

/// `f`'s result and how long it took.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, Duration) {
    let t = Instant::now();
    let out = f();
    (out, t.elapsed())
}
