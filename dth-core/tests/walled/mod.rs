//! `Walled`, the fixture of the failure tests `dth_failures.rs` and `hard_failures.rs`: a
//! Hamiltonian that becomes undefined part-way along an orbit.

use dth_core::nalgebra::{Matrix2, Vector2};
use dth_core::Hamiltonian;

/// The harmonic oscillator `H = (q^2 + p^2) / 2`, undefined (NaN) for `q > 1`.
pub struct Walled;

impl Hamiltonian<2> for Walled {
    fn value(&self, z: &Vector2<f64>) -> f64 {
        if z[0] > 1.0 {
            f64::NAN
        } else {
            0.5 * (z[0] * z[0] + z[1] * z[1])
        }
    }
    fn gradient(&self, z: &Vector2<f64>) -> Vector2<f64> {
        if z[0] > 1.0 {
            Vector2::repeat(f64::NAN)
        } else {
            Vector2::new(z[0], z[1])
        }
    }
    fn hessian(&self, _z: &Vector2<f64>) -> Matrix2<f64> {
        Matrix2::identity()
    }
}
