use crate::Flags;
use nalgebra::Const;
use nalgebra::{Matrix4, Vector4};

use crate::Hamiltonian;

/// The Henon-Heiles system
/// `H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2 q2 - q2^3/3`, `z = (q1, q2, p1, p2)`.
///
/// Bounded motion for `H < 1/6`; chaotic orbits appear from about `H = 1/8`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HenonHeiles;

impl Hamiltonian<Const<4>> for HenonHeiles {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default().with_separable(true)
    }

    fn value(&self, z: &Vector4<f64>) -> f64 {
        let (q1, q2, p1, p2) = (z[0], z[1], z[2], z[3]);
        0.5 * (p1 * p1 + p2 * p2) + 0.5 * (q1 * q1 + q2 * q2) + q1 * q1 * q2 - q2 * q2 * q2 / 3.0
    }

    fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = {
            let (q1, q2) = (z[0], z[1]);
            Vector4::new(q1 + 2.0 * q1 * q2, q2 + q1 * q1 - q2 * q2, z[2], z[3])
        };
    }

    fn hessian_into(&self, z: &Vector4<f64>, out: &mut Matrix4<f64>) {
        *out = {
            let (q1, q2) = (z[0], z[1]);
            let mut m = Matrix4::identity();
            m[(0, 0)] = 1.0 + 2.0 * q2;
            m[(0, 1)] = 2.0 * q1;
            m[(1, 0)] = 2.0 * q1;
            m[(1, 1)] = 1.0 - 2.0 * q2;
            m
        };
    }
}
