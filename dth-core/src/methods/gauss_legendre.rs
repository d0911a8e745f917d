//! The 2-stage Gauss-Legendre collocation method.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector, U2};
use std::cell::RefCell;

use super::newton::{self, Evaluation, NewtonOptions, Structured};
use super::{j_times_matrix, OneStepMethod};
use crate::linalg as linear;
use crate::{j_times, Error, Hamiltonian};

const S3: f64 = 0.288_675_134_594_812_9; // sqrt(3)/6
/// Butcher matrix `A` of the 2-stage Gauss method.
const A: [[f64; 2]; 2] = [[0.25, 0.25 - S3], [0.25 + S3, 0.25]];
/// Nodes `c`.
const C: [f64; 2] = [0.5 - S3, 0.5 + S3];

/// The 2-stage Gauss-Legendre Runge-Kutta method: order 4, symmetric, symplectic, conserves
/// quadratic invariants exactly.
///
/// Unknowns are the stage increments `Z_i = Y_i - z0` (a `D x 2` matrix), solved by full Newton
/// with the `2D x 2D` Jacobian `[delta_ij I - dt a_ij J Hess H(Y_j)]`: by block elimination (three
/// `D x D` LU solves, no heap), or for large sparse systems by the structured solver of
/// `crate::structured` on the whole `2D x 2D` matrix (see `methods::newton`). Predictor `Z_i = c_i dt J grad H(z0)`. The update is
/// `z1 = z0 + (dt/2) (f(Y1) + f(Y2))` with `f = J grad H` at the converged stages.
///
/// # References
/// E. Hairer, C. Lubich, G. Wanner, *Geometric Numerical Integration*, Table II.1.1 (Gauss
/// methods), Theorem VI.4.3 (symplectic), Theorem IV.2.2 (quadratic invariants), Section VIII.6
/// (implementation by stage increments).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GaussLegendre2 {
    /// Newton settings.
    pub newton: NewtonOptions,
    iterations: usize,
    structured: Structured,
}

impl GaussLegendre2 {
    /// With default Newton settings.
    pub fn new() -> Self {
        Self::default()
    }

    /// With the given Newton settings.
    pub fn with_newton(newton: NewtonOptions) -> Self {
        GaussLegendre2 {
            newton,
            iterations: 0,
            structured: Structured::default(),
        }
    }
}

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for GaussLegendre2
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "gauss_legendre2";
    const ORDER: u32 = 4;

    /// Allocates on a `Dyn` dimension (its Newton iterates are values); a fixed one's live on
    /// the stack.
    fn step_into(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        let f0 = j_times(&h.gradient(z0));
        let predictor =
            OMatrix::<f64, D, U2>::from_columns(&[&f0 * (C[0] * dt), &f0 * (C[1] * dt)]);
        let matrix = self.structured.matrix(h, 2).map(RefCell::new);
        let (stages, iterations) = newton::solve(
            <Self as OneStepMethod<D, H>>::NAME,
            &self.newton,
            predictor,
            z0.amax(),
            |z| {
                let y1 = z0 + z.column(0);
                let y2 = z0 + z.column(1);
                let f1 = j_times(&h.gradient(&y1));
                let f2 = j_times(&h.gradient(&y2));
                let r1 = z.column(0) - (&f1 * A[0][0] + &f2 * A[0][1]) * dt;
                let r2 = z.column(1) - (&f1 * A[1][0] + &f2 * A[1][1]) * dt;
                let residual = OMatrix::<f64, D, U2>::from_columns(&[r1.clone(), r2.clone()]);
                let delta = match &matrix {
                    Some(m) => {
                        let mut m = m.borrow_mut();
                        h.hessian_nonzeros(&y1, m.hessian_mut(0));
                        h.hessian_nonzeros(&y2, m.hessian_mut(1));
                        let a = [A[0][0] * dt, A[0][1] * dt, A[1][0] * dt, A[1][1] * dt];
                        m.factor(&a).ok().map(|()| {
                            // Column-major: stage 1's increments, then stage 2's.
                            let mut delta = residual.clone();
                            m.solve(delta.as_mut_slice());
                            delta
                        })
                    }
                    None => dense_update(h, &y1, &y2, dt, &r1, &r2),
                };
                Evaluation { residual, delta }
            },
        )?;
        self.iterations += iterations;
        let f1 = j_times(&h.gradient(&(z0 + stages.column(0))));
        let f2 = j_times(&h.gradient(&(z0 + stages.column(1))));
        *z1 = z0 + (f1 + f2) * (0.5 * dt);
        Ok(())
    }

    fn newton_iterations(&self) -> usize {
        self.iterations
    }
}

/// The Newton update with the dense `2D x 2D` Jacobian by block elimination (three `D x D`
/// LU solves), in a frame of its own (see `methods::newton`).
#[inline(never)]
fn dense_update<H: Hamiltonian<D>, D: Dim>(
    h: &H,
    y1: &OVector<f64, D>,
    y2: &OVector<f64, D>,
    dt: f64,
    r1: &OVector<f64, D>,
    r2: &OVector<f64, D>,
) -> Option<OMatrix<f64, D, U2>>
where
    DefaultAllocator: Alloc<D>,
{
    let (d, _) = y1.shape_generic();
    let identity = OMatrix::<f64, D, D>::identity_generic(d, d);
    let k1 = j_times_matrix(&h.hessian(y1)) * dt;
    let k2 = j_times_matrix(&h.hessian(y2)) * dt;
    let b11 = &identity - &k1 * A[0][0];
    let b12 = -&k2 * A[0][1];
    let b21 = -&k1 * A[1][0];
    let b22 = &identity - &k2 * A[1][1];
    let x = linear::solve(b11.clone(), b12)?;
    let y = linear::solve(b11, r1.clone())?;
    let d2 = linear::solve(b22 - &b21 * &x, r2 - &b21 * &y)?;
    let d1 = y - x * &d2;
    Some(OMatrix::<f64, D, U2>::from_columns(&[d1, d2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn butcher_tableau_satisfies_the_order_4_simplifying_conditions() {
        // C(2): sum_j a_ij = c_i, sum_j a_ij c_j = c_i^2 / 2; sqrt(3)/6 to the last digit.
        assert!((S3 - 3f64.sqrt() / 6.0).abs() <= f64::EPSILON);
        for i in 0..2 {
            assert!((A[i][0] + A[i][1] - C[i]).abs() <= 2.0 * f64::EPSILON);
            let ac = A[i][0] * C[0] + A[i][1] * C[1];
            assert!((ac - 0.5 * C[i] * C[i]).abs() <= 2.0 * f64::EPSILON);
        }
    }
}
