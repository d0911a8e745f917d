//! The linear algebra of the DTH Newton solvers behind one interface ([`Linear`]): the dense
//! fixed-size LU of `crate::linalg` for small `D`, or the structured
//! [`NewtonMatrix`](crate::structured::NewtonMatrix) for Hamiltonians that declare their
//! Hessian pattern and set [`Flags::structured_newton`](crate::Flags::structured_newton) (the peers' rule: generated types
//! beyond the measured crossover).
//!
//! Both solvers need from `A = I - c J Hess H(z)` (`c = h lambda / 2`) only a factorization,
//! solves, and the product `Hess z_lambda` for `g_lambda` (see `dth::newton`); and from `H` its
//! value, gradient and `Psi` ([`Point`]). On the structured path the Hessian is evaluated as its
//! nonzeros straight into the matrix's storage (`Hamiltonian::hessian_nonzeros`), value,
//! gradient and `Psi` by their own generated programs, so that no `D x D` matrix exists: the
//! stepper at `D = 1024` runs on a 2 MB stack. The dense path evaluates all four through the
//! fused `Hamiltonian::derivatives_into` (one program, shared subexpressions) into its kept
//! storage ([`Dense`], held by the stepper's workspace on the heap), and factors `A` through
//! its Schur complement when `H` is separable (half the dimension; see
//! [`crate::dense_newton`]).
//!
//! Every operation writes into the caller's storage: after the first step, which boxes the
//! dense path's storage, nothing here allocates, for `Const<N>` or `Dyn` dimensions alike.

use crate::hamiltonian::Alloc;
pub(crate) use crate::linalg::largest;
use crate::linalg::Pivot;
use crate::methods::Structured;
use crate::structured::NewtonMatrix;
use crate::Hamiltonian;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// `H`'s value, gradient and `Psi` at one point, and the size of its Hessian.
#[derive(Clone, Debug)]
pub(crate) struct Point<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `H(z)`.
    pub(crate) value: f64,
    /// `grad H(z)`.
    pub(crate) gradient: OVector<f64, D>,
    /// `Psi(z) = (J grad H)^T Hess H (J grad H)`.
    pub(crate) psi: f64,
    /// `max |Hess H(z)_ij|`; NaN when an entry is not finite.
    pub(crate) hessian_max: f64,
}

impl<D: Dim> Point<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Whether the value and the gradient are finite.
    pub(crate) fn finite(&self) -> bool {
        self.value.is_finite() && self.gradient.iter().all(|x| x.is_finite())
    }

    /// Whether every Hessian entry is finite.
    pub(crate) fn hessian_finite(&self) -> bool {
        self.hessian_max.is_finite()
    }
}

impl<D: Dim> Point<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Zeros of dimension `d`: storage for [`Linear::evaluate`].
    pub(crate) fn zeros(d: D) -> Self {
        Point {
            value: 0.0,
            gradient: crate::zeros(d),
            psi: 0.0,
            hessian_max: 0.0,
        }
    }
}

/// What the DTH Newton solvers need of `A = I - c J Hess H(z)` at their iterate.
pub(crate) trait Linear<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Evaluate `H` at `z` into `out` and keep its Hessian for [`factor`](Self::factor) and
    /// [`hessian_times_into`](Self::hessian_times_into) (the factorization is kept until the
    /// next `factor`).
    fn evaluate<H: Hamiltonian<D>>(&mut self, ham: &H, z: &OVector<f64, D>, out: &mut Point<D>);
    /// Factor `A = I - c J Hess` with the Hessian last evaluated.
    fn factor(&mut self, c: f64) -> Result<(), Pivot>;
    /// `x = A^{-1} b` with the last factorization (`x` and `b` distinct).
    fn solve_into(&mut self, b: &OVector<f64, D>, x: &mut OVector<f64, D>);
    /// `out = Hess x` with the Hessian last evaluated.
    fn hessian_times_into(&self, x: &OVector<f64, D>, out: &mut OVector<f64, D>);
    /// `sum_ij |x_i Hess_ij x_j|` with the Hessian last evaluated.
    fn hessian_abs_form(&self, x: &OVector<f64, D>) -> f64;
}

/// The dense path: the fused evaluation's derivatives and the factorization of `A` (through
/// the Schur complement for a separable `H`, see [`crate::dense_newton`]).
pub(crate) use crate::dense_newton::DenseNewton as Dense;

impl<D: Dim> Linear<D> for Dense<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn evaluate<H: Hamiltonian<D>>(&mut self, ham: &H, z: &OVector<f64, D>, out: &mut Point<D>) {
        let d = self.derivatives_at(ham, z);
        out.value = d.value;
        out.gradient.copy_from(&d.gradient);
        out.psi = d.psi;
        out.hessian_max = largest(d.hessian.as_slice());
    }

    fn factor(&mut self, c: f64) -> Result<(), Pivot> {
        Dense::factor(self, c)
    }

    fn solve_into(&mut self, b: &OVector<f64, D>, x: &mut OVector<f64, D>) {
        Dense::solve_into(self, b, x);
    }

    fn hessian_times_into(&self, x: &OVector<f64, D>, out: &mut OVector<f64, D>) {
        self.derivatives().hessian.mul_to(x, out);
    }

    fn hessian_abs_form(&self, x: &OVector<f64, D>) -> f64 {
        let hessian = &self.derivatives().hessian;
        let mut sum = 0.0;
        for j in 0..x.len() {
            for i in 0..x.len() {
                sum += (x[i] * hessian[(i, j)] * x[j]).abs();
            }
        }
        sum
    }
}

/// The structured path: the analysed [`NewtonMatrix`] of the stepper.
pub(crate) struct Sparse<'a> {
    pub(crate) matrix: &'a mut NewtonMatrix,
}

impl<D: Dim> Linear<D> for Sparse<'_>
where
    DefaultAllocator: Alloc<D>,
{
    fn evaluate<H: Hamiltonian<D>>(&mut self, ham: &H, z: &OVector<f64, D>, out: &mut Point<D>) {
        let nonzeros = self.matrix.hessian_mut(0);
        ham.hessian_nonzeros(z, nonzeros);
        out.hessian_max = largest(nonzeros);
        out.value = ham.value(z);
        ham.gradient_into(z, &mut out.gradient);
        out.psi = ham.psi(z);
    }

    fn factor(&mut self, c: f64) -> Result<(), Pivot> {
        self.matrix.factor(&[c])
    }

    fn solve_into(&mut self, b: &OVector<f64, D>, x: &mut OVector<f64, D>) {
        x.copy_from(b);
        self.matrix.solve(x.as_mut_slice());
    }

    fn hessian_times_into(&self, x: &OVector<f64, D>, out: &mut OVector<f64, D>) {
        self.matrix
            .hessian_times(0, x.as_slice(), out.as_mut_slice());
    }

    fn hessian_abs_form(&self, x: &OVector<f64, D>) -> f64 {
        self.matrix.hessian_abs_form(0, x.as_slice())
    }
}

/// The linear algebra of a stepper, chosen once per Hamiltonian: its structured Newton matrix
/// (analysed on first use and kept in `storage`, the peers' rule and cache) when `H` takes that
/// path, else the dense storage, created on first use and kept in `dense`.
pub(crate) enum Path<'a, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The dense fixed-size LU.
    Dense(&'a mut Dense<D>),
    /// The structured Newton matrix.
    Sparse(Sparse<'a>),
}

/// The [`Path`] of `H` for a stepper with this storage.
pub(crate) fn path<'a, H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    storage: &'a mut Structured,
    dense: &'a mut Option<Box<Dense<D>>>,
) -> Path<'a, D>
where
    DefaultAllocator: Alloc<D>,
{
    match storage.matrix(ham, 1) {
        Some(matrix) => Path::Sparse(Sparse { matrix }),
        None => Path::Dense(dense.get_or_insert_with(|| new_dense(ham.dim()))),
    }
}

/// The dense storage, in a frame of its own: its `D x D` matrices pass through the stack only
/// when it is built (a fixed-size stepper on the structured path, `D` in the thousands, never
/// has them in any frame).
#[inline(never)]
fn new_dense<D: Dim>(d: D) -> Box<Dense<D>>
where
    DefaultAllocator: Alloc<D>,
{
    Box::new(Dense::new(d))
}

impl<D: Dim> Linear<D> for Path<'_, D>
where
    DefaultAllocator: Alloc<D>,
{
    fn evaluate<H: Hamiltonian<D>>(&mut self, ham: &H, z: &OVector<f64, D>, out: &mut Point<D>) {
        match self {
            Path::Dense(d) => d.evaluate(ham, z, out),
            Path::Sparse(s) => s.evaluate(ham, z, out),
        }
    }

    fn factor(&mut self, c: f64) -> Result<(), Pivot> {
        match self {
            Path::Dense(d) => d.factor(c),
            Path::Sparse(s) => Linear::<D>::factor(s, c),
        }
    }

    fn solve_into(&mut self, b: &OVector<f64, D>, x: &mut OVector<f64, D>) {
        match self {
            Path::Dense(d) => d.solve_into(b, x),
            Path::Sparse(s) => s.solve_into(b, x),
        }
    }

    fn hessian_times_into(&self, x: &OVector<f64, D>, out: &mut OVector<f64, D>) {
        match self {
            Path::Dense(d) => d.hessian_times_into(x, out),
            Path::Sparse(s) => s.hessian_times_into(x, out),
        }
    }

    fn hessian_abs_form(&self, x: &OVector<f64, D>) -> f64 {
        match self {
            Path::Dense(d) => d.hessian_abs_form(x),
            Path::Sparse(s) => s.hessian_abs_form(x),
        }
    }
}
