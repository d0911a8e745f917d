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

use super::linear::{Linear, Point};
use super::newton::{all_finite, project_onto_energy, roundoff_scale};
use super::options::DthOptions;
use crate::hamiltonian::Alloc;
use crate::methods::{DiscreteGradient, NewtonOptions, OneStepMethod};
use crate::{zeros, Error, Hamiltonian};
use nalgebra::{DefaultAllocator, Dim, OVector};

/// The storage of fallback steps, kept by the stepper (built once: a step of a `Dyn`
/// dimension allocates nothing). After [`fallback_step`], `z` and `point` hold the new node
/// and `H`'s value, gradient and `Psi` there.
#[derive(Clone, Debug)]
pub(crate) struct FallbackWork<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    pub(crate) z: OVector<f64, D>,
    pub(crate) point: Point<D>,
    g0: OVector<f64, D>,
    gbar: OVector<f64, D>,
    f: OVector<f64, D>,
    zp: OVector<f64, D>,
    pp: Point<D>,
    /// The discrete-gradient peer (its Newton buffers kept between steps).
    method: DiscreteGradient,
}

impl<D: Dim> FallbackWork<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Storage for fallback steps on `H`; the peer's Newton buffers too when `robust` (a
    /// fallback step may come at any step and must not allocate then; without the robust mode
    /// only [`Dth::diagnose`](super::Dth::diagnose) walks with the peer, on an error path, where
    /// allocating its buffers is fine and a `Dyn` stepper of a large `D` is spared a second
    /// `D x D` Hessian and LU).
    pub(crate) fn new<H: Hamiltonian<D>>(ham: &H, robust: bool) -> Self {
        let d = ham.dim();
        let mut method = DiscreteGradient::new();
        if robust {
            method.reserve(ham);
        }
        FallbackWork {
            z: zeros(d),
            point: Point::zeros(d),
            g0: zeros(d),
            gbar: zeros(d),
            f: zeros(d),
            zp: zeros(d),
            pp: Point::zeros(d),
            method,
        }
    }
}

/// One discrete-gradient step of size `dt` from `z0` (which lies on `H = energy`), checked and
/// projected onto `H = energy`, into `work` (`z`, `point`); returns the peer's Newton
/// iterations. The peer's Newton failures come back as its `Method*` errors. `solver` is the
/// stepper's linear algebra (see `dth::linear`): the new point is evaluated without a `D x D`
/// Hessian where `H` takes the structured path.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fallback_step<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    z0: &OVector<f64, D>,
    dt: f64,
    energy: f64,
    options: &DthOptions,
    step: usize,
    solver: &mut L,
    work: &mut FallbackWork<D>,
) -> Result<u32, Error>
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
    let w = work;
    ham.gradient_into(z0, &mut w.g0);
    let scale_h = if ham.flags().exact_divided_differences {
        0.0
    } else {
        energy.abs().max(roundoff_scale(z0, &w.g0))
    };
    let z0_size = z0.amax().max(f64::MIN_POSITIVE);
    // (At an equilibrium, `grad H = 0`, the step does not move and the floor is not needed.)
    let floor = if scale_h > 0.0 && w.g0.amax() > 0.0 {
        options.residual_tolerance() * scale_h / (w.g0.amax() * z0_size)
    } else {
        0.0
    };
    let newton = NewtonOptions::default();
    // The peer's Newton accepts an update that stopped shrinking below its stall tolerance
    // (relative to `|z|`); raise it to the floor (capped at the peer's largest allowed value,
    // below which an update that still contracts is never accepted).
    let stall = floor.clamp(newton.stall_tolerance, 1e-8);
    w.method.newton = newton.with_stall_tolerance(stall).unwrap_or(newton);
    let before = OneStepMethod::<D, H>::newton_iterations(&w.method);
    OneStepMethod::<D, H>::step_into(&mut w.method, ham, z0, dt, &mut w.z)
        .map_err(|e| at_step(e, step))?;
    let iterations = OneStepMethod::<D, H>::newton_iterations(&w.method) - before;
    if !all_finite(&w.z) {
        return Err(Error::NonFinite {
            step,
            what: "H or its derivatives after a fallback step",
        });
    }
    solver.evaluate(ham, &w.z, &mut w.point);
    if !w.point.finite() || !w.point.hessian_finite() {
        return Err(Error::NonFinite {
            step,
            what: "H or its derivatives after a fallback step",
        });
    }
    // H(z) - H(z0) = gbar . (z - z0) = gbar . f exactly: the energy error the solve's own
    // residual explains, allowed in the check before projecting.
    ham.discrete_gradient_into(z0, &w.z, &mut w.gbar);
    // f = (z - z0) - dt J gbar, and the size of dt J gbar; `zp` holds z - z0 for its norm.
    let n = z0.len() / 2;
    let mut move_max = 0.0f64;
    for i in 0..z0.len() {
        let jg = if i < n { w.gbar[i + n] } else { -w.gbar[i - n] };
        let m = jg * dt;
        move_max = move_max.max(m.abs());
        w.zp[i] = w.z[i] - z0[i];
        w.f[i] = w.zp[i] - m;
    }
    // The peer's Newton accepts on its update size; insist on the residual too, relative to the
    // terms it is a difference of (a near-collision step can stall far from the solution),
    // including the rounding `dt scale_h / |d|` of the discrete gradient's correction (above).
    let d_size = w.zp.norm();
    let correction = if d_size > 0.0 && scale_h > 0.0 {
        dt * scale_h / d_size
    } else {
        0.0
    };
    let scale =
        w.z.amax()
            .max(z0.amax())
            .max(move_max)
            .max(correction)
            .max(f64::MIN_POSITIVE);
    let residual = w.f.amax();
    if residual.is_nan() || residual > options.residual_tolerance() * scale {
        return Err(Error::MethodNotConverged {
            method: "discrete_gradient",
            step,
            iterations,
            residual,
        });
    }
    let explained = w.gbar.dot(&w.f);
    project_onto_energy(
        ham,
        energy,
        (&mut w.z, &mut w.point),
        (&mut w.zp, &mut w.pp),
        roundoff_scale(z0, &w.g0),
        explained,
        options,
        step,
        solver,
    )?;
    Ok(u32::try_from(iterations).unwrap_or(u32::MAX))
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

// ---------------------------------------------------------------------------------------------
// The policy of the robust mode: when DTH runs, when a fallback step replaces it, how large
// the fallback step is.
//
// DTH's step has a positive root near `lambda_k` wherever `Psi != 0` (thesis Thm 3.11), of
// either sign; what breaks it is `Psi` passing through zero, where the law of time
// `lambda^3 Psi = const` (paper Theorem 5) sends `lambda`, hence the physical step, to
// infinity. So the robust mode measures how close `Psi = sum_ij v_i H_ij v_j`
// (`v = J grad H`, `H_ij` the Hessian) is to cancelling, as its ratio to the size of its terms,
// `Psi_scale = sum_ij |v_i H_ij v_j|`: 1 where no terms cancel, 0 where `Psi` changes sign
// (in the extended phase space `H_tt` is one of the terms, so a drive's `f''(t)` that cancels
// the rest is seen too). Each term is unchanged by rescaling a coordinate and its conjugate
// momentum (`q_i -> a q_i`, `p_i -> p_i / a`: units), so the ratio does not depend on them.
// DTH runs where the ratio is at least `LEAVE_BELOW`, on either side of a sign change (the
// run's law of time keeps its magnitude: `lambda^3 |Psi| = law`); fallback steps bridge the
// bands around the sign changes, with the physical step
// `dt = dtau (law / max(|Psi|, LEAVE_BELOW Psi_scale))^(1/3)`: a function of the state and
// `dtau` only, equal to DTH's law of time at the edge of the band and bounded inside it, so
// that both kinds of step shrink with `dtau` and the run converges at the order of its steps.
// ---------------------------------------------------------------------------------------------

/// Ratio `|Psi| / Psi_scale` below which the robust mode leaves DTH for fallback steps. On the
/// Kepler problem (pericentre 0.5, thesis normalisation) the ratio stays above 0.21 along the
/// whole orbit for e <= 0.7 and above 0.11 for e = 0.75, so those runs never fall back; at
/// e >= 0.8 it passes through zero. At the band's edge DTH's `lambda` is
/// `LEAVE_BELOW^(-1/3) ~ 2.7` times what it would be where nothing cancels.
pub(crate) const LEAVE_BELOW: f64 = 0.05;

/// Ratio at a fallback node from which DTH resumes: twice [`LEAVE_BELOW`], so that a run does
/// not flip between the two kinds of step at the band's edge (one DTH step changes the ratio
/// by `O(dtau)`).
pub(crate) const RESUME_ABOVE: f64 = 2.0 * LEAVE_BELOW;

/// Ratio at a midpoint inside a composed DTH step (order 4-8) below which the composed step is
/// redone as fallback steps: a composed step spans several `dtau` and may reach deep into a
/// band it started outside of, where its `lambda` grows without bound.
pub(crate) const REJECT_BELOW: f64 = 0.25 * LEAVE_BELOW;

/// What the robust mode's next step is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mode {
    /// A DTH step (always, without the robust mode).
    Dth,
    /// A fallback step.
    Fallback,
}

/// Scratch of [`psi_scale`].
#[derive(Clone, Debug)]
pub(crate) struct ScaleWork<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    v: OVector<f64, D>,
}

impl<D: Dim> ScaleWork<D>
where
    DefaultAllocator: Alloc<D>,
{
    pub(crate) fn new(d: D) -> Self {
        ScaleWork { v: zeros(d) }
    }
}

/// `Psi_scale = sum_ij |v_i H_ij v_j|` (`v = J grad H`, `H_ij` the Hessian last evaluated by
/// `solver`).
pub(crate) fn psi_scale<L: Linear<D>, D: Dim>(
    solver: &L,
    gradient: &OVector<f64, D>,
    work: &mut ScaleWork<D>,
) -> f64
where
    DefaultAllocator: Alloc<D>,
{
    let n = gradient.len() / 2;
    for i in 0..n {
        work.v[i] = gradient[i + n];
        work.v[i + n] = -gradient[i];
    }
    solver.hessian_abs_form(&work.v)
}

/// The robust mode's law of time `lambda^3 max(|Psi|, LEAVE_BELOW Psi_scale) = law` through
/// `(lambda, Psi, Psi_scale)` at a point: `None` when not positive and finite (`Psi` and its
/// scale both zero there: the law is then taken at the first point where it is).
pub(crate) fn law_through(lambda: f64, psi: f64, scale: f64) -> Option<f64> {
    let law = lambda.powi(3) * psi.abs().max(LEAVE_BELOW * scale);
    (law.is_finite() && law > 0.0).then_some(law)
}

/// The multiplier the law of time `law` gives at a point with `(Psi, Psi_scale)`: DTH's own
/// `(law / |Psi|)^(1/3)` where `Psi` does not cancel, bounded inside the bands where it does;
/// `None` when not positive and finite.
pub(crate) fn lambda_of(law: f64, psi: f64, scale: f64) -> Option<f64> {
    let lambda = (law / psi.abs().max(LEAVE_BELOW * scale)).cbrt();
    (lambda.is_finite() && lambda > 0.0).then_some(lambda)
}

/// `|Psi| / Psi_scale` (1 where the scale is zero: nothing cancels).
pub(crate) fn cancellation_ratio(psi: f64, scale: f64) -> f64 {
    if scale > 0.0 {
        psi.abs() / scale
    } else {
        1.0
    }
}
