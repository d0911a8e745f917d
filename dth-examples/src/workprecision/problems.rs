//! The five work-precision problems, each with its final time, reference solution and
//! invariant.
//!
//! | name | system | initial state | `T` | reference |
//! |---|---|---|---|---|
//! | `kepler_e044` | thesis Kepler `H = p1^2 + p2^2 - 1/r` | `q = (0.5, 0)`, `p = (0, 1.2)` (e = 0.44) | 10 periods | exact |
//! | `kepler_e07` | same `H` | `q = (0.5, 0)`, `p = (0, 1.30384..)` at pericenter (e = 0.7) | 10 periods | exact |
//! | `henon_heiles` | Henon-Heiles | `q = (0, 0.1)`, `p2 = 0`, `p1 > 0` with `H = 1/8` | 10 x 2 pi | Gauss-Legendre 2 |
//! | `pendulum` | `H = p^2/2 - cos q` | `q = 2`, `p = 0` (libration, amplitude 2 rad) | 10 periods | Gauss-Legendre 2 |
//! | `forced_oscillator` | `H = p^2/2 + 1.69 q^2/2 - 0.4 q cos(0.7 t)`, extended phase space | `q = 1`, `p = 0`, `t = 0` | 10 x 2 pi / 1.3 | exact |
//!
//! The quick sweep integrates one period instead of ten.

use dth::nalgebra::{SVector, Vector2, Vector4};
use serde::Serialize;

use dth::dth::DthOptions;
use dth::kepler::KeplerOrbit;
use dth::methods::{
    DiscreteGradient, DiscreteMechanics, GaussLegendre2, ImplicitMidpoint, Rk4, StormerVerlet,
    Trapezoidal,
};
use dth::systems::{ForcedOscillator, HenonHeiles, Kepler, Pendulum};
use dth::Hamiltonian;

use super::reference::{gauss_legendre_reference, Reference};
use super::runners::{sweep_dop853, sweep_dth, sweep_peer, Ladder};
use super::{Error, Record, ReferenceCheck, WorkPrecisionOptions};

/// Name, title and time scales of a problem, as written to the results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ProblemInfo {
    /// File-name safe name (`kepler_e044`, ...).
    pub name: &'static str,
    /// Title for diagrams and tables.
    pub title: &'static str,
    /// Final time `T` of every run.
    pub t_end: f64,
    /// Characteristic period (orbit period, libration period, `2 pi / omega`).
    pub period: f64,
    /// Name of the invariant besides the energy, if any.
    pub invariant: Option<&'static str>,
}

/// One problem: Hamiltonian, initial state, reference and diagnostics.
pub(crate) struct Problem<H, const D: usize> {
    pub info: ProblemInfo,
    pub hamiltonian: H,
    pub z0: SVector<f64, D>,
    pub reference: Reference<D>,
    /// The invariant besides the energy (angular momentum), if any.
    pub invariant: Option<fn(&SVector<f64, D>) -> f64>,
    /// The error of a state against the reference state at the same time.
    pub error: fn(&SVector<f64, D>, &SVector<f64, D>) -> f64,
}

/// A problem of any dimension, as the sweep sees it.
pub(crate) trait Sweep {
    fn sweep(
        &self,
        options: &WorkPrecisionOptions,
        records: &mut Vec<Record>,
        references: &mut Vec<ReferenceCheck>,
        infos: &mut Vec<ProblemInfo>,
    ) -> Result<(), Error>;
}

fn full_norm<const D: usize>(a: &SVector<f64, D>, b: &SVector<f64, D>) -> f64 {
    (a - b).norm()
}

/// The `(q, p)` part of an extended state `(q, t, p, p_t)` with one degree of freedom.
fn physical_norm(a: &Vector4<f64>, b: &Vector4<f64>) -> f64 {
    (a[0] - b[0]).hypot(a[2] - b[2])
}

/// Step sizes for a problem: points per period, the quick or the full ladder.
fn ladder(options: &WorkPrecisionOptions, info: &ProblemInfo) -> Ladder {
    let points_per_period: &[f64] = if options.is_quick() {
        &[32.0, 64.0, 128.0]
    } else {
        // 2.4 decades for the fixed-step methods.
        &[
            16.0, 32.0, 64.0, 128.0, 256.0, 512.0, 1024.0, 2048.0, 4096.0,
        ]
    };
    let tolerances: &[f64] = if options.is_quick() {
        &[1e-4, 1e-7, 1e-10]
    } else {
        &[
            1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14,
        ]
    };
    Ladder {
        dt: points_per_period.iter().map(|n| info.period / n).collect(),
        // DTH: the same points per period (the sweep divides by DTH's mean lambda), one
        // halving further since its steps concentrate where Psi is large.
        dtau: points_per_period
            .iter()
            .chain(if options.is_quick() {
                [].iter()
            } else {
                [8192.0].iter()
            })
            .map(|n| info.period / n)
            .collect(),
        tolerance: tolerances.to_vec(),
    }
}

impl<H, const D: usize> Problem<H, D>
where
    H: Hamiltonian<D> + Clone,
{
    /// Every method that applies to any Hamiltonian.
    fn sweep_common(&self, options: &WorkPrecisionOptions, records: &mut Vec<Record>) {
        let ladder = ladder(options, &self.info);
        let base = DthOptions::default();
        sweep_dth(self, options, &ladder, "dth_joint", base, records);
        sweep_dth(
            self,
            options,
            &ladder,
            "dth_nested",
            base.with_solver(dth::dth::Solver::Nested),
            records,
        );
        sweep_peer(self, options, &ladder, ImplicitMidpoint::new, records);
        sweep_peer(self, options, &ladder, Trapezoidal::new, records);
        sweep_peer(self, options, &ladder, DiscreteGradient::new, records);
        sweep_peer(self, options, &ladder, StormerVerlet::<D>::new, records);
        sweep_peer(self, options, &ladder, || Rk4, records);
        sweep_peer(self, options, &ladder, GaussLegendre2::new, records);
        sweep_dop853(self, options, &ladder, records);
    }

    fn push_info(&self, references: &mut Vec<ReferenceCheck>, infos: &mut Vec<ProblemInfo>) {
        references.push(self.reference.check.clone());
        infos.push(self.info.clone());
    }
}

/// Stormer-Verlet applies to separable Hamiltonians only; every problem here is separable
/// (the forced oscillator's `calH = p_t + p^2/2 + V(q, t)` too).
struct Generic<H, const D: usize>(Problem<H, D>);

impl<H: Hamiltonian<D> + Clone, const D: usize> Sweep for Generic<H, D> {
    fn sweep(
        &self,
        options: &WorkPrecisionOptions,
        records: &mut Vec<Record>,
        references: &mut Vec<ReferenceCheck>,
        infos: &mut Vec<ProblemInfo>,
    ) -> Result<(), Error> {
        self.0.sweep_common(options, records);
        self.0.push_info(references, infos);
        Ok(())
    }
}

/// Kepler: every method plus Greenspan's discrete mechanics (central forces only).
struct KeplerProblem(Problem<Kepler, 4>);

impl Sweep for KeplerProblem {
    fn sweep(
        &self,
        options: &WorkPrecisionOptions,
        records: &mut Vec<Record>,
        references: &mut Vec<ReferenceCheck>,
        infos: &mut Vec<ProblemInfo>,
    ) -> Result<(), Error> {
        self.0.sweep_common(options, records);
        let ladder = ladder(options, &self.0.info);
        sweep_peer(&self.0, options, &ladder, DiscreteMechanics::new, records);
        self.0.push_info(references, infos);
        Ok(())
    }
}

fn periods(options: &WorkPrecisionOptions) -> f64 {
    if options.is_quick() {
        1.0
    } else {
        10.0
    }
}

fn kepler(
    options: &WorkPrecisionOptions,
    name: &'static str,
    title: &'static str,
    z0: Vector4<f64>,
) -> Result<KeplerProblem, Error> {
    let hamiltonian = Kepler::thesis();
    let orbit = KeplerOrbit::new(&hamiltonian, &z0).map_err(|e| Error::Reference {
        system: name,
        message: e.to_string(),
    })?;
    let period = orbit.elements().period;
    Ok(KeplerProblem(Problem {
        info: ProblemInfo {
            name,
            title,
            t_end: periods(options) * period,
            period,
            invariant: Some("angular momentum"),
        },
        hamiltonian,
        z0,
        reference: Reference::exact(name, move |t| orbit.state_at(t)),
        invariant: Some(Kepler::angular_momentum),
        error: full_norm,
    }))
}

/// Pericenter state at `r = 0.5` of the thesis Kepler problem (`m = 1/2`, `k = 1`) with
/// eccentricity `e`: speed `sqrt(mu (1 + e) / r)`, `mu = k/m`.
fn pericenter(e: f64) -> Vector4<f64> {
    let (m, k, r) = (0.5, 1.0, 0.5);
    Vector4::new(r, 0.0, 0.0, m * (k / m * (1.0 + e) / r).sqrt())
}

/// Complete elliptic integral of the first kind `K(k)` by the arithmetic-geometric mean.
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0, (1.0 - k * k).sqrt());
    while (a - b).abs() > 4.0 * f64::EPSILON * a {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    std::f64::consts::FRAC_PI_2 / a
}

/// All five problems.
pub(crate) fn all(options: &WorkPrecisionOptions) -> Result<Vec<Box<dyn Sweep>>, Error> {
    let n = periods(options);
    let tau = std::f64::consts::TAU;
    let mut list: Vec<Box<dyn Sweep>> = vec![
        Box::new(kepler(
            options,
            "kepler_e044",
            "Kepler, e = 0.44 (thesis orbit)",
            Vector4::new(0.5, 0.0, 0.0, 1.2),
        )?),
        Box::new(kepler(
            options,
            "kepler_e07",
            "Kepler, e = 0.7",
            pericenter(0.7),
        )?),
    ];

    // Henon-Heiles at E = 1/8 from q = (0, 0.1), p2 = 0.
    let hh = HenonHeiles;
    let (q2, energy): (f64, f64) = (0.1, 0.125);
    let v = 0.5 * q2 * q2 - q2 * q2 * q2 / 3.0;
    let z0 = Vector4::new(0.0, q2, (2.0 * (energy - v)).sqrt(), 0.0);
    let info = ProblemInfo {
        name: "henon_heiles",
        title: "Henon-Heiles, E = 1/8",
        t_end: n * tau,
        period: tau,
        invariant: None,
    };
    let reference = gauss_legendre_reference(info.name, &hh, &z0, info.t_end, tau / 4000.0)?;
    list.push(Box::new(Generic(Problem {
        info,
        hamiltonian: hh,
        z0,
        reference,
        invariant: None,
        error: full_norm,
    })));

    // Pendulum libration with amplitude 2 rad: period 4 K(sin 1).
    let pendulum = Pendulum::normalized();
    let q0: f64 = 2.0;
    let period = 4.0 * elliptic_k((0.5 * q0).sin());
    let z0 = Vector2::new(q0, 0.0);
    let info = ProblemInfo {
        name: "pendulum",
        title: "Pendulum libration, amplitude 2 rad",
        t_end: n * period,
        period,
        invariant: None,
    };
    let reference =
        gauss_legendre_reference(info.name, &pendulum, &z0, info.t_end, period / 4000.0)?;
    list.push(Box::new(Generic(Problem {
        info,
        hamiltonian: pendulum,
        z0,
        reference,
        invariant: None,
        error: full_norm,
    })));

    // Forced oscillator in the extended phase space (q, t, p, p_t), calH = p_t + H = 0.
    let forced = ForcedOscillator {
        omega0: 1.3,
        force: 0.4,
        omega: 0.7,
    };
    let (q0, p0) = (1.0, 0.0);
    let z0 = forced.initial_state(q0, p0, 0.0);
    let period = tau / forced.omega0;
    let info = ProblemInfo {
        name: "forced_oscillator",
        title: "Forced oscillator (extended phase space)",
        t_end: n * period,
        period,
        invariant: None,
    };
    let reference = Reference::exact(info.name, move |t| {
        let (q, p) = forced.exact(q0, p0, t);
        forced.initial_state(q, p, t)
    });
    list.push(Box::new(Generic(Problem {
        info,
        hamiltonian: forced,
        z0,
        reference,
        invariant: None,
        error: physical_norm,
    })));
    Ok(list)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pericenter_state_has_the_requested_eccentricity() {
        let orbit = KeplerOrbit::new(&Kepler::thesis(), &pericenter(0.7)).unwrap();
        // e from H and L: a few eps of cancellation in 1 + 2 H L^2 / (m mu^2).
        assert!((orbit.elements().eccentricity - 0.7).abs() < 1e-14);
        let thesis = KeplerOrbit::new(&Kepler::thesis(), &pericenter(0.44)).unwrap();
        assert!((thesis.elements().eccentricity - 0.44).abs() < 1e-14);
    }

    #[test]
    fn elliptic_k_matches_known_values() {
        // K(0) = pi/2; K(sin 45 deg) = 1.854074677301372 (Abramowitz-Stegun Table 17.1).
        assert!((elliptic_k(0.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((elliptic_k(0.5f64.sqrt()) - 1.854_074_677_301_372).abs() < 1e-14);
    }
}
