//! `dth check`'s estimate of how long a run takes, before it runs: each method's time per
//! step, measured on a few steps of the scene's own system from its own initial state (the
//! same code `dth run` runs: the compiled type or the text compiled at the scene's sizes, the
//! structured Newton at 4,096 sites as at 4), times the steps the duration needs (those of
//! [`crate::budget`]'s memory estimate: exact for `steps` and fixed-step methods, for DTH run
//! for a time from its average step over the `Psi` probe's run).
//!
//! **What is measured.** A method runs 2, then 8, 32, ... steps without effects until a run
//! takes [`MEASURE_SECONDS`] or [`MEASURE_STEPS`] steps (or the method stops early), and the
//! last run's time per step is the method's. Effects, writing the output folder and a DTH
//! step size that changes along the orbit are not in it: it is an estimate of the stepping,
//! good to a factor of about two, which is what deciding whether to run needs.

use std::time::Instant;

use dth::nalgebra::{DefaultAllocator, Dim};
use dth::Alloc;

use crate::budget::MemoryEstimate;
use crate::error::Error;
use crate::scene::{Duration, Scene};
use crate::simulate::{compute, RunOptions};
use crate::system::SceneSystem;

/// A measuring run that takes this long (seconds) is long enough.
pub const MEASURE_SECONDS: f64 = 0.05;

/// The most steps a measuring run takes.
pub const MEASURE_STEPS: usize = 2048;

/// Each method's seconds per step on `system` from the scene's initial state, in the order
/// of `scene.methods` (see the module docs).
///
/// # Errors
/// What a run of the scene refuses before it starts ([`compute`]'s errors).
pub fn seconds_per_step<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
) -> Result<Vec<f64>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let quiet = RunOptions::default().with_progress(false);
    let mut one = scene.clone();
    one.effects = Vec::new();
    one.members = None;
    one.ensemble = None;
    one.thesis_figures = false;
    scene
        .methods
        .iter()
        .map(|method| {
            one.methods = vec![method.clone()];
            let mut k = 2;
            loop {
                one.duration = Duration::Steps(k);
                let start = Instant::now();
                let results = compute(system, &one, &quiet)?;
                let seconds = start.elapsed().as_secs_f64();
                let taken = results.first().map_or(0, |r| r.summary.steps);
                if seconds >= MEASURE_SECONDS || k >= MEASURE_STEPS || taken < k {
                    return Ok(seconds / taken.max(1) as f64);
                }
                k *= 4;
            }
        })
        .collect()
}

/// The estimated seconds of a run: each method's steps (from `memory`, in the order of the
/// scene's methods) times its `seconds_per_step`, for each of `members` runs (1 for a single
/// run) shared by `threads` threads.
///
/// ```
/// use dth_examples::budget::MemoryEstimate;
/// use dth_examples::step_time::run_seconds;
/// let memory = MemoryEstimate { methods: vec![("dth".into(), 1000, 0), ("rk4".into(), 500, 0)] };
/// // 1000 * 2 ms + 500 * 1 ms = 2.5 s a member; 8 members on 4 threads: 5 s.
/// assert!((run_seconds(&memory, &[2e-3, 1e-3], 8, 4) - 5.0).abs() < 1e-12);
/// ```
pub fn run_seconds(
    memory: &MemoryEstimate,
    seconds_per_step: &[f64],
    members: usize,
    threads: usize,
) -> f64 {
    let one: f64 = memory
        .methods
        .iter()
        .zip(seconds_per_step)
        .map(|((_, steps, _), s)| *steps as f64 * s)
        .sum();
    // Members are spread over the threads in whole rounds.
    let rounds = members.max(1).div_ceil(threads.max(1));
    one * rounds as f64
}

/// `seconds` as people read an estimate: "0.25 s", "12 s", "4.2 min", "2.5 h", "3 days".
///
/// ```
/// use dth_examples::step_time::human;
/// assert_eq!(human(0.25), "0.25 s");
/// assert_eq!(human(12.3), "12 s");
/// assert_eq!(human(250.0), "4.2 min");
/// assert_eq!(human(9000.0), "2.5 h");
/// assert_eq!(human(3.0 * 86400.0), "3 days");
/// ```
pub fn human(seconds: f64) -> String {
    let s = seconds.max(0.0);
    // Two significant digits below 10, whole numbers above.
    let short = |x: f64| {
        let digits = if x < 1.0 {
            2
        } else if x < 10.0 {
            1
        } else {
            0
        };
        let text = format!("{x:.digits$}");
        if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        }
    };
    if s < 60.0 {
        format!("{} s", short(s))
    } else if s < 3600.0 {
        format!("{} min", short(s / 60.0))
    } else if s < 2.0 * 86400.0 {
        format!("{} h", short(s / 3600.0))
    } else {
        format!("{} days", short(s / 86400.0))
    }
}
