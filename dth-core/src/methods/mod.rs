//! Fixed-step peer integrators, one per module, behind one trait and one driver.
//!
//! Every method implements [`OneStepMethod`] for the Hamiltonians it applies to (generic and
//! monomorphized: no `dyn`, no heap allocation per step); [`run`] takes `N` steps and calls an
//! [`Observer`] after each one (the same protocol as the DTH stepper's), storing nothing unless
//! the observer does ([`Recorder`](crate::observer::Recorder)).
//!
//! | module | method | order | exact invariants |
//! |---|---|---|---|
//! | [`trapezoidal`] | trapezoidal rule | 2 | none |
//! | [`midpoint`] | implicit midpoint | 2 | quadratic (angular momentum) |
//! | [`discrete_mechanics`] | Greenspan's discrete mechanics (central force) | 2 | energy, angular momentum |
//! | [`verlet`] | Stormer-Verlet (separable H) | 2 | none (symplectic) |
//! | [`rk4`] | classical Runge-Kutta | 4 | none |
//! | [`gauss_legendre`] | 2-stage Gauss-Legendre | 4 | quadratic (symplectic) |
//! | [`discrete_gradient`] | Gonzalez midpoint discrete gradient | 2 | energy |
//!
//! # Time-dependent Hamiltonians
//! A time-dependent `H(t, q, p)` implements [`Hamiltonian`] on the extended phase space
//! `z = (q, t, p, p_t)` with value `calH = p_t + H` (paper Theorem 1). Then `dt/ds = dcalH/dp_t
//! = 1`: the extended flow *is* the time-dependent flow with `t` as a coordinate, and every
//! method here integrates it unchanged (the stage times of RK4 and Gauss-Legendre come out of
//! the `t` coordinate of the stages). The driver's clock `t0 + k dt` then equals the `t`
//! coordinate of the state up to roundoff, except for [`DiscreteGradient`] with Gonzalez's
//! discrete gradient, whose correction is along `z1 - z0` (which has a `t` component): there
//! the `t` coordinate differs from the clock by `O(dt^2)`, consistently with second order.
//! (Tested on [`ForcedOscillator`](crate::systems::ForcedOscillator) in
//! `tests/methods_order.rs`.)
//!
//! ```
//! use dth_core::methods::{run, ImplicitMidpoint};
//! use dth_core::observer::Recorder;
//! use dth_core::systems::Kepler;
//! use dth_core::nalgebra::Vector4;
//!
//! let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
//! let mut recorder = Recorder::new();
//! let end = run(&mut ImplicitMidpoint::new(), &Kepler::thesis(), &z0, 0.0, 0.15, 100, &mut recorder)?;
//! assert_eq!(end.steps, 100);
//! assert_eq!(recorder.z.len(), 101); // the initial state and one per step
//! let l = Kepler::angular_momentum(&end.z);
//! assert!((l - 0.6).abs() < 1e-14); // midpoint keeps quadratic invariants
//! # Ok::<(), dth_core::Error>(())
//! ```

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};
pub mod discrete_gradient;
pub mod discrete_mechanics;
mod fixed_run;
pub mod gauss_legendre;
mod kept;
pub mod midpoint;
mod newton;
pub mod rk4;
pub mod trapezoidal;
pub mod verlet;

pub use discrete_gradient::DiscreteGradient;
pub use discrete_mechanics::DiscreteMechanics;
pub(crate) use fixed_run::{Advanced, Beside, FixedRun, Span};
pub use gauss_legendre::GaussLegendre2;
pub use midpoint::ImplicitMidpoint;
pub use newton::NewtonOptions;
pub(crate) use newton::Structured;
pub use rk4::Rk4;
pub use trapezoidal::Trapezoidal;
pub use verlet::StormerVerlet;

/// A run that stopped early: the error, and in `partial` the last good [`RunEnd`] (the
/// observer has seen it and every state before it). The same type as the DTH stepper's.
pub use crate::error::RunError;
use crate::observer::Observer;
use crate::{Error, Hamiltonian};

/// A fixed-step one-step method for the Hamiltonian `H` on `R^D`.
pub trait OneStepMethod<D: Dim, H: Hamiltonian<D>>
where
    DefaultAllocator: Alloc<D>,
{
    /// Short name, used in errors and tables (`"midpoint"`, `"rk4"`, ...).
    const NAME: &'static str;
    /// Classical order of accuracy.
    const ORDER: u32;

    /// Advances `z` by `dt` into `z1` (of `z`'s dimension, distinct from it): what [`run`]
    /// calls. Every method here does it without allocating (for a `Dyn` dimension after its
    /// first step, buffers kept in the method value). Errors report `step: 0`; [`run`] fills
    /// in the step index. On error `z1` holds no meaningful value.
    ///
    /// Each call is a step on its own: `h` may differ from the last call's (another value of
    /// a parameter, say), and nothing a method keeps between calls depends on it.
    ///
    /// # Errors
    /// Every method here: [`Error::WrongStateLength`] when `z` or `z1` is not of the
    /// Hamiltonian's dimension (a `Dyn` vector), [`Error::OddDimension`] for a Hamiltonian of
    /// odd dimension, [`Error::InvalidOption`] (`dt`) for a zero or non-finite `dt`; then the
    /// method's own failures ([`Error::MethodNonFinite`] for a state that is not finite,
    /// [`Error::MethodNotConverged`] and [`Error::MethodSingularMatrix`] for the implicit
    /// ones, [`Error::NotSeparable`]).
    fn step_into(
        &mut self,
        h: &H,
        z: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error>;

    /// The next step of a run: [`step_into`](Self::step_into), where the caller vouches that
    /// `h` is the Hamiltonian of this method value's last step, unchanged since (the same
    /// value, no parameter set in between), so that the method may reuse what it computed
    /// there ([`StormerVerlet`] its last force, when `z` is that step's result). What [`run`]
    /// calls after its first step. The default is `step_into`.
    ///
    /// # Errors
    /// As [`step_into`](Self::step_into).
    fn continue_into(
        &mut self,
        h: &H,
        z: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        self.step_into(h, z, dt, z1)
    }

    /// [`step_into`](Self::step_into) returning the new state (allocates it for a `Dyn`
    /// dimension).
    fn step(&mut self, h: &H, z: &OVector<f64, D>, dt: f64) -> Result<OVector<f64, D>, Error> {
        let mut z1 = z.clone();
        self.step_into(h, z, dt, &mut z1)?;
        Ok(z1)
    }

    /// Newton iterations spent by this method value so far (0 for explicit methods).
    fn newton_iterations(&self) -> usize {
        0
    }
}

/// The checks of a phase space every integrator makes before it steps: an even dimension
/// (`z = (q1..qn, p1..pn)`), and a state `z` (named `what` in the error) of the Hamiltonian's
/// dimension. Both hold by construction for a fixed dimension `Const<N>` with `N` even; a
/// `Dyn` vector may have any length.
pub(crate) fn check_state<H: Hamiltonian<D>, D: Dim>(
    hamiltonian: &H,
    z: &OVector<f64, D>,
    what: &'static str,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let dim = hamiltonian.dim().value();
    if dim % 2 != 0 {
        return Err(Error::OddDimension { dim });
    }
    if z.len() != dim {
        return Err(Error::WrongStateLength {
            what,
            expected: dim,
            found: z.len(),
        });
    }
    Ok(())
}

/// What every method's [`OneStepMethod::step_into`] checks first (`O(1)`): `z` and `z1` of the
/// Hamiltonian's (even) dimension, and `dt` finite and non-zero, as [`run`] requires.
pub(crate) fn check_step<H: Hamiltonian<D>, D: Dim>(
    hamiltonian: &H,
    z: &OVector<f64, D>,
    dt: f64,
    z1: &OVector<f64, D>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    check_state(hamiltonian, z, "z")?;
    check_state(hamiltonian, z1, "z1")?;
    check_dt(dt)
}

/// `dt` finite and non-zero (negative integrates backwards).
pub(crate) fn check_dt(dt: f64) -> Result<(), Error> {
    if dt.is_finite() && dt != 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidOption {
            name: "dt",
            value: dt,
            reason: "must be finite and non-zero",
        })
    }
}

/// An explicit method's new state, checked: NaN or infinite components (the state ran into a
/// singularity of `H`, or `dt` is far too large) are [`Error::MethodNonFinite`], not a result.
pub(crate) fn check_finite<D: Dim>(method: &'static str, z1: &OVector<f64, D>) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    if z1.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Error::MethodNonFinite {
            method,
            step: 0,
            what: "state",
        })
    }
}

/// Where a run ended: the last state computed, its time and the number of steps taken.
#[derive(Clone, Debug, PartialEq)]
pub struct RunEnd<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The last state.
    pub z: OVector<f64, D>,
    /// Its time `t0 + steps * dt`.
    pub t: f64,
    /// Steps taken.
    pub steps: usize,
}

/// `Copy` for fixed sizes, as before the dimension became a type.
impl<const N: usize> Copy for RunEnd<nalgebra::Const<N>> {}

/// Integrates `steps` steps of size `dt` from `z0` at time `t0`, calling `observer` on the
/// initial state and after each step.
///
/// `dt` must be finite and non-zero (negative integrates backwards) and `z0` finite; a state
/// that becomes non-finite is [`Error::MethodNonFinite`]. On failure the states already
/// computed are kept: the observer has seen them and [`RunError::partial`] holds the last.
/// (To end at a time, exactly, and for one driver of every method, DTH included:
/// [`crate::solve`](mod@crate::solve).)
///
/// # Errors
/// [`RunError`] with the first error (of the input checks, or of the failing step, with its
/// index) and the last good [`RunEnd`]; `?` converts it into [`Error`] (dropping the
/// [`RunEnd`]).
pub fn run<D: Dim, H, M, O>(
    method: &mut M,
    h: &H,
    z0: &OVector<f64, D>,
    t0: f64,
    dt: f64,
    steps: usize,
    observer: &mut O,
) -> Result<RunEnd<D>, RunError<RunEnd<D>>>
where
    DefaultAllocator: Alloc<D>,
    H: Hamiltonian<D>,
    M: OneStepMethod<D, H>,
    O: Observer<D>,
{
    let mut run = FixedRun::start(method, h, z0, t0, dt, observer)?;
    match run.advance(
        method,
        h,
        dt,
        Span::Steps(steps),
        &mut Beside::nothing(),
        observer,
    ) {
        Ok(_) => Ok(run.end),
        Err(error) => Err(RunError {
            error,
            partial: run.end,
        }),
    }
}

/// The number of steps a fixed-step run of step `dt > 0` takes from `t_a` to end at `t_b`
/// ([`crate::solve`](mod@crate::solve)): the least `m` that reaches `t_b` (0 when `t_b <= t_a`), where a last
/// step that would only make up the rounding of `(t_b - t_a) / dt` (at most `4 eps` of it) is
/// merged into the one before. Its steps are `m - 1` of `dt` and a last one of what is left.
///
/// ```
/// use dth_core::methods::steps_until;
/// assert_eq!(steps_until(0.0, 1.0, 0.3), 4); // 0.3, 0.6, 0.9, then 0.1
/// assert_eq!(steps_until(0.0, 1.0, 0.1), 10); // ten steps, the last 1 - 9 * 0.1
/// assert_eq!(steps_until(2.0, 1.0, 0.1), 0);
/// assert_eq!(steps_until(100.0, 100.001, 0.001), 1); // not a second step of size 0
/// ```
pub fn steps_until(t_a: f64, t_b: f64, dt: f64) -> usize {
    let x = (t_b - t_a) / dt;
    if x.is_nan() || x <= 0.0 {
        return 0;
    }
    // Saturates at usize::MAX for an astronomically long run (a step cap stops it).
    let mut m = x.ceil() as usize;
    if m > 1 && x - (m - 1) as f64 <= 4.0 * f64::EPSILON * x {
        m -= 1;
    }
    // The clock `t_a + (m - 1) dt` rounds relative to `t_a`: a step ending at or past `t_b`
    // by that rounding would leave a last step of zero (or negative) size.
    while m > 1 && t_a + (m - 1) as f64 * dt >= t_b {
        m -= 1;
    }
    m
}

/// Fills in the step index of a method error.
pub(crate) fn at_step(error: Error, k: usize) -> Error {
    match error {
        Error::MethodNotConverged {
            method,
            iterations,
            residual,
            ..
        } => Error::MethodNotConverged {
            method,
            step: k,
            iterations,
            residual,
        },
        Error::MethodSingularMatrix {
            method,
            iteration,
            residual,
            ..
        } => Error::MethodSingularMatrix {
            method,
            step: k,
            iteration,
            residual,
        },
        Error::MethodNonFinite { method, what, .. } => Error::MethodNonFinite {
            method,
            step: k,
            what,
        },
        other => other,
    }
}

/// `J M` for `J = [[0, I], [-I, 0]]`: rows `(M_p, -M_q)` (a test oracle: the steps write `J`
/// entry by entry).
#[cfg(test)]
pub(crate) fn j_times_matrix<D: Dim>(
    m: &nalgebra::OMatrix<f64, D, D>,
) -> nalgebra::OMatrix<f64, D, D>
where
    DefaultAllocator: Alloc<D>,
{
    let n = m.nrows() / 2;
    let (r, c) = m.shape_generic();
    nalgebra::OMatrix::from_fn_generic(
        r,
        c,
        |i, j| if i < n { m[(i + n, j)] } else { -m[(i - n, j)] },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::StepRecord;
    use crate::systems::HarmonicOscillator;
    use nalgebra::Const;
    use nalgebra::{Matrix2, Vector2};

    #[test]
    fn j_times_matrix_matches_j_times_columns() {
        let m = Matrix2::new(1.0, 2.0, 3.0, 4.0);
        let jm = j_times_matrix(&m);
        for c in 0..2 {
            let col: Vector2<f64> = m.column(c).into();
            assert_eq!(jm.column(c).into_owned(), crate::j_times(&col));
        }
    }

    #[test]
    fn run_rejects_bad_input_and_keeps_the_start() {
        let h = HarmonicOscillator { mass: 1.0, k: 1.0 };
        let z0 = Vector2::new(1.0, 0.0);
        let err = run(&mut Rk4::new(), &h, &z0, 0.0, 0.0, 10, &mut ()).unwrap_err();
        assert!(matches!(err.error, Error::InvalidOption { name: "dt", .. }));
        assert_eq!(err.partial.z, z0);
        let bad = Vector2::new(f64::NAN, 0.0);
        let err = run(&mut Rk4::new(), &h, &bad, 0.0, 0.1, 10, &mut ()).unwrap_err();
        assert!(matches!(
            err.error,
            Error::NonFiniteInitialState { index: 0, .. }
        ));
    }

    /// `H = p^2/2 + 2 q^(3/2)`: defined for `q >= 0` only, NaN beyond. A particle released at
    /// `q = 1` falls to `q < 0` in finite time.
    struct HalfLine;
    impl Hamiltonian<Const<2>> for HalfLine {
        fn dim(&self) -> Const<2> {
            Const
        }

        fn value(&self, z: &Vector2<f64>) -> f64 {
            0.5 * z[1] * z[1] + 2.0 * z[0].powf(1.5)
        }
        fn gradient_into(&self, z: &Vector2<f64>, out: &mut Vector2<f64>) {
            *out = Vector2::new(3.0 * z[0].sqrt(), z[1]);
        }
        fn hessian_into(&self, z: &Vector2<f64>, out: &mut Matrix2<f64>) {
            *out = Matrix2::new(1.5 / z[0].sqrt(), 0.0, 0.0, 1.0);
        }
    }

    #[test]
    fn failure_keeps_what_was_computed_and_names_the_step() {
        let z0 = Vector2::new(1.0, 0.0);
        let mut count = 0;
        let err = run(
            &mut Rk4::new(),
            &HalfLine,
            &z0,
            0.0,
            0.01,
            100_000,
            &mut |_: &StepRecord<Const<2>>| count += 1,
        )
        .unwrap_err();
        assert!(matches!(
            err.error,
            Error::MethodNonFinite { method: "rk4", step, .. } if step == err.partial.steps + 1
        ));
        assert_eq!(count, err.partial.steps + 1);
        assert!(err.partial.steps > 10 && err.partial.z[0] >= 0.0);
    }
}
