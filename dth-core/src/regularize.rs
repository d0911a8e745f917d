//! Physical states in and out of a regularization: the Levi-Civita map ([`LeviCivita`]) between
//! the plane `(q, p)` at time `t` and the regularized state `(u, t, P, p_t)` of
//! `K = |u|^2 (H + p_t)`, and the Kustaanheimo-Stiefel map ([`KustaanheimoStiefel`]) for space
//! (the Hamiltonian itself is compiled by the symbolic engine: `dth_symbolic::regularize`,
//! `hamiltonian!`'s `#[regularize(..)]`, `dth::runtime::RuntimeHamiltonian::levi_civita` and
//! `::kustaanheimo_stiefel`).
//!
//! `q = (u1^2 - u2^2, 2 u1 u2)` and `p = A(u) P / (2 |u|^2)` with `A(u) = [[u1, -u2], [u2, u1]]`;
//! back, `u` is a square root of `q` read as a complex number (`u` and `-u` give the same
//! `q`: [`LeviCivita::start`] takes the root with `u1 >= 0`, computed without cancellation)
//! and `P = 2 A(u)^T p`. The run starts on `K = 0`: `p_t = -H(q, p)`.
//!
//! **The energy sets the period.** `p_t` is a coordinate DTH keeps exactly, and for a Kepler
//! problem the regularized orbit's period follows it (`T ~ |E|^(-3/2)`): pass the start's
//! energy to full relative precision where many orbits matter. At high eccentricity `E` is a
//! small difference of large terms (`|p|^2 - k/r` at pericentre): the plain sum carries one
//! rounding of the terms, `eps |p|^2`, which at e = 0.999 is 1e-13 of `E` and moves the state
//! by 2e-6 after 100 orbits; computed with one rounding (`p.mul_add(p, -k / r)` where `k / r`
//! is exact), DTH-8 ends within 6e-9 of the exact orbit at 64 or more steps per orbit (the
//! `regularized_vs_ias15` example of `dth-examples`). The same holds for
//! [`KustaanheimoStiefel`]. So the regularized Hamiltonians compute it for you, from the
//! physical `H` they were built from, in double-double arithmetic rounded once: a
//! `hamiltonian!` type with `#[regularize(levi_civita)]` (or `kustaanheimo_stiefel`) has
//! `start(&z, t)` (this module's `start` with `p_t = -physical_energy(&z)`), and a run-time
//! `K` has `dth::runtime::RuntimeHamiltonian::physical_energy_slice`; scenes with `regularize`
//! and Python's `regularize=` start that way.
//!
//! **Beyond double precision.** A start in doubles still carries the roundings of `u`, `P`
//! and `p_t`: its `K` is some 1e-16 off zero, which for Kepler is a gravitational parameter off
//! by as much, and each DTH step rounds its advances; together they hold a run at about 1e-16
//! of the time elapsed (1e-9 at the pericentre after 100 orbits at e = 0.999).
//! `start_double_double` (here from an energy `hi + lo`; a regularized `hamiltonian!` type's
//! from its physical `H` in double-double) gives the exact image of the physical start as a
//! state and its low part, and a DTH run started from both (`solve(..).start_low(low)`)
//! solves every step in double-double: DTH-8 then ends within its truncation error (1.3e-11
//! at 91 steps per orbit there), for about 18% more per step.
//!
//! ```
//! use dth_core::nalgebra::Vector4;
//! use dth_core::regularize::LeviCivita;
//! let z = Vector4::new(-0.3, 0.4, 0.7, -1.1); // (q1, q2, p1, p2)
//! let w = LeviCivita::start(&z, 2.5, -0.25)?; // at t = 2.5 with H(q, p) = -0.25
//! assert_eq!((w[2], w[5]), (2.5, 0.25)); // (u1, u2, t, P1, P2, p_t)
//! let (back, t) = LeviCivita::physical(&w);
//! assert!((back - z).amax() < 1e-15 && t == 2.5);
//! # Ok::<(), dth_core::Error>(())
//! ```

use nalgebra::{SVector, Vector4, Vector6};
use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::double_double::Dd;
use crate::Error;

/// The arithmetic of a start: `f64` ([`LeviCivita::start`]) or double-double
/// ([`LeviCivita::start_double_double`]), the same operations in the same order.
trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    fn of(x: f64) -> Self;
    fn sqrt(self) -> Self;
    /// `sqrt(self^2 + other^2)`.
    fn hypot(self, other: Self) -> Self;
}

impl Real for f64 {
    fn of(x: f64) -> Self {
        x
    }
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    fn hypot(self, other: Self) -> Self {
        f64::hypot(self, other)
    }
}

impl Real for Dd {
    fn of(x: f64) -> Self {
        Dd::new(x)
    }
    fn sqrt(self) -> Self {
        Dd::sqrt(self)
    }
    fn hypot(self, other: Self) -> Self {
        (self * self + other * other).sqrt()
    }
}

/// A double-double vector as its rounding and what the rounding dropped.
fn split<const N: usize>(x: [Dd; N]) -> (SVector<f64, N>, SVector<f64, N>) {
    let high = SVector::from_fn(|i, _| x[i].to_f64());
    let low = SVector::from_fn(|i, _| (x[i] - Dd::new(high[i])).to_f64());
    (high, low)
}

/// A start's checks: every value (the state's components, then `t` and the energy) finite,
/// and `q` away from the centre (its length `r`), where the momenta have no regularized image.
fn check_start(values: &[f64], r: f64) -> Result<(), Error> {
    if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(Error::NonFiniteInitialState { index, value });
    }
    if r == 0.0 {
        return Err(Error::InvalidOption {
            name: "q",
            value: 0.0,
            reason: "a regularized start needs q away from the centre (q = 0 is the collision)",
        });
    }
    Ok(())
}

/// The Levi-Civita map of the plane (see the [module docs](self)).
#[derive(Clone, Copy, Debug)]
pub struct LeviCivita;

impl LeviCivita {
    /// The regularized start `(u1, u2, t, P1, P2, p_t)` of the physical state
    /// `z = (q1, q2, p1, p2)` at time `t` whose energy is `energy = H(z)` (`p_t = -energy`, so
    /// that `K = 0`). The orbit's period is as accurate as `energy` (see the
    /// [module docs](self)).
    ///
    /// # Errors
    /// [`Error::NonFiniteInitialState`] for a component, time or energy that is not finite;
    /// [`Error::InvalidOption`] (`q`) at the centre `q = 0`, where the momenta have no
    /// regularized image.
    pub fn start(z: &Vector4<f64>, t: f64, energy: f64) -> Result<Vector6<f64>, Error> {
        check_start(&[z[0], z[1], z[2], z[3], t, energy], z[0].hypot(z[1]))?;
        Ok(Vector6::from(Self::map(z, t, energy)))
    }

    /// [`LeviCivita::start`] in double-double, from the energy `hi + lo`: the state rounded
    /// and its low part (what the rounding of each coordinate dropped), for a run solved in
    /// double-double ([`Dth::with_low`](crate::dth::Dth::with_low)). The state is
    /// [`LeviCivita::start`]'s to an ulp.
    ///
    /// # Errors
    /// As [`LeviCivita::start`].
    pub fn start_double_double(
        z: &Vector4<f64>,
        t: f64,
        (hi, lo): (f64, f64),
    ) -> Result<(Vector6<f64>, Vector6<f64>), Error> {
        check_start(&[z[0], z[1], z[2], z[3], t, hi, lo], z[0].hypot(z[1]))?;
        Ok(split(Self::map(z, t, Dd { hi, lo })))
    }

    /// The map of a checked start, in `T`'s arithmetic.
    fn map<T: Real>(z: &Vector4<f64>, t: f64, energy: T) -> [T; 6] {
        let [q1, q2, p1, p2] = [z[0], z[1], z[2], z[3]].map(T::of);
        let r = q1.hypot(q2);
        let half = T::of(0.5);
        let two = T::of(2.0);
        // u^2 = q as complex numbers; the larger of |u1|, |u2| from a sum without cancellation.
        let (u1, u2) = if z[0] >= 0.0 {
            let u1 = (half * (r + q1)).sqrt();
            (u1, q2 / (two * u1))
        } else {
            let u2 = (half * (r - q1)).sqrt();
            let u2 = if z[1] < 0.0 || (z[1] == 0.0 && z[1].is_sign_negative()) {
                -u2
            } else {
                u2
            };
            (q2 / (two * u2), u2)
        };
        [
            u1,
            u2,
            T::of(t),
            two * (u1 * p1 + u2 * p2),
            two * (-u2 * p1 + u1 * p2),
            -energy,
        ]
    }

    /// The physical state `(q1, q2, p1, p2)` and time `t` of a regularized state
    /// `(u1, u2, t, P1, P2, p_t)` (at `u = 0`, the collision, the momenta are infinite).
    pub fn physical(w: &Vector6<f64>) -> (Vector4<f64>, f64) {
        let (u1, u2, pp1, pp2) = (w[0], w[1], w[3], w[4]);
        let s = u1 * u1 + u2 * u2;
        let z = Vector4::new(
            u1 * u1 - u2 * u2,
            2.0 * u1 * u2,
            (u1 * pp1 - u2 * pp2) / (2.0 * s),
            (u2 * pp1 + u1 * pp2) / (2.0 * s),
        );
        (z, w[2])
    }
}

/// The Kustaanheimo-Stiefel map of space: `q = (L(u) u)_{1..3}`, `p = (L(u) P)_{1..3} / (2 |u|^2)`
/// with the KS matrix `L(u)` (`dth_symbolic::regularize`), on the manifold where the bilinear
/// invariant ([`KustaanheimoStiefel::bilinear`]) is zero.
///
/// ```
/// use dth_core::nalgebra::Vector6;
/// use dth_core::regularize::KustaanheimoStiefel;
/// let z = Vector6::new(-0.3, 0.4, 0.2, 0.7, -1.1, 0.5); // (q1, q2, q3, p1, p2, p3)
/// let w = KustaanheimoStiefel::start(&z, 0.0, -0.25)?; // (u1..u4, t, P1..P4, p_t)
/// assert_eq!(KustaanheimoStiefel::bilinear(&w), 0.0);
/// let (back, _) = KustaanheimoStiefel::physical(&w);
/// assert!((back - z).amax() < 1e-15);
/// # Ok::<(), dth_core::Error>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct KustaanheimoStiefel;

/// `L(u) y` (all four rows).
fn ks_apply(u: &[f64; 4], y: &[f64; 4]) -> [f64; 4] {
    let [u1, u2, u3, u4] = *u;
    let [y1, y2, y3, y4] = *y;
    [
        u1 * y1 - u2 * y2 - u3 * y3 + u4 * y4,
        u2 * y1 + u1 * y2 - u4 * y3 - u3 * y4,
        u3 * y1 + u4 * y2 + u1 * y3 + u2 * y4,
        u4 * y1 - u3 * y2 + u2 * y3 - u1 * y4,
    ]
}

impl KustaanheimoStiefel {
    /// The regularized start `(u1..u4, t, P1..P4, p_t)` of the physical state
    /// `z = (q1, q2, q3, p1, p2, p3)` at time `t` with `energy = H(z)`: the point of the fibre
    /// with `u4 = 0` (or `u3 = 0` for `q1 < 0`, without cancellation), `P = 2 L(u)^T (p, 0)`
    /// (so the bilinear invariant is zero), `p_t = -energy`.
    ///
    /// # Errors
    /// As [`LeviCivita::start`].
    pub fn start(z: &Vector6<f64>, t: f64, energy: f64) -> Result<SVector<f64, 10>, Error> {
        let values = [z[0], z[1], z[2], z[3], z[4], z[5], t, energy];
        check_start(&values, z[0].hypot(z[1]).hypot(z[2]))?;
        Ok(SVector::from(Self::map(z, t, energy)))
    }

    /// [`KustaanheimoStiefel::start`] in double-double, from the energy `hi + lo`: the state
    /// rounded and its low part, as [`LeviCivita::start_double_double`].
    ///
    /// # Errors
    /// As [`LeviCivita::start`].
    pub fn start_double_double(
        z: &Vector6<f64>,
        t: f64,
        (hi, lo): (f64, f64),
    ) -> Result<(SVector<f64, 10>, SVector<f64, 10>), Error> {
        let values = [z[0], z[1], z[2], z[3], z[4], z[5], t, hi, lo];
        check_start(&values, z[0].hypot(z[1]).hypot(z[2]))?;
        Ok(split(Self::map(z, t, Dd { hi, lo })))
    }

    /// The map of a checked start, in `T`'s arithmetic.
    fn map<T: Real>(z: &Vector6<f64>, t: f64, energy: T) -> [T; 10] {
        let [q1, q2, q3] = [z[0], z[1], z[2]].map(T::of);
        let r = q1.hypot(q2).hypot(q3);
        let (half, two, zero) = (T::of(0.5), T::of(2.0), T::of(0.0));
        let u = if z[0] >= 0.0 {
            let u1 = (half * (r + q1)).sqrt();
            [u1, q2 / (two * u1), q3 / (two * u1), zero]
        } else {
            let u2 = (half * (r - q1)).sqrt();
            [q2 / (two * u2), u2, zero, q3 / (two * u2)]
        };
        // P = 2 L(u)^T (p, 0): L^T has the rows of L's columns.
        let p = [z[3], z[4], z[5], 0.0].map(T::of);
        let [u1, u2, u3, u4] = u;
        [
            u1,
            u2,
            u3,
            u4,
            T::of(t),
            two * (u1 * p[0] + u2 * p[1] + u3 * p[2] + u4 * p[3]),
            two * (-u2 * p[0] + u1 * p[1] + u4 * p[2] - u3 * p[3]),
            two * (-u3 * p[0] - u4 * p[1] + u1 * p[2] + u2 * p[3]),
            two * (u4 * p[0] - u3 * p[1] + u2 * p[2] - u1 * p[3]),
            -energy,
        ]
    }

    /// The physical state `(q1, q2, q3, p1, p2, p3)` and time `t` of a regularized state.
    pub fn physical(w: &SVector<f64, 10>) -> (Vector6<f64>, f64) {
        let u = [w[0], w[1], w[2], w[3]];
        let pp = [w[5], w[6], w[7], w[8]];
        let s = u.iter().map(|x| x * x).sum::<f64>();
        let q = ks_apply(&u, &u);
        let lp = ks_apply(&u, &pp);
        let z = Vector6::new(
            q[0],
            q[1],
            q[2],
            lp[0] / (2.0 * s),
            lp[1] / (2.0 * s),
            lp[2] / (2.0 * s),
        );
        (z, w[4])
    }

    /// The bilinear invariant `u4 P1 - u3 P2 + u2 P3 - u1 P4` (the fourth row of `L(u) P`):
    /// zero on the manifold the regularized flow lives on.
    pub fn bilinear(w: &SVector<f64, 10>) -> f64 {
        ks_apply(&[w[0], w[1], w[2], w[3]], &[w[5], w[6], w[7], w[8]])[3]
    }
}
