//! The fallback step of the robust mode: one step of the energy-conserving discrete-gradient
//! method ([`DiscreteGradient`]) in `(q, p)`, used where DTH itself has no positive root
//! (`Psi` changes sign), followed by the same energy check and projection against
//! `H(zbar_0)` as the cancellation-free DTH step.
//!
//! `z1 = z0 + dt J gbar(z0, z1)` with the Hamiltonian's discrete gradient `gbar` (exact
//! divided differences where the Hamiltonian provides them, Gonzalez's midpoint discrete
//! gradient otherwise), so `H(z1) - H(z0) = gbar . (z1 - z0) = dt gbar^T J gbar = 0` in exact
//! arithmetic; in floating point `H(z1) - H(z0) = gbar . f` with `f` the solve's residual,
//! which the check allows and the projection removes, so the roundoff of successive solves does
//! not random-walk. Second order, symmetric.
//!
//! # References
//! O. Gonzalez, *Time integration and discrete Hamiltonian systems*, J. Nonlinear Sci. 6
//! (1996); R. I. McLachlan, G. R. W. Quispel, N. Robidoux, *Geometric integration using
//! discrete gradients*, Phil. Trans. R. Soc. A 357 (1999). Used where Shibberu's DTH has no
//! positive root (thesis Ch. III, Thm 3.11).

use nalgebra::SVector;

use super::newton::{all_finite, project_onto_energy};
use super::options::DthOptions;
use crate::methods::{DiscreteGradient, NewtonOptions, OneStepMethod};
use crate::{j_times, Derivatives, Error, Hamiltonian};

/// A solved fallback step.
pub(crate) struct FallbackStep<const D: usize> {
    pub(crate) z: SVector<f64, D>,
    pub(crate) derivatives: Derivatives<D>,
    pub(crate) iterations: u32,
}

/// One discrete-gradient step of size `dt` from `z0` (which lies on `H = energy`), checked and
/// projected onto `H = energy`. The peer's Newton failures come back as its `Method*` errors.
pub(crate) fn fallback_step<H: Hamiltonian<D>, const D: usize>(
    ham: &H,
    z0: &SVector<f64, D>,
    dt: f64,
    energy: f64,
    options: &DthOptions,
    step: usize,
) -> Result<FallbackStep<D>, Error> {
    let mut method = DiscreteGradient::with_newton(NewtonOptions::default());
    let z = OneStepMethod::<D, H>::step(&mut method, ham, z0, dt).map_err(|e| at_step(e, step))?;
    let iterations = OneStepMethod::<D, H>::newton_iterations(&method);
    let d = ham.derivatives(&z);
    if !all_finite(&z)
        || !d.value.is_finite()
        || !all_finite(&d.gradient)
        || !d.hessian.iter().all(|x| x.is_finite())
    {
        return Err(Error::NonFinite {
            step,
            what: "H or its derivatives after a fallback step",
        });
    }
    // H(z) - H(z0) = gbar . (z - z0) = gbar . f exactly: the energy error the solve's own
    // residual explains, allowed in the check before projecting.
    let gbar = ham.discrete_gradient(z0, &z);
    let move_ = j_times(&gbar) * dt;
    let f = (z - z0) - move_;
    // The peer's Newton accepts on its update size; insist on the residual too, relative to the
    // terms it is a difference of (a near-collision step can stall far from the solution).
    let scale = z
        .amax()
        .max(z0.amax())
        .max(move_.amax())
        .max(f64::MIN_POSITIVE);
    let residual = f.amax();
    if residual.is_nan() || residual > options.residual_tolerance() * scale {
        return Err(Error::MethodNotConverged {
            method: "discrete_gradient",
            step,
            iterations,
            residual,
        });
    }
    let (z, derivatives) = project_onto_energy(ham, energy, z, d, gbar.dot(&f), options, step)?;
    Ok(FallbackStep {
        z,
        derivatives,
        iterations: u32::try_from(iterations).unwrap_or(u32::MAX),
    })
}

/// Label a peer method's error (step 0 for a direct call) with the run's step index.
fn at_step(mut error: Error, k: usize) -> Error {
    match &mut error {
        Error::MethodNotConverged { step, .. }
        | Error::MethodSingularMatrix { step, .. }
        | Error::MethodNonFinite { step, .. } => *step = k,
        _ => {}
    }
    error
}
