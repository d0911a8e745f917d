//! `dth run`, `dth check`, `dth list` and the output folder, through the built binary.

mod common;

use common::*;

#[test]
fn good_scene_runs_and_writes_every_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = manifest_dir().join("tests/scenes/pipeline-kepler.toml");
    let o = dth(
        &["run", scene.to_str().unwrap(), "--out", "out/pipeline"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = dir.path().join("out/pipeline");
    let files = entries(&out);
    for f in [
        ".dth-output",
        "index.html",
        "summary.json",
        "energy_deviation.png",
        "energy_deviation.svg",
        "invariant_angular_momentum.png",
        "poincare1.png",
        "phase1.png",
        "phase1.svg",
        "time_law_t.png",
        "midpoint_trajectory.csv",
        "midpoint_energy.csv",
        "midpoint_angular_momentum.csv",
        "midpoint_poincare1.csv",
        "dth_coarse_time_law.csv",
        "dth_coarse_trajectory.csv",
        "time_law_lambda.png",
    ] {
        assert!(files.contains(&f.to_string()), "missing {f} in {files:?}");
    }
    // Nothing else next to the output folder (the staging folder was moved, not copied).
    assert_eq!(entries(&dir.path().join("out")), ["pipeline"]);
    // The summary is valid JSON with both methods, run for 2 orbits of the thesis period.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let methods = summary["methods"].as_array().unwrap();
    assert_eq!(methods.len(), 2);
    let t_end = methods[0]["t_end"].as_f64().unwrap();
    assert!((t_end - 2.0 * 3.7483).abs() < 2e-3, "{t_end}");
    // The page references the figures by relative path and loads nothing from the network.
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("<img src=\"phase1.png\""));
    assert!(!html.contains("http://") && !html.contains("https://") && !html.contains("<script"));
    // `until = 1.0` keeps the time series to t <= 1 (steps 0..=1000 at dt = 0.001).
    let series = std::fs::read_to_string(out.join("midpoint_phase2.csv")).unwrap();
    assert_eq!(series.lines().count(), 1 + 1001);
    let last_t: f64 = series
        .lines()
        .last()
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(last_t <= 1.0 && last_t > 0.999, "{last_t}");
    // The ensemble: 4 x 4 members, each after 25 steps of dt = 0.001 (t = 0.025).
    let ens = std::fs::read_to_string(out.join("midpoint_ensemble.csv")).unwrap();
    assert_eq!(ens.lines().count(), 1 + 16);
    for line in ens.lines().skip(1) {
        let t: f64 = line.split(',').nth(2).unwrap().parse().unwrap();
        assert!((t - 0.025).abs() < 1e-12, "{line}");
    }
    assert!(files.contains(&"ensemble_dth_coarse.png".to_string()));
    // PNGs are PNGs.
    let png = std::fs::read(out.join("phase1.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn rerun_replaces_an_old_output_folder_only_after_success() {
    let dir = tempfile::tempdir().unwrap();
    let good = manifest_dir().join("tests/scenes/pipeline-kepler.toml");
    let o = dth(&["run", good.to_str().unwrap(), "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let before = std::fs::read(dir.path().join("o/summary.json")).unwrap();
    // A run that cannot start (the exact Kepler solution of an unbound orbit, H > 0) fails
    // before anything is moved.
    let unbound = std::fs::read_to_string(&good)
        .unwrap()
        .replace("p = [0.0, 1.2]", "p = [0.0, 3.0]")
        .replace("orbits = 2", "steps = 10")
        .replace("kind = \"midpoint\"", "kind = \"exact\"");
    std::fs::write(dir.path().join("unbound.toml"), unbound).unwrap();
    let o = dth(&["run", "unbound.toml", "--out", "o"], dir.path());
    std::fs::remove_file(dir.path().join("unbound.toml")).unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "method `exact` cannot run: this system has no exact solution for this initial state"
        ),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        std::fs::read(dir.path().join("o/summary.json")).unwrap(),
        before
    );
    assert_eq!(
        entries(dir.path()),
        ["o"],
        "a staging folder was left behind"
    );
    // Running again succeeds and replaces it.
    let o = dth(&["run", good.to_str().unwrap(), "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(entries(dir.path()), ["o"]);
}

#[test]
fn a_foreign_folder_is_never_replaced() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("mine")).unwrap();
    std::fs::write(dir.path().join("mine/notes.txt"), "keep").unwrap();
    let good = manifest_dir().join("tests/scenes/pipeline-kepler.toml");
    let o = dth(
        &["run", good.to_str().unwrap(), "--out", "mine"],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("not a dth output folder"),
        "{}",
        stderr(&o)
    );
    assert_eq!(entries(&dir.path().join("mine")), ["notes.txt"]);
    assert_eq!(entries(dir.path()), ["mine"]);
}

/// A scene kept in its own output folder (`dth run out/scene.toml --out out`) was deleted when
/// the run replaced the folder. Such a run is now refused before it starts.
#[test]
fn an_output_folder_holding_the_scene_is_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::fs::read(manifest_dir().join("tests/scenes/pipeline-kepler.toml")).unwrap();
    std::fs::write(dir.path().join("s.toml"), &scene).unwrap();
    let o = dth(&["run", "s.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    std::fs::write(dir.path().join("out/s.toml"), &scene).unwrap();
    let before = files(&dir.path().join("out"));
    let o = dth(&["run", "out/s.toml", "--out", "out"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("refusing to write to `out`: it holds the scene"),
        "{err}"
    );
    assert_eq!(files(&dir.path().join("out")), before);
    assert_eq!(entries(dir.path()), ["out", "s.toml"]);
}

#[test]
fn a_method_failing_mid_run_keeps_its_trajectory_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let scene = manifest_dir().join("tests/scenes/rk4-blowup.toml");
    let o = dth(&["run", scene.to_str().unwrap(), "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("method `rk4` failed at step") && err.contains("non-finite"),
        "{err}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("o/summary.json")).unwrap())
            .unwrap();
    let m = &summary["methods"][0];
    let failed_at = m["failure"]["step"].as_u64().unwrap();
    // |z| grows by |R(3i)| = 1.505 per step from 1: overflow past 1.8e308 after ~1,740 steps.
    assert!(failed_at > 1500 && failed_at < 2000, "{failed_at}");
    // Every state before the failing step is in the trajectory (header + steps 0..failed_at-1).
    let csv = std::fs::read_to_string(dir.path().join("o/rk4_trajectory.csv")).unwrap();
    assert_eq!(csv.lines().count() as u64, 1 + failed_at);
}

#[test]
fn check_accepts_every_shipped_scene() {
    let dir = manifest_dir().join("scenes");
    let mut n = 0;
    for f in entries(&dir) {
        if !f.ends_with(".toml") {
            continue;
        }
        n += 1;
        let o = dth(&["check", dir.join(&f).to_str().unwrap()], &dir);
        assert_eq!(o.status.code(), Some(0), "{f}: {}", stderr(&o));
        assert!(stdout(&o).contains(": ok ("), "{}", stdout(&o));
        assert!(
            stdout(&o).contains("stepping takes about"),
            "{}",
            stdout(&o)
        );
    }
    assert!(
        n >= 5,
        "scenes/ holds the thesis scene and at least four others, found {n}"
    );
    for f in ["pipeline-kepler.toml", "rk4-blowup.toml"] {
        let path = manifest_dir().join("tests/scenes").join(f);
        let o = dth(&["check", path.to_str().unwrap()], &dir);
        assert_eq!(o.status.code(), Some(0), "{f}: {}", stderr(&o));
    }
}

#[test]
fn the_default_scene_is_the_shipped_thesis_scene() {
    let shipped =
        std::fs::read_to_string(manifest_dir().join("scenes/thesis-kepler.toml")).unwrap();
    assert_eq!(dth_examples::DEFAULT_SCENE, shipped);
    let scene = dth_examples::check_scene(
        dth_examples::DEFAULT_SCENE,
        "default",
        &dth_examples::catalogue::Catalogue::builtin(),
    )
    .unwrap();
    assert_eq!(
        (scene.q.as_slice(), scene.p.as_slice()),
        ([0.5, 0.0].as_slice(), [0.0, 1.2].as_slice())
    );
    assert_eq!(scene.duration, dth_examples::scene::Duration::Steps(10_000));
}

#[test]
fn list_and_help_describe_everything() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["list"], dir.path());
    assert_eq!(o.status.code(), Some(0));
    let s = stdout(&o);
    for word in [
        "kepler",
        "harmonic_oscillator",
        "pendulum",
        "henon_heiles",
        "double_pendulum",
        "toda_chain",
        "forced_oscillator",
        "dth",
        "midpoint",
        "poincare",
        "time_law",
        "mass",
    ] {
        assert!(s.contains(word), "`dth list` does not mention {word}");
    }
    for sub in [
        &["--help"][..],
        &["run", "--help"],
        &["check", "--help"],
        &["list", "--help"],
        &["table41", "--help"],
        &["workprecision", "--help"],
    ] {
        let o = dth(sub, dir.path());
        assert_eq!(o.status.code(), Some(0), "{sub:?}");
        assert!(stdout(&o).contains("Usage"), "{sub:?}");
    }
    // --help must not create output.
    assert!(entries(dir.path()).is_empty());
}

/// Every scene in `scenes/` runs to completion with every method (full duration: each takes
/// well under a few seconds in the dev profile), and writes its summary and page.
#[test]
fn every_shipped_scene_runs() {
    let scenes = manifest_dir().join("scenes");
    let dir = tempfile::tempdir().unwrap();
    let mut n = 0;
    for f in entries(&scenes) {
        let Some(stem) = f.strip_suffix(".toml") else {
            continue;
        };
        // The FPUT scene takes 134,000 DTH steps at D = 64 (dense Newton: over a minute in the
        // dev profile); `tests/fput.rs` runs it at reduced length instead.
        // `fput-4096.toml`, `cluster-64.toml` and `calogero-256.toml` are benchmark scenes
        // (4,096 sites; 64 and 256 bodies with dense Newton matrices: for release);
        // `tests/scene_hamiltonian.rs` runs them at reduced sizes.
        if [
            "fput.toml",
            "fput-4096.toml",
            "cluster-64.toml",
            "calogero-256.toml",
        ]
        .contains(&f.as_str())
        {
            continue;
        }
        n += 1;
        let o = dth(
            &["run", scenes.join(&f).to_str().unwrap(), "--out", stem],
            dir.path(),
        );
        assert_eq!(o.status.code(), Some(0), "{f}: {}", stderr(&o));
        let out = dir.path().join(stem);
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        for m in summary["methods"].as_array().unwrap() {
            assert!(m["failure"].is_null(), "{f}: {m}");
            assert!(m["steps"].as_u64().unwrap() > 0, "{f}: {m}");
        }
        assert!(out.join("index.html").is_file(), "{f}");
    }
    assert!(n >= 5, "{n} scenes");
}

/// No arguments runs the embedded thesis scene (the full run, 10,000 steps per method plus the
/// refined runs of Figures 4.14 and 4.15: a few seconds in the dev profile) into
/// `dth-out/thesis-kepler`: Table 4.1 on stdout, Figures 4.1-4.15 as PNG and SVG, CSV data,
/// `summary.json`, `table41.json` and `index.html`.
#[test]
fn no_arguments_runs_the_thesis_experiment_with_every_figure() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&[], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = dir.path().join("dth-out/thesis-kepler");
    let files = entries(&out);
    let numbers: Vec<String> = (1..=15).map(|i| format!("4.{i}")).collect();
    for i in 1..=15 {
        for ext in ["png", "svg"] {
            let f = format!("fig4_{i}.{ext}");
            assert!(files.contains(&f), "missing {f} in {files:?}");
        }
        let png = std::fs::read(out.join(format!("fig4_{i}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    }
    for f in [
        "index.html",
        "summary.json",
        "table41.json",
        "dth_trajectory.csv",
        "exact_trajectory.csv",
        "trapezoidal_energy.csv",
        "dth_poincare1.csv",
    ] {
        assert!(files.contains(&f.to_string()), "missing {f} in {files:?}");
    }
    // Table 4.1 is printed with the thesis's values beside ours.
    let s = stdout(&o);
    assert!(s.contains("Table 4.1"), "{s}");
    assert!(
        s.contains("| dth_vertices |") && s.contains("1.750e-2"),
        "{s}"
    );
    // The summary lists the figures in the thesis's order, and the table's five rows.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let listed: Vec<&str> = summary["thesis_figures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["number"].as_str().unwrap())
        .collect();
    assert_eq!(listed, numbers);
    assert_eq!(summary["table41"]["rows"].as_array().unwrap().len(), 5);
    for m in summary["methods"].as_array().unwrap() {
        assert!(m["failure"].is_null(), "{m}");
        assert_eq!(m["steps"], 10_000, "{m}");
    }
    // The page shows Table 4.1 and every figure by relative path, with nothing from the network.
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("<h2>Table 4.1</h2>"));
    assert!(html.contains("; duration 10,000 steps.</p>"), "{html}");
    for i in 1..=15 {
        assert!(
            html.contains(&format!("<img src=\"fig4_{i}.png\"")),
            "fig4_{i}"
        );
    }
    assert!(!html.contains("http://") && !html.contains("https://") && !html.contains("<script"));
    // Only the output folder was created.
    assert_eq!(entries(dir.path()), ["dth-out"]);
    assert_eq!(entries(&dir.path().join("dth-out")), ["thesis-kepler"]);
}

/// The files and the page say what they hold: CSV columns named after the effect's
/// coordinates (not `x,y`), the duration as people write it (not Rust's debug text).
#[test]
fn outputs_name_what_they_hold() {
    let dir = tempfile::tempdir().unwrap();
    let scene = manifest_dir().join("tests/scenes/pipeline-kepler.toml");
    let o = dth(&["run", scene.to_str().unwrap(), "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = dir.path().join("o");
    let header = |f: &str| {
        std::fs::read_to_string(out.join(f))
            .unwrap()
            .lines()
            .next()
            .unwrap_or_default()
            .to_string()
    };
    // phase_plot x = "q1", y = "q2"; then x = "t", y = "q1"; the section is plotted in q1, p1.
    assert_eq!(header("midpoint_phase1.csv"), "t,q1,q2");
    assert_eq!(header("dth_coarse_phase2.csv"), "t,q1");
    assert_eq!(header("midpoint_poincare1.csv"), "t,q1,p1");
    // Every CSV of states has `t`, and every row the header's number of cells (DTH's last,
    // shortened step has no vertex: its vertex cells are empty, not missing).
    for name in entries(&out).iter().filter(|n| n.ends_with(".csv")) {
        let text = std::fs::read_to_string(out.join(name)).unwrap();
        let mut lines = text.lines();
        let columns: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert!(columns.contains(&"t"), "{name}: {columns:?}");
        for (i, line) in lines.enumerate() {
            assert_eq!(
                line.split(',').count(),
                columns.len(),
                "{name} row {i}: {line}"
            );
        }
    }
    // The trajectory says what its rows are: DTH's initial vertex, then midpoints; a
    // fixed-step method's states after steps.
    let rows = |f: &str| -> Vec<String> {
        let text = std::fs::read_to_string(out.join(f)).unwrap();
        let mut lines = text.lines();
        let col = lines
            .next()
            .unwrap()
            .split(',')
            .position(|c| c == "row")
            .unwrap();
        lines
            .map(|l| l.split(',').nth(col).unwrap().to_string())
            .collect()
    };
    let dth = rows("dth_coarse_trajectory.csv");
    assert_eq!(dth[0], "vertex");
    assert!(
        dth.len() > 2 && dth[1..].iter().all(|r| r == "midpoint"),
        "{dth:?}"
    );
    assert!(rows("midpoint_trajectory.csv").iter().all(|r| r == "step"));
    // The trajectory as `.npy`: the CSV's numeric columns (all but `step_kind` and `row`),
    // the same numbers.
    let csv = std::fs::read_to_string(out.join("dth_coarse_trajectory.csv")).unwrap();
    let npy = std::fs::read(out.join("dth_coarse_trajectory.npy")).unwrap();
    assert_eq!(&npy[..6], b"\x93NUMPY");
    let len = usize::from(u16::from_le_bytes([npy[8], npy[9]]));
    let header = String::from_utf8_lossy(&npy[10..10 + len]).into_owned();
    let cells: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let width = cells[0].len() - 2;
    assert!(
        header.contains(&format!("'shape': ({}, {width})", cells.len())),
        "{header}"
    );
    let values: Vec<f64> = npy[10 + len..]
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect();
    for (i, row) in cells.iter().enumerate() {
        for (j, cell) in row[..width].iter().enumerate() {
            let v = values[i * width + j];
            match cell.parse::<f64>() {
                Ok(x) => assert_eq!(x, v, "row {i} column {j}"),
                Err(_) => assert!(cell.is_empty() && v.is_nan(), "row {i} column {j}"),
            }
        }
    }
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("; duration 2 orbits.</p>"), "{html}");
    assert!(!html.contains("Orbits("), "{html}");
}

/// A method that failed shows the last time it reached, marked, not `-`.
#[test]
fn a_failed_method_shows_where_it_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let scene = manifest_dir().join("tests/scenes/rk4-blowup.toml");
    let o = dth(&["run", scene.to_str().unwrap(), "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("o/summary.json")).unwrap())
            .unwrap();
    let m = &summary["methods"][0];
    let steps = m["steps"].as_f64().unwrap();
    assert_eq!(steps + 1.0, m["failure"]["step"].as_f64().unwrap());
    // dt = 3 from t = 0: the last state before the failing step is at t = 3 steps.
    let t_end = m["t_end"].as_f64().expect("t_end is the last time reached");
    assert_eq!(t_end, 3.0 * steps);
    let html = std::fs::read_to_string(dir.path().join("o/index.html")).unwrap();
    assert!(
        html.contains(&format!(
            "<td><span class=\"fail\">{t_end:.4e} (stopped)</span></td>"
        )),
        "{html}"
    );
    assert!(html.contains("duration 3,000 steps"), "{html}");
}

/// `dth list` names every system a method is restricted to, from the catalogue: `exact`
/// serves the free particle as well as Kepler.
#[test]
fn list_names_the_systems_each_restricted_method_runs_on() {
    let dir = tempfile::tempdir().unwrap();
    let o = dth(&["list"], dir.path());
    assert_eq!(o.status.code(), Some(0));
    let s = stdout(&o);
    let systems_of = |method: &str| {
        let mut lines = s
            .lines()
            .skip_while(|l| !l.starts_with(&format!("  {method} ")));
        let doc = lines.next().unwrap_or_default().to_string();
        (doc, lines.next().unwrap_or_default().trim().to_string())
    };
    let (doc, systems) = systems_of("exact");
    assert!(!doc.contains("kepler"), "{doc}");
    assert_eq!(systems, "systems: kepler, free_particle");
    assert_eq!(
        systems_of("discrete_mechanics").1,
        "systems: kepler, free_particle"
    );
    // Each parameter's rule, as validation enforces it.
    assert!(s.contains("m = 1 (mass, > 0)"), "{s}");
    assert!(s.contains("f = 0.1 (forcing amplitude)"), "{s}");
    // Every system runs midpoint: no list.
    assert!(!systems_of("midpoint").1.starts_with("systems:"), "{s}");
}

/// `time_law` on a fixed-step method used to write `NaN` as its `lambda` (a method without a
/// law of time has none): the column is empty, as in the trajectory, and DTH's is a number.
#[test]
fn time_law_writes_no_nan_for_a_fixed_step_method() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[system]\nname = \"harmonic_oscillator\"\n[initial]\nq = [1.0]\np = [0.0]\n\
                 [[method]]\nkind = \"midpoint\"\ndt = 0.1\n[[method]]\nkind = \"dth\"\ndtau = 0.1\n\
                 [duration]\nsteps = 2\n[[effect]]\nkind = \"time_law\"\n";
    std::fs::write(dir.path().join("law.toml"), scene).unwrap();
    let o = dth(&["run", "law.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let read = |f: &str| std::fs::read_to_string(dir.path().join("out").join(f)).unwrap();
    let midpoint = read("midpoint_time_law.csv");
    assert_eq!(midpoint, "step,t,lambda\n0,0e0,\n1,1e-1,\n2,2e-1,\n");
    let dth_rows: Vec<String> = read("dth_time_law.csv").lines().map(String::from).collect();
    assert_eq!(dth_rows.len(), 4, "{dth_rows:?}");
    for row in &dth_rows[1..] {
        let lambda: f64 = row.rsplit(',').next().unwrap().parse().unwrap();
        assert!(lambda.is_finite() && lambda > 0.0, "{row}");
    }
}

/// A scene with `thesis_figures = true` whose DTH breaks down (Kepler at e = 0.9): the
/// figures run the methods again, the failure there was an error, and the whole output
/// (every method's results, Table 4.1) was discarded. Now the figures are missing, said why,
/// and the rest is written (exit 1, as for any failed method).
#[test]
fn a_failing_method_costs_the_thesis_figures_not_the_output() {
    let scene = "thesis_figures = true\n[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\n\
                 p = [0.0, 1.378404875209022]\n\
                 [[method]]\nkind = \"exact\"\ndt = 0.15\n[[method]]\nkind = \"trapezoidal\"\ndt = 0.15\n\
                 [[method]]\nkind = \"midpoint\"\ndt = 0.15\n[[method]]\nkind = \"discrete_mechanics\"\ndt = 0.15\n\
                 [[method]]\nkind = \"dth\"\ndtau = 0.01\n[duration]\nsteps = 40\n\
                 [ensemble]\nx = \"q1\"\ny = \"p1\"\nhalf_width = 0.01\nper_side = 2\nsteps = 5\n\
                 [[effect]]\nkind = \"final_state\"\n";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("e09.toml"), scene).unwrap();
    let o = dth(&["run", "e09.toml", "--out", "out"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("error: the thesis's figures were not drawn: method `dth (thesis Figures 4.1-4.9)` failed at step"),
        "{err}"
    );
    let out = dir.path().join("out");
    let files = entries(&out);
    for f in [
        "summary.json",
        "index.html",
        "table41.json",
        "midpoint_ensemble.csv",
    ] {
        assert!(files.contains(&f.to_string()), "{f} missing: {files:?}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(summary["thesis_figures_failure"]
        .as_str()
        .is_some_and(|s| s.contains("DTH breaks down")));
    let failed: Vec<&str> = summary["methods"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| !m["failure"].is_null())
        .map(|m| m["label"].as_str().unwrap())
        .collect();
    assert_eq!(failed, ["dth"]);
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("not drawn: method `dth (thesis Figures 4.1-4.9)`"));
}

/// A method that fails at its first step has no deviation to show: its table rows printed
/// `0.000e0` (perfect conservation) for a mean over no states. They now show `-`, in the
/// printed table and in index.html.
#[test]
fn a_method_that_took_no_step_shows_no_deviation() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [[method]]\nkind = \"midpoint\"\ndt = 1e300\n[duration]\nsteps = 3\n\
                 [[effect]]\nkind = \"comparison_table\"\n";
    std::fs::write(dir.path().join("bad-dt.toml"), scene).unwrap();
    let o = dth(&["run", "bad-dt.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let table = stdout(&o);
    assert!(
        table.contains("| midpoint | energy | - | - | - | - |"),
        "{table}"
    );
    assert!(!table.contains("0.000e0"), "{table}");
    let html = std::fs::read_to_string(dir.path().join("out/index.html")).unwrap();
    assert!(
        html.contains("<tr><td>midpoint</td><td>energy</td><td>-</td><td>-</td>"),
        "{html}"
    );
}

/// The thesis's square around a Kepler orbit near escape: `exact` cannot run from the member
/// past the escape energy, and that ended the run (exit 1, nothing written). The member is
/// now a row with its failure and the others complete.
#[test]
fn a_square_member_a_method_cannot_run_from_is_its_row() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.40]\n\
                 [[method]]\nkind = \"exact\"\ndt = 0.01\n[duration]\nsteps = 10\n\
                 [ensemble]\nx = \"q1\"\ny = \"p2\"\nhalf_width = 0.02\nper_side = 2\nsteps = 5\n";
    std::fs::write(dir.path().join("square.toml"), scene).unwrap();
    let o = dth(&["run", "square.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let csv = std::fs::read_to_string(dir.path().join("out/exact_ensemble.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 4, "{csv}");
    // p2 = 1.42 at q1 = 0.52 is past the escape speed (E = p^2 - 1/r > 0): that member only.
    let failed: Vec<&&str> = rows.iter().filter(|r| r.contains("cannot run")).collect();
    // The last column is the member's fallback steps (none: `exact` has no robust mode).
    assert_eq!(failed, [&"5.2e-1,1.42e0,,,,,,step 0: method `exact` cannot run: this system has no exact solution for this initial state (Kepler: an elliptic orbit is needed),0"]);
}

/// RK4 at `dt` = 10 on `H = (p^2 + q^2)/2` from `q = 1e150` grows the state about 400-fold a
/// step: `q^2` overflows at step 2 while the state stays finite, so the energy deviation is
/// infinite. `summary.json` wrote it as `null`, the same as a missing value (`"vertices":
/// null`); every JSON the command writes now spells a non-finite number as a string.
#[test]
fn an_infinite_deviation_is_not_null_in_summary_json() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[system]\nhamiltonian = \"(p1^2 + q1^2)/2\"\n[initial]\nq = [1e150]\np = [0.0]\n\
                 [[method]]\nkind = \"rk4\"\ndt = 10.0\n[duration]\nsteps = 3\n\
                 [[effect]]\nkind = \"energy_deviation\"\n";
    std::fs::write(dir.path().join("inf.toml"), scene).unwrap();
    let o = dth(&["run", "inf.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    let energy = &summary["methods"][0]["energy"];
    assert_eq!(energy["points"]["max"], "Infinity", "{text}");
    assert_eq!(energy["points"]["mean"], "Infinity", "{text}");
    assert_eq!(energy["points"]["count"], 3, "{text}");
    // A value that is absent is still `null`.
    assert!(energy["vertices"].is_null(), "{text}");
}

/// A rerun removes only what dth wrote (the manifest in `.dth-output`): a user's notes and
/// plots kept in the output folder survive it. A rerun that does not complete (a method
/// fails mid-run) does not replace the complete result: it goes to `o.incomplete`, and the
/// command says where.
#[test]
fn a_rerun_keeps_the_users_files_and_the_complete_result() {
    let dir = tempfile::tempdir().unwrap();
    let good = manifest_dir().join("tests/scenes/pipeline-kepler.toml");
    let o = dth(&["run", good.to_str().unwrap(), "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = dir.path().join("o");
    std::fs::write(out.join("my_notes.txt"), "mine").unwrap();
    std::fs::create_dir(out.join("myplots")).unwrap();
    std::fs::write(out.join("myplots/a.png"), "mine").unwrap();
    let o = dth(&["run", good.to_str().unwrap(), "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(out.join("my_notes.txt")).unwrap(),
        "mine"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("myplots/a.png")).unwrap(),
        "mine"
    );
    assert!(out.join("summary.json").is_file());
    assert_eq!(
        entries(dir.path()),
        ["o"],
        "a hidden folder was left behind"
    );
    let complete = (
        entries(&out),
        std::fs::read(out.join("summary.json")).unwrap(),
    );
    // A failing rerun into the same folder.
    let blowup = manifest_dir().join("tests/scenes/rk4-blowup.toml");
    let o = dth(&["run", blowup.to_str().unwrap(), "--out", "o"], dir.path());
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("`o` holds a complete earlier result, kept as it was; this incomplete run is in `o.incomplete`"),
        "{err}"
    );
    assert_eq!(
        (
            entries(&out),
            std::fs::read(out.join("summary.json")).unwrap()
        ),
        complete
    );
    assert!(dir.path().join("o.incomplete/rk4_trajectory.csv").is_file());
    let manifest = std::fs::read_to_string(dir.path().join("o.incomplete/.dth-output")).unwrap();
    assert!(manifest.contains("state = incomplete"), "{manifest}");
    assert_eq!(entries(dir.path()), ["o", "o.incomplete"]);
}

/// Fixed-step methods end exactly at the scene's end time: `exact` with `dt = 1` on
/// `orbits = 10` of a Kepler orbit of period 3.748 ended at 38 (a whole step past it). The
/// last step is now what is left to T.
#[test]
fn fixed_step_methods_end_at_the_end_time() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[system]\nname = \"kepler\"\nparams = { m = 0.5, k = 1.0 }\n\
                 [initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [[method]]\nkind = \"exact\"\ndt = 1.0\n\
                 [[method]]\nkind = \"rk4\"\ndt = 1.0\n\
                 [duration]\norbits = 10\n[[effect]]\nkind = \"final_state\"\n";
    std::fs::write(dir.path().join("k.toml"), scene).unwrap();
    let o = dth(&["run", "k.toml", "--out", "o"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("o/summary.json")).unwrap())
            .unwrap();
    // Kepler's third law: E = |p|^2/(2m) - k/|q|, a = k/(2|E|), T = 2 pi sqrt(m a^3/k).
    let (m, k) = (0.5f64, 1.0f64);
    let e = 1.2f64.powi(2) / (2.0 * m) - k / 0.5;
    let a = k / (2.0 * e.abs());
    let t_end = 10.0 * 2.0 * std::f64::consts::PI * (m * a.powi(3) / k).sqrt();
    for method in summary["methods"].as_array().unwrap() {
        let t = method["t_end"].as_f64().unwrap();
        // Roundoff of the period's arithmetic (a few eps of 37.5).
        assert!(
            (t - t_end).abs() <= 16.0 * f64::EPSILON * t_end,
            "{}: ended at {t}, T = {t_end}",
            method["label"]
        );
        assert_eq!(method["steps"].as_u64(), Some(38), "{method}");
    }
}
