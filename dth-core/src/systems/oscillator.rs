use crate::Flags;
use nalgebra::Const;
use nalgebra::{Matrix2, Vector2};

use crate::Hamiltonian;

/// The harmonic oscillator `H = p^2 / (2 m) + k q^2 / 2`, `z = (q, p)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HarmonicOscillator {
    /// Mass `m`.
    pub mass: f64,
    /// Spring constant `k`.
    pub k: f64,
}

impl Hamiltonian<Const<2>> for HarmonicOscillator {
    fn dim(&self) -> Const<2> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default()
            .with_separable(true)
            .with_exact_divided_differences(true)
    }

    fn value(&self, z: &Vector2<f64>) -> f64 {
        z[1] * z[1] / (2.0 * self.mass) + 0.5 * self.k * z[0] * z[0]
    }

    fn gradient_into(&self, z: &Vector2<f64>, out: &mut Vector2<f64>) {
        *out = Vector2::new(self.k * z[0], z[1] / self.mass);
    }

    fn hessian_into(&self, _z: &Vector2<f64>, out: &mut Matrix2<f64>) {
        *out = Matrix2::new(self.k, 0.0, 0.0, 1.0 / self.mass);
    }

    /// Quadratic `H`: the discrete gradient is the gradient at the midpoint, exactly.
    fn discrete_gradient_into(&self, z0: &Vector2<f64>, z1: &Vector2<f64>, out: &mut Vector2<f64>) {
        *out = self.gradient(&((z0 + z1) * 0.5));
    }

    /// Quadratic `H`: `g0 + g1 = 2 gbar` exactly.
    fn discrete_gradient_defect_into(
        &self,
        _z0: &Vector2<f64>,
        _z1: &Vector2<f64>,
        _gbar: &Vector2<f64>,
        out: &mut Vector2<f64>,
    ) {
        *out = Vector2::zeros();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psi_is_positive_and_matches_closed_form() {
        // Psi = k p^2/m^2 * ... : J grad H = (p/m, -k q); Psi = k (p/m)^2 + (k q)^2 / m.
        let h = HarmonicOscillator { mass: 2.0, k: 3.0 };
        let z = Vector2::new(0.5, -1.5);
        let expected = 3.0 * (-1.5f64 / 2.0).powi(2) + (3.0f64 * 0.5).powi(2) / 2.0;
        assert!((h.psi(&z) - expected).abs() <= 4.0 * f64::EPSILON * expected);
    }
}
