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
//! not random-walk. Where rounding the projected node's positions leaves more than rounding its
//! momenta would (close encounters), the momenta alone then take the rest of the move
//! ([`project_momenta`]): `H(z1) - H(zbar_0)` is at the roundoff of `H`'s terms. Second order,
//! symmetric.
//!
//! # References
//! O. Gonzalez, *Time integration and discrete Hamiltonian systems*, J. Nonlinear Sci. 6
//! (1996); R. I. McLachlan, G. R. W. Quispel, N. Robidoux, *Geometric integration using
//! discrete gradients*, Phil. Trans. R. Soc. A 357 (1999). Used where Shibberu's DTH has no
//! positive root (thesis Ch. III, Thm 3.11).

use super::linear::{largest, Linear, Point};
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
    /// The Newton correction `A^{-1} f` of the residual check (see [`converged`]).
    delta: OVector<f64, D>,
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
            delta: zeros(d),
            method,
        }
    }
}

/// One discrete-gradient step of size `dt` from `z0` (which lies on `H = energy`), checked (see
/// [`converged`]) and projected onto `H = energy` (along `grad H`, then, where the positions'
/// rounding needs it, along the momenta: [`project_momenta`]), into `work` (`z`, `point`);
/// returns the peer's Newton iterations. The peer's Newton failures come back as its `Method*`
/// errors. `solver` is the stepper's linear algebra (see `dth::linear`): the new point is
/// evaluated without a `D x D` Hessian where `H` takes the structured path.
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
    let tolerance = options.residual_tolerance() * scale;
    // (The correction check evaluates `H` at the step's midpoint.)
    let corrected = residual > tolerance;
    if residual.is_nan() || (corrected && !converged(ham, z0, dt, tolerance, solver, &mut *w)) {
        return Err(Error::MethodNotConverged {
            method: "discrete_gradient",
            step,
            iterations,
            residual,
        });
    }
    // The energy error the solve leaves: `gbar . f` for a residual that passed the plain
    // check; for one judged by its Newton correction, `z` is `delta` away from the solution,
    // so `gbar . delta` (the residual itself then carries the amplified rounding of `z`, and
    // `gbar . f` would excuse any deviation: seen on a near-collision Kepler orbit, a node
    // 139 off `H = E` at a roundoff scale of 6e3 passed). A deviation beyond it is a step
    // that did not converge: redone smaller, like the peer's own failures.
    let explained = if corrected {
        w.gbar.dot(&w.delta)
    } else {
        w.gbar.dot(&w.f)
    };
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
    )
    .map_err(|e| match e {
        Error::EnergyCheckFailed { .. } if corrected => Error::MethodNotConverged {
            method: "discrete_gradient",
            step,
            iterations,
            residual,
        },
        e => e,
    })?;
    project_momenta(ham, energy, solver, w);
    if corrected {
        // The caller reads the node's Hessian from the solver (the robust mode's `Psi_scale`),
        // which may still hold the midpoint's (a node on `H = E` is not moved, and a move not
        // kept leaves its try's). Only on this rare path: re-evaluate at the node.
        solver.evaluate(ham, &w.z, &mut w.point);
    }
    Ok(u32::try_from(iterations).unwrap_or(u32::MAX))
}

/// Deviation from `H = E`, relative to the larger of `|E|` and `sum_i |p_i dH/dp_i|`, at or
/// below which [`project_momenta`] leaves the node alone. Below it the positions' rounding is
/// not what is left: after the move along `grad H` the deviation is at most about
/// `eps/2 sum_i |z_i dH/dz_i|`, so it exceeds `8 eps` of the momenta's sum only where the
/// positions' sum is over 8 times theirs (a close pair far from the origin, a coordinate that
/// grows); on Kepler the two sums are alike and the node is never moved (with `1 eps` here the
/// thesis's DTH run moved 2% of its points for no measurable gain). What a node that is not
/// moved keeps is at most `8 eps max(|E|, 2T)`, `16 eps` of the terms' size `T + |V|` for a
/// kinetic energy `T`.
const MOVE_MOMENTA_ABOVE: f64 = 8.0 * f64::EPSILON;

/// After the move along `grad H` ([`project_onto_energy`]), move the node onto `H = E` along the
/// momentum part of `grad H` alone, where the deviation left is the rounding of the positions.
///
/// The move along `grad H` lands on the float grid: each coordinate is rounded by up to half
/// an ulp, which moves `H` by up to `eps/2 sum_i |z_i dH/dz_i|`. Near a close encounter the
/// positions dominate that sum by far: a pair at separation `r` at positions of size `|q|`
/// has `|q_i dH/dq_i| ~ |q| / r^2` against its energy `1/r` (its separation is known only to
/// `eps |q| / r` relative), so the node is off `H = E` by up to `|q| / r` times the roundoff of
/// `H`'s terms. Measured on a 50-body cluster (`D = 200`, `dtau = 0.002`, 5,056 steps): up to
/// `8e-11` of the terms' size `T + |V|`, `|H - H0| = 6e-4` at `|H0| = 971`. A move of the
/// momenta alone lands on a grid whose energy steps are `eps |p_i dH/dp_i|` (about `eps T` in
/// all for a kinetic energy `|p|^2/2m`), the roundoff of the terms: after it the same run's
/// fallback nodes stay within `1.6e-15` of `T + |V|`. The move, `dev / |dH/dp|`, changes the
/// momenta by about `eps |q| / r` relative, the relative rounding of the pair's separation
/// itself: it picks, within the state's own rounding, a node that has the energy. A move that
/// does not reduce the deviation is not kept; no momentum dependence, nothing to move.
///
/// Fallback nodes only: a DTH midpoint moved so would break the quadratic invariants that DTH
/// keeps at its vertices by the same factor (on a Kepler pair at `|q| = 100`, separation
/// `2.5e-3`, with exact divided differences: the vertex angular momentum's deviation went from
/// `7.7e-12` to `5.1e-11` while the midpoints' energy went from `1.6e-12` to `1.4e-15` of the
/// terms); a fallback node has no vertex invariants to keep.
fn project_momenta<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    energy: f64,
    solver: &mut L,
    w: &mut FallbackWork<D>,
) where
    DefaultAllocator: Alloc<D>,
{
    let (z, d) = (&mut w.z, &mut w.point);
    let deviation = d.value - energy;
    let n = z.len() / 2;
    let (mut gg, mut momenta) = (0.0f64, 0.0f64);
    for i in n..z.len() {
        gg += d.gradient[i] * d.gradient[i];
        momenta += (z[i] * d.gradient[i]).abs();
    }
    if deviation.abs() <= MOVE_MOMENTA_ABOVE * energy.abs().max(momenta) || gg == 0.0 {
        return;
    }
    let c = deviation / gg;
    for i in 0..z.len() {
        w.zp[i] = if i < n {
            z[i]
        } else {
            z[i] - d.gradient[i] * c
        };
    }
    solver.evaluate(ham, &w.zp, &mut w.pp);
    if w.pp.finite() && w.pp.hessian_finite() && (w.pp.value - energy).abs() < deviation.abs() {
        std::mem::swap(z, &mut w.zp);
        std::mem::swap(d, &mut w.pp);
    }
}

/// Whether the solution `w.z` of a fallback step whose residual `w.f` failed the plain check
/// is nevertheless converged: the Newton correction it implies, `delta = A^{-1} f` with the
/// peer's Newton matrix `A = I - (dt/2) J Hess H(y)` at the step's midpoint
/// `y = (z0 + z)/2`, is at most `tolerance` (the error left in `z` to first order).
///
/// The residual of the exact solution rounded to floats, `z = z* + rho` (`|rho_i|` half an ulp
/// of `z_i`), is `f = A rho`: near a close encounter, where `(dt/2) |Hess H|` is large, it is
/// the rounding of the positions times `(dt/2) Hess H`, far above `eps |z|`. Measured on a
/// 50-body cluster (`dtau = 0.002`, 5,056 steps, `(dt/2) max |Hess H_ij|` of `7e3` to `5e5` at
/// those steps): 386 fallback solves failed the plain check with residuals of 64-1,240
/// `eps |z|`, and 3,841 with Gonzalez's discrete gradient, where each rejection halved the step
/// until it was stuck at `dt = 5e-14` at a tight binary (the run reached `t = 0.107` against
/// `0.209`). With this check, 313 of the 318 such solves of the run have a correction below
/// half an ulp and are kept; 5 (corrections of 77-770 `eps |z|`) are still rejected.
/// `A^{-1} f` measures what the residual means for `z` whatever the conditioning. Costs one
/// evaluation, factorization and solve, only where the plain check fails; `w.zp`, `w.pp` and
/// `w.delta` are scratch, the solver's Hessian is `H`'s at `y` afterwards.
fn converged<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    z0: &OVector<f64, D>,
    dt: f64,
    tolerance: f64,
    solver: &mut L,
    w: &mut FallbackWork<D>,
) -> bool
where
    DefaultAllocator: Alloc<D>,
{
    for ((y, a), b) in w.zp.iter_mut().zip(z0.iter()).zip(w.z.iter()) {
        *y = (a + b) * 0.5;
    }
    solver.evaluate(ham, &w.zp, &mut w.pp);
    if !w.pp.hessian_finite() || solver.factor(0.5 * dt).is_err() {
        return false;
    }
    solver.solve_into(&w.f, &mut w.delta);
    // (A NaN fails the comparison.)
    largest(w.delta.as_slice()) <= tolerance
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
// DTH runs where the ratio is at least [`leave_below`], on either side of a sign change (the
// run's law of time keeps its magnitude: `lambda^3 |Psi| = law`); fallback steps bridge the
// bands around the sign changes, with the physical step `dt = dtau lambda`, `lambda` the law of
// time's [`lambda_of`]: DTH's own `(law / |Psi|)^(1/3)` from the ratio at which DTH resumes
// ([`RESUME_ABOVE`]) up, a fraction of it that shrinks linearly toward the sign change below:
// a function of the state and `dtau` only, continuous where DTH resumes and bounded inside the
// band, so that both kinds of step shrink with `dtau` and the run converges at the order of
// its steps.
// ---------------------------------------------------------------------------------------------

/// Ratio `|Psi| / Psi_scale` below which an order-2 run leaves DTH for fallback steps (see
/// [`leave_below`]). On the Kepler problem (pericentre 0.5, thesis normalisation) the ratio
/// stays above 0.21 along the whole orbit for e <= 0.7 and above 0.11 for e = 0.75, so those
/// runs never fall back; at e >= 0.8 it passes through zero. At the band's edge DTH's `lambda`
/// is `LEAVE_BELOW^(-1/3) ~ 2.5` times what it would be where nothing cancels.
///
/// A single DTH step (order 2) that ends below it is kept, and the next step is a fallback
/// step: redoing it instead changed the Kepler errors by under 1% and lowered the driven
/// pendulum's observed order from 2 to 1.89. Above [`LEAVE_BELOW_COMPOSED`] for order 2: the
/// DTH step that ends inside the band (its `lambda` growing as `Psi` cancels) made most of the
/// pendulum in rotation's error, by an amount that varies irregularly with `dtau`. Measured
/// with the law of [`lambda_of`], order 2: error / `dtau^2` of the pendulum in rotation
/// (`p0 = 2.5`, `t = 20`) over 48 `dtau` from 0.01 to 0.00125, median 3.4 and largest 11.0 at
/// 0.05, 2.8 and 7.6 at 0.065; of the driven pendulum (12 `dtau`), median 5.0 and 3.0; Kepler
/// e = 0.9, three orbits, `dtau` 0.001: 9.0e-4 and 9.2e-4.
pub(crate) const LEAVE_BELOW: f64 = 0.065;

/// Ratio below which a composed run (orders 4-8) leaves DTH: no DTH midpoint below it is kept,
/// a composed step any of whose sub-steps ends below it is redone from its start as fallback
/// steps. A composed step spans several `dtau` and its sub-steps go back and forth; those that
/// reached into a band kept its growing `lambda`, and their local errors dominated the run's.
/// Measured on Kepler e = 0.9, order 8, three orbits, when only sub-steps below a quarter of it
/// were rejected: the error stayed at 4e-5 to 1e-4 for `dtau` 0.04 down to 0.01 (single
/// composed steps with lambda 100-135 and local errors of 3e-6), then fell by 10^4 within two
/// halvings; rejecting below it, 7e-5, 1.4e-5, 3.7e-6, 4.5e-8, 3.0e-9 for `dtau` 0.04, 0.028,
/// 0.02, 0.014, 0.01, at the same cost (2% more Newton iterations). Lower than order 2's: with
/// 0.07 here, order 8's fitted order (the range of `robust_convergence`, shifted by
/// `2^(-j/12)`, j = 0..11) fell from a median of 6.1 to 5.4, the lowest from 4.7 to 3.7.
pub(crate) const LEAVE_BELOW_COMPOSED: f64 = 0.05;

/// The ratio below which a run of `stages` sub-steps per step leaves DTH.
pub(crate) fn leave_below(stages: usize) -> f64 {
    if stages > 1 {
        LEAVE_BELOW_COMPOSED
    } else {
        LEAVE_BELOW
    }
}

/// Ratio at a fallback node from which DTH resumes: above both [`LEAVE_BELOW`]s, so that a run
/// does not flip between the two kinds of step at the band's edge (one DTH step changes the
/// ratio by `O(dtau)`).
pub(crate) const RESUME_ABOVE: f64 = 0.1;

/// The fallback law's `lambda`, relative to DTH's at [`RESUME_ABOVE`], where `Psi` changes
/// sign: below `RESUME_ABOVE` the law goes linearly from DTH's value there down to this
/// fraction of it. The fallback steps at the band's edge, where DTH's `lambda` had grown by
/// `RESUME_ABOVE^(-1/3)`, carried half the run's error (Kepler e = 0.9, order 2, `dtau` 0.001:
/// 1.41e-3, a step law bounded at DTH's edge value); shrinking them toward the sign change left
/// 9.2e-4 at 11% more steps. A law with no such bound in between (`lambda^3 Psi_scale = law`)
/// left 8.1e-4, but the pendulum in rotation's error then varied irregularly with `dtau`.
const BAND_CENTRE: f64 = 0.3;

/// `lambda (Psi_scale / law)^(1/3)` of the law of time at the ratio `r = |Psi| / Psi_scale`:
/// DTH's `r^(-1/3)` from [`RESUME_ABOVE`] up, linear down to [`BAND_CENTRE`] of it at `r = 0`.
fn law_factor(r: f64) -> f64 {
    let edge = RESUME_ABOVE.cbrt().recip();
    if r >= RESUME_ABOVE {
        r.cbrt().recip()
    } else {
        let x = r / RESUME_ABOVE;
        edge * (BAND_CENTRE + (1.0 - BAND_CENTRE) * x)
    }
}

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

/// The robust mode's law of time `law` through `(lambda, Psi, Psi_scale)` at a point (the
/// inverse of [`lambda_of`]; `lambda^3 |Psi|` from [`RESUME_ABOVE`] up): `None` when not
/// positive and finite (`Psi` and its scale both zero there: the law is then taken at the first
/// point where it is).
pub(crate) fn law_through(lambda: f64, psi: f64, scale: f64) -> Option<f64> {
    let law = if psi.abs() >= RESUME_ABOVE * scale {
        lambda.powi(3) * psi.abs()
    } else {
        scale * (lambda / law_factor(psi.abs() / scale)).powi(3)
    };
    (law.is_finite() && law > 0.0).then_some(law)
}

/// The multiplier the law of time `law` gives at a point with `(Psi, Psi_scale)`: DTH's own
/// `(law / |Psi|)^(1/3)` where `Psi` does not cancel (from [`RESUME_ABOVE`] up), bounded and
/// shrinking toward the sign change inside the bands where it does; `None` when not positive
/// and finite.
pub(crate) fn lambda_of(law: f64, psi: f64, scale: f64) -> Option<f64> {
    let lambda = if psi.abs() >= RESUME_ABOVE * scale {
        (law / psi.abs()).cbrt()
    } else {
        (law / scale).cbrt() * law_factor(psi.abs() / scale)
    };
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

/// Two gravitating bodies as a cluster writes them (a close pair far from the origin), shared
/// with the integration tests.
#[cfg(test)]
#[path = "../../tests/hard_support/pair.rs"]
mod test_pair;

#[cfg(test)]
mod tests {
    use super::test_pair::{Pair, V8};
    use super::*;
    use crate::dth::linear::Dense;
    use nalgebra::Const;

    /// The pair at separation `r` on a circular relative orbit about `(1, 0.5)`, drifting at
    /// `(0.3, 0)`; and its relative period.
    fn pair(r: f64) -> (V8, f64) {
        let period = 2.0 * std::f64::consts::PI * (r.powi(3) / 2.0).sqrt();
        (Pair::at_pericentre(r, 0.0), period)
    }

    /// `f = (z - z0) - dt J gbar(z0, z)` into `w.f`, as [`fallback_step`] computes it.
    fn residual_into(z0: &V8, dt: f64, w: &mut FallbackWork<Const<8>>) {
        Pair.discrete_gradient_into(z0, &w.z, &mut w.gbar);
        for i in 0..8 {
            let jg = if i < 4 { w.gbar[i + 4] } else { -w.gbar[i - 4] };
            w.f[i] = (w.z[i] - z0[i]) - jg * dt;
        }
    }

    /// The pair at separation `1e-5`, a step of 1% of its period, solved by the peer: its
    /// solution and residual in `w` (`z`, `f`), and `(z0, dt)`.
    fn solved(w: &mut FallbackWork<Const<8>>) -> (V8, f64) {
        let (z0, period) = pair(1e-5);
        let dt = 0.01 * period;
        OneStepMethod::<Const<8>, Pair>::step_into(
            &mut DiscreteGradient::new(),
            &Pair,
            &z0,
            dt,
            &mut w.z,
        )
        .expect("the peer converges");
        residual_into(&z0, dt, w);
        (z0, dt)
    }

    /// At separation `1e-5` and a step of 1% of the period `(dt/2) |Hess H|` is about `1e3`:
    /// the residual of the converged step is the rounding of the positions (relative to 1)
    /// amplified by it, about 1,600 `eps |z|` (25 times the tolerance), and the plain check
    /// alone rejected the step (the robust mode then halved it, in vain). Its Newton
    /// correction is below an ulp: it is converged.
    #[test]
    fn a_converged_step_at_a_close_encounter_is_accepted() {
        let options = DthOptions::thesis_kepler();
        let mut work = FallbackWork::new(&Pair, true);
        let mut dense = Dense::new(Const::<8>);
        let (z0, dt) = solved(&mut work);
        let scale = work.z.amax();
        let tolerance = options.residual_tolerance() * scale;
        let residual = work.f.amax();
        assert!(residual > 10.0 * tolerance, "{:e}", residual / scale);
        assert!(converged(&Pair, &z0, dt, tolerance, &mut dense, &mut work));
        assert!(largest(work.delta.as_slice()) <= f64::EPSILON * scale);
        let energy = Pair.value(&z0);
        let result = fallback_step(&Pair, &z0, dt, energy, &options, 3, &mut dense, &mut work);
        assert!(result.is_ok(), "{result:?}");
    }

    /// The same solution moved by `1e-9` relative: the correction sees it.
    #[test]
    fn an_unconverged_step_is_rejected() {
        let options = DthOptions::thesis_kepler();
        let mut work = FallbackWork::new(&Pair, true);
        let mut dense = Dense::new(Const::<8>);
        let (z0, dt) = solved(&mut work);
        let scale = work.z.amax();
        work.z[6] += 1e-9 * scale;
        residual_into(&z0, dt, &mut work);
        let tolerance = options.residual_tolerance() * scale;
        assert!(!converged(&Pair, &z0, dt, tolerance, &mut dense, &mut work));
        let moved = largest(work.delta.as_slice()) / scale;
        assert!((0.5e-9..2e-9).contains(&moved), "{moved:e}");
    }
}
