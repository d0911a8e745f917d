use crate::hamiltonian::Alloc;
use crate::Hamiltonian;
use nalgebra::{DefaultAllocator, Dim};

/// `eps^(1/3)`, the relative radius change below which the divided difference of `phi` is
/// replaced by `phi'` (see [`CentralForce::phi_divided_difference`]).
pub const DIVIDED_DIFFERENCE_SWITCH: f64 = 6.055_454_452_393_343e-6;

/// A central-force Hamiltonian `H = |p|^2 / (2 m) + phi(|q|)`, `z = (q, p)`, `q` in `R^(D/2)`:
/// the description Greenspan's discrete mechanics
/// ([`DiscreteMechanics`](crate::methods::DiscreteMechanics)) needs.
///
/// The [`Hamiltonian`] implementation must be this `H` (same `m` and `phi`).
pub trait CentralForce<D: Dim>: Hamiltonian<D>
where
    DefaultAllocator: Alloc<D>,
{
    /// The mass `m`.
    fn mass(&self) -> f64;
    /// The potential `phi(r)`.
    fn phi(&self, r: f64) -> f64;
    /// Its derivative `phi'(r)`.
    fn dphi(&self, r: f64) -> f64;

    /// The divided difference `(phi(r1) - phi(r0)) / (r1 - r0)`, guarded as `r1 -> r0`.
    ///
    /// Implementations with an exact cancellation-free form (Kepler: `k / (r0 r1)`) may
    /// override it; the default is [`guarded_divided_difference`].
    fn phi_divided_difference(&self, r0: f64, r1: f64) -> f64 {
        guarded_divided_difference(|r| self.phi(r), |r| self.dphi(r), r0, r1)
    }
}

/// `(phi(r1) - phi(r0)) / (r1 - r0)`, or `phi'((r0 + r1)/2)` when
/// `|r1 - r0| <= eps^(1/3) max(r0, r1)`.
///
/// Why that switch: the numerator is a difference of two values each rounded to about
/// `eps |phi|`, so the quotient carries an absolute error of about `eps |phi| / |r1 - r0|`,
/// relative to the force scale `|phi| / r` that is `eps / x` with `x = |r1 - r0| / r`: it
/// grows without bound as the radii approach (cancellation). The fallback `phi'(rbar)` has no
/// cancellation but a truncation error `phi''' (r1 - r0)^2 / 24`, relative `O(x^2)`. The two
/// balance at `x = eps^(1/3)` (about `6e-6`), where both are about `eps^(2/3)` (`4e-11`)
/// relative. For energy conservation, the quotient is exact by construction
/// (`G (r1 - r0) = phi(r1) - phi(r0)` to roundoff) and the fallback's defect
/// `|phi'''| |r1 - r0|^3 / 24 <= eps r^3 |phi'''| / 24` is itself at roundoff. A test on
/// `|r1 - r0|` alone with an absolute threshold would be wrong for radii far from 1.
///
/// The switch is also the widest at which the fallback still conserves energy to roundoff, so
/// it is not widened for potentials whose values are large compared with their variation
/// (`|phi| >> |phi'| r`, e.g. a large constant offset): there the quotient's noise
/// `eps |phi| / |r1 - r0|` is larger, but trading it for an energy defect would defeat the
/// method. Subtract such constants from `phi`.
pub fn guarded_divided_difference(
    phi: impl Fn(f64) -> f64,
    dphi: impl Fn(f64) -> f64,
    r0: f64,
    r1: f64,
) -> f64 {
    let dr = r1 - r0;
    if dr.abs() <= DIVIDED_DIFFERENCE_SWITCH * r0.abs().max(r1.abs()) {
        dphi(0.5 * (r0 + r1))
    } else {
        (phi(r1) - phi(r0)) / dr
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn switch_is_the_cube_root_of_eps() {
        // Within 2 ulps of the libm cube root.
        let cbrt = f64::EPSILON.cbrt();
        assert!((DIVIDED_DIFFERENCE_SWITCH - cbrt).abs() <= 4.0 * f64::EPSILON * cbrt);
    }

    #[test]
    fn guard_is_accurate_on_both_sides_of_the_switch() {
        // phi = -1/r: exact divided difference 1/(r0 r1). Check relative accuracy for radius
        // gaps from 1e-15 to 1e-1 around r = 0.7: the error stays below the balanced bound
        // eps^(2/3) (4e-11) times a small safety factor for phi's own rounding.
        let phi = |r: f64| -1.0 / r;
        let dphi = |r: f64| 1.0 / (r * r);
        let r0 = 0.7;
        let mut gap = 1e-15;
        while gap < 0.1 {
            let r1 = r0 + gap;
            let exact = 1.0 / (r0 * r1);
            let g = guarded_divided_difference(phi, dphi, r0, r1);
            let rel = ((g - exact) / exact).abs();
            assert!(rel < 4.0 * f64::EPSILON.powf(2.0 / 3.0), "gap {gap}: {rel}");
            gap *= 1.7;
        }
        // Equal radii: phi'(r), no 0/0.
        assert_eq!(guarded_divided_difference(phi, dphi, r0, r0), dphi(r0));
    }
}
