//! Work storage a method keeps between steps when its dimension is known only at run time.

use crate::hamiltonian::Alloc;
use nalgebra::{DVector, DefaultAllocator, Dim, OVector, U1};
use std::any::Any;

/// A method's work storage (its vectors, or a struct of its own) for a `Dyn` dimension, kept
/// between steps so that only the first step allocates; a fixed dimension's lives in the
/// step's own frame (no heap at all).
/// A cache, not part of the method's value: a clone starts empty and any two compare equal.
#[derive(Default)]
pub(crate) struct Kept(Option<Box<dyn Any + Send + Sync>>);

impl Kept {
    /// Runs `step` on `K` vectors of dimension `d` (their values are whatever the last step
    /// left: `step` writes before it reads).
    pub(crate) fn vectors<D: Dim, const K: usize, R>(
        &mut self,
        d: D,
        step: impl FnOnce(&mut [OVector<f64, D>; K]) -> R,
    ) -> R
    where
        DefaultAllocator: Alloc<D>,
    {
        let n = d.value();
        self.with(
            d,
            || std::array::from_fn(|_| OVector::<f64, D>::zeros_generic(d, U1)),
            || {
                Box::new(std::array::from_fn::<DVector<f64>, K, _>(|_| {
                    DVector::zeros(n)
                }))
            },
            |v: &[OVector<f64, D>; K]| v.iter().all(|v| v.len() == n),
            step,
        )
    }

    /// Runs `step` on a method's work storage `T` for dimension `d` (its values are whatever
    /// the last step left). A fixed dimension's is made by `make` in this frame. A `Dyn`
    /// dimension's is kept between steps and made again only when the kept one does not `fit`
    /// (another dimension), by `boxed`: `make`'s storage at `Dyn`, boxed (`T` is then that
    /// type; only a concrete `Dyn` type is known to be `Send + Sync`, hence the two makers).
    pub(crate) fn with<D: Dim, T: Any, R>(
        &mut self,
        _d: D,
        make: impl FnOnce() -> T,
        boxed: impl FnOnce() -> Box<dyn Any + Send + Sync>,
        fits: impl Fn(&T) -> bool,
        step: impl FnOnce(&mut T) -> R,
    ) -> R {
        if D::try_to_usize().is_some() {
            return step(&mut make());
        }
        let kept_fits = self
            .0
            .as_deref()
            .and_then(|b| b.downcast_ref::<T>())
            .is_some_and(&fits);
        if !kept_fits {
            self.0 = Some(boxed());
        }
        match self.0.as_deref_mut().and_then(|b| b.downcast_mut::<T>()) {
            Some(kept) => step(kept),
            // `boxed` made another type than `T`: correct still, if not allocation-free.
            None => step(&mut make()),
        }
    }
}

impl Clone for Kept {
    /// Empty: the clone makes its own vectors on its first step.
    fn clone(&self) -> Self {
        Kept(None)
    }
}

impl PartialEq for Kept {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for Kept {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() { "Kept(..)" } else { "Kept" })
    }
}
