//! Newton solvers for one DTH segment.
//!
//! The step equation (paper eq. 28, thesis 2.3.5) from midpoint `zbar_k` with multiplier
//! `lambda_k` says that the right vertex of segment `k`,
//! `v = zbar_k + (h/2) lambda_k J gradH(zbar_k)`, is also the left vertex of segment `k + 1`:
//!
//! ```text
//! f(z, lambda) = z - v - (h/2) lambda J gradH(z) = 0,      r(z) = H(z) - E = 0,
//! ```
//!
//! with `E = H(zbar_0)` (eq. 30: measured against the first midpoint, not the previous one, so
//! the energy error cannot random-walk). Unknowns `z = zbar_{k+1}`, `lambda = lambda_{k+1}`.
//!
//! Both solvers share one Jacobian `A = I - (h lambda/2) J HessH(z)` and the derivative
//! `z_lambda = A^{-1} (h/2) J gradH(z)` of the decoupling function `z(h, lambda)` (thesis 3.2).
//! `g_lambda = gradH^T z_lambda` is `O(h^2)`; it is computed as
//! `(h lambda/2) gradH^T J HessH z_lambda` (the dropped term `(h/2) gradH^T J gradH` is exactly
//! zero), which keeps full relative accuracy.
//!
//! The linear algebra (factor `A`, solve, `Hess z_lambda`) and the evaluations of `H` go through
//! `dth::linear`: the dense fixed-size LU for small `D`, the structured `NewtonMatrix` (no
//! `D x D` matrix anywhere) for generated types beyond the crossover. Both solvers factor `A`
//! alone and border it with two solves, so the structured solver sees only `A`'s band.
//!
//! Joint Newton factors `A` afresh while the relative update is above `1e-6` and keeps the last
//! factorization below (simplified Newton: as fast there, one factorization fewer per step on
//! the thesis Kepler orbit); `Segment::factorizations` counts the factorizations.
//!
//! Newton stops by the crate's one stopping rule ([`crate::newton`]) with the DTH parameters:
//! relative updates `u = max(|dz|/|z|, |dlambda|/|lambda|)`, every stop gated on the scaled
//! residual at the final iterate (nothing is accepted on the update size alone), and a stall
//! tolerance raised per iterate to the roundoff floor of the plain energy residual (see
//! `Eval::stall`). A gated stop that fails after an update of at most `4 eps`, or the iteration
//! limit, is [`Error::NewtonDiverged`].

use super::linear::{self, Dense, Linear, Point, Sparse};
use super::options::{DthOptions, Solver};
use crate::hamiltonian::Alloc;
use crate::linalg::Pivot;
use crate::methods::Structured;
use crate::newton::{self, Convergence, Status, DTH};
use crate::structured::NewtonMatrix;
use crate::{j_times, zeros, Error, Hamiltonian};
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Relative update below which joint Newton evaluates the cancellation-free residual at every
/// iterate: from there, quadratic convergence can reach a stop at the next iterate.
const CF_FROM: f64 = 1e-5;

/// Relative update at or below which joint Newton keeps the last factorization of `A` (and its
/// `z_lambda`, `g_lambda`) instead of factoring again: a simplified-Newton iteration. The
/// frozen matrix differs from the current one by `O(|Hess'| |dz|)`, so the iteration contracts
/// by about the last relative update: from `1e-6` the error after one such iteration is below
/// `1e-12` of what was left, as fast as Newton's to roundoff, and the stopping rule (gated on
/// the residual at the final iterate) is unchanged.
const REFACTOR_ABOVE: f64 = 1e-6;

/// One solved DTH segment: its midpoint, multiplier and both vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// Midpoint `zbar`.
    pub zbar: OVector<f64, D>,
    /// Multiplier `lambda = dt/dtau` on the segment.
    pub lambda: f64,
    /// `H(zbar)`.
    pub value: f64,
    /// `grad H(zbar)`.
    pub gradient: OVector<f64, D>,
    /// `Psi(zbar) = (J grad H)^T Hess H (J grad H)`.
    pub psi: f64,
    /// Newton iterations: for the joint solver its iterations; for the nested one the inner
    /// iterations of all its outer ones (each factors `A`, so this equals `factorizations`).
    pub iterations: u32,
    /// LU factorizations of `A` (the cost measure common to both solvers).
    pub factorizations: u32,
}

/// `Copy` for fixed sizes, as before the dimension became a type.
impl<const N: usize> Copy for Segment<nalgebra::Const<N>> {}

/// The previous midpoint of a step, for the cancellation-free energy residual (see
/// [`EnergyResidual`](super::EnergyResidual)): `H(z) - H(zbar_k)` is evaluated through exact
/// divided differences between `zbar_k` and `z`.
#[derive(Clone, Debug)]
pub(crate) struct Previous<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `zbar_k`.
    pub(crate) zbar: OVector<f64, D>,
    /// `grad H(zbar_k)`.
    pub(crate) gradient: OVector<f64, D>,
    /// `lambda_k`.
    pub(crate) lambda: f64,
}

/// What a segment is solved from: its left vertex `v`, the energy level `E`, and (for the
/// cancellation-free residual) the previous midpoint.
#[derive(Clone, Debug)]
pub(crate) struct Anchor<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    pub(crate) v: OVector<f64, D>,
    pub(crate) energy: f64,
    pub(crate) previous: Option<Previous<D>>,
}

/// The parts of the cancellation-free energy residual at one iterate.
struct CancellationFree<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    gbar: OVector<f64, D>,
    /// `(h/2) gbar^T J w`: equals `H(z) - H(zbar_k) - gbar . f`.
    r_cf: f64,
    /// Size of the terms `r_cf` is a sum of: `(h/4)(lambda + lambda_k) sum |gbar_i (g - g_k)_i|`.
    scale: f64,
    /// Roundoff scale of the energy residual when the Hamiltonian does not declare exact
    /// divided differences (the cancellation-free form forced on it): the plain residual's
    /// `|terms of H|`, which bounds the noise of a plain-difference `gbar` or defect. Zero for
    /// Hamiltonians with `exact_divided_differences`.
    inexact_scale: f64,
}

/// Everything the Newton loops need at one iterate.
struct Eval<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    d: Point<D>,
    jg: OVector<f64, D>,
    f: OVector<f64, D>,
    /// Energy residual for the Newton update: `H(z) - E` (plain) or `H(z) - H(zbar_k)` as
    /// `r_cf + gbar . f` (cancellation-free).
    r: f64,
    /// `|f| / scale_f`.
    f_residual: f64,
    /// Size of the terms of `f`: `|z|`, `|v|`, `|(h lambda/2) J grad H|`.
    scale_f: f64,
    /// Roundoff scale of the energy equation being solved: `scale_r`, or 0 for the
    /// cancellation-free form with exact divided differences.
    noise: f64,
    /// Plain scaled energy residual `|H(z) - E| / scale_r` (for the plain form and the final
    /// check of the cancellation-free form).
    plain_residual: f64,
    /// Size of the terms of `H(z) - E`.
    scale_r: f64,
    cf: Option<CancellationFree<D>>,
}

impl<D: Dim> Eval<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Storage for [`evaluate`], overwritten by each evaluation.
    fn empty(d: D) -> Self {
        Eval {
            d: Point {
                value: 0.0,
                gradient: zeros(d),
                psi: 0.0,
                hessian_max: 0.0,
            },
            jg: zeros(d),
            f: zeros(d),
            r: 0.0,
            f_residual: 0.0,
            scale_f: 0.0,
            noise: 0.0,
            plain_residual: 0.0,
            scale_r: 0.0,
            cf: None,
        }
    }

    /// The scaled residual Newton must drive below tolerance. For the cancellation-free form the
    /// energy part is the residual left after eliminating `f` to first order with the last
    /// linearization (`A` factored, `g_lambda`): `r_cf + gbar . f + grad H . A^{-1}(-f)`, whose
    /// roundoff is `eps h^2` (`r_cf + gbar . f` alone carries the rounding of `z` to the f64
    /// grid, `eps |z|`, through `gbar . f`). It is scaled by the larger of the size of the terms
    /// of `r_cf` and `|g_lambda lambda|` (the residual that a relative change `eps` of `lambda`
    /// makes): where the gradient barely turns (Kepler's apocentre) the terms are much smaller
    /// than the sensitivity, and the residual is a forward estimate of the relative error of
    /// `lambda`.
    fn residual<L: Linear<D>>(&self, last: Last<'_, L, D>, lambda: f64) -> f64 {
        let energy = match (&self.cf, last) {
            (Some(c), Some((lin, solver))) => {
                let g_lambda = lin.g_lambda;
                let u = solver.solve(&(-&self.f));
                let scale = c.scale.max((g_lambda * lambda).abs()).max(c.inexact_scale);
                (c.r_cf + (c.gbar.dot(&self.f) + self.d.gradient.dot(&u))).abs() / scale
            }
            (Some(_), None) => f64::INFINITY,
            (None, _) => self.plain_residual,
        };
        self.f_residual.max(energy)
    }

    /// The stall tolerance for this iterate: the option, raised for the plain residual to the
    /// relative noise its roundoff puts into `lambda`, `eps |terms of H| / |g_lambda lambda|`
    /// (`~eps / h^2`): below that, updates are noise and can never settle.
    /// The same holds for the cancellation-free form forced on a Hamiltonian without exact
    /// divided differences; with them the option stands.
    fn stall<L: Linear<D>>(&self, options: &DthOptions, last: Last<'_, L, D>, lambda: f64) -> f64 {
        let noise = self.noise;
        match last {
            Some((lin, _)) if noise > 0.0 => options
                .stall_tolerance()
                .max(8.0 * f64::EPSILON * noise / (lin.g_lambda * lambda).abs())
                .min(0.5),
            _ => options.stall_tolerance(),
        }
    }

    /// The residual gate of the stopping rule at the iterate `(z, lambda)` evaluated here.
    fn passes<L: Linear<D>>(
        &self,
        options: &DthOptions,
        last: Last<'_, L, D>,
        lambda: f64,
    ) -> bool {
        self.residual(last, lambda) <= options.residual_tolerance()
    }

    /// The failure of a segment solve after `iterations` Newton iterations (LU factorizations),
    /// at the iterate `(z, lambda)` evaluated here.
    fn diverged<L: Linear<D>>(
        &self,
        last: Last<'_, L, D>,
        lambda: f64,
        iterations: u32,
        step: usize,
    ) -> Error {
        Error::NewtonDiverged {
            step,
            iterations,
            residual: self.residual(last, lambda),
        }
    }

    /// The end of a segment solve at the iterate `(z, lambda)` evaluated here, after
    /// `iterations` Newton iterations and `factorizations` LU factorizations: the segment when
    /// Newton has converged, the failure when it has diverged (labelled with the iterations),
    /// `None` to go on.
    fn finish<L: Linear<D>>(
        &self,
        status: Status,
        (z, lambda): (&OVector<f64, D>, f64),
        last: Last<'_, L, D>,
        (iterations, factorizations): (u32, u32),
        step: usize,
    ) -> Option<Result<Segment<D>, Error>> {
        match status {
            Status::Converged => Some(Ok(Segment {
                zbar: z.clone(),
                lambda,
                value: self.d.value,
                gradient: self.d.gradient.clone(),
                psi: self.d.psi,
                iterations,
                factorizations,
            })),
            Status::Diverged => Some(Err(self.diverged(last, lambda, iterations, step))),
            Status::Continue => None,
        }
    }
}

fn pivot_error(p: Pivot, step: usize) -> Error {
    match p {
        Pivot::Singular => Error::SingularMatrix { step },
        Pivot::NonFinite => Error::NonFinite {
            step,
            what: "Newton matrix A = I - (h lambda/2) J Hess H",
        },
    }
}

pub(crate) fn all_finite<D: Dim>(v: &OVector<f64, D>) -> bool
where
    DefaultAllocator: Alloc<D>,
{
    v.iter().all(|x| x.is_finite())
}

/// Evaluate everything at the iterate `(z, lambda)` into `e`, the Hessian into `solver`.
#[allow(clippy::too_many_arguments)]
fn evaluate<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    solver: &mut L,
    anchor: &Anchor<D>,
    h: f64,
    z: &OVector<f64, D>,
    lambda: f64,
    step: usize,
    e: &mut Eval<D>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    e.d = solver.evaluate(ham, z);
    let d = &e.d;
    if !d.finite() {
        return Err(Error::NonFinite {
            step,
            what: "H or grad H at a Newton iterate",
        });
    }
    if !d.hessian_finite() {
        return Err(Error::NonFinite {
            step,
            what: "Hess H at a Newton iterate",
        });
    }
    let v = &anchor.v;
    let energy = anchor.energy;
    let jg = j_times(&d.gradient);
    let move_ = &jg * (0.5 * h * lambda);
    // Roundoff scales: the magnitudes of the terms each residual is a difference of.
    let scale_f = z
        .amax()
        .max(v.amax())
        .max(move_.amax())
        .max(f64::MIN_POSITIVE);
    let r_plain = d.value - energy;
    let scale_r = energy
        .abs()
        .max(d.value.abs())
        .max(z.component_mul(&d.gradient).abs().sum())
        .max(f64::MIN_POSITIVE);
    let plain_residual = r_plain.abs() / scale_r;
    let f = z - v - &move_;
    e.f_residual = f.amax() / scale_f;
    e.scale_f = scale_f;
    e.jg = jg;
    e.f = f;
    e.r = r_plain;
    e.plain_residual = plain_residual;
    e.scale_r = scale_r;
    e.cf = None;
    // The roundoff scale of the energy equation that is being solved (see `Eval::stall`): the
    // plain residual's, or, for the cancellation-free form, zero when the Hamiltonian has
    // exact divided differences.
    e.noise = if anchor.previous.is_some() && ham.flags().exact_divided_differences {
        0.0
    } else {
        scale_r
    };
    Ok(())
}

/// Replace the plain residuals of the evaluated iterate `e` at `(z, lambda)` by the
/// cancellation-free ones (the anchor must carry the previous midpoint).
fn add_cancellation_free<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    p: &Previous<D>,
    h: f64,
    z: &OVector<f64, D>,
    lambda: f64,
    step: usize,
    e: &mut Eval<D>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let d = &e.d;
    // f = (z - zbar_k) - (h/2) J (lambda g + lambda_k g_k): the difference z - zbar_k
    // is exact (Sterbenz) for small steps, so f carries roundoff eps h, not eps |z|.
    let dz = z - &p.zbar;
    let f = dz - j_times(&(&d.gradient * lambda + &p.gradient * p.lambda)) * (0.5 * h);
    let gbar = ham.discrete_gradient(&p.zbar, z);
    let t = ham.discrete_gradient_defect(&p.zbar, z, &gbar);
    let dg = &d.gradient - &p.gradient;
    let w = &dg * (0.5 * (lambda - p.lambda)) + t * (0.5 * (lambda + p.lambda));
    let r_cf = 0.5 * h * gbar.dot(&j_times(&w));
    let scale = (0.25 * h * (lambda + p.lambda)).abs() * gbar.component_mul(&dg).abs().sum()
        + f64::MIN_POSITIVE;
    if !r_cf.is_finite() || !all_finite(&gbar) {
        return Err(Error::NonFinite {
            step,
            what: "discrete gradient at a Newton iterate",
        });
    }
    let r = r_cf + gbar.dot(&f);
    let inexact_scale = if ham.flags().exact_divided_differences {
        0.0
    } else {
        e.scale_r
    };
    e.f_residual = f.amax() / e.scale_f;
    e.f = f;
    e.r = r;
    e.cf = Some(CancellationFree {
        gbar,
        r_cf,
        scale,
        inexact_scale,
    });
    Ok(())
}

/// `z_lambda` and `g_lambda` from the factored `A = I - (h lambda / 2) J HessH` (held by the
/// solver).
struct Linearization<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    z_lambda: OVector<f64, D>,
    g_lambda: f64,
}

impl<D: Dim> Linearization<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn empty(d: D) -> Self {
        Linearization {
            z_lambda: zeros(d),
            g_lambda: 0.0,
        }
    }
}

/// The last linearization and the solver holding its factorization; `None` before the first.
type Last<'a, L, D> = Option<(&'a Linearization<D>, &'a L)>;

/// Factor `A = I - c J HessH` (`c = h lambda / 2`) at the Hessian last evaluated.
fn factor<L: Linear<D>, D: Dim>(solver: &mut L, c: f64, step: usize) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    solver.factor(c).map_err(|p| pivot_error(p, step))
}

/// Linearize at the evaluated iterate `e` into `lin` (in place), factoring `A` in `solver`.
fn linearize<L: Linear<D>, D: Dim>(
    e: &Eval<D>,
    solver: &mut L,
    h: f64,
    lambda: f64,
    step: usize,
    lin: &mut Linearization<D>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    factor(solver, 0.5 * h * lambda, step)?;
    let z_lambda = solver.solve(&(&e.jg * (0.5 * h)));
    // Cancellation-free g_lambda = (h lambda/2) gradH^T J HessH z_lambda
    //                          = -(h lambda/2) (J gradH)^T HessH z_lambda.
    let g_lambda = -(0.5 * h * lambda) * e.jg.dot(&solver.hessian_times(&z_lambda));
    if !g_lambda.is_finite() || !all_finite(&z_lambda) {
        return Err(Error::NonFinite {
            step,
            what: "Newton linear solve",
        });
    }
    if g_lambda == 0.0 {
        return Err(Error::SingularMatrix { step });
    }
    lin.z_lambda = z_lambda;
    lin.g_lambda = g_lambda;
    Ok(())
}

/// The DTH measure of an update: the larger of the relative changes of `z` and `lambda`.
fn relative_update<D: Dim>(dz: &OVector<f64, D>, z: &OVector<f64, D>, dl: f64, lambda: f64) -> f64
where
    DefaultAllocator: Alloc<D>,
{
    (dz.amax() / z.amax().max(f64::MIN_POSITIVE))
        .max(dl.abs() / lambda.abs().max(f64::MIN_POSITIVE))
}

/// Solve one segment of signed step `h` in `tau` from `anchor` (left vertex, energy, previous
/// midpoint for the cancellation-free form), starting Newton from the predictor
/// `(z0, lambda0)`. `step` labels errors; `storage` holds the structured Newton matrix when `H`
/// takes that path. For the cancellation-free form the caller finishes with [`project`] (after
/// rejecting roots with the wrong `lambda`, whose energy check would misreport them).
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_segment<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    anchor: &Anchor<D>,
    z0: OVector<f64, D>,
    lambda0: f64,
    h: f64,
    options: &DthOptions,
    step: usize,
    storage: &mut Structured,
) -> Result<Segment<D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    match linear::matrix(ham, storage) {
        Some(matrix) => solve_with(
            ham,
            &mut Sparse { matrix },
            anchor,
            z0,
            lambda0,
            h,
            options,
            step,
        ),
        None => solve_dense(ham, anchor, z0, lambda0, h, options, step),
    }
}

/// [`solve_segment`] on the dense path, in a frame of its own (its `D x D` storage).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn solve_dense<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    anchor: &Anchor<D>,
    z0: OVector<f64, D>,
    lambda0: f64,
    h: f64,
    options: &DthOptions,
    step: usize,
) -> Result<Segment<D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut solver = Dense::new(z0.shape_generic().0);
    solve_with(ham, &mut solver, anchor, z0, lambda0, h, options, step)
}

/// [`solve_segment`] with the given linear solver.
#[allow(clippy::too_many_arguments)]
fn solve_with<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    solver: &mut L,
    anchor: &Anchor<D>,
    z0: OVector<f64, D>,
    lambda0: f64,
    h: f64,
    options: &DthOptions,
    step: usize,
) -> Result<Segment<D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    match options.solver() {
        Solver::Joint => joint(ham, solver, anchor, z0, lambda0, h, options, step),
        Solver::Nested => nested(ham, solver, anchor, z0, lambda0, h, options, step),
    }
}

/// Check a cancellation-free solution against the energy level `E` and project it onto it
/// (see [`EnergyResidual`](super::EnergyResidual)). `from_scale` is the roundoff scale of the
/// previous midpoint (see [`roundoff_scale`]); `matrix` as for [`project_onto_energy`].
pub(crate) fn project<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    energy: f64,
    mut s: Segment<D>,
    from_scale: f64,
    options: &DthOptions,
    step: usize,
    matrix: Option<&mut NewtonMatrix>,
) -> Result<Segment<D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let d = Point {
        value: s.value,
        gradient: s.gradient,
        psi: s.psi,
        hessian_max: 0.0,
    };
    let (z, d) = project_onto_energy(
        ham, energy, s.zbar, d, from_scale, 0.0, options, step, matrix,
    )?;
    s.zbar = z;
    s.value = d.value;
    s.gradient = d.gradient;
    s.psi = d.psi;
    Ok(s)
}

/// Check `z` (with its point `d`) against the energy level `E` with the plain residual
/// ([`Error::EnergyCheckFailed`] beyond the residual tolerance) and move it onto `H = E` along
/// `grad H` (one Newton step of `H(z) = E` in that direction). The move is a few ulps of `z`,
/// inside the roundoff of the equation that produced `z`; it keeps the roundoff of successive
/// energy-difference solves from random-walking.
///
/// The tolerance is relative to the roundoff scale of the evaluations involved: that of `z`,
/// and `from_scale`, that of the point the step started from. The step solved an equation
/// relative to that point (`H(z) = H(z_from)` through an exact discrete gradient), and the
/// point lies on `H = E` only to within its own evaluation roundoff, `eps` times its scale: so
/// `H(z) - E` carries both. They differ a lot where a term of `H` changes fast: for a
/// time-dependent `H` the `t` coordinate grows, and `t dH/dt` may be large at one end of a
/// step and near zero at the other. `explained` is a part of the deviation that the caller knows
/// the size of (the fallback step's `gbar . f`), allowed on top of the tolerance. The projected
/// point is evaluated through `matrix` when `H` takes the structured path (its Hessian
/// nonzeros land there; nothing reads them before the next evaluation).
#[allow(clippy::too_many_arguments)]
pub(crate) fn project_onto_energy<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    energy: f64,
    z: OVector<f64, D>,
    d: Point<D>,
    from_scale: f64,
    explained: f64,
    options: &DthOptions,
    step: usize,
    matrix: Option<&mut NewtonMatrix>,
) -> Result<(OVector<f64, D>, Point<D>), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let deviation = d.value - energy;
    let scale = energy
        .abs()
        .max(d.value.abs())
        .max(roundoff_scale(&z, &d.gradient))
        .max(from_scale)
        .max(f64::MIN_POSITIVE);
    let scaled = deviation.abs() / scale;
    if deviation.abs() > options.residual_tolerance() * scale + 2.0 * explained.abs() {
        return Err(Error::EnergyCheckFailed {
            step,
            deviation,
            scaled,
        });
    }
    let gg = d.gradient.norm_squared();
    if deviation != 0.0 && gg > 0.0 {
        let zp = &z - &d.gradient * (deviation / gg);
        let dp = linear::point(ham, &zp, matrix);
        // Keep the projection only if it does not make things worse (it cannot, beyond
        // evaluation roundoff).
        if dp.finite() && dp.hessian_finite() && (dp.value - energy).abs() <= deviation.abs() {
            return Ok((zp, dp));
        }
    }
    Ok((z, d))
}

/// The roundoff scale of evaluating `H` at `z`: `sum_i |z_i dH/dz_i|`, the size of the terms
/// whose rounding (of `z_i` by an ulp, propagated through `dH/dz_i`) the computed `H(z)`
/// carries.
pub(crate) fn roundoff_scale<D: Dim>(z: &OVector<f64, D>, gradient: &OVector<f64, D>) -> f64
where
    DefaultAllocator: Alloc<D>,
{
    z.component_mul(gradient).abs().sum()
}

/// A fresh stopping rule for one Newton solve of a segment.
fn convergence(options: &DthOptions) -> Convergence {
    Convergence::new(DTH, options.max_iterations() as usize)
}

/// An iteration count, at most [`DthOptions::max_iterations`] (a `u32`).
fn count(iterations: usize) -> u32 {
    u32::try_from(iterations).unwrap_or(u32::MAX)
}

#[allow(clippy::too_many_arguments)]
fn joint<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    solver: &mut L,
    anchor: &Anchor<D>,
    mut z: OVector<f64, D>,
    mut lambda: f64,
    h: f64,
    options: &DthOptions,
    step: usize,
) -> Result<Segment<D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut convergence = convergence(options);
    // Workspace, overwritten in place each iteration.
    let mut e = Eval::empty(z.shape_generic().0);
    let mut lin = Linearization::empty(z.shape_generic().0);
    // Whether the last update came from the cancellation-free residual.
    let mut cf_update = false;
    let mut factorizations = 0u32;
    loop {
        evaluate(ham, solver, anchor, h, &z, lambda, step, &mut e)?;
        let last = (convergence.iterations() > 0).then_some((&lin, &*solver));
        let mut stop = convergence.stop(e.stall(options, last, lambda));
        if let Some(p) = &anchor.previous {
            // The cancellation-free residual (a discrete gradient and its defect) only where it
            // can matter. Far from the solution (relative update above `CF_FROM`, and its
            // square above the plain residual's noise in lambda, `eps scale_r / |g_lambda
            // lambda|`) the two residuals differ by roundoff far below the update, so the
            // plain one gives the same iterates to within that roundoff and the following
            // cancellation-free iterations remove it. Newton stops only at an iterate reached
            // by a cancellation-free update (below `CF_FROM` a stop after a plain update
            // cannot happen with quadratic convergence; if it does, one more iteration).
            let near = match (convergence.last(), last) {
                (Some(u), Some((lin, _))) => {
                    u <= CF_FROM
                        || u * u <= 64.0 * f64::EPSILON * e.scale_r / (lin.g_lambda * lambda).abs()
                }
                _ => false,
            };
            if stop.is_some() || near {
                add_cancellation_free(ham, p, h, &z, lambda, step, &mut e)?;
            }
            if !cf_update {
                stop = None;
            }
        }
        let status = convergence.status(stop, || e.passes(options, last, lambda));
        let iterations = count(convergence.iterations());
        if let Some(end) = e.finish(
            status,
            (&z, lambda),
            last,
            (iterations, factorizations),
            step,
        ) {
            return end;
        }
        if convergence.last().is_none_or(|u| u > REFACTOR_ABOVE) {
            linearize(&e, solver, h, lambda, step, &mut lin)?;
            factorizations += 1;
        }
        cf_update = e.cf.is_some();
        // Bordered system [[A, -(h/2) J g], [g^T, 0]] (dz, dl) = -(f, r):
        // dz = u + z_lambda dl with A u = -f, and g^T dz = -r.
        let u = solver.solve(&(-&e.f));
        let dl = -(e.r + e.d.gradient.dot(&u)) / lin.g_lambda;
        let dz = u + &lin.z_lambda * dl;
        z += &dz;
        lambda += dl;
        if !all_finite(&z) || !lambda.is_finite() {
            return Err(Error::NonFinite {
                step,
                what: "Newton iterate",
            });
        }
        convergence.push(relative_update(&dz, &z, dl, lambda));
    }
}

/// The inner Newton's iterate and workspace in [`nested`].
struct Inner<'a, L, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    z: OVector<f64, D>,
    e: &'a mut Eval<D>,
    solver: &'a mut L,
    factorizations: u32,
}

/// The nested solver (thesis 4.1): an inner Newton for `z(h, lambda)` at fixed `lambda`, an
/// outer Newton on `H(z(h, lambda)) = E`. One solver holds both loops' factorizations: the
/// outer residual gate eliminates `f` with the latest factorization of `A` (the inner loop's,
/// at the current `lambda`), and `g_lambda` of the last outer linearization.
#[allow(clippy::too_many_arguments)]
fn nested<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    solver: &mut L,
    anchor: &Anchor<D>,
    mut z: OVector<f64, D>,
    mut lambda: f64,
    h: f64,
    options: &DthOptions,
    step: usize,
) -> Result<Segment<D>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut outer = convergence(options);
    let mut factorizations = 0u32;
    // Workspace, overwritten in place.
    let mut e = Eval::empty(z.shape_generic().0);
    let mut lin = Linearization::empty(z.shape_generic().0);
    // Everything at an iterate, with the cancellation-free residual whenever the anchor has it.
    let evaluate_at = |solver: &mut L, z: &OVector<f64, D>, lambda: f64, e: &mut Eval<D>| {
        evaluate(ham, solver, anchor, h, z, lambda, step, e)?;
        match &anchor.previous {
            Some(p) => add_cancellation_free(ham, p, h, z, lambda, step, e),
            None => Ok(()),
        }
    };
    loop {
        let started = outer.iterations() > 0;
        // Inner Newton (thesis 4.1.2): z(h, lambda) at fixed lambda, on the residual f alone.
        evaluate_at(solver, &z, lambda, &mut e)?;
        let mut inner = Inner {
            z,
            e: &mut e,
            solver: &mut *solver,
            factorizations,
        };
        newton::solve(
            convergence(options),
            options.stall_tolerance(),
            &mut inner,
            |s, _| {
                factor(s.solver, 0.5 * h * lambda, step)?;
                s.factorizations += 1;
                let dz = s.solver.solve(&(-&s.e.f));
                s.z += &dz;
                if !all_finite(&s.z) {
                    return Err(Error::NonFinite {
                        step,
                        what: "inner Newton iterate",
                    });
                }
                evaluate_at(s.solver, &s.z, lambda, s.e)?;
                Ok(dz.amax() / s.z.amax().max(f64::MIN_POSITIVE))
            },
            |s| s.e.f_residual <= options.residual_tolerance(),
            |s, _| {
                let last = started.then_some((&lin, &*s.solver));
                s.e.diverged(last, lambda, s.factorizations, step)
            },
        )?;
        (z, factorizations) = (inner.z, inner.factorizations);
        // Outer Newton (thesis 4.1.1) on g(lambda) = H(z(h, lambda)) - E.
        let last = started.then_some((&lin, &*solver));
        let status = outer.check(e.stall(options, last, lambda), || {
            e.passes(options, last, lambda)
        });
        if let Some(end) = e.finish(
            status,
            (&z, lambda),
            last,
            (factorizations, factorizations),
            step,
        ) {
            return end;
        }
        linearize(&e, solver, h, lambda, step, &mut lin)?;
        factorizations += 1;
        let dl = if e.cf.is_some() {
            // Eliminate the inner solve's remaining f to first order, as the joint update does:
            // its roundoff (eps h) must not reach lambda through gbar . f.
            let u = solver.solve(&(-&e.f));
            let dl = -(e.r + e.d.gradient.dot(&u)) / lin.g_lambda;
            lambda += dl;
            z += u + &lin.z_lambda * dl;
            dl
        } else {
            let dl = -e.r / lin.g_lambda;
            lambda += dl;
            // Warm start of the next inner solve: first-order change of z(h, lambda).
            z += &lin.z_lambda * dl;
            dl
        };
        if !lambda.is_finite() || !all_finite(&z) {
            return Err(Error::NonFinite {
                step,
                what: "outer Newton iterate",
            });
        }
        outer.push(dl.abs() / lambda.abs().max(f64::MIN_POSITIVE));
    }
}

/// Predictor for segment `k + 1` from its left vertex `v`: two fixed-point sweeps of
/// `z = v + (h/2) lambda J gradH(z)` from `z = v` (error `O(h^3)`). It never starts at
/// `zbar_k`, whose neighbourhood holds the spurious root `lambda_{k+1} = -lambda_k`.
pub(crate) fn predict<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    v: &OVector<f64, D>,
    lambda: f64,
    h: f64,
) -> OVector<f64, D>
where
    DefaultAllocator: Alloc<D>,
{
    let half = 0.5 * h * lambda;
    let z1 = v + j_times(&ham.gradient(v)) * half;
    v + j_times(&ham.gradient(&z1)) * half
}

/// One DTH segment from a given left vertex at a given energy: find `zbar`, `lambda > 0` with
/// `zbar = vertex + (h/2) lambda J gradH(zbar)` and `H(zbar) = energy`; the right vertex is
/// `2 zbar - vertex`.
///
/// This is the vertex-to-vertex map of the paper's Theorem 3 (in the extended phase space,
/// where `energy = 0`, it is symplectic); the stepper [`Dth`](super::Dth) uses the same solver.
/// `lambda_guess` (positive) starts Newton.
///
/// # Errors
/// [`Error::InvalidOption`] for a non-positive or non-finite `lambda_guess`,
/// [`Error::NonFiniteInitialState`] for a non-finite vertex, and the Newton failures of a step
/// (labelled step 0).
///
/// # References
/// Shibberu (1998) eqs. 28-30 and Theorem 3; thesis eqs. 2.3.5-2.3.7.
pub fn segment_from_vertex<H: Hamiltonian<D>, D: Dim>(
    hamiltonian: &H,
    vertex: &OVector<f64, D>,
    energy: f64,
    lambda_guess: f64,
    options: &DthOptions,
) -> Result<(Segment<D>, OVector<f64, D>), Error>
where
    DefaultAllocator: Alloc<D>,
{
    if !(lambda_guess.is_finite() && lambda_guess > 0.0) {
        return Err(Error::InvalidOption {
            name: "lambda_guess",
            value: lambda_guess,
            reason: "must be positive and finite",
        });
    }
    if let Some((index, &value)) = vertex.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(Error::NonFiniteInitialState { index, value });
    }
    let z0 = predict(hamiltonian, vertex, lambda_guess, options.dtau());
    let anchor = Anchor {
        v: vertex.clone(),
        energy,
        previous: None,
    };
    let s = solve_segment(
        hamiltonian,
        &anchor,
        z0,
        lambda_guess,
        options.dtau(),
        options,
        0,
        &mut Structured::default(),
    )?;
    if s.lambda <= 0.0 {
        return Err(Error::SpuriousRoot {
            step: 0,
            lambda: s.lambda,
        });
    }
    let right = &s.zbar * 2.0 - vertex;
    Ok((s, right))
}
