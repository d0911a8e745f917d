//! A system whose `Psi` is identically zero (the free particle) is registered without DTH:
//! every peer method runs on it, and a scene naming `dth` for it is rejected with the place
//! and the reason (exit 2, nothing written).

mod common;

use common::*;
use dth::dth::Solver;
use dth::nalgebra::Vector4;
use dth_examples::catalogue::Catalogue;
use dth_examples::scene::{MethodKind, StepSpec};
use dth_examples::simulate::{compute, RunOptions};
use dth_examples::system::WithoutDth;
use dth_examples::systems::FreeParticle;
use dth_examples::Error;

const SCENE: &str = "[system]
name = \"free_particle\"
params = { m = 2.0 }
[initial]
q = [1.0, 0.0]
p = [0.5, 1.0]
[[method]]
kind = \"midpoint\"
dt = 0.1
[duration]
steps = 200
[[effect]]
kind = \"final_state\"
";

#[test]
fn check_and_run_reject_dth_with_place_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!("{SCENE}[[method]]\nkind = \"dth\"\ndtau = 0.1\n");
    std::fs::write(dir.path().join("free.toml"), scene).unwrap();
    for args in [
        &["check", "free.toml"][..],
        &["run", "free.toml", "--out", "o"],
    ] {
        let o = dth(args, dir.path());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        // Line 15 is `kind = "dth"`, its value starts at column 8.
        assert!(
            err.contains("free.toml:15:8: method `dth` cannot integrate system `free_particle`"),
            "{err}"
        );
        assert!(
            err.contains("Psi = (J gradH)^T HessH (J gradH) is identically zero")
                && err.contains("thesis Section 3.4")
                && err.contains("expected a peer method"),
            "{err}"
        );
        assert_eq!(entries(dir.path()), ["free.toml"], "output left behind");
    }
}

#[test]
fn every_peer_runs_and_follows_the_straight_line() {
    let mut text = SCENE.replace("[[method]]\nkind = \"midpoint\"\ndt = 0.1\n", "");
    for kind in [
        "exact",
        "midpoint",
        "trapezoidal",
        "rk4",
        "gauss_legendre2",
        "discrete_gradient",
        "stormer_verlet",
        "discrete_mechanics",
    ] {
        text.push_str(&format!("[[method]]\nkind = \"{kind}\"\ndt = 0.1\n"));
    }
    text.push_str("[[effect]]\nkind = \"comparison_table\"\n");
    let scene = dth_examples::check_scene(&text, "free.toml", &Catalogue::builtin()).unwrap();
    let system = WithoutDth(FreeParticle { m: 2.0 });
    let results = compute(&system, &scene, &RunOptions::default().with_progress(false)).unwrap();
    assert_eq!(results.len(), 8);
    for r in &results {
        let s = &r.summary;
        assert!(s.failure.is_none(), "{}: {:?}", s.label, s.failure);
        assert_eq!(s.steps, 200, "{}", s.label);
        // Every one of these methods is exact for q' = p/m, p' = 0 (all integrate constants
        // and linear functions of t exactly): after 200 steps of 0.1, t = 20 and
        // q = q0 + p0 t / m = (6, 10), up to the roundoff of 200 additions of O(1) numbers
        // (a few hundred eps of |q| = 10).
        let f = s.final_state.as_ref().unwrap();
        let z = Vector4::from_iterator(f.z.iter().copied());
        let exact = Vector4::new(6.0, 10.0, 0.5, 1.0);
        assert!((f.t - 20.0).abs() < 1e-12, "{}: t = {}", s.label, f.t);
        assert!((z - exact).amax() < 1e-12, "{}: {z}", s.label);
        // Energy, momentum and angular momentum kept to roundoff.
        assert!(s.energy.as_ref().unwrap().points.max < 1e-14, "{}", s.label);
        let names: Vec<&str> = s.invariants.iter().map(|i| i.name.as_str()).collect();
        assert_eq!(names, ["p1", "p2", "angular_momentum"]);
        for i in &s.invariants {
            // |L| = |q1 p2 - q2 p1| <= 20: a few eps of the products.
            assert!(i.points.max < 1e-13, "{}: {i:?}", s.label);
        }
    }
}

#[test]
fn the_runner_refuses_dth_even_when_validation_is_bypassed() {
    let mut scene = dth_examples::check_scene(SCENE, "free.toml", &Catalogue::builtin()).unwrap();
    scene.methods[0].kind = MethodKind::Dth;
    scene.methods[0].step = StepSpec::Dth {
        dtau: 0.1,
        lambda0: 1.0,
        solver: Solver::Joint,
        robust: false,
        order: 2,
        double_double: false,
    };
    let err = compute(
        &WithoutDth(FreeParticle { m: 2.0 }),
        &scene,
        &RunOptions::default().with_progress(false),
    )
    .unwrap_err();
    assert!(
        matches!(&err, Error::NotAvailable { what: "method", name, reason }
            if name == "dth" && reason.contains("identically zero")),
        "{err}"
    );
}

#[test]
fn list_shows_the_free_particle() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["list"], dir.path());
    assert_eq!(o.status.code(), Some(0));
    let s = stdout(&o);
    let line = s
        .lines()
        .skip_while(|l| !l.contains("free_particle"))
        .take(2)
        .collect::<Vec<_>>()
        .join("\n");
    assert!(line.contains("every method but dth"), "{s}");
}
