//! `dth table41 --json PATH` reproduces the thesis's Table 4.1, through the binary.

mod common;

use common::*;

use std::sync::OnceLock;

use dth::kepler::THESIS_TABLE_4_1 as THESIS;

/// An entry is "at roundoff" when the thesis's value is: below 1e-13, i.e. a few hundred eps
/// times the O(1) energy and angular momentum. Ours must then be at most 3e-14: the
/// average of |Q_k - Q_0| for a quantity conserved exactly by the method is a random walk of
/// roundoff, a few eps sqrt(k) at worst over 10^4 steps.
const ROUNDOFF: f64 = 1e-13;

/// One run of `dth table41 --json t41.json` in an empty folder, shared by the tests here (the
/// run is the slow part).
struct Run {
    status: Option<i32>,
    stdout: String,
    stderr: String,
    /// The JSON file's text.
    json: String,
    /// What the folder held afterwards.
    entries: Vec<String>,
}

fn table41() -> &'static Run {
    static RUN: OnceLock<Run> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let o = dth(&["table41", "--json", "t41.json"], dir.path());
        Run {
            status: o.status.code(),
            stdout: stdout(&o),
            stderr: stderr(&o),
            json: std::fs::read_to_string(dir.path().join("t41.json")).unwrap_or_default(),
            entries: entries(dir.path()),
        }
    })
}

#[test]
fn table41_matches_the_thesis() {
    let run = table41();
    assert_eq!(run.status, Some(0), "{}", run.stderr);
    let md = &run.stdout;
    let json: serde_json::Value = serde_json::from_str(&run.json).unwrap();
    // Exactly {"rows": [{"method", "energy", "angular_momentum"}, ...]} in the thesis's order.
    let obj = json.as_object().unwrap();
    assert_eq!(obj.keys().collect::<Vec<_>>(), ["rows"]);
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), THESIS.len());
    for (row, t) in rows.iter().zip(&THESIS) {
        let (method, e_thesis, l_thesis) = (t.method, t.energy, t.angular_momentum);
        let mut keys: Vec<_> = row.as_object().unwrap().keys().cloned().collect();
        keys.sort();
        assert_eq!(keys, ["angular_momentum", "energy", "method"]);
        assert_eq!(row["method"], method);
        for (what, ours, thesis) in [
            ("energy", row["energy"].as_f64().unwrap(), e_thesis),
            (
                "angular_momentum",
                row["angular_momentum"].as_f64().unwrap(),
                l_thesis,
            ),
        ] {
            if thesis < ROUNDOFF {
                assert!(
                    (0.0..=3e-14).contains(&ours),
                    "{method} {what}: {ours:e} is not at roundoff"
                );
            } else {
                assert!(
                    ((ours - thesis) / thesis).abs() <= 0.01,
                    "{method} {what}: {ours:e} vs thesis {thesis:e}"
                );
            }
        }
        // The markdown shows the thesis's value beside ours.
        assert!(
            md.lines().any(|l| l.starts_with(&format!("| {method} |"))
                && l.contains(&format!("{e_thesis:.3e}"))),
            "{md}"
        );
    }
    // The DTH midpoint energy is no worse than the thesis's 1.285e-14.
    let dth_energy = rows[3]["energy"].as_f64().unwrap();
    assert!(dth_energy <= 1.285e-14, "{dth_energy:e}");
    // Nothing but the requested file is written.
    assert_eq!(run.entries, ["t41.json"]);
}

/// The root README shows what `dth table41` prints: its table under `### Table 4.1` is the
/// command's markdown, row for row, so the numbers cannot go stale unnoticed.
#[test]
fn the_readme_shows_what_table41_prints() {
    let run = table41();
    assert_eq!(run.status, Some(0), "{}", run.stderr);
    let readme = std::fs::read_to_string(manifest_dir().join("../README.md")).unwrap();
    let section = readme
        .split_once("\n### Table 4.1\n")
        .map(|(_, rest)| rest)
        .expect("the README has a `### Table 4.1` section");
    let table = |text: &str| -> Vec<String> {
        text.lines()
            .skip_while(|l| !l.starts_with('|'))
            .take_while(|l| l.starts_with('|'))
            .map(|l| l.trim_end().to_string())
            .collect()
    };
    let printed = table(&run.stdout);
    assert_eq!(printed.len(), 2 + THESIS.len(), "{}", run.stdout);
    assert_eq!(
        table(section),
        printed,
        "update the README's Table 4.1 to what `cargo run --release -- table41` prints"
    );
}
