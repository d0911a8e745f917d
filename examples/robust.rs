//! DTH breaks down on an eccentric orbit (Psi changes sign); the robust mode goes through
//! with energy-conserving fallback steps and says how many it took:
//! `cargo run --release -p dth --example robust`.

use dth::nalgebra::Vector4;
use dth::observer::StepKind;
use dth::systems::Kepler;
use dth::{solve, DthOptions, Error, Method};

pub fn main() -> Result<(), Error> {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt()); // e = 0.9, period 59.6
    let options = DthOptions::new(0.01)?;

    // Plain DTH stops with a typed error; what it computed is kept.
    match solve(&kepler, z0, Method::Dth(options)).until(60.0).run() {
        Ok(_) => println!("plain DTH went through"),
        Err(stopped) => println!(
            "plain DTH: {} (kept {} states up to t = {:.3})",
            stopped.error,
            stopped.partial.len(),
            stopped.partial.end_time().unwrap_or(0.0)
        ),
    }

    // Robust mode: to the end, with a report of what it did.
    let run = solve(&kepler, z0, Method::Dth(options.with_robust(true)))
        .until(60.0)
        .run()?;
    let radius = |z: &Vector4<f64>| z[0].hypot(z[1]);
    let fallback_radii = run
        .z
        .iter()
        .zip(&run.kinds)
        .filter(|(_, kind)| **kind == StepKind::Fallback)
        .map(|(z, _)| radius(z));
    let (r_min, r_max) =
        fallback_radii.fold((f64::INFINITY, 0.0_f64), |(a, b), r| (a.min(r), b.max(r)));
    println!(
        "robust DTH: ended at t = {:.12}, {} of {} steps fallback (at r = {r_min:.2} .. {r_max:.2}), max |H - H0| = {:.1e}",
        run.end_time().unwrap_or(f64::NAN),
        run.fallback_steps,
        run.steps,
        run.max_energy_error()
    );
    Ok(())
}
