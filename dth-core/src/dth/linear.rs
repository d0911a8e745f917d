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
//! fused `Hamiltonian::derivatives` (one program, shared subexpressions) and keeps its `D x D`
//! storage in frames of its own (`#[inline(never)]`), which exist only when it runs.

use crate::hamiltonian::Alloc;
use crate::linalg::{Lu, Pivot};
use crate::methods::Structured;
use crate::structured::NewtonMatrix;
use crate::Hamiltonian;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

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

/// `max |x_i|` over `entries`, NaN when one is not finite.
fn largest<'a>(entries: impl IntoIterator<Item = &'a f64>) -> f64 {
    let mut max = 0.0f64;
    for x in entries {
        if !x.is_finite() {
            return f64::NAN;
        }
        max = max.max(x.abs());
    }
    max
}

/// The Hamiltonian's point at `z`; with a structured `matrix`, its Hessian nonzeros are written
/// into the matrix's storage (stage 0) on the way.
pub(crate) fn point<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    z: &OVector<f64, D>,
    matrix: Option<&mut NewtonMatrix>,
) -> Point<D>
where
    DefaultAllocator: Alloc<D>,
{
    match matrix {
        Some(m) => structured_point(ham, z, m),
        None => dense_point(ham, z),
    }
}

/// [`point`] on the structured path.
fn structured_point<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    z: &OVector<f64, D>,
    matrix: &mut NewtonMatrix,
) -> Point<D>
where
    DefaultAllocator: Alloc<D>,
{
    let nonzeros = matrix.hessian_mut(0);
    ham.hessian_nonzeros(z, nonzeros);
    Point {
        value: ham.value(z),
        gradient: ham.gradient(z),
        psi: ham.psi(z),
        hessian_max: largest(nonzeros.iter()),
    }
}

/// [`point`] on the dense path, in a frame of its own (the fused evaluation's `D x D` Hessian).
#[inline(never)]
fn dense_point<H: Hamiltonian<D>, D: Dim>(ham: &H, z: &OVector<f64, D>) -> Point<D>
where
    DefaultAllocator: Alloc<D>,
{
    let d = ham.derivatives(z);
    Point {
        value: d.value,
        hessian_max: largest(d.hessian.iter()),
        gradient: d.gradient,
        psi: d.psi,
    }
}

/// The structured Newton matrix of a DTH stepper (one stage), when `H` takes the structured
/// path: analysed on first use and kept in `storage` (the peers' rule and cache).
pub(crate) fn matrix<'a, H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    storage: &'a mut Structured,
) -> Option<&'a mut NewtonMatrix>
where
    DefaultAllocator: Alloc<D>,
{
    storage.matrix(ham, 1)
}

/// What the DTH Newton solvers need of `A = I - c J Hess H(z)` at their iterate.
pub(crate) trait Linear<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Evaluate `H` at `z` and keep its Hessian for [`factor`](Self::factor) and
    /// [`hessian_times`](Self::hessian_times) (the factorization is kept until the next
    /// `factor`).
    fn evaluate<H: Hamiltonian<D>>(&mut self, ham: &H, z: &OVector<f64, D>) -> Point<D>;
    /// Factor `A = I - c J Hess` with the Hessian last evaluated.
    fn factor(&mut self, c: f64) -> Result<(), Pivot>;
    /// `A^{-1} b` with the last factorization.
    fn solve(&self, b: &OVector<f64, D>) -> OVector<f64, D>;
    /// `Hess x` with the Hessian last evaluated.
    fn hessian_times(&self, x: &OVector<f64, D>) -> OVector<f64, D>;
}

/// The dense path: the fused evaluation's Hessian and the fixed-size LU.
pub(crate) struct Dense<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    hessian: OMatrix<f64, D, D>,
    lu: Lu<D>,
}

impl<D: Dim> Dense<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Empty storage of dimension `d`.
    pub(crate) fn new(d: D) -> Self {
        Dense {
            hessian: OMatrix::zeros_generic(d, d),
            lu: Lu::empty(d),
        }
    }
}

impl<D: Dim> Linear<D> for Dense<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn evaluate<H: Hamiltonian<D>>(&mut self, ham: &H, z: &OVector<f64, D>) -> Point<D> {
        let d = ham.derivatives(z);
        self.hessian.copy_from(&d.hessian);
        Point {
            value: d.value,
            gradient: d.gradient,
            psi: d.psi,
            hessian_max: largest(self.hessian.iter()),
        }
    }

    /// `A` entry by entry, `delta_ij - c (J Hess)_ij`, factored in place.
    fn factor(&mut self, c: f64) -> Result<(), Pivot> {
        let n = self.hessian.nrows() / 2;
        let hessian = &self.hessian;
        self.lu.factor_from(|i, j| {
            let jh = if i < n {
                hessian[(i + n, j)]
            } else {
                -hessian[(i - n, j)]
            };
            if i == j {
                1.0 - jh * c
            } else {
                -(jh * c)
            }
        })
    }

    fn solve(&self, b: &OVector<f64, D>) -> OVector<f64, D> {
        self.lu.solve(b)
    }

    fn hessian_times(&self, x: &OVector<f64, D>) -> OVector<f64, D> {
        &self.hessian * x
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
    fn evaluate<H: Hamiltonian<D>>(&mut self, ham: &H, z: &OVector<f64, D>) -> Point<D> {
        structured_point(ham, z, self.matrix)
    }

    fn factor(&mut self, c: f64) -> Result<(), Pivot> {
        self.matrix.factor(&[c])
    }

    fn solve(&self, b: &OVector<f64, D>) -> OVector<f64, D> {
        let mut x = b.clone();
        let mut work = b.clone();
        self.matrix
            .solve_with(x.as_mut_slice(), work.as_mut_slice());
        x
    }

    fn hessian_times(&self, x: &OVector<f64, D>) -> OVector<f64, D> {
        let mut out = x.clone();
        self.matrix
            .hessian_times(0, x.as_slice(), out.as_mut_slice());
        out
    }
}
