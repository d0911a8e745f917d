//! SIGINT (Ctrl-C) and SIGTERM during `dth run` stop the run at the next step: it writes what
//! it computed, `summary.json` says where it stopped, and it exits with 130. Outside a run
//! (here `dth workprecision`) a signal quits at once: exit 130, nothing written, no temporary
//! folder left.

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::*;

/// A scene that runs for minutes (10^9 DTH steps, then as many midpoint steps), so the signal
/// arrives mid-run.
const LONG: &str = "[system]\nname = \"pendulum\"\n[initial]\nq = [0.5]\np = [0.0]\n\
                    [[method]]\nkind = \"dth\"\ndtau = 0.01\n\
                    [[method]]\nkind = \"midpoint\"\ndt = 0.01\n[duration]\nsteps = 1000000000\n\
                    [[effect]]\nkind = \"comparison_table\"\n";

/// The staging folders (`.NAME.tmp-*`) in `dir`.
fn staging(dir: &Path) -> Vec<String> {
    entries(dir)
        .into_iter()
        .filter(|n| n.starts_with('.') && n.contains(".tmp-"))
        .collect()
}

/// Starts `dth ARGS` in `dir`, waits until its staging folder exists (it is then computing),
/// and sends it `signal`.
fn signal_when_staged(args: &[&str], dir: &Path, signal: &str) -> Child {
    let child = Command::new(env!("CARGO_BIN_EXE_dth"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while staging(dir).is_empty() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no staging folder appeared"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let kill = Command::new("kill")
        .args(["-s", signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    child
}

fn interrupt(signal: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("long.toml"), LONG).unwrap();
    let child = signal_when_staged(&["run", "long.toml", "--out", "out"], dir.path(), signal);
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted before step") && err.contains("of method `dth`"),
        "{err}"
    );
    assert!(err.contains("not run: midpoint"), "{err}");
    assert!(staging(dir.path()).is_empty(), "{:?}", entries(dir.path()));
    let text = std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let interrupted = &summary["interrupted"];
    assert_eq!(interrupted["method"], "dth", "{text}");
    assert_eq!(
        interrupted["not_run"],
        serde_json::json!(["midpoint"]),
        "{text}"
    );
    // It stopped before `step`: the steps before it are in the output.
    let step = interrupted["step"].as_u64().unwrap();
    let dth = &summary["methods"][0];
    assert_eq!(dth["steps"].as_u64(), Some(step - 1), "{text}");
    assert_eq!(
        dth["energy"]["points"]["count"].as_u64(),
        Some(step - 1),
        "{text}"
    );
    assert_eq!(
        summary["methods"].as_array().map(Vec::len),
        Some(1),
        "{text}"
    );
    assert!(dir.path().join("out/index.html").is_file());
}

#[test]
fn sigint_stops_a_run_and_writes_what_it_computed() {
    interrupt("INT");
}

#[test]
fn sigterm_stops_a_run_and_writes_what_it_computed() {
    interrupt("TERM");
}

#[test]
fn a_signal_outside_a_run_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let child = signal_when_staged(&["workprecision", "--out", "wp"], dir.path(), "INT");
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    assert!(stderr(&out).contains("interrupted: nothing was written"));
    assert!(entries(dir.path()).is_empty(), "{:?}", entries(dir.path()));
}
