//! Scenes whose `[system]` gives the Hamiltonian as text (`hamiltonian = "..."`): the
//! expression validation read ([`TextHamiltonian`]) built into a
//! [`dth::runtime::RuntimeHamiltonian`] (the engine's derivatives compiled to machine code
//! when the scene loads), a `Hamiltonian<Dyn>` whose dimension is the expression's. As
//! [`TextSystem`] it is a [`SceneSystem<Dyn>`] and runs through the same pipeline as a
//! catalogue system (`catalogue::Catalogue::run`): every method and effect validation
//! admits.
//!
//! A text of small dimension runs at a fixed size: [`dispatch`] hands the pipeline a
//! [`Fixed<N>`] (`Hamiltonian<Const<N>>`, the same compiled code) for `D = 4`, so the stepper and the peers use nalgebra's fixed-size linear algebra
//! (stack storage, unrolled loops) as for a catalogue system; any other `D` runs as
//! [`TextSystem`] (`Dyn`). Measured on Kepler (`docs/performance.md`, "Run-time
//! compiled text against the macro"): 300,000 DTH and midpoint steps took 1.3-1.4x the
//! built-in system's CPU time at the fixed size, 2.05x at `Dyn` (3.3x before the `Dyn` DTH
//! step stopped allocating). Each fixed size is one more
//! instance of the whole pipeline to compile (measured: about a quarter more build time of
//! this crate per size), so there is one: another size is one more arm in [`dispatch`].

use std::collections::BTreeMap;
use std::sync::Arc;

use dth::nalgebra::{Const, DMatrix, DVector, DefaultAllocator, Dim, Dyn};
use dth::runtime::{Fixed, RuntimeHamiltonian};
use dth::{Alloc, Derivatives, Flags, Hamiltonian};

use crate::error::Error;
use crate::regularized::Regularized;
use crate::scene::{Scene, TextHamiltonian};
use crate::system::{Regularizable, SceneSystem};

/// A scene's Hamiltonian given as text, compiled: cloning shares the compiled code (the DTH
/// stepper owns its Hamiltonian; each thread of an ensemble holds a clone). It has its energy
/// and nothing else: no invariants, period or exact solution (validation refuses the effects
/// and methods that need them).
///
/// A scene runs it as [`SceneText`], which for `[system] regularize` runs method `dth` on the
/// regularized `K` ([`Regularizable`]; the peers run on `H`).
#[derive(Debug, Clone)]
pub struct TextSystem(pub Arc<RuntimeHamiltonian>);

/// What a scene whose Hamiltonian is given as text runs: its [`TextSystem`], with the
/// regularized `K` method `dth` runs on when the scene asks for `[system] regularize`.
pub type SceneText = Regularizable<TextSystem>;

impl TextSystem {
    /// The scene's Hamiltonian given as text, compiled with the scene's parameters.
    ///
    /// # Errors
    /// [`Error::NotAvailable`] when the scene names a catalogue system, or (for a scene built
    /// by hand, since validation reports these at their place in the file) when the
    /// expression or a parameter is refused.
    ///
    /// ```
    /// use dth_examples::{catalogue::Catalogue, check_scene, runtime_system::TextSystem};
    /// let scene = check_scene(
    ///     "[system]\nhamiltonian = \"p1^2/2 + k*q1^2/2\"\nparams = { k = 4.0 }\n\
    ///      [initial]\nq = [1.0]\np = [0.0]\n[[method]]\nkind = \"midpoint\"\ndt = 0.1\n\
    ///      [duration]\nsteps = 10\n",
    ///     "spring.toml",
    ///     &Catalogue::builtin(),
    /// )?;
    /// let h = TextSystem::build(&scene)?;
    /// assert_eq!(h.0 .0.value_slice(&[1.0, 0.0]).unwrap(), 2.0);
    /// # Ok::<(), dth_examples::Error>(())
    /// ```
    pub fn build(scene: &Scene) -> Result<SceneText, Error> {
        compile(scene, text(scene)?, &scene.params)
    }
}

impl SceneText {
    /// The same Hamiltonian with the parameters `params` (an ensemble member's): this one
    /// when they are the ones it was built with, else compiled anew.
    ///
    /// # Errors
    /// As [`TextSystem::build`].
    pub fn with_params(
        &self,
        scene: &Scene,
        params: &BTreeMap<String, f64>,
    ) -> Result<Self, Error> {
        let h = &self.0 .0;
        let same = h
            .parameters()
            .all(|(name, value)| params.get(name) == Some(&value));
        if same && params.len() == h.parameters().count() {
            return Ok(self.clone());
        }
        compile(scene, text(scene)?, params)
    }
}

/// The scene's text `h` compiled with `params`, and its regularized `K` when the scene asks.
fn compile(
    scene: &Scene,
    h: &TextHamiltonian,
    params: &BTreeMap<String, f64>,
) -> Result<SceneText, Error> {
    let params: Vec<(&str, f64)> = params.iter().map(|(k, &v)| (k.as_str(), v)).collect();
    let refused = |reason: String| Error::NotAvailable {
        what: "system",
        name: scene.system.clone(),
        reason,
    };
    let runtime =
        RuntimeHamiltonian::new(&h.source, &params).map_err(|e| refused(e.to_string()))?;
    let regularized = match &scene.regularize {
        Some(r) => Some(Arc::new(
            Regularized::compile(r, &params).map_err(|e| refused(e.to_string()))?,
        )),
        None => None,
    };
    Ok(Regularizable(TextSystem(Arc::new(runtime)), regularized))
}

/// The scene's [`TextHamiltonian`].
fn text(scene: &Scene) -> Result<&TextHamiltonian, Error> {
    scene
        .hamiltonian
        .as_ref()
        .ok_or_else(|| Error::NotAvailable {
            what: "system",
            name: scene.system.clone(),
            reason: "the scene names a catalogue system, not a Hamiltonian given as text".into(),
        })
}

/// Every method is the compiled one of [`RuntimeHamiltonian`]'s `Hamiltonian<Dyn>`.
impl Hamiltonian<Dyn> for TextSystem {
    #[inline]
    fn dim(&self) -> Dyn {
        Hamiltonian::dim(self.0.as_ref())
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
    fn value(&self, z: &DVector<f64>) -> f64 {
        Hamiltonian::value(self.0.as_ref(), z)
    }
    #[inline]
    fn gradient_into(&self, z: &DVector<f64>, out: &mut DVector<f64>) {
        self.0.gradient_into(z, out)
    }
    #[inline]
    fn hessian_into(&self, z: &DVector<f64>, out: &mut DMatrix<f64>) {
        self.0.hessian_into(z, out)
    }
    #[inline]
    fn hessian_nonzeros(&self, z: &DVector<f64>, values: &mut [f64]) {
        self.0.hessian_nonzeros(z, values)
    }
    #[inline]
    fn psi(&self, z: &DVector<f64>) -> f64 {
        Hamiltonian::psi(self.0.as_ref(), z)
    }
    #[inline]
    fn derivatives_into(&self, z: &DVector<f64>, out: &mut Derivatives<Dyn>) {
        self.0.derivatives_into(z, out)
    }
    #[inline]
    fn discrete_gradient_into(&self, z0: &DVector<f64>, z1: &DVector<f64>, out: &mut DVector<f64>) {
        self.0.discrete_gradient_into(z0, z1, out)
    }
    #[inline]
    fn discrete_gradient_defect_into(
        &self,
        z0: &DVector<f64>,
        z1: &DVector<f64>,
        gbar: &DVector<f64>,
        out: &mut DVector<f64>,
    ) {
        self.0.discrete_gradient_defect_into(z0, z1, gbar, out)
    }
    #[inline]
    fn energy_difference(&self, z0: &DVector<f64>, z1: &DVector<f64>) -> f64 {
        Hamiltonian::energy_difference(self.0.as_ref(), z0, z1)
    }
    #[inline]
    fn gradient_double_double_into(
        &self,
        z: (&DVector<f64>, &DVector<f64>),
        out: (&mut DVector<f64>, &mut DVector<f64>),
    ) -> bool {
        Hamiltonian::gradient_double_double_into(self.0.as_ref(), z, out)
    }
}

/// Energy only: the defaults (no invariants, period, exact solution, central force).
impl SceneSystem<Dyn> for TextSystem {}

/// Energy only, as [`TextSystem`]: the fixed-size view of the same compiled code.
impl<const N: usize> SceneSystem<Const<N>> for Fixed<N> {}

/// Builds a scene's system from parameters (the scene's, or an ensemble member's).
pub type MakeSystem<'a, S> = dyn Fn(&BTreeMap<String, f64>) -> Result<S, Error> + Sync + 'a;

/// Work to do on a scene's text Hamiltonian at whichever dimension type [`dispatch`] picks:
/// `make` builds the system from parameters (the scene's, or an ensemble member's).
pub trait TextJob {
    /// What the work returns.
    type Output;

    /// Does the work on the systems `make` builds.
    fn run<D: Dim, S: SceneSystem<D>>(self, make: &MakeSystem<'_, S>) -> Self::Output
    where
        DefaultAllocator: Alloc<D>;
}

/// Compiles the scene's text and runs `job` on it: at `Const<D>` ([`Fixed`]) when its
/// dimension `D` is 4 (two degrees of freedom, or one in the extended phase space of a
/// time-dependent `H`) and not regularized, else at `Dyn` ([`TextSystem`]). The one place a
/// text's dimension picks a type.
///
/// # Errors
/// As [`TextSystem::build`].
pub fn dispatch<J: TextJob>(scene: &Scene, job: J) -> Result<J::Output, Error> {
    let system = TextSystem::build(scene)?;
    fn fixed<const N: usize>(
        system: &SceneText,
        scene: &Scene,
        params: &BTreeMap<String, f64>,
    ) -> Result<Fixed<N>, Error> {
        let text = system.with_params(scene, params)?;
        Fixed::new(text.0 .0).map_err(|e| Error::NotAvailable {
            what: "system",
            name: scene.system.clone(),
            reason: e.to_string(),
        })
    }
    // A regularized scene's DTH runs on K at `Dyn` whatever the size of H.
    Ok(match (system.0 .0.dimension(), &scene.regularize) {
        (4, None) => job.run::<Const<4>, Fixed<4>>(&|p| fixed(&system, scene, p)),
        _ => job.run::<Dyn, SceneText>(&|p| system.with_params(scene, p)),
    })
}
