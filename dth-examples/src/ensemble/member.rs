//! One member of an ensemble scene run with every method ([`run_member`]), and what it
//! yields ([`MemberResult`]).

use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::Alloc;
use std::collections::BTreeMap;

use dth::observer::{Observer, StepRecord};

use super::chaos::{Megno, Tangent};
use super::sample::{on_shell, Candidate, Shell};
use crate::driver::Stop;
use crate::effects::{Crossings, Effects};
use crate::error::Error;
use crate::fallback::FallbackWatch;
use crate::method::{run_method, unavailable};
use crate::output_times::OutputTimes;
use crate::scene::{ChaosIndicator, Members, MethodKind, MethodSpec, Scene};
use crate::simulate::{initial_state, stop_for, Failure, RunOptions};
use crate::system::SceneSystem;

/// Builds a scene's system from a member's parameters.
pub type Build<'a, S> = dyn Fn(&BTreeMap<String, f64>) -> Result<S, Error> + Sync + 'a;

/// One method's run of one member.
#[derive(Debug, Clone, PartialEq)]
pub struct MemberRun {
    /// The method's label.
    pub method: String,
    /// Steps taken (for a failed run, the steps before the failing one).
    pub steps: usize,
    /// Time of the last state reached.
    pub t_end: f64,
    /// The last state reached (DTH: its last midpoint).
    pub end: Vec<f64>,
    /// `max_k |H(z_k) - H(z_0)|` over the states reached.
    pub energy_error: f64,
    /// Steps robust DTH took as fallback steps (`crate::fallback`; 0 for every other method).
    pub fallback_steps: usize,
    /// Why the run stopped early, if it did.
    pub failure: Option<Failure>,
    /// MEGNO `<Y>` (when the ensemble asks for it and the run lasted).
    pub megno: Option<f64>,
    /// Benettin's maximal Lyapunov exponent estimate (beside MEGNO).
    pub lyapunov: Option<f64>,
    /// The smaller alignment index SALI (beside MEGNO).
    pub sali: Option<f64>,
    /// The crossings of each `poincare` effect of the scene, in scene order.
    pub crossings: Vec<Crossings>,
}

/// A member after its runs.
#[derive(Debug, Clone, PartialEq)]
pub struct MemberResult {
    /// Its position in the sampler's order.
    pub index: usize,
    /// The system's parameters for it.
    pub params: BTreeMap<String, f64>,
    /// The initial phase-space state (on the shell, when asked); `None` when skipped.
    pub start: Option<Vec<f64>>,
    /// Why it did not run at all: the energy shell has no real solution for it (then
    /// [`MemberResult::skipped`]), or its parameters make no system.
    pub not_run: Option<String>,
    /// `true` when the energy shell skipped it (counted, not a failure).
    pub skipped: bool,
    /// One run per method, in scene order (empty when it did not run).
    pub runs: Vec<MemberRun>,
}

/// The last state, its time and the largest energy deviation of a run, and MEGNO when asked.
struct Watch<'s, D: Dim, S>
where
    DefaultAllocator: Alloc<D>,
{
    system: &'s S,
    h0: Option<f64>,
    energy_error: f64,
    last: Option<(usize, f64, OVector<f64, D>)>,
    megno: Option<Megno<'s, D, S>>,
    fallback: FallbackWatch,
}

impl<D: Dim, S: SceneSystem<D>> Observer<D> for Watch<'_, D, S>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, record: &StepRecord<D>) {
        let h = self.system.value(&record.z);
        match self.h0 {
            None => self.h0 = Some(h),
            Some(h0) => {
                let d = (h - h0).abs();
                // NaN (a state that left the domain) counts as the worst error.
                let d = if d.is_nan() { f64::INFINITY } else { d };
                self.energy_error = self.energy_error.max(d);
            }
        }
        match &mut self.last {
            // The stored state is overwritten: no allocation per step for `Dyn`.
            Some((k, t, z)) => {
                (*k, *t) = (record.k, record.t);
                z.copy_from(&record.z);
            }
            None => self.last = Some((record.k, record.t, record.z.clone())),
        }
        if let Some(m) = &mut self.megno {
            m.on_step(record);
        }
        self.fallback.on_step(record);
    }
}

/// Runs method `m` from `z0` with the watch and the scene's effects as observers.
fn run_one<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    chaos: Option<ChaosIndicator>,
    m: &MethodSpec,
    z0: OVector<f64, D>,
    stop: Stop,
) -> Result<MemberRun, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let watch = Watch {
        system,
        h0: None,
        energy_error: 0.0,
        last: None,
        megno: chaos.map(|ChaosIndicator::Megno| Megno::new(system).with_tangent(tangent(m))),
        fallback: FallbackWatch::new(scene.q.len()),
    };
    let times = OutputTimes::new(&scene.effects, scene.t0, stop.limit.end_time())?;
    let stop = stop.with_times(times.landings());
    let (end, watch, crossings) = match Effects::new(system, &scene.effects, &times) {
        Some(effects) => {
            let mut obs = (watch, effects);
            let end = run_method(m, system, z0.clone(), scene.t0, stop, &mut obs)?;
            (end, obs.0, obs.1.finish().poincare)
        }
        None => {
            let mut obs = watch;
            let end = run_method(m, system, z0.clone(), scene.t0, stop, &mut obs)?;
            (end, obs, Vec::new())
        }
    };
    let (k, t, z) = watch.last.unwrap_or((0, scene.t0, z0));
    let indicators = watch.megno.as_ref().and_then(Megno::indicators);
    let failure = end.err().map(|f| Failure::from(&f));
    Ok(MemberRun {
        method: m.label.clone(),
        steps: k,
        t_end: t,
        end: z.iter().copied().collect(),
        energy_error: watch.energy_error,
        fallback_steps: watch.fallback.finish().steps,
        failure,
        megno: indicators.map(|i| i.megno),
        lyapunov: indicators.map(|i| i.lyapunov),
        sali: indicators.map(|i| i.sali),
        crossings,
    })
}

/// Runs member `c` of the ensemble `members` of `scene` with every method: the system built
/// from its parameters by `build`, its initial state put on the energy shell when asked.
///
/// A member that cannot run (no real momentum on the shell: skipped; parameters that make
/// no system, or a duration the member's state cannot give: recorded as not run) and a
/// member whose method fails mid-run are results, not errors: the others complete.
///
/// # Errors
/// What fails for every member alike: a method not available for the system, an energy
/// shell of a system that is not quadratic in the solved momentum. A method that cannot run
/// from one member's state (`method::unavailable`) is a failed run of that member.
pub fn run_member<D: Dim, S: SceneSystem<D>>(
    build: &Build<'_, S>,
    scene: &Scene,
    members: &Members,
    c: &Candidate,
    options: &RunOptions,
) -> Result<MemberResult, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut result = MemberResult {
        index: c.index,
        params: c.params.clone(),
        start: None,
        not_run: None,
        skipped: false,
        runs: Vec::new(),
    };
    if options.interrupted() {
        result.not_run = Some("the run was interrupted before this member".into());
        return Ok(result);
    }
    let system = match build(&c.params) {
        Ok(s) => s,
        Err(e) => {
            result.not_run = Some(e.to_string());
            return Ok(result);
        }
    };
    let own = Scene {
        q: c.q.clone(),
        p: c.p.clone(),
        params: c.params.clone(),
        ..scene.clone()
    };
    let mut z0 = initial_state(&system, &own)?;
    if let Some(shell) = members.shell {
        if system.flags().time_dependent {
            return Err(Error::NotAvailable {
                what: "energy shell for system",
                name: scene.system.clone(),
                reason:
                    "its H depends on time, so H = E is no invariant set: drop `energy` and `solve`"
                        .into(),
            });
        }
        match on_shell(&system, &mut z0, shell) {
            Shell::On => {}
            Shell::NoRealSolution => {
                result.not_run = Some(format!(
                    "no real {} puts this state on the shell H = {}",
                    shell.solve.name(),
                    shell.energy
                ));
                result.skipped = true;
                return Ok(result);
            }
            Shell::NotQuadratic => {
                return Err(Error::NotAvailable {
                    what: "energy shell for system",
                    name: scene.system.clone(),
                    reason: format!(
                        "H is not a quadratic polynomial in {}, so `solve` cannot solve it",
                        shell.solve.name()
                    ),
                })
            }
        }
    }
    result.start = Some(z0.iter().copied().collect());
    let stop = match stop_for(&system, &own, &z0, options) {
        Ok(stop) => stop,
        Err(e) => {
            result.not_run = Some(e.to_string());
            return Ok(result);
        }
    };
    for m in &scene.methods {
        let run = match unavailable(m, &system, &z0) {
            // A method that cannot run from this member's state (e.g. `exact` on an unbound
            // orbit) is this member's row, not the ensemble's end: the others complete.
            Some(reason) => MemberRun {
                method: m.label.clone(),
                steps: 0,
                t_end: scene.t0,
                end: z0.iter().copied().collect(),
                energy_error: 0.0,
                fallback_steps: 0,
                failure: Some(Failure {
                    step: 0,
                    reason: format!("method `{}` cannot run: {reason}", m.label),
                }),
                megno: None,
                lyapunov: None,
                sali: None,
                crossings: vec![Vec::new(); sections(scene)],
            },
            None => run_one(&system, scene, members.chaos, m, z0.clone(), stop)?,
        };
        result.runs.push(run);
    }
    Ok(result)
}

/// The number of sections (`poincare`, `stroboscopic`) of `scene` (one list of points each).
fn sections(scene: &Scene) -> usize {
    scene.effects.iter().filter(|e| e.is_section()).count()
}

/// The tangent step that follows method `m` (`super::chaos`): Stormer-Verlet's own map after
/// it, the fourth-order step after a method of order 4 or more, the implicit midpoint's
/// otherwise.
fn tangent(m: &MethodSpec) -> Tangent {
    match m.kind {
        MethodKind::StormerVerlet => Tangent::Verlet,
        _ if m.order() >= 4 => Tangent::Fourth,
        _ => Tangent::Midpoint,
    }
}
