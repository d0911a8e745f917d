//! The linear normal modes of a chain with fixed ends, and the energy in each: what the
//! `normal_modes` effect records and the Fermi-Pasta-Ulam-Tsingou experiment is read in.
//!
//! # Conventions
//! A chain of `N` unit masses with displacements `q_1..q_N`, momenta `p_1..p_N` and fixed ends
//! `q_0 = q_{N+1} = 0`, whose potential is to second order the harmonic chain
//! `sum_{i=0}^{N} (q_{i+1} - q_i)^2 / 2` (unit springs: FPUT-alpha, FPUT-beta, the Toda
//! chain between walls). Its normal modes `k = 1..N` are, as in Fermi, Pasta and Ulam (1955),
//! the review of Berman and Izrailev (2005) and Dauxois (2008):
//!
//! - amplitudes `Q_k = sqrt(2/(N+1)) sum_{i=1}^{N} q_i sin(i k pi/(N+1))` and
//!   `P_k = sqrt(2/(N+1)) sum_i p_i sin(i k pi/(N+1))` (the sine transform is orthonormal and
//!   its own inverse, so the change of variables is canonical);
//! - frequencies `omega_k = 2 sin(k pi/(2(N+1)))`;
//! - energies `E_k = (P_k^2 + omega_k^2 Q_k^2) / 2`.
//!
//! The `E_k` of all `N` modes sum to the harmonic part of `H` (kinetic energy plus the
//! quadratic springs); the anharmonic terms (`alpha`, `beta`, Toda's higher orders) are in no
//! mode. For the harmonic chain each `E_k` is constant.
//!
//! # References
//! - E. Fermi, J. Pasta, S. Ulam, *Studies of nonlinear problems I*, Los Alamos report
//!   LA-1940 (1955), with M. Tsingou.
//! - G. P. Berman, F. M. Izrailev, *The Fermi-Pasta-Ulam problem: fifty years of progress*,
//!   Chaos 15, 015104 (2005), arXiv:nlin/0411062.
//! - T. Dauxois, *Fermi, Pasta, Ulam, and a mysterious lady*, Physics Today 61(1), 55 (2008).
//!
//! ```
//! use dth_examples::normal_modes::ChainModes;
//! // Mode 2 of a chain of 8, at rest: all its energy is in mode 2.
//! let modes = ChainModes::new(8, 3);
//! let q: Vec<f64> = (1..=8).map(|i| (i as f64 * 2.0 * std::f64::consts::PI / 9.0).sin()).collect();
//! let mut e = [0.0; 3];
//! modes.energies(&q, &[0.0; 8], &mut e);
//! assert!(e[0].abs() < 1e-15 && e[2].abs() < 1e-15);
//! // Q_2 = sqrt(2/9) * 9/2, omega_2 = 2 sin(pi/9): E_2 = omega_2^2 Q_2^2 / 2.
//! let w = 2.0 * (std::f64::consts::PI / 9.0).sin();
//! assert!((e[1] - w * w * 4.5 / 2.0).abs() < 1e-14);
//! ```

use std::f64::consts::PI;

/// The first `modes` linear normal modes of a fixed-end chain of `n` particles: the sine
/// table and the frequencies, computed once, and the mode energies of a state.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainModes {
    n: usize,
    /// `sqrt(2/(n+1)) sin(i k pi/(n+1))`, row `k - 1`, column `i - 1`.
    sines: Vec<f64>,
    /// `omega_k`, `k = 1..modes`.
    omega: Vec<f64>,
}

impl ChainModes {
    /// The first `modes` modes of a chain of `n` particles (`modes` is at most `n`; more are
    /// dropped, as the chain has only `n`).
    pub fn new(n: usize, modes: usize) -> Self {
        let modes = modes.min(n);
        let m = (n + 1) as f64;
        let scale = (2.0 / m).sqrt();
        let sines = (1..=modes)
            .flat_map(|k| (1..=n).map(move |i| scale * ((i * k) as f64 * PI / m).sin()))
            .collect();
        let omega = (1..=modes)
            .map(|k| 2.0 * (k as f64 * PI / (2.0 * m)).sin())
            .collect();
        ChainModes { n, sines, omega }
    }

    /// The number of modes computed.
    pub fn modes(&self) -> usize {
        self.omega.len()
    }

    /// The frequencies `omega_k` of the modes computed.
    pub fn frequencies(&self) -> &[f64] {
        &self.omega
    }

    /// Writes `E_k = (P_k^2 + omega_k^2 Q_k^2)/2` of the state `(q, p)` for `k = 1..modes`
    /// into `out` (`q`, `p` of length `n`, `out` of length [`ChainModes::modes`]).
    pub fn energies(&self, q: &[f64], p: &[f64], out: &mut [f64]) {
        debug_assert!(
            q.len() == self.n && p.len() == self.n,
            "a state of the chain's size"
        );
        // `max(1)`: a chain of no particles has no modes (and `chunks_exact(0)` would panic).
        for ((e, row), w) in out
            .iter_mut()
            .zip(self.sines.chunks_exact(self.n.max(1)))
            .zip(&self.omega)
        {
            let dot = |x: &[f64]| row.iter().zip(x).map(|(s, x)| s * x).sum::<f64>();
            let (qk, pk) = (dot(q), dot(p));
            *e = 0.5 * (pk * pk + w * w * qk * qk);
        }
    }
}

/// Why a Hamiltonian whose gradient and Hessian at `z = 0` are `gradient` and `hessian`
/// (`D = 2n` entries and `D x D` column-major, `z = (q, p)`) is not, to second order about
/// rest, the unit chain with fixed ends whose modes [`ChainModes`] computes; `None` when it
/// is. That chain's expansion is `H = |p|^2/2 + q^T K q/2 + O(|z|^3)` with
/// `K = tridiag(-1, 2, -1)`: zero gradient, Hessian `[[K, 0], [0, I]]`. What a scene's
/// Hamiltonian given as text must satisfy for the `normal_modes` effect.
///
/// Entries are compared to roundoff: `4 eps (1 + |expected|)`, the error of evaluating a few
/// operations on numbers of size 1 (the derivatives of such chains at rest are exact small
/// integers: `1 + 2 alpha (q_2 - q_1)`, `exp(q_2 - q_1)` at 0).
///
/// ```
/// use dth_examples::normal_modes::unit_chain_mismatch;
/// // Two particles: K = [[2, -1], [-1, 2]], then the identity for p.
/// let mut h = vec![0.0; 16];
/// for (i, j, v) in [(0, 0, 2.0), (1, 1, 2.0), (0, 1, -1.0), (1, 0, -1.0), (2, 2, 1.0), (3, 3, 1.0)] {
///     h[i + 4 * j] = v;
/// }
/// assert_eq!(unit_chain_mismatch(2, &[0.0; 4], &h), None);
/// h[0] = 3.0; // a spring to a wall of stiffness 2
/// assert!(unit_chain_mismatch(2, &[0.0; 4], &h).unwrap().contains("d2H/dq1dq1 = 3"));
/// ```
pub fn unit_chain_mismatch(n: usize, gradient: &[f64], hessian: &[f64]) -> Option<String> {
    let d = 2 * n;
    if gradient.len() != d || hessian.len() != d * d {
        return Some(format!(
            "it has {} coordinates, not the 2 x {n} of a chain of {n} particles",
            gradient.len()
        ));
    }
    let entries = (0..d).flat_map(|j| (0..d).map(move |i| (i, j, hessian[i + d * j])));
    unit_chain_mismatch_sparse(n, gradient, entries)
}

/// [`unit_chain_mismatch`] for a Hessian given by its nonzero entries `(i, j, value)` (every
/// entry not listed is zero; `(i, j)` and `(j, i)` may both be listed or either): what a
/// lattice of thousands of sites gives, whose dense Hessian would not fit in memory
/// (`D = 8192` is 512 MB).
///
/// ```
/// use dth_examples::normal_modes::unit_chain_mismatch_sparse;
/// let chain = [(0, 0, 2.0), (1, 1, 2.0), (0, 1, -1.0), (2, 2, 1.0), (3, 3, 1.0)];
/// assert_eq!(unit_chain_mismatch_sparse(2, &[0.0; 4], chain.into_iter()), None);
/// // The coupling left out: an entry of the chain is missing.
/// let loose = [(0, 0, 2.0), (1, 1, 2.0), (2, 2, 1.0), (3, 3, 1.0)];
/// assert!(unit_chain_mismatch_sparse(2, &[0.0; 4], loose.into_iter()).unwrap().contains("d2H/dq1dq2 = 0"));
/// ```
pub fn unit_chain_mismatch_sparse(
    n: usize,
    gradient: &[f64],
    entries: impl Iterator<Item = (usize, usize, f64)>,
) -> Option<String> {
    let d = 2 * n;
    if gradient.len() != d {
        return Some(format!(
            "it has {} coordinates, not the 2 x {n} of a chain of {n} particles",
            gradient.len()
        ));
    }
    let close = |x: f64, e: f64| (x - e).abs() <= 4.0 * f64::EPSILON * (1.0 + e.abs());
    let name = |i: usize| {
        if i < n {
            format!("q{}", i + 1)
        } else {
            format!("p{}", i - n + 1)
        }
    };
    if let Some((i, g)) = gradient.iter().enumerate().find(|&(_, &g)| !close(g, 0.0)) {
        return Some(format!(
            "rest is not an equilibrium: dH/d{} = {g} at z = 0",
            name(i)
        ));
    }
    let expected = |i: usize, j: usize| match (i < n, j < n) {
        (true, true) if i == j => 2.0,
        (true, true) if i.abs_diff(j) == 1 => -1.0,
        (false, false) if i == j => 1.0,
        _ => 0.0,
    };
    let wrong = |i: usize, j: usize, v: f64| {
        let e = expected(i, j);
        format!(
            "its expansion at rest is not the unit chain's: d2H/d{}d{} = {v} at z = 0, the chain has {e}",
            name(i),
            name(j)
        )
    };
    // The chain's nonzeros (upper triangle) seen among the entries.
    let mut seen = std::collections::HashSet::new();
    for (i, j, v) in entries {
        let (i, j) = (i.min(j), i.max(j));
        if !close(v, expected(i, j)) {
            return Some(wrong(i, j, v));
        }
        seen.insert((i, j));
    }
    let chain = (0..d).map(|i| (i, i)).chain((1..n).map(|i| (i - 1, i)));
    for (i, j) in chain {
        if !seen.contains(&(i, j)) {
            return Some(wrong(i, j, 0.0));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ensemble::sample::SplitMix64;

    /// A seeded state of `n` particles in `[-0.5, 0.5)`.
    fn state(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = SplitMix64::new(seed);
        (0..n).map(|_| rng.unit() - 0.5).collect()
    }

    /// All `N` mode energies sum to the harmonic chain's energy
    /// `sum p_i^2/2 + sum_{i=0}^{N} (q_{i+1} - q_i)^2/2`: the transform is orthonormal and
    /// diagonalises the fixed-end chain. Roundoff: sums of `N` terms of size ~1, a few eps N.
    #[test]
    fn all_mode_energies_sum_to_the_harmonic_energy() {
        for n in [1, 2, 7, 32] {
            let (q, p) = (state(n, 1), state(n, 2));
            let modes = ChainModes::new(n, n);
            let mut e = vec![0.0; n];
            modes.energies(&q, &p, &mut e);
            let mut x = vec![0.0];
            x.extend(&q);
            x.push(0.0);
            let springs: f64 = x.windows(2).map(|w| (w[1] - w[0]).powi(2) / 2.0).sum();
            let kinetic: f64 = p.iter().map(|p| p * p / 2.0).sum();
            let total: f64 = e.iter().sum();
            assert!(
                (total - springs - kinetic).abs() < 1e-14 * n as f64,
                "n = {n}: {total} vs {}",
                springs + kinetic
            );
        }
    }

    /// The harmonic chain's exact solution keeps each `E_k`: a state with `Q_k = a_k`,
    /// `P_k = 0` at `t = 0` is `Q_k(t) = a_k cos(omega_k t)`, `P_k = -a_k omega_k sin(omega_k t)`
    /// in the original coordinates; its mode energies are `omega_k^2 a_k^2 / 2` at every `t`.
    #[test]
    fn harmonic_chain_solution_keeps_every_mode_energy() {
        let n = 12;
        let modes = ChainModes::new(n, n);
        let a: Vec<f64> = (1..=n).map(|k| 1.0 / k as f64).collect();
        let m = (n + 1) as f64;
        let s = |i: usize, k: usize| (2.0 / m).sqrt() * ((i * k) as f64 * PI / m).sin();
        let w = modes.frequencies().to_vec();
        for t in [0.0, 0.7, 13.0, 250.0] {
            let q: Vec<f64> = (1..=n)
                .map(|i| {
                    (1..=n)
                        .map(|k| s(i, k) * a[k - 1] * (w[k - 1] * t).cos())
                        .sum()
                })
                .collect();
            let p: Vec<f64> = (1..=n)
                .map(|i| {
                    (1..=n)
                        .map(|k| -s(i, k) * a[k - 1] * w[k - 1] * (w[k - 1] * t).sin())
                        .sum()
                })
                .collect();
            let mut e = vec![0.0; n];
            modes.energies(&q, &p, &mut e);
            for k in 0..n {
                let want = 0.5 * w[k] * w[k] * a[k] * a[k];
                assert!(
                    (e[k] - want).abs() < 1e-14,
                    "t = {t}, mode {}: {}",
                    k + 1,
                    e[k]
                );
            }
        }
    }

    #[test]
    fn fput_mode_one_frequency_and_energy() {
        // N = 32: omega_1 = 2 sin(pi/66); q_i = sin(i pi/33) has Q_1 = sqrt(33/2), so
        // E_1 = omega_1^2 * 33/4 = 0.0747 (the FPUT scene's initial energy).
        let modes = ChainModes::new(32, 1);
        let w1 = 2.0 * (PI / 66.0).sin();
        assert_eq!(modes.frequencies(), &[w1]);
        let q: Vec<f64> = (1..=32).map(|i| (i as f64 * PI / 33.0).sin()).collect();
        let mut e = [0.0];
        modes.energies(&q, &[0.0; 32], &mut e);
        assert!((e[0] - w1 * w1 * 33.0 / 4.0).abs() < 1e-15, "{}", e[0]);
        assert!((e[0] - 0.0747).abs() < 1e-4);
    }
}
