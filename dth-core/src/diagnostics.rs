//! Invariant diagnostics: deviation series and the thesis's average absolute deviation.
//!
//! Both are [`Observer`]s of any run (the peers' [`methods::run`](crate::methods::run), the DTH
//! stepper: they see its midpoints) and can be fed by hand (`push`) from any other loop, e.g.
//! over DTH vertices.
//!
//! ```
//! use dth_core::diagnostics::{planar_angular_momentum, AverageAbsoluteDeviation};
//! use dth_core::methods::{run, Trapezoidal};
//! use dth_core::systems::Kepler;
//! use dth_core::{nalgebra::Vector4, Hamiltonian};
//!
//! let h = Kepler::thesis();
//! let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
//! let mut energy = AverageAbsoluteDeviation::new(|z: &Vector4<f64>| h.value(z));
//! run(&mut Trapezoidal::new(), &h, &z0, 0.0, 0.15, 100, &mut energy)?;
//! assert_eq!(energy.count(), 100); // k = 1..N; the k = 0 state is the reference
//! assert!(energy.mean().unwrap() > 1e-3);
//! let mut l = AverageAbsoluteDeviation::with_reference(planar_angular_momentum, 0.6);
//! l.push(&z0);
//! assert_eq!(l.mean(), Some(0.0));
//! # Ok::<(), dth_core::methods::RunError<dth_core::methods::RunEnd<dth_core::nalgebra::U4>>>(())
//! ```

use crate::hamiltonian::Alloc;
use crate::linalg::two_sum;
use nalgebra::Vector4;
use nalgebra::{DefaultAllocator, Dim, OVector};

use crate::observer::{Observer, StepRecord};

/// Angular momentum `L = q1 p2 - q2 p1` of a planar state `z = (q1, q2, p1, p2)`.
pub fn planar_angular_momentum(z: &Vector4<f64>) -> f64 {
    z[0] * z[3] - z[1] * z[2]
}

/// A compensated sum (Neumaier's, through [`two_sum`]): the mean of 10^4 deviations of size 1e-16 keeps its digits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct CompensatedSum {
    sum: f64,
    compensation: f64,
}

impl CompensatedSum {
    fn add(&mut self, x: f64) {
        let (sum, error) = two_sum(self.sum, x);
        self.compensation += error;
        self.sum = sum;
    }

    fn value(&self) -> f64 {
        self.sum + self.compensation
    }
}

/// The thesis's "average absolute deviation" of a quantity `Q` (Table 4.1):
/// `(1/N) sum_{k=1..N} |Q(z_k) - Q_ref|`.
///
/// `Q_ref` is either given ([`with_reference`](Self::with_reference); the DTH vertex rows use
/// the first vertex) or taken from the first state pushed, which then does not count
/// ([`new`](Self::new); as an observer of a run that is the initial state `k = 0`).
#[derive(Clone, Debug)]
pub struct AverageAbsoluteDeviation<Q> {
    quantity: Q,
    reference: Option<f64>,
    sum: CompensatedSum,
    count: usize,
}

impl<Q> AverageAbsoluteDeviation<Q> {
    /// Reference taken from the first state pushed.
    pub fn new(quantity: Q) -> Self {
        AverageAbsoluteDeviation {
            quantity,
            reference: None,
            sum: CompensatedSum::default(),
            count: 0,
        }
    }

    /// With a given reference value; every state pushed counts.
    pub fn with_reference(quantity: Q, reference: f64) -> Self {
        AverageAbsoluteDeviation {
            reference: Some(reference),
            ..Self::new(quantity)
        }
    }

    /// The reference value, once known.
    pub fn reference(&self) -> Option<f64> {
        self.reference
    }

    /// Number of deviations accumulated.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The mean absolute deviation; `None` before the first deviation.
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum.value() / self.count as f64)
    }

    /// Adds one state.
    pub fn push<D: Dim>(&mut self, z: &OVector<f64, D>)
    where
        DefaultAllocator: Alloc<D>,
        Q: Fn(&OVector<f64, D>) -> f64,
    {
        let value = (self.quantity)(z);
        match self.reference {
            None => self.reference = Some(value),
            Some(reference) => {
                self.sum.add((value - reference).abs());
                self.count += 1;
            }
        }
    }
}

impl<D: Dim, Q: Fn(&OVector<f64, D>) -> f64> Observer<D> for AverageAbsoluteDeviation<Q>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, record: &StepRecord<D>) {
        self.push(&record.z);
    }
}

/// The series `(t_k, Q(z_k) - Q_ref)`, e.g. the energy deviation `H(z_k) - H(z_0)` for a plot.
/// `Q_ref` as in [`AverageAbsoluteDeviation`]; the reference state itself is recorded (with
/// deviation 0) when it is taken from the first state.
#[derive(Clone, Debug)]
pub struct DeviationSeries<Q> {
    quantity: Q,
    reference: Option<f64>,
    /// Times `t_k`.
    pub t: Vec<f64>,
    /// Deviations `Q(z_k) - Q_ref`.
    pub deviation: Vec<f64>,
}

impl<Q> DeviationSeries<Q> {
    /// Reference taken from the first state pushed.
    pub fn new(quantity: Q) -> Self {
        DeviationSeries {
            quantity,
            reference: None,
            t: Vec::new(),
            deviation: Vec::new(),
        }
    }

    /// With a given reference value.
    pub fn with_reference(quantity: Q, reference: f64) -> Self {
        DeviationSeries {
            reference: Some(reference),
            ..Self::new(quantity)
        }
    }

    /// Largest absolute deviation so far (0 when empty).
    pub fn max_abs(&self) -> f64 {
        self.deviation.iter().fold(0.0, |m, d| m.max(d.abs()))
    }

    /// Adds one state at time `t`.
    pub fn push<D: Dim>(&mut self, t: f64, z: &OVector<f64, D>)
    where
        DefaultAllocator: Alloc<D>,
        Q: Fn(&OVector<f64, D>) -> f64,
    {
        let value = (self.quantity)(z);
        let reference = *self.reference.get_or_insert(value);
        self.t.push(t);
        self.deviation.push(value - reference);
    }
}

impl<D: Dim, Q: Fn(&OVector<f64, D>) -> f64> Observer<D> for DeviationSeries<Q>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, record: &StepRecord<D>) {
        self.push(record.t, &record.z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector1;

    #[test]
    fn average_skips_the_reference_state() {
        let mut a = AverageAbsoluteDeviation::new(|z: &Vector1<f64>| z[0]);
        for x in [1.0, 2.0, 0.0, 1.5] {
            a.push(&Vector1::new(x));
        }
        assert_eq!(a.reference(), Some(1.0));
        assert_eq!(a.count(), 3);
        assert_eq!(a.mean(), Some((1.0 + 1.0 + 0.5) / 3.0));
    }

    #[test]
    fn compensated_sum_keeps_small_terms() {
        // 1 + 1e4 * 1e-16 - 1: plain summation loses every 1e-16; compensated gets 1e-12.
        let mut s = CompensatedSum::default();
        s.add(1.0);
        for _ in 0..10_000 {
            s.add(1e-16);
        }
        s.add(-1.0);
        assert!((s.value() - 1e-12).abs() < 1e-24);
    }

    #[test]
    fn series_records_deviation_from_first() {
        let mut s = DeviationSeries::new(|z: &Vector1<f64>| 2.0 * z[0]);
        s.push(0.0, &Vector1::new(1.0));
        s.push(0.5, &Vector1::new(0.25));
        assert_eq!(s.deviation, vec![0.0, -1.5]);
        assert_eq!(s.max_abs(), 1.5);
    }
}
