//! The user-facing entry point: `examples/custom_system.rs` (a `hamiltonian!` type defined
//! outside the library, registered in a catalogue and run through `run_scene`), exercised by
//! including that very file.

#[allow(dead_code)] // its `main` is the example's, not called here
#[path = "../examples/custom_system.rs"]
mod custom_system;

use custom_system::Duffing;
use dth::nalgebra::Vector2;
use dth::{ConstFlags, Hamiltonian};
use dth_examples::simulate::RunOptions;

mod common;

use common::entries;

#[test]
fn the_example_runs_its_scene_on_its_own_system() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("duffing");
    let report = custom_system::run(&out, &RunOptions::default().with_progress(false)).unwrap();
    assert_eq!(report.system, "duffing");
    // The scene's b = 0.5 and the registered default a = 1.
    assert_eq!(report.params.get("a"), Some(&1.0));
    assert_eq!(report.params.get("b"), Some(&0.5));
    let labels: Vec<&str> = report.methods.iter().map(|m| m.label.as_str()).collect();
    assert_eq!(labels, ["dth", "stormer_verlet"]);
    for m in &report.methods {
        assert!(m.failure.is_none(), "{}: {:?}", m.label, m.failure);
        assert!(m.t_end >= 30.0, "{}: {}", m.label, m.t_end);
    }
    let energy = |i: usize| report.methods[i].energy.as_ref().unwrap();
    // DTH: H(zbar_k) = H(zbar_0) to roundoff (|H| = 0.625: a few eps).
    assert!(energy(0).points.max < 1e-14, "{:?}", energy(0));
    // Stormer-Verlet: bounded O(dt^2) energy error, not roundoff (dt = 0.05, |H''| ~ 1).
    let sv = energy(1).points.max;
    assert!(sv > 1e-6 && sv < 1e-2, "{sv:e}");
    let files = entries(&out);
    for f in [
        "index.html",
        "summary.json",
        "dth_energy.csv",
        "stormer_verlet_phase1.csv",
        "phase1.png",
    ] {
        assert!(files.contains(&f.to_string()), "missing {f} in {files:?}");
    }
}

#[test]
fn the_example_system_has_the_derivatives_of_its_formula() {
    let h = Duffing { a: 1.5, b: 0.5 };
    let z = Vector2::new(0.8, -0.3);
    let (q, p) = (z[0], z[1]);
    // H = p^2/2 + a q^2/2 + b q^4/4, by hand.
    assert!((h.value(&z) - (p * p / 2.0 + 0.75 * q * q + 0.125 * q.powi(4))).abs() < 1e-15);
    let g = h.gradient(&z);
    assert!((g[0] - (1.5 * q + 0.5 * q.powi(3))).abs() < 1e-15 && g[1] == p);
    let hess = h.hessian(&z);
    assert!((hess[(0, 0)] - (1.5 + 1.5 * q * q)).abs() < 1e-15);
    assert!(hess[(0, 1)] == 0.0 && hess[(1, 1)] == 1.0);
    // What the scene relies on (checked when this test compiles): Stormer-Verlet needs a
    // separable H, DTH a Psi not identically zero.
    const { assert!(Duffing::FLAGS.separable && !Duffing::FLAGS.psi_identically_zero) };
}

#[test]
fn bad_parameters_are_reported_at_the_value_by_their_declared_rule() {
    let dir = tempfile::tempdir().unwrap();
    let text = custom_system::SCENE.replace("params = { b = 0.5 }", "params = { a = -1.0 }");
    let err = dth_examples::run_scene(
        &text,
        "duffing.toml",
        &custom_system::catalogue().unwrap(),
        &dir.path().join("o"),
        &RunOptions::default().with_progress(false),
    )
    .unwrap_err();
    assert_eq!(err.exit_code(), 2, "{err}");
    assert!(
        err.to_string().contains(
            "duffing.toml:6:16: parameter `a` (linear stiffness) of system `duffing` = -1: expected a positive number (> 0)"
        ),
        "{err}"
    );
    assert!(entries(dir.path()).is_empty(), "output left behind");
}
