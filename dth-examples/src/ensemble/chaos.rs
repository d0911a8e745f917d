//! The MEGNO chaos indicator (Cincotta and Simo 2000) and Benettin's maximal Lyapunov
//! exponent estimate, from the variational equations integrated alongside a run.
//!
//! A tangent vector `delta` obeys `delta' = J HessH(z(t)) delta` along the trajectory. The
//! observer [`Megno`] sees the states `z_k` at times `t_k` of any method (DTH: its midpoints
//! `zbar_k` at `tbar_k`) and carries `delta` from `t_k` to `t_{k+1}` by the trapezoidal rule
//! on that linear equation,
//! `(I - h/2 A_{k+1}) delta_{k+1} = (I + h/2 A_k) delta_k`, `A_k = J HessH(z_k)`,
//! `h = t_{k+1} - t_k` (second order, with the exact Hessian the `hamiltonian!` macro
//! generates), renormalising `delta` to length 1 each step and keeping the sum of the
//! logarithms of the growth factors, `ln |delta(t)|`. From it:
//!
//! - MEGNO `Y(t) = (2/t) int_0^t s d(ln |delta(s)|)` and its running mean
//!   `<Y>(t) = (1/t) int_0^t Y(s) ds` (the Stieltjes integral by the midpoint of each step, the
//!   mean by the trapezoidal rule). `<Y> -> 2` on quasi-periodic (regular) orbits, `-> 0` on
//!   stable periodic ones, and grows like `lambda t / 2` on chaotic ones;
//! - Benettin's estimate of the maximal Lyapunov exponent, `ln |delta(t)| / t`.
//!
//! Why not the DTH step's own tangent map: `docs/theory.md#chaos-indicators`.

use dth::linalg::Lu;
use dth::nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};
use dth::observer::{Observer, StepRecord};
use dth::Alloc;
use dth::Hamiltonian;

/// `J M` for `J = [[0, I], [-I, 0]]` (`D/2` blocks): `z' = J gradH`.
fn j_times<D: Dim>(m: &OMatrix<f64, D, D>) -> OMatrix<f64, D, D>
where
    DefaultAllocator: Alloc<D>,
{
    let (d, _) = m.shape_generic();
    let h = d.value() / 2;
    let mut out = OMatrix::zeros_generic(d, d);
    for c in 0..d.value() {
        for r in 0..h {
            out[(r, c)] = m[(h + r, c)];
            out[(h + r, c)] = -m[(r, c)];
        }
    }
    out
}

/// The indicators at the end of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Indicators {
    /// MEGNO's running mean `<Y>`.
    pub megno: f64,
    /// Benettin's maximal Lyapunov exponent estimate `ln |delta| / t`.
    pub lyapunov: f64,
}

/// The observer: MEGNO and the Lyapunov estimate along a run (see the module docs).
pub struct Megno<'s, D: Dim, S>
where
    DefaultAllocator: Alloc<D>,
{
    system: &'s S,
    /// Start time, previous time, previous `A = J HessH`.
    start: Option<f64>,
    prev: Option<(f64, OMatrix<f64, D, D>)>,
    delta: OVector<f64, D>,
    log_norm: f64,
    stieltjes: f64,
    y_prev: f64,
    y_integral: f64,
    /// Set when a step's linear system was singular or a value not finite.
    broken: bool,
}

impl<'s, D: Dim, S: Hamiltonian<D>> Megno<'s, D, S>
where
    DefaultAllocator: Alloc<D>,
{
    /// The observer for a run of `system`; the tangent vector starts along `(1, ..., 1)`.
    pub fn new(system: &'s S) -> Self {
        Megno {
            system,
            start: None,
            prev: None,
            delta: {
                let d = system.dim();
                OVector::from_element_generic(d, dth::nalgebra::U1, 1.0 / (d.value() as f64).sqrt())
            },
            log_norm: 0.0,
            stieltjes: 0.0,
            y_prev: 0.0,
            y_integral: 0.0,
            broken: false,
        }
    }

    /// MEGNO `<Y>` and the Lyapunov estimate so far (`None` before any time has passed or
    /// when the variational step broke down).
    pub fn indicators(&self) -> Option<Indicators> {
        let (t, _) = self.prev.as_ref()?;
        let span = t - self.start?;
        (span > 0.0 && !self.broken).then(|| Indicators {
            megno: self.y_integral / span,
            lyapunov: self.log_norm / span,
        })
    }
}

impl<D: Dim, S: Hamiltonian<D>> Observer<D> for Megno<'_, D, S>
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, record: &StepRecord<D>) {
        if self.broken {
            return;
        }
        let a1 = j_times(&self.system.hessian(&record.z));
        let Some((t0, a0)) = self.prev.take() else {
            self.start = Some(record.t);
            self.prev = Some((record.t, a1));
            return;
        };
        let start = self.start.unwrap_or(t0);
        let h = record.t - t0;
        let (d, _) = a1.shape_generic();
        let id = OMatrix::<f64, D, D>::identity_generic(d, d);
        let rhs = (&id + a0 * (h / 2.0)) * &self.delta;
        // The core's allocation-free fixed-size LU: one factorization per step, no heap.
        let lhs = id - &a1 * (h / 2.0);
        let next = Lu::factor(&lhs).ok().map(|lu| lu.solve(&rhs));
        let Some(next) = next else {
            self.broken = true;
            return;
        };
        let norm = next.norm();
        if !(norm.is_finite() && norm > 0.0) {
            self.broken = true;
            return;
        }
        self.delta = next / norm;
        let growth = norm.ln();
        self.log_norm += growth;
        // int s d(ln|delta|) over the step, s at the step's middle.
        self.stieltjes += ((t0 + record.t) / 2.0 - start) * growth;
        let span = record.t - start;
        let y = if span > 0.0 {
            2.0 * self.stieltjes / span
        } else {
            0.0
        };
        self.y_integral += h * (self.y_prev + y) / 2.0;
        self.y_prev = y;
        self.prev = Some((record.t, a1));
    }
}
