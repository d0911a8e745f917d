//! The systems a scene can name, and how a user adds their own.
//!
//! A [`Catalogue`] maps names to [`SystemEntry`]s: the system's size, parameters (with
//! defaults) and a function that builds the Hamiltonian from the scene's
//! parameters and runs the scene on it. Validation ([`crate::scene::parse`]) needs only the
//! metadata ([`SystemInfo`], through the [`SystemLookup`] the catalogue implements); running
//! needs the builder.
//!
//! The built-in systems are the `hamiltonian!` types of [`crate::systems`]. A user's own
//! system (a `hamiltonian!` type or a hand-written `Hamiltonian`) implements [`SceneSystem`]
//! and is registered the same way, with [`SystemEntry::runnable`] and [`Catalogue::register`];
//! see `examples/custom_system.rs`.
//!
//! A scene whose Hamiltonian is given as text names no entry: [`Catalogue::run`] builds it
//! ([`crate::runtime_system::dispatch`]: dimension `Const<D>` for small `D`, else `Dyn`) and
//! runs it through the same path.
//!
//! A system whose `Psi` is identically zero (`Flags::psi_identically_zero`, e.g. a free
//! particle) cannot run DTH: the stepper's constructor rejects it with
//! `Error::PsiIdenticallyZero` (thesis Section 3.4). Register it with [`SystemEntry::runnable_without_dth`]: every peer method
//! runs, and a scene naming `dth` for it is rejected by validation.

use dth::nalgebra::{Const, DefaultAllocator, Dim, SVector};
use dth::{Alloc, ConstFlags};

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use crate::budget::{self, Measure, MemoryEstimate};
use crate::ensemble;
use crate::error::Error;
use crate::pipeline::{run_system, RunError};
use crate::probe::{probe_psi, PsiSignChange};
use crate::regularized::Regularized;
use crate::report::RunReport;
use crate::runtime_system::{self, MakeSystem, TextJob};
use crate::scene::{ParamSpec, Regularization, Scene, SystemInfo, SystemLookup};
use crate::simulate::{initial_state, preflight, stop_for, RunOptions};
use crate::step_time;
use crate::system::{Regularizable, SceneSystem, WithoutDth};
use crate::systems::{
    CalogeroMoser8, DoublePendulum, ForcedOscillator, FputAlpha32, FputBeta32, FreeParticle,
    Gravity3d4, HarmonicOscillator, HenonHeiles, Kepler, NBody2d3, NBody3d3, Pendulum, TodaChain10,
    TodaChain4, TodaFixedEnds32,
};

type RunFn =
    dyn Fn(&Scene, &Path, &RunOptions) -> Result<RunReport, RunError> + Send + Sync + 'static;
type EstimateFn =
    dyn Fn(&Scene, &RunOptions) -> Result<MemoryEstimate, Error> + Send + Sync + 'static;
type ProbeFn = dyn Fn(&Scene) -> Result<Option<PsiSignChange>, Error> + Send + Sync + 'static;
type StepTimeFn = dyn Fn(&Scene) -> Result<Vec<f64>, Error> + Send + Sync + 'static;
type EvaluateFn = dyn Fn(&Params, &[f64]) -> Result<(f64, Vec<f64>), Error> + Send + Sync + 'static;

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
    fixed_end_chain: bool,
    dth: bool,
    psi_identically_zero: bool,
    text: Option<String>,
    sizable: bool,
    run: Box<RunFn>,
    estimate: Box<EstimateFn>,
    probe: Box<ProbeFn>,
    step_time: Box<StepTimeFn>,
    evaluate: Box<EvaluateFn>,
}

impl std::fmt::Debug for SystemEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SystemEntry")
            .field("name", &self.name)
            .field("n", &self.n)
            .finish_non_exhaustive()
    }
}

/// Parameters as the scene gives them (catalogue defaults filled in).
pub type Params = BTreeMap<String, f64>;

/// The parameter `name` of a built-in `system`. Validation fills in every declared parameter
/// (given or default), so a missing one means the entry's list and its builder disagree.
fn param(system: &str, params: &Params, name: &str) -> Result<f64, String> {
    params.get(name).copied().ok_or_else(|| {
        format!("{system} has no parameter `{name}` (the catalogue entry does not declare it)")
    })
}

/// The parameters `names` of a built-in `system` ([`param`] for each). Their rules (e.g.
/// `> 0`) are declared in the entry's [`ParamSpec`]s and enforced before a builder runs, by
/// validation and again by [`Catalogue::run`]; builders do not re-check them.
fn params<const N: usize>(
    system: &str,
    params: &Params,
    names: [&str; N],
) -> Result<[f64; N], String> {
    let mut values = [0.0; N];
    for (v, n) in values.iter_mut().zip(names) {
        *v = param(system, params, n)?;
    }
    Ok(values)
}

/// Runs a validated scene on the systems `make` builds from parameters (the scene's, or an
/// ensemble member's): an ensemble scene's members on every core after its memory estimate, a
/// single run on rank 0 (under `mpirun`). The one path of every system, catalogue or text.
fn run_built<D: Dim, S: SceneSystem<D>>(
    make: &(dyn Fn(&Params) -> Result<S, Error> + Sync),
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
) -> Result<RunReport, RunError>
where
    DefaultAllocator: Alloc<D>,
{
    if scene.members.is_some() {
        estimate_built::<D, S>(make, scene, options)?;
        return ensemble::run::<D, S>(make, scene, out, options);
    }
    if ensemble::schedule::is_worker_rank() {
        // Under `mpirun`, a single run is rank 0's alone.
        return Ok(ensemble::idle_report(scene));
    }
    let system = make(&scene.params)?;
    run_system::<D, S>(&system, scene, out, options)
}

/// The memory estimate of a validated scene on the system `make` builds from its parameters
/// (`dth check`; also checked before an ensemble scene runs, a single run checks it in
/// `simulate::compute`).
fn estimate_built<D: Dim, S: SceneSystem<D>>(
    make: &(dyn Fn(&Params) -> Result<S, Error> + Sync),
    scene: &Scene,
    options: &RunOptions,
) -> Result<MemoryEstimate, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let system = make(&scene.params)?;
    let z0 = initial_state(&system, scene)?;
    let stop = stop_for(&system, scene, &z0, options)?;
    let estimate = budget::check(
        &system,
        scene,
        (&z0, stop),
        options.memory_limit(),
        Measure::Always,
    )?;
    if scene.members.is_none() {
        // What a single run refuses before it starts, `dth check` reports too (an ensemble's
        // members each have their own state: a member that cannot run is a row of its table).
        preflight(&system, scene, &z0, stop)?;
    }
    Ok(estimate)
}

/// [`probe_psi`] of a validated scene on the system `make` builds from its parameters.
fn probe_built<D: Dim, S: SceneSystem<D>>(
    make: &(dyn Fn(&Params) -> Result<S, Error> + Sync),
    scene: &Scene,
) -> Result<Option<PsiSignChange>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let system = make(&scene.params)?;
    // A start the scene cannot run from is the estimate's error (`dth check` asks it first).
    Ok(initial_state(&system, scene)
        .ok()
        .and_then(|z0| probe_psi(&system, scene, &z0)))
}

/// [`probe_built`] on a scene's text Hamiltonian.
struct ProbeText<'a> {
    scene: &'a Scene,
}

impl TextJob for ProbeText<'_> {
    type Output = Result<Option<PsiSignChange>, Error>;

    fn run<D: Dim, S: SceneSystem<D>>(self, make: &MakeSystem<'_, S>) -> Self::Output
    where
        DefaultAllocator: Alloc<D>,
    {
        probe_built::<D, S>(make, self.scene)
    }
}

/// [`step_time::seconds_per_step`] of a validated scene on the system `make` builds from its
/// parameters.
fn step_time_built<D: Dim, S: SceneSystem<D>>(
    make: &(dyn Fn(&Params) -> Result<S, Error> + Sync),
    scene: &Scene,
) -> Result<Vec<f64>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    step_time::seconds_per_step(&make(&scene.params)?, scene)
}

/// [`step_time_built`] on a scene's text Hamiltonian.
struct StepTimeText<'a> {
    scene: &'a Scene,
}

impl TextJob for StepTimeText<'_> {
    type Output = Result<Vec<f64>, Error>;

    fn run<D: Dim, S: SceneSystem<D>>(self, make: &MakeSystem<'_, S>) -> Self::Output
    where
        DefaultAllocator: Alloc<D>,
    {
        step_time_built::<D, S>(make, self.scene)
    }
}

/// [`run_built`] on a scene's text Hamiltonian.
struct RunText<'a> {
    scene: &'a Scene,
    out: &'a Path,
    options: &'a RunOptions,
}

impl TextJob for RunText<'_> {
    type Output = Result<RunReport, RunError>;

    fn run<D: Dim, S: SceneSystem<D>>(self, make: &MakeSystem<'_, S>) -> Self::Output
    where
        DefaultAllocator: Alloc<D>,
    {
        run_built::<D, S>(make, self.scene, self.out, self.options)
    }
}

/// [`estimate_built`] on a scene's text Hamiltonian.
struct EstimateText<'a> {
    scene: &'a Scene,
    options: &'a RunOptions,
}

impl TextJob for EstimateText<'_> {
    type Output = Result<MemoryEstimate, Error>;

    fn run<D: Dim, S: SceneSystem<D>>(self, make: &MakeSystem<'_, S>) -> Self::Output
    where
        DefaultAllocator: Alloc<D>,
    {
        estimate_built::<D, S>(make, self.scene, self.options)
    }
}

impl SystemEntry {
    /// A runnable entry: `build` makes the Hamiltonian from the scene's parameters (returning a
    /// message for an invalid combination), and scenes naming `name` run on it with every
    /// method that applies, DTH included. Each parameter's [`ParamSpec::rule`] is checked
    /// before `build` runs (by validation, at the scene's value), so `build` need not repeat it.
    ///
    /// `n` is `D / 2` (or `(D - 2) / 2` for a time-dependent `S`); a scene whose `q` and `p`
    /// do not have that length is rejected by validation. A system whose `Psi` is identically zero does not compile here
    /// (DTH is undetermined for it): use [`SystemEntry::runnable_without_dth`].
    ///
    /// ```compile_fail
    /// use dth_examples::catalogue::SystemEntry;
    /// use dth_examples::systems::FreeParticle;
    /// // error: this system's Psi is identically zero, so DTH cannot run on it ...
    /// let _ = SystemEntry::runnable::<4, FreeParticle, _>("particle", "", &[], |_| {
    ///     Ok(FreeParticle { m: 1.0 })
    /// });
    /// ```
    pub fn runnable<const D: usize, S, F>(
        name: &str,
        doc: &str,
        params: &[ParamSpec],
        build: F,
    ) -> Self
    where
        S: SceneSystem<Const<D>> + ConstFlags + 'static,
        F: Fn(&Params) -> Result<S, String> + Send + Sync + 'static,
    {
        const {
            assert!(
                !S::FLAGS.psi_identically_zero,
                "this system's Psi is identically zero, so DTH cannot run on it (thesis Section \
                 3.4): register it with SystemEntry::runnable_without_dth"
            )
        };
        Self::with_runner::<D, S, F>(name, doc, params, true, build)
    }

    /// A runnable entry that offers every peer method but not DTH: for systems whose `Psi` is
    /// identically zero (`Flags::psi_identically_zero`, e.g. a free particle), which the
    /// DTH stepper rejects with `Error::PsiIdenticallyZero`. The system runs as [`WithoutDth`]`<S>`, so the
    /// stepper is never instantiated for it; validation rejects a scene naming method `dth`
    /// for it (file, line and column, and why).
    ///
    /// ```
    /// use dth_examples::catalogue::{Catalogue, SystemEntry};
    /// use dth_examples::scene::ParamSpec;
    /// use dth_examples::systems::FreeParticle;
    /// let mut c = Catalogue::new();
    /// c.register(SystemEntry::runnable_without_dth::<4, FreeParticle, _>(
    ///     "particle",
    ///     "H = |p|^2/(2 m)",
    ///     &[ParamSpec::new("m", Some(1.0), "mass").positive()],
    ///     |p| Ok(FreeParticle { m: p["m"] }),
    /// ))?;
    /// let text = "[system]\nname = \"particle\"\n[initial]\nq = [0.0, 0.0]\np = [1.0, 0.0]\n\
    ///             [[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\nsteps = 10\n";
    /// let err = dth_examples::check_scene(text, "p.toml", &c).unwrap_err().to_string();
    /// assert!(err.contains("p.toml:7:8: method `dth` cannot integrate system `particle`"), "{err}");
    /// # Ok::<(), dth_examples::Error>(())
    /// ```
    pub fn runnable_without_dth<const D: usize, S, F>(
        name: &str,
        doc: &str,
        params: &[ParamSpec],
        build: F,
    ) -> Self
    where
        S: SceneSystem<Const<D>> + ConstFlags + 'static,
        F: Fn(&Params) -> Result<S, String> + Send + Sync + 'static,
    {
        let mut entry =
            Self::with_runner::<D, WithoutDth<S>, _>(name, doc, params, false, move |p| {
                build(p).map(WithoutDth)
            });
        entry.psi_identically_zero = S::FLAGS.psi_identically_zero;
        entry
    }

    fn with_runner<const D: usize, S, F>(
        name: &str,
        doc: &str,
        params: &[ParamSpec],
        dth: bool,
        build: F,
    ) -> Self
    where
        S: SceneSystem<Const<D>> + ConstFlags + 'static,
        F: Fn(&Params) -> Result<S, String> + Send + Sync + 'static,
    {
        let n = if S::FLAGS.time_dependent {
            (D - 2) / 2
        } else {
            D / 2
        };
        let build = std::sync::Arc::new(build);
        let specs = std::sync::Arc::new(params.to_vec());
        // The one place parameters become a system: a scene built by hand skipped validation,
        // so hold it to the same parameter rules, and a builder never sees a value its entry
        // declares invalid. A scene's regularization (validated on the entry's text) is
        // compiled here with these parameters (an ensemble member's own).
        let make = move |name: &str, params: &Params, regularize: Option<&Regularization>| {
            let unavailable = |reason| Error::NotAvailable {
                what: "system",
                name: name.to_string(),
                reason,
            };
            for p in specs.iter() {
                if let Some(&v) = params.get(p.name) {
                    p.check(name, v).map_err(unavailable)?;
                }
            }
            let system = build(params).map_err(unavailable)?;
            let k = match regularize {
                None => None,
                Some(r) => {
                    let named: Vec<(&str, f64)> =
                        params.iter().map(|(k, &v)| (k.as_str(), v)).collect();
                    let k =
                        Regularized::compile(r, &named).map_err(|e| unavailable(e.to_string()))?;
                    Some(Arc::new(k))
                }
            };
            Ok(Regularizable(system, k))
        };
        let (run_name, estimate_name, probe_name, step_time_name, evaluate_name) = (
            name.to_string(),
            name.to_string(),
            name.to_string(),
            name.to_string(),
            name.to_string(),
        );
        let (make_too, make_probe, make_step_time, make_evaluate) =
            (make.clone(), make.clone(), make.clone(), make.clone());
        SystemEntry {
            name: name.to_string(),
            doc: doc.to_string(),
            n,
            params: params.to_vec(),
            time_dependent: S::FLAGS.time_dependent,
            has_period: S::HAS_PERIOD,
            has_exact: S::HAS_EXACT,
            separable: S::FLAGS.separable,
            central_force: S::CENTRAL_FORCE,
            fixed_end_chain: S::FIXED_END_CHAIN,
            dth,
            psi_identically_zero: S::FLAGS.psi_identically_zero,
            text: None,
            sizable: false,
            run: Box::new(move |scene, out, options| {
                let make = |p: &Params| make(&run_name, p, scene.regularize.as_ref());
                run_built::<Const<D>, Regularizable<S>>(&make, scene, out, options)
            }),
            estimate: Box::new(move |scene, options| {
                let make = |p: &Params| make_too(&estimate_name, p, scene.regularize.as_ref());
                estimate_built::<Const<D>, Regularizable<S>>(&make, scene, options)
            }),
            probe: Box::new(move |scene| {
                let make = |p: &Params| make_probe(&probe_name, p, scene.regularize.as_ref());
                probe_built::<Const<D>, Regularizable<S>>(&make, scene)
            }),
            step_time: Box::new(move |scene| {
                let make =
                    |p: &Params| make_step_time(&step_time_name, p, scene.regularize.as_ref());
                step_time_built::<Const<D>, Regularizable<S>>(&make, scene)
            }),
            evaluate: Box::new(move |params, z| {
                let Regularizable(system, _) = make_evaluate(&evaluate_name, params, None)?;
                if z.len() != D {
                    return Err(Error::NotAvailable {
                        what: "state for system",
                        name: evaluate_name.clone(),
                        reason: format!("it has length {}, expected {D}", z.len()),
                    });
                }
                let z = SVector::<f64, D>::from_column_slice(z);
                Ok((system.value(&z), system.gradient(&z).as_slice().to_vec()))
            }),
        }
    }

    /// `H` and its gradient at the state `z` (of length `D`, the extended state for a
    /// time-dependent system) of the system built from `params` (every parameter given: the
    /// defaults are in [`SystemEntry::info`]), as the compiled type computes them: what a
    /// twin of the system (the Python package's `dth.systems`, a text) is checked against.
    ///
    /// # Errors
    /// [`Error::NotAvailable`] for parameters the entry refuses or a state of another length.
    ///
    /// ```
    /// use dth_examples::catalogue::Catalogue;
    /// let c = Catalogue::builtin();
    /// let params = [("m".to_string(), 0.5), ("k".to_string(), 1.0)].into();
    /// let (h, g) = c.get("kepler").unwrap().evaluate(&params, &[0.5, 0.0, 0.0, 1.2])?;
    /// assert!((h + 0.56).abs() < 1e-15 && g.len() == 4);
    /// # Ok::<(), dth_examples::Error>(())
    /// ```
    pub fn evaluate(&self, params: &Params, z: &[f64]) -> Result<(f64, Vec<f64>), Error> {
        (self.evaluate)(params, z)
    }

    /// The entry with its text: the Hamiltonian in the grammar of `hamiltonian!`, its sizes
    /// declared after `where` (`where N = 32, q[0] = q[N+1] = 0`) and the entry's parameters
    /// by name. At the declared sizes the text is the compiled system (a unit test compares
    /// `H` and its gradient to the bit); a scene that sets other sizes (`[system] sizes = { N
    /// = 4096 }`) runs the text at those sizes, compiled at run time.
    pub fn with_sizes(mut self, text: &str) -> Self {
        self.text = Some(text.to_string());
        self.sizable = true;
        self
    }

    /// The entry with its text, the Hamiltonian in the grammar of `hamiltonian!` with the
    /// entry's parameters by name, for a system of fixed size: a scene that regularizes it
    /// (`[system] regularize = "levi-civita" | "ks"`) runs DTH on this text's regularized `K`
    /// and everything else on the compiled system. The text must be the compiled system (a
    /// unit test compares `H` and its gradient to the bit, as for [`SystemEntry::with_sizes`]).
    pub fn with_text(mut self, text: &str) -> Self {
        self.text = Some(text.to_string());
        self
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
            fixed_end_chain: self.fixed_end_chain,
            dth: self.dth,
            psi_identically_zero: self.psi_identically_zero,
            text: self.text.as_deref(),
            sizable: self.sizable,
        }
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

    /// The built-in systems: the `hamiltonian!` types of [`crate::systems`], under the names
    /// and with the parameters `dth list` shows.
    pub fn builtin() -> Self {
        let mut c = Catalogue::new();
        let entries = [
            SystemEntry::runnable::<4, Kepler, _>(
                "kepler",
                "planar Kepler H = (p1^2 + p2^2)/(2 m) - k (q1^2 + q2^2)^(-1/2) (thesis: m = 1/2, k = 1), n = 2",
                &[
                    ParamSpec::new("m", Some(0.5), "mass").positive(),
                    ParamSpec::new("k", Some(1.0), "force constant").positive(),
                ],
                |p| Ok(Kepler { m: param("kepler", p, "m")?, k: param("kepler", p, "k")? }),
            )
            .with_text("(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)"),
            SystemEntry::runnable::<2, HarmonicOscillator, _>(
                "harmonic_oscillator",
                "H = p1^2/(2 m) + k q1^2/2, n = 1",
                &[
                    ParamSpec::new("m", Some(1.0), "mass").positive(),
                    ParamSpec::new("k", Some(1.0), "spring constant").positive(),
                ],
                |p| {
                    let [m, k] = params("harmonic_oscillator", p, ["m", "k"])?;
                    Ok(HarmonicOscillator { m, k })
                },
            ),
            SystemEntry::runnable::<2, Pendulum, _>(
                "pendulum",
                "H = p1^2/(2 m l^2) - m g l cos(q1), n = 1",
                &[
                    ParamSpec::new("m", Some(1.0), "mass").positive(),
                    ParamSpec::new("l", Some(1.0), "length").positive(),
                    ParamSpec::new("g", Some(1.0), "gravity").positive(),
                ],
                |p| {
                    let [m, l, g] = params("pendulum", p, ["m", "l", "g"])?;
                    Ok(Pendulum { m, l, g })
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
                "planar double pendulum in canonical coordinates: masses m1, m2, lengths l1, l2, angles q1, q2 from the downward vertical, n = 2",
                &[
                    ParamSpec::new("m1", Some(1.0), "upper bob mass").positive(),
                    ParamSpec::new("m2", Some(1.0), "lower bob mass").positive(),
                    ParamSpec::new("l1", Some(1.0), "upper rod length").positive(),
                    ParamSpec::new("l2", Some(1.0), "lower rod length").positive(),
                    ParamSpec::new("g", Some(1.0), "gravity").positive(),
                ],
                |p| {
                    let [m1, m2, l1, l2, g] = params("double_pendulum", p, ["m1", "m2", "l1", "l2", "g"])?;
                    Ok(DoublePendulum { m1, m2, l1, l2, g })
                },
            ),
            SystemEntry::runnable::<8, TodaChain4, _>(
                "toda_chain",
                "periodic Toda chain of 4 particles, H = sum p_i^2/2 + sum exp(q_i - q_{i+1}), q5 = q1, n = 4",
                &[],
                |_| Ok(TodaChain4),
            ),
            SystemEntry::runnable::<20, TodaChain10, _>(
                "toda_chain_10",
                "periodic Toda chain of 10 particles, H = sum p_i^2/2 + sum exp(q_i - q_{i+1}), q11 = q1, n = 10",
                &[],
                |_| Ok(TodaChain10),
            ),
            SystemEntry::runnable::<64, FputAlpha32, _>(
                "fput_alpha",
                "FPUT-alpha chain of 32 unit masses, fixed ends q0 = q33 = 0: H = sum p_i^2/2 + sum_{i=0}^{32} [d_i^2/2 + alpha d_i^3/3], d_i = q_{i+1} - q_i, n = 32",
                // Any coupling: the sign only mirrors the chain (q -> -q).
                &[ParamSpec::new("alpha", Some(0.25), "cubic coupling (FPUT 1955: 1/4)")],
                |p| Ok(FputAlpha32 { alpha: param("fput_alpha", p, "alpha")? }),
            )
            .with_sizes("sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3) where N = 32, q[0] = q[N+1] = 0"),
            SystemEntry::runnable::<64, FputBeta32, _>(
                "fput_beta",
                "FPUT-beta chain of 32 unit masses, fixed ends q0 = q33 = 0: H = sum p_i^2/2 + sum_{i=0}^{32} [d_i^2/2 + beta d_i^4/4], d_i = q_{i+1} - q_i, n = 32",
                // beta < 0 is studied too (its potential is bounded below only locally).
                &[ParamSpec::new("beta", Some(1.0), "quartic coupling")],
                |p| Ok(FputBeta32 { beta: param("fput_beta", p, "beta")? }),
            )
            .with_sizes("sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + beta*(q[i+1] - q[i])^4/4) where N = 32, q[0] = q[N+1] = 0"),
            SystemEntry::runnable::<64, TodaFixedEnds32, _>(
                "toda_fixed_ends",
                "Toda chain of 32 unit masses between walls q0 = q33 = 0: H = sum p_i^2/2 + sum_{i=0}^{32} exp(q_i - q_{i+1}), n = 32",
                &[],
                |_| Ok(TodaFixedEnds32),
            )
            .with_sizes("sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, exp(q[i] - q[i+1])) where N = 32, q[0] = q[N+1] = 0"),
            SystemEntry::runnable::<12, NBody2d3, _>(
                "nbody_2d",
                "three gravitating bodies in the plane, all pairs: H = sum |p_i|^2/(2 m_i) - g sum_{i<j} m_i m_j/|q_i - q_j|, body i at (q_{2i-1}, q_{2i}), n = 6",
                &[
                    ParamSpec::new("m1", Some(1.0), "mass of body 1").positive(),
                    ParamSpec::new("m2", Some(1.0), "mass of body 2").positive(),
                    ParamSpec::new("m3", Some(1.0), "mass of body 3").positive(),
                    ParamSpec::new("g", Some(1.0), "gravitational constant").positive(),
                ],
                |p| {
                    let [m1, m2, m3, g] = params("nbody_2d", p, ["m1", "m2", "m3", "g"])?;
                    Ok(NBody2d3 { m1, m2, m3, g })
                },
            ),
            SystemEntry::runnable::<18, NBody3d3, _>(
                "nbody_3d",
                "three gravitating bodies in space, all pairs: H = sum |p_i|^2/(2 m_i) - g sum_{i<j} m_i m_j/|q_i - q_j|, body i at (q_{3i-2}, q_{3i-1}, q_{3i}), n = 9",
                &[
                    ParamSpec::new("m1", Some(1.0), "mass of body 1").positive(),
                    ParamSpec::new("m2", Some(1.0), "mass of body 2").positive(),
                    ParamSpec::new("m3", Some(1.0), "mass of body 3").positive(),
                    ParamSpec::new("g", Some(1.0), "gravitational constant").positive(),
                ],
                |p| {
                    let [m1, m2, m3, g] = params("nbody_3d", p, ["m1", "m2", "m3", "g"])?;
                    Ok(NBody3d3 { m1, m2, m3, g })
                },
            ),
            SystemEntry::runnable::<24, Gravity3d4, _>(
                "gravity_3d",
                "N gravitating point masses m in space, all pairs (N = 4; any N by a scene's sizes): H = sum |p_i|^2/(2 m) - g m^2 sum_{i<j} 1/|q_i - q_j|, body i at (q_{3i-2}, q_{3i-1}, q_{3i}), n = 3N",
                &[
                    ParamSpec::new("m", Some(1.0), "mass of each body").positive(),
                    ParamSpec::new("g", Some(1.0), "gravitational constant").positive(),
                ],
                |p| {
                    let [m, g] = params("gravity_3d", p, ["m", "g"])?;
                    Ok(Gravity3d4 { m, g })
                },
            )
            .with_sizes("sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/(2*m)) - g*m^2*sum(1 <= i < j <= N, ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 + (q[3*i] - q[3*j])^2)^(-1/2)) where N = 4"),
            SystemEntry::runnable::<16, CalogeroMoser8, _>(
                "calogero_moser",
                "Calogero-Moser system of N unit masses on a line (N = 8; any N by a scene's sizes): H = sum p_i^2/2 + g^2 sum_{i<j} (q_i - q_j)^-2, n = N",
                &[ParamSpec::new("g", Some(0.5), "coupling")],
                |p| Ok(CalogeroMoser8 { g: param("calogero_moser", p, "g")? }),
            )
            .with_sizes("sum(i = 1..N, p[i]^2/2) + g^2*sum(1 <= i < j <= N, (q[i] - q[j])^(-2)) where N = 8"),
            SystemEntry::runnable::<4, ForcedOscillator, _>(
                "forced_oscillator",
                "time-dependent H = p1^2/2 + omega0^2 q1^2/2 - f q1 cos(omega t), n = 1 (extended phase space)",
                &[
                    ParamSpec::new("omega0", Some(1.0), "natural frequency").positive(),
                    // Any forcing is allowed.
                    ParamSpec::new("f", Some(0.1), "forcing amplitude"),
                    ParamSpec::new("omega", Some(1.3), "forcing frequency"),
                ],
                |p| {
                    let [omega0, f, omega] = params("forced_oscillator", p, ["omega0", "f", "omega"])?;
                    Ok(ForcedOscillator { omega0, f, omega })
                },
            ),
            SystemEntry::runnable_without_dth::<4, FreeParticle, _>(
                "free_particle",
                "free particle H = (p1^2 + p2^2)/(2 m), n = 2; every method but dth (Psi is identically zero, thesis Section 3.4)",
                &[ParamSpec::new("m", Some(1.0), "mass").positive()],
                |p| Ok(FreeParticle { m: param("free_particle", p, "m")? }),
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

    /// The entry named `name`.
    pub fn get(&self, name: &str) -> Option<&SystemEntry> {
        self.entries.iter().find(|e| e.name == name)
    }

    /// All entries.
    pub fn entries(&self) -> &[SystemEntry] {
        &self.entries
    }

    /// Runs a validated scene into `out` (see [`crate::pipeline::run_system`] for the output
    /// folder's rules); a scene whose Hamiltonian is given as text runs through
    /// [`crate::runtime_system::dispatch`] (at a fixed size or `Dyn`). A run that lost a method
    /// is [`RunError::MethodsFailed`], with the report of what was written.
    pub fn run(
        &self,
        scene: &Scene,
        out: &Path,
        options: &RunOptions,
    ) -> Result<RunReport, RunError> {
        if scene.hamiltonian.is_some() {
            return runtime_system::dispatch(
                scene,
                RunText {
                    scene,
                    out,
                    options,
                },
            )?;
        }
        (self.entry(scene)?.run)(scene, out, options)
    }

    /// The entry of the system `scene` names.
    fn entry(&self, scene: &Scene) -> Result<&SystemEntry, Error> {
        self.get(&scene.system).ok_or_else(|| Error::NotAvailable {
            what: "system",
            name: scene.system.clone(),
            reason: "it is not in this catalogue".into(),
        })
    }

    /// What a validated scene's effects would keep in memory ([`crate::budget`]), refused
    /// ([`Error::MemoryLimit`]) above `options`' limit, as a run would refuse it: so that
    /// `dth check` and `dth run` agree.
    pub fn estimate(&self, scene: &Scene, options: &RunOptions) -> Result<MemoryEstimate, Error> {
        if scene.hamiltonian.is_some() {
            return runtime_system::dispatch(scene, EstimateText { scene, options })?;
        }
        (self.entry(scene)?.estimate)(scene, options)
    }
}

impl Catalogue {
    /// Where `Psi` changes sign along a validated scene's orbit, if it does
    /// ([`crate::probe`]): `dth check` warns with it. `Ok(None)` for a scene whose probe saw
    /// no sign change or that is not probed.
    ///
    /// # Errors
    /// Only what building the scene's system fails with (as [`Catalogue::estimate`]); the
    /// probe itself never fails a check.
    pub fn probe_psi(&self, scene: &Scene) -> Result<Option<PsiSignChange>, Error> {
        if scene.hamiltonian.is_some() {
            return runtime_system::dispatch(scene, ProbeText { scene })?;
        }
        (self.entry(scene)?.probe)(scene)
    }

    /// Each method's seconds per step on a validated scene, measured on a few steps from its
    /// initial state ([`step_time::seconds_per_step`]): `dth check`'s time estimate.
    ///
    /// # Errors
    /// What a run of the scene refuses before it starts.
    pub fn seconds_per_step(&self, scene: &Scene) -> Result<Vec<f64>, Error> {
        if scene.hamiltonian.is_some() {
            return runtime_system::dispatch(scene, StepTimeText { scene })?;
        }
        (self.entry(scene)?.step_time)(scene)
    }
}

impl SystemLookup for Catalogue {
    fn info(&self, name: &str) -> Option<SystemInfo<'_>> {
        self.get(name).map(SystemEntry::info)
    }

    /// In registration order.
    fn names(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.name.as_str()).collect()
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
                "toda_chain_10",
                "fput_alpha",
                "fput_beta",
                "toda_fixed_ends",
                "nbody_2d",
                "nbody_3d",
                "gravity_3d",
                "calogero_moser",
                "forced_oscillator",
                "free_particle"
            ]
        );
        assert_eq!(c.info("kepler").map(|i| i.n), Some(2));
        // What validation checks methods against, from the generated types' flags.
        let info = |name| c.info(name).unwrap();
        assert!(info("kepler").central_force && info("kepler").has_exact);
        assert!(!info("double_pendulum").separable && info("henon_heiles").separable);
        assert!(info("forced_oscillator").time_dependent);
        assert_eq!(info("toda_chain").n, 4);
        assert_eq!(info("toda_chain_10").n, 10);
        assert_eq!(
            (info("fput_alpha").n, info("nbody_2d").n, info("nbody_3d").n),
            (32, 6, 9)
        );
        // The normal modes are offered on the chains with fixed ends only.
        for e in c.entries() {
            let chain = ["fput_alpha", "fput_beta", "toda_fixed_ends"].contains(&e.name());
            assert_eq!(e.info().fixed_end_chain, chain, "{}", e.name());
        }
        // DTH everywhere but on the free particle, whose Psi is identically zero.
        for e in c.entries() {
            let i = e.info();
            assert_eq!(i.dth, e.name() != "free_particle", "{}", e.name());
            assert_eq!(i.psi_identically_zero, !i.dth, "{}", e.name());
        }
    }

    /// An entry's text (at its declared size, for a sizable one) is the compiled system: `H`
    /// and its gradient to the bit at states of every scale (the run-time programs perform the
    /// macro's operations in its order).
    #[test]
    fn an_entrys_text_is_its_compiled_system() {
        let c = Catalogue::builtin();
        let mut texts = Vec::new();
        for e in c.entries() {
            let Some(text) = e.info().text else {
                continue;
            };
            texts.push((e.name(), e.info().sizable));
            let params: Params = e
                .params
                .iter()
                .filter_map(|p| p.default.map(|v| (p.name.to_string(), v)))
                .collect();
            let named: Vec<(&str, f64)> = params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
            let rt = dth::runtime::RuntimeHamiltonian::new(text, &named).unwrap();
            let d = 2 * e.n;
            assert_eq!(rt.dimension(), d, "{}", e.name());
            for scale in [1e-3, 0.3, 2.0] {
                let z: Vec<f64> = (0..d).map(|k| scale * ((k as f64 * 0.7).sin())).collect();
                let (h, g) = e.evaluate(&params, &z).unwrap();
                let mut g_text = vec![0.0; d];
                rt.gradient_slice(&z, &mut g_text).unwrap();
                assert_eq!(rt.value_slice(&z).unwrap(), h, "{} at {scale}", e.name());
                assert_eq!(g_text, g, "{} at {scale}", e.name());
            }
        }
        assert_eq!(
            texts,
            [
                ("kepler", false),
                ("fput_alpha", true),
                ("fput_beta", true),
                ("toda_fixed_ends", true),
                ("gravity_3d", true),
                ("calogero_moser", true)
            ]
        );
    }

    const KEPLER: &str = "[system]\nname = \"kepler\"\nparams = { m = -1.0 }\n[initial]\n\
                          q = [0.5, 0.0]\np = [0.0, 1.2]\n[[method]]\nkind = \"midpoint\"\n\
                          dt = 0.1\n[duration]\nsteps = 1\n";

    #[test]
    fn parameter_rules_are_checked_by_validation_at_the_value() {
        let c = Catalogue::builtin();
        let err = crate::check_scene(KEPLER, "bad.toml", &c).unwrap_err();
        assert!(matches!(err, Error::Scene(_)), "{err:?}");
        assert_eq!(err.exit_code(), 2);
        assert!(
            err.to_string().contains(
                "bad.toml:3:16: parameter `m` (mass) of system `kepler` = -1: expected a positive number (> 0)"
            ),
            "{err}"
        );
    }

    #[test]
    fn a_hand_built_scene_is_held_to_the_same_parameter_rules() {
        let c = Catalogue::builtin();
        let good = KEPLER.replace("m = -1.0", "m = 1.0");
        let mut scene = crate::check_scene(&good, "good.toml", &c).unwrap();
        scene.params.insert("m".into(), -1.0);
        let dir = std::env::temp_dir().join("dth-catalogue-hand-built-parameters");
        let err = c
            .run(&scene, &dir, &RunOptions::default().with_progress(false))
            .unwrap_err();
        assert!(
            err.to_string().contains(
                "parameter `m` (mass) of system `kepler` = -1: expected a positive number (> 0)"
            ),
            "{err}"
        );
        assert!(!dir.exists());
    }

    #[test]
    fn a_default_that_breaks_its_rule_is_reported_at_the_system_name() {
        let mut c = Catalogue::new();
        c.register(SystemEntry::runnable::<2, HarmonicOscillator, _>(
            "spring",
            "",
            &[
                ParamSpec::new("m", Some(0.0), "mass").positive(),
                ParamSpec::new("k", Some(1.0), "spring constant"),
            ],
            |p| {
                let [m, k] = params("spring", p, ["m", "k"])?;
                Ok(HarmonicOscillator { m, k })
            },
        ))
        .unwrap();
        let text = "[system]\nname = \"spring\"\n[initial]\nq = [1.0]\np = [0.0]\n\
                    [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 1\n";
        let err = crate::check_scene(text, "s.toml", &c)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("s.toml:2:8: parameter `m` (mass) of system `spring` = 0: expected a positive number (> 0) (the default: give `m` in `params`)"),
            "{err}"
        );
        // Given in the scene, the default is not used.
        let ok = text.replace(
            "name = \"spring\"",
            "name = \"spring\"\nparams = { m = 2.0 }",
        );
        assert!(crate::check_scene(&ok, "s.toml", &c).is_ok());
    }
}
