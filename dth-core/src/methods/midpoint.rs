//! The implicit midpoint rule, one of the thesis's comparisons.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::newton::{self, NewtonOptions, Structured};
use super::OneStepMethod;
use crate::{j_times, Error, Hamiltonian};

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
            |z1, _| {
                let zbar = (z0 + z1) * 0.5;
                (z1 - z0 - j_times(&h.gradient(&zbar)) * dt, zbar)
            },
        )
    }

    fn newton_iterations(&self) -> usize {
        self.iterations
    }
}
