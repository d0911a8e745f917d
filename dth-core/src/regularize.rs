//! Physical states in and out of a regularization: the Levi-Civita map between the plane
//! `(q, p)` at time `t` and the regularized state `(u, t, P, p_t)` of
//! `K = |u|^2 (H + p_t)` (the Hamiltonian itself is compiled by the symbolic engine:
//! `dth_symbolic::regularize`, `dth::runtime::RuntimeHamiltonian::levi_civita`).
//!
//! `q = (u1^2 - u2^2, 2 u1 u2)` and `p = A(u) P / (2 |u|^2)` with `A(u) = [[u1, -u2], [u2, u1]]`;
//! back, `u` is a square root of `q` read as a complex number (`u` and `-u` give the same
//! `q`: [`LeviCivita::start`] takes the root with `u1 >= 0`, computed without cancellation)
//! and `P = 2 A(u)^T p`. The run starts on `K = 0`: `p_t = -H(q, p)`.
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

use nalgebra::{Vector4, Vector6};

use crate::Error;

/// The Levi-Civita map of the plane (see the [module docs](self)).
#[derive(Clone, Copy, Debug)]
pub struct LeviCivita;

impl LeviCivita {
    /// The regularized start `(u1, u2, t, P1, P2, p_t)` of the physical state
    /// `z = (q1, q2, p1, p2)` at time `t` whose energy is `energy = H(z)` (`p_t = -energy`, so
    /// that `K = 0`).
    ///
    /// # Errors
    /// [`Error::NonFiniteInitialState`] for a component, time or energy that is not finite;
    /// [`Error::InvalidOption`] (`q`) at the centre `q = 0`, where the momenta have no
    /// regularized image.
    pub fn start(z: &Vector4<f64>, t: f64, energy: f64) -> Result<Vector6<f64>, Error> {
        let all = [z[0], z[1], z[2], z[3], t, energy];
        if let Some((index, &value)) = all.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFiniteInitialState { index, value });
        }
        let (q1, q2) = (z[0], z[1]);
        let r = q1.hypot(q2);
        if r == 0.0 {
            return Err(Error::InvalidOption {
                name: "q",
                value: 0.0,
                reason: "a regularized start needs q away from the centre (q = 0 is the collision)",
            });
        }
        // u^2 = q as complex numbers; the larger of |u1|, |u2| from a sum without cancellation.
        let (u1, u2) = if q1 >= 0.0 {
            let u1 = (0.5 * (r + q1)).sqrt();
            (u1, q2 / (2.0 * u1))
        } else {
            let u2 = (0.5 * (r - q1)).sqrt().copysign(q2);
            (q2 / (2.0 * u2), u2)
        };
        let (p1, p2) = (z[2], z[3]);
        Ok(Vector6::new(
            u1,
            u2,
            t,
            2.0 * (u1 * p1 + u2 * p2),
            2.0 * (-u2 * p1 + u1 * p2),
            -energy,
        ))
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
