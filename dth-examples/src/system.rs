//! What a scene needs from a system beyond `dth::Hamiltonian` ([`SceneSystem`]), and the
//! wrappers that change how method `dth` runs on it: [`WithoutDth`] runs a system whose `Psi`
//! is identically zero with every method but DTH, [`Regularizable`] runs DTH on a
//! regularized `K` of the system.

use std::sync::Arc;

use dth::methods::RunEnd;
use dth::nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};
use dth::observer::Observer;
use dth::Alloc;
use dth::{ConstFlags, Flags, Hamiltonian};

use crate::driver::{DthRunner, MethodFailure, Stop};
use crate::regularized::Regularized;

/// What a scene needs from a system beyond [`Hamiltonian`]: its quadratic invariants (for the
/// `invariants` effect) and, optionally, an orbit period (for durations in `orbits`).
///
/// `D` is the phase-space dimension of the implementation, `2n`, or `2n + 2` when
/// `Flags::time_dependent` (the extended phase space `(q, t, p, p_t)`), as nalgebra's
/// dimension type: `Const<N>` for a type whose size is known when compiled (the catalogue's
/// `hamiltonian!` systems), `Dyn` for one known at run time (a scene's Hamiltonian given as
/// text, [`crate::runtime_system::TextSystem`]).
///
/// `Clone` because the DTH stepper owns its Hamiltonian (systems are small parameter structs).
pub trait SceneSystem<D: Dim>: Hamiltonian<D> + Clone
where
    DefaultAllocator: Alloc<D>,
{
    /// `true` when [`SceneSystem::period`] returns `Some` for bound initial states.
    const HAS_PERIOD: bool = false;

    /// Names of the quadratic invariants [`SceneSystem::invariants`] fills in (e.g. `["L"]`).
    fn invariant_names(&self) -> &'static [&'static str] {
        &[]
    }

    /// Writes the invariants at `z` into `out` (length `invariant_names().len()`).
    fn invariants(&self, z: &OVector<f64, D>, out: &mut [f64]) {
        let _ = (z, out);
    }

    /// `true` when [`SceneSystem::exact_solution`] is implemented.
    const HAS_EXACT: bool = false;

    /// The exact solution at time `t` after the state `z0`, or `None` when it cannot be
    /// computed (not implemented, or outside its domain).
    fn exact_solution(&self, z0: &OVector<f64, D>, t: f64) -> Option<OVector<f64, D>> {
        let _ = (z0, t);
        None
    }

    /// Orbit period from the initial state, if known.
    fn period(&self, z0: &OVector<f64, D>) -> Option<f64> {
        let _ = z0;
        None
    }

    /// `true` for a chain of `n` unit masses with fixed ends `q_0 = q_{n+1} = 0` whose
    /// potential is, to second order, the unit-spring chain `sum_{i=0}^{n} (q_{i+1} - q_i)^2/2`
    /// (FPUT, the Toda chain between walls): the `normal_modes` effect decomposes its state
    /// into that chain's linear normal modes ([`crate::normal_modes`]).
    const FIXED_END_CHAIN: bool = false;

    /// `true` when [`SceneSystem::run_discrete_mechanics`] runs (central-force systems that
    /// implement `dth::systems::CentralForce`).
    const CENTRAL_FORCE: bool = false;

    /// Runs Greenspan's discrete mechanics (`dth::methods::DiscreteMechanics`, which needs
    /// `dth::systems::CentralForce`); `None` for systems that are not central forces. A
    /// central-force system implements it as
    /// `Some(run_peer(DiscreteMechanics::new(), self, dt, z0, t0, stop, observer))`.
    fn run_discrete_mechanics<O: Observer<D>>(
        &self,
        dt: f64,
        z0: OVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd<D>, MethodFailure>> {
        let _ = (dt, z0, t0, stop, observer);
        None
    }

    /// Runs the DTH stepper (`runner`) on this system. Keep the default (the wrapper
    /// [`Regularizable`] overrides it to run a regularized scene on its `K`): it is the
    /// only place the scene runner instantiates the stepper for `Self`, so a system whose `Psi` is
    /// identically zero (rejected by the stepper with `Error::PsiIdenticallyZero`) runs through [`WithoutDth`]
    /// instead, which returns `None` here ([`SystemEntry::runnable_without_dth`](crate::catalogue::SystemEntry::runnable_without_dth)
    /// does that).
    fn run_dth<O: Observer<D>>(
        &self,
        runner: &DthRunner,
        z0: OVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd<D>, MethodFailure>> {
        Some(runner.run(self, (z0, None), t0, stop, observer))
    }
}

/// The [`Hamiltonian`] and [`SceneSystem`] impls of a wrapper `$wrapper<S>` around a system in
/// its field `.0`: every item forwards to `S` but [`SceneSystem::run_dth`], which is `$run_dth`
/// (the one thing a wrapper changes).
macro_rules! forward_to_system {
    ($wrapper:ident, $($run_dth:tt)*) => {
        impl<S: ConstFlags> ConstFlags for $wrapper<S> {
            const FLAGS: Flags = S::FLAGS;
        }

        impl<D: Dim, S: Hamiltonian<D>> Hamiltonian<D> for $wrapper<S>
        where
            DefaultAllocator: Alloc<D>,
        {
            #[inline]
            fn dim(&self) -> D {
                self.0.dim()
            }
            #[inline]
            fn flags(&self) -> Flags {
                self.0.flags()
            }
            #[inline]
            fn hessian_pattern(&self) -> Option<&[(usize, usize)]> {
                self.0.hessian_pattern()
            }
            #[inline]
            fn value(&self, z: &OVector<f64, D>) -> f64 {
                self.0.value(z)
            }
            #[inline]
            fn gradient_into(&self, z: &OVector<f64, D>, out: &mut OVector<f64, D>) {
                self.0.gradient_into(z, out)
            }
            #[inline]
            fn hessian_into(&self, z: &OVector<f64, D>, out: &mut OMatrix<f64, D, D>) {
                self.0.hessian_into(z, out)
            }
            #[inline]
            fn hessian_nonzeros(&self, z: &OVector<f64, D>, values: &mut [f64]) {
                self.0.hessian_nonzeros(z, values)
            }
            #[inline]
            fn psi(&self, z: &OVector<f64, D>) -> f64 {
                self.0.psi(z)
            }
            #[inline]
            fn derivatives_into(&self, z: &OVector<f64, D>, out: &mut dth::Derivatives<D>) {
                self.0.derivatives_into(z, out)
            }
            #[inline]
            fn discrete_gradient_into(
                &self,
                z0: &OVector<f64, D>,
                z1: &OVector<f64, D>,
                out: &mut OVector<f64, D>,
            ) {
                self.0.discrete_gradient_into(z0, z1, out)
            }
            #[inline]
            fn discrete_gradient_defect_into(
                &self,
                z0: &OVector<f64, D>,
                z1: &OVector<f64, D>,
                gbar: &OVector<f64, D>,
                out: &mut OVector<f64, D>,
            ) {
                self.0.discrete_gradient_defect_into(z0, z1, gbar, out)
            }
            #[inline]
            fn energy_difference(&self, z0: &OVector<f64, D>, z1: &OVector<f64, D>) -> f64 {
                self.0.energy_difference(z0, z1)
            }
            #[inline]
            fn gradient_double_double_into(
                &self,
                z: (&OVector<f64, D>, &OVector<f64, D>),
                out: (&mut OVector<f64, D>, &mut OVector<f64, D>),
            ) -> bool {
                self.0.gradient_double_double_into(z, out)
            }
        }

        impl<D: Dim, S: SceneSystem<D>> SceneSystem<D> for $wrapper<S>
        where
            DefaultAllocator: Alloc<D>,
        {
            const HAS_PERIOD: bool = S::HAS_PERIOD;
            const HAS_EXACT: bool = S::HAS_EXACT;
            const CENTRAL_FORCE: bool = S::CENTRAL_FORCE;
            const FIXED_END_CHAIN: bool = S::FIXED_END_CHAIN;

            fn invariant_names(&self) -> &'static [&'static str] {
                self.0.invariant_names()
            }

            fn invariants(&self, z: &OVector<f64, D>, out: &mut [f64]) {
                self.0.invariants(z, out);
            }

            fn exact_solution(&self, z0: &OVector<f64, D>, t: f64) -> Option<OVector<f64, D>> {
                self.0.exact_solution(z0, t)
            }

            fn period(&self, z0: &OVector<f64, D>) -> Option<f64> {
                self.0.period(z0)
            }

            fn run_discrete_mechanics<O: Observer<D>>(
                &self,
                dt: f64,
                z0: OVector<f64, D>,
                t0: f64,
                stop: Stop,
                observer: &mut O,
            ) -> Option<Result<RunEnd<D>, MethodFailure>> {
                self.0.run_discrete_mechanics(dt, z0, t0, stop, observer)
            }

            $($run_dth)*
        }
    };
}

/// A system run without DTH: every [`Hamiltonian`] and [`SceneSystem`] item forwards to `S`,
/// except [`SceneSystem::run_dth`], which returns `None` without instantiating the DTH stepper
/// for `S`. This is how systems whose `Psi` is identically zero run scenes (the stepper rejects
/// them with `Error::PsiIdenticallyZero`); `catalogue::SystemEntry::runnable_without_dth` registers them with
/// it.
///
/// ```
/// use dth_examples::catalogue::Catalogue;
/// use dth_examples::simulate::{compute, RunOptions};
/// use dth_examples::system::WithoutDth;
/// use dth_examples::systems::FreeParticle;
/// let scene = dth_examples::check_scene(
///     "[system]\nname = \"free_particle\"\n[initial]\nq = [0.0, 0.0]\np = [1.0, 0.5]\n\
///      [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 10\n\
///      [[effect]]\nkind = \"final_state\"\n",
///     "free.toml",
///     &Catalogue::builtin(),
/// )?;
/// let system = WithoutDth(FreeParticle { m: 2.0 });
/// let results = compute(&system, &scene, &RunOptions::default().with_progress(false))?;
/// // q(t) = q0 + p t / m, exactly enough for the midpoint rule: t = 1, q1 = 0.5.
/// let z = &results[0].summary.final_state.as_ref().unwrap().z;
/// assert!((z[0] - 0.5).abs() < 1e-14);
/// # Ok::<(), dth_examples::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WithoutDth<S>(pub S);

forward_to_system!(
    WithoutDth,
    /// `None`: DTH is not offered (see [`WithoutDth`]).
    fn run_dth<O: Observer<D>>(
        &self,
        runner: &DthRunner,
        z0: OVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd<D>, MethodFailure>> {
        let _ = (runner, z0, t0, stop, observer);
        None
    }
);

/// A system whose scene may ask for `[system] regularize`: with `Some` regularized `K`
/// (built from the system's text, `catalogue::SystemEntry::with_text`), method `dth` runs on
/// `K` and every record is mapped back to the physical state ([`Regularized::run`]); every
/// other item is the system's own, so its invariants, exact solution, period and peer methods
/// stay what they are. With `None` it is the system itself. The catalogue's systems and a
/// scene's text (`crate::runtime_system::SceneText`) run through it.
#[derive(Debug, Clone)]
pub struct Regularizable<S>(pub S, pub Option<Arc<Regularized>>);

forward_to_system!(
    Regularizable,
    /// DTH on the regularized `K` when there is one, else the system's own.
    fn run_dth<O: Observer<D>>(
        &self,
        runner: &DthRunner,
        z0: OVector<f64, D>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd<D>, MethodFailure>> {
        match &self.1 {
            Some(k) => Some(k.run(runner, z0, t0, stop, observer)),
            None => self.0.run_dth(runner, z0, t0, stop, observer),
        }
    }
);
