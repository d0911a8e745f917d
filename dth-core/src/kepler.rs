//! The exact solution of the planar Kepler problem `H = |p|^2 / (2m) - k / |q|` on elliptic
//! orbits, for measuring the errors of integrators.
//!
//! ```
//! use dth_core::kepler::KeplerOrbit;
//! use dth_core::systems::Kepler;
//! use dth_core::nalgebra::Vector4;
//!
//! let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
//! let orbit = KeplerOrbit::new(&Kepler::thesis(), &z0)?;
//! let e = orbit.elements();
//! assert!((e.energy + 0.56).abs() < 1e-15 && (e.eccentricity - 0.44).abs() < 1e-15);
//! assert!((e.period - 3.7483).abs() < 1e-4);
//! // One period later the state returns.
//! assert!((orbit.state_at(e.period) - z0).amax() < 1e-13);
//! # Ok::<(), dth_core::Error>(())
//! ```

use std::f64::consts::TAU;

use nalgebra::{Vector2, Vector4};

use crate::systems::Kepler;
use crate::Error;

/// One row of the thesis's Table 4.1 (Shibberu 1992, Section 4.2): the average absolute
/// deviation of energy and angular momentum over 10,000 steps on the orbit `q = (0.5, 0)`,
/// `p = (0, 1.2)` of `H = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)` (25 points per orbit, 400 orbits).
/// The average is the mean over `k = 1..N` of `|Q_k - Q_ref|`, with `Q_ref` the initial value
/// (fixed-step methods), `H(zbar_0)` (DTH midpoints) or the value at the first vertex `z^(0)`
/// (DTH vertices); see `docs/thesis.md#table-4-1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Table41Row {
    /// `trapezoidal`, `midpoint`, `discrete_mechanics`, `dth_midpoints` or `dth_vertices`.
    pub method: &'static str,
    /// Average absolute energy deviation.
    pub energy: f64,
    /// Average absolute angular-momentum deviation.
    pub angular_momentum: f64,
}

/// The thesis's Table 4.1, in its order: what every reproduction of it compares with.
/// Entries below `1e-13` are roundoff (a few hundred eps of the `O(1)` quantities), bars to
/// meet rather than values to reproduce.
pub const THESIS_TABLE_4_1: [Table41Row; 5] = [
    Table41Row {
        method: "trapezoidal",
        energy: 1.322e-1,
        angular_momentum: 4.593e-2,
    },
    Table41Row {
        method: "midpoint",
        energy: 5.969e-2,
        angular_momentum: 7.387e-16,
    },
    Table41Row {
        method: "discrete_mechanics",
        energy: 3.901e-15,
        angular_momentum: 1.738e-15,
    },
    Table41Row {
        method: "dth_midpoints",
        energy: 1.285e-14,
        angular_momentum: 8.204e-4,
    },
    Table41Row {
        method: "dth_vertices",
        energy: 1.750e-2,
        angular_momentum: 2.221e-15,
    },
];

/// Orbital elements of an elliptic Kepler orbit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitalElements {
    /// `H = |p|^2 / (2m) - k / r` (negative).
    pub energy: f64,
    /// `L = q1 p2 - q2 p1`.
    pub angular_momentum: f64,
    /// Eccentricity `e`, in `[0, 1)`.
    pub eccentricity: f64,
    /// Semi-major axis `a = -k / (2 H)`.
    pub semi_major_axis: f64,
    /// Period `2 pi sqrt(a^3 / mu)`, `mu = k / m`.
    pub period: f64,
}

/// An elliptic Kepler orbit through a given state; [`KeplerOrbit::state_at`] evaluates it.
///
/// Method: Lagrange's `f` and `g` functions in the eccentric-anomaly change `x = E - E0`, which
/// solves Kepler's equation in the form `x - C sin x + S (1 - cos x) = n t` with
/// `C = e cos E0 = 1 - r0/a`, `S = e sin E0 = (q0 . v0) / sqrt(mu a)` (no division by `e`:
/// circular orbits are fine). The left side is increasing with slope `1 - e cos(E0 + x)` in
/// `[1 - e, 1 + e]` and differs from `x` by at most `2e`, so the root is bracketed in
/// `[n t - 2e, n t + 2e]`; Newton safeguarded by bisection converges for every `e < 1`
/// (tested to `e = 0.999`). Times are reduced modulo the period first.
///
/// # References
/// R. Battin, *An Introduction to the Mathematics and Methods of Astrodynamics* (1999),
/// Sections 4.3-4.4 (f and g functions, Kepler's equation); thesis Section 4.2 (the orbit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeplerOrbit {
    mass: f64,
    mu: f64,
    q0: Vector2<f64>,
    v0: Vector2<f64>,
    r0: f64,
    /// `e cos E0`.
    c: f64,
    /// `e sin E0`.
    s: f64,
    /// Mean motion `n`.
    n: f64,
    elements: OrbitalElements,
}

impl KeplerOrbit {
    /// The orbit of `kepler` through `z0 = (q1, q2, p1, p2)` at `t = 0`.
    ///
    /// Errors: [`Error::NonFiniteInitialState`] for a NaN/infinite component,
    /// [`Error::InvalidOption`] for non-positive `mass` or `k` or `q = 0`,
    /// [`Error::KeplerNotElliptic`] when `H >= 0` (parabolic or hyperbolic).
    pub fn new(kepler: &Kepler, z0: &Vector4<f64>) -> Result<Self, Error> {
        if let Some((index, &value)) = z0.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFiniteInitialState { index, value });
        }
        for (name, value) in [("mass", kepler.mass), ("k", kepler.k)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::InvalidOption {
                    name,
                    value,
                    reason: "must be positive and finite",
                });
            }
        }
        let q0 = Vector2::new(z0[0], z0[1]);
        let v0 = Vector2::new(z0[2], z0[3]) / kepler.mass;
        let r0 = q0.norm();
        if r0 == 0.0 {
            return Err(Error::InvalidOption {
                name: "q",
                value: r0,
                reason: "the orbit starts at the singularity r = 0",
            });
        }
        let mu = kepler.k / kepler.mass;
        let energy = kepler.mass * (0.5 * v0.norm_squared() - mu / r0);
        let angular_momentum = Kepler::angular_momentum(z0);
        // e^2 = 1 + 2 (H/m) (L/m)^2 / mu^2.
        let h_per_mass = angular_momentum / kepler.mass;
        let e2 = 1.0 + 2.0 * (energy / kepler.mass) * h_per_mass * h_per_mass / (mu * mu);
        let eccentricity = e2.max(0.0).sqrt();
        if energy >= 0.0 || eccentricity >= 1.0 {
            return Err(Error::KeplerNotElliptic {
                energy,
                eccentricity,
            });
        }
        let a = -mu * kepler.mass / (2.0 * energy);
        let n = (mu / (a * a * a)).sqrt();
        Ok(KeplerOrbit {
            mass: kepler.mass,
            mu,
            q0,
            v0,
            r0,
            c: 1.0 - r0 / a,
            s: q0.dot(&v0) / (mu * a).sqrt(),
            n,
            elements: OrbitalElements {
                energy,
                angular_momentum,
                eccentricity,
                semi_major_axis: a,
                period: TAU / n,
            },
        })
    }

    /// The orbital elements.
    pub fn elements(&self) -> OrbitalElements {
        self.elements
    }

    /// The state `(q1, q2, p1, p2)` at time `t` (any sign).
    pub fn state_at(&self, t: f64) -> Vector4<f64> {
        let period = self.elements.period;
        // Reduce t to [-period/2, period/2): the motion is periodic, the f, g formulas below
        // use the reduced time consistently, and |x| <= pi + 2e keeps g = t - (x - sin x)/n and
        // 1 - cos x free of the cancellation they suffer near x = 2 pi (a return close to the
        // initial point).
        let t = t - (t / period).round() * period;
        let a = self.elements.semi_major_axis;
        let x = self.solve_anomaly(self.n * t);
        let (sin_x, cos_x) = x.sin_cos();
        let r = a * (1.0 - self.c * cos_x + self.s * sin_x);
        let f = 1.0 - a / self.r0 * (1.0 - cos_x);
        let g = t - (x - sin_x) / self.n;
        let fdot = -(self.mu * a).sqrt() / (r * self.r0) * sin_x;
        let gdot = 1.0 - a / r * (1.0 - cos_x);
        let q = self.q0 * f + self.v0 * g;
        let p = (self.q0 * fdot + self.v0 * gdot) * self.mass;
        Vector4::new(q[0], q[1], p[0], p[1])
    }

    /// Solves `x - C sin x + S (1 - cos x) = m` for `x` by Newton safeguarded with bisection
    /// on the bracket `[m - 2e, m + 2e]`, to roundoff.
    fn solve_anomaly(&self, m: f64) -> f64 {
        let (c, s) = (self.c, self.s);
        let e = self.elements.eccentricity;
        let kepler = |x: f64| {
            let (sin_x, cos_x) = x.sin_cos();
            (
                x - c * sin_x + s * (1.0 - cos_x) - m,
                1.0 - c * cos_x + s * sin_x,
            )
        };
        let (mut lo, mut hi) = (m - 2.0 * e, m + 2.0 * e);
        // Starting value: the mean anomaly shifted towards the root; good for small e, and
        // the bracket keeps Newton safe for e close to 1.
        let mut x = m;
        for _ in 0..200 {
            let (f, df) = kepler(x);
            if f == 0.0 {
                return x;
            }
            if f < 0.0 {
                lo = lo.max(x);
            } else {
                hi = hi.min(x);
            }
            let newton = x - f / df;
            let next = if newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            // Stop when the step is at the spacing of floats near x (roundoff), or the bracket
            // has collapsed.
            if (next - x).abs() <= 2.0 * f64::EPSILON * x.abs().max(1.0) || hi - lo <= 0.0 {
                return next;
            }
            x = next;
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thesis() -> KeplerOrbit {
        KeplerOrbit::new(&Kepler::thesis(), &Vector4::new(0.5, 0.0, 0.0, 1.2)).unwrap()
    }

    #[test]
    fn thesis_orbit_elements() {
        let e = thesis().elements();
        // Closed forms: H = 1.2^2 - 1/0.5 = -0.56, L = 0.6, e^2 = 1 - 2*1.12*1.44/4 = 0.1936,
        // a = 2/2.24, T = 2 pi sqrt(a^3/2); checked to a few ulps.
        let tol = 8.0 * f64::EPSILON;
        assert!((e.energy + 0.56).abs() <= tol);
        assert!((e.angular_momentum - 0.6).abs() <= tol);
        assert!((e.eccentricity - 0.44).abs() <= tol);
        let a = 2.0 / 2.24;
        assert!((e.semi_major_axis - a).abs() <= tol);
        assert!((e.period - TAU * (a * a * a / 2.0).sqrt()).abs() <= tol * 4.0);
        assert!((e.period - 3.7483).abs() < 5e-5, "{}", e.period); // thesis: 3.7483
    }

    #[test]
    fn conserves_energy_and_angular_momentum_and_reaches_aphelion_at_half_period() {
        let orbit = thesis();
        let h = Kepler::thesis();
        let el = orbit.elements();
        for i in 0..=100 {
            let t = el.period * i as f64 / 37.0;
            let z = orbit.state_at(t);
            use crate::Hamiltonian;
            // O(1) quantities, a few hundred flops: 1e-14 is ~50 eps.
            assert!((h.value(&z) - el.energy).abs() < 1e-14, "t {t}");
            assert!((Kepler::angular_momentum(&z) - el.angular_momentum).abs() < 1e-14);
        }
        // Starting at perihelion (q.p = 0, r = a(1-e) = 0.5): aphelion r = a(1+e) at T/2.
        let z = orbit.state_at(0.5 * el.period);
        let r = z[0].hypot(z[1]);
        assert!((r - el.semi_major_axis * (1.0 + el.eccentricity)).abs() < 1e-14);
        assert!((z[0] + r).abs() < 1e-14 && z[1].abs() < 1e-14);
    }

    #[test]
    fn satisfies_the_equations_of_motion() {
        // Central differences of the exact solution against J grad H: O(h^2) + eps/h, h = 1e-4.
        use crate::{j_times, Hamiltonian};
        let orbit = thesis();
        let h = Kepler::thesis();
        let dt = 1e-4;
        for i in 0..20 {
            let t = 0.37 * i as f64;
            let deriv = (orbit.state_at(t + dt) - orbit.state_at(t - dt)) / (2.0 * dt);
            let rhs = j_times(&h.gradient(&orbit.state_at(t)));
            assert!(
                (deriv - rhs).amax() < 1e-6,
                "t {t}: {}",
                (deriv - rhs).amax()
            );
        }
    }

    #[test]
    fn robust_up_to_eccentricity_0_999() {
        use crate::Hamiltonian;
        let h = Kepler { mass: 1.0, k: 1.0 };
        for e in [0.0f64, 0.5, 0.9, 0.99, 0.999] {
            // Perihelion of an orbit with a = 1: r = 1 - e, v = sqrt((1 + e)/(1 - e)).
            let z0 = Vector4::new(1.0 - e, 0.0, 0.0, ((1.0 + e) / (1.0 - e)).sqrt());
            let orbit = KeplerOrbit::new(&h, &z0).unwrap();
            let el = orbit.elements();
            assert!((el.eccentricity - e).abs() < 1e-12, "{e}");
            for i in 1..200 {
                let z = orbit.state_at(el.period * i as f64 / 199.0 * 0.999_7);
                // Energy relative to |H| = 1/2; speeds up to 45 at e = 0.999 make the
                // kinetic energy ~1e3: allow eps * 1e3 * a small factor.
                assert!(
                    (h.value(&z) - el.energy).abs() < 1e-12,
                    "e {e}, i {i}: {:e}",
                    h.value(&z) - el.energy
                );
            }
        }
    }

    #[test]
    fn rejects_unbound_orbits() {
        let err = KeplerOrbit::new(&Kepler::thesis(), &Vector4::new(0.5, 0.0, 0.0, 2.0));
        assert!(matches!(err, Err(Error::KeplerNotElliptic { energy, .. }) if energy > 0.0));
        let err = KeplerOrbit::new(&Kepler::thesis(), &Vector4::new(0.0, 0.0, 0.0, 1.0));
        assert!(matches!(err, Err(Error::InvalidOption { name: "q", .. })));
    }
}
