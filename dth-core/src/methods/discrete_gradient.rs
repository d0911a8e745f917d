//! An energy-preserving discrete-gradient method.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::newton::{self, residual_minus_j, NewtonOptions, Structured};
use super::OneStepMethod;
use crate::{Error, Hamiltonian};

/// The discrete-gradient method `z1 = z0 + dt J gbar(z0, z1)`, with `gbar` the Hamiltonian's
/// [`Hamiltonian::discrete_gradient`] (Gonzalez's midpoint discrete gradient by default).
///
/// Second order and symmetric; since `gbar . (z1 - z0) = H(z1) - H(z0)` and `gbar^T J gbar = 0`,
/// the energy is conserved exactly (to roundoff once the nonlinear equation is solved to
/// roundoff). The Newton matrix is `I - (dt/2) J Hess H((z0 + z1)/2)`, the Jacobian up to
/// `O(dt |z1 - z0|)`: the iteration contracts by `O(dt^2)` per step and is run to roundoff by
/// the stopping rule of [`NewtonOptions`].
///
/// On an extended phase space (time-dependent `H`) the Gonzalez correction moves the `t`
/// coordinate by `O(dt^3)` per step relative to `dt`; the state stays second-order accurate.
///
/// # References
/// O. Gonzalez, *Time integration and discrete Hamiltonian systems*, J. Nonlinear Sci. 6 (1996)
/// 449-467, eq. (3.6); R. McLachlan, G. Quispel, N. Robidoux, *Geometric integration using
/// discrete gradients*, Phil. Trans. R. Soc. A 357 (1999) 1021-1045. Compared with DTH, which
/// conserves energy at midpoints (thesis eq. 2.3.7).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DiscreteGradient {
    /// Newton settings.
    pub newton: NewtonOptions,
    iterations: usize,
    structured: Structured,
}

impl DiscreteGradient {
    /// With default Newton settings.
    pub fn new() -> Self {
        Self::default()
    }

    /// With the given Newton settings.
    pub fn with_newton(newton: NewtonOptions) -> Self {
        DiscreteGradient {
            newton,
            iterations: 0,
            structured: Structured::default(),
        }
    }

    /// Allocate the Newton buffers of a dynamic dimension for `h` now rather than on the first
    /// step (see `Structured::reserve`).
    pub(crate) fn reserve<D: Dim, H: Hamiltonian<D>>(&mut self, h: &H)
    where
        DefaultAllocator: Alloc<D>,
    {
        self.structured.reserve(h);
    }
}

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for DiscreteGradient
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "discrete_gradient";
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
                // y = (z0 + z1)/2; F = z1 - z0 - dt J gbar(z0, z1).
                h.discrete_gradient_into(z0, z1, &mut r.scratch);
                residual_minus_j(z1, z0, &r.scratch, dt, &mut r.residual);
                for i in 0..z1.len() {
                    r.y[i] = (z0[i] + z1[i]) * 0.5;
                }
            },
        )
    }

    fn newton_iterations(&self) -> usize {
        self.iterations
    }
}
