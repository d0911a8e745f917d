//! The trapezoidal rule, one of the thesis's comparisons.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::newton::{self, residual_minus_j, NewtonOptions, Structured};
use super::OneStepMethod;
use crate::{Error, Hamiltonian};

/// The trapezoidal rule `z1 = z0 + (dt/2) J (grad H(z0) + grad H(z1))`.
///
/// Second order, symmetric, not symplectic; conserves neither energy nor angular momentum in
/// general. For `H = z^T A z / 2` with `A` positive definite it coincides with DTH at
/// `lambda = 1`. Solved by Newton with the matrix `I - (dt/2) J Hess H(z1)` from an explicit
/// Euler predictor.
///
/// # References
/// Thesis Section 3.5 (eq. 2.3.5 with `lambda_k = 1` is the trapezoidal rule) and Table 4.1.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trapezoidal {
    /// Newton settings.
    pub newton: NewtonOptions,
    iterations: usize,
    structured: Structured,
}

impl Trapezoidal {
    /// With default Newton settings.
    pub fn new() -> Self {
        Self::default()
    }

    /// With the given Newton settings.
    pub fn with_newton(newton: NewtonOptions) -> Self {
        Trapezoidal {
            newton,
            iterations: 0,
            structured: Structured::default(),
        }
    }
}

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for Trapezoidal
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "trapezoidal";
    const ORDER: u32 = 2;

    fn step_into(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        let name = <Self as OneStepMethod<D, H>>::NAME;
        newton::one_stage(
            name,
            &self.newton,
            &mut self.iterations,
            &mut self.structured,
            h,
            z0,
            dt,
            z1,
            |z1, g0, r| {
                // y = z1; F = z1 - z0 - (dt/2) J (grad H(z0) + grad H(z1)).
                r.y.copy_from(z1);
                h.gradient_into(z1, &mut r.scratch);
                r.scratch += g0;
                residual_minus_j(z1, z0, &r.scratch, 0.5 * dt, &mut r.residual);
            },
        )
    }

    fn newton_iterations(&self) -> usize {
        self.iterations
    }
}
