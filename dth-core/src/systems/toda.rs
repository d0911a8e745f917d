use crate::hamiltonian::Alloc;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

use crate::{Flags, Hamiltonian};

/// Boundary condition of a [`TodaChain`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TodaBoundary {
    /// Bonds `(i, i+1)` for `i = 1..N` with `q_{N+1} = q_1`: `N` bonds, total momentum conserved.
    Periodic,
    /// Walls `q_0 = q_{N+1} = 0`: bonds `(0, 1), (1, 2), ..., (N, N+1)`, `N + 1` bonds.
    FixedEnds,
}

/// The Toda lattice of `N` unit masses, `z = (q_1..q_N, p_1..p_N)`, `D = 2N`:
/// `H = sum_i p_i^2 / 2 + sum_bonds exp(q_i - q_{i+1})`.
///
/// Implemented as `Hamiltonian<D>` for every `D`, with a compile-time check `D == 2N`, so the
/// dimension follows from the state: `TodaChain::<10>` integrates `SVector<f64, 20>`.
///
/// ```
/// use dth_core::systems::{TodaBoundary, TodaChain};
/// use dth_core::{nalgebra::SVector, Hamiltonian};
/// let toda = TodaChain::<10>::new(TodaBoundary::Periodic);
/// let z = SVector::<f64, 20>::zeros();
/// assert_eq!(toda.value(&z), 10.0); // ten bonds at rest length
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TodaChain<const N: usize> {
    /// The boundary condition.
    pub boundary: TodaBoundary,
}

impl<const N: usize> TodaChain<N> {
    /// A chain with the given boundary condition.
    pub const fn new(boundary: TodaBoundary) -> Self {
        TodaChain { boundary }
    }

    /// Calls `bond(i, j, e)` for every bond, `e = exp(q_i - q_j)`, with `None` for a wall.
    fn for_each_bond<D: Dim>(
        &self,
        z: &OVector<f64, D>,
        mut bond: impl FnMut(Option<usize>, Option<usize>, f64),
    ) where
        DefaultAllocator: Alloc<D>,
    {
        match self.boundary {
            TodaBoundary::Periodic => {
                for i in 0..N {
                    let j = (i + 1) % N;
                    bond(Some(i), Some(j), (z[i] - z[j]).exp());
                }
            }
            TodaBoundary::FixedEnds => {
                if N == 0 {
                    return;
                }
                bond(None, Some(0), (-z[0]).exp());
                for i in 0..N - 1 {
                    bond(Some(i), Some(i + 1), (z[i] - z[i + 1]).exp());
                }
                bond(Some(N - 1), None, z[N - 1].exp());
            }
        }
    }
}

impl<const N: usize, D: Dim> Hamiltonian<D> for TodaChain<N>
where
    DefaultAllocator: Alloc<D>,
{
    /// `2N`: `D` must be `Const<2N>` or `Dyn` (another `Const` panics here, when a stepper is
    /// built: a type error the compiler cannot see).
    fn dim(&self) -> D {
        D::from_usize(2 * N)
    }

    fn flags(&self) -> Flags {
        Flags::default().with_separable(true)
    }
    fn value(&self, z: &OVector<f64, D>) -> f64 {
        let mut v = 0.0;
        self.for_each_bond(z, |_, _, e| v += e);
        0.5 * z.rows(N, N).norm_squared() + v
    }

    fn gradient_into(&self, z: &OVector<f64, D>, g: &mut OVector<f64, D>) {
        g.fill(0.0);
        self.for_each_bond(z, |i, j, e| {
            if let Some(i) = i {
                g[i] += e;
            }
            if let Some(j) = j {
                g[j] -= e;
            }
        });
        for i in N..2 * N {
            g[i] = z[i];
        }
    }

    fn hessian_into(&self, z: &OVector<f64, D>, m: &mut OMatrix<f64, D, D>) {
        m.fill(0.0);
        self.for_each_bond(z, |i, j, e| {
            if let Some(i) = i {
                m[(i, i)] += e;
            }
            if let Some(j) = j {
                m[(j, j)] += e;
            }
            if let (Some(i), Some(j)) = (i, j) {
                m[(i, j)] -= e;
                m[(j, i)] -= e;
            }
        });
        for i in N..2 * N {
            m[(i, i)] = 1.0;
        }
    }
}
