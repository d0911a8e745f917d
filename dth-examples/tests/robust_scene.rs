//! `robust = true` on a `dth` method: a scene whose orbit breaks down (Kepler at e = 0.9,
//! where `Psi` changes sign) stops with a typed breakdown without it, and runs through with it,
//! energy still at roundoff at every midpoint (fallback nodes included).

use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::{compute, MethodResult, RunOptions};
use dth_examples::systems::Kepler;

/// Kepler e = 0.9 from pericentre `q = (0.5, 0)`: `p2 = sqrt(1.9)` (thesis H, `m = 1/2`,
/// `k = 1`), at `dtau = 0.0157`, where DTH breaks down at step 19.
fn run(robust: &str) -> MethodResult {
    let text = format!(
        "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, {}]\n\
         [[method]]\nkind = \"dth\"\ndtau = 0.0157\n{robust}\n\
         [duration]\nsteps = 2000\n[[effect]]\nkind = \"comparison_table\"\n",
        1.9f64.sqrt()
    );
    let scene = dth_examples::check_scene(&text, "robust.toml", &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    let mut results = compute(
        &Kepler::thesis(),
        &scene,
        &RunOptions::default().with_progress(false),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    results.remove(0)
}

#[test]
fn robust_mode_runs_through_a_breakdown_that_stops_plain_dth() {
    let plain = run("");
    let failure = plain.failure.expect("plain DTH breaks down on this orbit");
    assert!(
        matches!(
            failure.cause,
            dth_examples::driver::FailureCause::Integrator(dth::Error::Breakdown { .. })
        ),
        "{failure}"
    );
    assert!(!plain.summary.step.contains_key("robust"));
    assert_eq!(plain.summary.fallback.steps, 0);

    let robust = run("robust = true");
    assert!(robust.failure.is_none(), "{:?}", robust.failure);
    assert_eq!(robust.summary.steps, 2000);
    assert_eq!(robust.summary.step["robust"], true);
    // Energy at every midpoint and fallback node is H(zbar_0) = 1.9 - 1/0.5 = -0.1 to
    // roundoff: a few eps of the O(1) terms 1.9 and 2 (the library's own tests bound it the
    // same way), here 1e-14 = 45 eps.
    let energy = robust
        .summary
        .energy
        .expect("comparison_table was asked for");
    assert!(energy.points.max <= 1e-14, "{:e}", energy.points.max);
    // Psi < 0 on a band of radii the orbit crosses: robust mode fell back there, and says why.
    let fallback = &robust.summary.fallback;
    assert!(fallback.steps > 0 && fallback.time > 0.0, "{fallback:?}");
    let cause = fallback.cause.as_deref().unwrap_or_default();
    assert!(
        cause.starts_with("Psi changes sign along the orbit"),
        "{cause}"
    );
    // Where it changed sign, H has its 1/r singularity at the origin: the run says that
    // Levi-Civita would have avoided the fallback steps (summary line, warning, summary.json).
    let r = fallback
        .regularization
        .as_ref()
        .expect("a regularization applies to Kepler");
    assert_eq!(r.scene_keys(), "regularize = \"levi-civita\"");
    assert!(
        fallback
            .to_string()
            .ends_with("; `regularize = \"levi-civita\"` under [system] would avoid them"),
        "{fallback}"
    );
    let warning = fallback.warning("dth").unwrap_or_default();
    assert!(
        warning.contains("a regularization applies: `regularize = \"levi-civita\"` under [system]"),
        "{warning}"
    );
    let json = serde_json::to_value(fallback).unwrap();
    assert_eq!(json["regularization"]["preset"], "levi-civita");
    assert_eq!(
        json["regularization"]["centre"],
        serde_json::json!([0.0, 0.0])
    );
}

/// A pendulum in rotation falls back over the top, where no regularization applies (one
/// degree of freedom, no singularity): the run names none.
#[test]
fn a_fallback_without_a_singularity_names_no_regularization() {
    let text = "[system]\nname = \"pendulum\"\n[initial]\nq = [0.0]\np = [2.5]\n\
                [[method]]\nkind = \"dth\"\ndtau = 0.05\nrobust = true\n[duration]\ntime = 10\n";
    let scene = dth_examples::check_scene(text, "rotation.toml", &Catalogue::builtin()).unwrap();
    let pendulum = dth_examples::systems::Pendulum {
        m: 1.0,
        l: 1.0,
        g: 1.0,
    };
    let results = compute(
        &pendulum,
        &scene,
        &RunOptions::default().with_progress(false),
    )
    .unwrap();
    let fallback = &results[0].summary.fallback;
    assert!(fallback.steps > 0, "{fallback:?}");
    assert_eq!(fallback.regularization, None);
    assert!(!fallback.to_string().contains("regularize"), "{fallback}");
}

#[test]
fn robust_is_a_key_of_dth_only() {
    let text = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                [[method]]\nkind = \"midpoint\"\ndt = 0.1\nrobust = true\n\
                [duration]\nsteps = 10\n";
    let err = dth_examples::check_scene(text, "bad.toml", &Catalogue::builtin())
        .expect_err("robust on midpoint")
        .to_string();
    assert!(
        err.contains(
            "bad.toml:9:10: `robust` is a key of method `dth` only: `midpoint` takes `dt`"
        ),
        "{err}"
    );
}

mod common;

use common::{dth, manifest_dir, stderr, stdout};

/// What `dth run` wrote into `out`.
struct Written {
    stdout: String,
    stderr: String,
    summary: serde_json::Value,
    html: String,
    out: std::path::PathBuf,
}

/// `dth run` of `scene` (a scene's text) into a fresh folder; it must succeed.
fn dth_run(scene: &str, dir: &std::path::Path) -> Written {
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let o = dth(&["run", "scene.toml", "--out", "out"], dir);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = dir.join("out");
    let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
    Written {
        stdout: stdout(&o),
        stderr: stderr(&o),
        summary: serde_json::from_str(&read("summary.json")).unwrap(),
        html: read("index.html"),
        out,
    }
}

/// The `step_kind` column of a trajectory CSV with each row's time: `(t, kind)`.
fn step_kinds(csv: &str) -> Vec<(f64, String)> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let t = header.iter().position(|c| *c == "t").unwrap();
    let kind = header.iter().position(|c| *c == "step_kind").unwrap();
    lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            (cells[t].parse().unwrap(), cells[kind].to_string())
        })
        .collect()
}

/// The shipped e = 0.9 scene (Psi < 0 on a band of radii that the orbit crosses twice per
/// period, so robust mode must fall back there) with every step in the trajectory: the fallback
/// steps and their time reported in `summary.json` are the trajectory's `fallback` rows, the
/// summary line and `index.html` give them, and stderr warns (more than 1% fell back) naming
/// Psi's sign change. The counts themselves are the stepper's business and are not pinned.
#[test]
fn the_fallback_steps_reported_are_the_ones_in_the_trajectory() {
    let scene = std::fs::read_to_string(manifest_dir().join("scenes/kepler-e09-robust.toml"))
        .unwrap()
        + "\n[[effect]]\nkind = \"trajectory\"\nevery = 1\n";
    let dir = tempfile::tempdir().unwrap();
    let w = dth_run(&scene, dir.path());
    let methods = w.summary["methods"].as_array().unwrap();
    let (robust, midpoint) = (&methods[0], &methods[1]);
    let reported = &robust["fallback"];
    let fallback_steps = reported["steps"].as_u64().unwrap() as usize;
    let steps = robust["steps"].as_u64().unwrap() as usize;

    let rows = step_kinds(&std::fs::read_to_string(w.out.join("dth_trajectory.csv")).unwrap());
    assert_eq!(rows.len(), steps + 1);
    let mut counted = (0, 0.0);
    for pair in rows.windows(2) {
        if pair[1].1 == "fallback" {
            counted = (counted.0 + 1, counted.1 + (pair[1].0 - pair[0].0));
        } else {
            assert!(
                ["dth", "shortened"].contains(&pair[1].1.as_str()),
                "{pair:?}"
            );
        }
    }
    assert_eq!(counted.0, fallback_steps, "{reported}");
    let time = reported["time"].as_f64().unwrap();
    assert!(
        (counted.1 - time).abs() <= 1e-12 * time,
        "{counted:?} {reported}"
    );
    let share = reported["share_of_steps"].as_f64().unwrap();
    // serde_json (without its `float_roundtrip` feature) parses a float to within a few ulps.
    let expected = fallback_steps as f64 / steps as f64;
    assert!(
        (share - expected).abs() <= 4.0 * f64::EPSILON * expected,
        "{share} {expected}"
    );
    let t_end = robust["t_end"].as_f64().unwrap();
    let share_of_time = reported["share_of_time"].as_f64().unwrap();
    assert!((share_of_time - time / t_end).abs() <= 1e-12, "{reported}");
    // Physics, not the policy: the orbit spends a sizeable part of its time where Psi < 0.
    assert!(share > 0.01 && share_of_time > 0.01, "{reported}");

    // Stdout's summary line, the warning, the page.
    let line = format!("fallback steps: dth {fallback_steps} of {steps} steps (");
    assert!(w.stdout.contains(&line), "{}", w.stdout);
    let warning = format!("warning: method `dth`: {fallback_steps} of {steps} steps (");
    assert!(w.stderr.contains(&warning), "{}", w.stderr);
    assert!(
        w.stderr.contains("cause: Psi changes sign along the orbit"),
        "{}",
        w.stderr
    );
    assert!(
        w.html
            .contains(&format!("<td>{fallback_steps} of {steps} steps (")),
        "{}",
        w.html
    );
    assert!(w.html.contains("Warning: method `dth`"), "{}", w.html);
    assert!(
        w.html.contains("so the invariants DTH conserves at its vertices (angular_momentum) do not hold across them"),
        "{}",
        w.html
    );

    // The peer beside it: no fallback, and every row a fixed step.
    assert_eq!(midpoint["fallback"]["steps"], 0);
    assert!(midpoint["fallback"]["cause"].is_null());
    let peer = std::fs::read_to_string(w.out.join("midpoint_trajectory.csv")).unwrap();
    assert!(step_kinds(&peer).iter().all(|(_, k)| k == "fixed"));
}

/// A robust run that never falls back (the thesis orbit, e = 0.44: Psi > 0 everywhere) and a
/// run without robust mode report zero fallback steps and warn about nothing; only the robust
/// one mentions fallback in its summary line and in the page's methods table.
#[test]
fn a_run_without_fallback_steps_reports_zero_and_no_warning() {
    let scene = |robust: &str| {
        format!(
            "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
             [[method]]\nkind = \"dth\"\ndtau = 0.05\n{robust}\n[[method]]\nkind = \"rk4\"\ndt = 0.05\n\
             [duration]\norbits = 1\n[[effect]]\nkind = \"trajectory\"\nevery = 1\n\
             [[effect]]\nkind = \"invariants\"\n"
        )
    };
    for robust in ["robust = true", ""] {
        let dir = tempfile::tempdir().unwrap();
        let w = dth_run(&scene(robust), dir.path());
        for m in w.summary["methods"].as_array().unwrap() {
            assert_eq!(m["fallback"]["steps"], 0, "{robust}: {m}");
            assert_eq!(m["fallback"]["time"], 0.0, "{robust}: {m}");
            assert!(m["fallback"]["cause"].is_null(), "{robust}: {m}");
        }
        let rows = step_kinds(&std::fs::read_to_string(w.out.join("dth_trajectory.csv")).unwrap());
        assert!(rows.iter().all(|(_, k)| k != "fallback"), "{robust}");
        assert!(!w.stderr.contains("warning"), "{robust}: {}", w.stderr);
        assert!(
            !w.html.contains("Warning") && !w.html.contains("Note:"),
            "{robust}"
        );
        let steps = w.summary["methods"][0]["steps"].as_u64().unwrap();
        let line =
            format!("(fallback steps: dth 0 of {steps} steps (0.0%), 0.0% of the physical time)");
        assert_eq!(
            w.stdout.contains(&line),
            !robust.is_empty(),
            "{robust}: {}",
            w.stdout
        );
        assert_eq!(
            w.html.contains("<th>fallback steps</th>"),
            !robust.is_empty(),
            "{robust}"
        );
    }
}
