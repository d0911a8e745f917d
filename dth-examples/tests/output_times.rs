//! States at chosen times and at events through the `dth` command: a `trajectory` with
//! `every_time` and a `stroboscopic` section give every method rows at the same times, each
//! the method's own state there (DTH's with its energy exact), whose error is the method's
//! own; an `[[event]]` is located where its condition turns true, to the method's accuracy
//! against the exact solution, and a stop ends the run there.

mod common;

use common::*;
use std::path::Path;

/// The rows of a CSV file with a header: `(header, rows of numbers)`; cells that are not
/// numbers (the step kinds) are NaN.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (header, rows)
}

/// Column `name` of a CSV read by [`read_csv`].
fn column(csv: &(Vec<String>, Vec<Vec<f64>>), name: &str) -> Vec<f64> {
    let i = csv.0.iter().position(|h| h == name).unwrap();
    csv.1.iter().map(|r| r[i]).collect()
}

/// Runs `scene` (text) with `dth run` into `dir/out`, which it returns.
fn run(scene: &str, dir: &Path) -> std::path::PathBuf {
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let o = dth(&["run", "scene.toml", "--out", "out"], dir);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    dir.join("out")
}

/// The largest difference of the states `q1..p2` between two trajectories' rows.
fn max_difference(a: &(Vec<String>, Vec<Vec<f64>>), b: &(Vec<String>, Vec<Vec<f64>>)) -> f64 {
    ["q1", "q2", "p1", "p2"]
        .iter()
        .flat_map(|c| column(a, c).into_iter().zip(column(b, c)))
        .fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// The shipped scene: DTH, the midpoint rule and the exact solution write rows at
/// `0, 0.25, ..., 7.25` (two orbits end at 7.4967): the same times, DTH's rows exact
/// midpoints, and the rows' error falls at order 2 when the steps are halved (no
/// interpolation error on top of the method's).
#[test]
fn every_method_writes_its_rows_at_the_same_times() {
    let scene =
        std::fs::read_to_string(manifest_dir().join("scenes/kepler-output-times.toml")).unwrap();
    let halved = scene
        .replace("dtau = 0.02", "dtau = 0.01")
        .replace("dt = 0.01", "dt = 0.005");
    assert_ne!(scene, halved);
    let mut errors = Vec::new();
    for text in [&scene, &halved] {
        let dir = tempfile::tempdir().unwrap();
        let out = run(text, dir.path());
        let csv = |label: &str| read_csv(&out.join(format!("{label}_trajectory.csv")));
        let (dth, midpoint, exact) = (csv("dth"), csv("midpoint"), csv("exact"));
        let want: Vec<f64> = (0..30).map(|j| f64::from(j) * 0.25).collect();
        assert_eq!(column(&midpoint, "t"), want);
        assert_eq!(column(&exact, "t"), want);
        for (t, want) in column(&dth, "t").iter().zip(&want) {
            // The landing's tolerance: the rounding of DTH's time sum, 4 eps T.
            assert!(
                (t - want).abs() <= 4.0 * f64::EPSILON * 7.5,
                "{t} for {want}"
            );
        }
        assert_eq!(dth.1.len(), want.len());
        // Each DTH row is an exact midpoint: H = p^2 - 1/|q| is H0 to roundoff (its terms are
        // at most ~4 on this orbit, printed to the last digit).
        let h = |r: &Vec<f64>| r[4] * r[4] + r[5] * r[5] - (r[2] * r[2] + r[3] * r[3]).powf(-0.5);
        let h0 = h(&dth.1[0]);
        for r in &dth.1 {
            assert!(
                (h(r) - h0).abs() <= 32.0 * f64::EPSILON,
                "t = {}: H - H0 = {:e}",
                r[1],
                h(r) - h0
            );
        }
        errors.push((
            max_difference(&dth, &exact),
            max_difference(&midpoint, &exact),
        ));
    }
    // Order 2: halving the step divides the error by 4 as h -> 0; measured 5.8 (DTH) and
    // 4.0 (midpoint) at these steps. An interpolation of lower order, or a landing that
    // restarted the grid, would show as a smaller ratio.
    let (coarse, fine) = (errors[0], errors[1]);
    assert!(coarse.0 / fine.0 > 3.5, "DTH: {coarse:?} then {fine:?}");
    assert!(
        coarse.1 / fine.1 > 3.5,
        "midpoint: {coarse:?} then {fine:?}"
    );
    // And the errors are those of second-order methods at these steps over two orbits.
    assert!(coarse.0 < 1e-2 && coarse.1 < 3e-2, "{coarse:?}");
}

/// A stroboscopic section of the forced oscillator (period of the drive 2 pi / 1.3): the
/// points lie at `j T` for every method, start and end included, and DTH's and the midpoint
/// rule's are as close to those of a reference (Gauss-Legendre, order 4, at a 20 times
/// smaller step: about 1e-11 from the solution) as their order makes them.
#[test]
fn a_stroboscopic_section_lands_once_per_period() {
    let period = 2.0 * std::f64::consts::PI / 1.3;
    let t_end = 20.0 * period;
    let scene = format!(
        "[system]
name = \"forced_oscillator\"
params = {{ omega0 = 1.0, f = 0.1, omega = 1.3 }}
[initial]
q = [1.0]
p = [0.0]
t = 0.0
[[method]]
kind = \"dth\"
dtau = 0.02
[[method]]
kind = \"midpoint\"
dt = 0.02
[[method]]
kind = \"gauss_legendre2\"
dt = 0.001
[duration]
time = {t_end:?}
[[effect]]
kind = \"stroboscopic\"
period = {period:?}
x = \"q1\"
y = \"p1\"
"
    );
    let dir = tempfile::tempdir().unwrap();
    let out = run(&scene, dir.path());
    let csv = |label: &str| read_csv(&out.join(format!("{label}_poincare1.csv")));
    let (dth, midpoint, exact) = (csv("dth"), csv("midpoint"), csv("gauss_legendre2"));
    let want: Vec<f64> = (0..=20).map(|j| 0.0 + f64::from(j) * period).collect();
    assert_eq!(column(&midpoint, "t"), want);
    assert_eq!(column(&exact, "t"), want);
    let t = column(&dth, "t");
    assert_eq!(t.len(), want.len());
    for (t, want) in t.iter().zip(&want) {
        assert!(
            (t - want).abs() <= 4.0 * f64::EPSILON * t_end,
            "{t} for {want}"
        );
    }
    for (label, points) in [("dth", &dth), ("midpoint", &midpoint)] {
        let error = ["q1", "p1"]
            .iter()
            .flat_map(|c| column(points, c).into_iter().zip(column(&exact, c)))
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        // Second order at h = 0.02 over 97 time units of an oscillation of amplitude ~1:
        // about h^2 t / 12 ~ 3e-3 for the midpoint rule's phase error.
        assert!(error < 1e-2, "{label}: {error:e}");
        assert!(
            error > 1e-6,
            "{label}: {error:e} (the reference is the method itself?)"
        );
    }
}

/// The shipped close encounter: from the apocentre `r = 1` of an orbit with pericentre 0.02,
/// the event `close` (r < 0.05) stops each method where the orbit first comes that close, and
/// `inside` (r < 0.5) is recorded on the way. Against Kepler's equation: regularized DTH of
/// order 8 locates both to 1e-12, Gauss-Legendre at its step to its own error; each event's
/// state is on its radius to roundoff; the run ends at the stop, and says so.
#[test]
fn a_close_encounter_stops_each_method_at_the_exact_time() {
    let dir = tempfile::tempdir().unwrap();
    let scene = manifest_dir().join("scenes/kepler-close-encounter.toml");
    std::fs::copy(&scene, dir.path().join("scene.toml")).unwrap();
    let o = dth(&["run", "scene.toml", "--out", "out"], dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("dth_order8 stopped by `close` at t = 0.80374160885"),
        "{}",
        stdout(&o)
    );
    let out = dir.path().join("out");
    // The exact crossing times, from the scene's start at the apocentre (eccentric anomaly
    // pi): H = p2^2 - 1, a = -1/(2H), e = 1/a - 1, n = sqrt(2/a^3) (mu = k/m = 2), and on the
    // way in r = a (1 - e cos E) with E in (pi, 2 pi), t = (E - e sin E - pi)/n.
    let p2: f64 = 0.14002800840280114;
    let a = -1.0 / (2.0 * (p2 * p2 - 1.0));
    let e = 1.0 / a - 1.0;
    let n = (2.0 / (a * a * a)).sqrt();
    let exact = |r: f64| {
        let big_e = 2.0 * std::f64::consts::PI - ((1.0 - r / a) / e).acos();
        (big_e - e * big_e.sin() - std::f64::consts::PI) / n
    };
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    // DTH of order 8 on the regularized K: its time error at this step is at roundoff (the
    // times are ~0.8, their rounding 1e-16; 1e-12 leaves the roundoff of the root search and
    // of K's t coordinate over ~300 steps). Gauss-Legendre (order 4) at dt = 0.0005: 3.7e-10
    // measured, its own error near the pericentre.
    for (label, tolerance) in [("dth_order8", 1e-12), ("gauss_legendre2", 1e-9)] {
        let events = read_csv(&out.join(format!("{label}_events.csv")));
        assert_eq!(events.1.len(), 2, "{label}: inside, then close");
        let t = column(&events, "t");
        let (q1, q2) = (column(&events, "q1"), column(&events, "q2"));
        for (k, radius) in [0.5, 0.05].into_iter().enumerate() {
            let error = (t[k] - exact(radius)).abs();
            assert!(
                error <= tolerance,
                "{label}: r = {radius} at t = {} ({error:e} from exact)",
                t[k]
            );
            // On its radius to roundoff: the root search's bracket is within 8 eps t, across
            // which r moves by at most |v| 8 eps t (|v| <= 10 here).
            let r = q1[k].hypot(q2[k]);
            assert!((r - radius).abs() <= 1e-13, "{label}: r = {r} at the event");
        }
        let method = summary["methods"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["label"] == label)
            .unwrap();
        assert_eq!(
            method["t_end"].as_f64(),
            Some(t[1]),
            "{label}: the run ended at the stop"
        );
        assert_eq!(method["events"][1]["name"], "close");
        assert_eq!(method["events"][1]["stopped"], true);
        assert_eq!(method["events"][0]["stopped"], false);
        assert!(method["failure"].is_null(), "{label}: a stop is no failure");
    }
}

/// The exact solution locates an event on itself: on the thesis orbit from its pericentre
/// (a = 1/1.12, e = 0.44), `r > 1` turns true where Kepler's equation says, to roundoff;
/// DTH's event in the same scene is its own estimate, within its error at this step.
#[test]
fn the_exact_solution_locates_an_event_to_roundoff() {
    let scene = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                 [[method]]\nkind = \"exact\"\ndt = 0.1\n[[method]]\nkind = \"dth\"\ndtau = 0.01\n\
                 [duration]\ntime = 10.0\n\
                 [[event]]\nname = \"out\"\nwhen = \"q1^2 + q2^2 > 1\"\naction = \"stop\"\n";
    let dir = tempfile::tempdir().unwrap();
    let out = run(scene, dir.path());
    let (a, e) = (1.0 / 1.12, 0.44);
    let period = 2.0 * std::f64::consts::PI * (a * a * a / 2.0f64).sqrt();
    let big_e = ((1.0 - 1.0 / a) / e).acos();
    let exact = (big_e - e * big_e.sin()) * period / (2.0 * std::f64::consts::PI);
    for (label, tolerance) in [("exact", 1e-14), ("dth", 1e-3)] {
        let events = read_csv(&out.join(format!("{label}_events.csv")));
        let t = column(&events, "t");
        assert_eq!(t.len(), 1, "{label}");
        // The exact solution: the search's bracket (8 eps t) and Kepler's equation solved to
        // roundoff. DTH at dtau = 0.01: its phase error after a third of an orbit.
        assert!(
            (t[0] - exact).abs() <= tolerance,
            "{label}: {} vs {exact}",
            t[0]
        );
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for m in summary["methods"].as_array().unwrap() {
        // Each run ended at its event.
        assert_eq!(m["t_end"], m["events"][0]["t"], "{}", m["label"]);
    }
}
