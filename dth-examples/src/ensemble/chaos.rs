//! The MEGNO chaos indicator (Cincotta and Simo 2000) and Benettin's maximal Lyapunov
//! exponent estimate, from the variational equations integrated alongside a run.
//!
//! A tangent vector `delta` obeys `delta' = J HessH(z(t)) delta` along the trajectory. The
//! observer [`Megno`] sees the states `z_k` at times `t_k` of any method (DTH: its midpoints
//! `zbar_k` at `tbar_k`) and carries `delta` from `t_k` to `t_{k+1}` by the implicit midpoint
//! rule on that linear equation,
//! `(I - h/2 A) delta_{k+1} = (I + h/2 A) delta_k`, `A = J HessH((z_k + z_{k+1})/2)`,
//! `h = t_{k+1} - t_k` (second order, with the exact Hessian the `hamiltonian!` macro
//! generates), renormalising `delta` to length 1 each step and keeping the sum of the
//! logarithms of the growth factors, `ln |delta(t)|`.
//!
//! One `A` per step, between the step's ends, makes the step's map a Cayley transform of a
//! Hamiltonian matrix: symplectic, as the flow's tangent map is (and for the implicit midpoint
//! method exactly that method's tangent map). The trapezoidal form with `A` at each end is not
//! symplectic, and on a torus, whose tangent dynamics is a shear (eigenvalues 1), its
//! `O(h^2)` defect per step turns the shear hyperbolic: a regular Henon-Heiles orbit read
//! `<Y>` = 3.8 at DTH's `dtau = 0.2` and 6.4 with Gauss-Legendre at `dt = 0.1` (2 is right).
//! From `ln |delta(t)|`:
//!
//! - MEGNO `Y(t) = (2/t) int_0^t s d(ln |delta(s)|)` and its running mean
//!   `<Y>(t) = (1/t) int_0^t Y(s) ds` (the Stieltjes integral by the midpoint of each step, the
//!   mean by the trapezoidal rule). `<Y> -> 2` on quasi-periodic (regular) orbits, `-> 0` on
//!   stable periodic ones, and grows like `lambda t / 2` on chaotic ones;
//! - Benettin's estimate of the maximal Lyapunov exponent, `ln |delta(t)| / t`;
//! - SALI, the smaller alignment index (Skokos 2001): a second tangent vector `w` carried by
//!   the same steps and also renormalised, `SALI = min(|delta + w|, |delta - w|)` at the end.
//!   On a torus of a system with 2 or more degrees of freedom the two vectors stay apart
//!   (`SALI` fluctuates about a positive value); on a chaotic orbit both turn towards the
//!   most unstable direction and `SALI` falls like `exp(-(l1 - l2) t)` to roundoff. It is a
//!   second opinion on MEGNO's verdict that reads off a different quantity.
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
    /// The smaller alignment index of two tangent vectors at the end (see the module docs).
    pub sali: f64,
}

/// The observer: MEGNO and the Lyapunov estimate along a run (see the module docs).
pub struct Megno<'s, D: Dim, S>
where
    DefaultAllocator: Alloc<D>,
{
    system: &'s S,
    /// Start time, previous time and state.
    start: Option<f64>,
    prev: Option<(f64, OVector<f64, D>)>,
    delta: OVector<f64, D>,
    /// SALI's second tangent vector (length 1).
    second: OVector<f64, D>,
    sali: f64,
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
    /// The observer for a run of `system`; the tangent vector starts along `(1, ..., 1)`,
    /// SALI's second one along `(1, -1, 1, ..., -1)` (orthogonal to it: `D` is even).
    pub fn new(system: &'s S) -> Self {
        Megno {
            system,
            start: None,
            prev: None,
            delta: {
                let d = system.dim();
                OVector::from_element_generic(d, dth::nalgebra::U1, 1.0 / (d.value() as f64).sqrt())
            },
            second: {
                let d = system.dim();
                let size = 1.0 / (d.value() as f64).sqrt();
                OVector::from_fn_generic(d, dth::nalgebra::U1, |i, _| {
                    if i % 2 == 0 {
                        size
                    } else {
                        -size
                    }
                })
            },
            sali: std::f64::consts::SQRT_2,
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
            sali: self.sali,
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
        let Some((t0, z0)) = self.prev.take() else {
            self.start = Some(record.t);
            self.prev = Some((record.t, record.z.clone()));
            return;
        };
        let start = self.start.unwrap_or(t0);
        let h = record.t - t0;
        let a = j_times(&self.system.hessian(&((z0 + &record.z) * 0.5)));
        let (d, _) = a.shape_generic();
        let id = OMatrix::<f64, D, D>::identity_generic(d, d);
        let forward = &id + &a * (h / 2.0);
        let (rhs, rhs2) = (&forward * &self.delta, forward * &self.second);
        // The core's allocation-free fixed-size LU: one factorization per step, no heap.
        let lhs = id - a * (h / 2.0);
        let next = Lu::factor(&lhs)
            .ok()
            .map(|lu| (lu.solve(&rhs), lu.solve(&rhs2)));
        let Some((next, second)) = next else {
            self.broken = true;
            return;
        };
        let (norm, norm2) = (next.norm(), second.norm());
        if !(norm.is_finite() && norm > 0.0 && norm2.is_finite() && norm2 > 0.0) {
            self.broken = true;
            return;
        }
        self.delta = next / norm;
        self.second = second / norm2;
        self.sali = (&self.delta + &self.second)
            .norm()
            .min((&self.delta - &self.second).norm());
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
        self.prev = Some((record.t, record.z.clone()));
    }
}
