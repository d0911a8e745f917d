//! The classical fourth-order Runge-Kutta method.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::OneStepMethod;
use crate::{j_times, Error, Hamiltonian};

/// Classical RK4 on `z' = J grad H(z)`: explicit, order 4, neither symplectic nor
/// energy-conserving (its energy error drifts linearly in time).
///
/// # References
/// E. Hairer, S. Norsett, G. Wanner, *Solving Ordinary Differential Equations I*, Section II.1,
/// Table 1.2 (left).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rk4;

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for Rk4
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "rk4";
    const ORDER: u32 = 4;

    fn step(&mut self, h: &H, z0: &OVector<f64, D>, dt: f64) -> Result<OVector<f64, D>, Error> {
        let f = |z: &OVector<f64, D>| j_times(&h.gradient(z));
        let k1 = f(z0);
        let k2 = f(&(z0 + &k1 * (0.5 * dt)));
        let k3 = f(&(z0 + &k2 * (0.5 * dt)));
        let k4 = f(&(z0 + &k3 * dt));
        Ok(z0 + (k1 + (k2 + k3) * 2.0 + k4) * (dt / 6.0))
    }
}
