//! The 2-stage Gauss-Legendre collocation method.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, Dyn, OMatrix, OVector, U2};

use super::kept::Kept;
use super::newton::{self, NewtonOptions, Step, Structured};
use super::{check_step, OneStepMethod};
use crate::dense_newton::DenseNewton;
use crate::structured::NewtonMatrix;
use crate::{j_times_into, zeros, zeros_matrix, Error, Hamiltonian};

const S3: f64 = 0.288_675_134_594_812_9; // sqrt(3)/6
/// Butcher matrix `A` of the 2-stage Gauss method.
const A: [[f64; 2]; 2] = [[0.25, 0.25 - S3], [0.25 + S3, 0.25]];
/// Nodes `c`.
const C: [f64; 2] = [0.5 - S3, 0.5 + S3];

/// The 2-stage Gauss-Legendre Runge-Kutta method: order 4, symmetric, symplectic, conserves
/// quadratic invariants exactly.
///
/// Unknowns are the stage increments `Z_i = Y_i - z0` (a `D x 2` matrix), solved by full Newton
/// with the `2D x 2D` Jacobian `[delta_ij I - dt a_ij J Hess H(Y_j)]`: by block elimination (two
/// `D x D` factorizations: `B11 = I - a11 dt J Hess H(Y1)`, a one-stage Newton matrix factored
/// through its `D/2 x D/2` Schur complement when `H` is separable, and the Schur complement of
/// `B11` in the `2D x 2D` matrix, a general one, by the pivoted LU), or for large sparse
/// systems by the structured solver of `crate::structured` on the whole `2D x 2D` matrix (see
/// `methods::newton`). Predictor `Z_i = c_i dt J grad H(z0)`. The update is
/// `z1 = z0 + (dt/2) (f(Y1) + f(Y2))` with `f = J grad H` at the converged stages.
///
/// No allocation: a fixed dimension's buffers live on the stack (the dense `D x D` ones in a
/// frame of their own, only on the dense path); a `Dyn` dimension's are made on the first step
/// and kept in the method value.
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
    kept: Kept,
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
            kept: Kept::default(),
        }
    }
}

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for GaussLegendre2
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "gauss_legendre2";
    const ORDER: u32 = 4;

    fn step_into(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        check_step(h, z0, dt, z1)?;
        let (d, _) = z0.shape_generic();
        let n = d.value();
        let GaussLegendre2 {
            newton,
            iterations,
            structured,
            kept,
        } = self;
        let step = Step {
            method: <Self as OneStepMethod<D, H>>::NAME,
            options: newton,
            h,
            z0,
            dt,
        };
        let done = kept.with(
            d,
            || Work::new(d),
            || Box::new(Work::<Dyn>::new(Dyn(n))),
            |w: &Work<D>| w.stages.points.g.len() == n,
            |work| {
                let Work { stages, dense } = work;
                let done = match structured.matrix(h, 2) {
                    Some(m) => run(&step, stages, |p, delta| {
                        structured_update(h, dt, m, p, delta)
                    }),
                    None if D::try_to_usize().is_some() => dense_fixed(&step, stages),
                    None => {
                        let dense = dense.get_or_insert_with(|| Dense::boxed(d));
                        run(&step, stages, |p, delta| dense.update(h, dt, p, delta))
                    }
                }?;
                // z1 = z0 + (dt/2) (f(Y1) + f(Y2)) at the converged stages.
                let Stages { z, points, .. } = stages;
                points.slopes(h, z0, z);
                let f = &points.f;
                for i in 0..n {
                    z1[i] = z0[i] + (f[0][i] + f[1][i]) * (0.5 * dt);
                }
                Ok::<usize, Error>(done)
            },
        )?;
        *iterations += done;
        Ok(())
    }

    fn newton_iterations(&self) -> usize {
        self.iterations
    }
}

/// A step's storage: the Newton buffers, and for a `Dyn` dimension on the dense path the
/// block elimination's (boxed: a fixed dimension's live in a frame of their own).
struct Work<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    stages: Stages<D>,
    dense: Option<Box<Dense<D>>>,
}

impl<D: Dim> Work<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn new(d: D) -> Self {
        Work {
            stages: Stages {
                z: OMatrix::zeros_generic(d, U2),
                delta: OMatrix::zeros_generic(d, U2),
                points: Points {
                    y: [zeros(d), zeros(d)],
                    f: [zeros(d), zeros(d)],
                    r: [zeros(d), zeros(d)],
                    g: zeros(d),
                },
            },
            dense: None,
        }
    }
}

/// The Newton iterate (the stage increments `Z`, one column per stage), its update, and what
/// the residual writes.
struct Stages<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    z: OMatrix<f64, D, U2>,
    delta: OMatrix<f64, D, U2>,
    points: Points<D>,
}

/// At an iterate `Z`: the stage points `Y_i = z0 + Z_i`, the slopes `f_i = J grad H(Y_i)`, the
/// residual's columns `r_i = Z_i - dt sum_j a_ij f_j`, and a gradient.
struct Points<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    y: [OVector<f64, D>; 2],
    f: [OVector<f64, D>; 2],
    r: [OVector<f64, D>; 2],
    g: OVector<f64, D>,
}

impl<D: Dim> Points<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// The stage points and slopes at `z`.
    fn slopes<H: Hamiltonian<D>>(&mut self, h: &H, z0: &OVector<f64, D>, z: &OMatrix<f64, D, U2>) {
        for s in 0..2 {
            for i in 0..z0.len() {
                self.y[s][i] = z0[i] + z[(i, s)];
            }
            h.gradient_into(&self.y[s], &mut self.g);
            j_times_into(&self.g, &mut self.f[s]);
        }
    }

    /// The residual at `z`; its infinity norm.
    fn residual<H: Hamiltonian<D>>(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z: &OMatrix<f64, D, U2>,
    ) -> f64 {
        self.slopes(h, z0, z);
        let Points { f, r, .. } = self;
        for (s, r) in r.iter_mut().enumerate() {
            for i in 0..z0.len() {
                r[i] = z[(i, s)] - (f[0][i] * A[s][0] + f[1][i] * A[s][1]) * dt;
            }
        }
        r[0].amax().max(r[1].amax())
    }
}

/// Newton from the predictor `Z_i = c_i dt J grad H(z0)` with the linear solve
/// `update(points, delta)` (`false` when the matrix is singular); the iterations.
fn run<H: Hamiltonian<D>, D: Dim>(
    step: &Step<'_, H, D>,
    stages: &mut Stages<D>,
    mut update: impl FnMut(&Points<D>, &mut OMatrix<f64, D, U2>) -> bool,
) -> Result<usize, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let (h, z0, dt) = (step.h, step.z0, step.dt);
    let Stages { z, delta, points } = stages;
    h.gradient_into(z0, &mut points.g);
    j_times_into(&points.g, &mut points.f[0]);
    for (s, c) in C.iter().enumerate() {
        for i in 0..z0.len() {
            z[(i, s)] = points.f[0][i] * (c * dt);
        }
    }
    newton::solve(
        step.method,
        step.options,
        z0.amax(),
        z,
        delta,
        points,
        |z, p| p.residual(h, z0, dt, z),
        |_, p, delta| update(p, delta),
    )
}

/// [`run`] on the dense path with a fixed dimension, in a frame of its own (its `D x D`
/// storage).
#[inline(never)]
fn dense_fixed<H: Hamiltonian<D>, D: Dim>(
    step: &Step<'_, H, D>,
    stages: &mut Stages<D>,
) -> Result<usize, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut dense = Dense::new(step.z0.shape_generic().0);
    let (h, dt) = (step.h, step.dt);
    run(step, stages, |p, delta| dense.update(h, dt, p, delta))
}

/// The Newton update on the structured path: the whole `2D x 2D` matrix from the Hessians'
/// nonzeros (column-major `delta`: stage 1's increments, then stage 2's).
fn structured_update<H: Hamiltonian<D>, D: Dim>(
    h: &H,
    dt: f64,
    m: &mut NewtonMatrix,
    p: &Points<D>,
    delta: &mut OMatrix<f64, D, U2>,
) -> bool
where
    DefaultAllocator: Alloc<D>,
{
    h.hessian_nonzeros(&p.y[0], m.hessian_mut(0));
    h.hessian_nonzeros(&p.y[1], m.hessian_mut(1));
    let a = [A[0][0] * dt, A[0][1] * dt, A[1][0] * dt, A[1][1] * dt];
    if m.factor(&a).is_err() {
        return false;
    }
    delta.set_column(0, &p.r[0]);
    delta.set_column(1, &p.r[1]);
    m.solve(delta.as_mut_slice());
    true
}

/// The dense path's storage: `B11 = I - a11 dt J Hess H(Y1)` with its Hessian and
/// factorization (a one-stage Newton matrix: through its Schur complement for a separable `H`,
/// see [`crate::dense_newton`]; every solve with it precedes the factorization of the `2D x 2D`
/// system's Schur complement, a general matrix, which reuses its storage),
/// `K2 = dt J Hess H(Y2)`, `X = B11^-1 B12` (the Hessian at `Y2` before it) and three vectors:
/// four `D x D` matrices.
struct Dense<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    b11: DenseNewton<D>,
    k2: OMatrix<f64, D, D>,
    x: OMatrix<f64, D, D>,
    v: [OVector<f64, D>; 3],
}

impl<D: Dim> Dense<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn new(d: D) -> Self {
        Dense {
            b11: DenseNewton::new(d),
            k2: zeros_matrix(d),
            x: zeros_matrix(d),
            v: [zeros(d), zeros(d), zeros(d)],
        }
    }

    /// On the heap (for a `Dyn` dimension), made in a frame of its own: a caller generic over
    /// the dimension keeps no `D x D` temporary in its frame.
    #[inline(never)]
    fn boxed(d: D) -> Box<Self> {
        Box::new(Self::new(d))
    }

    /// The Newton update with the dense `2D x 2D` Jacobian by block elimination: with
    /// `B_ij = delta_ij I - a_ij K_j`, `X = B11^-1 B12`, `y = B11^-1 r1`,
    /// `d2 = (B22 - B21 X)^-1 (r2 - B21 y)`, `d1 = y - X d2`. `false` when `B11` or the Schur
    /// complement is singular or not finite.
    fn update<H: Hamiltonian<D>>(
        &mut self,
        h: &H,
        dt: f64,
        p: &Points<D>,
        delta: &mut OMatrix<f64, D, U2>,
    ) -> bool {
        let Dense { b11, k2, x, v } = self;
        let n = p.g.len();
        let half = n / 2;
        // (J Hess)_ij.
        let jh = |hessian: &OMatrix<f64, D, D>, i: usize, j: usize| {
            if i < half {
                hessian[(i + half, j)]
            } else {
                -hessian[(i - half, j)]
            }
        };
        b11.hessian_at(h, &p.y[0]);
        h.hessian_into(&p.y[1], x);
        for j in 0..n {
            for i in 0..n {
                k2[(i, j)] = jh(x, i, j) * dt;
            }
        }
        let k2 = &*k2;
        let identity = |i: usize, j: usize| if i == j { 1.0 } else { 0.0 };
        if b11.factor(A[0][0] * dt).is_err() {
            return false;
        }
        let [y, b, s] = v;
        for j in 0..n {
            for i in 0..n {
                b[i] = -k2[(i, j)] * A[0][1];
            }
            b11.solve_into(b, s);
            x.set_column(j, s);
        }
        b11.solve_into(&p.r[0], y);
        // The last solve with B11: its factorization's storage takes the Schur complement's.
        let (hessian1, lu) = b11.hessian_and_spare_lu();
        // B21 = -a21 K1, K1 = dt J Hess H(Y1).
        let b21 = |i: usize, l: usize| -(jh(hessian1, i, l) * dt) * A[1][0];
        let schur = |i: usize, j: usize| {
            let b21_x = (0..n).fold(0.0, |acc, l| acc + b21(i, l) * x[(l, j)]);
            (identity(i, j) - k2[(i, j)] * A[1][1]) - b21_x
        };
        if lu.factor_from(schur).is_err() {
            return false;
        }
        for i in 0..n {
            b[i] = p.r[1][i] - (0..n).fold(0.0, |acc, l| acc + b21(i, l) * y[l]);
        }
        lu.solve_into(b, s);
        for i in 0..n {
            delta[(i, 0)] = y[i] - (0..n).fold(0.0, |acc, l| acc + x[(i, l)] * s[l]);
            delta[(i, 1)] = s[i];
        }
        true
    }
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
