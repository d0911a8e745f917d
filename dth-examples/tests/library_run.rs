//! A program built on the library (`run_scene`) cannot mistake a partial run for a complete
//! one: a run that lost a method is an error, and the error carries what was written.

use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::RunOptions;
use dth_examples::RunError;

const BLOWUP: &str = include_str!("scenes/rk4-blowup.toml");

#[test]
fn a_run_that_loses_a_method_is_an_error_carrying_the_partial_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let result = dth_examples::run_scene(
        BLOWUP,
        "rk4-blowup.toml",
        &Catalogue::builtin(),
        &out,
        &RunOptions::default().with_progress(false),
    );
    let err = result.expect_err("a run whose method failed returned Ok");
    assert_eq!(err.exit_code(), 1);
    let message = err.to_string();
    assert!(
        message.contains("method `rk4` failed at step") && message.contains("non-finite"),
        "{message}"
    );
    assert!(matches!(err, RunError::MethodsFailed { .. }), "{err:?}");
    // The outputs are written and the report says which method failed.
    let report = err.partial_report().unwrap();
    assert_eq!(report.out, out);
    let failed: Vec<&str> = report.failures().map(|m| m.label.as_str()).collect();
    assert_eq!(failed, ["rk4"]);
    assert!(out.join("summary.json").is_file() && out.join("rk4_trajectory.csv").is_file());
}

#[test]
fn a_scene_that_cannot_run_is_not_run() {
    let dir = tempfile::tempdir().unwrap();
    let err = dth_examples::run_scene(
        &BLOWUP.replace("rk4", "leapfrog"),
        "bad.toml",
        &Catalogue::builtin(),
        &dir.path().join("o"),
        &RunOptions::default().with_progress(false),
    )
    .unwrap_err();
    assert_eq!(err.exit_code(), 2);
    assert!(
        matches!(&err, RunError::NotRun(e) if e.exit_code() == 2),
        "{err:?}"
    );
    assert!(err.partial_report().is_err());
    assert!(!dir.path().join("o").exists());
}

/// A DTH run given a duration in time cannot know its steps in advance; when the cap on them
/// (`RunOptions::max_steps`) stopped it short of the end time, it used to end as a success at
/// an earlier time. It is now a failure at the step past the cap, with its results written.
#[test]
fn a_run_stopped_by_the_step_cap_is_a_failure_that_keeps_its_results() {
    let scene = "[system]\nname = \"harmonic_oscillator\"\n[initial]\nq = [1.0]\np = [0.0]\n\
                 [[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\ntime = 10.0\n\
                 [[effect]]\nkind = \"trajectory\"\n";
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let mut options = RunOptions::default().with_progress(false);
    options.max_steps = 5;
    let err = dth_examples::run_scene(scene, "cap.toml", &Catalogue::builtin(), &out, &options)
        .expect_err("a run stopped by the cap returned Ok");
    assert_eq!(err.exit_code(), 1);
    assert!(err.to_string().contains("the cap of 5 steps"), "{err}");
    let report = err.partial_report().unwrap();
    let failure = report.methods[0].failure.as_ref().unwrap();
    assert_eq!((report.methods[0].steps, failure.step), (5, 6));
    assert!(report.methods[0].t_end < 10.0);
    let rows = std::fs::read_to_string(out.join("dth_trajectory.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 6, "{rows}");
    // A fixed-step method knows its steps: it is refused before it runs (exit 2).
    let fixed = scene.replace("kind = \"dth\"\ndtau", "kind = \"midpoint\"\ndt");
    let err = dth_examples::run_scene(&fixed, "cap.toml", &Catalogue::builtin(), &out, &options)
        .unwrap_err();
    assert_eq!(err.exit_code(), 2, "{err}");
    assert!(
        err.to_string().contains("would need 1.000e2 steps"),
        "{err}"
    );
}

/// Ctrl-C discarded a whole run. With `RunOptions::interrupt` set, every driver (DTH, the
/// fixed-step peers, discrete mechanics, the sampled exact solution) stops at the next step
/// boundary: the flag is set by the observer at step 5, so each run has seen states 0..=5 and
/// ends with `FailureCause::Interrupted` at step 6.
#[test]
fn every_driver_stops_at_the_step_after_the_interrupt() {
    use dth_examples::driver::{FailureCause, Stop};
    use dth_examples::method::run_method;
    use dth_examples::simulate::initial_state;
    use std::sync::atomic::{AtomicBool, Ordering};
    static FLAG: AtomicBool = AtomicBool::new(false);
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [[method]]\nkind = \"dth\"\ndtau = 0.06\n[[method]]\nkind = \"midpoint\"\ndt = 0.1\n\
                 [[method]]\nkind = \"discrete_mechanics\"\ndt = 0.1\n\
                 [[method]]\nkind = \"exact\"\ndt = 0.1\n[duration]\nsteps = 100\n";
    let scene = dth_examples::check_scene(scene, "k.toml", &Catalogue::builtin()).unwrap();
    let system = dth_examples::systems::Kepler::thesis();
    let z0 = initial_state(&system, &scene).unwrap();
    for time in [false, true] {
        let stop = if time {
            Stop::time(100.0, 1000)
        } else {
            Stop::steps(100)
        };
        for m in &scene.methods {
            FLAG.store(false, Ordering::SeqCst);
            let mut seen = Vec::new();
            let mut observer = |r: &dth::observer::StepRecord<dth::nalgebra::Const<4>>| {
                seen.push(r.k);
                if r.k == 5 {
                    FLAG.store(true, Ordering::SeqCst);
                }
            };
            let stop = stop.with_interrupt(Some(&FLAG));
            let end = run_method(m, &system, z0, 0.0, stop, &mut observer).unwrap();
            let failure = end.expect_err(&m.label);
            assert_eq!(failure.cause, FailureCause::Interrupted, "{}", m.label);
            assert_eq!(failure.step, 6, "{}", m.label);
            assert_eq!(seen, (0..=5).collect::<Vec<_>>(), "{}", m.label);
            // Without the flag the same run completes.
            FLAG.store(false, Ordering::SeqCst);
            let end = run_method(m, &system, z0, 0.0, stop, &mut ()).unwrap();
            assert!(end.is_ok(), "{}: {end:?}", m.label);
        }
    }
}

/// An interrupted run writes what it computed: the interrupted method's results (here none:
/// the flag is set before the run, so it stops before step 1), `summary.json` saying where it
/// stopped and which methods did not run; the error is `RunError::Interrupted`, exit code 130.
#[test]
fn an_interrupted_run_writes_what_it_computed_and_says_where_it_stopped() {
    use std::sync::atomic::AtomicBool;
    static FLAG: AtomicBool = AtomicBool::new(true);
    let scene = "[system]\nname = \"harmonic_oscillator\"\n[initial]\nq = [1.0]\np = [0.0]\n\
                 [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[[method]]\nkind = \"dth\"\ndtau = 0.1\n\
                 [duration]\nsteps = 1000\n[[effect]]\nkind = \"trajectory\"\n";
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let options = RunOptions::default()
        .with_progress(false)
        .with_interrupt(&FLAG);
    let err = dth_examples::run_scene(scene, "i.toml", &Catalogue::builtin(), &out, &options)
        .expect_err("an interrupted run returned Ok");
    assert_eq!(err.exit_code(), 130);
    let message = err.to_string();
    assert!(
        message.contains("interrupted before step 1 of method `midpoint`")
            && message.contains("not run: dth"),
        "{message}"
    );
    assert!(matches!(err, RunError::Interrupted { .. }), "{err:?}");
    let report = err.partial_report().unwrap();
    assert_eq!(report.methods.len(), 1);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let interrupted = &summary["interrupted"];
    assert_eq!(interrupted["method"], "midpoint", "{summary}");
    assert_eq!(interrupted["step"], 1, "{summary}");
    assert_eq!(interrupted["t"], 0.0, "{summary}");
    assert_eq!(
        interrupted["not_run"],
        serde_json::json!(["dth"]),
        "{summary}"
    );
    assert_eq!(summary["methods"][0]["steps"], 0, "{summary}");
    // The initial state is the trajectory's one row.
    let rows = std::fs::read_to_string(out.join("midpoint_trajectory.csv")).unwrap();
    assert_eq!(rows.lines().count(), 2, "{rows}");
    // The page says so too.
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        page.contains("The run was interrupted before step 1 of method `midpoint` (last state at t = 0); not run: dth (SIGINT or SIGTERM)"),
        "{page}"
    );
}

/// An ensemble interrupted before its members ran writes its table, every member marked as
/// not run because of the interruption, and returns `RunError::Interrupted`.
#[test]
fn an_interrupted_ensemble_writes_its_table_with_the_members_not_run() {
    use std::sync::atomic::AtomicBool;
    static FLAG: AtomicBool = AtomicBool::new(true);
    let scene = "[system]\nname = \"pendulum\"\n[initial]\nq = [0.0]\np = [0.0]\n\
                 [[method]]\nkind = \"rk4\"\ndt = 0.1\n[duration]\nsteps = 10\n\
                 [ensemble]\nkind = \"grid\"\nx = \"q1\"\nx_range = [0.0, 1.0]\nx_count = 3\n";
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let options = RunOptions::default()
        .with_progress(false)
        .with_interrupt(&FLAG);
    let err = dth_examples::run_scene(scene, "e.toml", &Catalogue::builtin(), &out, &options)
        .expect_err("an interrupted ensemble returned Ok");
    assert_eq!(err.exit_code(), 130);
    let report = err.partial_report().unwrap();
    assert_eq!(report.ensemble.map(|c| (c.drawn, c.not_run)), Some((3, 3)));
    let table = std::fs::read_to_string(out.join("ensemble.csv")).unwrap();
    assert_eq!(table.matches("interrupted").count(), 3, "{table}");
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(
        summary.contains("\"during\": \"the ensemble's members (ensemble.csv marks"),
        "{summary}"
    );
}

/// The interruptible driver is transparent to a run's cost: Stormer-Verlet reuses its last
/// force inside a run (`OneStepMethod::continue_into`), so a run of `n` steps evaluates the
/// gradient `3 + 2 (n - 1)` times (the first step has no force yet), with or without an
/// interrupt flag; a wrapper that dropped `continue_into` would make it `3 n`.
#[test]
fn an_interruptible_run_keeps_verlets_reused_force() {
    use dth::methods::StormerVerlet;
    use dth::nalgebra::{Const, Matrix2, Vector2};
    use dth::{Flags, Hamiltonian};
    use dth_examples::driver::{run_peer, Stop};
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

    /// `H = (p^2 + q^2) / 2`, counting its gradient evaluations.
    struct Counted(AtomicUsize);
    impl Hamiltonian<Const<2>> for Counted {
        fn dim(&self) -> Const<2> {
            Const
        }
        fn flags(&self) -> Flags {
            Flags::default().with_separable(true)
        }
        fn value(&self, z: &Vector2<f64>) -> f64 {
            0.5 * z.norm_squared()
        }
        fn gradient_into(&self, z: &Vector2<f64>, out: &mut Vector2<f64>) {
            self.0.fetch_add(1, Ordering::Relaxed);
            *out = *z;
        }
        fn hessian_into(&self, _: &Vector2<f64>, out: &mut Matrix2<f64>) {
            *out = Matrix2::identity();
        }
    }
    static FLAG: AtomicBool = AtomicBool::new(false);
    let n = 10;
    for flag in [None, Some(&FLAG)] {
        let h = Counted(AtomicUsize::new(0));
        let stop = Stop::steps(n).with_interrupt(flag);
        let z0 = Vector2::new(1.0, 0.0);
        let end = run_peer(StormerVerlet::new(), &h, 0.1, z0, 0.0, stop, &mut ()).unwrap();
        assert_eq!(end.steps, n);
        assert_eq!(
            h.0.load(Ordering::Relaxed),
            3 + 2 * (n - 1),
            "flag {:?}",
            flag.is_some()
        );
    }
}
