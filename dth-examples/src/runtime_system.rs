//! Scenes whose `[system]` gives the Hamiltonian as text (`hamiltonian = "..."`): the
//! expression validation read ([`TextHamiltonian`]) built into a
//! [`dth::runtime::RuntimeHamiltonian`] (the engine's derivatives compiled to machine code
//! when the scene loads), a `Hamiltonian<Dyn>` whose dimension is the expression's. As
//! [`TextSystem`] it is a [`SceneSystem<Dyn>`] and runs through the same pipeline as a
//! catalogue system (`catalogue::Catalogue::run`): every method and effect validation
//! admits.

use std::collections::BTreeMap;
use std::sync::Arc;

use dth::nalgebra::{DMatrix, DVector, Dyn};
use dth::runtime::RuntimeHamiltonian;
use dth::{Derivatives, Flags, Hamiltonian};

use crate::error::Error;
use crate::scene::{Scene, TextHamiltonian};
use crate::system::SceneSystem;

/// A scene's Hamiltonian given as text, compiled: cloning shares the compiled code (the DTH
/// stepper owns its Hamiltonian; each thread of an ensemble holds a clone). It has its energy
/// and nothing else: no invariants, period or exact solution (validation refuses the effects
/// and methods that need them).
#[derive(Debug, Clone)]
pub struct TextSystem(pub Arc<RuntimeHamiltonian>);

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
    /// assert_eq!(h.0.value(&[1.0, 0.0]).unwrap(), 2.0);
    /// # Ok::<(), dth_examples::Error>(())
    /// ```
    pub fn build(scene: &Scene) -> Result<Self, Error> {
        Self::compile(scene, text(scene)?, &scene.params)
    }

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
        let same = self
            .0
            .parameters()
            .all(|(name, value)| params.get(name) == Some(&value));
        if same && params.len() == self.0.parameters().count() {
            return Ok(self.clone());
        }
        Self::compile(scene, text(scene)?, params)
    }

    fn compile(
        scene: &Scene,
        h: &TextHamiltonian,
        params: &BTreeMap<String, f64>,
    ) -> Result<Self, Error> {
        let params: Vec<(&str, f64)> = params.iter().map(|(k, &v)| (k.as_str(), v)).collect();
        let runtime =
            RuntimeHamiltonian::new(&h.source, &params).map_err(|e| Error::NotAvailable {
                what: "system",
                name: scene.system.clone(),
                reason: e.to_string(),
            })?;
        Ok(TextSystem(Arc::new(runtime)))
    }
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
}

/// Energy only: the defaults (no invariants, period, exact solution, central force).
impl SceneSystem<Dyn> for TextSystem {}
