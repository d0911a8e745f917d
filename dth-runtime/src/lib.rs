//! Hamiltonians built from text at run time, at compiled speed.
//!
//! `dth::hamiltonian!` derives a Hamiltonian's gradient, Hessian, Psi and exact discrete
//! gradients when the program is compiled. This crate does the same for a Hamiltonian that
//! arrives as data (a scene file, a command line): the same engine
//! ([`dth_symbolic::compile`], one grammar, the same error messages) lowers each derivative
//! to a straight-line program, and [Cranelift](https://cranelift.dev) compiles the programs
//! to machine code when the Hamiltonian is built, in milliseconds.
//!
//! ```
//! use dth_runtime::{Backend, RuntimeHamiltonian};
//!
//! let pendulum = RuntimeHamiltonian::new(
//!     "p1^2/(2*m*l^2) - m*g*l*cos(q1)",
//!     &[("m", 1.0), ("l", 2.0), ("g", 9.81)],
//! )?;
//! let z = [0.3, 0.1];
//! let mut d = pendulum.derivatives_buffer();
//! pendulum.derivatives_slice(&z, &mut d)?;
//! assert!((d.gradient()[0] - 9.81 * 2.0 * 0.3f64.sin()).abs() < 1e-14);
//!
//! // The interpreter is the reference: compiled code returns its bits.
//! let reference = RuntimeHamiltonian::with_backend(
//!     "p1^2/(2*m*l^2) - m*g*l*cos(q1)",
//!     &[("m", 1.0), ("l", 2.0), ("g", 9.81)],
//!     Backend::Interpreter,
//! )?;
//! let mut e = reference.derivatives_buffer();
//! reference.derivatives_slice(&z, &mut e)?;
//! assert_eq!(d, e);
//! # Ok::<(), dth_runtime::RuntimeError>(())
//! ```
//!
//! # Layers
//!
//! Each module imports only from those listed before it:
//!
//! 1. [`error`]: the expression's, the parameters', the JIT's and the evaluations' errors.
//! 2. [`layout`]: the trait methods ([`Function`]), the engine program each is cut from, and
//!    where each output lands in the caller's buffer.
//! 3. [`shims`]: the `extern "C"` wrappers compiled code calls for transcendentals.
//! 4. [`jit`]: programs to machine code.
//! 5. [`backend`]: the JIT or the interpreter behind one call that checks lengths and
//!    finiteness.
//! 6. [`hamiltonian`]: [`RuntimeHamiltonian`], the public face; [`function`]: a function of
//!    the state from text ([`StateFunction`], an event's condition), compiled the same way.
//! 7. [`typed`]: `RuntimeHamiltonian` as a `dth_core::Hamiltonian<Dyn>`, and [`Typed`], the
//!    same checked for a `Const<D>` named at compile time, so the stepper and the peers run it.
//!
//! # Compiled code equals the interpreter
//!
//! Each operation of a program becomes one instruction or one call, in the program's order.
//! Cranelift does not reassociate floating-point arithmetic or fuse multiplies and adds; its
//! only float rewrites are exact (folding constants whose result is not NaN, `-(-x) = x`,
//! `(-x)(-y) = xy`). Arithmetic and square roots are correctly rounded in both; every other
//! function is a call to the Rust function the interpreter calls ([`shims`]). So compiled
//! code returns the interpreter's bits (`tests/jit_matches_interpreter.rs` checks it with
//! `to_bits` on every catalogue system and on generated expressions), and, since the macro
//! emits the same programs, the bits of `hamiltonian!`'s code.
//!
//! # Costs
//!
//! Building compiles eight programs (value, gradient, Hessian, Psi, the fused derivatives,
//! the discrete gradient, the energy difference and the defect) into one module; the
//! measured compile times against expression size are in `docs/performance.md`. The code is
//! freed when the Hamiltonian is dropped. An evaluation checks the slice lengths, makes one
//! call into compiled code, and checks its outputs are finite; a non-finite output is
//! [`RuntimeError::NonFinite`], not a NaN passed on. The interpreter backend allocates its
//! result on every call.
//!
//! # The `Hamiltonian` trait
//!
//! `dth_core::Hamiltonian<D>` is generic over nalgebra's dimensions, and its flags are
//! values: [`RuntimeHamiltonian`] implements `Hamiltonian<Dyn>` with the dimension and flags
//! its text gives, so DTH and every peer run it with `DVector`s (`docs/runtime_dimension.md`).
//! [`Typed`] names a `Const<D>` and the flags in its type and checks them when built, for code
//! that wants fixed-size vectors; [`Fixed`] names only the `Const<D>` and keeps the text's
//! flags, for code that chooses the size at run time. Either way every trait method is one call of the compiled
//! function of the same name ([`Function`] is named after them), with the macro's bits
//! (`tests/typed_matches_macro.rs` and `tests/runtime_dyn.rs` in the `dth` crate step both).
//! The trait's methods cannot return an error: a `Dyn` vector of another length than the
//! text's dimension panics there, naming the method and both sizes, as nalgebra does on a
//! dimension mismatch (the integrators check a state's length first and return an error; the
//! slice methods return [`RuntimeError::WrongLength`]).
#![warn(missing_docs)]

pub mod backend;
pub mod error;
pub mod function;
pub mod hamiltonian;
pub mod jit;
pub mod lattice;
pub mod layout;
mod looped;
pub mod shims;
pub mod typed;

pub use backend::Backend;
pub use error::{JitError, RuntimeError};
pub use function::StateFunction;
pub use hamiltonian::{Derivatives, RuntimeHamiltonian};
pub use layout::Function;
pub use typed::{Fixed, Typed};
