//! The [`Hamiltonian`] trait: value, gradient, Hessian and Psi of `H(z)`.

use nalgebra::{SMatrix, SVector};

/// Value, gradient, Hessian and Psi of a Hamiltonian at one point, computed together.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Derivatives<const D: usize> {
    /// `H(z)`.
    pub value: f64,
    /// `grad H(z)`.
    pub gradient: SVector<f64, D>,
    /// `Hess H(z)` (symmetric).
    pub hessian: SMatrix<f64, D, D>,
    /// `Psi(z) = (J grad H)^T Hess H (J grad H)`.
    pub psi: f64,
}

/// A Hamiltonian `H(z)` on a phase space of dimension `D = 2n`, `z = (q1..qn, p1..pn)`.
///
/// `hamiltonian!` generates implementations with exact symbolic derivatives; hand-written
/// implementations must provide `value`, `gradient` and `hessian` and may rely on the defaults
/// for the rest.
///
/// A time-dependent Hamiltonian `H(t, q, p)` implements this trait on the extended phase space
/// of Shibberu (1998), Theorem 1: `z = (q1..qn, t, p1..pn, p_t)`, `D = 2n + 2`, and
/// `value` returns `calH = p_t + H(t, q, p)`; it sets [`Hamiltonian::TIME_DEPENDENT`].
pub trait Hamiltonian<const D: usize> {
    /// `true` when the implementation is the extended-phase-space `calH = p_t + H(t, q, p)`.
    const TIME_DEPENDENT: bool = false;
    /// `true` when `H = T(p) + V(q)` (the q-p block of the Hessian is identically zero).
    const SEPARABLE: bool = false;
    /// `true` when `Psi` is identically zero (e.g. `H` linear, a free particle): DTH is
    /// undetermined there (thesis Section 3.4), the peer methods are not.
    const PSI_IDENTICALLY_ZERO: bool = false;
    /// `true` when [`Hamiltonian::discrete_gradient`] and
    /// [`Hamiltonian::discrete_gradient_defect`] are computed from exact divided differences,
    /// without cancellation as `z1 -> z0` (each component to a few `eps` relative). The DTH
    /// stepper then solves its energy equation in a cancellation-free form by default
    /// (`dth::EnergyResidual::Auto`).
    const EXACT_DIVIDED_DIFFERENCES: bool = false;

    /// `H(z)`.
    fn value(&self, z: &SVector<f64, D>) -> f64;
    /// `grad H(z)`.
    fn gradient(&self, z: &SVector<f64, D>) -> SVector<f64, D>;
    /// `Hess H(z)`, symmetric.
    fn hessian(&self, z: &SVector<f64, D>) -> SMatrix<f64, D, D>;

    /// `Psi(z) = (J grad H)^T Hess H (J grad H)`.
    fn psi(&self, z: &SVector<f64, D>) -> f64 {
        psi_from(&self.gradient(z), &self.hessian(z))
    }

    /// Value, gradient, Hessian and Psi in one evaluation (generated code shares every
    /// common subexpression between them).
    fn derivatives(&self, z: &SVector<f64, D>) -> Derivatives<D> {
        let gradient = self.gradient(z);
        let hessian = self.hessian(z);
        Derivatives {
            value: self.value(z),
            gradient,
            hessian,
            psi: psi_from(&gradient, &hessian),
        }
    }

    /// A discrete gradient `gbar(z0, z1)`: `gbar . (z1 - z0) = H(z1) - H(z0)` and
    /// `gbar(z, z) = grad H(z)`.
    ///
    /// The default is Gonzalez's midpoint discrete gradient, which computes `H(z1) - H(z0)` as
    /// a plain difference (cancellation when `z1` is close to `z0`). Generated code may override
    /// it with exact divided differences.
    fn discrete_gradient(&self, z0: &SVector<f64, D>, z1: &SVector<f64, D>) -> SVector<f64, D> {
        let mid = (z0 + z1) * 0.5;
        let g = self.gradient(&mid);
        let d = z1 - z0;
        let dd = d.dot(&d);
        if dd == 0.0 {
            return g;
        }
        let defect = self.value(z1) - self.value(z0) - g.dot(&d);
        g + d * (defect / dd)
    }

    /// The trapezoid defect of the discrete gradient,
    /// `t(z0, z1) = grad H(z0) + grad H(z1) - 2 gbar(z0, z1)`, which is `O(|z1 - z0|^2)`.
    ///
    /// The DTH stepper's cancellation-free energy residual needs it to a few `eps` *relative*
    /// (an exact second divided difference). The default forms it from plain differences
    /// (absolute error `eps |grad H|`); implementations that set
    /// [`Hamiltonian::EXACT_DIVIDED_DIFFERENCES`] override it together with
    /// [`Hamiltonian::discrete_gradient`], consistently with it.
    fn discrete_gradient_defect(
        &self,
        z0: &SVector<f64, D>,
        z1: &SVector<f64, D>,
        gbar: &SVector<f64, D>,
    ) -> SVector<f64, D> {
        self.gradient(z0) + self.gradient(z1) - gbar * 2.0
    }
}

/// `J v` for `J = [[0, I], [-I, 0]]`: `(v_p, -v_q)`.
///
/// ```
/// use dth_core::{j_times, nalgebra::Vector4};
/// let v = Vector4::new(1.0, 2.0, 3.0, 4.0);
/// assert_eq!(j_times(&v), Vector4::new(3.0, 4.0, -1.0, -2.0));
/// ```
pub fn j_times<const D: usize>(v: &SVector<f64, D>) -> SVector<f64, D> {
    const { assert!(D.is_multiple_of(2), "phase space dimension D must be even") };
    let n = D / 2;
    SVector::<f64, D>::from_fn(|i, _| if i < n { v[i + n] } else { -v[i - n] })
}

/// `Psi = (J g)^T Hess (J g)` from a gradient and a Hessian.
pub fn psi_from<const D: usize>(gradient: &SVector<f64, D>, hessian: &SMatrix<f64, D, D>) -> f64 {
    let w = j_times(gradient);
    w.dot(&(hessian * w))
}
