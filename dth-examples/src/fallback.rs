//! What the robust mode of DTH did in a run (`dth::dth::DthOptions::with_robust`, scene key
//! `robust = true`): the steps that fell back to energy-conserving discrete-gradient steps where
//! DTH had no root, their share of the run's steps and of its physical time, and why, read from
//! the step records alone ([`FallbackWatch`], an observer every method of `dth run` carries).
//!
//! This is the one place the numbers are computed: the command's summary line and warning,
//! `summary.json` (per method, `fallback`) and `index.html` read [`Fallback`]; the trajectory
//! CSV's `step_kind` column names each record's kind with [`kind_name`].
//!
//! Where a regularization would have removed the cause (a `1/r`-like singularity in two or
//! three degrees of freedom, `crate::singularity`), the run says so: the caller, which has the
//! system, looks at the state the watch kept ([`FallbackWatch::cause_state`]) and sets
//! [`Fallback::regularization`], which the summary line, the warning and `summary.json` show.
//!
//! ```
//! use dth::nalgebra::Vector2;
//! use dth::observer::{DthRecord, Observer, StepKind, StepRecord};
//! use dth_examples::fallback::FallbackWatch;
//!
//! let record = |k: usize, t: f64, kind: StepKind, psi: f64| StepRecord {
//!     k, t, kind, z: Vector2::new(t, 0.0), iterations: 0, factorizations: 0,
//!     dth: Some(DthRecord { lambda: 1.0, vertex: Vector2::zeros(), vertex_time: t, psi }),
//! };
//! let mut watch = FallbackWatch::new(1);
//! watch.on_step(&record(0, 0.0, StepKind::Dth, 2.0));
//! watch.on_step(&record(1, 1.0, StepKind::Dth, 1.0));
//! watch.on_step(&record(2, 1.5, StepKind::Fallback, -1.0)); // Psi changed sign
//! watch.on_step(&record(3, 4.0, StepKind::Dth, 1.0));
//! let f = watch.finish();
//! assert_eq!((f.steps, f.time), (1, 0.5)); // one step of 1.5 - 1.0
//! assert_eq!((f.share_of_steps, f.share_of_time), (1.0 / 3.0, 0.5 / 4.0));
//! assert!(f.cause.as_deref().is_some_and(|c| c.starts_with("Psi changes sign along the orbit")));
//! assert!(f.warning("dth").is_some()); // 1 of 3 steps is above 1%
//! ```

use dth::nalgebra::{DefaultAllocator, Dim};
use dth::observer::{Observer, StepKind, StepRecord};
use dth::Alloc;
use serde::Serialize;

use crate::singularity::Regularization;

/// `dth run` warns about a method when more than this share of its steps fell back
/// ([`Fallback::warning`]). An isolated fallback step (a close approach, one breakdown) costs
/// a run little; once one step in a hundred is not DTH, the run is a composite of two methods,
/// and what the report says about DTH (vertex invariants, the law of time) no longer describes
/// it.
pub const WARN_ABOVE: f64 = 0.01;

/// At most this many configuration coordinates `q` are named where a cause is located (a
/// position in the plane or in space; beyond that, the time and step say where).
const SHOW_Q: usize = 3;

/// The name of a step's kind, as the trajectory CSV's `step_kind` column writes it: `dth`,
/// `fallback`, `shortened` (DTH's last step, shortened to end on the end time), `fixed` (a
/// fixed-step method).
pub fn kind_name(kind: StepKind) -> &'static str {
    match kind {
        StepKind::Dth => "dth",
        StepKind::Fallback => "fallback",
        StepKind::Shortened => "shortened",
        StepKind::Fixed => "fixed",
        // `StepKind` is non-exhaustive: a kind added later is named here once it is known.
        _ => "other",
    }
}

/// What robust mode did in one method's run (`summary.json`'s `fallback`): zero for a run
/// without fallback steps, which every method other than robust DTH is.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Fallback {
    /// Steps that fell back (records of kind `StepKind::Fallback`).
    pub steps: usize,
    /// The physical time they covered: the sum of each fallback record's `t` minus the
    /// previous record's.
    pub time: f64,
    /// `steps` over the run's steps (0 for a run without steps).
    pub share_of_steps: f64,
    /// `time` over the run's physical time, from its first state to its last (0 for a run
    /// that did not move).
    pub share_of_time: f64,
    /// Why DTH fell back, as far as the records tell (`None` when no step fell back).
    pub cause: Option<String>,
    /// The regularization that would have removed the cause, where one applies (the scene
    /// keys to add and the singular point); set by the caller from
    /// [`FallbackWatch::cause_state`].
    pub regularization: Option<Regularization>,
    /// The run's steps, for [`Fallback`]'s `Display` (in `summary.json` as the method's
    /// `steps`).
    #[serde(skip)]
    pub run_steps: usize,
}

/// "1517 of 1621 steps (93.6%), 97.2% of the physical time", and where a regularization
/// applies, "; `regularize = "levi-civita"` under `[system]` would avoid them".
impl std::fmt::Display for Fallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} of {} steps ({}), {} of the physical time",
            self.steps,
            self.run_steps,
            percent(self.share_of_steps),
            percent(self.share_of_time)
        )?;
        if let Some(r) = &self.regularization {
            write!(f, "; `{}` under [system] would avoid them", r.scene_keys())?;
        }
        Ok(())
    }
}

/// A share as a percentage with one decimal; a share that is not zero is never shown as 0.
fn percent(share: f64) -> String {
    if share > 0.0 && share < 0.0005 {
        "<0.1%".into()
    } else {
        format!("{:.1}%", 100.0 * share)
    }
}

impl Fallback {
    /// The warning `dth run` prints for the method `label` when more than [`WARN_ABOVE`] of
    /// its steps fell back: how many, their share of the time, the cause, and the
    /// regularization that removes it where one applies; `None` otherwise.
    pub fn warning(&self, label: &str) -> Option<String> {
        (self.share_of_steps > WARN_ABOVE).then(|| {
            let fix = self
                .regularization
                .as_ref()
                .map_or(String::new(), |r| format!("; a regularization applies: {r}"));
            format!(
                "method `{label}`: {} of {} steps ({}) fell back to discrete-gradient steps (robust mode), {} of the physical time; cause: {}; DTH's vertex invariants do not hold across them{fix}",
                self.steps,
                self.run_steps,
                percent(self.share_of_steps),
                percent(self.share_of_time),
                self.cause.as_deref().unwrap_or("not known")
            )
        })
    }
}

/// A point of the run: its step, time and first configuration coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct At {
    k: usize,
    t: f64,
    /// `q_1..q_n` for `n <= SHOW_Q`.
    q: Option<[f64; SHOW_Q]>,
    n: usize,
}

/// "t = 2.5 (step 19, q = (0.51, 0.12))".
impl std::fmt::Display for At {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Six digits; in the exponent form where the fixed one would hide them.
        if (1e-3..1e7).contains(&self.t.abs()) {
            write!(f, "t = {:.6}", self.t)?;
        } else {
            write!(f, "t = {:.6e}", self.t)?;
        }
        write!(f, " (step {}", self.k)?;
        if let Some(q) = self.q {
            let q: Vec<String> = q[..self.n].iter().map(|x| format!("{x:.4}")).collect();
            write!(f, ", q = ({})", q.join(", "))?;
        }
        f.write_str(")")
    }
}

/// An observer that counts a run's fallback steps and keeps what names their cause
/// ([`FallbackWatch::finish`]). It stores nothing per step; it allocates twice at most, to
/// keep the state of the first sign change of `Psi` and of the first fallback step
/// ([`FallbackWatch::cause_state`]).
#[derive(Debug, Clone)]
pub struct FallbackWatch {
    /// Configuration coordinates `q` of the system (the first `n` components of `z`).
    n: usize,
    /// Time of the first record and of the last one.
    t0: Option<f64>,
    t: f64,
    /// The last record's step.
    k: usize,
    steps: usize,
    time: f64,
    /// `Psi(zbar_0)`, DTH's sign of reference (its law of time has this sign).
    psi0: Option<f64>,
    /// The first fallback step.
    first_fallback: Option<At>,
    /// The first record whose `Psi` has the sign opposite to `Psi(zbar_0)` (or is zero).
    first_opposite: Option<At>,
    /// The smallest `|Psi / Psi(zbar_0)|` at a fallback node.
    smallest_psi: f64,
    /// The whole state of the first record with the sign of `Psi` opposite to
    /// `Psi(zbar_0)`, and of the first fallback step.
    opposite_state: Option<Vec<f64>>,
    fallback_state: Option<Vec<f64>>,
}

impl FallbackWatch {
    /// A watch for a system with `n` configuration coordinates (to name positions).
    pub fn new(n: usize) -> Self {
        FallbackWatch {
            n,
            t0: None,
            t: 0.0,
            k: 0,
            steps: 0,
            time: 0.0,
            psi0: None,
            first_fallback: None,
            first_opposite: None,
            smallest_psi: f64::INFINITY,
            opposite_state: None,
            fallback_state: None,
        }
    }

    /// Where the cause of the fallback steps is to be looked at, as a whole state: the first
    /// sign change of `Psi`, or without one the first fallback step; `None` for a run without
    /// fallback steps.
    pub fn cause_state(&self) -> Option<&[f64]> {
        if self.steps == 0 {
            return None;
        }
        self.opposite_state
            .as_deref()
            .or(self.fallback_state.as_deref())
    }

    /// The time of the last state seen (`None` before the first).
    pub fn last_time(&self) -> Option<f64> {
        self.t0.map(|_| self.t)
    }

    /// The counts and the cause.
    pub fn finish(&self) -> Fallback {
        let share = |part: f64, whole: f64| if whole > 0.0 { part / whole } else { 0.0 };
        let span = self.t0.map_or(0.0, |t0| (self.t - t0).abs());
        Fallback {
            steps: self.steps,
            time: self.time,
            share_of_steps: share(self.steps as f64, self.k as f64),
            share_of_time: share(self.time.abs(), span),
            cause: (self.steps > 0).then(|| self.cause()),
            regularization: None,
            run_steps: self.k,
        }
    }

    /// Why DTH fell back, from the records: `Psi` taking the sign opposite to `Psi(zbar_0)`
    /// somewhere on the orbit (DTH's law of time `lambda^3 |Psi| = const` sends `lambda` to
    /// infinity at a sign change), or else a near-cancellation of `Psi` or a failure of DTH's
    /// step where `Psi` kept its sign, which the records cannot tell apart further.
    fn cause(&self) -> String {
        let first = self.first_fallback.map_or(String::new(), |at| {
            format!("; the first fallback step at {at}")
        });
        match (self.psi0, self.first_opposite) {
            (Some(psi0), Some(at)) => format!(
                "Psi changes sign along the orbit: it first has the sign opposite to Psi(zbar_0) = {psi0:.3e} at {at}, and near its zeros DTH's law of time lambda^3 |Psi| = c sends lambda to infinity, so the robust mode bridges them with discrete-gradient steps{first}"
            ),
            (Some(_), None) => {
                let smallest = if self.smallest_psi.is_finite() {
                    format!(
                        "; the smallest |Psi / Psi(zbar_0)| at a fallback node is {:.1e}",
                        self.smallest_psi
                    )
                } else {
                    String::new()
                };
                format!(
                    "not a sign change of Psi (it keeps the sign of Psi(zbar_0) at every reported point{smallest}): the robust mode falls back where the terms of Psi nearly cancel (to within 5%), or where a DTH step failed (Newton did not converge, or its lambda was not positive or grew too fast), e.g. a step too large{first}"
                )
            }
            (None, _) => format!("the records carry no Psi to tell{first}"),
        }
    }

    fn at<D: Dim>(&self, r: &StepRecord<D>) -> At
    where
        DefaultAllocator: Alloc<D>,
    {
        let n = self.n.min(r.z.len());
        let q = (n <= SHOW_Q).then(|| {
            let mut q = [0.0; SHOW_Q];
            q[..n].copy_from_slice(&r.z.as_slice()[..n]);
            q
        });
        At {
            k: r.k,
            t: r.t,
            q,
            n,
        }
    }
}

impl<D: Dim> Observer<D> for FallbackWatch
where
    DefaultAllocator: Alloc<D>,
{
    #[inline]
    fn on_step(&mut self, r: &StepRecord<D>) {
        let previous = self.t;
        self.t = r.t;
        self.k = r.k;
        let Some(d) = &r.dth else {
            self.t0.get_or_insert(r.t);
            return;
        };
        if self.t0.is_none() {
            // The initial midpoint: the reference sign of Psi.
            self.t0 = Some(r.t);
            self.psi0 = Some(d.psi);
            return;
        }
        // No reference sign (Psi(zbar_0) zero or not finite): no sign change to find.
        let psi0 = self.psi0.filter(|p| *p != 0.0).unwrap_or(f64::NAN);
        if self.first_opposite.is_none() && d.psi * psi0 <= 0.0 {
            self.first_opposite = Some(self.at(r));
            self.opposite_state = Some(r.z.iter().copied().collect());
        }
        if r.kind == StepKind::Fallback {
            self.steps += 1;
            self.time += r.t - previous;
            if self.first_fallback.is_none() {
                self.first_fallback = Some(self.at(r));
                self.fallback_state = Some(r.z.iter().copied().collect());
            }
            let ratio = (d.psi / psi0).abs();
            if ratio.is_finite() {
                self.smallest_psi = self.smallest_psi.min(ratio);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dth::nalgebra::Vector4;
    use dth::observer::DthRecord;

    fn record(k: usize, t: f64, kind: StepKind, psi: f64) -> StepRecord<dth::nalgebra::U4> {
        StepRecord {
            k,
            t,
            z: Vector4::new(1.0, 2.0, 3.0, 4.0),
            kind,
            iterations: 0,
            factorizations: 0,
            dth: Some(DthRecord {
                lambda: 1.0,
                vertex: Vector4::zeros(),
                vertex_time: t,
                psi,
            }),
        }
    }

    /// A run without fallback steps reports zero, no cause and no warning.
    #[test]
    fn a_run_without_fallback_reports_zero() {
        let mut w = FallbackWatch::new(2);
        for k in 0..5 {
            w.on_step(&record(k, k as f64, StepKind::Dth, 1.0));
        }
        let f = w.finish();
        assert_eq!((f.steps, f.time, f.share_of_steps), (0, 0.0, 0.0));
        assert_eq!((f.cause, f.run_steps), (None, 4));
        assert!(Fallback::default().warning("dth").is_none());
        assert!(w.finish().warning("dth").is_none());
    }

    /// Where Psi keeps its sign, the cause says so and names no sign change.
    #[test]
    fn a_fallback_without_a_sign_change_says_psi_kept_its_sign() {
        let mut w = FallbackWatch::new(2);
        w.on_step(&record(0, 0.0, StepKind::Dth, 4.0));
        w.on_step(&record(1, 1.0, StepKind::Fallback, 1.0));
        let f = w.finish();
        let cause = f.cause.as_deref().unwrap_or_default();
        assert!(cause.starts_with("not a sign change of Psi"), "{cause}");
        assert!(cause.contains("2.5e-1"), "{cause}");
        assert!(cause.contains("q = (1.0000, 2.0000)"), "{cause}");
    }

    /// Psi(zbar_0) = 0 gives no sign to change from: every later Psi times it is zero, which
    /// must not read as a sign change.
    #[test]
    fn a_zero_initial_psi_is_no_sign_change() {
        let mut w = FallbackWatch::new(2);
        w.on_step(&record(0, 0.0, StepKind::Dth, 0.0));
        w.on_step(&record(1, 1.0, StepKind::Fallback, 1.0));
        let cause = w.finish().cause.unwrap_or_default();
        assert!(cause.starts_with("not a sign change of Psi"), "{cause}");
        // No ratio to Psi(zbar_0) = 0 is named.
        assert!(!cause.contains("smallest"), "{cause}");
    }

    /// The warning is given above 1% of the steps, not at it.
    #[test]
    fn the_warning_starts_above_one_percent() {
        let run = |fallback: usize| {
            let mut w = FallbackWatch::new(2);
            w.on_step(&record(0, 0.0, StepKind::Dth, 1.0));
            for k in 1..=100 {
                let kind = if k <= fallback {
                    StepKind::Fallback
                } else {
                    StepKind::Dth
                };
                w.on_step(&record(k, k as f64, kind, -1.0));
            }
            w.finish()
        };
        assert!(run(1).warning("a").is_none());
        let two = run(2);
        assert_eq!((two.steps, two.time), (2, 2.0));
        let warning = two.warning("a").unwrap_or_default();
        assert!(
            warning.starts_with(
                "method `a`: 2 of 100 steps (2.0%) fell back to discrete-gradient steps (robust mode), 2.0% of the physical time; cause: Psi changes sign"
            ),
            "{warning}"
        );
        assert!(
            warning.contains("= 1.000e0 at t = 1.000000 (step 1, q = (1.0000, 2.0000))"),
            "{warning}"
        );
    }
}
