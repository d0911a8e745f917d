//! The compensated state of a regularized run: each midpoint carried as a high part (the
//! stepper's `zbar`) and a low part, so the sum of the steps' advances does not random-walk.
//!
//! The step equations give the advance from midpoint to midpoint,
//! `zbar_{k+1} - zbar_k = (h/2) J (lambda_k grad K_k + lambda_{k+1} grad K_{k+1})`, a number
//! small next to `zbar` and known to a few eps of itself. Newton solves for `zbar_{k+1}`
//! itself, which it can only hold to half an ulp of each coordinate, and each step starts from
//! that rounded point. On a regularized Kepler orbit, where DTH of order 8 is exact to 1e-11
//! within a few dozen steps per orbit, those roundings are what is left: after 100 orbits at
//! e = 0.99 with only the clock `t` compensated, twelve runs from 64 to 376 steps per orbit
//! ended 1.3e-11 to 2.4e-9 from the exact solution (median 2.3e-10); the five above 9e-10 take
//! a whole number of steps per orbit, so every pericentre passage is stepped at the same phase
//! and its roundings add up orbit after orbit instead of averaging out. Carrying what each
//! rounding dropped in a low part, and adding the energy projection's move to it, keeps every
//! coordinate within an ulp of the exact sum of the advances: the same runs end 4.5e-13 to
//! 1.4e-10 away (median 3.4e-11; `tests/regularized_kepler.rs`,
//! `the_compensated_state_keeps_e099_within_1e_10_of_the_exact_orbit`).
//!
//! **Solved in double-double.** What remains is a shift along the orbit, the clock against the
//! phase of `(u, P)`, of about 1e-16 of the time elapsed (1e-9 at the pericentre after 100
//! orbits at e = 0.999). Two roundings make it, both measured: each advance is computed from
//! `grad K` rounded to doubles at the high part of the point (adding only `Hess K low` to the
//! gradient left 2e-10), and the start itself, whose `K` after rounding is some 1e-16 off
//! zero, which for Kepler is a gravitational parameter off by as much (and the energy
//! `E = -p_t` rounded: half an ulp of `E = -0.01` moves the state by 6e-11). A run started in
//! double-double ([`Compensated::start_from`], `Dth::with_low`: the regularized types'
//! `start_double_double` maps the physical start exactly, energy included) therefore solves
//! each step's equation beyond double precision ([`Compensated::settle_exact`]: one
//! correction with a double-double residual, `grad K` in double-double from the Hamiltonian),
//! and its last step lands on the physical time with the clock's low part. At e = 0.999, 100
//! orbits, DTH-8 then ends 1.3e-11 from the exact state at 91 steps per orbit and 8e-13 at 128
//! (within its truncation error: an all-double-double DTH-8 gives the same) where the run from
//! doubles ends 1.8e-9 and 4.4e-9 away, for about 18% more per step. A run from doubles keeps
//! the cheaper compensation above: the evaluations of `K` and its derivatives see the high
//! part only, which changes each advance by a relative `eps h |Hess K|`, far below what is
//! compensated (the rounding of `zbar` itself, `eps |zbar|` per step).
//!
//! A step that sets the midpoint any other way (a fallback step) leaves a midpoint whose bits
//! are not the ones the low part belongs to: the low part is then zero, and the compensation
//! starts afresh from that midpoint. (A step redone from its start restores the start's low
//! part with the rest of the state.)
//!
//! Only for regularized runs (`Flags::regularized`, in the extended phase space), where DTH's
//! truncation error goes below this roundoff; elsewhere it would add a pass over the state at
//! every sub-step for a gain hidden under the truncation error.

use super::linear::Linear;
use crate::double_double::Dd;
use crate::hamiltonian::Alloc;
use crate::linalg::two_sum;
use crate::{zeros, Hamiltonian};
use nalgebra::{DefaultAllocator, Dim, OVector};

/// The low part of a midpoint, and the midpoint (its bits) it belongs to.
#[derive(Clone, Debug)]
pub(crate) struct Compensated<D: Dim>
where
    DefaultAllocator: Alloc<D>,
{
    /// The midpoint the low part belongs to (NaN before the first step: no midpoint matches);
    /// between [`Compensated::carry`] and [`Compensated::settle`], Newton's new midpoint.
    paired: OVector<f64, D>,
    /// The low part of `paired`.
    low: OVector<f64, D>,
    /// `grad K` at `paired + low` in double-double, where the Hamiltonian provides it
    /// ([`Hamiltonian::gradient_double_double_into`]) and `exact` says it is current.
    gradient: (OVector<f64, D>, OVector<f64, D>),
    exact: bool,
    /// Whether the steps are solved in double-double ([`Compensated::settle_exact`]): the run
    /// started from a point in double-double ([`Compensated::start_from`]).
    double_double: bool,
    /// Scratch of [`Compensated::settle_exact`]: the left vertex (high and low part), the
    /// residual and the correction.
    vertex: (OVector<f64, D>, OVector<f64, D>),
    residual: OVector<f64, D>,
    correction: OVector<f64, D>,
}

impl<D: Dim> Compensated<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// No low part yet, for a state of dimension `d`.
    pub(crate) fn new(d: D) -> Self {
        let mut paired = zeros(d);
        paired.fill(f64::NAN);
        let pair = || (zeros(d), zeros(d));
        Compensated {
            paired,
            low: zeros(d),
            gradient: pair(),
            exact: false,
            double_double: false,
            vertex: pair(),
            residual: zeros(d),
            correction: zeros(d),
        }
    }

    /// Make this a copy of `other` without allocating (the scratch is not copied).
    pub(crate) fn assign(&mut self, other: &Self) {
        self.paired.copy_from(&other.paired);
        self.low.copy_from(&other.low);
        self.gradient.0.copy_from(&other.gradient.0);
        self.gradient.1.copy_from(&other.gradient.1);
        self.exact = other.exact;
        self.double_double = other.double_double;
    }

    /// The low part of the current midpoint (zero where the compensation starts afresh).
    pub(crate) fn low(&self) -> &OVector<f64, D> {
        &self.low
    }

    /// Start from the midpoint `zbar + low`, and solve the steps in double-double from here.
    pub(crate) fn start_from(&mut self, zbar: &OVector<f64, D>, low: &OVector<f64, D>) {
        self.paired.copy_from(zbar);
        self.low.copy_from(low);
        self.exact = false;
        self.double_double = true;
    }

    /// Whether the steps are solved in double-double.
    pub(crate) fn double_double(&self) -> bool {
        self.double_double
    }

    /// The first half of a step's compensation, before Newton's new midpoint `newton` is
    /// projected onto the energy level: the low part stays if `old` is the midpoint it belongs
    /// to (else it is zero), and `newton` is kept to measure what the projection adds.
    pub(crate) fn carry(&mut self, old: &OVector<f64, D>, newton: &OVector<f64, D>) {
        let fresh = old
            .iter()
            .zip(self.paired.iter())
            .any(|(a, b)| a.to_bits() != b.to_bits());
        if fresh {
            self.low.fill(0.0);
            self.exact = false;
        }
        self.paired.copy_from(newton);
    }

    /// Whether `grad K` at the old midpoint `old + low` is known in double-double (evaluated
    /// here unless the last step left it, and unless the Hamiltonian does not provide it).
    fn old_gradient<H: Hamiltonian<D>>(&mut self, ham: &H, old: &OVector<f64, D>) -> bool {
        if !self.exact {
            let (hi, lo) = (&mut self.gradient.0, &mut self.gradient.1);
            self.exact = ham.gradient_double_double_into((old, &self.low), (hi, lo));
        }
        self.exact
    }

    /// [`Self::settle`], then, in a run solved in double-double where the Hamiltonian gives
    /// its gradient so, the step's equation solved beyond double precision: one correction of
    /// the new midpoint `z = new + low` by `A dz = -f(z)`, where
    /// `f(z) = z - v - (h/2) lambda J grad K(z)` with the left vertex
    /// `v = old + (h/2) old_lambda J grad K(old)`, both gradients and the sums in
    /// double-double (`lambda` and `old_lambda` are the doubles Newton found: the step's
    /// multipliers as they stand), and `A = I - (h lambda / 2) J Hess K` factored by Newton
    /// at an iterate at most a relative `1e-4` from `z`. The settled `z` is a few ulps off the
    /// solution; the correction keeps about `h lambda |Hess' K| 1e-4` of that, some 1e-21 of
    /// `|z|` on Kepler. The gradient kept for the next step moves with `z` by `Hess K dz`.
    ///
    /// Why: [`Self::settle`] adds advances computed from `grad K` rounded to doubles, at the
    /// high part of the point. On a regularized Kepler orbit at e = 0.999 those roundings, the
    /// same at each pericentre passage, move the clock against the orbit's phase by about
    /// `1e-16` of the time elapsed, 1e-9 at the pericentre after 100 orbits; solved this way
    /// DTH-8 ends within its truncation error (docs/performance.md).
    pub(crate) fn settle_exact<H: Hamiltonian<D>, L: Linear<D>>(
        &mut self,
        ham: &H,
        solver: &mut L,
        h: f64,
        (old, old_gradient, old_lambda): (&OVector<f64, D>, &OVector<f64, D>, f64),
        (new, gradient, lambda): (&mut OVector<f64, D>, &OVector<f64, D>, f64),
    ) {
        if !(self.double_double && self.old_gradient(ham, old)) {
            self.settle(h, (old, old_gradient, old_lambda), (new, gradient, lambda));
            return;
        }
        // The left vertex in double-double, from the old midpoint with its low part.
        let n = old.len() / 2;
        let (vh, vl) = (&mut self.vertex.0, &mut self.vertex.1);
        for j in 0..old.len() {
            let (gh, gl) = j_entry(&self.gradient, j, n);
            let (ah, al) = scaled(0.5 * h, old_lambda, gh, gl);
            let (sum, error) = two_sum(old[j], ah);
            (vh[j], vl[j]) = (sum, error + self.low[j] + al);
        }
        self.settle(h, (old, old_gradient, old_lambda), (new, gradient, lambda));
        let (gh, gl) = (&mut self.gradient.0, &mut self.gradient.1);
        if !ham.gradient_double_double_into((new, &self.low), (gh, gl)) {
            self.exact = false;
            return;
        }
        for j in 0..new.len() {
            let (gh, gl) = j_entry(&self.gradient, j, n);
            let (ah, al) = scaled(0.5 * h, lambda, gh, gl);
            // f_j = (z_j - v_j) - advance_j: the high parts' differences exact, the rest (all
            // of the size of f, a few ulps of z) summed in doubles.
            let (d, e1) = two_sum(new[j], -self.vertex.0[j]);
            let (f, e2) = two_sum(d, -ah);
            self.residual[j] = f + (((e1 + e2) + (self.low[j] - self.vertex.1[j])) - al);
        }
        solver.solve_into(&self.residual, &mut self.correction);
        self.correction.neg_mut();
        for j in 0..new.len() {
            let (sum, error) = two_sum(new[j], self.correction[j]);
            (new[j], self.low[j]) = fast_two_sum(sum, error + self.low[j]);
        }
        // The gradient moves with the point: `+ Hess K dz`, to first order (the second is
        // `|Hess' K| |dz|^2`, some eps^2 of the gradient squared).
        solver.hessian_times_into(&self.correction, &mut self.residual);
        for j in 0..new.len() {
            let (gh, gl) = (&mut self.gradient.0[j], &mut self.gradient.1[j]);
            (*gh, *gl) = two_sum(*gh, *gl + self.residual[j]);
        }
        self.paired.copy_from(new);
    }

    /// The second half, after the projection moved the new midpoint to `new` (with `lambda`
    /// and `gradient` there): `new` becomes the exact sum `old + low + (h/2) J (old_lambda
    /// old_gradient + lambda gradient)` plus the projection's move `new - newton`, rounded,
    /// and what the rounding drops is the new low part.
    pub(crate) fn settle(
        &mut self,
        h: f64,
        (old, old_gradient, old_lambda): (&OVector<f64, D>, &OVector<f64, D>, f64),
        (new, gradient, lambda): (&mut OVector<f64, D>, &OVector<f64, D>, f64),
    ) {
        let n = old.len() / 2;
        let c = 0.5 * h;
        let (paired, low) = (&self.paired, &mut self.low);
        // The advance of coordinate `j`, `c (old_lambda (J old_gradient)_j + lambda (J
        // gradient)_j)`, added: `(J g)_j` is `g_{j+n}` for a coordinate, `-g_{j-n}` for a
        // momentum (two loops, no branch per coordinate).
        let mut add = |j: usize, advance: f64| {
            let (sum, error) = two_sum(old[j], advance);
            // What Newton's midpoint lacks to be the exact sum (`sum - newton` is exact:
            // Newton's solution is a few ulps from the sum), added to the projected one. That
            // is a few ulps of `new[j]` (unless `new[j]` is near zero, where an inexact last
            // sum loses an ulp of those few ulps): the fast two-sum suffices.
            let missing = (sum - paired[j]) + (error + low[j]);
            (new[j], low[j]) = fast_two_sum(new[j], missing);
        };
        for j in 0..n {
            add(
                j,
                c * (old_lambda * old_gradient[j + n] + lambda * gradient[j + n]),
            );
        }
        for j in n..2 * n {
            add(
                j,
                -c * (old_lambda * old_gradient[j - n] + lambda * gradient[j - n]),
            );
        }
        self.paired.copy_from(new);
    }
}

/// Entry `j` of `J g` for the double-double `g = (high, low)`: `g_{j+n}` for a coordinate,
/// `-g_{j-n}` for a momentum.
#[inline]
fn j_entry<D: Dim>(
    (high, low): &(OVector<f64, D>, OVector<f64, D>),
    j: usize,
    n: usize,
) -> (f64, f64)
where
    DefaultAllocator: Alloc<D>,
{
    if j < n {
        (high[j + n], low[j + n])
    } else {
        (-high[j - n], -low[j - n])
    }
}

/// `c lambda (gh + gl)` in double-double, as its high and low part (`c lambda` exact).
#[inline]
fn scaled(c: f64, lambda: f64, gh: f64, gl: f64) -> (f64, f64) {
    let p = Dd::new(c) * Dd::new(lambda) * Dd { hi: gh, lo: gl };
    (p.hi, p.lo)
}

/// `a + b` rounded and its rounding error, exact when `|a| >= |b|` (Dekker's fast two-sum).
#[inline]
fn fast_two_sum(a: f64, b: f64) -> (f64, f64) {
    let sum = a + b;
    (sum, b - (sum - a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Const, Vector2};

    /// A million advances `h = 0.1` of the drift `q' = 1` (`H = p`, `lambda = 1`), each new
    /// midpoint rounded as Newton would return it: the compensated sum is the double nearest
    /// to the exact sum of the million doubles `0.1` (which is 1e5 + 5.6e-12, so 1e5 itself),
    /// where the plain sum drifts by about a million half-ulps.
    #[test]
    fn the_compensated_sum_of_advances_stays_exact() {
        let gradient = Vector2::new(0.0, 1.0);
        let h = 0.1;
        let mut c = Compensated::<Const<2>>::new(Const::<2>);
        let (mut z, mut plain) = (Vector2::new(0.0, 0.0), 0.0f64);
        for _ in 0..1_000_000 {
            let mut new = Vector2::new(z[0] + h, z[1]);
            c.carry(&z, &new);
            c.settle(h, (&z, &gradient, 1.0), (&mut new, &gradient, 1.0));
            z = new;
            plain += h;
        }
        assert_eq!(z[0], 100_000.0);
        assert!((plain - 100_000.0).abs() > 1e-7, "{plain}");
    }

    /// A midpoint set another way (not the one the low part belongs to) starts afresh.
    #[test]
    fn a_midpoint_set_another_way_starts_afresh() {
        let gradient = Vector2::new(0.0, 1.0);
        let mut c = Compensated::<Const<2>>::new(Const::<2>);
        let z = Vector2::new(1.0, 0.0);
        let mut new = Vector2::new(1.0, 0.0);
        // Advance 2^-60: lost in the rounding of 1 + 2^-60, kept in the low part.
        c.carry(&z, &new);
        c.settle(
            2f64.powi(-60),
            (&z, &gradient, 1.0),
            (&mut new, &gradient, 1.0),
        );
        assert_eq!(c.low[0], 2f64.powi(-60));
        // From the same midpoint the low part carries on; from another it is dropped.
        let mut next = new;
        c.carry(&new, &next);
        c.settle(0.0, (&new, &gradient, 1.0), (&mut next, &gradient, 1.0));
        assert_eq!(c.low[0], 2f64.powi(-60));
        let other = Vector2::new(2.0, 0.0);
        let mut next = other;
        c.carry(&other, &next);
        c.settle(0.0, (&other, &gradient, 1.0), (&mut next, &gradient, 1.0));
        assert_eq!(c.low[0], 0.0);
    }
}
