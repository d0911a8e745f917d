//! The `normal_modes` effect: validated against the system (chains with fixed ends only, from
//! the catalogue or given as text and checked at rest,
//! `modes` within the chain), written as CSV and a figure per method, and measuring what the
//! harmonic chain keeps (each mode's energy).

use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::RunOptions;

/// A scene on `system` with `initial` and the effect `effect`, 200 midpoint steps of 0.5.
fn scene(system: &str, params: &str, initial: &str, effect: &str) -> String {
    format!(
        "[system]\nname = \"{system}\"\n{params}\n[initial]\n{initial}\n\
         [[method]]\nkind = \"midpoint\"\ndt = 0.5\n[duration]\nsteps = 200\n\
         [[effect]]\n{effect}\n"
    )
}

/// `q` of a chain of 32 in mode `k` with amplitude `a`, at rest.
fn chain_in_mode(k: usize, a: f64) -> String {
    let q: Vec<String> = (1..=32)
        .map(|i| {
            format!(
                "{:e}",
                a * ((i * k) as f64 * std::f64::consts::PI / 33.0).sin()
            )
        })
        .collect();
    format!(
        "q = [{}]\np = [{}]",
        q.join(", "),
        vec!["0.0"; 32].join(", ")
    )
}

#[test]
fn normal_modes_needs_a_chain_with_fixed_ends() {
    let text = scene(
        "kepler",
        "",
        "q = [0.5, 0.0]\np = [0.0, 1.2]",
        "kind = \"normal_modes\"",
    );
    let err = dth_examples::check_scene(&text, "k.toml", &Catalogue::builtin())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("k.toml:13:8: effect `normal_modes` needs a chain with fixed ends"),
        "{err}"
    );
    assert!(err.contains("system `kepler` is not one"), "{err}");
}

#[test]
fn normal_modes_count_is_checked_against_the_chain() {
    for (modes, ok) in [("0", false), ("33", false), ("32", true), ("1", true)] {
        let text = scene(
            "fput_alpha",
            "",
            &chain_in_mode(1, 0.1),
            &format!("kind = \"normal_modes\"\nmodes = {modes}"),
        );
        let got = dth_examples::check_scene(&text, "m.toml", &Catalogue::builtin());
        match (got, ok) {
            (Ok(_), true) => {}
            (Err(e), false) => {
                let e = e.to_string();
                assert!(
                    e.contains(&format!(
                        "`modes` = {modes}: expected an integer from 1 to 32"
                    )),
                    "{e}"
                );
            }
            (got, _) => panic!("modes = {modes}: {got:?}"),
        }
    }
    // `modes` belongs to `normal_modes` only.
    let text = scene(
        "fput_alpha",
        "",
        &chain_in_mode(1, 0.1),
        "kind = \"trajectory\"\nmodes = 3",
    );
    let err = dth_examples::check_scene(&text, "m.toml", &Catalogue::builtin())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`modes` is not a key of effect `trajectory`"),
        "{err}"
    );
}

/// At `alpha = 0` the chain is harmonic: mode 3 keeps its energy `omega_3^2 Q_3^2 / 2` and the
/// others stay empty, up to the midpoint rule's error (it conserves the quadratic energy of
/// each mode exactly: the modes decouple and the rule preserves quadratic invariants, so only
/// roundoff remains, a few eps of E3 per step over 200 steps).
#[test]
fn harmonic_chain_keeps_each_mode_energy_and_writes_csv_and_figure() {
    let text = scene(
        "fput_alpha",
        "params = { alpha = 0.0 }",
        &chain_in_mode(3, 0.2),
        "kind = \"normal_modes\"\nmodes = 4\nevery = 10",
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("modes");
    let report = dth_examples::run_scene(
        &text,
        "modes.toml",
        &Catalogue::builtin(),
        &out,
        &RunOptions::default().with_progress(false),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    for f in [
        "midpoint_normal_modes.csv",
        "normal_modes_midpoint.png",
        "normal_modes_midpoint.svg",
    ] {
        assert!(
            report.files.contains(&f.to_string()),
            "{f}: {:?}",
            report.files
        );
    }
    let csv = std::fs::read_to_string(out.join("midpoint_normal_modes.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("step,t,E1,E2,E3,E4"));
    let w3 = 2.0 * (3.0 * std::f64::consts::PI / 66.0).sin();
    // Q3 = sqrt(2/33) * 0.2 * 33/2.
    let q3 = (2.0f64 / 33.0).sqrt() * 0.2 * 16.5;
    let e3 = w3 * w3 * q3 * q3 / 2.0;
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 21, "steps 0, 10, ..., 200");
    for r in &rows {
        assert!(
            (r[4] - e3).abs() < 1e-13 * e3,
            "step {}: E3 = {} vs {e3}",
            r[0],
            r[4]
        );
        for k in [2, 3, 5] {
            assert!(r[k].abs() < 1e-15, "step {}: E{} = {}", r[0], k - 1, r[k]);
        }
    }
    let png = std::fs::read(out.join("normal_modes_midpoint.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

/// A scene with `[system]` given as text, `initial`, midpoint and `effect` as [`scene`].
fn text_scene(hamiltonian: &str, params: &str, initial: &str, effect: &str) -> String {
    let text = scene("x", params, initial, effect);
    text.replacen(
        "name = \"x\"",
        &format!("hamiltonian = \"{hamiltonian}\""),
        1,
    )
}

/// FPUT-alpha with fixed ends, written as sums over a chain of `n`.
fn fput_text(n: usize) -> String {
    format!(
        "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + alpha*(q[i+1] - q[i])^3/3) where N = {n}, q[0] = q[N+1] = 0"
    )
}

/// The mode-energy rows a run of `text` writes.
fn mode_rows(text: &str) -> Vec<Vec<f64>> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("modes");
    dth_examples::run_scene(
        text,
        "modes.toml",
        &Catalogue::builtin(),
        &out,
        &RunOptions::default().with_progress(false),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let csv = std::fs::read_to_string(out.join("midpoint_normal_modes.csv")).unwrap();
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect()
}

/// A chain given as text has the effect when its expansion at rest is the unit chain's, and
/// measures what the catalogue's chain measures: the same Hamiltonian, its derivatives
/// evaluated in another order (loops against the macro's code), so each midpoint step agrees
/// to a few eps and 200 steps of this regular motion to well below 1e-12 of the energies.
#[test]
fn a_chain_given_as_text_has_normal_modes_as_the_catalogue_chain() {
    let initial = chain_in_mode(1, 0.5);
    let effect = "kind = \"normal_modes\"\nmodes = 4\nevery = 20";
    let params = "params = { alpha = 0.25 }";
    let from_text = mode_rows(&text_scene(&fput_text(32), params, &initial, effect));
    let builtin = mode_rows(&scene("fput_alpha", params, &initial, effect));
    assert_eq!(from_text.len(), 11, "steps 0, 20, ..., 200");
    assert_eq!(from_text.len(), builtin.len());
    let scale = builtin[0][2];
    for (a, b) in from_text.iter().zip(&builtin) {
        for k in 2..6 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-12 * scale,
                "step {}: E{} = {} from text, {} built in",
                a[0],
                k - 1,
                a[k],
                b[k]
            );
        }
    }
    // Energy moved between the modes (the test sees the anharmonic coupling at work).
    assert!(builtin.iter().any(|r| r[3] > 1e-8 * scale));
}

/// A text that is not the unit chain to second order is refused with what differs, at the
/// effect: a spring to a wall of another stiffness, rest off equilibrium, time dependence.
#[test]
fn a_text_that_is_not_the_unit_chain_is_refused_with_the_difference() {
    let initial = "q = [0.1, 0.0]\np = [0.0, 0.0]";
    let effect = "kind = \"normal_modes\"";
    for (h, says) in [
        (
            "p1^2/2 + p2^2/2 + q1^2 + (q2 - q1)^2/2 + q2^2/2",
            "its expansion at rest is not the unit chain's: d2H/dq1dq1 = 3 at z = 0, the chain has 2",
        ),
        (
            "p1^2/2 + p2^2/2 + q1^2/2 + (q2 - q1)^2/2 + q2^2/2 + q1",
            "rest is not an equilibrium: dH/dq1 = 1 at z = 0",
        ),
        (
            "p1^2/2 + p2^2/2 + q1^2/2 + (q2 - q1)^2/2 + q2^2/2 + q1^2*cos(t)",
            "it depends on `t`",
        ),
    ] {
        let text = text_scene(h, "", initial, effect);
        let err = dth_examples::check_scene(&text, "t.toml", &Catalogue::builtin())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("t.toml:13:8: effect `normal_modes` needs a chain with fixed ends"),
            "{err}"
        );
        assert!(
            err.contains(&format!(
                "the Hamiltonian given as text is not one: {says}"
            )),
            "{h}: {err}"
        );
    }
    // The same chain with walls of unit stiffness is one.
    let chain = "p1^2/2 + p2^2/2 + q1^2/2 + (q2 - q1)^2/2 + q2^2/2";
    let text = text_scene(chain, "", initial, effect);
    assert!(dth_examples::check_scene(&text, "t.toml", &Catalogue::builtin()).is_ok());
}
