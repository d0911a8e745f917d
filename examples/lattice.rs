//! A lattice written once: the Fermi-Pasta-Ulam-Tsingou alpha chain of 32 particles, started
//! in its lowest normal mode (FPUT 1955, Figure 1); the energy flows into modes 2, 3, ... and
//! near t = 10,000 comes back almost entirely to mode 1
//! (`cargo run --release -p dth --example lattice`).

use dth::nalgebra::SVector;
use dth::{solve, DthOptions, Hamiltonian, Method};

const N: usize = 32;

dth::hamiltonian! {
    /// FPUT-alpha chain between fixed walls.
    pub struct Fput { alpha: f64 } =
        sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3) + sum(i = 1..N, p[i]^2/2)
        where N = 32, q[0] = q[N+1] = 0
}

/// The harmonic energy of normal mode `k` (1-based) of the fixed-end chain.
fn mode_energy(z: &SVector<f64, { 2 * N }>, k: usize) -> f64 {
    let scale = (2.0 / (N as f64 + 1.0)).sqrt();
    let angle = |i: usize| (i * k) as f64 * std::f64::consts::PI / (N as f64 + 1.0);
    let (mut a, mut b) = (0.0, 0.0);
    for i in 1..=N {
        a += scale * z[i - 1] * angle(i).sin();
        b += scale * z[N + i - 1] * angle(i).sin();
    }
    let omega = 2.0 * (k as f64 * std::f64::consts::PI / (2.0 * (N as f64 + 1.0))).sin();
    0.5 * (b * b + omega * omega * a * a)
}

pub fn main() -> Result<(), dth::Error> {
    let chain = Fput { alpha: 0.25 };
    // FPUT's single sine wave: q_i = sin(i pi/(N+1)), at rest (E1 = 0.0747).
    let z0 = SVector::<f64, { 2 * N }>::from_fn(|j, _| {
        let i = j + 1;
        if i <= N {
            (i as f64 * std::f64::consts::PI / (N as f64 + 1.0)).sin()
        } else {
            0.0
        }
    });
    let times: Vec<f64> = (0..=10).map(|k| 1000.0 * k as f64).collect();
    let run = solve(&chain, z0, Method::Dth(DthOptions::new(0.35)?))
        .save_at(times)
        .run()?;
    println!("     t   E1       E2       E3       E4      |H - H0|");
    for (t, z) in run.t.iter().zip(&run.z) {
        let e: Vec<String> = (1..=4)
            .map(|k| format!("{:.2e}", mode_energy(z, k)))
            .collect();
        println!(
            "{t:6.0}  {}  {:.1e}",
            e.join(" "),
            (chain.value(z) - run.energy0).abs()
        );
    }
    Ok(())
}
