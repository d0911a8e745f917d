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

use super::linear::{self, Point};
use super::newton::{all_finite, project_onto_energy, roundoff_scale};
use super::options::DthOptions;
use crate::hamiltonian::Alloc;
use crate::methods::{DiscreteGradient, NewtonOptions, OneStepMethod, Structured};
use crate::{j_times, Error, Hamiltonian};
use nalgebra::{DefaultAllocator, Dim, OVector};

/// A solved fallback step.
pub(crate) struct FallbackStep<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    pub(crate) z: OVector<f64, D>,
    /// `H`'s value, gradient and `Psi` at `z`.
    pub(crate) point: Point<D>,
    pub(crate) iterations: u32,
}

/// One discrete-gradient step of size `dt` from `z0` (which lies on `H = energy`), checked and
/// projected onto `H = energy`. The peer's Newton failures come back as its `Method*` errors.
/// `storage` is the stepper's structured Newton storage (see `dth::linear`): the new point is
/// evaluated without a `D x D` Hessian where `H` takes that path.
pub(crate) fn fallback_step<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    z0: &OVector<f64, D>,
    dt: f64,
    energy: f64,
    options: &DthOptions,
    step: usize,
    storage: &mut Structured,
) -> Result<FallbackStep<D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    // Roundoff floor of the solve near an equilibrium. Without exact divided differences the
    // discrete gradient's correction `d (H(z1) - H(z0) - g . d) / |d|^2` (`d = z1 - z0`) divides
    // the rounding of a difference of numbers of size `scale_h` (the terms of `H`) by `|d|`, so
    // the residual `f = d - dt J gbar` cannot go below about `eps dt scale_h / |d|`, i.e.
    // `eps scale_h / |grad H|` since `|d| ~ dt |grad H|`: independent of `dt` (halving cannot
    // help) and unbounded as `grad H -> 0`. That noise lies along `J d ~ -dt grad H`, across the
    // energy surface, and moves `H` by `eps scale_h`: it is the width of the float level set
    // `H = E` in the gradient direction, not an error of the step (the projection below puts
    // the point back on `H = E`). So the Newton stall floor and the residual check are taken
    // relative to it; away from equilibria (`|grad H| |z| >> scale_h`) nothing changes. With
    // exact divided differences (`flags().exact_divided_differences`) there is no such cancellation
    // and no floor.
    let g0 = ham.gradient(z0);
    let scale_h = if ham.flags().exact_divided_differences {
        0.0
    } else {
        energy.abs().max(z0.component_mul(&g0).abs().sum())
    };
    let z0_size = z0.amax().max(f64::MIN_POSITIVE);
    // (At an equilibrium, `grad H = 0`, the step does not move and the floor is not needed.)
    let floor = if scale_h > 0.0 && g0.amax() > 0.0 {
        options.residual_tolerance() * scale_h / (g0.amax() * z0_size)
    } else {
        0.0
    };
    let newton = NewtonOptions::default();
    // The peer's Newton accepts an update that stopped shrinking below its stall tolerance
    // (relative to `|z|`); raise it to the floor (capped at the peer's largest allowed value,
    // below which an update that still contracts is never accepted).
    let stall = floor.clamp(newton.stall_tolerance, 1e-8);
    let newton = newton.with_stall_tolerance(stall).unwrap_or(newton);
    let mut method = DiscreteGradient::with_newton(newton);
    let z = OneStepMethod::<D, H>::step(&mut method, ham, z0, dt).map_err(|e| at_step(e, step))?;
    let iterations = OneStepMethod::<D, H>::newton_iterations(&method);
    if !all_finite(&z) {
        return Err(Error::NonFinite {
            step,
            what: "H or its derivatives after a fallback step",
        });
    }
    let d = linear::point(ham, &z, linear::matrix(ham, storage));
    if !d.finite() || !d.hessian_finite() {
        return Err(Error::NonFinite {
            step,
            what: "H or its derivatives after a fallback step",
        });
    }
    // H(z) - H(z0) = gbar . (z - z0) = gbar . f exactly: the energy error the solve's own
    // residual explains, allowed in the check before projecting.
    let gbar = ham.discrete_gradient(z0, &z);
    let move_ = j_times(&gbar) * dt;
    let f = (&z - z0) - &move_;
    // The peer's Newton accepts on its update size; insist on the residual too, relative to the
    // terms it is a difference of (a near-collision step can stall far from the solution),
    // including the rounding `dt scale_h / |d|` of the discrete gradient's correction (above).
    let d_size = (&z - z0).norm();
    let correction = if d_size > 0.0 && scale_h > 0.0 {
        dt * scale_h / d_size
    } else {
        0.0
    };
    let scale = z
        .amax()
        .max(z0.amax())
        .max(move_.amax())
        .max(correction)
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
    let (z, point) = project_onto_energy(
        ham,
        energy,
        z,
        d,
        roundoff_scale(z0, &g0),
        gbar.dot(&f),
        options,
        step,
        linear::matrix(ham, storage),
    )?;
    Ok(FallbackStep {
        z,
        point,
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
