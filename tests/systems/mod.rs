//! `hamiltonian!` versions of the hand-written reference systems of `dth::systems`, one
//! definition each, shared by `tests/macro_systems.rs` and the `derivatives` bench of
//! `dth-examples` (which includes this file by path). Each type carries the same parameters as
//! its hand-written twin, under the same names.

/// `dth::systems::Kepler`: `H = |p|^2 / (2 m) - k / |q|`.
pub mod kepler {
    dth::hamiltonian! {
        /// Planar Kepler problem.
        #[derive(Clone, Copy, Debug)]
        pub struct Kepler { pub mass: f64, pub k: f64 } =
            (p1^2 + p2^2)/(2*mass) - k*(q1^2 + q2^2)^(-1/2)
    }
}

/// `dth::systems::HarmonicOscillator`: `H = p^2 / (2 m) + k q^2 / 2`.
pub mod oscillator {
    dth::hamiltonian! {
        /// Harmonic oscillator.
        #[derive(Clone, Copy, Debug)]
        pub struct HarmonicOscillator { pub mass: f64, pub k: f64 } = p1^2/(2*mass) + k*q1^2/2
    }
}

/// `dth::systems::Pendulum`: `H = p^2 / (2 m l^2) - m g l cos q`.
pub mod pendulum {
    dth::hamiltonian! {
        /// Plane pendulum.
        #[derive(Clone, Copy, Debug)]
        pub struct Pendulum { pub mass: f64, pub length: f64, pub gravity: f64 } =
            p1^2/(2*mass*length^2) - mass*gravity*length*cos(q1)
    }
}

/// `dth::systems::HenonHeiles`.
pub mod henon_heiles {
    dth::hamiltonian! {
        /// Henon-Heiles.
        #[derive(Clone, Copy, Debug, Default)]
        pub struct HenonHeiles = (p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3
    }
}

/// `dth::systems::DoublePendulum` in canonical coordinates (angles and conjugate momenta).
pub mod double_pendulum {
    dth::hamiltonian! {
        /// Planar double pendulum.
        #[derive(Clone, Copy, Debug)]
        pub struct DoublePendulum { pub m1: f64, pub m2: f64, pub l1: f64, pub l2: f64, pub g: f64 } =
            (m2*l2^2*p1^2 + (m1 + m2)*l1^2*p2^2 - 2*m2*l1*l2*p1*p2*cos(q1 - q2))
                / (2*m2*l1^2*l2^2*(m1 + m2*sin(q1 - q2)^2))
            - (m1 + m2)*g*l1*cos(q1) - m2*g*l2*cos(q2)
    }
}

/// `dth::systems::TodaChain::<10>`, both boundary conditions (`D = 20`).
pub mod toda {
    dth::hamiltonian! {
        /// Periodic Toda chain of 10 unit masses: bonds `(i, i+1)`, `q11 = q1`.
        #[derive(Clone, Copy, Debug, Default)]
        pub struct TodaPeriodic10 =
            (p1^2 + p2^2 + p3^2 + p4^2 + p5^2 + p6^2 + p7^2 + p8^2 + p9^2 + p10^2)/2
            + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4 - q5) + exp(q5 - q6)
            + exp(q6 - q7) + exp(q7 - q8) + exp(q8 - q9) + exp(q9 - q10) + exp(q10 - q1)
    }

    dth::hamiltonian! {
        /// Toda chain of 10 unit masses between walls at `q0 = q11 = 0`.
        #[derive(Clone, Copy, Debug, Default)]
        pub struct TodaFixed10 =
            (p1^2 + p2^2 + p3^2 + p4^2 + p5^2 + p6^2 + p7^2 + p8^2 + p9^2 + p10^2)/2
            + exp(-q1) + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4 - q5) + exp(q5 - q6)
            + exp(q6 - q7) + exp(q7 - q8) + exp(q8 - q9) + exp(q9 - q10) + exp(q10)
    }
}

/// `dth::systems::ForcedOscillator`: `H = p^2/2 + omega0^2 q^2/2 - F q cos(omega t)` on the
/// extended phase space `z = (q, t, p, p_t)`.
pub mod forced_oscillator {
    dth::hamiltonian! {
        /// Periodically forced oscillator.
        #[derive(Clone, Copy, Debug)]
        pub struct ForcedOscillator { pub omega0: f64, pub force: f64, pub omega: f64 } =
            p1^2/2 + omega0^2*q1^2/2 - force*q1*cos(omega*t)
    }
}
