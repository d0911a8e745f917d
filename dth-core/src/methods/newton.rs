//! The Newton iteration of the implicit peer methods: [`NewtonOptions`], the peers' adapter of
//! the crate's Newton loop, and the one-stage step shared by the midpoint, trapezoidal,
//! discrete-gradient and discrete-mechanics methods.
//!
//! Newton stops by the crate's one stopping rule (`crate::newton`, where it is documented) with
//! the peers' parameters, summarised for users on [`NewtonOptions`].
//!
//! # Two linear solvers
//! Each Newton iteration solves with `I - (dt/2) J Hess` (one stage) or the `2D x 2D`
//! Gauss-Legendre matrix. For a Hamiltonian that declares its Hessian pattern and sets
//! [`Flags::structured_newton`](crate::Flags::structured_newton) (generated types beyond the measured crossover), the
//! matrix is assembled from the Hessian's nonzeros and factored by the banded LU of
//! [`crate::structured`], held in the method's [`Structured`] storage (analysed on the first
//! step, reused without allocation after); no `D x D` matrix is formed. Otherwise it is the
//! dense fixed-size LU, in a function of its own so that its `D x D` stack frame exists only
//! when it runs. Both paths take the same iterations to the same stopping rule and agree to
//! roundoff (`tests/structured_newton.rs`).

use crate::hamiltonian::Alloc;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, Dyn, OMatrix, OVector};
use std::any::Any;

use crate::dense_newton::DenseNewton;
use crate::newton::{self, Convergence, PEERS};
use crate::structured::NewtonMatrix;
use crate::{j_times_into, zeros, Error, Hamiltonian};

/// The structured Newton storage of a peer method: the analysed Newton matrix, built on the
/// first structured step (the only allocation, with a copy of the pattern) and reused while
/// the pattern (compared entry by entry: `O(nonzeros)`, less than evaluating them), the
/// dimension and the number of stages stay the same. A cache, not
/// part of the method's value: two methods compare equal whatever their storage holds. A
/// clone copies it, so that it steps without allocating as the original does (the DTH
/// stepper's robust mode reserves its fallback buffers in `Dth::new` and must not allocate
/// them on a clone's first fallback step).
#[derive(Default)]
pub(crate) struct Structured {
    matrix: Option<(Vec<(usize, usize)>, NewtonMatrix)>,
    /// A dynamic dimension's Newton buffers (see [`one_stage`]), kept between steps.
    buffers: Option<Box<Kept<Dyn>>>,
}

impl Clone for Structured {
    /// The analysed matrix and the buffers.
    fn clone(&self) -> Self {
        Structured {
            matrix: self.matrix.clone(),
            buffers: self.buffers.clone(),
        }
    }
}

impl std::fmt::Debug for Structured {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Structured")
            .field("matrix", &self.matrix)
            .finish_non_exhaustive()
    }
}

impl PartialEq for Structured {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Structured {
    /// The Newton matrix for `stages` stages of `H`, analysed if this storage holds none for
    /// it; `None` when `H` takes the dense path (no pattern, or not
    /// [`Flags::structured_newton`](crate::Flags::structured_newton)).
    pub(crate) fn matrix<H: Hamiltonian<D>, D: Dim>(
        &mut self,
        ham: &H,
        stages: usize,
    ) -> Option<&mut NewtonMatrix>
    where
        DefaultAllocator: Alloc<D>,
    {
        if !ham.flags().structured_newton {
            return None;
        }
        let pattern = ham.hessian_pattern()?;
        let d = ham.dim().value();
        let fits = self
            .matrix
            .as_ref()
            .is_some_and(|(p, m)| p.as_slice() == pattern && m.fits(d, stages, pattern.len()));
        if !fits {
            // A generated pattern is valid by construction; a hand-written one that is not
            // falls back to the dense path.
            self.matrix = NewtonMatrix::analyse(d, stages, pattern)
                .ok()
                .map(|m| (pattern.to_vec(), m));
        }
        self.matrix.as_mut().map(|(_, m)| m)
    }

    /// A dynamic dimension's one-stage Newton buffers for `H`, allocated now rather than on
    /// the first step (nothing to do for a fixed dimension): for callers that must not
    /// allocate once they run, such as the DTH stepper's robust mode, whose first fallback
    /// step may come at any step.
    pub(crate) fn reserve<H: Hamiltonian<D>, D: Dim>(&mut self, h: &H)
    where
        DefaultAllocator: Alloc<D>,
    {
        if D::try_to_usize().is_some() {
            return;
        }
        let d = h.dim();
        let dense = self.matrix(h, 1).is_none().then(|| DenseNewton::new(d));
        let kept = Box::new(Kept {
            stage: OneStage::new(d),
            dense,
        });
        self.buffers = (kept as Box<dyn Any>).downcast::<Kept<Dyn>>().ok();
    }
}

/// Settings of the Newton iteration of the implicit peer methods.
///
/// Newton measures each update relative to the state (`|delta|_inf` over the larger of
/// `|x|_inf` and the size of the step's initial state) and stops with success when an update
/// is zero, when the error left after it, estimated from the observed contraction, is below
/// `eps / 1024`, or when updates no longer halve below
/// [`stall_tolerance`](Self::stall_tolerance): a returned value is converged to roundoff.
/// Linearly converging iterations (the discrete-gradient and discrete-mechanics methods) are
/// thus run to the noise floor, so that their remainder does not drift the invariants. Updates
/// that stop shrinking above `stall_tolerance` are not accepted: the step fails with
/// [`Error::MethodNotConverged`] at `max_iterations`, reporting the residual. A failed linear
/// solve is [`Error::MethodSingularMatrix`], a NaN or infinity [`Error::MethodNonFinite`].
///
/// ```
/// use dth_core::methods::NewtonOptions;
/// let opts = NewtonOptions::default().with_max_iterations(100)?;
/// assert_eq!(opts.max_iterations, 100);
/// assert!(NewtonOptions::default().with_stall_tolerance(0.1).is_err());
/// # Ok::<(), dth_core::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct NewtonOptions {
    /// Iteration limit per step; default 50.
    pub max_iterations: usize,
    /// Relative update size below which updates that no longer halve count as stalled at
    /// roundoff, i.e. converged; default `1024 eps` (about `2.3e-13`).
    pub stall_tolerance: f64,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            max_iterations: 50,
            stall_tolerance: 1024.0 * f64::EPSILON,
        }
    }
}

impl NewtonOptions {
    /// Sets the iteration limit (at least 1).
    pub fn with_max_iterations(mut self, max_iterations: usize) -> Result<Self, Error> {
        if max_iterations == 0 {
            return Err(Error::InvalidOption {
                name: "max_iterations",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        self.max_iterations = max_iterations;
        Ok(self)
    }

    /// Sets the stall tolerance, in `[4 eps, 1e-8]`: looser would accept unconverged iterates.
    pub fn with_stall_tolerance(mut self, stall_tolerance: f64) -> Result<Self, Error> {
        if !(4.0 * f64::EPSILON..=1e-8).contains(&stall_tolerance) {
            return Err(Error::InvalidOption {
                name: "stall_tolerance",
                value: stall_tolerance,
                reason: "must lie in [4 eps, 1e-8]",
            });
        }
        self.stall_tolerance = stall_tolerance;
        Ok(self)
    }
}

/// One Newton iteration's update for the peer methods, after the residual (infinity norm
/// `residual_norm`) and the Newton step `delta` (`None`: the matrix was singular) are known:
/// `x -= delta`, with the checks both peer solvers make, in this order (a non-finite residual,
/// a singular matrix, a non-finite update). Returns the update's size relative to `scale` and
/// `x`, what [`newton::solve`] tests for convergence.
fn update<R: Dim, C: Dim>(
    method: &'static str,
    iteration: usize,
    residual_norm: f64,
    x: &mut OMatrix<f64, R, C>,
    delta: Option<&OMatrix<f64, R, C>>,
    scale: f64,
) -> Result<f64, Error>
where
    DefaultAllocator: Allocator<R, C>,
{
    let non_finite = |what| Error::MethodNonFinite {
        method,
        step: 0,
        what,
    };
    if !residual_norm.is_finite() {
        return Err(non_finite("Newton residual"));
    }
    let Some(delta) = delta else {
        return Err(Error::MethodSingularMatrix {
            method,
            step: 0,
            iteration,
            residual: residual_norm,
        });
    };
    *x -= delta;
    let size = delta.amax();
    if !size.is_finite() {
        return Err(non_finite("Newton update"));
    }
    Ok(size / scale.max(x.amax()).max(f64::MIN_POSITIVE))
}

/// Solves `F(x) = 0` by Newton from the `x` given, in place, with the caller's buffers: the
/// update `delta` and the `work` storage of the equation. `residual(x, work)` writes `F(x)`
/// into `work` and returns its infinity norm; `solve(x, work, delta)` then writes the update
/// `A^{-1} F(x)` into `delta`, `false` when the matrix `A` is singular (called only at a
/// finite residual). The iterate moves to `x - delta`. `scale` is the size of the state the
/// unknowns belong to (see [`NewtonOptions`]). Returns the number of iterations.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve<R: Dim, C: Dim, W>(
    method: &'static str,
    options: &NewtonOptions,
    scale: f64,
    x: &mut OMatrix<f64, R, C>,
    delta: &mut OMatrix<f64, R, C>,
    work: &mut W,
    residual: impl Fn(&OMatrix<f64, R, C>, &mut W) -> f64,
    mut solve: impl FnMut(&OMatrix<f64, R, C>, &mut W, &mut OMatrix<f64, R, C>) -> bool,
) -> Result<usize, Error>
where
    DefaultAllocator: Allocator<R, C>,
{
    let mut state = (x, delta, work);
    newton::solve(
        Convergence::new(PEERS, options.max_iterations),
        options.stall_tolerance,
        &mut state,
        |(x, delta, work), iteration| {
            let residual_norm = residual(x, work);
            // Solve only at a finite residual (`update` reports a non-finite one first).
            let solved = residual_norm.is_finite() && solve(x, work, delta);
            update(
                method,
                iteration,
                residual_norm,
                x,
                solved.then_some(&**delta),
                scale,
            )
        },
        |_| true,
        |(x, _, work), iterations| Error::MethodNotConverged {
            method,
            step: 0,
            iterations,
            // A failure: the residual at the last iterate.
            residual: residual(x, work),
        },
    )
}

/// The buffers of one Newton iterate of a one-stage method, which its equation fills:
/// `residual = F(z1)`, the point `y` where the Newton matrix's Hessian is taken, and a
/// scratch vector for the equation's own use (a gradient).
#[derive(Clone)]
pub(crate) struct Residual<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    pub(crate) residual: OVector<f64, D>,
    pub(crate) y: OVector<f64, D>,
    pub(crate) scratch: OVector<f64, D>,
}

impl<D: Dim> Residual<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn new(d: D) -> Self {
        Residual {
            residual: zeros(d),
            y: zeros(d),
            scratch: zeros(d),
        }
    }
}

/// Everything a one-stage step writes besides the Hessian: `grad H(z0)`, the iterate's
/// [`Residual`] and the Newton update.
#[derive(Clone)]
struct OneStage<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    g0: OVector<f64, D>,
    r: Residual<D>,
    delta: OVector<f64, D>,
}

impl<D: Dim> OneStage<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn new(d: D) -> Self {
        OneStage {
            g0: zeros(d),
            r: Residual::new(d),
            delta: zeros(d),
        }
    }
}

/// A dynamic dimension's buffers, kept in the method's [`Structured`] storage between steps.
#[derive(Clone)]
struct Kept<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    stage: OneStage<D>,
    dense: Option<DenseNewton<D>>,
}

/// One step of a one-stage implicit method from `z0` into `z1`: Newton on `F(z1) = 0` from the
/// explicit Euler predictor `z0 + dt J grad H(z0)`, with the matrix `I - (dt/2) J Hess H(y)`
/// (structured or dense, see the [module docs](self)). `equation(z1, grad H(z0), r)` writes
/// `F(z1)` and the point `y` (the midpoint `(z0 + z1)/2`, or `z1` for the trapezoidal rule)
/// into `r`. The Newton iterations are added to `iterations`.
///
/// No allocation: a fixed dimension's buffers live in this frame (the dense `D x D` ones in a
/// frame of their own, only on the dense path); a dynamic dimension's are allocated on the
/// method's first step and kept in `structured` (a cache: reallocated when the dimension
/// changes).
#[allow(clippy::too_many_arguments)]
pub(crate) fn one_stage<H: Hamiltonian<D>, D: Dim>(
    method: &'static str,
    options: &NewtonOptions,
    iterations: &mut usize,
    structured: &mut Structured,
    h: &H,
    z0: &OVector<f64, D>,
    dt: f64,
    z1: &mut OVector<f64, D>,
    equation: impl Fn(&OVector<f64, D>, &OVector<f64, D>, &mut Residual<D>),
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    super::check_step(h, z0, dt, z1)?;
    let (d, _) = z0.shape_generic();
    let solve = Solve {
        step: Step {
            method,
            options,
            h,
            z0,
            dt,
        },
        equation: &equation,
    };
    let n = if D::try_to_usize().is_some() {
        let mut stage = OneStage::new(d);
        match structured.matrix(h, 1) {
            Some(matrix) => solve.structured(matrix, &mut stage, z1)?,
            None => solve.dense_fixed(&mut stage, z1)?,
        }
    } else {
        // `D` is `Dyn` here: the kept box is the same type, seen through `Any`.
        let kept = structured
            .buffers
            .take()
            .and_then(|b| (b as Box<dyn Any>).downcast::<Kept<D>>().ok());
        let mut kept = match kept {
            Some(k) if k.stage.g0.len() == d.value() => k,
            _ => Box::new(Kept {
                stage: OneStage::new(d),
                dense: None,
            }),
        };
        let Kept { stage, dense } = &mut *kept;
        let result = match structured.matrix(h, 1) {
            Some(matrix) => solve.structured(matrix, stage, z1),
            None => {
                let dense = dense.get_or_insert_with(|| DenseNewton::new(d));
                solve.run(stage, z1, |y, residual, delta| {
                    dense.solve_at(h, y, 0.5 * dt, residual, delta).is_ok()
                })
            }
        };
        structured.buffers = (kept as Box<dyn Any>).downcast::<Kept<Dyn>>().ok();
        result?
    };
    *iterations += n;
    Ok(())
}

/// `out = z1 - z0 - (J g) c`, entry by entry as the vector expression computes it.
pub(crate) fn residual_minus_j<D: Dim>(
    z1: &OVector<f64, D>,
    z0: &OVector<f64, D>,
    g: &OVector<f64, D>,
    c: f64,
    out: &mut OVector<f64, D>,
) where
    DefaultAllocator: Alloc<D>,
{
    let n = z1.len() / 2;
    for i in 0..z1.len() {
        let jg = if i < n { g[i + n] } else { -g[i - n] };
        out[i] = (z1[i] - z0[i]) - jg * c;
    }
}

/// What a step's Newton solve needs besides its buffers and its equation.
pub(crate) struct Step<'a, H, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The method's name, for errors.
    pub(crate) method: &'static str,
    pub(crate) options: &'a NewtonOptions,
    pub(crate) h: &'a H,
    /// The state the step starts from.
    pub(crate) z0: &'a OVector<f64, D>,
    pub(crate) dt: f64,
}

/// A one-stage Newton solve: the step and its equation.
struct Solve<'a, H, D: Dim, E>
where
    DefaultAllocator: Alloc<D>,
{
    step: Step<'a, H, D>,
    equation: &'a E,
}

impl<H: Hamiltonian<D>, D: Dim, E> Solve<'_, H, D, E>
where
    DefaultAllocator: Alloc<D>,
    E: Fn(&OVector<f64, D>, &OVector<f64, D>, &mut Residual<D>),
{
    /// On the structured path.
    fn structured(
        &self,
        m: &mut NewtonMatrix,
        stage: &mut OneStage<D>,
        z1: &mut OVector<f64, D>,
    ) -> Result<usize, Error> {
        let (h, c) = (self.step.h, 0.5 * self.step.dt);
        self.run(stage, z1, |y, residual, delta| {
            h.hessian_nonzeros(y, m.hessian_mut(0));
            if m.factor(&[c]).is_err() {
                return false;
            }
            delta.copy_from(residual);
            m.solve(delta.as_mut_slice());
            true
        })
    }

    /// On the dense path with a fixed dimension, in a frame of its own (its `D x D` storage).
    #[inline(never)]
    fn dense_fixed(
        &self,
        stage: &mut OneStage<D>,
        z1: &mut OVector<f64, D>,
    ) -> Result<usize, Error> {
        let mut dense = DenseNewton::new(self.step.z0.shape_generic().0);
        let (h, c) = (self.step.h, 0.5 * self.step.dt);
        self.run(stage, z1, |y, residual, delta| {
            dense.solve_at(h, y, c, residual, delta).is_ok()
        })
    }

    /// Newton from the predictor with the linear solve `linear(y, residual, delta)` (`false`
    /// when the matrix is singular); the iterations.
    fn run(
        &self,
        stage: &mut OneStage<D>,
        z1: &mut OVector<f64, D>,
        mut linear: impl FnMut(&OVector<f64, D>, &OVector<f64, D>, &mut OVector<f64, D>) -> bool,
    ) -> Result<usize, Error> {
        let (method, z0, dt) = (self.step.method, self.step.z0, self.step.dt);
        let OneStage { g0, r, delta } = stage;
        self.step.h.gradient_into(z0, g0);
        // The predictor z0 + (J g0) dt.
        j_times_into(g0, &mut r.scratch);
        for i in 0..z1.len() {
            z1[i] = z0[i] + r.scratch[i] * dt;
        }
        let g0 = &*g0;
        solve(
            method,
            self.step.options,
            z0.amax(),
            z1,
            delta,
            r,
            |x, r| {
                (self.equation)(x, g0, r);
                r.residual.amax()
            },
            |_, r, delta| linear(&r.y, &r.residual, delta),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector1;

    /// Newton on the scalar `f(x) = 0` from `x0` with derivative `df`, its residual kept in
    /// the work storage; `None` for the update makes the matrix singular.
    fn scalar(
        x0: f64,
        f: impl Fn(f64) -> f64,
        df: impl Fn(f64) -> Option<f64>,
    ) -> Result<(f64, usize), Error> {
        let (mut x, mut delta, mut fx) = (Vector1::new(x0), Vector1::zeros(), 0.0);
        let iterations = solve(
            "test",
            &NewtonOptions::default(),
            1.0,
            &mut x,
            &mut delta,
            &mut fx,
            |x, fx| {
                *fx = f(x[0]);
                fx.abs()
            },
            |x, fx, delta| df(x[0]).map(|d| delta[0] = *fx / d).is_some(),
        )?;
        Ok((x[0], iterations))
    }

    #[test]
    fn converges_to_roundoff_on_a_scalar_root() {
        // x^2 - 2 = 0 from 1: quadratic convergence to sqrt(2) within one ulp.
        let (x, iterations) = scalar(1.0, |x| x * x - 2.0, |x| Some(2.0 * x)).unwrap();
        assert!((x - 2f64.sqrt()).abs() <= f64::EPSILON * 2f64.sqrt());
        assert!(iterations <= 8, "{iterations}");
    }

    #[test]
    fn no_root_is_reported_with_the_residual() {
        // x^2 + 1 = 0 has no real root: Newton wanders; it must not claim convergence.
        let err = scalar(0.5, |x| x * x + 1.0, |x| Some(2.0 * x)).unwrap_err();
        match err {
            Error::MethodNotConverged {
                iterations,
                residual,
                ..
            } => {
                assert_eq!(iterations, 50);
                assert!(residual >= 1.0);
            }
            Error::MethodNonFinite { .. } => {}
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn singular_matrix_is_a_typed_error() {
        let err = scalar(0.5, |x| x, |_| None).unwrap_err();
        assert!(matches!(
            err,
            Error::MethodSingularMatrix { iteration: 1, residual, .. } if residual == 0.5
        ));
    }
}
