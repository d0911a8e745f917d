//! Side by side: the FPUT chain as a looped text (compiled in loops, structured Newton) and
//! written out term by term (the path every text took before: dense Newton), the time of one
//! DTH step at N = 512, and the JIT's compile time of the looped text against N.
//!
//! `cargo run --release -p dth-runtime --example looped_step`

use std::time::Instant;

use dth_core::dth::{Dth, DthOptions};
use dth_core::nalgebra::DVector;
use dth_runtime::RuntimeHamiltonian;

fn fput(n: usize) -> String {
    format!(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/12) \
         where N = {n}, q[0] = q[N+1] = 0"
    )
}

fn start(n: usize) -> DVector<f64> {
    DVector::from_fn(2 * n, |k, _| {
        if k < n {
            0.1 * ((k + 1) as f64 * std::f64::consts::PI / (n + 1) as f64).sin()
        } else {
            0.0
        }
    })
}

/// Seconds per DTH step over `steps` steps (after one untimed step).
fn step_time(
    h: RuntimeHamiltonian,
    n: usize,
    steps: usize,
) -> Result<f64, Box<dyn std::error::Error>> {
    let mut dth = Dth::new(h, start(n), DthOptions::new(0.05)?)?;
    dth.advance(1)?;
    let t = Instant::now();
    dth.advance(steps)?;
    Ok(t.elapsed().as_secs_f64() / steps as f64)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for n in [64, 1024, 4096, 16384] {
        let t = Instant::now();
        let h = RuntimeHamiltonian::new(&fput(n), &[])?;
        let build = t.elapsed().as_secs_f64();
        println!(
            "looped text, N = {n:5}: built (parse, plans, JIT) in {:7.2} ms",
            1e3 * build
        );
        drop(h);
    }
    let n = 512;
    let looped = RuntimeHamiltonian::new(&fput(n), &[])?;
    assert!(looped.looped().is_some());
    let new = step_time(looped, n, 200)?;
    println!(
        "N = {n}: looped text, structured Newton: {:9.3} ms per DTH step",
        1e3 * new
    );
    let t = Instant::now();
    let written = RuntimeHamiltonian::new(&dth_symbolic::sources::fput_alpha_fixed_ends(n), &[])?;
    println!(
        "N = {n}: written-out text built in {:.2} s",
        t.elapsed().as_secs_f64()
    );
    assert!(written.looped().is_none());
    let old = step_time(written, n, 3)?;
    println!(
        "N = {n}: written-out text, dense Newton: {:9.3} ms per DTH step",
        1e3 * old
    );
    println!("speed-up: {:.0}x", old / new);
    Ok(())
}
