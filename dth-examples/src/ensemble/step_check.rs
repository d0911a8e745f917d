//! Whether a chaos map's verdicts depend on the step: a sample of the members is run again
//! with every method's step halved, and the regular-or-not verdict (MEGNO `<Y>` at most
//! [`REGULAR_MAX`]) of each sampled run compared with the full run's.
//!
//! A verdict that changes when the step is halved is the step's, not the orbit's: the count
//! goes into `summary.json`, `ensemble.json`, `index.html` and the command's last line, with a
//! warning to halve the step. The sample is [`SAMPLE`] members evenly spread over the
//! sampler's order (all of them when there are fewer), so the check costs at most about
//! `2 SAMPLE / members` of the run; it is the same for any thread or rank count.

use crate::report::StepCheck;
use crate::scene::{Duration, Scene, StepSpec};

use super::member::MemberResult;

/// Members run again at half the step (at most).
pub const SAMPLE: usize = 48;

/// The largest MEGNO `<Y>` called regular (quasi-periodic: `<Y> -> 2`); the chaos map's first
/// class.
pub const REGULAR_MAX: f64 = 2.5;

/// The indices (in the sampler's order) of the members to run again: `SAMPLE` of `count`,
/// evenly spread, or all of them.
pub fn sample(count: usize) -> Vec<usize> {
    let n = count.min(SAMPLE);
    // Member k * count / n: distinct because count >= n.
    (0..n).map(|k| k * count / n).collect()
}

/// `scene` with every method's step halved, over the same span of time (a duration in steps
/// takes twice as many).
pub fn halved(scene: &Scene) -> Scene {
    let mut half = scene.clone();
    for m in &mut half.methods {
        match &mut m.step {
            StepSpec::Fixed { dt } => *dt /= 2.0,
            StepSpec::Dth { dtau, .. } => *dtau /= 2.0,
        }
    }
    if let Duration::Steps(n) = &mut half.duration {
        *n = n.saturating_mul(2);
    }
    half
}

/// Compares the runs of the members `sampled` (indices into `full`) with their runs at half
/// the step (`half`, in the same order).
pub fn compare(full: &[MemberResult], sampled: &[usize], half: &[MemberResult]) -> StepCheck {
    let mut check = StepCheck {
        compared: 0,
        changed: 0,
    };
    let regular = |y: f64| y <= REGULAR_MAX;
    for (&i, h) in sampled.iter().zip(half) {
        let Some(f) = full.get(i) else { continue };
        for (a, b) in f.runs.iter().zip(&h.runs) {
            let both = a.failure.is_none() && b.failure.is_none();
            if let (Some(ya), Some(yb), true) = (a.megno, b.megno, both) {
                check.compared += 1;
                check.changed += usize::from(regular(ya) != regular(yb));
            }
        }
    }
    check
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_is_spread_and_distinct() {
        assert_eq!(sample(5), vec![0, 1, 2, 3, 4]);
        let s = sample(574);
        assert_eq!(s.len(), SAMPLE);
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(s[0], 0);
        assert!(*s.last().unwrap_or(&0) >= 574 - 574 / SAMPLE - 1);
    }
}
