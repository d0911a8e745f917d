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

impl Hamiltonian<2> for Pendulum {
    const SEPARABLE: bool = true;

    fn value(&self, z: &Vector2<f64>) -> f64 {
        z[1] * z[1] / (2.0 * self.inertia()) - self.mgl() * z[0].cos()
    }

    fn gradient(&self, z: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(self.mgl() * z[0].sin(), z[1] / self.inertia())
    }

    fn hessian(&self, z: &Vector2<f64>) -> Matrix2<f64> {
        Matrix2::new(self.mgl() * z[0].cos(), 0.0, 0.0, 1.0 / self.inertia())
    }
}
