//! The runtime Hamiltonian as a `dth_core::Hamiltonian`: [`RuntimeHamiltonian`] implements
//! `Hamiltonian<Dyn>` (the dimension and the flags are the text's, known when it is read), so
//! the DTH stepper and every peer integrator run a Hamiltonian read from text without
//! recompiling; [`Typed`] is the same Hamiltonian checked for a fixed `Const<D>`, for Rust code
//! that wants fixed-size vectors (`SVector<f64, D>`) from a text.
//!
//! Each trait method is one call of the compiled function of the same name, written straight
//! into the caller's storage (`out.as_mut_slice()`): no allocation and no evaluation code of
//! its own. The fused `derivatives_into` needs one contiguous buffer (`1 + D + D^2 + 1`
//! values) that the runtime's layout splits into the four outputs; it is a per-thread scratch
//! grown to the largest `D` seen on that thread, so it allocates only on a thread's first call
//! at a new largest size (a stepper makes that call when it is built).
//!
//! The trait's methods cannot fail. A non-finite output (outside the domain of `ln`, an
//! overflow) is returned as it is, so the stepper's own checks report it as a typed error
//! (`dth::Error::NonFinite { step, what }`, or the peers' `MethodNonFinite`), as for any other
//! implementation. A point or an output of the wrong length (a `Dyn` vector not of the text's
//! dimension) is a caller's mistake that no output could report, so it panics, as nalgebra
//! does on a dimension mismatch, with a message that names the method, the length found and
//! the dimension expected. The checked alternatives are [`RuntimeHamiltonian`]'s own
//! `value_slice`, `gradient_slice`, ..., which return [`RuntimeError::WrongLength`] instead,
//! and every integrator checks a state's length before its first evaluation
//! (`dth::Error::WrongStateLength`), so a run never reaches the panic. The check is the
//! comparison of lengths each evaluation made already (and of a Hessian's shape), the panic
//! out of line; a `Const<D>` view ([`Typed`], [`Fixed`]) cannot reach it, its `D` checked
//! once when it was built.
//!
//! [`RuntimeHamiltonian`]'s own evaluations on slices are named apart (`value_slice`,
//! `gradient_slice`, ...), so with the trait in scope `h.value(&z)` on a `DVector` is the
//! trait's (before, an inherent `value(&[f64])` of the same name took precedence and
//! `h.value(&z)` did not compile). Its dimension as a `usize` is likewise `dimension()`, so
//! `h.dim()` is always the trait's, `Dyn` of it (an inherent `dim() -> usize` shadowed it).
//!
//! ```
//! use dth_core::dth::{Dth, DthOptions};
//! use dth_core::nalgebra::DVector;
//! use dth_core::Hamiltonian;
//! use dth_runtime::RuntimeHamiltonian;
//!
//! let text = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";
//! let kepler = RuntimeHamiltonian::new(text, &[("m", 0.5), ("k", 1.0)])?;
//! let zbar0 = DVector::from_column_slice(&[0.5, 0.0, 0.0, 1.2]); // D = 4, from the text
//! let mut dth = Dth::new(kepler, zbar0.clone(), DthOptions::thesis_kepler())?;
//! dth.advance(100)?;
//! let e0 = dth.hamiltonian().value(&zbar0);
//! assert!((dth.hamiltonian().value(dth.zbar()) - e0).abs() < 1e-15);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::sync::Arc;

use std::cell::RefCell;
use std::fmt;

use dth_core::{Alloc, Derivatives, Flags, Hamiltonian};
use nalgebra::{Const, DefaultAllocator, Dim, Dyn, OMatrix, OVector};

use crate::error::RuntimeError;
use crate::hamiltonian::RuntimeHamiltonian;
use crate::layout::Function;

/// A [`RuntimeHamiltonian`] checked to have dimension `D`, time dependence `TIME_DEPENDENT`
/// and, when `SEPARABLE` is set, the form `H = T(p) + V(q)`: it implements
/// `dth_core::Hamiltonian<Const<D>>` with these flags, `exact_divided_differences` (its
/// discrete gradients are the engine's exact divided differences, as the macro's), and, for a
/// lattice compiled in loops, its Hessian pattern and the structured Newton flag as the
/// macro's looped type has them (otherwise no pattern: the implicit methods use the dense
/// Newton solver). Without a fixed `D`
/// in mind, use the [`RuntimeHamiltonian`] itself: it is a `Hamiltonian<Dyn>`.
///
/// `SEPARABLE = false` is allowed for a separable Hamiltonian (the methods that need
/// separability then refuse it, as for any type that does not declare it); the other
/// mismatches are errors. A Hamiltonian whose Psi is identically zero is refused (the DTH
/// stepper refuses it too, with `dth_core::Error::PsiIdenticallyZero`, when given the
/// [`RuntimeHamiltonian`] itself).
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
        if runtime.dimension() != D {
            return Err(RuntimeError::DimensionMismatch {
                expected: D,
                found: runtime.dimension(),
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
}

/// A [`RuntimeHamiltonian`] checked to have dimension `D`, with the flags its text gives
/// (read when it is built, not declared in the type as [`Typed`]'s): a
/// `dth_core::Hamiltonian<Const<D>>` for code that picks a fixed size at run time from a
/// short list, so that the stepper and the peers use fixed-size linear algebra (stack storage,
/// unrolled loops) on a Hamiltonian read from text. The scene runner runs a text of small
/// dimension this way. Evaluations are those of [`Typed`] and of the `Dyn` implementation:
/// one call of compiled code each, the same bits.
///
/// ```
/// use dth_core::{nalgebra::Vector4, Hamiltonian};
/// use dth_runtime::{Fixed, RuntimeError, RuntimeHamiltonian};
///
/// let text = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";
/// let kepler = Fixed::<4>::new(RuntimeHamiltonian::new(text, &[("m", 0.5), ("k", 1.0)])?)?;
/// assert!(kepler.flags().separable);
/// assert!((kepler.value(&Vector4::new(0.5, 0.0, 0.0, 1.2)) - (1.44 - 2.0)).abs() < 1e-15);
///
/// let wrong = Fixed::<2>::new(RuntimeHamiltonian::new(text, &[("m", 0.5), ("k", 1.0)])?);
/// assert!(matches!(wrong, Err(RuntimeError::DimensionMismatch { expected: 2, found: 4 })));
/// # Ok::<(), RuntimeError>(())
/// ```
#[derive(Clone, Debug)]
pub struct Fixed<const D: usize> {
    runtime: Arc<RuntimeHamiltonian>,
    flags: Flags,
}

impl<const D: usize> Fixed<D> {
    /// The view of `runtime` (owned, or shared through an [`Arc`]) at `Const<D>`.
    ///
    /// # Errors
    /// [`RuntimeError::DimensionMismatch`] when the text's `D` is not `D`.
    pub fn new(runtime: impl Into<Arc<RuntimeHamiltonian>>) -> Result<Self, RuntimeError> {
        let runtime = runtime.into();
        if runtime.dimension() != D {
            return Err(RuntimeError::DimensionMismatch {
                expected: D,
                found: runtime.dimension(),
            });
        }
        let flags = derived_flags(&runtime);
        Ok(Fixed { runtime, flags })
    }

    /// The runtime Hamiltonian viewed.
    pub fn runtime(&self) -> &RuntimeHamiltonian {
        &self.runtime
    }
}

/// Runs `f` at `z0`, `z1` into `out`. A non-finite output is left in `out` for the caller's
/// checks to report (see the module docs).
///
/// # Panics
/// When `z0`, `z1` or `out` is not of the Hamiltonian's dimension ([`wrong_length`]).
#[track_caller]
fn run(runtime: &RuntimeHamiltonian, f: Function, z0: &[f64], z1: &[f64], out: &mut [f64]) {
    match runtime.run(f, z0, z1, out) {
        Ok(()) | Err(RuntimeError::NonFinite { .. }) => {}
        Err(error) => refused(runtime, f, error),
    }
}

/// A one-value function.
///
/// # Panics
/// As [`run`].
#[track_caller]
fn scalar(runtime: &RuntimeHamiltonian, f: Function, z0: &[f64], z1: &[f64]) -> f64 {
    let mut out = [0.0];
    run(runtime, f, z0, z1, &mut out);
    out[0]
}

/// The trait method that runs `f`, for the panic messages.
fn trait_method(f: Function) -> &'static str {
    match f {
        Function::Value => "value",
        Function::Gradient => "gradient_into",
        Function::Hessian => "hessian_into",
        Function::Psi => "psi",
        Function::Derivatives => "derivatives_into",
        Function::DiscreteGradient => "discrete_gradient_into",
        Function::EnergyDifference => "energy_difference",
        Function::DiscreteGradientDefect => "discrete_gradient_defect_into",
    }
}

/// The size of an argument of the wrong dimension, for the panic message.
#[derive(Clone, Copy, Debug)]
enum Found {
    /// A vector's length.
    Components(usize),
    /// A matrix's rows and columns.
    Shape(usize, usize),
}

impl fmt::Display for Found {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Found::Components(1) => write!(f, "has 1 component"),
            Found::Components(n) => write!(f, "has {n} components"),
            Found::Shape(rows, columns) => write!(f, "is {rows} x {columns}"),
        }
    }
}

/// The panic of the trait method running `f` given `what` (a point, or the output) of
/// another size than the Hamiltonian's dimension: the method, the two sizes, and the checked
/// method that returns the error instead (`value_slice` for `value`, ...). Out of line and
/// cold, so an evaluation pays only for the comparison that leads here.
#[cold]
#[inline(never)]
#[track_caller]
fn wrong_length(runtime: &RuntimeHamiltonian, f: Function, what: &str, found: Found) -> ! {
    panic!(
        "RuntimeHamiltonian::{}: {what} {found}, the Hamiltonian's dimension is {} (the checked \
         RuntimeHamiltonian::{}_slice returns an error instead)",
        trait_method(f),
        runtime.dimension(),
        f.name(),
    )
}

/// The panic for an error of [`RuntimeHamiltonian::run`] other than a non-finite output.
#[cold]
#[inline(never)]
#[track_caller]
fn refused(runtime: &RuntimeHamiltonian, f: Function, error: RuntimeError) -> ! {
    match error {
        // The output of a matrix is checked before (`square`): here it is a vector's.
        RuntimeError::WrongLength { what, found, .. } if what != "params" => {
            wrong_length(runtime, f, what, Found::Components(found))
        }
        // The lengths of the points and the output are the only errors a caller can cause:
        // the parameters are the Hamiltonian's own, and the interpreter checks only the
        // lengths checked before it.
        error => panic!(
            "RuntimeHamiltonian::{}: {error} (not a caller's mistake: a bug in dth-runtime)",
            trait_method(f)
        ),
    }
}

/// Panics unless `matrix` (a Hessian output) is `D x D`: [`run`] checks only its length, and a
/// `2 x 8` matrix would take a `4 x 4` Hessian's entries in the wrong places.
#[track_caller]
fn square<D: Dim>(
    runtime: &RuntimeHamiltonian,
    f: Function,
    what: &str,
    matrix: &OMatrix<f64, D, D>,
) where
    DefaultAllocator: Alloc<D>,
{
    let d = runtime.dimension();
    let (rows, columns) = matrix.shape();
    if (rows, columns) != (d, d) {
        wrong_length(runtime, f, what, Found::Shape(rows, columns));
    }
}

thread_local! {
    /// The fused evaluation's contiguous buffer (see the module docs).
    static FUSED: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// One call of the fused program, its pieces copied into `out`. The Hessian is written
/// row-major with both triangles, which for a symmetric matrix is the same array as
/// column-major (nalgebra's storage).
///
/// # Panics
/// When `z` or a piece of `out` is not of the Hamiltonian's dimension, before anything is
/// written.
#[track_caller]
fn fused<D: Dim>(runtime: &RuntimeHamiltonian, z: &[f64], out: &mut Derivatives<D>)
where
    DefaultAllocator: Alloc<D>,
{
    let f = Function::Derivatives;
    let d = runtime.dimension();
    // Checked here, not by `run` inside the closure (which would report the closure's line,
    // not the caller's); `out` first, so that the copies below, which take their sizes from
    // `d`, cannot panic with a message of their own.
    if z.len() != d {
        wrong_length(runtime, f, "z", Found::Components(z.len()));
    }
    if out.gradient.len() != d {
        let found = Found::Components(out.gradient.len());
        wrong_length(runtime, f, "out.gradient", found);
    }
    square(runtime, f, "out.hessian", &out.hessian);
    let len = f.len(d);
    FUSED.with_borrow_mut(|buffer| {
        if buffer.len() < len {
            buffer.resize(len, 0.0);
        }
        let buffer = &mut buffer[..len];
        run(runtime, f, z, z, buffer);
        out.value = buffer[0];
        out.gradient
            .as_mut_slice()
            .copy_from_slice(&buffer[1..1 + d]);
        out.hessian
            .as_mut_slice()
            .copy_from_slice(&buffer[1 + d..1 + d + d * d]);
        out.psi = buffer[1 + d + d * d];
    });
}

/// The trait's evaluation methods, each one call of compiled code into `out`, for a type whose
/// runtime Hamiltonian is `self.runtime()`. Each is `#[track_caller]`, so that a panic for a
/// wrong length names the caller's line.
macro_rules! evaluations {
    ($d:ty) => {
        /// The lattice's pattern for a text compiled in loops
        /// ([`RuntimeHamiltonian::hessian_pattern`]); `None` otherwise.
        fn hessian_pattern(&self) -> Option<&[(usize, usize)]> {
            self.runtime().hessian_pattern()
        }

        /// One call of the lattice's looped nonzeros (nothing without a pattern).
        ///
        /// # Panics
        /// When `z` is not of the Hamiltonian's dimension or `values` is shorter than the
        /// pattern; [`RuntimeHamiltonian::hessian_nonzeros_slice`] returns the error instead.
        #[track_caller]
        fn hessian_nonzeros(&self, z: &OVector<f64, $d>, values: &mut [f64]) {
            nonzeros(self.runtime(), z.as_slice(), values);
        }

        /// # Panics
        /// When `z` is not of the Hamiltonian's dimension (only a `Dyn` vector can be);
        /// [`RuntimeHamiltonian::value_slice`] returns the error instead.
        #[track_caller]
        fn value(&self, z: &OVector<f64, $d>) -> f64 {
            scalar(self.runtime(), Function::Value, z.as_slice(), z.as_slice())
        }

        /// # Panics
        /// When `z` or `out` is not of the Hamiltonian's dimension (only a `Dyn` vector can
        /// be); [`RuntimeHamiltonian::gradient_slice`] returns the error instead.
        #[track_caller]
        fn gradient_into(&self, z: &OVector<f64, $d>, out: &mut OVector<f64, $d>) {
            run(
                self.runtime(),
                Function::Gradient,
                z.as_slice(),
                z.as_slice(),
                out.as_mut_slice(),
            );
        }

        /// Written row-major with both triangles, which for a symmetric matrix is the same
        /// array as column-major (nalgebra's storage): each entry and its mirror are one
        /// output.
        ///
        /// # Panics
        /// When `z` is not of the Hamiltonian's dimension `D` or `out` is not `D x D` (only a
        /// `Dyn` vector or matrix can be); [`RuntimeHamiltonian::hessian_slice`] returns the
        /// error instead.
        #[track_caller]
        fn hessian_into(&self, z: &OVector<f64, $d>, out: &mut OMatrix<f64, $d, $d>) {
            square(self.runtime(), Function::Hessian, "out", out);
            run(
                self.runtime(),
                Function::Hessian,
                z.as_slice(),
                z.as_slice(),
                out.as_mut_slice(),
            );
        }

        /// # Panics
        /// When `z` is not of the Hamiltonian's dimension (only a `Dyn` vector can be);
        /// [`RuntimeHamiltonian::psi_slice`] returns the error instead.
        #[track_caller]
        fn psi(&self, z: &OVector<f64, $d>) -> f64 {
            scalar(self.runtime(), Function::Psi, z.as_slice(), z.as_slice())
        }

        /// # Panics
        /// When `z`, `out.gradient` or `out.hessian` is not of the Hamiltonian's dimension
        /// (only a `Dyn` one can be), before anything is written;
        /// [`RuntimeHamiltonian::derivatives_slice`] returns the error instead.
        #[track_caller]
        fn derivatives_into(&self, z: &OVector<f64, $d>, out: &mut Derivatives<$d>) {
            fused(self.runtime(), z.as_slice(), out);
        }

        /// # Panics
        /// When `z0`, `z1` or `out` is not of the Hamiltonian's dimension (only a `Dyn` vector
        /// can be); [`RuntimeHamiltonian::discrete_gradient_slice`] returns the error instead.
        #[track_caller]
        fn discrete_gradient_into(
            &self,
            z0: &OVector<f64, $d>,
            z1: &OVector<f64, $d>,
            out: &mut OVector<f64, $d>,
        ) {
            run(
                self.runtime(),
                Function::DiscreteGradient,
                z0.as_slice(),
                z1.as_slice(),
                out.as_mut_slice(),
            );
        }

        /// Recomputes `gbar` inside, as the macro's types do (`gbar` is not read).
        ///
        /// # Panics
        /// When `z0`, `z1` or `out` is not of the Hamiltonian's dimension (only a `Dyn` vector
        /// can be); [`RuntimeHamiltonian::discrete_gradient_defect_slice`] returns the error
        /// instead.
        #[track_caller]
        fn discrete_gradient_defect_into(
            &self,
            z0: &OVector<f64, $d>,
            z1: &OVector<f64, $d>,
            _gbar: &OVector<f64, $d>,
            out: &mut OVector<f64, $d>,
        ) {
            run(
                self.runtime(),
                Function::DiscreteGradientDefect,
                z0.as_slice(),
                z1.as_slice(),
                out.as_mut_slice(),
            );
        }

        /// # Panics
        /// When `z0` or `z1` is not of the Hamiltonian's dimension (only a `Dyn` vector can
        /// be); [`RuntimeHamiltonian::energy_difference_slice`] returns the error instead.
        #[track_caller]
        fn energy_difference(&self, z0: &OVector<f64, $d>, z1: &OVector<f64, $d>) -> f64 {
            scalar(
                self.runtime(),
                Function::EnergyDifference,
                z0.as_slice(),
                z1.as_slice(),
            )
        }

        /// A regularization's gradient in double-double
        /// ([`RuntimeHamiltonian::gradient_double_double_slice`]); `false` for any other text
        /// (and for slices of another length, which only a `Dyn` vector can be).
        fn gradient_double_double_into(
            &self,
            (hi, lo): (&OVector<f64, $d>, &OVector<f64, $d>),
            (out_hi, out_lo): (&mut OVector<f64, $d>, &mut OVector<f64, $d>),
        ) -> bool {
            self.runtime()
                .gradient_double_double_slice(
                    (hi.as_slice(), lo.as_slice()),
                    (out_hi.as_mut_slice(), out_lo.as_mut_slice()),
                )
                .is_ok()
        }
    };
}

/// The Hessian's nonzeros into `values[..nnz]`. A non-finite entry is left in `values` for
/// the caller's checks (see the module docs).
///
/// # Panics
/// When `z` is not of the Hamiltonian's dimension, or `values` is shorter than the pattern.
#[track_caller]
fn nonzeros(runtime: &RuntimeHamiltonian, z: &[f64], values: &mut [f64]) {
    let Some(nnz) = runtime.hessian_pattern().map(<[_]>::len) else {
        return;
    };
    let f = Function::Hessian;
    if z.len() != runtime.dimension() {
        wrong_length(runtime, f, "z", Found::Components(z.len()));
    }
    if values.len() < nnz {
        nonzeros_too_short(values.len(), nnz);
    }
    match runtime.hessian_nonzeros_slice(z, &mut values[..nnz]) {
        Ok(()) | Err(RuntimeError::NonFinite { .. }) => {}
        Err(error) => refused(runtime, f, error),
    }
}

/// The panic of `hessian_nonzeros` given fewer values than the pattern has entries.
#[cold]
#[inline(never)]
#[track_caller]
fn nonzeros_too_short(found: usize, nnz: usize) -> ! {
    panic!(
        "RuntimeHamiltonian::hessian_nonzeros: values has {found} entries, the Hessian's pattern \
         {nnz} (the checked RuntimeHamiltonian::hessian_nonzeros_slice returns an error instead)"
    )
}

/// The flags the engine derived from the text.
fn derived_flags(runtime: &RuntimeHamiltonian) -> Flags {
    Flags::default()
        .with_time_dependent(runtime.time_dependent())
        .with_regularized(runtime.regularized())
        .with_separable(runtime.separable())
        .with_psi_identically_zero(runtime.psi_identically_zero())
        .with_exact_divided_differences(true)
        .with_structured_newton(runtime.structured_newton())
}

/// The dimension and the flags are the text's.
impl Hamiltonian<Dyn> for RuntimeHamiltonian {
    fn dim(&self) -> Dyn {
        Dyn(self.dimension())
    }

    fn flags(&self) -> Flags {
        derived_flags(self)
    }

    evaluations!(Dyn);
}

/// Self-reference for [`evaluations!`] on the runtime types themselves.
trait Runtime {
    fn runtime(&self) -> &RuntimeHamiltonian;
}

impl Runtime for RuntimeHamiltonian {
    fn runtime(&self) -> &RuntimeHamiltonian {
        self
    }
}

/// The flags the type declares (checked against the text's in [`Typed::new`]).
impl<const D: usize, const TIME_DEPENDENT: bool, const SEPARABLE: bool> Hamiltonian<Const<D>>
    for Typed<D, TIME_DEPENDENT, SEPARABLE>
{
    fn dim(&self) -> Const<D> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default()
            .with_time_dependent(TIME_DEPENDENT)
            .with_separable(SEPARABLE)
            .with_exact_divided_differences(true)
            .with_structured_newton(self.runtime.structured_newton())
            // Not a type parameter: what the text is (a regularization's time is its `t`).
            .with_regularized(self.runtime().regularized())
    }

    evaluations!(Const<D>);
}

/// The text's flags, as the `Dyn` implementation gives them.
impl<const D: usize> Hamiltonian<Const<D>> for Fixed<D> {
    fn dim(&self) -> Const<D> {
        Const
    }

    fn flags(&self) -> Flags {
        self.flags
    }

    evaluations!(Const<D>);
}
