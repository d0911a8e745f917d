//! The catalogue's systems, compiled with `dth::hamiltonian!`: value, gradient, Hessian, Psi
//! and the discrete gradient of each are derived at compile time from the formula on its
//! type. Each type's fields are its parameters, under the names scenes use in `params`.
//!
//! The lattices (FPUT-alpha and -beta, the Toda chain between walls) are written once, as
//! indexed sums: `hamiltonian!` compiles them to loops over the sites, so their code (and
//! rustc's time on it) does not grow with the number of particles. The three-body systems
//! are written out: sums over all pairs are built site by site (the same code as written out),
//! and three pairs read more plainly as three terms.
//!
//! What a formula does not say is written here by hand, from the parameters: the quadratic
//! (and linear) invariants, orbit periods, Kepler's exact solution
//! (`dth::kepler::KeplerOrbit`) and the central-force description Greenspan's discrete
//! mechanics needs (`dth::systems::CentralForce`).
//!
//! ```
//! use dth::Hamiltonian;
//! use dth_examples::systems::Kepler;
//! let z = dth::nalgebra::Vector4::new(0.5, 0.0, 0.0, 1.2);
//! // The thesis's orbit: H = 1.2^2 - 1/0.5 = -0.56.
//! assert!((Kepler::thesis().value(&z) + 0.56).abs() < 1e-15);
//! ```

use dth::kepler::KeplerOrbit;
use dth::methods::{DiscreteMechanics, RunEnd};
use dth::nalgebra::Const;
use dth::nalgebra::SVector;
use dth::observer::Observer;
use dth::systems::CentralForce;
use dth::Hamiltonian;

use crate::driver::{run_peer, MethodFailure, Stop};
use crate::system::SceneSystem;

dth::hamiltonian! {
    /// The planar Kepler problem `H = |p|^2/(2 m) - k/|q|`, `z = (q1, q2, p1, p2)`. The
    /// thesis's form `p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)` is `m = 1/2`, `k = 1`
    /// ([`Kepler::thesis`]).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Kepler {
        /// Mass `m`.
        pub m: f64,
        /// Force constant `k`.
        pub k: f64,
    } = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)
}

impl Kepler {
    /// The thesis's Kepler problem: `m = 1/2`, `k = 1`.
    pub const fn thesis() -> Self {
        Kepler { m: 0.5, k: 1.0 }
    }

    /// The hand-written reference type with the same parameters (what
    /// `dth::kepler::KeplerOrbit` takes).
    pub const fn reference(&self) -> dth::systems::Kepler {
        dth::systems::Kepler {
            mass: self.m,
            k: self.k,
        }
    }
}

/// `L = q1 p2 - q2 p1` of a planar state `(q1, q2, p1, p2)`.
fn angular_momentum(z: &SVector<f64, 4>) -> f64 {
    z[0] * z[3] - z[1] * z[2]
}

impl SceneSystem<Const<4>> for Kepler {
    const HAS_PERIOD: bool = true;
    const HAS_EXACT: bool = true;
    const CENTRAL_FORCE: bool = true;

    fn invariant_names(&self) -> &'static [&'static str] {
        &["angular_momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 4>, out: &mut [f64]) {
        out[0] = angular_momentum(z);
    }

    /// Kepler's equation (`dth::kepler::KeplerOrbit`); `None` for orbits that are not
    /// elliptic.
    fn exact_solution(&self, z0: &SVector<f64, 4>, t: f64) -> Option<SVector<f64, 4>> {
        KeplerOrbit::new(&self.reference(), z0)
            .ok()
            .map(|o| o.state_at(t))
    }

    /// `T = 2 pi sqrt(m a^3 / k)` with `a = -k / (2 H)`, for `H < 0`.
    fn period(&self, z0: &SVector<f64, 4>) -> Option<f64> {
        let h = self.value(z0);
        (h < 0.0).then(|| {
            let a = -self.k / (2.0 * h);
            std::f64::consts::TAU * (self.m * a * a * a / self.k).sqrt()
        })
    }

    fn run_discrete_mechanics<O: Observer<Const<4>>>(
        &self,
        dt: f64,
        z0: SVector<f64, 4>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd<Const<4>>, MethodFailure>> {
        Some(run_peer(
            DiscreteMechanics::new(),
            self,
            dt,
            z0,
            t0,
            stop,
            observer,
        ))
    }
}

/// `phi(r) = -k / r`.
impl CentralForce<Const<4>> for Kepler {
    fn mass(&self) -> f64 {
        self.m
    }

    fn phi(&self, r: f64) -> f64 {
        -self.k / r
    }

    fn dphi(&self, r: f64) -> f64 {
        self.k / (r * r)
    }

    /// `(-k/r1 + k/r0) / (r1 - r0) = k / (r0 r1)` exactly: no cancellation, no guard needed.
    fn phi_divided_difference(&self, r0: f64, r1: f64) -> f64 {
        self.k / (r0 * r1)
    }
}

dth::hamiltonian! {
    /// The harmonic oscillator `H = p^2/(2 m) + k q^2/2`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct HarmonicOscillator {
        /// Mass `m`.
        pub m: f64,
        /// Spring constant `k`.
        pub k: f64,
    } = p1^2/(2*m) + k*q1^2/2
}

impl SceneSystem<Const<2>> for HarmonicOscillator {
    const HAS_PERIOD: bool = true;

    /// `2 pi sqrt(m / k)`, whatever the amplitude.
    fn period(&self, _z0: &SVector<f64, 2>) -> Option<f64> {
        Some(std::f64::consts::TAU * (self.m / self.k).sqrt())
    }
}

dth::hamiltonian! {
    /// The plane pendulum `H = p^2/(2 m l^2) - m g l cos q`, `q` the angle from the downward
    /// vertical.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Pendulum {
        /// Bob mass `m`.
        pub m: f64,
        /// Rod length `l`.
        pub l: f64,
        /// Gravity `g`.
        pub g: f64,
    } = p1^2/(2*m*l^2) - m*g*l*cos(q1)
}

impl SceneSystem<Const<2>> for Pendulum {}

dth::hamiltonian! {
    /// The Henon-Heiles system
    /// `H = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2 q2 - q2^3/3`.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct HenonHeiles = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3
}

impl SceneSystem<Const<4>> for HenonHeiles {}

dth::hamiltonian! {
    /// The planar double pendulum in canonical coordinates: angles `q1`, `q2` from the
    /// downward vertical and their conjugate momenta.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct DoublePendulum {
        /// Upper bob mass.
        pub m1: f64,
        /// Lower bob mass.
        pub m2: f64,
        /// Upper rod length.
        pub l1: f64,
        /// Lower rod length.
        pub l2: f64,
        /// Gravity.
        pub g: f64,
    } = (m2*l2^2*p1^2 + (m1 + m2)*l1^2*p2^2 - 2*m2*l1*l2*p1*p2*cos(q1 - q2))
            / (2*m2*l1^2*l2^2*(m1 + m2*sin(q1 - q2)^2))
        - (m1 + m2)*g*l1*cos(q1) - m2*g*l2*cos(q2)
}

impl SceneSystem<Const<4>> for DoublePendulum {}

dth::hamiltonian! {
    /// The periodic Toda chain of 4 unit masses: bonds `(i, i+1)` with `q5 = q1`.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct TodaChain4 =
        (p1^2 + p2^2 + p3^2 + p4^2)/2
        + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4 - q1)
}

dth::hamiltonian! {
    /// The periodic Toda chain of 10 unit masses: bonds `(i, i+1)` with `q11 = q1`.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct TodaChain10 =
        (p1^2 + p2^2 + p3^2 + p4^2 + p5^2 + p6^2 + p7^2 + p8^2 + p9^2 + p10^2)/2
        + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4 - q5) + exp(q5 - q6)
        + exp(q6 - q7) + exp(q7 - q8) + exp(q8 - q9) + exp(q9 - q10) + exp(q10 - q1)
}

/// A periodic chain's total momentum `sum p_i` (a linear invariant: the potential depends
/// on differences only), reported under `invariants`.
fn total_momentum<const D: usize>(z: &SVector<f64, D>) -> f64 {
    z.rows(D / 2, D / 2).sum()
}

impl SceneSystem<Const<8>> for TodaChain4 {
    fn invariant_names(&self) -> &'static [&'static str] {
        &["total_momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 8>, out: &mut [f64]) {
        out[0] = total_momentum(z);
    }
}

impl SceneSystem<Const<20>> for TodaChain10 {
    fn invariant_names(&self) -> &'static [&'static str] {
        &["total_momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 20>, out: &mut [f64]) {
        out[0] = total_momentum(z);
    }
}

dth::hamiltonian! {
    /// The FPUT-alpha chain of 32 unit masses with fixed ends (`q0 = q33 = 0`):
    /// `H = sum p_i^2/2 + sum_{i=0}^{32} [d_i^2/2 + alpha d_i^3/3]`, `d_i = q_{i+1} - q_i`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct FputAlpha32 {
        /// The cubic coupling `alpha`.
        pub alpha: f64,
    } = sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3)
        where N = 32, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    /// The FPUT-beta chain of 32 unit masses with fixed ends (`q0 = q33 = 0`):
    /// `H = sum p_i^2/2 + sum_{i=0}^{32} [d_i^2/2 + beta d_i^4/4]`, `d_i = q_{i+1} - q_i`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct FputBeta32 {
        /// The quartic coupling `beta`.
        pub beta: f64,
    } = sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + beta*(q[i+1] - q[i])^4/4)
        where N = 32, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    /// The Toda chain of 32 unit masses between walls (`q0 = q33 = 0`):
    /// `H = sum p_i^2/2 + sum_{i=0}^{32} exp(q_i - q_{i+1})`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct TodaFixedEnds32 =
        sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, exp(q[i] - q[i+1])) where N = 32, q[0] = q[N+1] = 0
}

dth::hamiltonian! {
    /// Three gravitating point masses in the plane, all pairs:
    /// `H = sum |p_i|^2/(2 m_i) - g sum_{i<j} m_i m_j / |q_i - q_j|`, body `i` at
    /// `(q_{2i-1}, q_{2i})`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct NBody2d3 {
        /// Mass of body 1.
        pub m1: f64,
        /// Mass of body 2.
        pub m2: f64,
        /// Mass of body 3.
        pub m3: f64,
        /// Gravitational constant `G`.
        pub g: f64,
    } = (p1^2 + p2^2)/(2*m1) + (p3^2 + p4^2)/(2*m2) + (p5^2 + p6^2)/(2*m3)
        - g*m1*m2*((q1 - q3)^2 + (q2 - q4)^2)^(-1/2)
        - g*m1*m3*((q1 - q5)^2 + (q2 - q6)^2)^(-1/2)
        - g*m2*m3*((q3 - q5)^2 + (q4 - q6)^2)^(-1/2)
}

dth::hamiltonian! {
    /// Three gravitating point masses in space, all pairs:
    /// `H = sum |p_i|^2/(2 m_i) - g sum_{i<j} m_i m_j / |q_i - q_j|`, body `i` at
    /// `(q_{3i-2}, q_{3i-1}, q_{3i})`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct NBody3d3 {
        /// Mass of body 1.
        pub m1: f64,
        /// Mass of body 2.
        pub m2: f64,
        /// Mass of body 3.
        pub m3: f64,
        /// Gravitational constant `G`.
        pub g: f64,
    } = (p1^2 + p2^2 + p3^2)/(2*m1) + (p4^2 + p5^2 + p6^2)/(2*m2) + (p7^2 + p8^2 + p9^2)/(2*m3)
        - g*m1*m2*((q1 - q4)^2 + (q2 - q5)^2 + (q3 - q6)^2)^(-1/2)
        - g*m1*m3*((q1 - q7)^2 + (q2 - q8)^2 + (q3 - q9)^2)^(-1/2)
        - g*m2*m3*((q4 - q7)^2 + (q5 - q8)^2 + (q6 - q9)^2)^(-1/2)
}

dth::hamiltonian! {
    /// `N` gravitating point masses `m` in space, all pairs, the pair sum written once (and
    /// looped): `H = sum |p_i|^2/(2 m) - g m^2 sum_{i<j} 1/|q_i - q_j|`, body `i` at
    /// `(q_{3i-2}, q_{3i-1}, q_{3i})`; `N = 4` here, any `N` from a scene's `sizes`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Gravity3d4 {
        /// Mass of each body.
        pub m: f64,
        /// Gravitational constant `G`.
        pub g: f64,
    } = sum(i = 1..N, (p[3*i-2]^2 + p[3*i-1]^2 + p[3*i]^2)/(2*m)) - g*m^2*sum(1 <= i < j <= N,
        ((q[3*i-2] - q[3*j-2])^2 + (q[3*i-1] - q[3*j-1])^2 + (q[3*i] - q[3*j])^2)^(-1/2))
        where N = 4
}

dth::hamiltonian! {
    /// The Calogero-Moser system of `N` unit masses on a line, the pair sum written once (and
    /// looped): `H = sum p_i^2/2 + g^2 sum_{i<j} (q_i - q_j)^(-2)`; `N = 8` here, any `N` from
    /// a scene's `sizes`.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct CalogeroMoser8 {
        /// Coupling `g`.
        pub g: f64,
    } = sum(i = 1..N, p[i]^2/2) + g^2*sum(1 <= i < j <= N, (q[i] - q[j])^(-2)) where N = 8
}

/// The chains with fixed ends whose harmonic part is the unit-spring chain (the `normal_modes`
/// effect's modes, [`crate::normal_modes`]).
impl SceneSystem<Const<64>> for FputAlpha32 {
    const FIXED_END_CHAIN: bool = true;
}

impl SceneSystem<Const<64>> for FputBeta32 {
    const FIXED_END_CHAIN: bool = true;
}

/// `exp(-d) = 1 - d + d^2/2 - ...` for each bond `d = q_{i+1} - q_i`: the linear terms
/// telescope to `q_{33} - q_0 = 0`, so the harmonic part is the unit-spring chain.
impl SceneSystem<Const<64>> for TodaFixedEnds32 {
    const FIXED_END_CHAIN: bool = true;
}

/// The conserved total momentum and angular momentum of `B` bodies in the plane,
/// `z = (q, p)` with body `i` at `(q_{2i-1}, q_{2i})`: `(P_x, P_y, L)`.
fn planar_momenta<const D: usize>(z: &SVector<f64, D>, out: &mut [f64]) {
    let (q, p) = z.as_slice().split_at(D / 2);
    out[0] = p.iter().step_by(2).sum();
    out[1] = p.iter().skip(1).step_by(2).sum();
    out[2] = (0..D / 4)
        .map(|b| q[2 * b] * p[2 * b + 1] - q[2 * b + 1] * p[2 * b])
        .sum();
}

/// The names of [`spatial_momenta`]' components.
const SPATIAL_MOMENTA: &[&str] = &[
    "momentum_x",
    "momentum_y",
    "momentum_z",
    "angular_momentum_x",
    "angular_momentum_y",
    "angular_momentum_z",
];

/// The conserved total momentum and angular momentum `sum q_i x p_i` of `B` bodies in space,
/// body `i` at `(q_{3i-2}, q_{3i-1}, q_{3i})`: `(P_x, P_y, P_z, L_x, L_y, L_z)`.
fn spatial_momenta<const D: usize>(z: &SVector<f64, D>, out: &mut [f64]) {
    let (q, p) = z.as_slice().split_at(D / 2);
    out[..6].fill(0.0);
    for (x, v) in q.chunks_exact(3).zip(p.chunks_exact(3)) {
        for c in 0..3 {
            out[c] += v[c];
        }
        out[3] += x[1] * v[2] - x[2] * v[1];
        out[4] += x[2] * v[0] - x[0] * v[2];
        out[5] += x[0] * v[1] - x[1] * v[0];
    }
}

impl SceneSystem<Const<12>> for NBody2d3 {
    fn invariant_names(&self) -> &'static [&'static str] {
        &["momentum_x", "momentum_y", "angular_momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 12>, out: &mut [f64]) {
        planar_momenta(z, out);
    }
}

impl SceneSystem<Const<18>> for NBody3d3 {
    fn invariant_names(&self) -> &'static [&'static str] {
        SPATIAL_MOMENTA
    }

    fn invariants(&self, z: &SVector<f64, 18>, out: &mut [f64]) {
        spatial_momenta(z, out);
    }
}

impl SceneSystem<Const<24>> for Gravity3d4 {
    fn invariant_names(&self) -> &'static [&'static str] {
        SPATIAL_MOMENTA
    }

    fn invariants(&self, z: &SVector<f64, 24>, out: &mut [f64]) {
        spatial_momenta(z, out);
    }
}

/// The pair forces cancel: the total momentum is conserved.
impl SceneSystem<Const<16>> for CalogeroMoser8 {
    fn invariant_names(&self) -> &'static [&'static str] {
        &["momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 16>, out: &mut [f64]) {
        out[0] = z.as_slice()[8..].iter().sum();
    }
}

dth::hamiltonian! {
    /// The periodically forced oscillator `H = p^2/2 + omega0^2 q^2/2 - f q cos(omega t)`,
    /// on the extended phase space `z = (q, t, p, p_t)` (`calH = p_t + H`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct ForcedOscillator {
        /// Natural frequency `omega0`.
        pub omega0: f64,
        /// Forcing amplitude `f`.
        pub f: f64,
        /// Forcing frequency `omega`.
        pub omega: f64,
    } = p1^2/2 + omega0^2*q1^2/2 - f*q1*cos(omega*t)
}

impl SceneSystem<Const<4>> for ForcedOscillator {}

dth::hamiltonian! {
    /// A free particle in the plane, `H = (p1^2 + p2^2)/(2 m)`.
    ///
    /// `Psi = (J gradH)^T HessH (J gradH)` is identically zero (`J gradH = (p/m, 0)` and the
    /// Hessian has only its `p`-`p` block), so DTH's energy condition does not determine
    /// `lambda` (thesis Section 3.4): the catalogue registers it with
    /// [`SystemEntry::runnable_without_dth`](crate::catalogue::SystemEntry::runnable_without_dth).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct FreeParticle {
        /// Mass `m`.
        pub m: f64,
    } = (p1^2 + p2^2)/(2*m)
}

impl SceneSystem<Const<4>> for FreeParticle {
    const HAS_EXACT: bool = true;
    const CENTRAL_FORCE: bool = true;

    /// Momentum is conserved (`p1`, `p2`: linear invariants), and so is `L`.
    fn invariant_names(&self) -> &'static [&'static str] {
        &["p1", "p2", "angular_momentum"]
    }

    fn invariants(&self, z: &SVector<f64, 4>, out: &mut [f64]) {
        out[0] = z[2];
        out[1] = z[3];
        out[2] = angular_momentum(z);
    }

    /// `q(t) = q0 + p0 t / m`, `p(t) = p0`.
    fn exact_solution(&self, z0: &SVector<f64, 4>, t: f64) -> Option<SVector<f64, 4>> {
        let s = t / self.m;
        Some(SVector::<f64, 4>::new(
            z0[0] + s * z0[2],
            z0[1] + s * z0[3],
            z0[2],
            z0[3],
        ))
    }

    fn run_discrete_mechanics<O: Observer<Const<4>>>(
        &self,
        dt: f64,
        z0: SVector<f64, 4>,
        t0: f64,
        stop: Stop,
        observer: &mut O,
    ) -> Option<Result<RunEnd<Const<4>>, MethodFailure>> {
        Some(run_peer(
            DiscreteMechanics::new(),
            self,
            dt,
            z0,
            t0,
            stop,
            observer,
        ))
    }
}

/// `phi = 0`: a central force without force.
impl CentralForce<Const<4>> for FreeParticle {
    fn mass(&self) -> f64 {
        self.m
    }

    fn phi(&self, _r: f64) -> f64 {
        0.0
    }

    fn dphi(&self, _r: f64) -> f64 {
        0.0
    }

    fn phi_divided_difference(&self, _r0: f64, _r1: f64) -> f64 {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The catalogue's types agree with the hand-written references of `dth::systems` (same
    /// formula, different evaluation order): values, gradients and Hessians to a few eps of
    /// their size.
    #[test]
    fn catalogue_systems_match_the_hand_written_references() {
        fn close<const D: usize>(
            a: &impl Hamiltonian<Const<D>>,
            b: &impl Hamiltonian<Const<D>>,
            z: &SVector<f64, D>,
        ) {
            let tol = |x: f64| 1e-14 * x.abs().max(1.0);
            assert!(
                (a.value(z) - b.value(z)).abs() <= tol(a.value(z)),
                "value at {z}"
            );
            let (ga, gb) = (a.gradient(z), b.gradient(z));
            assert!((ga - gb).amax() <= tol(ga.amax()), "{ga} vs {gb}");
            let (ha, hb) = (a.hessian(z), b.hessian(z));
            assert!((ha - hb).amax() <= tol(ha.amax()), "{ha} vs {hb}");
        }
        let z4 = SVector::<f64, 4>::new(0.5, -0.3, 0.2, 1.1);
        let z2 = SVector::<f64, 2>::new(0.7, -0.4);
        close(
            &Kepler { m: 0.7, k: 1.3 },
            &dth::systems::Kepler { mass: 0.7, k: 1.3 },
            &z4,
        );
        close(
            &HarmonicOscillator { m: 2.0, k: 3.0 },
            &dth::systems::HarmonicOscillator { mass: 2.0, k: 3.0 },
            &z2,
        );
        close(
            &Pendulum {
                m: 1.5,
                l: 0.8,
                g: 9.81,
            },
            &dth::systems::Pendulum {
                mass: 1.5,
                length: 0.8,
                gravity: 9.81,
            },
            &z2,
        );
        close(&HenonHeiles, &dth::systems::HenonHeiles, &z4);
        let (m1, m2, l1, l2, g) = (1.0, 2.0, 0.5, 1.5, 9.81);
        close(
            &DoublePendulum { m1, m2, l1, l2, g },
            &dth::systems::DoublePendulum { m1, m2, l1, l2, g },
            &z4,
        );
        let z8 = SVector::<f64, 8>::from_fn(|i, _| 0.1 * i as f64 - 0.3);
        close(
            &TodaChain4,
            &dth::systems::TodaChain::<4>::new(dth::systems::TodaBoundary::Periodic),
            &z8,
        );
        let z20 = SVector::<f64, 20>::from_fn(|i, _| 0.05 * (i as f64).sin());
        close(
            &TodaChain10,
            &dth::systems::TodaChain::<10>::new(dth::systems::TodaBoundary::Periodic),
            &z20,
        );
        close(
            &ForcedOscillator {
                omega0: 1.2,
                f: 0.3,
                omega: 1.7,
            },
            &dth::systems::ForcedOscillator {
                omega0: 1.2,
                force: 0.3,
                omega: 1.7,
            },
            &z4,
        );
    }

    /// The chains against the hand-written Toda reference and the FPUT definitions written as
    /// loops here: value and gradient to a few eps of their size.
    #[test]
    fn catalogue_chains_match_their_definitions() {
        let z = SVector::<f64, 64>::from_fn(|i, _| 0.3 * ((i * i) as f64 * 0.37).sin());
        let tol = |x: f64| 1e-13 * x.abs().max(1.0);
        let toda = dth::systems::TodaChain::<32>::new(dth::systems::TodaBoundary::FixedEnds);
        let (a, b) = (TodaFixedEnds32.value(&z), toda.value(&z));
        assert!((a - b).abs() <= tol(a), "{a} vs {b}");
        let (ga, gb) = (TodaFixedEnds32.gradient(&z), toda.gradient(&z));
        assert!((ga - gb).amax() <= tol(ga.amax()));
        // FPUT: bonds d_i = q_{i+1} - q_i, i = 0..32, q_0 = q_33 = 0.
        let mut x = vec![0.0];
        x.extend(z.rows(0, 32).iter());
        x.push(0.0);
        let kinetic: f64 = z.rows(32, 32).iter().map(|p| p * p / 2.0).sum();
        let bonds = |v: &dyn Fn(f64) -> f64| x.windows(2).map(|w| v(w[1] - w[0])).sum::<f64>();
        let alpha = FputAlpha32 { alpha: 0.3 };
        let want = kinetic + bonds(&|d| d * d / 2.0 + 0.3 * d * d * d / 3.0);
        assert!((alpha.value(&z) - want).abs() <= tol(want));
        let beta = FputBeta32 { beta: 1.7 };
        let want = kinetic + bonds(&|d| d * d / 2.0 + 1.7 * d.powi(4) / 4.0);
        assert!((beta.value(&z) - want).abs() <= tol(want));
        // Force on particle i: V'(d_i) - V'(d_{i-1}), i.e. -dH/dq_i = V'(d_i) - V'(d_{i-1}).
        let g = alpha.gradient(&z);
        let dv = |d: f64| d + 0.3 * d * d;
        for i in 1..=32 {
            let f = dv(x[i + 1] - x[i]) - dv(x[i] - x[i - 1]);
            assert!(
                (g[i - 1] + f).abs() <= 1e-14,
                "q{i}: {} vs {}",
                g[i - 1],
                -f
            );
        }
    }

    /// The FPUT-beta chain of `n` particles with fixed ends written out term by term (the
    /// last bond `0 - q_n` written `q_n`: even powers only).
    fn fput_beta_written_out(n: usize) -> String {
        let kinetic: Vec<String> = (1..=n).map(|i| format!("p{i}^2")).collect();
        let mut src = format!("({})/2 + q1^2/2 + beta*q1^4/4", kinetic.join(" + "));
        for i in 1..n {
            let d = format!("(q{} - q{i})", i + 1);
            src.push_str(&format!(" + {d}^2/2 + beta*{d}^4/4"));
        }
        src.push_str(&format!(" + q{n}^2/2 + beta*q{n}^4/4"));
        src
    }

    /// Every method of a looped catalogue chain against the engine's interpreter on the chain
    /// written out term by term (the text compiled at run time, no written-out type): the
    /// value, gradient, Hessian, Psi, the discrete gradient, the energy difference and the
    /// defect, at seeded points. Roundoff: the two add the same terms (each below about 1 at
    /// these points, `|z| < 0.4`) in different orders, so they differ by a few eps times the
    /// number of terms; `64 eps (1 + |x|)` bounds that with room.
    fn equals_written_out(typed: &impl Hamiltonian<Const<64>>, text: &str, params: &[(&str, f64)]) {
        let close =
            |a: f64, b: f64| (a - b).abs() <= 64.0 * f64::EPSILON * (1.0 + a.abs().max(b.abs()));
        let all_close = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| close(*x, *y))
        };
        let names: Vec<&str> = params.iter().map(|p| p.0).collect();
        let values: Vec<f64> = params.iter().map(|p| p.1).collect();
        let h = dth_symbolic::compile(text, &names).expect("the written-out chain compiles");
        let (all, pair, defect) = (
            h.program(dth_symbolic::Method::All),
            h.program(dth_symbolic::Method::DiscreteGradient),
            h.program(dth_symbolic::Method::DiscreteGradientDefect),
        );
        let mut rng = crate::ensemble::sample::SplitMix64::new(text.len() as u64);
        let mut point = || SVector::<f64, 64>::from_fn(|_, _| 0.8 * (rng.unit() - 0.5));
        for _ in 0..3 {
            let (z0, z1) = (point(), point());
            let e = all.eval(z0.as_slice(), &values).expect("engine evaluation");
            assert!(close(typed.value(&z0), e.value), "{text}: value");
            assert!(
                all_close(typed.gradient(&z0).as_slice(), &e.gradient),
                "{text}: gradient"
            );
            // Row-major in the engine, column-major in nalgebra: the same symmetric matrix.
            assert!(
                all_close(typed.hessian(&z0).as_slice(), &e.hessian),
                "{text}: Hessian"
            );
            assert!(close(typed.psi(&z0), e.psi), "{text}: Psi");
            let near = z0 + (z1 - z0) * 1e-7;
            for z1 in [z1, near, z0] {
                let (a, b) = (z0.as_slice(), z1.as_slice());
                let p = pair
                    .eval_pair(a, b, &values)
                    .expect("engine pair evaluation");
                let gbar = typed.discrete_gradient(&z0, &z1);
                assert!(
                    all_close(gbar.as_slice(), &p.discrete_gradient),
                    "{text}: gbar"
                );
                assert!(
                    close(typed.energy_difference(&z0, &z1), p.energy_difference),
                    "{text}: energy difference"
                );
                let d = defect
                    .eval_pair(a, b, &values)
                    .expect("engine defect evaluation");
                let t = typed.discrete_gradient_defect(&z0, &z1, &gbar);
                assert!(
                    all_close(t.as_slice(), &d.discrete_gradient_defect),
                    "{text}: defect"
                );
            }
        }
    }

    #[test]
    fn looped_chains_equal_the_chains_written_out() {
        use dth_symbolic::sources::{fput_alpha_fixed_ends, toda_fixed_ends};
        // `fput_alpha_fixed_ends` fixes alpha = 1/4 (FPUT's).
        equals_written_out(
            &FputAlpha32 { alpha: 0.25 },
            &fput_alpha_fixed_ends(32),
            &[],
        );
        equals_written_out(
            &FputBeta32 { beta: 1.7 },
            &fput_beta_written_out(32),
            &[("beta", 1.7)],
        );
        equals_written_out(&TodaFixedEnds32, &toda_fixed_ends(32), &[]);
    }

    /// The N-body formulas against their definition written as loops here.
    #[test]
    fn nbody_values_match_their_definition() {
        fn check<const D: usize>(h: &impl Hamiltonian<Const<D>>, dim: usize, m: [f64; 3], g: f64) {
            let nq = D / 2;
            // Bodies apart: offsets of 1 along the first axis on top of a small state.
            let z = SVector::<f64, D>::from_fn(|i, _| {
                0.3 * ((i * 5 + 1) as f64).sin()
                    + if i < nq && i.is_multiple_of(dim) {
                        (i / dim) as f64
                    } else {
                        0.0
                    }
            });
            let (q, p) = z.as_slice().split_at(nq);
            let mut want = 0.0;
            for i in 0..3 {
                let pi = &p[dim * i..dim * (i + 1)];
                want += pi.iter().map(|x| x * x).sum::<f64>() / (2.0 * m[i]);
                for j in i + 1..3 {
                    let r2: f64 = (0..dim)
                        .map(|c| (q[dim * i + c] - q[dim * j + c]).powi(2))
                        .sum();
                    want -= g * m[i] * m[j] / r2.sqrt();
                }
            }
            let v = h.value(&z);
            // A dozen terms of size below 10: roundoff is a few eps times 10.
            assert!((v - want).abs() < 1e-14 * 10.0, "dim {dim}: {v} vs {want}");
        }
        let (m1, m2, m3, g) = (1.0, 2.0, 0.5, 1.3);
        check(&NBody2d3 { m1, m2, m3, g }, 2, [m1, m2, m3], g);
        check(&NBody3d3 { m1, m2, m3, g }, 3, [m1, m2, m3], g);
    }

    /// The N-body invariants are conserved by the flow: `dI/dt = grad I . J grad H` vanishes to
    /// roundoff at a random state (momentum: Newton's third law in the derived
    /// gradient; angular momentum: its rotation invariance).
    #[test]
    fn nbody_invariants_are_conserved_by_the_flow() {
        fn check<const D: usize, S: SceneSystem<Const<D>>>(s: &S, z: SVector<f64, D>) {
            let n = D / 2;
            let g = s.gradient(&z);
            // zdot = J grad H = (dH/dp, -dH/dq).
            let zdot = SVector::<f64, D>::from_fn(|i, _| if i < n { g[n + i] } else { -g[i - n] });
            let names = s.invariant_names();
            let h = 0.5;
            for (k, name) in names.iter().enumerate() {
                // The invariants are linear or quadratic in z: the central difference of
                // I(z + h zdot) is grad I . zdot for any h, up to roundoff (eps times the
                // size of I and its terms, here below 10).
                let at = |z: SVector<f64, D>| {
                    let mut out = vec![0.0; names.len()];
                    s.invariants(&z, &mut out);
                    out[k]
                };
                let rate = (at(z + zdot * h) - at(z - zdot * h)) / (2.0 * h);
                assert!(rate.abs() < 1e-13, "{name}: dI/dt = {rate:e}");
            }
        }
        let spread = |i: usize| {
            0.4 * ((i * 7 + 3) as f64).sin()
                + if i.is_multiple_of(3) {
                    i as f64 * 0.3
                } else {
                    0.0
                }
        };
        check(
            &NBody2d3 {
                m1: 1.0,
                m2: 2.0,
                m3: 0.5,
                g: 1.3,
            },
            SVector::<f64, 12>::from_fn(|i, _| spread(i)),
        );
        check(
            &NBody3d3 {
                m1: 1.0,
                m2: 2.0,
                m3: 0.5,
                g: 1.3,
            },
            SVector::<f64, 18>::from_fn(|i, _| spread(i)),
        );
    }

    // The flags validation relies on, as `hamiltonian!` derived them from the formulas
    // (checked when the tests compile).
    use dth::ConstFlags;
    const _: () = {
        assert!(FreeParticle::FLAGS.psi_identically_zero && FreeParticle::FLAGS.separable);
        assert!(!Kepler::FLAGS.psi_identically_zero && Kepler::FLAGS.separable);
        assert!(!DoublePendulum::FLAGS.separable);
        assert!(ForcedOscillator::FLAGS.time_dependent && !Kepler::FLAGS.time_dependent);
    };

    #[test]
    fn kepler_period_is_the_thesis_period() {
        // T = 2 pi sqrt(m a^3 / k) = 3.7483 for q = (0.5, 0), p = (0, 1.2): H = -0.56,
        // a = 1/1.12 (docs/thesis.md#kepler-orbit).
        let t = Kepler::thesis()
            .period(&SVector::<f64, 4>::new(0.5, 0.0, 0.0, 1.2))
            .unwrap_or(f64::NAN);
        assert!((t - 3.7483).abs() < 1e-4, "{t}");
    }

    #[test]
    fn kepler_central_force_is_its_hamiltonian() {
        // H = |p|^2/(2m) + phi(|q|) at a point, and the divided difference of phi is exact.
        let k = Kepler { m: 0.7, k: 1.3 };
        let z = SVector::<f64, 4>::new(0.3, 0.4, 0.2, -0.1);
        let by_parts = (0.04 + 0.01) / (2.0 * 0.7) + k.phi(0.5);
        assert!((k.value(&z) - by_parts).abs() < 1e-15);
        let (r0, r1) = (0.5, 0.75);
        let dd = (k.phi(r1) - k.phi(r0)) / (r1 - r0);
        assert!((k.phi_divided_difference(r0, r1) - dd).abs() < 1e-14 * dd.abs());
    }
}
