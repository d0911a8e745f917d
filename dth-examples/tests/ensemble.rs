//! Ensemble scenes: the same bytes for any thread count, the energy shell, MEGNO on known
//! Henon-Heiles orbits, and a failing member recorded while the others complete.

mod common;

use common::files;
use std::path::Path;

use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::RunOptions;

/// Runs `scene` into `out` with `threads` threads.
fn run(scene: &str, out: &Path, threads: usize) -> dth_examples::report::RunReport {
    let options = RunOptions::default()
        .with_progress(false)
        .with_threads(threads);
    dth_examples::run_scene(scene, "ensemble.toml", &Catalogue::builtin(), out, &options).unwrap()
}

fn json(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("ensemble.json")).unwrap()).unwrap()
}

/// Henon-Heiles starts on the plane q1 = 0, p1 solved from H = E.
fn henon_heiles(sampler: &str, energy: &str, extra: &str, method: &str, time: f64) -> String {
    format!(
        "title = \"HH\"\n[system]\nname = \"henon_heiles\"\n[initial]\nq = [0.0, 0.0]\np = [0.0, 0.0]\n\
         [ensemble]\n{sampler}\nenergy = {energy}\nsolve = \"p1\"\n{extra}\n\
         {method}\n[duration]\ntime = {time}\n"
    )
}

const SECTION: &str =
    "[[effect]]\nkind = \"poincare\"\ncoordinate = \"q1\"\nx = \"q2\"\ny = \"p2\"\n";

#[test]
fn the_files_are_the_same_bytes_on_one_and_on_two_threads() {
    let scene = henon_heiles(
        "kind = \"random\"\nx = \"q2\"\nx_range = [-0.4, 0.6]\ny = \"p2\"\ny_range = [-0.45, 0.45]\nsamples = 24\nseed = 7",
        "0.125",
        "chaos = \"megno\"",
        &format!("[[method]]\nkind = \"dth\"\ndtau = 0.1\n[[method]]\nkind = \"rk4\"\ndt = 0.1\n{SECTION}"),
        60.0,
    );
    // Both runs write the same folder (its path is in summary.json), one after the other.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let r1 = run(&scene, &out, 1);
    let a = files(&out);
    let rows = json(&out)["rows"].as_array().unwrap().len();
    let r2 = run(&scene, &out, 2);
    let b = files(&out);
    assert_eq!(r1.ensemble, r2.ensemble);
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, bytes) in &a {
        assert!(bytes == &b[name], "{name} differs between 1 and 2 threads");
    }
    // The run did something: members with crossings and indicators.
    assert!(a.contains_key("section1_dth.png") && a.contains_key("chaos_map_rk4.png"));
    assert!(rows >= 2 * 12, "{rows} rows");
}

/// `V(0, q2) = q2^2/2 - q2^3/3` on the plane q1 = 0.
fn hh(q: [f64; 2], p: [f64; 2]) -> f64 {
    (p[0] * p[0] + p[1] * p[1]) / 2.0 + (q[0] * q[0] + q[1] * q[1]) / 2.0 + q[0] * q[0] * q[1]
        - q[1].powi(3) / 3.0
}

#[test]
fn the_energy_shell_puts_members_on_h_equals_e_and_counts_the_rest() {
    let e = 0.125;
    let scene = henon_heiles(
        "kind = \"grid\"\nx = \"q2\"\nx_range = [-0.5, 0.7]\nx_count = 9\ny = \"p2\"\ny_range = [-0.5, 0.5]\ny_count = 7",
        "0.125",
        "",
        "[[method]]\nkind = \"rk4\"\ndt = 0.1\n",
        0.2,
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let report = run(&scene, &out, 2);
    // Skipped exactly where p2^2/2 + V(0, q2) > E: no real p1 (counted independently here).
    let mut expected_skipped = Vec::new();
    for i in 0..9 {
        for j in 0..7 {
            let q2 = -0.5 + 1.2 * i as f64 / 8.0;
            let p2 = -0.5 + 1.0 * j as f64 / 6.0;
            if hh([0.0, q2], [0.0, p2]) > e {
                expected_skipped.push(i * 7 + j);
            }
        }
    }
    let v = json(&out);
    let skipped: Vec<usize> = v["skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as usize)
        .collect();
    assert_eq!(skipped, expected_skipped);
    let counts = report.ensemble.unwrap();
    assert_eq!(counts.drawn, 63);
    assert_eq!(counts.skipped, expected_skipped.len());
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 63 - expected_skipped.len());
    for r in rows {
        let s: Vec<f64> = r["start"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        // On the shell to roundoff: H and its terms are O(0.1), so a few eps of them.
        let h = hh([s[0], s[1]], [s[2], s[3]]);
        assert!((h - e).abs() <= 4.0 * f64::EPSILON, "H = {h} at {s:?}");
        assert_eq!(s[0], 0.0);
        assert!(s[2] >= 0.0, "the larger root: p1 >= 0");
    }
}

/// MEGNO `<Y>` and SALI of one start (q2, p2) on the plane q1 = 0 at energy `e`, run to
/// t = 500.
fn megno(e: &str, q2: f64, p2: f64, method: &str) -> (f64, f64) {
    megno_until(e, q2, p2, method, 500.0)
}

/// MEGNO `<Y>` and SALI of one start (q2, p2) on the plane q1 = 0 at energy `e`, run to
/// `time`.
fn megno_until(e: &str, q2: f64, p2: f64, method: &str, time: f64) -> (f64, f64) {
    let scene = henon_heiles(
        &format!("kind = \"list\"\nmembers = \"\"\"\nq2, p2\n{q2}, {p2}\n\"\"\""),
        e,
        "chaos = \"megno\"",
        method,
        time,
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    run(&scene, &out, 1);
    let row = &json(&out)["rows"][0];
    (
        row["megno"].as_f64().unwrap(),
        row["sali"].as_f64().unwrap(),
    )
}

#[test]
fn megno_separates_a_regular_from_a_chaotic_henon_heiles_orbit() {
    // A start inside the main island of the E = 1/8 section (a torus: <Y> -> 2 from below) and
    // one in the chaotic sea at E = 1/6 (<Y> grows like lambda t / 2). Two integrators, so the
    // verdict is the orbit's, not one method's.
    for method in [
        "[[method]]\nkind = \"dth\"\ndtau = 0.05\n",
        "[[method]]\nkind = \"gauss_legendre2\"\ndt = 0.05\n",
    ] {
        let (regular, regular_sali) = megno("0.125", 0.3, 0.0, method);
        let (chaotic, chaotic_sali) = megno("0.16666666666666666", 0.0, -0.25, method);
        assert!(regular < 2.5, "{method}: regular orbit <Y> = {regular}");
        assert!(chaotic > 8.0, "{method}: chaotic orbit <Y> = {chaotic}");
        // SALI: the two tangent vectors stay apart on the torus and align on the chaotic
        // orbit (falling like exp(-(l1 - l2) t): with l1 ~ 0.05 and t = 500, below e^-20).
        assert!(
            regular_sali > 1e-2,
            "{method}: regular orbit SALI = {regular_sali}"
        );
        assert!(
            chaotic_sali < 1e-8,
            "{method}: chaotic orbit SALI = {chaotic_sali}"
        );
    }
}

#[test]
fn a_regular_orbits_verdict_does_not_depend_on_the_step() {
    // Inside the main island at E = 1/8 (q2 = 0.3, p2 = 0.05), t = 1000: a torus, <Y> -> 2.
    // With the tangent step's Hessian taken at each end of the step, coarse steps read
    // <Y> = 3.8 (DTH, dtau = 0.2) and 6.4 (Gauss-Legendre, dt = 0.1) and called it chaotic. The
    // step's Cayley map with the Hessian between its ends is symplectic (the tangent map of the
    // implicit midpoint rule exactly), so the torus's tangent dynamics stays a shear at every
    // step size: the verdict holds at the shipped step (dtau = 0.1), twice and half of it.
    for method in [
        "[[method]]\nkind = \"dth\"\ndtau = 0.2\n",
        "[[method]]\nkind = \"dth\"\ndtau = 0.1\n",
        "[[method]]\nkind = \"dth\"\ndtau = 0.05\n",
        "[[method]]\nkind = \"midpoint\"\ndt = 0.1\n",
        "[[method]]\nkind = \"midpoint\"\ndt = 0.05\n",
        // A fourth-order method with the fourth-order tangent step: 4.05 with the midpoint's.
        "[[method]]\nkind = \"gauss_legendre2\"\ndt = 0.1\n",
        // Stormer-Verlet with its own tangent map: 4.09 with the midpoint's.
        "[[method]]\nkind = \"stormer_verlet\"\ndt = 0.1\n",
        "[[method]]\nkind = \"dth\"\ndtau = 0.2\norder = 4\n",
    ] {
        let (y, _) = megno_until("0.125", 0.3, 0.05, method, 1000.0);
        assert!(
            (1.5..=2.5).contains(&y),
            "{method}: regular orbit <Y> = {y}"
        );
    }
}

#[test]
fn a_chaos_map_checks_its_verdicts_at_half_the_step() {
    // One member, `member` at energy `energy` to time `time`, with `method`: the check's
    // counts, as summary.json has them too.
    let check = |member: &str, energy: &str, time: f64, method: &str| {
        let scene = henon_heiles(
            &format!("kind = \"list\"\nmembers = \"\"\"\nq2, p2\n{member}\n\"\"\""),
            energy,
            "chaos = \"megno\"",
            method,
            time,
        );
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let report = run(&scene, &out, 1);
        let check = report.ensemble.unwrap().step_check.unwrap();
        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
        assert_eq!(
            summary["ensemble"]["step_check"]["changed"].as_u64(),
            Some(check.changed as u64)
        );
        (check.compared, check.changed)
    };
    // At E = 1/6 from q2 = 0.4, p2 = 0, t = 500, DTH at dtau = 0.2 reads <Y> = 7.5 (SALI
    // 8e-7: chaotic) but 1.05 at dtau = 0.1 and 1.08 at 0.025 (regular): a coarse step whose
    // trajectory leaves the torus, which the check must report.
    let dth = "[[method]]\nkind = \"dth\"\ndtau = 0.2\n";
    assert_eq!(check("0.4, 0.0", "0.16666666666666666", 500.0, dth), (1, 1));
    // The regular orbit above (E = 1/8), t = 1000: unchanged at half the step for DTH at the
    // shipped dtau = 0.1 (2.06, then 1.9), Gauss-Legendre at dt = 0.05 (fourth-order tangent
    // step: 1.876 at both) and Stormer-Verlet at dt = 0.05 (its own tangent map: 1.877; the
    // midpoint step along its states read 3.15, then below 2.5 at half).
    for method in [
        "[[method]]\nkind = \"dth\"\ndtau = 0.1\n",
        "[[method]]\nkind = \"gauss_legendre2\"\ndt = 0.05\n",
        "[[method]]\nkind = \"stormer_verlet\"\ndt = 0.05\n",
    ] {
        assert_eq!(
            check("0.3, 0.05", "0.125", 1000.0, method),
            (1, 0),
            "{method}"
        );
    }
}

#[test]
fn a_member_that_fails_is_recorded_and_the_others_complete() {
    // Kepler from q = 0 (the singularity) fails at once; the two bound orbits complete.
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [ensemble]\nkind = \"list\"\nmembers = \"\"\"\nq1, p2\n0.5, 1.2\n0.0, 0.0\n0.6, 1.1\n\"\"\"\n\
                 [[method]]\nkind = \"midpoint\"\ndt = 0.01\n[duration]\nsteps = 200\n";
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let report = run(scene, &out, 2);
    let v = json(&out);
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert!(rows[1]["failure"].is_object(), "{}", rows[1]);
    for i in [0, 2] {
        assert!(rows[i]["failure"].is_null(), "{}", rows[i]);
        assert_eq!(rows[i]["steps"], 200);
    }
    assert_eq!(
        report.ensemble.unwrap().failed_runs + report.ensemble.unwrap().not_run,
        1
    );
    let csv = std::fs::read_to_string(out.join("ensemble.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4);
}

#[test]
fn a_parameter_grid_runs_each_member_with_its_own_system() {
    // Harmonic oscillator H = p^2/(2m) + k q^2/2 over k in [0, 2]: k = 0 breaks the
    // parameter's rule (> 0), so that member is recorded as not run; the others run with their
    // own k: q(t) = cos(sqrt(k) t) from q = 1, p = 0 (m = 1).
    let scene = "[system]\nname = \"harmonic_oscillator\"\n[initial]\nq = [1.0]\np = [0.0]\n\
                 [ensemble]\nkind = \"grid\"\nx = \"k\"\nx_range = [0.0, 2.0]\nx_count = 3\n\
                 [[method]]\nkind = \"gauss_legendre2\"\ndt = 0.001\n[duration]\nsteps = 3000\n";
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let report = run(scene, &out, 2);
    let v = json(&out);
    let rows = v["rows"].as_array().unwrap();
    let k: Vec<f64> = rows
        .iter()
        .map(|r| r["params"]["k"].as_f64().unwrap())
        .collect();
    assert_eq!(k, [0.0, 1.0, 2.0]);
    let why = rows[0]["failure"]["reason"].as_str().unwrap();
    assert!(why.starts_with("not run:") && why.contains("`k`"), "{why}");
    assert_eq!(report.ensemble.unwrap().not_run, 1);
    // At t = 3: Gauss-Legendre (order 4) with dt = 1e-3 is within ~1e-12 of the exact value.
    let q = rows[1]["end"][0].as_f64().unwrap();
    assert!((q - 3f64.cos()).abs() < 1e-9, "k = 1: q = {q}");
    let q2 = rows[2]["end"][0].as_f64().unwrap();
    assert!(
        (q2 - (2f64.sqrt() * 3.0).cos()).abs() < 1e-9,
        "k = 2: q = {q2}"
    );
}

/// A grid over Kepler's `p2` from bound to unbound orbits with method `exact`: the members
/// whose orbit has no exact solution used to end the whole ensemble with an error (every
/// member's results discarded, nothing written). They are now failed runs of their rows.
#[test]
fn a_method_that_cannot_run_from_one_member_is_that_members_row() {
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [[method]]\nkind = \"midpoint\"\ndt = 0.01\n[[method]]\nkind = \"exact\"\ndt = 0.01\n\
                 [duration]\nsteps = 10\n\
                 [ensemble]\nkind = \"grid\"\nx = \"p2\"\nx_range = [1.0, 3.0]\nx_count = 3\n\
                 [[effect]]\nkind = \"poincare\"\ncoordinate = \"q2\"\nx = \"q1\"\ny = \"p1\"\n";
    let dir = tempfile::tempdir().unwrap();
    let report = run(scene, dir.path(), 1);
    assert_eq!(report.ensemble.map(|c| c.failed_runs), Some(2));
    let rows = json(dir.path());
    let rows = rows["rows"].as_array().unwrap();
    let failed: Vec<(u64, &str)> = rows
        .iter()
        .filter(|r| !r["failure"].is_null())
        .map(|r| (r["member"].as_u64().unwrap(), r["method"].as_str().unwrap()))
        .collect();
    assert_eq!(failed, [(1, "exact"), (2, "exact")]);
    // Every midpoint run, and the bound orbit's exact one, ran their 10 steps.
    let full = rows
        .iter()
        .filter(|r| r["steps"].as_u64() == Some(10))
        .count();
    assert_eq!(full, 4);
}

/// The last column of a CSV file's rows, as numbers (the `fallback_steps` of both ensemble
/// tables).
fn last_column(csv: &str) -> Vec<u64> {
    let mut lines = csv.lines();
    assert!(lines.next().unwrap().ends_with(",fallback_steps"), "{csv}");
    lines
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect()
}

/// Robust DTH on Kepler at e = 0.9 (Psi < 0 on a band of radii the orbit crosses) falls back
/// and at e = 0.44 does not: each member's fallback steps are in its row of both tables, the
/// counts say how many runs took any, and the peer beside it has none. The same for the
/// thesis's square of initial states around the e = 0.9 orbit.
#[test]
fn each_members_fallback_steps_are_in_its_row() {
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [ensemble]\nkind = \"list\"\nmembers = \"\"\"\np2\n1.378404875209022\n1.2\n\"\"\"\n\
                 [[method]]\nkind = \"dth\"\ndtau = 0.0157\nrobust = true\n\
                 [[method]]\nkind = \"rk4\"\ndt = 0.01\n[duration]\norbits = 1\n";
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let report = run(scene, &out, 1);
    let v = json(&out);
    let rows = v["rows"].as_array().unwrap();
    let fallback: Vec<u64> = rows
        .iter()
        .map(|r| r["fallback_steps"].as_u64().unwrap())
        .collect();
    // Rows: (e = 0.9, dth), (e = 0.9, rk4), (e = 0.44, dth), (e = 0.44, rk4).
    assert!(fallback[0] > 0, "{fallback:?}");
    assert_eq!(fallback[1..], [0, 0, 0], "{fallback:?}");
    let csv = std::fs::read_to_string(out.join("ensemble.csv")).unwrap();
    assert_eq!(last_column(&csv), fallback);
    let counts = report.ensemble.unwrap();
    assert_eq!(counts.fallback_runs, 1);
    assert_eq!(v["counts"]["fallback_runs"], 1);
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        page.contains("1 method runs took fallback steps (robust mode)"),
        "{page}"
    );

    // The square: every member near the e = 0.9 orbit falls back within its 100 steps (plain
    // DTH breaks down at step 19 on the orbit itself); the peer does not.
    let square = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.378404875209022]\n\
                  [ensemble]\nx = \"q1\"\ny = \"p2\"\nhalf_width = 0.001\nper_side = 2\nsteps = 100\n\
                  [[method]]\nkind = \"dth\"\ndtau = 0.0157\nrobust = true\n\
                  [[method]]\nkind = \"midpoint\"\ndt = 0.01\n[duration]\nsteps = 10\n";
    let out = dir.path().join("square");
    let options = RunOptions::default().with_progress(false);
    dth_examples::run_scene(square, "square.toml", &Catalogue::builtin(), &out, &options).unwrap();
    let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
    let dth = last_column(&read("dth_ensemble.csv"));
    assert!(dth.len() == 4 && dth.iter().all(|&n| n > 0), "{dth:?}");
    assert_eq!(last_column(&read("midpoint_ensemble.csv")), [0; 4]);
}
