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
//! **Order.** That step is second order: it suits DTH of order 2 and the second-order peers,
//! but after a fourth-order method (Gauss-Legendre, RK4, DTH of order 4-8) the tangent step's
//! error would dominate the indicator's (Gauss-Legendre at `dt = 0.1` read `<Y>` = 4.05 on a
//! regular orbit, where 2 is right). [`Megno::with_order`] 4 carries `delta` by a fourth-order
//! step instead, symplectic too: the fourth-order Magnus expansion over the step,
//! `Omega = h/2 (A1 + A2) + sqrt(3)/12 h^2 (A2 A1 - A1 A2)` with `A_i = J HessH(z(t_i))` at the
//! Gauss nodes `t_i = t_k + (1/2 -+ sqrt(3)/6) h` (a Hamiltonian matrix: sums and commutators of
//! Hamiltonian matrices are), applied by the (2,2) Pade approximant of the exponential,
//! `(I - Omega/2 + Omega^2/12)^(-1) (I + Omega/2 + Omega^2/12)`, which is fourth order and maps
//! a Hamiltonian matrix to a symplectic one. The states at the nodes come from the cubic
//! Hermite interpolant through `z_k`, `z_{k+1}` and their derivatives `J gradH` (fourth order),
//! since an observer sees only the step's ends. One LU per step, two Hessians and two
//! gradients, still no heap for a fixed dimension.
//!
//! After Stormer-Verlet the observer takes that method's own tangent map instead
//! ([`Tangent::Verlet`]: kick, drift, kick with the Hessian's blocks, all at states the step's
//! ends determine), as the implicit midpoint step is the implicit midpoint method's: the
//! midpoint step along Verlet's states is not the derivative of its map, and its `O(h^2)` defect
//! drifted `<Y>` on a regular orbit to 4.1 at `dt = 0.1` (2 is right).
//!
//! Why not the DTH step's own tangent map: `docs/ensembles.md#chaos-indicators`.

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
    /// How `delta` is carried over a step.
    tangent: Tangent,
    /// Stormer-Verlet's tangent map: the last step's end and `HessH` there (the next step's
    /// first kick).
    verlet_end: Option<AtState<D>>,
}

/// A state and `HessH` there.
type AtState<D> = (OVector<f64, D>, OMatrix<f64, D, D>);

/// How the observer carries the tangent vectors over a step (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tangent {
    /// The implicit midpoint rule on the variational equations (order 2; the implicit
    /// midpoint method's own tangent map).
    Midpoint,
    /// Stormer-Verlet's own tangent map (kick, drift, kick with the Hessian's blocks), for a
    /// run of Stormer-Verlet on a separable `H`.
    Verlet,
    /// The fourth-order step: Magnus at the Gauss nodes and the (2,2) Pade approximant.
    Fourth,
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
            tangent: Tangent::Midpoint,
            verlet_end: None,
        }
    }

    /// The same observer with the tangent step of the order of the method it follows: the
    /// fourth-order step for `order >= 4` (see the module docs), else the implicit midpoint.
    pub fn with_order(self, order: u32) -> Self {
        self.with_tangent(if order >= 4 {
            Tangent::Fourth
        } else {
            Tangent::Midpoint
        })
    }

    /// The same observer with the tangent step `tangent`.
    pub fn with_tangent(mut self, tangent: Tangent) -> Self {
        self.tangent = tangent;
        self
    }

    /// The step's map `delta_{k+1} = lhs^(-1) rhs delta_k` from `z0` at `t0` to `z1` over
    /// `h`, as `(lhs, rhs)`.
    fn tangent_step(
        &mut self,
        h: f64,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
    ) -> (OMatrix<f64, D, D>, OMatrix<f64, D, D>) {
        let d = self.delta.shape_generic().0;
        let id = OMatrix::<f64, D, D>::identity_generic(d, d);
        match self.tangent {
            Tangent::Midpoint => {
                let a = j_times(&self.system.hessian(&((z0 + z1) * 0.5)));
                return (&id - &a * (h / 2.0), id + a * (h / 2.0));
            }
            Tangent::Verlet => return (id.clone(), self.verlet_map(h, z0, z1, id)),
            Tangent::Fourth => {}
        }
        // The Hermite interpolant's derivatives at the ends: J grad H.
        let slope = |z: &OVector<f64, D>| dth::j_times(&self.system.gradient(z));
        let (f0, f1) = (slope(z0), slope(z1));
        let at = |theta: f64| {
            let (t2, t3) = (theta * theta, theta * theta * theta);
            let (h00, h10, h01, h11) = (
                2.0 * t3 - 3.0 * t2 + 1.0,
                t3 - 2.0 * t2 + theta,
                -2.0 * t3 + 3.0 * t2,
                t3 - t2,
            );
            let z = z0 * h00 + &f0 * (h * h10) + z1 * h01 + &f1 * (h * h11);
            j_times(&self.system.hessian(&z))
        };
        let offset = 3f64.sqrt() / 6.0;
        let (a1, a2) = (at(0.5 - offset), at(0.5 + offset));
        let commutator = &a2 * &a1 - &a1 * &a2;
        let omega = (a1 + a2) * (h / 2.0) + commutator * (3f64.sqrt() / 12.0 * h * h);
        let square = &omega * &omega / 12.0;
        let half = omega / 2.0;
        (&id - &half + &square, id + half + square)
    }

    /// Stormer-Verlet's tangent map over the step from `z0` to `z1` (a separable `H`): the
    /// half kick with `HessH`'s q-block at `z0`, the drift with its p-block at the half-kicked
    /// state, the half kick at `z1`; `id` is the identity.
    fn verlet_map(
        &mut self,
        h: f64,
        z0: &OVector<f64, D>,
        z1: &OVector<f64, D>,
        id: OMatrix<f64, D, D>,
    ) -> OMatrix<f64, D, D> {
        let n = z0.len() / 2;
        let g0 = self.system.gradient(z0);
        let mut kicked = z0.clone();
        for i in 0..n {
            kicked[n + i] -= h / 2.0 * g0[i];
        }
        let kick = |hess: &OMatrix<f64, D, D>| {
            let mut m = id.clone();
            for r in 0..n {
                for c in 0..n {
                    m[(n + r, c)] -= h / 2.0 * hess[(r, c)];
                }
            }
            m
        };
        let hess = self.system.hessian(&kicked);
        let mut drift = id.clone();
        for r in 0..n {
            for c in 0..n {
                drift[(r, n + c)] += h * hess[(n + r, n + c)];
            }
        }
        // HessH at the step's start: the last step's end's, kept, when the run goes on from it.
        let at_start = match self.verlet_end.take() {
            Some((z, hess)) if z == *z0 => hess,
            _ => self.system.hessian(z0),
        };
        let at_end = self.system.hessian(z1);
        let map = kick(&at_end) * drift * kick(&at_start);
        self.verlet_end = Some((z1.clone(), at_end));
        map
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
        let (lhs, forward) = self.tangent_step(h, &z0, &record.z);
        let (rhs, rhs2) = (&forward * &self.delta, forward * &self.second);
        // The core's allocation-free fixed-size LU: one factorization per step, no heap.
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

#[cfg(test)]
mod tests {
    use super::*;
    use dth::nalgebra::Vector4;
    use dth::solve::{solve, Method};
    use dth::systems::HenonHeiles;

    /// `ln |delta(T)|` along Gauss-Legendre (order 4) at step `dt`, with the tangent step of
    /// `order`.
    fn log_growth(dt: f64, order: u32) -> f64 {
        let system = HenonHeiles;
        // A regular orbit at E = 1/8: q2 = 0.3, p2 = 0.05, p1 from the energy.
        let v = 0.3f64 * 0.3 / 2.0 - 0.3f64.powi(3) / 3.0;
        let p1 = (2.0 * (0.125 - v - 0.05 * 0.05 / 2.0)).sqrt();
        let z0 = Vector4::new(0.0, 0.3, p1, 0.05);
        let mut megno = Megno::new(&system).with_order(order);
        solve(&system, z0, Method::GaussLegendre2 { dt })
            .until(20.0)
            .save_every(usize::MAX)
            .observer(&mut megno)
            .run()
            .unwrap();
        let i = megno.indicators().unwrap();
        i.lyapunov * 20.0
    }

    /// Stormer-Verlet's tangent map is the derivative of its step: carried over one step,
    /// `delta` matches the difference of two Verlet steps from `z0` and `z0 + eps delta`.
    #[test]
    fn verlets_tangent_map_is_the_derivative_of_its_step() {
        use dth::methods::{OneStepMethod, StormerVerlet};
        let system = HenonHeiles;
        let z0 = Vector4::new(0.1, 0.3, 0.4, 0.05);
        let h = 0.1;
        let mut verlet = StormerVerlet::new();
        let z1 = verlet.step(&system, &z0, h).unwrap();
        let mut m = Megno::new(&system).with_tangent(Tangent::Verlet);
        let d = m.delta.shape_generic().0;
        let id = OMatrix::<f64, dth::nalgebra::Const<4>, dth::nalgebra::Const<4>>::identity_generic(
            d, d,
        );
        let (lhs, map) = m.tangent_step(h, &z0, &z1);
        assert_eq!(lhs, id);
        let direction = Vector4::new(0.3, -0.2, 0.5, 0.1);
        let eps = 1e-6;
        let moved = verlet.step(&system, &(z0 + direction * eps), h).unwrap();
        let difference = (moved - z1) / eps;
        // A central difference would be O(eps^2); this one-sided one is O(eps) ~ 1e-6.
        assert!(
            (map * direction - difference).amax() < 1e-5,
            "{}",
            (map * direction - difference).amax()
        );
    }

    #[test]
    fn the_tangent_step_has_the_order_asked() {
        for (order, want) in [(2, 4.0), (4, 16.0)] {
            let l: Vec<f64> = [0.1, 0.05, 0.025]
                .iter()
                .map(|&dt| log_growth(dt, order))
                .collect();
            let ratio = (l[0] - l[1]).abs() / (l[1] - l[2]).abs();
            // Halving the step divides the error by 2^order as h -> 0; 0.7 of it leaves
            // room for the next terms at these steps.
            assert!(
                ratio > 0.7 * want,
                "order {order}: ln|delta| = {l:?}, ratio {ratio:.2}"
            );
        }
    }
}
