//! The systems a scene can name, and how a user adds their own.
//!
//! A [`Catalogue`] maps names to [`SystemEntry`]s: the system's size, parameters (with
//! defaults) and, for runnable entries, a function that builds the Hamiltonian from the scene's
//! parameters and runs the scene on it. Validation ([`crate::scene::parse`]) needs only the
//! metadata ([`SystemInfo`]); running needs the builder.
//!
//! A user's own system (a `hamiltonian!` type or a hand-written [`Hamiltonian`]) implements
//! [`SceneSystem`] and is registered with [`SystemEntry::runnable`] and
//! [`Catalogue::register`]; see `examples/custom_system.rs`.

use std::collections::BTreeMap;
use std::path::Path;

use dth::kepler::KeplerOrbit;
use dth::methods::DiscreteMechanics;
use dth::nalgebra::SVector;
use dth::systems::{
    DoublePendulum, ForcedOscillator, HarmonicOscillator, HenonHeiles, Kepler, Pendulum,
    TodaBoundary, TodaChain,
};
use dth::Hamiltonian;

use crate::error::Error;
use crate::method::{run_peer, MethodFailure, Observer, RunEnd, Stop};
use crate::run::{run_system, RunOptions, RunReport};
use crate::scene::Scene;

/// A named parameter of a catalogue system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Name used in the scene's `params` table.
    pub name: &'static str,
    /// Default, or `None` when the scene must give it.
    pub default: Option<f64>,
    /// One line of documentation.
    pub doc: &'static str,
}

/// What validation needs to know about a system.
#[derive(Debug, Clone, Copy)]
pub struct SystemInfo<'a> {
    /// Degrees of freedom `n` (length of `q` and `p`; time is not counted).
    pub n: usize,
    /// Parameters.
    pub params: &'a [ParamSpec],
    /// `true` for `H(t, q, p)` (run in the extended phase space).
    pub time_dependent: bool,
    /// `true` when the system can give an orbit period (durations in `orbits`).
    pub has_period: bool,
    /// `true` when the system has an exact solution (method `exact`).
    pub has_exact: bool,
    /// `true` for `H = T(p) + V(q)` (method `stormer_verlet`).
    pub separable: bool,
    /// `true` for a central force `|p|^2/(2m) + phi(|q|)` (method `discrete_mechanics`).
    pub central_force: bool,
}

/// What a scene needs from a system beyond [`Hamiltonian`]: its quadratic invariants (for the
/// `invariants` effect) and, optionally, an orbit period (for durations in `orbits`).
///
/// `D` is the phase-space dimension of the implementation: `2n`, or `2n + 2` when
/// `Hamiltonian::TIME_DEPENDENT` (the extended phase space `(q, t, p, p_t)`).
///
/// `Clone` because the DTH stepper owns its Hamiltonian (systems are small parameter structs).
pub trait SceneSystem<const D: usize>: Hamiltonian<D> + Clone {
    /// `true` when [`SceneSystem::period`] returns `Some` for bound initial states.
    const HAS_PERIOD: bool = false;

    /// Names of the quadratic invariants [`SceneSystem::invariants`] fills in (e.g. `["L"]`).
    fn invariant_names(&self) -> &'static [&'static str] {
        &[]
    }

    /// Writes the invariants at `z` into `out` (length `invariant_names().len()`).
    fn invariants(&self, z: &SVector<f64, D>, out: &mut [f64]) {
        let _ = (z, out);
    }

    /// `true` when [`SceneSystem::exact_solution`] is implemented.
    const HAS_EXACT: bool = false;

    /// The exact solution at time `t` after the state `z0`, or `None` when it cannot be
    /// computed (not implemented, or outside its domain).
    fn exact_solution(&self, z0: &SVector<f64, D>, t: f64) -> Option<SVector<f64, D>> {
        let _ = (z0, t);
        None
    }

    /// Orbit period from the initial state, if known.
    fn period(&self, z0: &SVector<f64, D>) -> Option<f64> {
        let _ = z0;
        None
    }

    /// `true` when [`SceneSystem::run_discrete_mechanics`] runs (central-force systems that
    /// implement `dth::systems::CentralForce`).
    const CENTRAL_FORCE: bool = false;

    /// Runs Greenspan's discrete mechanics (`dth::methods::DiscreteMechanics`, which needs
    /// `dth::systems::CentralForce`); `None` for systems that are not central forces. A
    /// central-force system implements it as
    /// `Some(run_peer(&mut DiscreteMechanics::new(), self, dt, z0, t0, stop, observer))`.
    fn run_discrete_mechanics<O: Observer<D>>(
        &self,
        dt: f64,
        z0: SVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd, MethodFailure>> {
        let _ = (dt, z0, t0, stop, observer);
        None
    }
}

impl SceneSystem<4> for Kepler {
    const HAS_PERIOD: bool = true;
    const HAS_EXACT: bool = true;

    const CENTRAL_FORCE: bool = true;

    /// Kepler's equation (`dth::kepler::KeplerOrbit`); `None` for orbits that are not
    /// elliptic.
    fn exact_solution(&self, z0: &SVector<f64, 4>, t: f64) -> Option<SVector<f64, 4>> {
        KeplerOrbit::new(self, z0).ok().map(|o| o.state_at(t))
    }

    fn run_discrete_mechanics<O: Observer<4>>(
        &self,
        dt: f64,
        z0: SVector<f64, 4>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd, MethodFailure>> {
        Some(run_peer(
            &mut DiscreteMechanics::new(),
            self,
            dt,
            z0,
            t0,
            stop,
            observer,
        ))
    }

    fn invariant_names(&self) -> &'static [&'static str] {
        &["angular_momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 4>, out: &mut [f64]) {
        out[0] = Kepler::angular_momentum(z);
    }

    /// `T = 2 pi sqrt(m a^3 / k)` with `a = -k / (2 H)`, for `H < 0`.
    fn period(&self, z0: &SVector<f64, 4>) -> Option<f64> {
        let h = self.value(z0);
        (h < 0.0).then(|| {
            let a = -self.k / (2.0 * h);
            2.0 * std::f64::consts::PI * (self.mass * a * a * a / self.k).sqrt()
        })
    }
}

impl SceneSystem<2> for HarmonicOscillator {
    const HAS_PERIOD: bool = true;

    fn period(&self, _z0: &SVector<f64, 2>) -> Option<f64> {
        Some(2.0 * std::f64::consts::PI * (self.mass / self.k).sqrt())
    }
}

impl SceneSystem<2> for Pendulum {}

impl SceneSystem<4> for HenonHeiles {}

impl SceneSystem<4> for DoublePendulum {}

/// The periodic Toda chain of the catalogue (4 particles): its total momentum is conserved
/// (a linear invariant, reported under `invariants`).
impl SceneSystem<8> for TodaChain<4> {
    fn invariant_names(&self) -> &'static [&'static str] {
        &["total_momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 8>, out: &mut [f64]) {
        out[0] = z[4] + z[5] + z[6] + z[7];
    }
}

impl SceneSystem<4> for ForcedOscillator {}

type RunFn = dyn Fn(&Scene, &Path, &RunOptions) -> Result<RunReport, Error> + Send + Sync + 'static;

/// One system of a [`Catalogue`].
pub struct SystemEntry {
    name: String,
    doc: String,
    n: usize,
    params: Vec<ParamSpec>,
    time_dependent: bool,
    has_period: bool,
    has_exact: bool,
    separable: bool,
    central_force: bool,
    run: Option<Box<RunFn>>,
    unavailable: &'static str,
}

impl std::fmt::Debug for SystemEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SystemEntry")
            .field("name", &self.name)
            .field("n", &self.n)
            .field("runnable", &self.run.is_some())
            .finish()
    }
}

/// Parameters as the scene gives them (catalogue defaults filled in).
pub type Params = BTreeMap<String, f64>;

fn param(params: &Params, name: &str) -> f64 {
    // Validation fills every declared parameter (default or given), so the lookup succeeds for
    // declared names; NaN makes a programming error visible instead of panicking.
    params.get(name).copied().unwrap_or(f64::NAN)
}

impl SystemEntry {
    /// A runnable entry: `build` makes the Hamiltonian from the scene's parameters (returning a
    /// message for an invalid combination), and scenes naming `name` run on it.
    ///
    /// `D` must be `2 n` (or `2 n + 2` for a time-dependent `S`); a mismatch is reported by
    /// [`Catalogue::register`].
    pub fn runnable<const D: usize, S, F>(
        name: &str,
        doc: &str,
        params: &[ParamSpec],
        build: F,
    ) -> Self
    where
        S: SceneSystem<D> + 'static,
        F: Fn(&Params) -> Result<S, String> + Send + Sync + 'static,
    {
        let n = if S::TIME_DEPENDENT {
            (D - 2) / 2
        } else {
            D / 2
        };
        let entry_name = name.to_string();
        SystemEntry {
            name: name.to_string(),
            doc: doc.to_string(),
            n,
            params: params.to_vec(),
            time_dependent: S::TIME_DEPENDENT,
            has_period: S::HAS_PERIOD,
            has_exact: S::HAS_EXACT,
            separable: S::SEPARABLE,
            central_force: S::CENTRAL_FORCE,
            run: Some(Box::new(move |scene, out, options| {
                let system = build(&scene.params).map_err(|reason| Error::NotAvailable {
                    what: "system",
                    name: entry_name.clone(),
                    reason,
                })?;
                run_system::<D, S>(&system, scene, out, options)
            })),
            unavailable: "",
        }
    }

    /// An entry scenes can name and `dth check` validates, but that cannot run in this build
    /// (`reason` says what it waits for).
    pub fn declared(
        name: &str,
        doc: &str,
        n: usize,
        params: &[ParamSpec],
        time_dependent: bool,
        has_period: bool,
        reason: &'static str,
    ) -> Self {
        SystemEntry {
            name: name.to_string(),
            doc: doc.to_string(),
            n,
            params: params.to_vec(),
            time_dependent,
            has_period,
            has_exact: false,
            separable: false,
            central_force: false,
            run: None,
            unavailable: reason,
        }
    }

    /// The name scenes use.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// One line of documentation.
    pub fn doc(&self) -> &str {
        &self.doc
    }

    /// Metadata for validation.
    pub fn info(&self) -> SystemInfo<'_> {
        SystemInfo {
            n: self.n,
            params: &self.params,
            time_dependent: self.time_dependent,
            has_period: self.has_period,
            has_exact: self.has_exact,
            separable: self.separable,
            central_force: self.central_force,
        }
    }

    /// `true` when scenes naming this system can run in this build.
    pub fn is_runnable(&self) -> bool {
        self.run.is_some()
    }
}

/// The systems scenes can name.
#[derive(Debug, Default)]
pub struct Catalogue {
    entries: Vec<SystemEntry>,
}

impl Catalogue {
    /// An empty catalogue (register your own systems).
    pub fn new() -> Self {
        Self::default()
    }

    /// The built-in systems.
    pub fn builtin() -> Self {
        let mut c = Catalogue::new();
        let entries = [
            SystemEntry::runnable::<4, Kepler, _>(
                "kepler",
                "planar Kepler H = |p|^2/(2 mass) - k/|q| (thesis: mass 0.5, k 1), n = 2",
                &[
                    ParamSpec { name: "mass", default: Some(0.5), doc: "mass m" },
                    ParamSpec { name: "k", default: Some(1.0), doc: "force constant k" },
                ],
                |p| {
                    let (mass, k) = (param(p, "mass"), param(p, "k"));
                    if mass > 0.0 && k > 0.0 {
                        Ok(Kepler { mass, k })
                    } else {
                        Err(format!("kepler needs mass > 0 and k > 0 (got mass = {mass}, k = {k})"))
                    }
                },
            ),
            SystemEntry::runnable::<2, HarmonicOscillator, _>(
                "harmonic_oscillator",
                "H = p^2/(2 mass) + k q^2/2, n = 1",
                &[
                    ParamSpec { name: "mass", default: Some(1.0), doc: "mass m" },
                    ParamSpec { name: "k", default: Some(1.0), doc: "spring constant k" },
                ],
                |p| {
                    let (mass, k) = (param(p, "mass"), param(p, "k"));
                    if mass > 0.0 && k > 0.0 {
                        Ok(HarmonicOscillator { mass, k })
                    } else {
                        Err(format!("harmonic_oscillator needs mass > 0 and k > 0 (got mass = {mass}, k = {k})"))
                    }
                },
            ),
            SystemEntry::runnable::<2, Pendulum, _>(
                "pendulum",
                "H = p^2/(2 m l^2) - m g l cos q, n = 1",
                &[
                    ParamSpec { name: "m", default: Some(1.0), doc: "mass" },
                    ParamSpec { name: "l", default: Some(1.0), doc: "length" },
                    ParamSpec { name: "g", default: Some(1.0), doc: "gravity" },
                ],
                |p| {
                    let (mass, length, gravity) = (param(p, "m"), param(p, "l"), param(p, "g"));
                    if mass > 0.0 && length > 0.0 && gravity > 0.0 {
                        Ok(Pendulum { mass, length, gravity })
                    } else {
                        Err(format!("pendulum needs m, l, g > 0 (got m = {mass}, l = {length}, g = {gravity})"))
                    }
                },
            ),
            SystemEntry::runnable::<4, HenonHeiles, _>(
                "henon_heiles",
                "H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2 q2 - q2^3/3, n = 2",
                &[],
                |_| Ok(HenonHeiles),
            ),
            SystemEntry::runnable::<4, DoublePendulum, _>(
                "double_pendulum",
                "planar double pendulum, masses m1, m2, lengths l1, l2, angles q1, q2 from the downward vertical, n = 2",
                &[
                    ParamSpec { name: "m1", default: Some(1.0), doc: "upper bob mass" },
                    ParamSpec { name: "m2", default: Some(1.0), doc: "lower bob mass" },
                    ParamSpec { name: "l1", default: Some(1.0), doc: "upper rod length" },
                    ParamSpec { name: "l2", default: Some(1.0), doc: "lower rod length" },
                    ParamSpec { name: "g", default: Some(1.0), doc: "gravity" },
                ],
                |p| {
                    let d = DoublePendulum {
                        m1: param(p, "m1"),
                        m2: param(p, "m2"),
                        l1: param(p, "l1"),
                        l2: param(p, "l2"),
                        g: param(p, "g"),
                    };
                    if [d.m1, d.m2, d.l1, d.l2, d.g].iter().all(|&x| x > 0.0) {
                        Ok(d)
                    } else {
                        Err(format!("double_pendulum needs m1, m2, l1, l2, g > 0 (got {d:?})"))
                    }
                },
            ),
            SystemEntry::runnable::<8, TodaChain<4>, _>(
                "toda_chain",
                "periodic Toda chain of 4 particles, H = sum p_i^2/2 + sum exp(q_i - q_{i+1}), n = 4",
                &[],
                |_| Ok(TodaChain::new(TodaBoundary::Periodic)),
            ),
            SystemEntry::runnable::<4, ForcedOscillator, _>(
                "forced_oscillator",
                "time-dependent H = p^2/2 + omega0^2 q^2/2 - f q cos(omega t), n = 1 (extended phase space)",
                &[
                    ParamSpec { name: "omega0", default: Some(1.0), doc: "natural frequency" },
                    ParamSpec { name: "f", default: Some(0.1), doc: "forcing amplitude" },
                    ParamSpec { name: "omega", default: Some(1.3), doc: "forcing frequency" },
                ],
                |p| {
                    let (omega0, force, omega) = (param(p, "omega0"), param(p, "f"), param(p, "omega"));
                    if omega0 > 0.0 && omega.is_finite() && force.is_finite() {
                        Ok(ForcedOscillator { omega0, force, omega })
                    } else {
                        Err(format!("forced_oscillator needs omega0 > 0 (got omega0 = {omega0})"))
                    }
                },
            ),
        ];
        for e in entries {
            // Built-in names are distinct and sizes consistent; a failure here is a bug in
            // this list, caught by the unit test `builtin_catalogue_registers`.
            let _ = c.register(e);
        }
        c
    }

    /// Adds a system. Errors on a duplicate name or a name scenes cannot spell.
    pub fn register(&mut self, entry: SystemEntry) -> Result<&mut Self, Error> {
        let bad = |reason: &str| Error::Registration {
            name: entry.name.clone(),
            reason: reason.to_string(),
        };
        if entry.name.is_empty()
            || !entry
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return Err(bad("a name is letters, digits, `_` or `-`"));
        }
        if self.entries.iter().any(|e| e.name == entry.name) {
            return Err(bad("a system with this name is already registered"));
        }
        if entry.n == 0 {
            return Err(bad("a system needs at least one degree of freedom"));
        }
        self.entries.push(entry);
        Ok(self)
    }

    /// Metadata of a system, for validation.
    pub fn info(&self, name: &str) -> Option<SystemInfo<'_>> {
        self.get(name).map(SystemEntry::info)
    }

    /// The entry named `name`.
    pub fn get(&self, name: &str) -> Option<&SystemEntry> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// All names, in registration order.
    pub fn names(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.name.as_str()).collect()
    }

    /// All entries.
    pub fn entries(&self) -> &[SystemEntry] {
        &self.entries
    }

    /// Runs a validated scene into `out` (see [`crate::run::run_system`] for the output
    /// folder's rules).
    pub fn run(&self, scene: &Scene, out: &Path, options: &RunOptions) -> Result<RunReport, Error> {
        let entry = self.get(&scene.system).ok_or_else(|| Error::NotAvailable {
            what: "system",
            name: scene.system.clone(),
            reason: "it is not in this catalogue".into(),
        })?;
        match &entry.run {
            Some(run) => run(scene, out, options),
            None => Err(Error::NotAvailable {
                what: "system",
                name: entry.name.clone(),
                reason: entry.unavailable.into(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_catalogue_registers() {
        let c = Catalogue::builtin();
        assert_eq!(
            c.names(),
            [
                "kepler",
                "harmonic_oscillator",
                "pendulum",
                "henon_heiles",
                "double_pendulum",
                "toda_chain",
                "forced_oscillator"
            ]
        );
        assert_eq!(c.info("kepler").map(|i| i.n), Some(2));
        assert!(c.entries().iter().all(SystemEntry::is_runnable));
        // What validation checks methods against.
        let info = |name| c.info(name).unwrap();
        assert!(info("kepler").central_force && info("kepler").has_exact);
        assert!(!info("double_pendulum").separable && info("henon_heiles").separable);
        assert!(info("forced_oscillator").time_dependent);
        assert_eq!(info("toda_chain").n, 4);
    }

    #[test]
    fn kepler_period_is_the_thesis_period() {
        // NOTES.md: period 3.7483 for q = (0.5, 0), p = (0, 1.2).
        let t = Kepler::thesis()
            .period(&SVector::<f64, 4>::new(0.5, 0.0, 0.0, 1.2))
            .unwrap_or(f64::NAN);
        assert!((t - 3.7483).abs() < 1e-4, "{t}");
    }
}
