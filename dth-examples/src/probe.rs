//! `dth check`'s look at a scene's orbit before it runs: does `Psi = (J grad H)^T Hess H
//! (J grad H)` keep its sign ([`probe_psi`])? DTH's law of time `lambda^3 |Psi| = c` has no
//! positive root across a sign change, so plain DTH breaks down there and robust mode falls
//! back to discrete-gradient steps; where the cause is a `1/r`-like singularity in two or three
//! degrees of freedom a regularization removes it ([`crate::singularity`]), and the warning
//! says which (`regularize = "levi-civita"` or `"ks"` under `[system]`), else it suggests
//! robust mode.
//!
//! The same run measures DTH's average step ([`time_per_step`]), from which `crate::budget`
//! counts the steps of a DTH run for a time (and `dth check` its time).
//!
//! **What the probe runs, and why.** `Psi` is sampled where DTH itself evaluates it: at the
//! midpoints of a short run of the scene's first `dth` method (its `dtau`, `lambda0` and
//! solver), of order 2 whatever the scene's order (a composed step's sub-steps sample the same
//! orbit, at 5-17 times the cost) and in robust mode, so that the run goes on through the
//! sign change instead of stopping short of it (a fallback node carries `Psi` too). It covers
//! one orbit where the system knows its period (a sign change on a periodic orbit shows in
//! every orbit), else the scene's own duration, and never more than [`PROBE_STEPS`] steps or
//! the scene's own steps: milliseconds for the catalogue's systems. A scene without a `dth`
//! method, an ensemble of members (each starts elsewhere) and a system run without DTH are
//! not probed. The probe never fails a check: a probe run that fails (Newton, a step cap)
//! reports what it saw up to there.

use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::observer::{Observer, StepRecord};
use dth::Alloc;

use crate::driver::{DthRunner, Stop};
use crate::scene::{component_names, Duration, Scene, StepSpec};
use crate::singularity::{regularization, Regularization};
use crate::system::SceneSystem;

/// The probe takes at most this many DTH steps: it must not make `dth check` slow. On an
/// e = 0.9 Kepler orbit at the shipped scene's `dtau` one orbit is ~360 robust steps.
pub const PROBE_STEPS: usize = 2_000;

/// Where `Psi` changed sign on a scene's orbit, and the fix ([`PsiSignChange::warning`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PsiSignChange {
    /// The label of the scene's `dth` method that was probed.
    pub method: String,
    /// Whether that method is in robust mode already (it falls back there instead of
    /// breaking down).
    pub robust: bool,
    /// `Psi` at the initial state, the sign DTH's law of time keeps.
    pub psi0: f64,
    /// The first probed point where `Psi` has the opposite sign (or is zero): its time...
    pub t: f64,
    /// ...its state, component by component (`q1 .. qn, p1 .. pn`, with `t_ext`, `p_t` for a
    /// time-dependent system)...
    pub state: Vec<(String, f64)>,
    /// ...and `Psi` there.
    pub psi: f64,
    /// The probe's step at which it was found.
    pub step: usize,
    /// The regularization that removes it, where one applies (a `1/r`-like singularity in
    /// two or three degrees of freedom), found at that state.
    pub regularization: Option<Regularization>,
}

impl PsiSignChange {
    /// The warning `dth check` prints: where `Psi` changed sign, what DTH will do there, and
    /// the fix (a regularization where one applies, else robust mode).
    pub fn warning(&self) -> String {
        let mut state: Vec<String> = self
            .state
            .iter()
            .take(SHOWN_COORDINATES)
            .map(|(name, x)| format!("{name} = {x:.6}"))
            .collect();
        if self.state.len() > SHOWN_COORDINATES {
            state.push(format!(
                "... {} more coordinates",
                self.state.len() - SHOWN_COORDINATES
            ));
        }
        let consequence = if self.robust {
            "its robust mode will fall back to discrete-gradient steps there (second order, and DTH's vertex invariants do not hold across them)"
        } else {
            "plain DTH will break down there (its law of time lambda^3 |Psi| = c has no positive root across a sign change)"
        };
        let fix = match (&self.regularization, self.robust) {
            (Some(r), _) => format!("fix: {r}"),
            (None, false) => format!(
                "fix: `robust = true` on method `{}` (energy-conserving discrete-gradient steps across the sign change; no regularization applies: it needs a 1/r-like singularity in two or three degrees of freedom)",
                self.method
            ),
            (None, true) => {
                "no regularization applies (it needs a 1/r-like singularity in two or three degrees of freedom), so robust mode is the way through".to_string()
            }
        };
        format!(
            "method `{}`: Psi = (J gradH)^T HessH (J gradH) changes sign along the orbit: Psi(z0) = {:.3e}, but Psi = {:.3e} at t = {} ({}), step {} of a short DTH probe; {consequence}; {fix}",
            self.method,
            self.psi0,
            self.psi,
            short(self.t),
            state.join(", "),
            self.step,
        )
    }
}

/// The most coordinates of the state a warning names: a 64-body cluster's 384 would bury
/// the warning (a run writes the whole state; the warning says where in time).
const SHOWN_COORDINATES: usize = 8;

/// Six significant digits, in the exponent form where the fixed one would hide them.
fn short(x: f64) -> String {
    if x == 0.0 || (1e-3..1e7).contains(&x.abs()) {
        format!("{x:.6}")
    } else {
        format!("{x:.6e}")
    }
}

/// Watches DTH's records for the first `Psi` of the sign opposite to `Psi(zbar_0)`.
struct SignWatch<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    psi0: Option<f64>,
    /// The first opposite record: step, time, state, `Psi`.
    found: Option<(usize, f64, OVector<f64, D>, f64)>,
}

impl<D: Dim> Observer<D> for SignWatch<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, r: &StepRecord<D>) {
        let Some(d) = &r.dth else { return };
        match self.psi0 {
            None => self.psi0 = Some(d.psi),
            Some(psi0) => {
                // Psi(zbar_0) = 0 (or not finite) gives no sign to keep: nothing to find.
                let opposite = psi0 != 0.0 && psi0.is_finite() && d.psi * psi0 <= 0.0;
                if opposite && self.found.is_none() {
                    self.found = Some((r.k, r.t, r.z.clone(), d.psi));
                }
            }
        }
    }
}

/// The probe's run (see the [module docs](self)) on `system` from `z0`, every record shown to
/// `observer`: the probed method's label, whether it is robust, and its `dtau lambda0`; `None`
/// when the scene is not probed. A failed probe run (Newton, the step cap) has shown the
/// observer what it computed: enough.
fn probe_run<D: Dim, S: SceneSystem<D>, O: Observer<D>>(
    system: &S,
    scene: &Scene,
    z0: &OVector<f64, D>,
    observer: &mut O,
) -> Option<(String, bool, f64)>
where
    DefaultAllocator: Alloc<D>,
{
    if scene.members.is_some() {
        return None;
    }
    let (method, dtau, lambda0, solver, robust) =
        scene.methods.iter().find_map(|m| match m.step {
            StepSpec::Dth {
                dtau,
                lambda0,
                solver,
                robust,
                ..
            } => Some((m.label.clone(), dtau, lambda0, solver, robust)),
            StepSpec::Fixed { .. } => None,
        })?;
    let runner = DthRunner::new(dtau, lambda0, solver, true, 2).ok()?;
    let period = system.period(z0).filter(|p| p.is_finite() && *p > 0.0);
    let stop = match (scene.duration, period) {
        (Duration::Steps(n), Some(p)) => Stop::time(scene.t0 + p, n.min(PROBE_STEPS)),
        (Duration::Steps(n), None) => Stop::steps(n.min(PROBE_STEPS)),
        (Duration::Time(t), p) => Stop::time(scene.t0 + p.map_or(t, |p| p.min(t)), PROBE_STEPS),
        (Duration::Orbits(k), p) => Stop::time(scene.t0 + k.min(1.0) * p?, PROBE_STEPS),
    };
    let _ = system.run_dth(&runner, z0.clone(), scene.t0, stop, observer)?;
    Some((method, robust, dtau * lambda0))
}

/// Probes `Psi` along the orbit of `scene` on `system` from its initial state `z0` (see the
/// [module docs](self)): where it changes sign, where and the fix; `None` where it keeps its
/// sign over the probe, or the scene is not probed.
pub fn probe_psi<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    z0: &OVector<f64, D>,
) -> Option<PsiSignChange>
where
    DefaultAllocator: Alloc<D>,
{
    let mut watch = SignWatch {
        psi0: None,
        found: None,
    };
    let (method, robust, _) = probe_run(system, scene, z0, &mut watch)?;
    let (step, t, z, psi) = watch.found?;
    let names = component_names(scene.q.len(), z.len());
    Some(PsiSignChange {
        method,
        robust,
        psi0: watch.psi0?,
        t,
        state: names.into_iter().zip(z.iter().copied()).collect(),
        psi,
        step,
        regularization: regularization(system, &z),
    })
}

/// Counts a run's steps and keeps its last time: the last midpoint's, then the last vertex's
/// when the run finishes.
struct Clock {
    steps: usize,
    t: f64,
}

impl<D: Dim> Observer<D> for Clock
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, r: &StepRecord<D>) {
        self.steps = r.k;
        self.t = r.t;
    }

    fn on_finish(&mut self, _last_vertex: &OVector<f64, D>, last_vertex_time: f64) {
        self.t = last_vertex_time;
    }
}

/// The physical time a DTH step of `scene` on `system` covers on average, per unit of its
/// `dtau lambda0`, measured on the probe's run from `z0` (see the [module docs](self)):
/// DTH's step `dt = lambda dtau` follows the state (`lambda` grows where `|Psi|` falls, and a
/// regularized run's physical step is `|u|^2` times its fictitious one), so the step count of
/// a run for a time is this over a probed orbit, not `dtau lambda0` from the start. `None`
/// when the scene is not probed or its probe did not advance.
pub fn time_per_step<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    z0: &OVector<f64, D>,
) -> Option<f64>
where
    DefaultAllocator: Alloc<D>,
{
    let mut clock = Clock {
        steps: 0,
        t: scene.t0,
    };
    let (_, _, unit) = probe_run(system, scene, z0, &mut clock)?;
    let per_step = (clock.t - scene.t0) / clock.steps as f64;
    (clock.steps > 0 && per_step.is_finite() && per_step > 0.0).then_some(per_step / unit)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn change(coordinates: usize) -> PsiSignChange {
        PsiSignChange {
            method: "dth".to_string(),
            robust: false,
            psi0: 1.0,
            t: 0.35,
            state: (1..=coordinates).map(|i| (format!("q{i}"), 0.5)).collect(),
            psi: -1.0,
            step: 33,
            regularization: None,
        }
    }

    #[test]
    fn the_warning_names_a_small_state_whole_and_cuts_a_large_one() {
        let small = change(4).warning();
        assert!(small.contains("(q1 = 0.500000, q2 = 0.500000, q3 = 0.500000, q4 = 0.500000)"));
        // A 64-body cluster in space: 384 coordinates, of which the first eight are named.
        let large = change(384).warning();
        assert!(
            large.contains("q8 = 0.500000, ... 376 more coordinates)"),
            "{large}"
        );
        assert!(!large.contains("q9 ="), "{large}");
        assert!(large.len() < 900, "{} characters", large.len());
    }
}
