//! Run a scene on your own system, from your own crate.
//!
//! 1. Define the Hamiltonian (with `dth::hamiltonian!` once the macro lands; here by hand).
//! 2. Implement `SceneSystem` (its quadratic invariants and period, if any; both optional);
//!    the system must be `Clone` (the DTH stepper owns a copy).
//! 3. Register it under a name in a `Catalogue` (the built-in one, or an empty one).
//! 4. Run scene text that names it.
//!
//! `cargo run -p dth-examples --example custom_system` writes `dth-out/duffing/`.

use std::path::Path;

use dth::nalgebra::{Matrix2, Vector2};
use dth::Hamiltonian;
use dth_examples::catalogue::{Catalogue, ParamSpec, SceneSystem, SystemEntry};
use dth_examples::run::RunOptions;

/// Duffing oscillator `H = p^2/2 + a q^2/2 + b q^4/4`, `z = (q, p)`.
#[derive(Clone)]
struct Duffing {
    a: f64,
    b: f64,
}

impl Hamiltonian<2> for Duffing {
    const SEPARABLE: bool = true;

    fn value(&self, z: &Vector2<f64>) -> f64 {
        let q2 = z[0] * z[0];
        0.5 * z[1] * z[1] + 0.5 * self.a * q2 + 0.25 * self.b * q2 * q2
    }

    fn gradient(&self, z: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(self.a * z[0] + self.b * z[0].powi(3), z[1])
    }

    fn hessian(&self, z: &Vector2<f64>) -> Matrix2<f64> {
        Matrix2::new(self.a + 3.0 * self.b * z[0] * z[0], 0.0, 0.0, 1.0)
    }
}

/// No quadratic invariants, no closed-form period: the defaults.
impl SceneSystem<2> for Duffing {}

const SCENE: &str = r#"
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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut catalogue = Catalogue::builtin();
    catalogue.register(SystemEntry::runnable::<2, Duffing, _>(
        "duffing",
        "Duffing oscillator H = p^2/2 + a q^2/2 + b q^4/4, n = 1",
        &[
            ParamSpec {
                name: "a",
                default: Some(1.0),
                doc: "linear stiffness",
            },
            ParamSpec {
                name: "b",
                default: Some(1.0),
                doc: "cubic stiffness",
            },
        ],
        |p| {
            let (a, b) = (p["a"], p["b"]);
            if a > 0.0 && b >= 0.0 {
                Ok(Duffing { a, b })
            } else {
                Err(format!(
                    "duffing needs a > 0 and b >= 0 (got a = {a}, b = {b})"
                ))
            }
        },
    ))?;
    let report = dth_examples::run_scene(
        SCENE,
        "custom_system.rs",
        &catalogue,
        Path::new("dth-out/duffing"),
        &RunOptions::default(),
    )?;
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
