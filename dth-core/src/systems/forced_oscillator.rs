use crate::Flags;
use nalgebra::Const;
use nalgebra::{Matrix4, Vector4};

use crate::Hamiltonian;

/// The periodically forced oscillator `H(t, q, p) = p^2/2 + omega0^2 q^2/2 - F q cos(omega t)`,
/// a time-dependent Hamiltonian on the extended phase space `z = (q, t, p, p_t)`:
/// `calH = p_t + H(t, q, p)` (paper Theorem 1).
///
/// Separable in the extended space (`T = p_t + p^2/2`, `V = V(q, t)`). The exact solution for
/// `omega != omega0` is [`ForcedOscillator::exact`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForcedOscillator {
    /// Natural frequency `omega0`.
    pub omega0: f64,
    /// Forcing amplitude `F`.
    pub force: f64,
    /// Forcing frequency `omega`.
    pub omega: f64,
}

impl ForcedOscillator {
    /// The extended state at `t0` with `p_t` chosen so that `calH = 0`.
    pub fn initial_state(&self, q: f64, p: f64, t0: f64) -> Vector4<f64> {
        let h = 0.5 * p * p + 0.5 * self.omega0 * self.omega0 * q * q
            - self.force * q * (self.omega * t0).cos();
        Vector4::new(q, t0, p, -h)
    }

    /// `(q(t), p(t))` from `(q0, p0)` at time 0, for `omega != omega0`:
    /// `q = A cos(omega0 t) + B sin(omega0 t) + C cos(omega t)`, `C = F / (omega0^2 - omega^2)`.
    pub fn exact(&self, q0: f64, p0: f64, t: f64) -> (f64, f64) {
        let (w0, w) = (self.omega0, self.omega);
        let c = self.force / (w0 * w0 - w * w);
        let a = q0 - c;
        let b = p0 / w0;
        let (s0, c0) = (w0 * t).sin_cos();
        let (s1, c1) = (w * t).sin_cos();
        (
            a * c0 + b * s0 + c * c1,
            -a * w0 * s0 + b * w0 * c0 - c * w * s1,
        )
    }
}

impl Hamiltonian<Const<4>> for ForcedOscillator {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default()
            .with_time_dependent(true)
            .with_separable(true)
    }

    fn value(&self, z: &Vector4<f64>) -> f64 {
        let (q, t, p, pt) = (z[0], z[1], z[2], z[3]);
        pt + 0.5 * p * p + 0.5 * self.omega0 * self.omega0 * q * q
            - self.force * q * (self.omega * t).cos()
    }

    fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = {
            let (q, t, p) = (z[0], z[1], z[2]);
            let (s, c) = (self.omega * t).sin_cos();
            Vector4::new(
                self.omega0 * self.omega0 * q - self.force * c,
                self.force * self.omega * q * s,
                p,
                1.0,
            )
        };
    }

    fn hessian_into(&self, z: &Vector4<f64>, out: &mut Matrix4<f64>) {
        *out = {
            let (q, t) = (z[0], z[1]);
            let (s, c) = (self.omega * t).sin_cos();
            let qt = self.force * self.omega * s;
            let tt = self.force * self.omega * self.omega * q * c;
            Matrix4::new(
                self.omega0 * self.omega0,
                qt,
                0.0,
                0.0,
                qt,
                tt,
                0.0,
                0.0,
                0.0,
                0.0,
                1.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            )
        };
    }
}
