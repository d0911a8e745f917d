//! DTH of order 2, 4, 6 and 8 to a chosen time, against Kepler's equation:
//! `cargo run --release -p dth --example high_order`.

use dth::kepler::KeplerOrbit;
use dth::nalgebra::Vector4;
use dth::systems::Kepler;
use dth::{solve, DthOptions, Method};

pub fn main() -> Result<(), dth::Error> {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let t_end = 20.0; // about five orbits, not a whole number of steps
    let exact = KeplerOrbit::new(&kepler, &z0)?.state_at(t_end);
    for order in [2, 4, 6, 8] {
        let options = DthOptions::new(0.02)?.with_order(order)?;
        let run = solve(&kepler, z0, Method::Dth(options))
            .until(t_end)
            .save_every(usize::MAX)
            .run()?;
        let error = (run.end_state().unwrap_or(&z0) - exact).amax();
        println!(
            "order {order}: t = {:.15}, error {error:.1e}, {} Newton iterations",
            run.end_time().unwrap_or(f64::NAN),
            run.newton_iterations
        );
    }
    Ok(())
}
