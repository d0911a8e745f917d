//! SIGINT and SIGTERM stop a run cleanly: exit 130, nothing written, no temporary folder left,
//! the previous output folder untouched.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;

/// A scene that runs for minutes (10^9 DTH steps), so the signal arrives mid-run.
const LONG: &str = "[system]\nname = \"pendulum\"\n[initial]\nq = [0.5]\np = [0.0]\n\
                    [[method]]\nkind = \"dth\"\ndtau = 0.01\n[duration]\nsteps = 1000000000\n\
                    [[effect]]\nkind = \"comparison_table\"\n";

/// The same system for a few steps: the previous output.
const SHORT: &str = "[system]\nname = \"pendulum\"\n[initial]\nq = [0.5]\np = [0.0]\n\
                     [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[duration]\nsteps = 10\n\
                     [[effect]]\nkind = \"final_state\"\n";

/// The staging folders (`.out.tmp-*`) in `dir`.
fn staging(dir: &Path) -> Vec<String> {
    entries(dir)
        .into_iter()
        .filter(|n| n.starts_with(".out.tmp-"))
        .collect()
}

fn interrupt(signal: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("long.toml"), LONG).unwrap();
    std::fs::write(dir.path().join("short.toml"), SHORT).unwrap();
    let first = dth(&["run", "short.toml", "--out", "out"], dir.path());
    assert_eq!(first.status.code(), Some(0), "{}", stderr(&first));
    let before = entries(&dir.path().join("out"));

    let child = Command::new(env!("CARGO_BIN_EXE_dth"))
        .args(["run", "long.toml", "--out", "out"])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the run has its staging folder (it is then integrating).
    let start = Instant::now();
    while staging(dir.path()).is_empty() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no staging folder appeared"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(200));
    let kill = Command::new("kill")
        .args(["-s", signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    assert!(stderr(&out).contains("interrupted: nothing was written"));
    assert!(staging(dir.path()).is_empty(), "{:?}", entries(dir.path()));
    assert_eq!(entries(&dir.path().join("out")), before);
}

#[test]
fn sigint_leaves_nothing_behind() {
    interrupt("INT");
}

#[test]
fn sigterm_leaves_nothing_behind() {
    interrupt("TERM");
}
