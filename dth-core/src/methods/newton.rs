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
//! [`Hamiltonian::STRUCTURED_NEWTON`] (generated types beyond the measured crossover), the
//! matrix is assembled from the Hessian's nonzeros and factored by the banded LU of
//! [`crate::structured`], held in the method's [`Structured`] storage (analysed on the first
//! step, reused without allocation after); no `D x D` matrix is formed. Otherwise it is the
//! dense fixed-size LU, in a function of its own so that its `D x D` stack frame exists only
//! when it runs. Both paths take the same iterations to the same stopping rule and agree to
//! roundoff (`tests/structured_newton.rs`).

use crate::hamiltonian::Alloc;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};
use std::cell::RefCell;

use super::newton_matrix;
use crate::linalg as linear;
use crate::newton::{self, Convergence, PEERS};
use crate::structured::NewtonMatrix;
use crate::{j_times, Error, Hamiltonian};

/// The structured Newton storage of a peer method: the analysed Newton matrix, built on the
/// first structured step (the only allocation, with a copy of the pattern) and reused while
/// the pattern (compared entry by entry: `O(nonzeros)`, less than evaluating them), the
/// dimension and the number of stages stay the same. A cache, not
/// part of the method's value: two methods compare equal whatever their storage holds.
#[derive(Clone, Debug, Default)]
pub(crate) struct Structured {
    matrix: Option<(Vec<(usize, usize)>, NewtonMatrix)>,
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

/// One Newton evaluation: the residual `F(x)` and the update `delta = A^{-1} F(x)` (`None` when
/// the matrix `A` is singular). The iterate moves to `x - delta`.
pub(crate) struct Evaluation<R: Dim, C: Dim>
where
    DefaultAllocator: Allocator<R, C>,
{
    pub residual: OMatrix<f64, R, C>,
    pub delta: Option<OMatrix<f64, R, C>>,
}

/// Solves `F(x) = 0` from `x0`; `scale` is the size of the state the unknowns belong to (see
/// [`NewtonOptions`]). Returns the solution and the number of iterations.
pub(crate) fn solve<R: Dim, C: Dim>(
    method: &'static str,
    options: &NewtonOptions,
    x0: OMatrix<f64, R, C>,
    scale: f64,
    evaluate: impl Fn(&OMatrix<f64, R, C>) -> Evaluation<R, C>,
) -> Result<(OMatrix<f64, R, C>, usize), Error>
where
    DefaultAllocator: Allocator<R, C>,
{
    let mut x = x0;
    let iterations = newton::solve(
        Convergence::new(PEERS, options.max_iterations),
        options.stall_tolerance,
        &mut x,
        |x, iteration| {
            let non_finite = |what| Error::MethodNonFinite {
                method,
                step: 0,
                what,
            };
            let Evaluation { residual, delta } = evaluate(x);
            let residual_norm = residual.amax();
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
            *x -= &delta;
            let size = delta.amax();
            if !size.is_finite() {
                return Err(non_finite("Newton update"));
            }
            Ok(size / scale.max(x.amax()).max(f64::MIN_POSITIVE))
        },
        |_| true,
        |x, iterations| Error::MethodNotConverged {
            method,
            step: 0,
            iterations,
            residual: evaluate(x).residual.amax(),
        },
    )?;
    Ok((x, iterations))
}

/// One step of a one-stage implicit method from `z0`: Newton on `F(z1) = 0` from the explicit
/// Euler predictor `z0 + dt J grad H(z0)`, with the matrix `I - (dt/2) J Hess H(y)` (structured
/// or dense, see the [module docs](self)). `equation(z1, grad H(z0))` returns `F(z1)` and the
/// point `y` (the midpoint `(z0 + z1)/2`, or `z1` for the trapezoidal rule). The Newton
/// iterations are added to `iterations`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn one_stage<H: Hamiltonian<D>, D: Dim>(
    method: &'static str,
    options: &NewtonOptions,
    iterations: &mut usize,
    structured: &mut Structured,
    h: &H,
    z0: &OVector<f64, D>,
    dt: f64,
    equation: impl Fn(&OVector<f64, D>, &OVector<f64, D>) -> (OVector<f64, D>, OVector<f64, D>),
) -> Result<OVector<f64, D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let g0 = h.gradient(z0);
    let predictor = z0 + j_times(&g0) * dt;
    let (z1, n) = match structured.matrix(h, 1) {
        Some(matrix) => {
            let matrix = RefCell::new(matrix);
            solve(method, options, predictor, z0.amax(), |z1| {
                let (residual, y) = equation(z1, &g0);
                let mut m = matrix.borrow_mut();
                h.hessian_nonzeros(&y, m.hessian_mut(0));
                let delta = m.factor(&[0.5 * dt]).ok().map(|()| {
                    let mut delta = residual.clone();
                    m.solve(delta.as_mut_slice());
                    delta
                });
                Evaluation { residual, delta }
            })?
        }
        None => one_stage_dense(method, options, h, z0, dt, predictor, &g0, &equation)?,
    };
    *iterations += n;
    Ok(z1)
}

/// [`one_stage`]'s Newton with the dense `D x D` matrix, in a frame of its own.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn one_stage_dense<H: Hamiltonian<D>, D: Dim>(
    method: &'static str,
    options: &NewtonOptions,
    h: &H,
    z0: &OVector<f64, D>,
    dt: f64,
    predictor: OVector<f64, D>,
    g0: &OVector<f64, D>,
    equation: &impl Fn(&OVector<f64, D>, &OVector<f64, D>) -> (OVector<f64, D>, OVector<f64, D>),
) -> Result<(OVector<f64, D>, usize), Error>
where
    DefaultAllocator: Alloc<D>,
{
    solve(method, options, predictor, z0.amax(), |z1| {
        let (residual, y) = equation(z1, g0);
        let delta = linear::solve(newton_matrix(0.5 * dt, &h.hessian(&y)), residual.clone());
        Evaluation { residual, delta }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector1;

    #[test]
    fn converges_to_roundoff_on_a_scalar_root() {
        // x^2 - 2 = 0 from 1: quadratic convergence to sqrt(2) within one ulp.
        let (x, iterations) = solve(
            "test",
            &NewtonOptions::default(),
            Vector1::new(1.0),
            1.0,
            |x| {
                let f = Vector1::new(x[0] * x[0] - 2.0);
                Evaluation {
                    residual: f,
                    delta: Some(f / (2.0 * x[0])),
                }
            },
        )
        .unwrap();
        assert!((x[0] - 2f64.sqrt()).abs() <= f64::EPSILON * 2f64.sqrt());
        assert!(iterations <= 8, "{iterations}");
    }

    #[test]
    fn no_root_is_reported_with_the_residual() {
        // x^2 + 1 = 0 has no real root: Newton wanders; it must not claim convergence.
        let err = solve(
            "test",
            &NewtonOptions::default(),
            Vector1::new(0.5),
            1.0,
            |x| {
                let f = Vector1::new(x[0] * x[0] + 1.0);
                Evaluation {
                    residual: f,
                    delta: Some(f / (2.0 * x[0])),
                }
            },
        )
        .unwrap_err();
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
        let err = solve(
            "test",
            &NewtonOptions::default(),
            Vector1::new(0.5),
            1.0,
            |x| Evaluation {
                residual: *x,
                delta: None,
            },
        )
        .unwrap_err();
        assert!(matches!(
            err,
            Error::MethodSingularMatrix { iteration: 1, residual, .. } if residual == 0.5
        ));
    }
}
