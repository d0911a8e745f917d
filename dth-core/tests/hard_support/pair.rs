//! Two gravitating bodies written in absolute coordinates, as a cluster writes them: a close
//! pair far from the origin, whose positions are rounded relative to their size (about 1), not
//! to their separation. Hand-written, so with the trait's default (Gonzalez) discrete gradient.

use dth_core::nalgebra::{Const, SMatrix, SVector};
use dth_core::{Flags, Hamiltonian};

/// `z = (x1, y1, x2, y2, px1, py1, px2, py2)`.
pub type V8 = SVector<f64, 8>;

/// Two unit masses in the plane, `H = (|p1|^2 + |p2|^2)/2 - 1/|q1 - q2|` (`G = 1`).
#[derive(Clone, Copy, Debug)]
pub struct Pair;

impl Pair {
    /// The pair at pericentre of a relative orbit of semi-major axis `a` and eccentricity `e`,
    /// its centre of mass at `(1, 0.5)` drifting at `(0.3, 0)`.
    pub fn at_pericentre(a: f64, e: f64) -> V8 {
        let r = a * (1.0 - e);
        // Vis-viva for the relative orbit, total mass 2.
        let v = (2.0 * (2.0 / r - 1.0 / a)).sqrt();
        V8::from_column_slice(&[
            1.0 + 0.5 * r,
            0.5,
            1.0 - 0.5 * r,
            0.5,
            0.3,
            0.5 * v,
            0.3,
            -0.5 * v,
        ])
    }

    /// The kinetic energy `T`.
    pub fn kinetic(z: &V8) -> f64 {
        0.5 * (4..8).map(|i| z[i] * z[i]).sum::<f64>()
    }
}

impl Hamiltonian<Const<8>> for Pair {
    fn dim(&self) -> Const<8> {
        Const
    }
    fn flags(&self) -> Flags {
        Flags::default().with_separable(true)
    }
    fn value(&self, z: &V8) -> f64 {
        let (dx, dy) = (z[0] - z[2], z[1] - z[3]);
        Self::kinetic(z) - 1.0 / dx.hypot(dy)
    }
    fn gradient_into(&self, z: &V8, out: &mut V8) {
        let (dx, dy) = (z[0] - z[2], z[1] - z[3]);
        let r3 = dx.hypot(dy).powi(3);
        let (fx, fy) = (dx / r3, dy / r3);
        out.copy_from_slice(&[fx, fy, -fx, -fy, z[4], z[5], z[6], z[7]]);
    }
    fn hessian_into(&self, z: &V8, out: &mut SMatrix<f64, 8, 8>) {
        let (dx, dy) = (z[0] - z[2], z[1] - z[3]);
        let r = dx.hypot(dy);
        let (r3, r5) = (r.powi(3), r.powi(5));
        let k = [
            [1.0 / r3 - 3.0 * dx * dx / r5, -3.0 * dx * dy / r5],
            [-3.0 * dx * dy / r5, 1.0 / r3 - 3.0 * dy * dy / r5],
        ];
        out.fill(0.0);
        for a in 0..2 {
            for b in 0..2 {
                out[(a, b)] = k[a][b];
                out[(a + 2, b + 2)] = k[a][b];
                out[(a, b + 2)] = -k[a][b];
                out[(a + 2, b)] = -k[a][b];
            }
        }
        for i in 4..8 {
            out[(i, i)] = 1.0;
        }
    }
}
