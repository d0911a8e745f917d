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

impl Hamiltonian<4> for Kepler {
    const SEPARABLE: bool = true;

    fn value(&self, z: &Vector4<f64>) -> f64 {
        let r = z[0].hypot(z[1]);
        (z[2] * z[2] + z[3] * z[3]) / (2.0 * self.mass) - self.k / r
    }

    fn gradient(&self, z: &Vector4<f64>) -> Vector4<f64> {
        let r2 = z[0] * z[0] + z[1] * z[1];
        let kr3 = self.k / (r2 * r2.sqrt());
        Vector4::new(kr3 * z[0], kr3 * z[1], z[2] / self.mass, z[3] / self.mass)
    }

    fn hessian(&self, z: &Vector4<f64>) -> Matrix4<f64> {
        let r2 = z[0] * z[0] + z[1] * z[1];
        let kr3 = self.k / (r2 * r2.sqrt());
        let kr5 = 3.0 * kr3 / r2;
        let im = 1.0 / self.mass;
        let (x, y) = (z[0], z[1]);
        Matrix4::new(
            kr3 - kr5 * x * x,
            -kr5 * x * y,
            0.0,
            0.0,
            -kr5 * x * y,
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

impl crate::systems::CentralForce<4> for Kepler {
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
