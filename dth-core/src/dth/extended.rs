//! Extended phase space (paper Theorem 1): `z = (q1..qn, t, p1..pn, p_t)`, `calH = p_t + H`.

use std::marker::PhantomData;

use nalgebra::{DefaultAllocator, Dim, DimAdd, DimSum, OMatrix, OVector, U1, U2};

use crate::hamiltonian::Alloc;
use crate::methods::check_state;
use crate::{Error, Flags, Hamiltonian};

/// An autonomous `H: Hamiltonian<D>` lifted to the extended phase space
/// `z = (q1..qn, t, p1..pn, p_t)` of dimension `D + 2` (`DimSum<D, U2>`: `Const<N + 2>` for a
/// fixed `D`, `Dyn` for a dynamic one) with `calH(z) = p_t + H(q, p)`.
///
/// Run through [`Dth`](super::Dth), it gives the same trajectory as `H` itself (paper
/// Corollary 1); its use is to exercise and check the extended-phase-space path that
/// time-dependent Hamiltonians take.
///
/// ```
/// use dth_core::dth::{lift, set_momentum_of_time, Dth, DthOptions, Extended};
/// use dth_core::{nalgebra::{U4, Vector4}, systems::Kepler};
/// let ext: Extended<Kepler, U4> = Extended::new(Kepler::thesis());
/// let z = set_momentum_of_time(&ext, lift(&Vector4::new(0.5, 0.0, 0.0, 1.2), 0.0))?;
/// assert_eq!(z[5], 0.56); // p_t = -H
/// let mut dth = Dth::new(ext, z, DthOptions::thesis_kepler())?;
/// dth.advance(10)?;
/// # Ok::<(), dth_core::Error>(())
/// ```
///
/// # References
/// Shibberu (1998), Section 2.1 and Theorem 1 (eqs. 9-11); thesis eqs. 2.1.6, 2.2.2-2.2.5.
#[derive(Debug)]
pub struct Extended<H, D> {
    /// The autonomous Hamiltonian.
    pub inner: H,
    dim: PhantomData<D>,
}

impl<H: Clone, D> Clone for Extended<H, D> {
    fn clone(&self) -> Self {
        Extended::new(self.inner.clone())
    }
}

impl<H: Copy, D> Copy for Extended<H, D> {}

impl<H: PartialEq, D> PartialEq for Extended<H, D> {
    fn eq(&self, other: &Self) -> bool {
        self.inner == other.inner
    }
}

impl<H, D> Extended<H, D> {
    /// Lift `inner`.
    pub fn new(inner: H) -> Self {
        Extended {
            inner,
            dim: PhantomData,
        }
    }
}

impl<H, D: Dim> Extended<H, D>
where
    DefaultAllocator: Alloc<D>,
{
    /// Project an extended point `(q, t, p, p_t)` to `(q, p)` (of dimension `D`).
    pub fn reduce<E: Dim>(z: &OVector<f64, E>) -> OVector<f64, D>
    where
        DefaultAllocator: Alloc<E>,
    {
        let d = D::from_usize(z.len() - 2);
        let n = d.value() / 2;
        OVector::from_fn_generic(d, U1, |i, _| if i < n { z[i] } else { z[i + 1] })
    }
}

/// Extended point `(q, t, p, p_t = 0)` from `x = (q, p)` and `t`; use
/// [`set_momentum_of_time`] to make `calH` vanish.
pub fn lift<D: Dim + DimAdd<U2>>(x: &OVector<f64, D>, t: f64) -> OVector<f64, DimSum<D, U2>>
where
    DefaultAllocator: Alloc<D> + Alloc<DimSum<D, U2>>,
{
    let (d, _) = x.shape_generic();
    let n = d.value() / 2;
    OVector::from_fn_generic(d.add(U2), U1, |i, _| {
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
///
/// # Errors
/// [`Error::NotTimeDependent`] for an autonomous `H` (its last coordinate is `p_n`);
/// [`Error::WrongStateLength`] (`z`) for a `z` not of `H`'s dimension;
/// [`Error::NonFinite`] (step 0) when `H` is not finite at `z`.
pub fn set_momentum_of_time<H: Hamiltonian<E>, E: Dim>(
    hamiltonian: &H,
    mut z: OVector<f64, E>,
) -> Result<OVector<f64, E>, Error>
where
    DefaultAllocator: Alloc<E>,
{
    if !hamiltonian.flags().time_dependent {
        return Err(Error::NotTimeDependent);
    }
    check_state(hamiltonian, &z, "z")?;
    let last = z.len() - 1;
    z[last] = 0.0;
    let h = hamiltonian.value(&z);
    if !h.is_finite() {
        return Err(Error::NonFinite {
            step: 0,
            what: "H(t, q, p) at the point whose p_t is set",
        });
    }
    z[last] = -h;
    Ok(z)
}

impl<H: Hamiltonian<D>, D: Dim + DimAdd<U2>> Hamiltonian<DimSum<D, U2>> for Extended<H, D>
where
    DefaultAllocator: Alloc<D> + Alloc<DimSum<D, U2>>,
{
    fn dim(&self) -> DimSum<D, U2> {
        self.inner.dim().add(U2)
    }

    fn flags(&self) -> Flags {
        let inner = self.inner.flags();
        Flags::default()
            .with_time_dependent(true)
            .with_separable(inner.separable)
            .with_psi_identically_zero(inner.psi_identically_zero)
            .with_exact_divided_differences(inner.exact_divided_differences)
    }

    fn value(&self, z: &OVector<f64, DimSum<D, U2>>) -> f64 {
        z[z.len() - 1] + self.inner.value(&Self::reduce(z))
    }

    fn gradient_into(
        &self,
        z: &OVector<f64, DimSum<D, U2>>,
        out: &mut OVector<f64, DimSum<D, U2>>,
    ) {
        *out = lift(&self.inner.gradient(&Self::reduce(z)), 0.0);
        let last = out.len() - 1;
        out[last] = 1.0;
    }

    fn hessian_into(
        &self,
        z: &OVector<f64, DimSum<D, U2>>,
        out: &mut OMatrix<f64, DimSum<D, U2>, DimSum<D, U2>>,
    ) {
        let m = self.inner.hessian(&Self::reduce(z));
        let e = z.len();
        let n = (e - 2) / 2;
        // Index of extended coordinate i in (q, p), or None for t and p_t.
        let map = |i: usize| {
            if i < n {
                Some(i)
            } else if i == n || i == e - 1 {
                None
            } else {
                Some(i - 1)
            }
        };
        for j in 0..e {
            for i in 0..e {
                out[(i, j)] = match (map(i), map(j)) {
                    (Some(a), Some(b)) => m[(a, b)],
                    _ => 0.0,
                };
            }
        }
    }

    /// The inner discrete gradient, with `1` for `p_t` and `0` for `t` (`calH` is linear in
    /// `p_t` and does not depend on `t`).
    fn discrete_gradient_into(
        &self,
        z0: &OVector<f64, DimSum<D, U2>>,
        z1: &OVector<f64, DimSum<D, U2>>,
        out: &mut OVector<f64, DimSum<D, U2>>,
    ) {
        *out = lift(
            &self
                .inner
                .discrete_gradient(&Self::reduce(z0), &Self::reduce(z1)),
            0.0,
        );
        let last = out.len() - 1;
        out[last] = 1.0;
    }

    /// The inner defect, with `0` for `t` and `p_t`.
    fn discrete_gradient_defect_into(
        &self,
        z0: &OVector<f64, DimSum<D, U2>>,
        z1: &OVector<f64, DimSum<D, U2>>,
        gbar: &OVector<f64, DimSum<D, U2>>,
        out: &mut OVector<f64, DimSum<D, U2>>,
    ) {
        let t = self.inner.discrete_gradient_defect(
            &Self::reduce(z0),
            &Self::reduce(z1),
            &Self::reduce(gbar),
        );
        *out = lift(&t, 0.0);
    }
}
