//! The classical fourth-order Runge-Kutta method.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::kept::Kept;
use super::{check_finite, check_step, OneStepMethod};
use crate::{j_times_into, Error, Hamiltonian};

/// Classical RK4 on `z' = J grad H(z)`: explicit, order 4, neither symplectic nor
/// energy-conserving (its energy error drifts linearly in time).
///
/// # References
/// E. Hairer, S. Norsett, G. Wanner, *Solving Ordinary Differential Equations I*, Section II.1,
/// Table 1.2 (left).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rk4 {
    kept: Kept,
}

impl Rk4 {
    /// A fresh integrator (its stage buffers are made on the first step).
    pub fn new() -> Self {
        Self::default()
    }
}

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for Rk4
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "rk4";
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
        // The four slopes, a stage point and a gradient.
        self.kept
            .vectors(d, |[k1, k2, k3, k4, y, g]: &mut [OVector<f64, D>; 6]| {
                // k_i = f(z0 + c_i dt k_{i-1}) with c = (0, 1/2, 1/2, 1): k_1 = f(z0 + 0).
                let mut slope = |c: f64, k: &OVector<f64, D>, next: &mut OVector<f64, D>| {
                    y.zip_zip_apply(z0, k, |y, z, k| *y = z + k * (c * dt));
                    h.gradient_into(y, g);
                    j_times_into(g, next);
                };
                slope(0.0, z0, k1);
                slope(0.5, k1, k2);
                slope(0.5, k2, k3);
                slope(1.0, k3, k4);
                for i in 0..z0.len() {
                    z1[i] = z0[i] + (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * (dt / 6.0);
                }
            });
        check_finite(<Self as OneStepMethod<D, H>>::NAME, z1)
    }
}
