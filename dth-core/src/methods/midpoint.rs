//! The implicit midpoint rule, one of the thesis's comparisons.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::newton::{self, residual_minus_j, NewtonOptions, Structured};
use super::OneStepMethod;
use crate::{Error, Hamiltonian};

/// The implicit midpoint rule `z1 = z0 + dt J grad H((z0 + z1)/2)`.
///
/// Second order, symmetric and symplectic; conserves every quadratic invariant exactly (the
/// angular momentum of a central force to roundoff), not the energy. Solved by Newton with the
/// matrix `I - (dt/2) J Hess H((z0 + z1)/2)` from an explicit Euler predictor.
///
/// # References
/// Thesis Section 3.5 (eq. 2.3.6 with `lambda_k = 1` is the midpoint rule) and Table 4.1;
/// Hairer, Lubich, Wanner, *Geometric Numerical Integration*, Sections VI.3 and IV.2.1.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImplicitMidpoint {
    /// Newton settings.
    pub newton: NewtonOptions,
    iterations: usize,
    structured: Structured,
}

impl ImplicitMidpoint {
    /// With default Newton settings.
    pub fn new() -> Self {
        Self::default()
    }

    /// With the given Newton settings.
    pub fn with_newton(newton: NewtonOptions) -> Self {
        ImplicitMidpoint {
            newton,
            iterations: 0,
            structured: Structured::default(),
        }
    }
}

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for ImplicitMidpoint
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "midpoint";
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
            |z1, _, r| {
                // y = (z0 + z1)/2; F = z1 - z0 - dt J grad H(y).
                for i in 0..z1.len() {
                    r.y[i] = (z0[i] + z1[i]) * 0.5;
                }
                h.gradient_into(&r.y, &mut r.scratch);
                residual_minus_j(z1, z0, &r.scratch, dt, &mut r.residual);
            },
        )
    }

    fn newton_iterations(&self) -> usize {
        self.iterations
    }
}
