//! The Stormer-Verlet method for separable Hamiltonians.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::OneStepMethod;
use crate::{Error, Hamiltonian};

/// Stormer-Verlet (velocity Verlet, kick-drift-kick) for `H = T(p) + V(q)`:
/// `p_half = p0 - (dt/2) grad V(q0)`, `q1 = q0 + dt grad T(p_half)`,
/// `p1 = p_half - (dt/2) grad V(q1)`.
///
/// Explicit, second order, symmetric and symplectic. The partial gradients are read from
/// [`Hamiltonian::gradient`], which is exact for separable `H` (the `q` part depends on `q`
/// only, the `p` part on `p` only). A Hamiltonian without [`Flags::separable`](crate::Flags::separable) is refused with
/// [`Error::NotSeparable`]. The last force `grad V(q1)` is kept and reused by the next step when
/// it starts from `z1` (first-same-as-last): two gradient evaluations per step in a run.
///
/// # References
/// E. Hairer, C. Lubich, G. Wanner, *Geometric numerical integration illustrated by the
/// Stormer-Verlet method*, Acta Numerica 12 (2003) 399-450, eq. (1.5); compared with DTH, which
/// needs no separability.
#[derive(Clone, Debug, PartialEq)]
pub struct StormerVerlet<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `(z1, grad H(z1))` of the last step.
    last: Option<(OVector<f64, D>, OVector<f64, D>)>,
}

impl<D: Dim> Default for StormerVerlet<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn default() -> Self {
        StormerVerlet { last: None }
    }
}

impl<D: Dim> StormerVerlet<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// A fresh integrator.
    pub fn new() -> Self {
        Self::default()
    }
}

impl<D: Dim, H: Hamiltonian<D>> OneStepMethod<D, H> for StormerVerlet<D>
where
    DefaultAllocator: Alloc<D>,
{
    const NAME: &'static str = "verlet";
    const ORDER: u32 = 2;

    fn step(&mut self, h: &H, z0: &OVector<f64, D>, dt: f64) -> Result<OVector<f64, D>, Error> {
        if !h.flags().separable {
            return Err(Error::NotSeparable {
                method: <Self as OneStepMethod<D, H>>::NAME,
            });
        }
        let n = z0.len() / 2;
        let g0 = match self.last.take() {
            Some((z, g)) if z == *z0 => g,
            _ => h.gradient(z0),
        };
        let mut z = z0.clone();
        for i in 0..n {
            z[n + i] -= 0.5 * dt * g0[i];
        }
        let g_half = h.gradient(&z);
        for i in 0..n {
            z[i] += dt * g_half[n + i];
        }
        let g1 = h.gradient(&z);
        for i in 0..n {
            z[n + i] -= 0.5 * dt * g1[i];
        }
        // grad V(q1) is the q part of g1 whatever p is: valid at the new z.
        self.last = Some((z.clone(), g1));
        Ok(z)
    }
}
