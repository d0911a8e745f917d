//! [`Typed`]: a [`RuntimeHamiltonian`] as a `dth_core::Hamiltonian<D>`, so the DTH stepper
//! and every peer integrator run a Hamiltonian read from text.
//!
//! `dth_core::Hamiltonian<D>` fixes the dimension and the flags (`TIME_DEPENDENT`,
//! `SEPARABLE`, ...) at compile time; a runtime Hamiltonian knows them when its text is read.
//! Until the core is generic over nalgebra's dimensions (`docs/runtime_dimension.md`),
//! [`Typed`] bridges the two: the type names `D` and the flags, and [`Typed::new`] checks them
//! once against what the engine derived, with a typed error on a mismatch. It is a view: each
//! trait method is one call of the compiled function of the same name, into a stack buffer
//! (nalgebra's fixed-size storage), with no allocation and no evaluation code of its own.
//!
//! The trait's methods cannot fail. A non-finite output (outside the domain of `ln`, an
//! overflow) is returned as it is, so the stepper's own checks report it as a typed error
//! (`dth::Error::NonFinite { step, what }`, or the peers' `MethodNonFinite`), as for any other
//! implementation.

use std::sync::Arc;

use dth_core::{Derivatives, Hamiltonian};
use nalgebra::{SMatrix, SVector};

use crate::error::RuntimeError;
use crate::hamiltonian::RuntimeHamiltonian;
use crate::layout::Function;

/// A [`RuntimeHamiltonian`] checked to have dimension `D`, time dependence `TIME_DEPENDENT`
/// and, when `SEPARABLE` is set, the form `H = T(p) + V(q)`: it implements
/// `dth_core::Hamiltonian<D>` with these flags, `EXACT_DIVIDED_DIFFERENCES` (its discrete
/// gradients are the engine's exact divided differences, as the macro's), and no Hessian
/// pattern (the implicit methods use the dense Newton solver).
///
/// `SEPARABLE = false` is allowed for a separable Hamiltonian (the methods that need
/// separability then refuse it, as for any type that does not declare it); the other
/// mismatches are errors. A Hamiltonian whose Psi is identically zero is refused: the trait
/// declares it with a constant this view leaves `false`, and DTH cannot run on it.
///
/// Cloning shares the compiled code (an [`Arc`]): clones are cheap, and each thread of an
/// ensemble can own one.
///
/// ```
/// use dth_core::{nalgebra::Vector4, Hamiltonian};
/// use dth_runtime::{RuntimeError, RuntimeHamiltonian, Typed};
///
/// let text = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";
/// let kepler = Typed::<4>::new(RuntimeHamiltonian::new(text, &[("m", 0.5), ("k", 1.0)])?)?;
/// let z = Vector4::new(0.5, 0.0, 0.0, 1.2);
/// assert!((kepler.value(&z) - (1.44 - 2.0)).abs() < 1e-15);
///
/// // The dimension comes from the text: a mismatch is a typed error.
/// let wrong = Typed::<6>::new(RuntimeHamiltonian::new(text, &[("m", 0.5), ("k", 1.0)])?);
/// assert!(matches!(wrong, Err(RuntimeError::DimensionMismatch { expected: 6, found: 4 })));
/// # Ok::<(), RuntimeError>(())
/// ```
#[derive(Clone, Debug)]
pub struct Typed<const D: usize, const TIME_DEPENDENT: bool = false, const SEPARABLE: bool = false>
{
    runtime: Arc<RuntimeHamiltonian>,
}

impl<const D: usize, const TIME_DEPENDENT: bool, const SEPARABLE: bool>
    Typed<D, TIME_DEPENDENT, SEPARABLE>
{
    /// The view of `runtime` (owned, or shared through an [`Arc`]) after checking its
    /// dimension and flags against the type's.
    ///
    /// # Errors
    /// [`RuntimeError::DimensionMismatch`] when the text's `D` (`2n`, or `2n + 2` when it uses
    /// `t`) is not `D`; [`RuntimeError::FlagMismatch`] when `TIME_DEPENDENT` differs from the
    /// text's, or `SEPARABLE` is set for a Hamiltonian that is not separable, or Psi is
    /// identically zero.
    pub fn new(runtime: impl Into<Arc<RuntimeHamiltonian>>) -> Result<Self, RuntimeError> {
        let runtime = runtime.into();
        if runtime.dim() != D {
            return Err(RuntimeError::DimensionMismatch {
                expected: D,
                found: runtime.dim(),
            });
        }
        let mismatch = |flag, declared, derived| {
            Err(RuntimeError::FlagMismatch {
                flag,
                declared,
                derived,
            })
        };
        if TIME_DEPENDENT != runtime.time_dependent() {
            return mismatch("TIME_DEPENDENT", TIME_DEPENDENT, runtime.time_dependent());
        }
        if SEPARABLE && !runtime.separable() {
            return mismatch("SEPARABLE", true, false);
        }
        if runtime.psi_identically_zero() {
            return mismatch("PSI_IDENTICALLY_ZERO", false, true);
        }
        Ok(Typed { runtime })
    }

    /// The runtime Hamiltonian viewed: its expressions, parameters, backend, warnings.
    pub fn runtime(&self) -> &RuntimeHamiltonian {
        &self.runtime
    }

    /// Runs `f` at `z0`, `z1` into `out`. The lengths were checked against `D` when the view
    /// was built, so the only error left is a non-finite output, which is then in `out` for
    /// the caller's checks to report. Any other error (none is expected) fills `out` with NaN,
    /// which no caller takes for a value.
    fn run(&self, f: Function, z0: &SVector<f64, D>, z1: &SVector<f64, D>, out: &mut [f64]) {
        match self.runtime.run(f, z0.as_slice(), z1.as_slice(), out) {
            Ok(()) | Err(RuntimeError::NonFinite { .. }) => {}
            Err(_) => out.fill(f64::NAN),
        }
    }

    /// A one-value function.
    fn scalar(&self, f: Function, z0: &SVector<f64, D>, z1: &SVector<f64, D>) -> f64 {
        let mut out = [0.0];
        self.run(f, z0, z1, &mut out);
        out[0]
    }

    /// A `D`-vector function.
    fn vector(&self, f: Function, z0: &SVector<f64, D>, z1: &SVector<f64, D>) -> SVector<f64, D> {
        let mut out = SVector::<f64, D>::zeros();
        self.run(f, z0, z1, out.as_mut_slice());
        out
    }
}

impl<const D: usize, const TIME_DEPENDENT: bool, const SEPARABLE: bool> Hamiltonian<D>
    for Typed<D, TIME_DEPENDENT, SEPARABLE>
{
    const TIME_DEPENDENT: bool = TIME_DEPENDENT;
    const SEPARABLE: bool = SEPARABLE;
    const EXACT_DIVIDED_DIFFERENCES: bool = true;

    fn value(&self, z: &SVector<f64, D>) -> f64 {
        self.scalar(Function::Value, z, z)
    }

    fn gradient(&self, z: &SVector<f64, D>) -> SVector<f64, D> {
        self.vector(Function::Gradient, z, z)
    }

    /// Written row-major with both triangles, which for a symmetric matrix is the same array
    /// as column-major (nalgebra's storage): each entry and its mirror are one output.
    fn hessian(&self, z: &SVector<f64, D>) -> SMatrix<f64, D, D> {
        let mut out = SMatrix::<f64, D, D>::zeros();
        self.run(Function::Hessian, z, z, out.as_mut_slice());
        out
    }

    fn psi(&self, z: &SVector<f64, D>) -> f64 {
        self.scalar(Function::Psi, z, z)
    }

    /// One call of the fused program. Its buffer (`1 + D + D^2 + 1` values) lives on the
    /// stack as two `D x D` arrays, the smallest fixed-size array stable Rust can name that
    /// holds it for every even `D >= 2` (`2 D^2 >= D^2 + D + 2`); its pieces are then copied
    /// into [`Derivatives`]. That is twice the stack `Derivatives<D>` itself takes: fine for
    /// the dense solver's sizes, megabytes for `D` in the hundreds (the core's `Dim`
    /// generalisation writes into the caller's storage instead).
    fn derivatives(&self, z: &SVector<f64, D>) -> Derivatives<D> {
        let mut buffer = [[[0.0f64; D]; D]; 2];
        let flat = buffer.as_flattened_mut().as_flattened_mut();
        let out = &mut flat[..Function::Derivatives.len(D)];
        self.run(Function::Derivatives, z, z, out);
        Derivatives {
            value: out[0],
            gradient: SVector::from_column_slice(&out[1..1 + D]),
            hessian: SMatrix::from_column_slice(&out[1 + D..1 + D + D * D]),
            psi: out[1 + D + D * D],
        }
    }

    fn discrete_gradient(&self, z0: &SVector<f64, D>, z1: &SVector<f64, D>) -> SVector<f64, D> {
        self.vector(Function::DiscreteGradient, z0, z1)
    }

    /// Recomputes `gbar` inside, as the macro's types do (`gbar` is not read).
    fn discrete_gradient_defect(
        &self,
        z0: &SVector<f64, D>,
        z1: &SVector<f64, D>,
        _gbar: &SVector<f64, D>,
    ) -> SVector<f64, D> {
        self.vector(Function::DiscreteGradientDefect, z0, z1)
    }

    fn energy_difference(&self, z0: &SVector<f64, D>, z1: &SVector<f64, D>) -> f64 {
        self.scalar(Function::EnergyDifference, z0, z1)
    }
}
