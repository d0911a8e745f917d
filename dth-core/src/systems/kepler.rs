use crate::{Derivatives, Flags};
use nalgebra::Const;
use nalgebra::{Matrix4, Vector4};

use crate::Hamiltonian;

/// The planar Kepler problem `H = |p|^2 / (2 m) - k / |q|`, `z = (q1, q2, p1, p2)`.
///
/// The thesis's form `p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)` is `m = 1/2`, `k = 1`
/// ([`Kepler::thesis`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kepler {
    /// Mass `m`.
    pub mass: f64,
    /// Force constant `k` (`G M m`).
    pub k: f64,
}

/// `|q| = sqrt(q1^2 + q2^2)` from `r2 = q1^2 + q2^2`, one rounding each: within about one
/// unit in the last place, as `f64::hypot` (which guards against overflow of `r2` beyond
/// `|q| ~ 1e154`, far outside any orbit here, at several times the cost: `hypot` was a tenth
/// of a Kepler DTH step). Every method takes `|q|` from here, so that the fused
/// [`Hamiltonian::derivatives_into`] and the separate methods stay the same bits.
#[inline]
fn radius(r2: f64) -> f64 {
    r2.sqrt()
}

impl Kepler {
    /// The thesis's Kepler problem: `m = 1/2`, `k = 1`.
    pub const fn thesis() -> Self {
        Kepler { mass: 0.5, k: 1.0 }
    }

    /// Angular momentum `L = q1 p2 - q2 p1`.
    pub fn angular_momentum(z: &Vector4<f64>) -> f64 {
        z[0] * z[3] - z[1] * z[2]
    }
}

impl Hamiltonian<Const<4>> for Kepler {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default()
            .with_separable(true)
            .with_exact_divided_differences(true)
    }

    fn value(&self, z: &Vector4<f64>) -> f64 {
        let r = radius(z[0] * z[0] + z[1] * z[1]);
        (z[2] * z[2] + z[3] * z[3]) / (2.0 * self.mass) - self.k / r
    }

    fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = {
            let r2 = z[0] * z[0] + z[1] * z[1];
            let kr3 = self.k / (r2 * radius(r2));
            Vector4::new(kr3 * z[0], kr3 * z[1], z[2] / self.mass, z[3] / self.mass)
        };
    }

    fn hessian_into(&self, z: &Vector4<f64>, out: &mut Matrix4<f64>) {
        let r2 = z[0] * z[0] + z[1] * z[1];
        *out = self.hessian_from(z[0], z[1], r2, self.k / (r2 * radius(r2)));
    }

    /// Value, gradient, Hessian and `Psi` together: `|q|^2`, `|q|^3` and `k / |q|^3` once (the
    /// separate methods compute them each; value, gradient and Hessian are the same bits), and
    /// `Psi` from the Hessian's two diagonal blocks.
    fn derivatives_into(&self, z: &Vector4<f64>, out: &mut Derivatives<Const<4>>) {
        let r2 = z[0] * z[0] + z[1] * z[1];
        let r = radius(r2);
        let kr3 = self.k / (r2 * r);
        let im = 1.0 / self.mass;
        out.value = (z[2] * z[2] + z[3] * z[3]) / (2.0 * self.mass) - self.k / r;
        out.gradient = Vector4::new(kr3 * z[0], kr3 * z[1], z[2] / self.mass, z[3] / self.mass);
        out.hessian = self.hessian_from(z[0], z[1], r2, kr3);
        // Psi = (J g)^T Hess (J g) with J g = (g_p, -g_q) and a block-diagonal Hessian:
        // g_p^T Hess_qq g_p + g_q^T Hess_pp g_q (the same terms as `psi_from`, without its
        // products by the zero blocks).
        let (a, b) = (out.gradient[2], out.gradient[3]);
        let (c, d) = (out.gradient[0], out.gradient[1]);
        let h = &out.hessian;
        out.psi = a * a * h[(0, 0)]
            + 2.0 * (a * b * h[(0, 1)])
            + b * b * h[(1, 1)]
            + im * (c * c + d * d);
    }

    /// Exact divided differences, no cancellation as `z1 -> z0`:
    /// `gbar_q = k (q0 + q1) / (r0 r1 (r0 + r1))`, `gbar_p = (p0 + p1) / (2m)`.
    /// (`gbar_q . (q1 - q0) = k (r1^2 - r0^2) / (r0 r1 (r0 + r1)) = k/r0 - k/r1`.)
    fn discrete_gradient_into(&self, z0: &Vector4<f64>, z1: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = {
            let r0 = radius(z0[0] * z0[0] + z0[1] * z0[1]);
            let r1 = radius(z1[0] * z1[0] + z1[1] * z1[1]);
            let c = self.k / (r0 * r1 * (r0 + r1));
            let im = 0.5 / self.mass;
            Vector4::new(
                c * (z0[0] + z1[0]),
                c * (z0[1] + z1[1]),
                im * (z0[2] + z1[2]),
                im * (z0[3] + z1[3]),
            )
        };
    }

    /// `t = g0 + g1 - 2 gbar` from differences `dq = q1 - q0` only: `t_p = 0` and, with
    /// `a = 1/r0`, `b = 1/r1`, `qm = (q0 + q1)/2`, `a - b = 2 dq.qm / (r0 r1 (r0 + r1))`,
    ///
    /// ```text
    /// t_q = k (a - b)/(a + b) [ (a - b)(a^2 + 3ab + b^2) qm - (dq/2)(a^3 + b^3 + 2ab(a + b)) ]
    /// ```
    ///
    /// (from `t_q / k = q0 a^3 + q1 b^3 - 2 (q0 + q1) a^2 b^2 / (a + b)`).
    fn discrete_gradient_defect_into(
        &self,
        z0: &Vector4<f64>,
        z1: &Vector4<f64>,
        _gbar: &Vector4<f64>,
        out: &mut Vector4<f64>,
    ) {
        *out = {
            let r0 = radius(z0[0] * z0[0] + z0[1] * z0[1]);
            let r1 = radius(z1[0] * z1[0] + z1[1] * z1[1]);
            let (a, b) = (1.0 / r0, 1.0 / r1);
            let dq = [z1[0] - z0[0], z1[1] - z0[1]];
            let qm = [0.5 * (z0[0] + z1[0]), 0.5 * (z0[1] + z1[1])];
            let a_minus_b = 2.0 * (dq[0] * qm[0] + dq[1] * qm[1]) / (r0 * r1 * (r0 + r1));
            let c1 = a_minus_b * (a * a + 3.0 * a * b + b * b);
            let c2 = 0.5 * (a * a * a + b * b * b + 2.0 * a * b * (a + b));
            let f = self.k * a_minus_b / (a + b);
            Vector4::new(
                f * (c1 * qm[0] - c2 * dq[0]),
                f * (c1 * qm[1] - c2 * dq[1]),
                0.0,
                0.0,
            )
        };
    }
}

impl crate::systems::CentralForce<Const<4>> for Kepler {
    fn mass(&self) -> f64 {
        self.mass
    }

    fn phi(&self, r: f64) -> f64 {
        -self.k / r
    }

    fn dphi(&self, r: f64) -> f64 {
        self.k / (r * r)
    }

    /// `(-k/r1 + k/r0) / (r1 - r0) = k / (r0 r1)` exactly: no cancellation, no guard needed.
    fn phi_divided_difference(&self, r0: f64, r1: f64) -> f64 {
        self.k / (r0 * r1)
    }
}

impl Kepler {
    /// The Hessian at `q = (x, y)` from `r2 = |q|^2` and `kr3 = k / |q|^3`: what
    /// `hessian_into` and the fused `derivatives_into` both write.
    #[inline]
    fn hessian_from(&self, x: f64, y: f64, r2: f64, kr3: f64) -> Matrix4<f64> {
        let kr5 = 3.0 * kr3 / r2;
        let im = 1.0 / self.mass;
        let xy = -kr5 * x * y;
        Matrix4::new(
            kr3 - kr5 * x * x,
            xy,
            0.0,
            0.0,
            xy,
            kr3 - kr5 * y * y,
            0.0,
            0.0,
            0.0,
            0.0,
            im,
            0.0,
            0.0,
            0.0,
            0.0,
            im,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fused evaluation is the separate methods' bits for value, gradient and Hessian, and
    /// `psi_from`'s `Psi` to roundoff (the same terms without the zero blocks' products, summed
    /// in another order: a few eps of the largest term).
    #[test]
    fn fused_derivatives_are_the_separate_ones() {
        let k = Kepler::thesis();
        for z in [
            Vector4::new(0.5, 0.0, 0.0, 1.2),
            Vector4::new(-0.3, 0.8, 0.7, -0.2),
            Vector4::new(1e-3, -2e-3, 30.0, 5.0),
        ] {
            let mut d = Derivatives::<Const<4>>::zeros(Const);
            k.derivatives_into(&z, &mut d);
            assert_eq!(d.value, k.value(&z));
            assert_eq!(d.gradient, k.gradient(&z));
            assert_eq!(d.hessian, k.hessian(&z));
            let psi = crate::psi_from(&d.gradient, &d.hessian);
            let jg = crate::j_times(&d.gradient);
            let scale = jg.abs().dot(&(d.hessian.abs() * jg.abs()));
            assert!(
                (d.psi - psi).abs() <= 8.0 * f64::EPSILON * scale,
                "{z:?}: {} vs {psi}",
                d.psi
            );
        }
    }

    #[test]
    fn divided_differences_are_exact_and_cancellation_free() {
        let k = Kepler::thesis();
        let z0 = Vector4::new(0.5, 0.1, -0.3, 1.2);
        for s in [1e-1, 1e-4, 1e-8] {
            let z1 = z0 + Vector4::new(0.7, -0.4, 0.2, 0.9) * s;
            let d = z1 - z0;
            let gbar = k.discrete_gradient(&z0, &z1);
            let t = k.discrete_gradient_defect(&z0, &z1, &gbar);
            // Discrete gradient property. At s = 1e-1 the plain difference of H is accurate
            // (no cancellation to speak of): a few eps of |H| ~ 2.
            if s == 1e-1 {
                let dh = k.value(&z1) - k.value(&z0);
                assert!((gbar.dot(&d) - dh).abs() <= 16.0 * f64::EPSILON, "s {s}");
                let plain = k.gradient(&z0) + k.gradient(&z1) - gbar * 2.0;
                // t = O(s^2) ~ 1e-2 here; plain has absolute error ~eps |g| ~ 1e-15.
                assert!((t - plain).amax() <= 64.0 * f64::EPSILON, "s {s}");
            }
            // Second-order Taylor check of t (exact to O(s^4) relative to t ~ s^2): for the
            // symmetric gbar here, t = (1/6) (Hess1 - Hess0) d + O(s^4) when the q-part is
            // expanded; compare to a finite-precision-free statement instead: t is O(s^2)
            // with relative accuracy, so t / s^2 is independent of s up to O(s).
            let scaled = t / (s * s);
            assert!(
                scaled.amax() > 1e-3 && scaled.amax() < 10.0,
                "s {s}: {scaled:?}"
            );
        }
        // Relative accuracy of t at tiny s: the ratio t(s)/s^2 matches t(2s)/(4s^2) to O(s).
        let dir = Vector4::new(0.7, -0.4, 0.2, 0.9);
        let t_at = |s: f64| {
            let z1 = z0 + dir * s;
            let gbar = k.discrete_gradient(&z0, &z1);
            k.discrete_gradient_defect(&z0, &z1, &gbar) / (s * s)
        };
        let (a, b) = (t_at(1e-7), t_at(2e-7));
        // The rounding of z1 = z0 + dir s is part of the exact input, so use a loose but
        // roundoff-free bound: O(s) = 1e-6 relative difference.
        assert!((a - b).amax() <= 1e-5 * a.amax(), "{a:?} vs {b:?}");
    }
}
