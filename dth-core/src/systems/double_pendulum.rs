use nalgebra::Const;
use nalgebra::{Matrix4, Vector4};

use crate::Hamiltonian;

/// The planar double pendulum in canonical coordinates, `z = (theta1, theta2, p1, p2)`
/// (angles from the downward vertical and their conjugate momenta):
///
/// ```text
/// H = [m2 l2^2 p1^2 + (m1 + m2) l1^2 p2^2 - 2 m2 l1 l2 p1 p2 cos(d)]
///     / [2 m2 l1^2 l2^2 (m1 + m2 sin^2(d))]
///     - (m1 + m2) g l1 cos(theta1) - m2 g l2 cos(theta2),        d = theta1 - theta2.
/// ```
///
/// Not separable. Derivatives are written in `d`: with `T = N / (K A)`,
/// `K = 2 m2 l1^2 l2^2`, `A = m1 + m2 sin^2 d`, `d/dtheta1 = d/dd = -d/dtheta2` on `T`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DoublePendulum {
    /// Upper bob mass `m1`.
    pub m1: f64,
    /// Lower bob mass `m2`.
    pub m2: f64,
    /// Upper rod length `l1`.
    pub l1: f64,
    /// Lower rod length `l2`.
    pub l2: f64,
    /// Gravitational acceleration `g`.
    pub g: f64,
}

impl DoublePendulum {
    /// All masses, lengths and `g` equal to 1.
    pub const fn unit() -> Self {
        DoublePendulum {
            m1: 1.0,
            m2: 1.0,
            l1: 1.0,
            l2: 1.0,
            g: 1.0,
        }
    }
}

/// The kinetic term's pieces at one point.
struct Kinetic {
    /// `1 / (K A)`.
    inv_ka: f64,
    /// `N`, `dN/dd`, `d2N/dd2`.
    n: [f64; 3],
    /// `A`, `dA/dd`, `d2A/dd2`.
    a: [f64; 3],
    /// `dN/dp1`, `dN/dp2` and their `d`-derivatives.
    n_p: [f64; 2],
    n_pd: [f64; 2],
    c: f64,
}

impl DoublePendulum {
    fn kinetic(&self, z: &Vector4<f64>) -> Kinetic {
        let DoublePendulum { m1, m2, l1, l2, .. } = *self;
        let (p1, p2) = (z[2], z[3]);
        let (s, c) = (z[0] - z[1]).sin_cos();
        let b = m2 * l1 * l2;
        let k = 2.0 * m2 * l1 * l1 * l2 * l2;
        let a = m1 + m2 * s * s;
        Kinetic {
            inv_ka: 1.0 / (k * a),
            n: [
                m2 * l2 * l2 * p1 * p1 + (m1 + m2) * l1 * l1 * p2 * p2 - 2.0 * b * p1 * p2 * c,
                2.0 * b * p1 * p2 * s,
                2.0 * b * p1 * p2 * c,
            ],
            a: [a, 2.0 * m2 * s * c, 2.0 * m2 * (c * c - s * s)],
            n_p: [
                2.0 * m2 * l2 * l2 * p1 - 2.0 * b * p2 * c,
                2.0 * (m1 + m2) * l1 * l1 * p2 - 2.0 * b * p1 * c,
            ],
            n_pd: [2.0 * b * p2 * s, 2.0 * b * p1 * s],
            c,
        }
    }
}

impl Hamiltonian<Const<4>> for DoublePendulum {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn value(&self, z: &Vector4<f64>) -> f64 {
        let kin = self.kinetic(z);
        kin.n[0] * kin.inv_ka
            - (self.m1 + self.m2) * self.g * self.l1 * z[0].cos()
            - self.m2 * self.g * self.l2 * z[1].cos()
    }

    fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = {
            let Kinetic {
                inv_ka, n, a, n_p, ..
            } = self.kinetic(z);
            // T_d = (N_d A - N A_d) / (K A^2).
            let t_d = (n[1] - n[0] * a[1] / a[0]) * inv_ka;
            Vector4::new(
                t_d + (self.m1 + self.m2) * self.g * self.l1 * z[0].sin(),
                -t_d + self.m2 * self.g * self.l2 * z[1].sin(),
                n_p[0] * inv_ka,
                n_p[1] * inv_ka,
            )
        };
    }

    fn hessian_into(&self, z: &Vector4<f64>, out: &mut Matrix4<f64>) {
        *out = {
            let Kinetic {
                inv_ka,
                n,
                a,
                n_p,
                n_pd,
                c,
            } = self.kinetic(z);
            let DoublePendulum { m1, m2, l1, l2, g } = *self;
            // T_dd = [(N_dd A - N A_dd) A - 2 A_d (N_d A - N A_d)] / (K A^3).
            let t_dd = ((n[2] * a[0] - n[0] * a[2]) - 2.0 * a[1] * (n[1] - n[0] * a[1] / a[0]))
                / a[0]
                * inv_ka;
            // T_{p_i d} = (P_i,d A - P_i A_d) / (K A^2).
            let t_pd = [
                (n_pd[0] - n_p[0] * a[1] / a[0]) * inv_ka,
                (n_pd[1] - n_p[1] * a[1] / a[0]) * inv_ka,
            ];
            let b = m2 * l1 * l2;
            let t_pp = [
                2.0 * m2 * l2 * l2 * inv_ka,
                -2.0 * b * c * inv_ka,
                2.0 * (m1 + m2) * l1 * l1 * inv_ka,
            ];
            let v11 = (m1 + m2) * g * l1 * z[0].cos();
            let v22 = m2 * g * l2 * z[1].cos();
            Matrix4::new(
                t_dd + v11,
                -t_dd,
                t_pd[0],
                t_pd[1],
                -t_dd,
                t_dd + v22,
                -t_pd[0],
                -t_pd[1],
                t_pd[0],
                -t_pd[0],
                t_pp[0],
                t_pp[1],
                t_pd[1],
                -t_pd[1],
                t_pp[1],
                t_pp[2],
            )
        };
    }
}
