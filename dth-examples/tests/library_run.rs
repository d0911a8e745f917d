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
