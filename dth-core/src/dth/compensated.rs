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
//! `the_compensated_state_keeps_e099_within_1e_10_of_the_exact_orbit`). What remains is a shift
//! along the orbit, the clock against the phase of `(u, P)`, of about 1e-16 of the time
//! elapsed: the rounding of the energy `E = -p_t` is part of it (half an ulp of `E = -0.01`
//! moves the state after 100 orbits by 6e-11), the rest is not found yet (docs/performance.md,
//! "What the e = 0.999 floor is").
//!
//! The evaluations of `K` and its derivatives see the high part only: the low part moves the
//! point by less than an ulp, which changes each advance by a relative `eps h |Hess K|`, far
//! below what is compensated (the rounding of `zbar` itself, `eps |zbar|` per step).
//!
//! A step that sets the midpoint any other way (a fallback step) leaves a midpoint whose bits
//! are not the ones the low part belongs to: the low part is then zero, and the compensation
//! starts afresh from that midpoint. (A step redone from its start restores the start's low
//! part with the rest of the state.)
//!
//! Only for regularized runs (`Flags::regularized`, in the extended phase space), where DTH's
//! truncation error goes below this roundoff; elsewhere it would add a pass over the state at
//! every sub-step for a gain hidden under the truncation error.

use crate::hamiltonian::Alloc;
use crate::linalg::two_sum;
use crate::zeros;
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
}

impl<D: Dim> Compensated<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// No low part yet, for a state of dimension `d`.
    pub(crate) fn new(d: D) -> Self {
        let mut paired = zeros(d);
        paired.fill(f64::NAN);
        Compensated {
            paired,
            low: zeros(d),
        }
    }

    /// Make this a copy of `other` without allocating.
    pub(crate) fn assign(&mut self, other: &Self) {
        self.paired.copy_from(&other.paired);
        self.low.copy_from(&other.low);
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
        }
        self.paired.copy_from(newton);
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
