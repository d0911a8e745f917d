//! The Stormer-Verlet method for separable Hamiltonians.

use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OVector};

use super::{check_finite, check_step, OneStepMethod};
use crate::{Error, Hamiltonian};

/// Stormer-Verlet (velocity Verlet, kick-drift-kick) for `H = T(p) + V(q)`:
/// `p_half = p0 - (dt/2) grad V(q0)`, `q1 = q0 + dt grad T(p_half)`,
/// `p1 = p_half - (dt/2) grad V(q1)`.
///
/// Explicit, second order, symmetric and symplectic. The partial gradients are read from
/// [`Hamiltonian::gradient`], which is exact for separable `H` (the `q` part depends on `q`
/// only, the `p` part on `p` only). A Hamiltonian without [`Flags::separable`](crate::Flags::separable) is refused with
/// [`Error::NotSeparable`]. The last force `grad V(q1)` is kept and reused by the next step of a
/// run when it starts from `z1` (first-same-as-last): two gradient evaluations per step in
/// [`run`](super::run) and through [`OneStepMethod::continue_into`]. A call of
/// [`OneStepMethod::step_into`] (or `step`) evaluates it afresh (three evaluations): its `H`
/// may not be the last step's (a parameter set in between), and a force of another `H` would
/// be a silently wrong step.
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
    /// The step's buffers and the last force, made on the first step.
    kept: Option<Forces<D>>,
}

/// `z1` and `grad H(z1)` of the last step (`last` says whether they are one: a failed or
/// interrupted step leaves them unusable), and the half-step gradient.
#[derive(Clone, Debug, PartialEq)]
struct Forces<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    z: OVector<f64, D>,
    g: OVector<f64, D>,
    g_half: OVector<f64, D>,
    last: bool,
}

impl<D: Dim> Default for StormerVerlet<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn default() -> Self {
        StormerVerlet { kept: None }
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

    fn step_into(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        self.kick_drift_kick(h, z0, dt, z1, false)
    }

    fn continue_into(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
    ) -> Result<(), Error> {
        self.kick_drift_kick(h, z0, dt, z1, true)
    }
}

impl<D: Dim> StormerVerlet<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// One step; with `reuse`, the last step's force when it ended at `z0` (the caller vouches
    /// that `h` is that step's Hamiltonian).
    fn kick_drift_kick<H: Hamiltonian<D>>(
        &mut self,
        h: &H,
        z0: &OVector<f64, D>,
        dt: f64,
        z1: &mut OVector<f64, D>,
        reuse: bool,
    ) -> Result<(), Error> {
        check_step(h, z0, dt, z1)?;
        if !h.flags().separable {
            return Err(Error::NotSeparable {
                method: <Self as OneStepMethod<D, H>>::NAME,
            });
        }
        if self.kept.as_ref().is_some_and(|f| f.z.len() != z0.len()) {
            self.kept = None;
        }
        let f = self.kept.get_or_insert_with(|| Forces {
            z: z0.clone(),
            g: z0.clone(),
            g_half: z0.clone(),
            last: false,
        });
        if !(reuse && f.last && f.z == *z0) {
            h.gradient_into(z0, &mut f.g);
        }
        f.last = false;
        let n = z0.len() / 2;
        z1.copy_from(z0);
        for i in 0..n {
            z1[n + i] -= 0.5 * dt * f.g[i];
        }
        h.gradient_into(z1, &mut f.g_half);
        for i in 0..n {
            z1[i] += dt * f.g_half[n + i];
        }
        h.gradient_into(z1, &mut f.g);
        for i in 0..n {
            z1[n + i] -= 0.5 * dt * f.g[i];
        }
        check_finite(<Self as OneStepMethod<D, H>>::NAME, z1)?;
        // grad V(q1) is the q part of g at the new z: valid there whatever p is.
        f.z.copy_from(z1);
        f.last = true;
        Ok(())
    }
}
