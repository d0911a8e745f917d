use crate::Flags;
use nalgebra::Const;
use nalgebra::{Matrix2, Vector2};

use crate::Hamiltonian;

/// The plane pendulum `H = p^2 / (2 m l^2) - m g l cos q`, `z = (q, p)` (angle from the
/// downward vertical, angular momentum).
///
/// Librations for `H < m g l`, rotations for `H > m g l`, separatrix at `H = m g l`.
/// [`Pendulum::normalized`] is `m = l = g = 1`: `H = p^2/2 - cos q`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pendulum {
    /// Mass `m`.
    pub mass: f64,
    /// Length `l`.
    pub length: f64,
    /// Gravitational acceleration `g`.
    pub gravity: f64,
}

impl Pendulum {
    /// `m = l = g = 1`: `H = p^2 / 2 - cos q`.
    pub const fn normalized() -> Self {
        Pendulum {
            mass: 1.0,
            length: 1.0,
            gravity: 1.0,
        }
    }

    fn inertia(&self) -> f64 {
        self.mass * self.length * self.length
    }

    fn mgl(&self) -> f64 {
        self.mass * self.gravity * self.length
    }
}

impl Hamiltonian<Const<2>> for Pendulum {
    fn dim(&self) -> Const<2> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default()
            .with_separable(true)
            .with_exact_divided_differences(true)
    }

    fn value(&self, z: &Vector2<f64>) -> f64 {
        z[1] * z[1] / (2.0 * self.inertia()) - self.mgl() * z[0].cos()
    }

    fn gradient_into(&self, z: &Vector2<f64>, out: &mut Vector2<f64>) {
        *out = Vector2::new(self.mgl() * z[0].sin(), z[1] / self.inertia());
    }

    fn hessian_into(&self, z: &Vector2<f64>, out: &mut Matrix2<f64>) {
        *out = Matrix2::new(self.mgl() * z[0].cos(), 0.0, 0.0, 1.0 / self.inertia());
    }

    /// Exact divided differences without cancellation, `qm = (q0 + q1)/2`, `dq = q1 - q0`:
    /// `gbar_q = m g l (cos q0 - cos q1) / dq = m g l sin(qm) sinc(dq/2)`,
    /// `gbar_p = (p0 + p1) / (2 m l^2)`.
    fn discrete_gradient_into(&self, z0: &Vector2<f64>, z1: &Vector2<f64>, out: &mut Vector2<f64>) {
        *out = {
            let qm = 0.5 * (z0[0] + z1[0]);
            let x = 0.5 * (z1[0] - z0[0]);
            Vector2::new(
                self.mgl() * qm.sin() * sinc(x),
                (z0[1] + z1[1]) / (2.0 * self.inertia()),
            )
        };
    }

    /// `t_q = m g l (sin q0 + sin q1 - 2 sin(qm) sinc(dq/2)) = 2 m g l sin(qm) (cos x - sinc x)`
    /// with `x = dq/2` (series for small `x`), `t_p = 0`.
    fn discrete_gradient_defect_into(
        &self,
        z0: &Vector2<f64>,
        z1: &Vector2<f64>,
        _gbar: &Vector2<f64>,
        out: &mut Vector2<f64>,
    ) {
        *out = {
            let qm = 0.5 * (z0[0] + z1[0]);
            let x = 0.5 * (z1[0] - z0[0]);
            Vector2::new(2.0 * self.mgl() * qm.sin() * cos_minus_sinc(x), 0.0)
        };
    }
}

/// `sin x / x` (1 at 0).
fn sinc(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.sin() / x
    }
}

/// `cos x - sin x / x = -x^2/3 + x^4/30 - x^6/840 + x^8/45360 - ...`, without cancellation:
/// the series below |x| = 1/4 (next term x^10/3991680 < 3e-13 of the first there, and the
/// series is summed to that term), the closed form above (cancellation of at most a factor 50).
fn cos_minus_sinc(x: f64) -> f64 {
    if x.abs() < 0.25 {
        let x2 = x * x;
        x2 * (-1.0 / 3.0
            + x2 * (1.0 / 30.0 + x2 * (-1.0 / 840.0 + x2 * (1.0 / 45360.0 - x2 / 3991680.0))))
    } else {
        x.cos() - x.sin() / x
    }
}

#[cfg(test)]
mod divided_difference_tests {
    use super::*;

    #[test]
    fn exact_divided_differences_match_plain_ones_and_scale_as_dq_squared() {
        let p = Pendulum {
            mass: 1.3,
            length: 0.7,
            gravity: 9.8,
        };
        let z0 = Vector2::new(0.4, -1.1);
        // Against plain differences where those are accurate (dq = 0.3, both branches of
        // cos_minus_sinc around |x| = 1/4).
        for dq in [0.3, 0.6] {
            let z1 = z0 + Vector2::new(dq, 0.5);
            let gbar = p.discrete_gradient(&z0, &z1);
            let dh = p.value(&z1) - p.value(&z0);
            assert!((gbar.dot(&(z1 - z0)) - dh).abs() <= 16.0 * f64::EPSILON * 10.0);
            let t = p.discrete_gradient_defect(&z0, &z1, &gbar);
            let plain = p.gradient(&z0) + p.gradient(&z1) - gbar * 2.0;
            assert!(
                (t - plain).amax() <= 64.0 * f64::EPSILON * 10.0,
                "{t:?} {plain:?}"
            );
        }
        // Relative accuracy at tiny dq: t / dq^2 is independent of dq to O(dq).
        let t_at = |s: f64| {
            let z1 = z0 + Vector2::new(s, 0.5 * s);
            let gbar = p.discrete_gradient(&z0, &z1);
            p.discrete_gradient_defect(&z0, &z1, &gbar)[0] / (s * s)
        };
        let (a, b) = (t_at(1e-7), t_at(2e-7));
        assert!((a - b).abs() <= 1e-5 * a.abs(), "{a} {b}");
        assert!(a.abs() > 1e-3);
    }
}
