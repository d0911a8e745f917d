//! Greenspan's discrete mechanics for central forces.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::newton::{self, NewtonOptions, Structured};
use super::OneStepMethod;
use crate::systems::CentralForce;
use crate::Error;

/// Greenspan's energy- and angular-momentum-conserving discrete mechanics for
/// `H = |p|^2 / (2m) + phi(|q|)` ([`CentralForce`]), `v = p / m`:
///
/// ```text
/// q1 - q0 = (dt/2) (v1 + v0)
/// m (v1 - v0) = -dt G(r0, r1) (q1 + q0) / (r1 + r0),   G = (phi(r1) - phi(r0)) / (r1 - r0)
/// ```
///
/// Second order and symmetric. Energy: `|p1|^2 - |p0|^2 = -2 m G (r1 - r0)`, so
/// `T1 - T0 = -(phi(r1) - phi(r0))` exactly. Angular momentum: `p1 - p0` is parallel to
/// `q1 + q0` and `q1 - q0` to `p1 + p0`, so `q1 ^ p1 = q0 ^ p0`. Both hold to roundoff once the
/// equations are solved to roundoff. `G` is guarded as `r1 -> r0` by
/// [`CentralForce::phi_divided_difference`] (a cancellation-aware switch to `phi'`).
///
/// Newton on `z1` with the matrix `I - (dt/2) J Hess H((z0 + z1)/2)`: exact in the `q` rows,
/// correct to `O(dt |z1 - z0|)` in the `p` rows, so the iteration contracts by `O(dt^2)` and is
/// run to roundoff by the stopping rule of [`NewtonOptions`].
///
/// # References
/// D. Greenspan, *Conservative numerical methods for x'' = f(x)*, J. Comput. Phys. 56 (1984)
/// 28-41 (the thesis's ref. \[5\]); thesis Chapter I and Table 4.1 ("Discrete Mechanics").
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DiscreteMechanics {
    /// Newton settings.
    pub newton: NewtonOptions,
    iterations: usize,
    structured: Structured,
}

impl DiscreteMechanics {
    /// With default Newton settings.
    pub fn new() -> Self {
        Self::default()
    }

    /// With the given Newton settings.
    pub fn with_newton(newton: NewtonOptions) -> Self {
        DiscreteMechanics {
            newton,
            iterations: 0,
            structured: Structured::default(),
        }
    }
}

impl<D: Dim, H: CentralForce<D>> OneStepMethod<D, H> for DiscreteMechanics
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "discrete_mechanics";
    const ORDER: u32 = 2;

    fn step_into(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        let n = z0.len() / 2;
        let m = h.mass();
        let radius = |z: &OVector<f64, D>| z.rows(0, n).norm();
        let r0 = radius(z0);
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
                let r1 = radius(z1);
                let force = h.phi_divided_difference(r0, r1) / (r1 + r0);
                for i in 0..n {
                    r.residual[i] = z1[i] - z0[i] - (0.5 * dt / m) * (z1[n + i] + z0[n + i]);
                    r.residual[n + i] = z1[n + i] - z0[n + i] + dt * force * (z1[i] + z0[i]);
                }
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
