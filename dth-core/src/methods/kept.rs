//! Vectors a method keeps between steps when its dimension is known only at run time.

use crate::hamiltonian::Alloc;
use nalgebra::{DVector, DefaultAllocator, Dim, OVector, U1};
use std::any::Any;

/// A method's `K` work vectors for a `Dyn` dimension, kept between steps so that only the
/// first step allocates; a fixed dimension's live in the step's own frame (no heap at all).
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
        let fresh = || std::array::from_fn(|_| OVector::<f64, D>::zeros_generic(d, U1));
        if D::try_to_usize().is_some() {
            return step(&mut fresh());
        }
        let n = d.value();
        let fits = |b: &Box<dyn Any + Send + Sync>| {
            b.downcast_ref::<[DVector<f64>; K]>()
                .is_some_and(|v| v.iter().all(|v| v.len() == n))
        };
        if !self.0.as_ref().is_some_and(fits) {
            let kept: [DVector<f64>; K] = std::array::from_fn(|_| DVector::zeros(n));
            self.0 = Some(Box::new(kept));
        }
        // `D` is `Dyn` here, so the kept `[DVector<f64>; K]` is a `[OVector<f64, D>; K]`.
        match self
            .0
            .as_deref_mut()
            .and_then(|b| b.downcast_mut::<[OVector<f64, D>; K]>())
        {
            Some(kept) => step(kept),
            None => step(&mut fresh()),
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
