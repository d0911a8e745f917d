//! Integrate a Hamiltonian written as a math literal with DTH and two peers, to the same time,
//! and compare their energy errors: `cargo run --release -p dth --example compare_methods`.

use dth::nalgebra::Vector4;
use dth::{solve, DthOptions, Method};

pub fn main() -> Result<(), dth::Error> {
    // Kepler in the thesis's units; exact derivatives generated at compile time.
    let kepler = dth::hamiltonian!(p1 ^ 2 + p2 ^ 2 - (q1 ^ 2 + q2 ^ 2) ^ (-1 / 2));
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2); // e = 0.44, period 3.75
    for method in [
        Method::Dth(DthOptions::new(0.02)?),
        Method::Midpoint { dt: 0.02 },
        Method::GaussLegendre2 { dt: 0.02 },
    ] {
        let run = solve(&kepler, z0, method).until(37.5).run()?;
        println!(
            "{:>16}: {:5} steps, max |H - H0| = {:.1e}",
            run.method,
            run.steps,
            run.max_energy_error()
        );
    }
    Ok(())
}
