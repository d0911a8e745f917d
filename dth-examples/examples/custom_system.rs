//! Run a scene on your own system, from your own crate.
//!
//! 1. Define the Hamiltonian with `dth::hamiltonian!`: its fields are its parameters, and the
//!    gradient, Hessian, Psi and discrete gradient are derived at compile time.
//! 2. Implement `SceneSystem` for it: its quadratic invariants and period, if any (both
//!    optional; the empty `impl` takes the defaults). The type must be `Clone`.
//! 3. Register it under a name in a `Catalogue` (the built-in one, or `Catalogue::new()`),
//!    with its parameters and a function that builds it from a scene's `params`.
//! 4. Run scene text (or a file) that names it.
//!
//! `cargo run -p dth-examples --example custom_system` writes `dth-out/duffing/`.
//! `tests/custom_system.rs` runs this same file's `run` (it includes it as a module).

use std::path::Path;

use dth::nalgebra::Const;
use dth_examples::catalogue::{Catalogue, SystemEntry};
use dth_examples::report::RunReport;
use dth_examples::scene::{ParamRule, ParamSpec};
use dth_examples::simulate::RunOptions;
use dth_examples::system::SceneSystem;

dth::hamiltonian! {
    /// The Duffing oscillator `H = p^2/2 + a q^2/2 + b q^4/4`, `z = (q, p)`.
    #[derive(Clone, Copy, Debug)]
    pub struct Duffing {
        /// Linear stiffness.
        pub a: f64,
        /// Cubic stiffness (of the force).
        pub b: f64,
    } = p1^2/2 + a*q1^2/2 + b*q1^4/4
}

/// No quadratic invariants, no closed-form period: the defaults.
impl SceneSystem<Const<2>> for Duffing {}

/// The scene: DTH beside Stormer-Verlet (allowed: `hamiltonian!` found `H` separable).
pub const SCENE: &str = r#"
title = "Duffing oscillator"

[system]
name = "duffing"
params = { b = 0.5 }

[initial]
q = [1.0]
p = [0.0]

[[method]]
kind = "dth"
dtau = 0.05

[[method]]
kind = "stormer_verlet"
dt = 0.05

[duration]
time = 30.0

[[effect]]
kind = "energy_deviation"
every = 1

[[effect]]
kind = "phase_plot"
x = "q1"
y = "p1"
every = 1
"#;

/// The built-in catalogue with `duffing` added.
pub fn catalogue() -> Result<Catalogue, dth_examples::Error> {
    let mut catalogue = Catalogue::builtin();
    catalogue.register(SystemEntry::runnable::<2, Duffing, _>(
        "duffing",
        "Duffing oscillator H = p1^2/2 + a q1^2/2 + b q1^4/4, n = 1",
        &[
            ParamSpec::new("a", Some(1.0), "linear stiffness").positive(),
            ParamSpec::new("b", Some(1.0), "cubic stiffness").with_rule(ParamRule::NonNegative),
        ],
        // Validation filled in every declared parameter (given or default) and checked its
        // rule, so the builder only reads them.
        |p| {
            Ok(Duffing {
                a: p["a"],
                b: p["b"],
            })
        },
    ))?;
    Ok(catalogue)
}

/// Runs [`SCENE`] on the registered Duffing oscillator into `out` (staged, moved into place
/// on success, like `dth run`).
pub fn run(out: &Path, options: &RunOptions) -> Result<RunReport, dth_examples::RunError> {
    dth_examples::run_scene(SCENE, "custom_system.rs", &catalogue()?, out, options)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let report = run(Path::new("dth-out/duffing"), &RunOptions::default())?;
    for m in &report.methods {
        if let Some(e) = &m.energy {
            println!(
                "{}: mean |H - H0| = {:.3e} over {} steps",
                m.label, e.points.mean, m.steps
            );
        }
    }
    println!("wrote {}", report.out.join("index.html").display());
    Ok(())
}
