//! Extended phase space (paper Theorem 1): `z = (q1..qn, t, p1..pn, p_t)`, `calH = p_t + H`.

use nalgebra::{SMatrix, SVector};

use crate::Hamiltonian;

/// An autonomous `H: Hamiltonian<D>` lifted to the extended phase space
/// `z = (q1..qn, t, p1..pn, p_t)` of dimension `E = D + 2` with `calH(z) = p_t + H(q, p)`.
///
/// Run through [`Dth`](super::Dth), it gives the same trajectory as `H` itself (paper
/// Corollary 1); its use is to exercise and check the extended-phase-space path that
/// time-dependent Hamiltonians take.
///
/// ```
/// use dth_core::dth::{lift, set_momentum_of_time, Dth, DthOptions, Extended};
/// use dth_core::{nalgebra::Vector4, systems::Kepler};
/// let ext: Extended<Kepler, 4, 6> = Extended::new(Kepler::thesis());
/// let z = set_momentum_of_time(&ext, lift(&Vector4::new(0.5, 0.0, 0.0, 1.2), 0.0));
/// assert_eq!(z[5], 0.56); // p_t = -H
/// let mut dth = Dth::new(ext, z, DthOptions::default())?;
/// dth.advance(10)?;
/// # Ok::<(), dth_core::Error>(())
/// ```
///
/// # References
/// Shibberu (1998), Section 2.1 and Theorem 1 (eqs. 9-11); thesis eqs. 2.1.6, 2.2.2-2.2.5.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extended<H, const D: usize, const E: usize> {
    /// The autonomous Hamiltonian.
    pub inner: H,
}

impl<H: Hamiltonian<D>, const D: usize, const E: usize> Extended<H, D, E> {
    /// Lift `inner`; `E` must equal `D + 2` (checked at compile time).
    pub fn new(inner: H) -> Self {
        const {
            assert!(
                E == D + 2,
                "extended dimension E must be D + 2 (adds t and p_t)"
            )
        };
        Extended { inner }
    }

    /// Project an extended point to `(q, p)`.
    pub fn reduce(z: &SVector<f64, E>) -> SVector<f64, D> {
        let n = D / 2;
        SVector::<f64, D>::from_fn(|i, _| if i < n { z[i] } else { z[i + 1] })
    }
}

/// Extended point `(q, t, p, p_t = 0)` from `x = (q, p)` and `t`; use
/// [`set_momentum_of_time`] to make `calH` vanish.
pub fn lift<const D: usize, const E: usize>(x: &SVector<f64, D>, t: f64) -> SVector<f64, E> {
    const {
        assert!(
            E == D + 2,
            "extended dimension E must be D + 2 (adds t and p_t)"
        )
    };
    let n = D / 2;
    SVector::<f64, E>::from_fn(|i, _| {
        if i < n {
            x[i]
        } else if i == n {
            t
        } else if i < 2 * n + 1 {
            x[i - 1]
        } else {
            0.0
        }
    })
}

/// Set the momentum of time `p_t = z[E - 1]` so that `calH(z) = p_t + H(t, q, p) = 0`
/// (Theorem 1 requires it at `zbar_0`). For any extended-phase-space Hamiltonian, generated
/// or [`Extended`].
pub fn set_momentum_of_time<H: Hamiltonian<E>, const E: usize>(
    hamiltonian: &H,
    mut z: SVector<f64, E>,
) -> SVector<f64, E> {
    z[E - 1] = 0.0;
    z[E - 1] = -hamiltonian.value(&z);
    z
}

impl<H: Hamiltonian<D>, const D: usize, const E: usize> Hamiltonian<E> for Extended<H, D, E> {
    const TIME_DEPENDENT: bool = true;
    const SEPARABLE: bool = H::SEPARABLE;
    const PSI_IDENTICALLY_ZERO: bool = H::PSI_IDENTICALLY_ZERO;
    const EXACT_DIVIDED_DIFFERENCES: bool = H::EXACT_DIVIDED_DIFFERENCES;

    fn value(&self, z: &SVector<f64, E>) -> f64 {
        z[E - 1] + self.inner.value(&Self::reduce(z))
    }

    fn gradient(&self, z: &SVector<f64, E>) -> SVector<f64, E> {
        let mut g = lift::<D, E>(&self.inner.gradient(&Self::reduce(z)), 0.0);
        g[E - 1] = 1.0;
        g
    }

    fn hessian(&self, z: &SVector<f64, E>) -> SMatrix<f64, E, E> {
        let m = self.inner.hessian(&Self::reduce(z));
        let n = D / 2;
        // Index of extended coordinate i in (q, p), or None for t and p_t.
        let map = |i: usize| {
            if i < n {
                Some(i)
            } else if i == n || i == E - 1 {
                None
            } else {
                Some(i - 1)
            }
        };
        SMatrix::<f64, E, E>::from_fn(|i, j| match (map(i), map(j)) {
            (Some(a), Some(b)) => m[(a, b)],
            _ => 0.0,
        })
    }

    /// The inner discrete gradient, with `1` for `p_t` and `0` for `t` (`calH` is linear in
    /// `p_t` and does not depend on `t`).
    fn discrete_gradient(&self, z0: &SVector<f64, E>, z1: &SVector<f64, E>) -> SVector<f64, E> {
        let mut g = lift::<D, E>(
            &self
                .inner
                .discrete_gradient(&Self::reduce(z0), &Self::reduce(z1)),
            0.0,
        );
        g[E - 1] = 1.0;
        g
    }

    /// The inner defect, with `0` for `t` and `p_t`.
    fn discrete_gradient_defect(
        &self,
        z0: &SVector<f64, E>,
        z1: &SVector<f64, E>,
        gbar: &SVector<f64, E>,
    ) -> SVector<f64, E> {
        let t = self.inner.discrete_gradient_defect(
            &Self::reduce(z0),
            &Self::reduce(z1),
            &Self::reduce(gbar),
        );
        lift::<D, E>(&t, 0.0)
    }
}
