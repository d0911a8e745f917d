//! The 50-body gravitating cluster of the robust-mode tests (`robust_energy.rs`, and
//! `dth-examples/tests/robust_cluster_convergence.rs`): unit masses in the plane, `G = 1`, a
//! hard binary planted in it, its `H` read from text.

use dth::nalgebra::{DVector, Dyn};
use dth::runtime::{Backend, RuntimeHamiltonian};
use dth::Hamiltonian;

/// Bodies in the cluster (unit masses, `G = 1`, in the plane).
pub const BODIES: usize = 50;

/// The cluster's `H`: kinetic energy plus the 1,225 pair potentials.
pub fn cluster_text() -> String {
    format!(
        "sum(k = 1..M, p[k]^2/2) \
         - sum(1 <= i < j <= N, ((q[2*i-1] - q[2*j-1])^2 + (q[2*i] - q[2*j])^2)^(-1/2)) \
         where N = {BODIES}, M = {}",
        2 * BODIES
    )
}

/// The cluster's `H`, compiled by the JIT: its pair sum loops (`dth_symbolic::looped`), so the
/// code is one pair's summand in a loop over the 1,225 pairs, compiled in milliseconds.
pub fn cluster() -> RuntimeHamiltonian {
    let h = RuntimeHamiltonian::new(&cluster_text(), &[]).expect("the cluster's text compiles");
    assert!(h.looped().is_some() && h.backend() == Backend::Jit);
    h
}

/// A uniform number in `[0, 1)` from a seeded SplitMix64 sequence.
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The cluster's initial state: bodies uniform in the unit disc, velocities uniform in a
/// square scaled to virial equilibrium for all but bodies 1 and 2, which are replaced by a
/// binary of semi-major axis `1e-3` and eccentricity `0.99` about their centre of mass, at
/// pericentre (`1e-5`): the run starts in a close encounter (a cluster's own encounters come
/// and go with its last bits; the binary makes the test's independent of them).
/// `H0 = -1464`.
pub fn cluster_state(h: &RuntimeHamiltonian) -> DVector<f64> {
    let m = 2 * BODIES;
    let mut rng = SplitMix(3);
    let mut z = DVector::zeros(2 * m);
    for b in 0..BODIES {
        let (x, y) = loop {
            let (x, y) = (2.0 * rng.next() - 1.0, 2.0 * rng.next() - 1.0);
            if x * x + y * y <= 1.0 {
                break (x, y);
            }
        };
        z[2 * b] = x;
        z[2 * b + 1] = y;
        z[m + 2 * b] = 2.0 * rng.next() - 1.0;
        z[m + 2 * b + 1] = 2.0 * rng.next() - 1.0;
    }
    let (a, e) = (1e-3f64, 0.99);
    let pericentre = a * (1.0 - e);
    // Vis-viva for the relative orbit, total mass 2.
    let v = (2.0 * (2.0 / pericentre - 1.0 / a)).sqrt();
    let (cx, cy) = (0.5 * (z[0] + z[2]), 0.5 * (z[1] + z[3]));
    let (ux, uy) = (0.5 * (z[m] + z[m + 2]), 0.5 * (z[m + 1] + z[m + 3]));
    z[0] = cx + 0.5 * pericentre;
    z[1] = cy;
    z[2] = cx - 0.5 * pericentre;
    z[3] = cy;
    z[m] = ux;
    z[m + 1] = uy + 0.5 * v;
    z[m + 2] = ux;
    z[m + 3] = uy - 0.5 * v;
    // Virial equilibrium for the 48 other bodies: scale their velocities.
    let others = |z: &DVector<f64>| (4..m).map(|k| 0.5 * z[m + k] * z[m + k]).sum::<f64>();
    let binary = 0.25 * v * v - 1.0 / pericentre;
    let potential = Hamiltonian::<Dyn>::value(h, &z) - others(&z) - binary;
    let scale = (0.5 * potential.abs() / others(&z)).sqrt();
    for k in 4..m {
        z[m + k] *= scale;
    }
    z
}
