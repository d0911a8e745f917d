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
//! Joint Newton factors `A` afresh while the relative update is above `1e-4` and keeps the last
//! factorization below (simplified Newton: as many iterations there, one factorization fewer
//! per step on the thesis Kepler orbit); `Segment::factorizations` counts the factorizations.
//!
//! Newton stops by the crate's one stopping rule ([`crate::newton`]) with the DTH parameters:
//! relative updates `u = max(|dz|/|z|, |dlambda|/|lambda|)`, every stop gated on the scaled
//! residual at the final iterate (nothing is accepted on the update size alone), and a stall
//! tolerance raised per iterate to the roundoff floor of the plain energy residual (see
//! `Eval::stall`). A gated stop that fails after an update of at most `4 eps`, or the iteration
//! limit, is [`Error::NewtonDiverged`].

use super::linear::{self, largest, Dense, Linear, Path, Point};
use super::options::{DthOptions, Solver};
use crate::hamiltonian::Alloc;
use crate::linalg::Pivot;
use crate::methods::{check_state, Structured};
use crate::newton::{self, Convergence, Status, DTH};
use crate::{zeros, Error, Hamiltonian};
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Relative update below which joint Newton evaluates the cancellation-free residual at every
/// iterate: from there, quadratic convergence can reach a stop at the next iterate.
const CF_FROM: f64 = 1e-5;

/// Relative update at or below which joint Newton keeps the last factorization of `A` (and its
/// `z_lambda`, `g_lambda`) instead of factoring again: a simplified-Newton iteration. The
/// frozen matrix differs from the current one by `O(|Hess'| |dz|)`, the distance from the
/// iterate it was taken at, so the iteration contracts by about the update that left that
/// iterate: from `1e-4` each iteration keeps at most about `1e-4` of the error left (Newton
/// from the same iterate would keep the error squared). The stopping rule bounds the remainder
/// from the observed contraction, so it stops such a linearly converging tail at roundoff just
/// as it stops Newton's (one more iteration where the contraction is not below `4 eps /
/// update`). On the thesis Kepler orbit this keeps the iterations per step and takes the
/// factorizations from 3.00 to 2.34 per step (`docs/performance.md`, "Step cost: DTH
/// against the implicit midpoint rule").
const REFACTOR_ABOVE: f64 = 1e-4;

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
#[derive(Clone, Copy, Debug)]
pub(crate) struct Previous<'a, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `zbar_k`.
    pub(crate) zbar: &'a OVector<f64, D>,
    /// `grad H(zbar_k)`.
    pub(crate) gradient: &'a OVector<f64, D>,
    /// `lambda_k`.
    pub(crate) lambda: f64,
}

/// What a segment is solved from: its left vertex `v`, the energy level `E`, and (for the
/// cancellation-free residual) the previous midpoint.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Anchor<'a, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    pub(crate) v: &'a OVector<f64, D>,
    pub(crate) energy: f64,
    pub(crate) previous: Option<Previous<'a, D>>,
}

/// A solved segment whose midpoint and evaluation are in the [`Work`] (`z`, `e.d`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solved {
    pub(crate) lambda: f64,
    /// The relative roundoff noise of `lambda` (see [`Eval::lambda_noise`]).
    pub(crate) noise: f64,
    pub(crate) iterations: u32,
    pub(crate) factorizations: u32,
}

/// Everything the Newton loops need at one iterate.
#[derive(Clone, Debug)]
pub(crate) struct Eval<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// `H`, `grad H`, `Psi` at the iterate.
    pub(crate) d: Point<D>,
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
    /// Whether the cancellation-free parts below belong to this iterate.
    cf: bool,
    /// The discrete gradient `gbar(zbar_k, z)`.
    gbar: OVector<f64, D>,
    /// Its trapezoid defect, then `J w` (see [`add_cancellation_free`]).
    t: OVector<f64, D>,
    /// `(h/2) gbar^T J w`: equals `H(z) - H(zbar_k) - gbar . f`.
    r_cf: f64,
    /// Size of the terms `r_cf` is a sum of: `(h/4)(lambda + lambda_k) sum |gbar_i (g - g_k)_i|`.
    cf_scale: f64,
    /// Roundoff scale of the energy residual when the Hamiltonian does not declare exact
    /// divided differences (the cancellation-free form forced on it): the plain residual's
    /// `|terms of H|`, which bounds the noise of a plain-difference `gbar` or defect. Zero for
    /// Hamiltonians with `exact_divided_differences`.
    inexact_scale: f64,
}

impl<D: Dim> Eval<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Storage for [`evaluate`], overwritten by each evaluation.
    fn empty(d: D) -> Self {
        Eval {
            d: Point::zeros(d),
            jg: zeros(d),
            f: zeros(d),
            r: 0.0,
            f_residual: 0.0,
            scale_f: 0.0,
            noise: 0.0,
            plain_residual: 0.0,
            scale_r: 0.0,
            cf: false,
            gbar: zeros(d),
            t: zeros(d),
            r_cf: 0.0,
            cf_scale: 0.0,
            inexact_scale: 0.0,
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
    /// `lambda`. `u` is scratch; it holds `A^{-1}(-f)` afterwards when that was computed.
    fn residual<L: Linear<D>>(
        &self,
        last: Option<&Linearization<D>>,
        solver: &mut L,
        u: &mut OVector<f64, D>,
        lambda: f64,
    ) -> f64 {
        let energy = match (self.cf, last) {
            (true, Some(lin)) => {
                let g_lambda = lin.g_lambda;
                minus_solve(solver, &self.f, u);
                let scale = self
                    .cf_scale
                    .max((g_lambda * lambda).abs())
                    .max(self.inexact_scale);
                (self.r_cf + (self.gbar.dot(&self.f) + self.d.gradient.dot(u))).abs() / scale
            }
            (true, None) => f64::INFINITY,
            (false, _) => self.plain_residual,
        };
        self.f_residual.max(energy)
    }

    /// The stall tolerance for this iterate: the option, raised for the plain residual to the
    /// relative noise its roundoff puts into `lambda`, `eps |terms of H| / |g_lambda lambda|`
    /// (`~eps / h^2`): below that, updates are noise and can never settle.
    /// The same holds for the cancellation-free form forced on a Hamiltonian without exact
    /// divided differences; with them the option stands.
    fn stall(&self, options: &DthOptions, last: Option<&Linearization<D>>, lambda: f64) -> f64 {
        let noise = self.noise;
        match last {
            Some(lin) if noise > 0.0 => options
                .stall_tolerance()
                .max(8.0 * f64::EPSILON * noise / (lin.g_lambda * lambda).abs())
                .min(0.5),
            _ => options.stall_tolerance(),
        }
    }

    /// The relative noise the plain energy residual's roundoff puts into `lambda`,
    /// `8 eps |terms of H| / |g_lambda lambda|` (the floor [`Eval::stall`] raises the stall
    /// tolerance to); 0 where the cancellation-free form with exact divided differences is
    /// solved (`lambda` is then exact to about one eps, below every other rounding).
    fn lambda_noise(&self, last: Option<&Linearization<D>>, lambda: f64) -> f64 {
        match last {
            Some(lin) if self.noise > 0.0 => {
                8.0 * f64::EPSILON * self.noise / (lin.g_lambda * lambda).abs()
            }
            _ => 0.0,
        }
    }

    /// The failure of a segment solve after `iterations` Newton iterations (LU factorizations),
    /// at the iterate `(z, lambda)` evaluated here.
    fn diverged<L: Linear<D>>(
        &self,
        last: Option<&Linearization<D>>,
        solver: &mut L,
        u: &mut OVector<f64, D>,
        lambda: f64,
        iterations: u32,
        step: usize,
    ) -> Error {
        Error::NewtonDiverged {
            step,
            iterations,
            residual: self.residual(last, solver, u, lambda),
        }
    }
}

/// `u = A^{-1}(-f)` with the solver's factorization (bit for bit the solve of `-f`: the
/// substitutions are linear and negation is exact).
fn minus_solve<L: Linear<D>, D: Dim>(solver: &mut L, f: &OVector<f64, D>, u: &mut OVector<f64, D>)
where
    DefaultAllocator: Alloc<D>,
{
    solver.solve_into(f, u);
    u.neg_mut();
}

/// The storage of a segment solve: the iterate (the predictor on entry, the solution on
/// success), its evaluation, the linearization and scratch vectors. A stepper keeps one (built
/// once, so that a step of a `Dyn` dimension allocates nothing).
#[derive(Clone, Debug)]
pub(crate) struct Work<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The Newton iterate `z`: the start on entry, `zbar_{k+1}` after a solve.
    pub(crate) z: OVector<f64, D>,
    /// The evaluation at `z` (`e.d`: value, gradient, `Psi` of the solution after a solve).
    pub(crate) e: Eval<D>,
    lin: Linearization<D>,
    u: OVector<f64, D>,
    dz: OVector<f64, D>,
    /// The projected point and its evaluation (see [`project`]).
    zp: OVector<f64, D>,
    pp: Point<D>,
}

impl<D: Dim> Work<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Storage of dimension `d`.
    pub(crate) fn new(d: D) -> Self {
        Work {
            z: zeros(d),
            e: Eval::empty(d),
            lin: Linearization::empty(d),
            u: zeros(d),
            dz: zeros(d),
            zp: zeros(d),
            pp: Point::zeros(d),
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

/// `out = a + c J b` (`J b = (b_p, -b_q)`), element by element.
pub(crate) fn add_j_times<D: Dim>(
    a: &OVector<f64, D>,
    b: &OVector<f64, D>,
    c: f64,
    out: &mut OVector<f64, D>,
) where
    DefaultAllocator: Alloc<D>,
{
    let n = a.len() / 2;
    for i in 0..n {
        out[i] = a[i] + b[i + n] * c;
        out[i + n] = a[i + n] + (-b[i]) * c;
    }
}

/// Evaluate everything at the iterate `(z, lambda)` into `e`, the Hessian into `solver`; with
/// `fresh` false, `e.d` and the solver already hold `H` at `z` (the predictor's evaluation).
#[allow(clippy::too_many_arguments)]
fn evaluate<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    solver: &mut L,
    anchor: &Anchor<'_, D>,
    h: f64,
    (z, lambda): (&OVector<f64, D>, f64),
    step: usize,
    e: &mut Eval<D>,
    fresh: bool,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    if fresh {
        solver.evaluate(ham, z, &mut e.d);
    }
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
    let v = anchor.v;
    let energy = anchor.energy;
    // jg = J grad H; f = z - v - (h lambda/2) jg, and the largest |(h lambda/2) jg_i|.
    let half = 0.5 * h * lambda;
    let n = z.len() / 2;
    let mut move_max = 0.0f64;
    for i in 0..z.len() {
        let jg = if i < n {
            d.gradient[i + n]
        } else {
            -d.gradient[i - n]
        };
        let m = jg * half;
        e.jg[i] = jg;
        e.f[i] = z[i] - v[i] - m;
        move_max = move_max.max(m.abs());
    }
    // Roundoff scales: the magnitudes of the terms each residual is a difference of.
    let scale_f = largest(z.as_slice())
        .max(largest(v.as_slice()))
        .max(move_max)
        .max(f64::MIN_POSITIVE);
    let r_plain = d.value - energy;
    let scale_r = energy
        .abs()
        .max(d.value.abs())
        .max(roundoff_scale(z, &d.gradient))
        .max(f64::MIN_POSITIVE);
    e.plain_residual = r_plain.abs() / scale_r;
    e.f_residual = largest(e.f.as_slice()) / scale_f;
    e.scale_f = scale_f;
    e.r = r_plain;
    e.scale_r = scale_r;
    e.cf = false;
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
    p: &Previous<'_, D>,
    h: f64,
    z: &OVector<f64, D>,
    lambda: f64,
    step: usize,
    e: &mut Eval<D>,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let g = &e.d.gradient;
    let n = z.len() / 2;
    // f = (z - zbar_k) - (h/2) J (lambda g + lambda_k g_k): the difference z - zbar_k
    // is exact (Sterbenz) for small steps, so f carries roundoff eps h, not eps |z|.
    for i in 0..z.len() {
        let s = |k: usize| g[k] * lambda + p.gradient[k] * p.lambda;
        let js = if i < n { s(i + n) } else { -s(i - n) };
        e.f[i] = (z[i] - p.zbar[i]) - js * (0.5 * h);
    }
    ham.discrete_gradient_into(p.zbar, z, &mut e.gbar);
    ham.discrete_gradient_defect_into(p.zbar, z, &e.gbar, &mut e.t);
    // w = ((lambda - lambda_k)/2) (g - g_k) + ((lambda + lambda_k)/2) t, then J w in `t`
    // (in place: rows i and i + n are read before either is written).
    let (a, b) = (0.5 * (lambda - p.lambda), 0.5 * (lambda + p.lambda));
    let mut scale = 0.0f64;
    for i in 0..n {
        let (dq, dp) = (g[i] - p.gradient[i], g[i + n] - p.gradient[i + n]);
        let wq = dq * a + e.t[i] * b;
        let wp = dp * a + e.t[i + n] * b;
        e.t[i] = wp;
        e.t[i + n] = -wq;
    }
    for i in 0..z.len() {
        scale += (e.gbar[i] * (g[i] - p.gradient[i])).abs();
    }
    let r_cf = 0.5 * h * e.gbar.dot(&e.t);
    let scale = (0.25 * h * (lambda + p.lambda)).abs() * scale + f64::MIN_POSITIVE;
    if !r_cf.is_finite() || !all_finite(&e.gbar) {
        return Err(Error::NonFinite {
            step,
            what: "discrete gradient at a Newton iterate",
        });
    }
    e.r = r_cf + e.gbar.dot(&e.f);
    e.inexact_scale = if ham.flags().exact_divided_differences {
        0.0
    } else {
        e.scale_r
    };
    e.f_residual = largest(e.f.as_slice()) / e.scale_f;
    e.cf = true;
    e.r_cf = r_cf;
    e.cf_scale = scale;
    Ok(())
}

/// `z_lambda` and `g_lambda` from the factored `A = I - (h lambda / 2) J HessH` (held by the
/// solver).
#[derive(Clone, Debug)]
struct Linearization<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    z_lambda: OVector<f64, D>,
    g_lambda: f64,
    /// Scratch: the right-hand side `(h/2) J grad H`, then `Hess z_lambda`.
    scratch: OVector<f64, D>,
}

impl<D: Dim> Linearization<D>
where
    DefaultAllocator: Alloc<D>,
{
    fn empty(d: D) -> Self {
        Linearization {
            z_lambda: zeros(d),
            g_lambda: 0.0,
            scratch: zeros(d),
        }
    }
}

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
    for (s, jg) in lin.scratch.iter_mut().zip(e.jg.iter()) {
        *s = jg * (0.5 * h);
    }
    solver.solve_into(&lin.scratch, &mut lin.z_lambda);
    solver.hessian_times_into(&lin.z_lambda, &mut lin.scratch);
    // Cancellation-free g_lambda = (h lambda/2) gradH^T J HessH z_lambda
    //                          = -(h lambda/2) (J gradH)^T HessH z_lambda.
    let g_lambda = -(0.5 * h * lambda) * e.jg.dot(&lin.scratch);
    if !g_lambda.is_finite() || !all_finite(&lin.z_lambda) {
        return Err(Error::NonFinite {
            step,
            what: "Newton linear solve",
        });
    }
    if g_lambda == 0.0 {
        return Err(Error::SingularMatrix { step });
    }
    lin.g_lambda = g_lambda;
    Ok(())
}

/// The DTH measure of an update: the larger of the relative changes of `z` and `lambda`.
fn relative_update<D: Dim>(dz: &OVector<f64, D>, z: &OVector<f64, D>, dl: f64, lambda: f64) -> f64
where
    DefaultAllocator: Alloc<D>,
{
    (largest(dz.as_slice()) / largest(z.as_slice()).max(f64::MIN_POSITIVE))
        .max(dl.abs() / lambda.abs().max(f64::MIN_POSITIVE))
}

/// Solve one segment of signed step `h` in `tau` from `anchor` (left vertex, energy, previous
/// midpoint for the cancellation-free form), starting Newton from the predictor
/// `(work.z, lambda0)`, `start = (lambda0, evaluated)`: with `evaluated`, `work.e.d` and the
/// solver (the linear algebra in `storage`, `dense`) already hold `H` at `work.z` (the joint
/// solver then starts without evaluating again). The solution is left in `work` (`z`, `e.d`). `step` labels errors;
/// `storage` and `dense` hold the linear algebra of `H`'s [`Path`]. For the cancellation-free
/// form the caller finishes with [`project`] (after rejecting roots with the wrong `lambda`,
/// whose energy check would misreport them).
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_segment<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    anchor: &Anchor<'_, D>,
    start: (f64, bool),
    h: f64,
    options: &DthOptions,
    step: usize,
    storage: &mut Structured,
    dense: &mut Option<Box<Dense<D>>>,
    work: &mut Work<D>,
) -> Result<Solved, Error>
where
    DefaultAllocator: Alloc<D>,
{
    match linear::path(ham, storage, dense) {
        Path::Sparse(mut s) => solve_with(ham, &mut s, anchor, start, h, options, step, work),
        Path::Dense(d) => solve_with(ham, d, anchor, start, h, options, step, work),
    }
}

/// [`solve_segment`] with the given linear solver.
#[allow(clippy::too_many_arguments)]
fn solve_with<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    solver: &mut L,
    anchor: &Anchor<'_, D>,
    (lambda0, evaluated): (f64, bool),
    h: f64,
    options: &DthOptions,
    step: usize,
    work: &mut Work<D>,
) -> Result<Solved, Error>
where
    DefaultAllocator: Alloc<D>,
{
    match options.solver() {
        Solver::Joint => joint(
            ham,
            solver,
            anchor,
            (lambda0, evaluated),
            h,
            options,
            step,
            work,
        ),
        // (The nested solver's first inner iteration evaluates with its own cancellation-free
        // residual; it starts from scratch.)
        Solver::Nested => nested(ham, solver, anchor, lambda0, h, options, step, work),
    }
}

/// Check the cancellation-free solution in `work` against the energy level `E` and project it
/// onto it (see [`EnergyResidual`](super::EnergyResidual)). `from_scale` is the roundoff scale
/// of the previous midpoint (see [`roundoff_scale`]); `solver` as for [`project_onto_energy`].
pub(crate) fn project<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    energy: f64,
    work: &mut Work<D>,
    from_scale: f64,
    options: &DthOptions,
    step: usize,
    solver: &mut L,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    work.e.d.hessian_max = 0.0;
    project_onto_energy(
        ham,
        energy,
        (&mut work.z, &mut work.e.d),
        (&mut work.zp, &mut work.pp),
        from_scale,
        0.0,
        options,
        step,
        solver,
    )
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
/// point is evaluated through `solver` (on the structured path its Hessian nonzeros land in the
/// matrix; nothing reads them before the next evaluation) into `scratch`, and swapped into
/// `(z, d)` when kept.
#[allow(clippy::too_many_arguments)]
pub(crate) fn project_onto_energy<H: Hamiltonian<D>, L: Linear<D>, D: Dim>(
    ham: &H,
    energy: f64,
    (z, d): (&mut OVector<f64, D>, &mut Point<D>),
    (zp, dp): (&mut OVector<f64, D>, &mut Point<D>),
    from_scale: f64,
    explained: f64,
    options: &DthOptions,
    step: usize,
    solver: &mut L,
) -> Result<(), Error>
where
    DefaultAllocator: Alloc<D>,
{
    let deviation = d.value - energy;
    let scale = energy
        .abs()
        .max(d.value.abs())
        .max(roundoff_scale(z, &d.gradient))
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
    // A regularization's `t` and `p_t` stay out of the move: `p_t = -E` is the physical
    // energy, constant along the flow (`dp_t/ds = -dK/dt = 0`), and the projection's ulps
    // would random-walk it.
    let flags = ham.flags();
    let fixed = (flags.regularized && flags.time_dependent).then(|| (z.len() / 2 - 1, z.len() - 1));
    let direction = |i: usize, g: f64| match fixed {
        Some((t, pt)) if i == t || i == pt => 0.0,
        _ => g,
    };
    let gg: f64 = d
        .gradient
        .iter()
        .enumerate()
        .map(|(i, &g)| direction(i, g).powi(2))
        .sum();
    if deviation != 0.0 && gg > 0.0 {
        let c = deviation / gg;
        for (i, (p, x)) in zp.iter_mut().zip(z.iter()).enumerate() {
            *p = x - direction(i, d.gradient[i]) * c;
        }
        solver.evaluate(ham, zp, dp);
        // Keep the projection only if it does not make things worse (it cannot, beyond
        // evaluation roundoff).
        if dp.finite() && dp.hessian_finite() && (dp.value - energy).abs() <= deviation.abs() {
            std::mem::swap(z, zp);
            std::mem::swap(d, dp);
        }
    }
    Ok(())
}

/// The roundoff scale of evaluating `H` at `z`: `sum_i |z_i dH/dz_i|`, the size of the terms
/// whose rounding (of `z_i` by an ulp, propagated through `dH/dz_i`) the computed `H(z)`
/// carries.
pub(crate) fn roundoff_scale<D: Dim>(z: &OVector<f64, D>, gradient: &OVector<f64, D>) -> f64
where
    DefaultAllocator: Alloc<D>,
{
    z.iter()
        .zip(gradient.iter())
        .fold(0.0, |sum, (x, g)| sum + (x * g).abs())
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
    anchor: &Anchor<'_, D>,
    (mut lambda, evaluated): (f64, bool),
    h: f64,
    options: &DthOptions,
    step: usize,
    w: &mut Work<D>,
) -> Result<Solved, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut convergence = convergence(options);
    // Whether the last update came from the cancellation-free residual.
    let mut cf_update = false;
    let mut factorizations = 0u32;
    loop {
        let fresh = !evaluated || convergence.iterations() > 0;
        evaluate(
            ham,
            solver,
            anchor,
            h,
            (&w.z, lambda),
            step,
            &mut w.e,
            fresh,
        )?;
        let last = (convergence.iterations() > 0).then_some(&w.lin);
        let mut stop = convergence.stop(w.e.stall(options, last, lambda));
        if let Some(p) = &anchor.previous {
            // The cancellation-free residual (a discrete gradient and its defect) only where it
            // can matter. Far from the solution (relative update above `CF_FROM`, and its
            // square above the plain residual's noise in lambda, `eps scale_r / |g_lambda
            // lambda|`: see `cf_pays`) the two residuals differ by roundoff far below the
            // update, so the plain one gives the same iterates to within that roundoff and the
            // following cancellation-free iterations remove it. Newton stops only at an iterate
            // reached by a cancellation-free update (below `CF_FROM` a stop after a plain update
            // cannot happen with quadratic convergence; if it does, one more iteration). The
            // start, where no update is known yet, is decided after its first update (below).
            let near = match (convergence.last(), last) {
                (Some(u), Some(lin)) => cf_pays(u, &w.e, lin, lambda),
                _ => false,
            };
            if stop.is_some() || near {
                add_cancellation_free(ham, p, h, &w.z, lambda, step, &mut w.e)?;
            }
            if !cf_update {
                stop = None;
            }
        }
        let status = convergence.status(stop, || {
            w.e.residual(last, solver, &mut w.u, lambda) <= options.residual_tolerance()
        });
        let iterations = count(convergence.iterations());
        match status {
            Status::Converged => {
                return Ok(Solved {
                    lambda,
                    noise: w.e.lambda_noise(last, lambda),
                    iterations,
                    factorizations,
                })
            }
            Status::Diverged => {
                return Err(w
                    .e
                    .diverged(last, solver, &mut w.u, lambda, iterations, step))
            }
            Status::Continue => {}
        }
        // The gate (called only on a signalled stop) solved A u = -f with the last
        // factorization when the residual is cancellation-free: the update reuses that u
        // unless A is factored afresh.
        let mut solved = stop.is_some() && w.e.cf && last.is_some();
        if convergence.last().is_none_or(|u| u > REFACTOR_ABOVE) {
            linearize(&w.e, solver, h, lambda, step, &mut w.lin)?;
            factorizations += 1;
            solved = false;
        }
        cf_update = w.e.cf;
        let mut dl = bordered_update(solver, w, solved);
        // The first update, from the predictor, with the plain residual: where it is as small
        // as the plain residual's noise in lambda (the stepper's start is often that good,
        // see `refine_start` there), most of it is that noise, and a third update would take
        // it out again. Redo it with the cancellation-free residual (one more solve with the
        // same factorization, no evaluation).
        if let (None, Some(p), false) = (convergence.last(), &anchor.previous, w.e.cf) {
            if cf_pays(
                relative_update(&w.dz, &w.z, dl, lambda),
                &w.e,
                &w.lin,
                lambda,
            ) {
                add_cancellation_free(ham, p, h, &w.z, lambda, step, &mut w.e)?;
                cf_update = true;
                dl = bordered_update(solver, w, false);
            }
        }
        w.z += &w.dz;
        lambda += dl;
        if !all_finite(&w.z) || !lambda.is_finite() {
            return Err(Error::NonFinite {
                step,
                what: "Newton iterate",
            });
        }
        convergence.push(relative_update(&w.dz, &w.z, dl, lambda));
    }
}

/// Whether the cancellation-free residual pays at an iterate reached by a relative update `u`
/// (`e` evaluated there, `lin` the last linearization): near the solution (`u <= CF_FROM`,
/// after which quadratic convergence can stop at the next iterate), or where `u` is within
/// the square root of the plain residual's noise in lambda, `eps scale_r / |g_lambda lambda|`.
fn cf_pays<D: Dim>(u: f64, e: &Eval<D>, lin: &Linearization<D>, lambda: f64) -> bool
where
    DefaultAllocator: Alloc<D>,
{
    u <= CF_FROM || u * u <= 64.0 * f64::EPSILON * e.scale_r / (lin.g_lambda * lambda).abs()
}

/// The joint Newton update from the bordered system `[[A, -(h/2) J g], [g^T, 0]] (dz, dl) =
/// -(f, r)`: `dz = u + z_lambda dl` with `A u = -f` (solved here unless `solved`: `w.u` holds
/// it), and `g^T dz = -r`. `dz` goes into `w.dz`; returns `dl`.
fn bordered_update<L: Linear<D>, D: Dim>(solver: &mut L, w: &mut Work<D>, solved: bool) -> f64
where
    DefaultAllocator: Alloc<D>,
{
    if !solved {
        minus_solve(solver, &w.e.f, &mut w.u);
    }
    let dl = -(w.e.r + w.e.d.gradient.dot(&w.u)) / w.lin.g_lambda;
    for ((dz, u), zl) in w.dz.iter_mut().zip(w.u.iter()).zip(w.lin.z_lambda.iter()) {
        *dz = u + zl * dl;
    }
    dl
}

/// The inner Newton's workspace in [`nested`].
struct Inner<'a, L, D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    w: &'a mut Work<D>,
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
    anchor: &Anchor<'_, D>,
    mut lambda: f64,
    h: f64,
    options: &DthOptions,
    step: usize,
    w: &mut Work<D>,
) -> Result<Solved, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let mut outer = convergence(options);
    let mut factorizations = 0u32;
    // Everything at an iterate, with the cancellation-free residual whenever the anchor has it.
    let evaluate_at = |solver: &mut L, z: &OVector<f64, D>, lambda: f64, e: &mut Eval<D>| {
        evaluate(ham, solver, anchor, h, (z, lambda), step, e, true)?;
        match &anchor.previous {
            Some(p) => add_cancellation_free(ham, p, h, z, lambda, step, e),
            None => Ok(()),
        }
    };
    loop {
        let started = outer.iterations() > 0;
        // Inner Newton (thesis 4.1.2): z(h, lambda) at fixed lambda, on the residual f alone.
        evaluate_at(solver, &w.z, lambda, &mut w.e)?;
        let mut inner = Inner {
            w: &mut *w,
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
                let w = &mut *s.w;
                minus_solve(s.solver, &w.e.f, &mut w.dz);
                w.z += &w.dz;
                if !all_finite(&w.z) {
                    return Err(Error::NonFinite {
                        step,
                        what: "inner Newton iterate",
                    });
                }
                evaluate_at(s.solver, &w.z, lambda, &mut w.e)?;
                Ok(w.dz.amax() / w.z.amax().max(f64::MIN_POSITIVE))
            },
            |s| s.w.e.f_residual <= options.residual_tolerance(),
            |s, _| {
                let w = &mut *s.w;
                let last = started.then_some(&w.lin);
                w.e.diverged(last, s.solver, &mut w.u, lambda, s.factorizations, step)
            },
        )?;
        factorizations = inner.factorizations;
        // Outer Newton (thesis 4.1.1) on g(lambda) = H(z(h, lambda)) - E.
        let last = started.then_some(&w.lin);
        let status = outer.check(w.e.stall(options, last, lambda), || {
            w.e.residual(last, solver, &mut w.u, lambda) <= options.residual_tolerance()
        });
        match status {
            Status::Converged => {
                return Ok(Solved {
                    lambda,
                    noise: w.e.lambda_noise(last, lambda),
                    iterations: factorizations,
                    factorizations,
                })
            }
            Status::Diverged => {
                return Err(w
                    .e
                    .diverged(last, solver, &mut w.u, lambda, factorizations, step))
            }
            Status::Continue => {}
        }
        linearize(&w.e, solver, h, lambda, step, &mut w.lin)?;
        factorizations += 1;
        let dl = if w.e.cf {
            // Eliminate the inner solve's remaining f to first order, as the joint update does:
            // its roundoff (eps h) must not reach lambda through gbar . f.
            minus_solve(solver, &w.e.f, &mut w.u);
            let dl = -(w.e.r + w.e.d.gradient.dot(&w.u)) / w.lin.g_lambda;
            lambda += dl;
            for ((dz, u), zl) in w.dz.iter_mut().zip(w.u.iter()).zip(w.lin.z_lambda.iter()) {
                *dz = u + zl * dl;
            }
            w.z += &w.dz;
            dl
        } else {
            let dl = -w.e.r / w.lin.g_lambda;
            lambda += dl;
            // Warm start of the next inner solve: first-order change of z(h, lambda).
            for (z, zl) in w.z.iter_mut().zip(w.lin.z_lambda.iter()) {
                *z += zl * dl;
            }
            dl
        };
        if !lambda.is_finite() || !all_finite(&w.z) {
            return Err(Error::NonFinite {
                step,
                what: "outer Newton iterate",
            });
        }
        outer.push(dl.abs() / lambda.abs().max(f64::MIN_POSITIVE));
    }
}

/// Predictor for segment `k + 1` from its left vertex `v`: two fixed-point sweeps of
/// `z = v + (h/2) lambda J gradH(z)` from `z = v` (error `O(h^3)`), written into `out` (`g` and
/// `z1` are scratch). It never starts at `zbar_k`, whose neighbourhood holds the spurious root
/// `lambda_{k+1} = -lambda_k`.
pub(crate) fn predict_into<H: Hamiltonian<D>, D: Dim>(
    ham: &H,
    v: &OVector<f64, D>,
    lambda: f64,
    h: f64,
    (g, z1): (&mut OVector<f64, D>, &mut OVector<f64, D>),
    out: &mut OVector<f64, D>,
) where
    DefaultAllocator: Alloc<D>,
{
    let half = 0.5 * h * lambda;
    ham.gradient_into(v, g);
    add_j_times(v, g, half, z1);
    ham.gradient_into(z1, g);
    add_j_times(v, g, half, out);
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
/// [`Error::InvalidOption`] for a non-positive or non-finite `lambda_guess` or a non-finite
/// `energy`, [`Error::WrongStateLength`] (`vertex`) for a vertex not of `H`'s (even)
/// dimension, [`Error::NonFiniteInitialState`] for a non-finite vertex, and the Newton
/// failures of a step (labelled step 0).
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
    if !energy.is_finite() {
        return Err(Error::InvalidOption {
            name: "energy",
            value: energy,
            reason: "must be finite",
        });
    }
    check_state(hamiltonian, vertex, "vertex")?;
    if let Some((index, &value)) = vertex.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(Error::NonFiniteInitialState { index, value });
    }
    let d = hamiltonian.dim();
    let mut work = Work::new(d);
    let (mut g, mut z1) = (zeros(d), zeros(d));
    predict_into(
        hamiltonian,
        vertex,
        lambda_guess,
        options.dtau(),
        (&mut g, &mut z1),
        &mut work.z,
    );
    let anchor = Anchor {
        v: vertex,
        energy,
        previous: None,
    };
    let s = solve_segment(
        hamiltonian,
        &anchor,
        (lambda_guess, false),
        options.dtau(),
        options,
        0,
        &mut Structured::default(),
        &mut None,
        &mut work,
    )?;
    if s.lambda <= 0.0 {
        return Err(Error::SpuriousRoot {
            step: 0,
            lambda: s.lambda,
        });
    }
    let right = &work.z * 2.0 - vertex;
    let segment = Segment {
        zbar: work.z,
        lambda: s.lambda,
        value: work.e.d.value,
        gradient: work.e.d.gradient,
        psi: work.e.d.psi,
        iterations: s.iterations,
        factorizations: s.factorizations,
    };
    Ok((segment, right))
}
