//! A Hamiltonian read from text, swept over a parameter: the period of the quartic
//! oscillator `H = p^2/2 + q^2/2 + a q^4/4` against Lindstedt's first-order
//! `T = 2 pi (1 - 3 a A^2 / 8)`, for amplitude `A = 0.3`:
//! `cargo run --release -p dth --example parameter_sweep`.

use dth::nalgebra::DVector;
use dth::runtime::RuntimeHamiltonian;
use dth::{solve, DthOptions, Method};

pub fn main() -> Result<(), dth::Error> {
    let mut h = RuntimeHamiltonian::new("p1^2/2 + q1^2/2 + a*q1^4/4", &[("a", 0.0)])?;
    let amplitude = 0.3;
    let z0 = DVector::from_column_slice(&[amplitude, 0.0]);
    for a in [0.0, 0.1, 0.2, 0.4] {
        h.set_parameter("a", a)?;
        // Upward zero crossings of q, located by linear interpolation between states.
        let mut crossings = Vec::new();
        let mut last: Option<(f64, f64)> = None;
        solve(&h, z0.clone(), Method::Dth(DthOptions::new(0.01)?))
            .until(40.0)
            .save_every(usize::MAX)
            .observe(|r| {
                let q = r.z[0];
                if let Some((t0, q0)) = last {
                    if q0 < 0.0 && q >= 0.0 {
                        crossings.push(t0 + (r.t - t0) * (-q0) / (q - q0));
                    }
                }
                last = Some((r.t, q));
            })
            .run()?;
        let periods = crossings.len().saturating_sub(1).max(1) as f64;
        let period =
            (crossings.last().unwrap_or(&0.0) - crossings.first().unwrap_or(&0.0)) / periods;
        let lindstedt = 2.0 * std::f64::consts::PI * (1.0 - 3.0 * a * amplitude * amplitude / 8.0);
        println!("a = {a:.1}: period {period:.5}, Lindstedt {lindstedt:.5}");
    }
    Ok(())
}
