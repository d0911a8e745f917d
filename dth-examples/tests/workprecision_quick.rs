//! CI smoke test of the work-precision benchmark: the quick sweep runs every method on every
//! problem and writes its results and diagrams. It asserts what was computed and written,
//! never how fast.

use dth_examples::workprecision::{run, Record, WorkPrecisionOptions};

#[test]
fn quick_sweep_runs_and_writes_its_files() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let summary = run(&WorkPrecisionOptions::quick(), dir.path()).expect("quick sweep");

    let systems = [
        "kepler_e044",
        "kepler_e07",
        "henon_heiles",
        "pendulum",
        "forced_oscillator",
    ];
    let methods = [
        "dth_joint",
        "dth_nested",
        "dth_joint_scaled_stall",
        "midpoint",
        "trapezoidal",
        "discrete_gradient",
        "verlet",
        "rk4",
        "gauss_legendre2",
        "dop853",
        "dth4",
        "dth6",
        "dth8",
    ];
    for system in systems {
        for method in methods {
            let runs: Vec<_> = summary
                .records
                .iter()
                .filter(|r| r.system == system && r.method == method)
                .collect();
            assert_eq!(runs.len(), 3, "{system}/{method}: three points");
            // A method may fail at the coarsest step (midpoint's Euler predictor does at
            // pericenter of the e = 0.7 orbit): a recorded result, not an error. Every method
            // must succeed somewhere, and a success has finite results.
            assert!(
                runs.iter().any(|r| r.failure.is_none()),
                "{system}/{method}"
            );
            for r in runs.iter().filter(|r| r.failure.is_none()) {
                assert!(r.global_error.is_finite() && r.time > 0.0, "{r:?}");
            }
        }
        // DTH conserves energy at its midpoints to roundoff: each midpoint solves
        // H(zbar) = H(zbar_0) to a scaled residual of 64 eps (terms of size |z . grad H| of
        // order 1 here), so 1e-13 leaves a margin of about 7.
        for r in summary
            .records
            .iter()
            .filter(|r| r.system == system && r.method.starts_with("dth") && r.failure.is_none())
        {
            assert!(r.energy_error < 1e-13, "{r:?}");
            assert!(r.vertex_error.is_some() && r.newton_per_step.is_some());
            // Without robust mode DTH never falls back (it fails instead).
            assert_eq!(r.fallback_steps, Some(0), "{r:?}");
            // Its vertices conserve the angular momentum (a quadratic invariant; thesis
            // Table 4.1: 2.2e-15 over 10^4 steps), measured against the first vertex: a few
            // eps per step at most, over at most ~130 steps here. Plain DTH only: a composed
            // step (order 4-8) does not keep it at its vertices.
            if system.starts_with("kepler") && r.method.starts_with("dth_") {
                let l = r.vertex_invariant_error.expect("Kepler has an invariant");
                assert!(l < 1e-13, "{r:?}");
            }
        }
    }
    for method in [
        "discrete_mechanics",
        "dth_joint_scaled_stall_generated",
        "midpoint_generated",
        "gauss_legendre2_generated",
    ] {
        assert!(
            summary
                .records
                .iter()
                .any(|r| r.method == method && r.system == "kepler_e044" && r.failure.is_none()),
            "{method}"
        );
    }

    robust_orbit_is_swept(&summary.records);
    regularized_orbit_is_swept(&summary.records);

    for name in ["workprecision.json", "workprecision.csv", "summary.md"] {
        let path = dir.path().join(name);
        let len = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        assert!(len > 100, "{} missing or empty", path.display());
    }
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("workprecision.json")).expect("json"),
    )
    .expect("valid JSON");
    assert_eq!(
        json["records"].as_array().map(Vec::len),
        Some(summary.records.len())
    );
    let csv = std::fs::read_to_string(dir.path().join("workprecision.csv")).expect("csv");
    assert_eq!(csv.lines().count(), summary.records.len() + 1);

    // One PNG and one SVG per problem and error kind: global and energy everywhere, the
    // angular momentum on the four Kepler problems.
    for system in systems
        .into_iter()
        .chain(["kepler_e09", "kepler_e09_regularized"])
    {
        let mut kinds = vec!["global", "energy"];
        if system.starts_with("kepler") {
            kinds.push("invariant");
        }
        for kind in kinds {
            for ext in ["png", "svg"] {
                let path = dir.path().join(format!("{system}_{kind}.{ext}"));
                let bytes = std::fs::read(&path).unwrap_or_default();
                assert!(bytes.len() > 1000, "{} missing or empty", path.display());
                if ext == "png" {
                    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
                }
            }
        }
    }
    // The derivative-source figure of the thesis orbit.
    for ext in ["png", "svg"] {
        let path = dir
            .path()
            .join(format!("kepler_e044_derivatives_global.{ext}"));
        assert!(path.is_file(), "{} missing", path.display());
    }
    // 3 data files + PNG and SVG of (4 Kepler x 3 kinds + 3 others x 2 kinds + 1 derivatives).
    assert_eq!(summary.files.len(), 3 + 2 * (4 * 3 + 3 * 2 + 1));
}

/// Kepler e = 0.9, where `Psi` changes sign near pericenter: robust DTH of orders 2 and 8 runs
/// through it with fallback steps and energy at roundoff; plain DTH's breakdown is recorded as
/// a failure at every point; every peer is recorded at every point.
fn robust_orbit_is_swept(records: &[Record]) {
    let runs = |method: &str| -> Vec<&Record> {
        records
            .iter()
            .filter(|r| r.system == "kepler_e09" && r.method == method)
            .collect()
    };
    for method in ["dth_robust", "dth8_robust"] {
        let runs = runs(method);
        assert_eq!(runs.len(), 3, "{method}: three points");
        assert!(runs.iter().any(|r| r.failure.is_none()), "{method}");
        for r in runs.iter().filter(|r| r.failure.is_none()) {
            assert!(r.global_error.is_finite() && r.time > 0.0, "{r:?}");
            // Fallback steps conserve the energy to roundoff too (terms of size ~2 at
            // pericenter).
            assert!(r.energy_error < 1e-13, "{r:?}");
            // It did fall back, and not at every step (DTH resumes where Psi > 0).
            let fallback = r.fallback_steps.expect("DTH counts its fallback steps");
            assert!(fallback > 0 && fallback < r.steps, "{r:?}");
        }
    }
    for method in ["dth_joint", "dth8"] {
        let runs = runs(method);
        assert_eq!(runs.len(), 3, "{method}: three points");
        assert!(runs.iter().all(|r| r.failure.is_some()), "{runs:?}");
    }
    for method in [
        "midpoint",
        "trapezoidal",
        "discrete_gradient",
        "verlet",
        "rk4",
        "gauss_legendre2",
        "dop853",
        "discrete_mechanics",
    ] {
        assert_eq!(runs(method).len(), 3, "{method}: three points");
    }
}

/// Kepler e = 0.9 regularized by Levi-Civita: plain DTH of orders 2 and 8 runs through at
/// every point without a fallback step, the physical energy at its midpoints at roundoff and
/// (order 2) the angular momentum at its vertices too; beside it robust DTH and the three peers
/// at every point.
fn regularized_orbit_is_swept(records: &[Record]) {
    let runs = |method: &str| -> Vec<&Record> {
        records
            .iter()
            .filter(|r| r.system == "kepler_e09_regularized" && r.method == method)
            .collect()
    };
    for method in ["dth_lc", "dth8_lc"] {
        let runs = runs(method);
        assert_eq!(runs.len(), 3, "{method}: three points");
        for r in runs {
            assert!(r.failure.is_none(), "{r:?}");
            assert!(r.global_error.is_finite() && r.time > 0.0, "{r:?}");
            assert_eq!(r.fallback_steps, Some(0), "{r:?}");
            // `K = |u|^2 (H + p_t)` is solved to a few eps of its terms (k = 1), which is
            // eps / r in `H`: at pericentre r = 0.5, ~1e-15; 1e-13 leaves a wide margin.
            assert!(r.energy_error < 1e-13, "{r:?}");
            if method == "dth_lc" {
                // L = (u1 P2 - u2 P1) / 2 is quadratic in the regularized state: DTH keeps it
                // at its vertices.
                let l = r.vertex_invariant_error.expect("Kepler has an invariant");
                assert!(l < 1e-13, "{r:?}");
            }
        }
    }
    for method in [
        "dth_robust",
        "dth8_robust",
        "gauss_legendre2",
        "discrete_gradient",
        "dop853",
    ] {
        assert_eq!(runs(method).len(), 3, "{method}: three points");
    }
}

/// The command CI runs: `dth workprecision --quick --out DIR` succeeds and stages its output
/// (the marker of a dth output folder, the data files and the diagrams).
#[test]
fn dth_workprecision_quick_command_writes_its_folder() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let out = dir.path().join("wp");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_dth"))
        .args(["workprecision", "--quick", "--out"])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .status()
        .expect("run dth");
    assert!(status.success(), "{status}");
    for name in [
        ".dth-output",
        "workprecision.json",
        "workprecision.csv",
        "summary.md",
        "kepler_e044_global.png",
        "kepler_e044_invariant.svg",
        "kepler_e09_global.png",
        "forced_oscillator_energy.png",
    ] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
}
