//! The trapezoidal rule, one of the thesis's comparisons.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::newton::{self, NewtonOptions, Structured};
use super::OneStepMethod;
use crate::{j_times, Error, Hamiltonian};

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

    fn step(&mut self, h: &H, z0: &OVector<f64, D>, dt: f64) -> Result<OVector<f64, D>, Error> {
        let name = <Self as OneStepMethod<D, H>>::NAME;
        newton::one_stage(
            name,
            &self.newton,
            &mut self.iterations,
            &mut self.structured,
            h,
            z0,
            dt,
            |z1, g0| {
                (
                    z1 - z0 - j_times(&(g0 + h.gradient(z1))) * (0.5 * dt),
                    z1.clone(),
                )
            },
        )
    }

    fn newton_iterations(&self) -> usize {
        self.iterations
    }
}
