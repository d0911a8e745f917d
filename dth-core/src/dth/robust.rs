//! The fallback step of the robust mode: one energy-conserving discrete-gradient step in
//! `(q, p)`, used where DTH itself has no positive root (`Psi` changes sign).
//!
//! `z1 = z0 + dt J gbar(z0, z1)` with the Hamiltonian's discrete gradient `gbar`
//! ([`Hamiltonian::discrete_gradient`]: exact divided differences where the Hamiltonian
//! provides them, Gonzalez's midpoint discrete gradient otherwise). Then
//! `H(z1) - H(z0) = gbar . (z1 - z0) = dt gbar^T J gbar = 0`: energy is exact in exact
//! arithmetic, and the roundoff of each solve is kept from random-walking by the same check and
//! projection against `H(zbar_0)` as the cancellation-free DTH step. Second order, symmetric.
//!
//! # References
//! O. Gonzalez, *Time integration and discrete Hamiltonian systems*, J. Nonlinear Sci. 6
//! (1996), eq. (3.5) (the midpoint discrete gradient); R. I. McLachlan, G. R. W. Quispel,
//! N. Robidoux, *Geometric integration using discrete gradients*, Phil. Trans. R. Soc. A 357
//! (1999). Used here where Shibberu's DTH has no positive root (thesis Ch. III, Thm 3.11).

use nalgebra::{SMatrix, SVector};

use super::newton::{
    all_finite, factor, j_times_matrix, project_onto_energy, relative_update, Updates,
};
use super::options::DthOptions;
use crate::{j_times, Derivatives, Error, Hamiltonian};

/// A solved fallback step.
pub(crate) struct FallbackStep<const D: usize> {
    pub(crate) z: SVector<f64, D>,
    pub(crate) derivatives: Derivatives<D>,
    pub(crate) iterations: u32,
}

/// One discrete-gradient step of size `dt` from `z0` (which lies on `H = energy`).
/// Newton on `F(z) = z - z0 - dt J gbar(z0, z)` with the Jacobian `I - (dt/2) J Hess H(zm)`,
/// `zm = (z0 + z)/2` (`d gbar / d z = Hess H(zm) / 2 + O(|z - z0|^2)`, so the iteration
/// contracts by about `dt |z - z0|^2` per step); same stopping rule as the DTH Newton, residual
/// checked at the end.
pub(crate) fn fallback_step<H: Hamiltonian<D>, const D: usize>(
    ham: &H,
    z0: &SVector<f64, D>,
    dt: f64,
    energy: f64,
    options: &DthOptions,
    step: usize,
) -> Result<FallbackStep<D>, Error> {
    // Predictor: explicit midpoint rule (error O(dt^3)).
    let half = j_times(&ham.gradient(z0)) * (0.5 * dt);
    let mut z = z0 + j_times(&ham.gradient(&(z0 + half))) * dt;
    let mut updates = Updates::default();
    let mut iterations = 0u32;
    loop {
        if !all_finite(&z) {
            return Err(Error::NonFinite {
                step,
                what: "fallback step iterate",
            });
        }
        let d = ham.derivatives(&z);
        if !d.value.is_finite()
            || !all_finite(&d.gradient)
            || !d.hessian.iter().all(|x| x.is_finite())
        {
            return Err(Error::NonFinite {
                step,
                what: "H or its derivatives at a fallback iterate",
            });
        }
        let gbar = ham.discrete_gradient(z0, &z);
        let move_ = j_times(&gbar) * dt;
        let f = (z - z0) - move_;
        let scale = z
            .amax()
            .max(z0.amax())
            .max(move_.amax())
            .max(f64::MIN_POSITIVE);
        let residual = f.amax() / scale;
        if let Some(tiny) = updates.stopped(options.stall_tolerance()) {
            if residual <= options.residual_tolerance() {
                // H(z) - H(z0) = gbar . (z - z0) = gbar . f exactly: the energy error the
                // solve's own residual explains, allowed in the check before projecting.
                let explained = gbar.dot(&f);
                let (z, derivatives) =
                    project_onto_energy(ham, energy, z, d, explained, options, step)?;
                return Ok(FallbackStep {
                    z,
                    derivatives,
                    iterations,
                });
            }
            if tiny {
                return Err(Error::NewtonDiverged {
                    step,
                    iterations,
                    residual,
                });
            }
        }
        if iterations >= options.max_iterations() {
            return Err(Error::NewtonDiverged {
                step,
                iterations,
                residual,
            });
        }
        let hm = ham.hessian(&((z0 + z) * 0.5));
        if !hm.iter().all(|x| x.is_finite()) {
            return Err(Error::NonFinite {
                step,
                what: "Hess H at a fallback midpoint",
            });
        }
        let a = SMatrix::<f64, D, D>::identity() - j_times_matrix(&hm) * (0.5 * dt);
        let dz = factor(&a, step)?.solve(&(-f));
        z += dz;
        iterations += 1;
        updates.push(relative_update(&dz, &z, 0.0, 1.0));
    }
}
