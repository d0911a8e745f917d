//! The catalogue's systems (`dth-examples/src/systems.rs`) as text, with parameter values:
//! what a scene would give the runtime. Shared by the JIT tests here and, by path, by
//! `dth-examples` (its test that the runtime returns the macro types' bits, and the runtime
//! bench), so every comparison uses the same text.
#![allow(dead_code)]

/// One system: the catalogue's name, the Hamiltonian as text, and parameter values.
pub struct Entry {
    /// The catalogue's name.
    pub name: &'static str,
    /// `H` in the grammar of `hamiltonian!`.
    pub src: &'static str,
    /// Parameter names and values (the macro types' fields).
    pub params: &'static [(&'static str, f64)],
}

/// Every system of the catalogue.
pub const CATALOGUE: [Entry; 9] = [
    Entry {
        name: "kepler",
        src: "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)",
        params: &[("m", 0.5), ("k", 1.0)],
    },
    Entry {
        name: "harmonic_oscillator",
        src: "p1^2/(2*m) + k*q1^2/2",
        params: &[("m", 2.0), ("k", 3.0)],
    },
    Entry {
        name: "pendulum",
        src: "p1^2/(2*m*l^2) - m*g*l*cos(q1)",
        params: &[("m", 1.5), ("l", 0.8), ("g", 9.81)],
    },
    Entry {
        name: "henon_heiles",
        src: "(p1^2 + p2^2)/2 + (q1^2 + q2^2)/2 + q1^2*q2 - q2^3/3",
        params: &[],
    },
    Entry {
        name: "double_pendulum",
        src: "(m2*l2^2*p1^2 + (m1 + m2)*l1^2*p2^2 - 2*m2*l1*l2*p1*p2*cos(q1 - q2))
                / (2*m2*l1^2*l2^2*(m1 + m2*sin(q1 - q2)^2))
              - (m1 + m2)*g*l1*cos(q1) - m2*g*l2*cos(q2)",
        params: &[
            ("m1", 1.0),
            ("m2", 2.0),
            ("l1", 0.5),
            ("l2", 1.5),
            ("g", 9.81),
        ],
    },
    Entry {
        name: "toda_chain_4",
        src: "(p1^2 + p2^2 + p3^2 + p4^2)/2
              + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4 - q1)",
        params: &[],
    },
    Entry {
        name: "toda_chain_10",
        src: "(p1^2 + p2^2 + p3^2 + p4^2 + p5^2 + p6^2 + p7^2 + p8^2 + p9^2 + p10^2)/2
              + exp(q1 - q2) + exp(q2 - q3) + exp(q3 - q4) + exp(q4 - q5) + exp(q5 - q6)
              + exp(q6 - q7) + exp(q7 - q8) + exp(q8 - q9) + exp(q9 - q10) + exp(q10 - q1)",
        params: &[],
    },
    Entry {
        name: "forced_oscillator",
        src: "p1^2/2 + omega0^2*q1^2/2 - f*q1*cos(omega*t)",
        params: &[("omega0", 1.0), ("f", 0.5), ("omega", 1.3)],
    },
    Entry {
        name: "free_particle",
        src: "(p1^2 + p2^2)/(2*m)",
        params: &[("m", 1.5)],
    },
];

/// A small deterministic generator (xorshift64*), so points are the same on every run.
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11;
        lo + (hi - lo) * (bits as f64 / (1u64 << 53) as f64)
    }

    /// `d` coordinates uniform in `[-1.5, 1.5)`.
    pub fn point(&mut self, d: usize) -> Vec<f64> {
        (0..d).map(|_| self.uniform(-1.5, 1.5)).collect()
    }
}
