//! The Rust side of the Python package's speed comparison (`dth-python/benches/python_vs_rust.py`):
//! the thesis's Kepler as text (`dth::runtime`, the path `dth.Hamiltonian` wraps, viewed at
//! `Const<4>` through `Fixed` as the package runs a 4-D state), DTH with `dtau = 0.06277` for
//! the given number of steps through `dth::solve`, keeping only the first
//! and last states, as `dth.integrate(..., every=steps)` does. Prints the seconds taken and the
//! final state (so both sides can be checked to agree).
//!
//! `cargo run --release -p dth-examples --example python_baseline -- 1000000`

use std::time::Instant;

use dth::nalgebra::Vector4;
use dth::runtime::{Fixed, RuntimeHamiltonian};
use dth::{solve, DthOptions, Method};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let steps: usize = match std::env::args().nth(1) {
        Some(s) => s.parse()?,
        None => 1_000_000,
    };
    let h = Fixed::<4>::new(RuntimeHamiltonian::new(
        "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)",
        &[("m", 0.5), ("k", 1.0)],
    )?)?;
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let started = Instant::now();
    let run = solve(&h, z0, Method::Dth(DthOptions::new(0.06277)?))
        .steps(steps)
        .save_every(steps)
        .run()?;
    let seconds = started.elapsed().as_secs_f64();
    let last = run.z.last().ok_or("no state")?;
    println!(
        "seconds {seconds:.6} steps {} final {:e} {:e} {:e} {:e}",
        run.steps, last[0], last[1], last[2], last[3]
    );
    Ok(())
}
