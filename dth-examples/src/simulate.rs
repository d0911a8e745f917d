//! Simulation: every method of a validated scene run on a concrete system, with observers
//! only for the requested effects ([`compute`]); results stay in memory ([`MethodResult`]).
//! Writing them is the report's job (`crate::report`), staging the folder the pipeline's.

use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::Alloc;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};

use dth::observer::{Observer, StepRecord};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::budget::{self, Measure};
use crate::driver::{FailureCause, Limit, MethodFailure, Stop};
use crate::effects::{DeviationStats, EffectOutputs, Effects, FinalState};
use crate::error::Error;
use crate::events::{Conditions, EventHit, EventLog};
use crate::fallback::{Fallback, FallbackWatch};
use crate::method::{run_method, unavailable};
use crate::output_times::OutputTimes;
use crate::scene::{Duration, Ensemble, MethodKind, MethodSpec, Scene, StepSpec};
use crate::singularity::regularization;
use crate::system::SceneSystem;

/// How to run.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct RunOptions {
    /// Show progress bars (indicatif; they hide themselves when stderr is not a terminal).
    /// Default `true`.
    pub progress: bool,
    /// Safety cap on the steps of a run whose duration is a time or a number of orbits.
    /// Default 100,000,000.
    pub max_steps: usize,
    /// The most memory, in bytes, the effects may keep ([`budget`]); a run
    /// estimated above it is refused before it starts. Default `None`: half the memory the
    /// system reports available ([`budget::default_limit`]).
    pub memory_limit: Option<u64>,
    /// Threads an ensemble scene runs its members on (`crate::ensemble`); `None`, the
    /// default: one per core. The results do not depend on it.
    pub threads: Option<usize>,
    /// A flag that interrupts the run at the next step once set (the `dth` command's SIGINT
    /// and SIGTERM handler sets it): the method running stops with
    /// [`FailureCause::Interrupted`], the methods after it do not run, and what was computed
    /// is written. Default `None`.
    pub interrupt: Option<&'static AtomicBool>,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            progress: true,
            max_steps: 100_000_000,
            memory_limit: None,
            threads: None,
            interrupt: None,
        }
    }
}

impl RunOptions {
    /// Sets [`RunOptions::progress`].
    pub fn with_progress(mut self, progress: bool) -> Self {
        self.progress = progress;
        self
    }

    /// Sets [`RunOptions::memory_limit`] (bytes).
    pub fn with_memory_limit(mut self, bytes: u64) -> Self {
        self.memory_limit = Some(bytes);
        self
    }

    /// Sets [`RunOptions::threads`].
    pub fn with_threads(mut self, threads: usize) -> Self {
        self.threads = Some(threads);
        self
    }

    /// Sets [`RunOptions::interrupt`].
    ///
    /// ```
    /// use std::sync::atomic::{AtomicBool, Ordering};
    /// use dth_examples::simulate::RunOptions;
    /// static STOP: AtomicBool = AtomicBool::new(false);
    /// let options = RunOptions::default().with_interrupt(&STOP);
    /// assert!(!options.interrupted());
    /// STOP.store(true, Ordering::Relaxed);
    /// assert!(options.interrupted());
    /// ```
    pub fn with_interrupt(mut self, flag: &'static AtomicBool) -> Self {
        self.interrupt = Some(flag);
        self
    }

    /// `true` once [`RunOptions::interrupt`] is set.
    pub fn interrupted(&self) -> bool {
        self.interrupt.is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// The memory limit in force: the one set, or the default.
    pub fn memory_limit(&self) -> u64 {
        self.memory_limit.unwrap_or_else(budget::default_limit)
    }
}

/// A method that failed mid-run: the step and why (what came before is kept), as
/// `summary.json` and the ensemble CSV show it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Failure {
    /// The step that failed.
    pub step: usize,
    /// Why.
    pub reason: String,
}

impl From<&MethodFailure> for Failure {
    fn from(f: &MethodFailure) -> Self {
        Failure {
            step: f.step,
            reason: f.cause.to_string(),
        }
    }
}

/// The summary of one method's run (it goes into `summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MethodSummary {
    /// Label (file prefix).
    pub label: String,
    /// Method name.
    pub kind: String,
    /// `dt`, or `dtau` / `lambda0` / solver for DTH.
    pub step: BTreeMap<String, serde_json::Value>,
    /// Steps taken.
    pub steps: usize,
    /// Final physical time; for a method that failed, the time of the last state it reached
    /// (the last row of its trajectory).
    pub t_end: f64,
    /// Set when the method failed mid-run.
    pub failure: Option<Failure>,
    /// States observed by effects (0 when the scene requests none).
    pub observer_calls: usize,
    /// Numbers stored by effects (0 when the scene requests none).
    pub stored_values: usize,
    /// Energy deviation statistics (`energy_deviation` or `comparison_table`).
    pub energy: Option<DeviationStats>,
    /// Invariant deviation statistics (`invariants` or `comparison_table`).
    pub invariants: Vec<DeviationStats>,
    /// `final_state`.
    pub final_state: Option<FinalState>,
    /// The steps that fell back to discrete-gradient steps (DTH's robust mode), their share of
    /// the steps and of the physical time, and why; zero for every other method.
    pub fallback: Fallback,
    /// The scene's events that fired (`[[event]]`), in time order; the last one ended the run
    /// if it is a stop (`t_end` is its time).
    pub events: Vec<EventHit>,
}

impl MethodSummary {
    /// The event that ended the run, if one did.
    pub fn stopped_by(&self) -> Option<&EventHit> {
        self.events.iter().find(|e| e.stopped)
    }
}

impl MethodSummary {
    /// `true` for a method that can fall back (DTH in robust mode) or did: its fallback
    /// steps are reported in the summary line and `index.html` even when there are none.
    pub fn reports_fallback(&self) -> bool {
        self.fallback.steps > 0
            || self
                .step
                .get("robust")
                .and_then(serde_json::Value::as_bool)
                .unwrap_or(false)
    }
}

/// One member of an ensemble after its run.
#[derive(Debug, Clone, PartialEq)]
pub struct EnsembleMember {
    /// Initial value of the ensemble's `x` coordinate.
    pub x0: f64,
    /// Initial value of the ensemble's `y` coordinate.
    pub y0: f64,
    /// Final time and state, or why the member failed.
    pub end: Result<(f64, Vec<f64>), Failure>,
    /// Steps robust DTH took as fallback steps (0 for every other method).
    pub fallback_steps: usize,
}

/// One method's results in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodResult {
    /// Summary.
    pub summary: MethodSummary,
    /// Everything the effects produced.
    pub outputs: EffectOutputs,
    /// The scene's ensemble (thesis Figures 4.10-4.13), when it has one: every member, or,
    /// when the run was interrupted during it, the members before the interrupted one.
    pub ensemble: Option<Vec<EnsembleMember>>,
    /// Whether the run was interrupted during the ensemble (the method's own run completed).
    pub ensemble_interrupted: bool,
    /// Why the method stopped early, if it did (the summary holds it as text).
    pub failure: Option<MethodFailure>,
}

/// The initial states of the ensemble `e` around `z0`, row by row: `z0` shifted by
/// `(-w + i s, -w + j s)` in the plane of its two coordinates (`w` the half width, `s` the
/// spacing), with `calH = 0` restored for a time-dependent system.
///
/// # Errors
/// [`Error::Allocation`] when the square's `per_side^2` states cannot be allocated.
pub fn ensemble_starts<D: Dim, S: SceneSystem<D>>(
    system: &S,
    e: &Ensemble,
    z0: &OVector<f64, D>,
) -> Result<Vec<OVector<f64, D>>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let (Some(ix), Some(iy)) = (e.x.index(z0.len()), e.y.index(z0.len())) else {
        return Ok(Vec::new());
    };
    let h = 2.0 * e.half_width / (e.per_side - 1) as f64;
    let mut starts = budget::vec_with_capacity(e.per_side.saturating_mul(e.per_side), || {
        "the square of initial states".into()
    })?;
    for i in 0..e.per_side {
        for j in 0..e.per_side {
            let mut z = z0.clone();
            z[ix] += -e.half_width + i as f64 * h;
            z[iy] += -e.half_width + j as f64 * h;
            if system.flags().time_dependent {
                // Keep calH = 0 for the shifted state.
                put_on_zero_level(system, &mut z);
            }
            starts.push(z);
        }
    }
    Ok(starts)
}

/// The ensemble's members run with `m`, each for `e.steps` steps and interruptible by
/// `stop`'s flag; with `true` when the run was interrupted (the members from the interrupted
/// one on are missing).
fn run_ensemble<D: Dim, S: SceneSystem<D>>(
    system: &S,
    m: &MethodSpec,
    e: &Ensemble,
    z0: &OVector<f64, D>,
    (t0, stop): (f64, Stop),
) -> Result<(Vec<EnsembleMember>, bool), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let (Some(ix), Some(iy)) = (e.x.index(z0.len()), e.y.index(z0.len())) else {
        return Ok((Vec::new(), false));
    };
    let starts = ensemble_starts(system, e, z0)?;
    let mut members =
        budget::vec_with_capacity(starts.len(), || "the square's ensemble members".to_string())?;
    // The square's members run their steps: the scene's events are its own run's.
    let stop = stop.with_limit(Limit::Steps(e.steps)).with_events(&[]);
    for z in starts {
        let (x0, y0) = (z[ix], z[iy]);
        if let Some(reason) = unavailable(m, system, &z) {
            // A method that cannot run from this member (e.g. `exact` past the escape
            // energy) is the member's failure, not the run's end.
            members.push(EnsembleMember {
                x0,
                y0,
                end: Err(Failure {
                    step: 0,
                    reason: format!("method `{}` cannot run: {reason}", m.label),
                }),
                fallback_steps: 0,
            });
            continue;
        }
        // Only its count is kept: no position to name (0 coordinates).
        let mut watch = FallbackWatch::new(0);
        let end = run_method(m, system, z, t0, stop, &mut watch)?;
        if matches!(&end, Err(f) if f.cause == FailureCause::Interrupted) {
            return Ok((members, true));
        }
        members.push(EnsembleMember {
            x0,
            y0,
            end: end
                .map(|end| (end.t, end.z.iter().copied().collect()))
                .map_err(|f| Failure::from(&f)),
            fallback_steps: watch.finish().steps,
        });
    }
    Ok((members, false))
}

/// The initial phase-space point: `(q, p)`, or `(q, t0, p, p_t)` with `calH(z0) = 0` for a
/// time-dependent system (the extended phase space, `docs/theory.md#extended-phase-space`).
pub fn initial_state<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
) -> Result<OVector<f64, D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let n = scene.q.len();
    let expected = if system.flags().time_dependent {
        2 * n + 2
    } else {
        2 * n
    };
    let d = system.dim().value();
    if d != expected || scene.p.len() != n {
        return Err(Error::Registration {
            name: scene.system.clone(),
            reason: format!(
                "the implementation has phase-space dimension D = {d}, but the scene's q and p have lengths {} and {} (expected D = {expected})",
                n,
                scene.p.len()
            ),
        });
    }
    let mut z = dth::zeros(system.dim());
    let half = d / 2;
    for i in 0..n {
        z[i] = scene.q[i];
        z[half + i] = scene.p[i];
    }
    if system.flags().time_dependent {
        z[n] = scene.t0;
        put_on_zero_level(system, &mut z);
    }
    Ok(z)
}

/// Sets the momentum of time `p_t` (the last component of the extended state) so that
/// `calH(z) = p_t + H(t, q, p) = 0`, the level every extended-phase-space run starts on.
fn put_on_zero_level<D: Dim, S: SceneSystem<D>>(system: &S, z: &mut OVector<f64, D>)
where
    DefaultAllocator: Alloc<D>,
{
    let last = z.len() - 1;
    z[last] = 0.0;
    z[last] = -system.value(z);
}

/// When a run of `scene` stops: after its steps, or at its end time (a duration in orbits
/// needs the system's period from `z0`), capped at `options.max_steps`.
pub fn stop_for<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    z0: &OVector<f64, D>,
    options: &RunOptions,
) -> Result<Stop<'static>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let stop = match scene.duration {
        Duration::Steps(n) => Stop::steps(n),
        Duration::Time(t) => Stop::time(scene.t0 + t, options.max_steps),
        Duration::Orbits(k) => {
            let period = system.period(z0).ok_or_else(|| Error::NotAvailable {
                what: "duration in orbits for system",
                name: scene.system.clone(),
                reason:
                    "the initial state has no orbit period (e.g. unbound): use `steps` or `time`"
                        .into(),
            })?;
            Stop::time(scene.t0 + k * period, options.max_steps)
        }
    };
    Ok(stop.with_interrupt(options.interrupt))
}

/// Refuses, before any method runs, what would otherwise stop the run after some methods
/// computed (and lose their results) or end it short of what the scene asks:
/// - an initial state where `H` or its gradient is not finite ([`Error::InitialState`]:
///   outside `H`'s domain, or overflowing; no method can take a step from it);
/// - a method that cannot run from `z0` ([`Error::NotAvailable`], `method::unavailable`:
///   e.g. `exact` on an unbound Kepler orbit);
/// - a step too small to change the state in double precision ([`Error::StepUnresolved`]);
/// - a fixed-step method given a duration in time that would need more than
///   `options.max_steps` steps ([`Error::TooManySteps`]: the cap would stop it short);
/// - chosen times outside the run ([`OutputTimes::new`]).
///
/// Returns the run's chosen times, resolved.
///
/// A single run checks this in [`compute`]; `dth check` too (`Catalogue::estimate`).
pub fn preflight<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    z0: &OVector<f64, D>,
    stop: Stop,
) -> Result<OutputTimes, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let h = system.value(z0);
    let gradient = system.gradient(z0);
    if !h.is_finite() || gradient.iter().any(|g| !g.is_finite()) {
        // `{:?}`: exponents for large and small values, and every digit.
        let g: Vec<String> = gradient.iter().map(|g| format!("{g:?}")).collect();
        return Err(Error::InitialState {
            detail: format!(
                "H = {h:?} and grad H = [{}] at q = {:?}, p = {:?}: expected an initial state where `{}` and its gradient are finite",
                g.join(", "),
                scene.q,
                scene.p,
                scene.system
            ),
        });
    }
    // The step's effect on the state: `dt * |J grad H|`, whose largest component is that of
    // `grad H` (J only permutes and negates). Below `eps * max |z0|` a step changes no
    // component of the state in double precision, and Newton's matrices (differences of the
    // state) are zero: refused here with the smallest step that resolves, instead of a
    // "singular matrix" at step 1. A state at rest (zero gradient) or at the origin is not
    // bounded this way.
    let scale = z0.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let speed = gradient.iter().fold(0.0f64, |a, g| a.max(g.abs()));
    let resolved = f64::EPSILON * scale;
    for m in &scene.methods {
        let (dt, per_dt, unit) = match m.step {
            StepSpec::Fixed { dt } => (dt, 1.0, "dt"),
            StepSpec::Dth { dtau, lambda0, .. } => {
                (lambda0 * dtau, lambda0, "dtau (at this lambda0)")
            }
        };
        if speed > 0.0 && dt * speed < resolved {
            return Err(Error::StepUnresolved {
                method: m.label.clone(),
                dt,
                change: dt * speed,
                resolved,
                min_step: resolved / speed / per_dt,
                unit,
            });
        }
    }
    for m in &scene.methods {
        if let Some(reason) = unavailable(m, system, z0) {
            return Err(Error::NotAvailable {
                what: "method",
                name: m.label.clone(),
                reason: reason.to_string(),
            });
        }
        if let (StepSpec::Fixed { dt }, Limit::Time { t_end, max_steps }) = (m.step, stop.limit) {
            if dth::methods::steps_until(scene.t0, t_end, dt) > max_steps {
                return Err(Error::TooManySteps {
                    method: m.label.clone(),
                    steps: ((t_end - scene.t0) / dt).ceil(),
                    dt,
                    t_end,
                    max_steps,
                });
            }
        }
    }
    OutputTimes::new(&scene.effects, scene.t0, stop.limit.end_time())
}

/// Progress as an observer: moves the bar every 1024 steps (nothing else per step).
pub struct Progress(pub ProgressBar);

impl<D: Dim> Observer<D> for Progress
where
    DefaultAllocator: Alloc<D>,
{
    #[inline(always)]
    fn on_step(&mut self, record: &StepRecord<D>) {
        if record.k.is_multiple_of(1024) {
            self.0.set_position(record.k as u64);
        }
    }
}

/// The progress bar's template: with an ETA when the number of steps is known in advance
/// (`known_length`), a spinner otherwise.
pub fn progress_template(known_length: bool) -> &'static str {
    if known_length {
        "{prefix:>20} [{bar:40}] {pos}/{len} steps {elapsed} (eta {eta})"
    } else {
        "{prefix:>20} {spinner} {pos} steps {elapsed}"
    }
}

/// The progress bar of method `m` running from `t0` until `stop` (hidden unless
/// `options.progress`).
pub fn progress_bar(m: &MethodSpec, t0: f64, stop: Stop, options: &RunOptions) -> ProgressBar {
    if !options.progress {
        return ProgressBar::hidden();
    }
    let len = match (stop.limit, m.step) {
        (Limit::Steps(n), _) => Some(n as u64),
        (Limit::Time { .. }, StepSpec::Fixed { dt }) => Some(stop.fixed_steps(t0, dt) as u64),
        _ => None,
    };
    let bar = match len {
        Some(n) => ProgressBar::new(n),
        None => ProgressBar::new_spinner(),
    };
    if let Ok(style) = ProgressStyle::with_template(progress_template(len.is_some())) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix(m.label.clone());
    bar
}

fn step_summary(step: StepSpec) -> BTreeMap<String, serde_json::Value> {
    let mut m = BTreeMap::new();
    match step {
        StepSpec::Fixed { dt } => {
            m.insert("dt".into(), dt.into());
        }
        StepSpec::Dth {
            dtau,
            lambda0,
            solver,
            robust,
            order,
            double_double,
        } => {
            m.insert("dtau".into(), dtau.into());
            m.insert("lambda0".into(), lambda0.into());
            m.insert("solver".into(), solver.name().into());
            // Shown when on (a run without it reads as before).
            if robust {
                m.insert("robust".into(), robust.into());
            }
            if order != 2 {
                m.insert("order".into(), order.into());
            }
            if double_double {
                m.insert("double_double".into(), double_double.into());
            }
        }
    }
    m
}

/// What the robust mode did in a run `watch` saw, with the regularization that would have
/// avoided its fallback steps where one applies at the state of their cause.
fn fallback_of<D: Dim, S: SceneSystem<D>>(system: &S, watch: &FallbackWatch) -> Fallback
where
    DefaultAllocator: Alloc<D>,
{
    let mut fallback = watch.finish();
    if let Some(state) = watch.cause_state() {
        let mut z = dth::zeros(system.dim());
        if z.len() == state.len() {
            z.as_mut_slice().copy_from_slice(state);
            fallback.regularization = regularization(system, &z);
        }
    }
    fallback
}

/// Runs every method of `scene` on `system` and keeps the results in memory (no files).
/// Effects not requested are not constructed. A run interrupted through
/// [`RunOptions::interrupt`] returns the methods up to the interrupted one (its failure is
/// [`FailureCause::Interrupted`]); the ones after it are missing.
pub fn compute<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    options: &RunOptions,
) -> Result<Vec<MethodResult>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let z0 = initial_state(system, scene)?;
    let stop = stop_for(system, scene, &z0, options)?;
    budget::check(
        system,
        scene,
        (&z0, stop),
        options.memory_limit(),
        Measure::AboveLimit,
    )?;
    let times = preflight(system, scene, &z0, stop)?;
    let conditions = Conditions::compile(scene, system.flags().time_dependent).map_err(|e| {
        Error::NotAvailable {
            what: "event conditions of scene",
            name: scene.title.clone(),
            reason: e.to_string(),
        }
    })?;
    let watched = conditions.watched();
    let stop = stop.with_times(times.landings()).with_events(&watched);
    let mut results = Vec::new();
    for m in &scene.methods {
        let bar = progress_bar(m, scene.t0, stop, options);
        let progress = (
            (Progress(bar.clone()), FallbackWatch::new(scene.q.len())),
            EventLog::new(scene),
        );
        let (end, outputs, calls, stored, (watch, log)) =
            match Effects::new(system, &scene.effects, &times) {
                Some(effects) => {
                    let mut observers = (progress, effects);
                    let end = run_method(m, system, z0.clone(), scene.t0, stop, &mut observers)?;
                    let (((_, watch), log), effects) = observers;
                    let (calls, stored) = (effects.observer_calls(), effects.stored_values());
                    (end, effects.finish(), calls, stored, (watch, log))
                }
                None => {
                    let mut observers = progress;
                    let end = run_method(m, system, z0.clone(), scene.t0, stop, &mut observers)?;
                    let ((_, watch), log) = observers;
                    (end, EffectOutputs::default(), 0, 0, (watch, log))
                }
            };
        bar.finish_and_clear();
        let (steps, t_end, failure) = match &end {
            Ok(e) => (e.steps, e.t, None),
            // Where a method that failed stopped: the last state it reached.
            Err(f) => (
                f.step.saturating_sub(1),
                watch.last_time().unwrap_or(scene.t0),
                Some(Failure::from(f)),
            ),
        };
        let mut step = step_summary(m.step);
        if let (Some(r), MethodKind::Dth) = (&scene.regularize, m.kind) {
            // What it ran on; its records were mapped back to the physical state.
            step.insert("regularize".into(), r.map.name().into());
        }
        let summary = MethodSummary {
            label: m.label.clone(),
            kind: m.kind.name().to_string(),
            step,
            steps,
            t_end,
            failure,
            observer_calls: calls,
            stored_values: stored,
            energy: outputs.energy.as_ref().map(|e| e.0.clone()),
            invariants: outputs
                .invariants
                .as_ref()
                .map(|v| v.iter().map(|i| i.0.clone()).collect())
                .unwrap_or_default(),
            final_state: outputs.final_state.clone(),
            fallback: fallback_of(system, &watch),
            events: log.hits,
        };
        let mut interrupted = matches!(&end, Err(f) if f.cause == FailureCause::Interrupted);
        let (ensemble, ensemble_interrupted) = match &scene.ensemble {
            Some(e) if !interrupted => {
                let (members, stopped) = run_ensemble(system, m, e, &z0, (scene.t0, stop))?;
                (Some(members), stopped)
            }
            _ => (None, false),
        };
        interrupted |= ensemble_interrupted;
        results.push(MethodResult {
            summary,
            outputs,
            ensemble,
            ensemble_interrupted,
            failure: end.err(),
        });
        if interrupted {
            // The methods after it do not run: the caller writes what was computed.
            break;
        }
    }
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_progress_bar_of_known_length_shows_its_eta() {
        assert!(progress_template(true).contains("{eta}"));
        assert!(progress_template(true).contains("{len}"));
        // A spinner has no length, so no ETA to show.
        assert!(!progress_template(false).contains("{eta}"));
        for known in [true, false] {
            assert!(ProgressStyle::with_template(progress_template(known)).is_ok());
        }
    }

    /// The thesis's square of initial states stops at an interruption (the members from the
    /// interrupted one on are not run) and says so; without one, every member runs.
    #[test]
    fn an_interrupted_ensemble_stops_and_says_so() {
        static FLAG: AtomicBool = AtomicBool::new(true);
        let text = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                    [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 10\n\
                    [ensemble]\nx = \"q1\"\ny = \"p1\"\nhalf_width = 0.01\nsteps = 5\nper_side = 3\n";
        let scene =
            crate::check_scene(text, "square.toml", &crate::catalogue::Catalogue::builtin())
                .unwrap();
        let system = crate::systems::Kepler::thesis();
        let z0 = initial_state(&system, &scene).unwrap();
        let (m, e) = (&scene.methods[0], scene.ensemble.as_ref().unwrap());
        let interruptible = Stop::steps(10).with_interrupt(Some(&FLAG));
        let (members, stopped) = run_ensemble(&system, m, e, &z0, (0.0, interruptible)).unwrap();
        assert!(stopped && members.is_empty(), "{stopped} {}", members.len());
        FLAG.store(false, Ordering::SeqCst);
        let (members, stopped) = run_ensemble(&system, m, e, &z0, (0.0, interruptible)).unwrap();
        assert!(
            !stopped && members.len() == 9,
            "{stopped} {}",
            members.len()
        );
        assert!(members.iter().all(|m| m.end.is_ok()));
    }
}
