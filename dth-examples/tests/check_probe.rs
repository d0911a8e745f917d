//! `dth check` probes the sign of Psi along a scene's orbit: where it changes sign (Kepler at
//! e = 0.9, near pericentre; a pendulum in rotation, over the top) it warns where, and suggests
//! the regularization that removes it (Levi-Civita about the singular point) or else robust
//! mode; where it keeps its sign (the thesis orbit at e = 0.44, a harmonic oscillator) it says
//! nothing. Warnings never change the exit code.

mod common;

use common::{dth, manifest_dir, stderr};
use dth_examples::catalogue::Catalogue;
use dth_examples::derive::Regularization as Preset;
use dth_examples::probe::PsiSignChange;

fn probe(text: &str) -> Option<PsiSignChange> {
    let catalogue = Catalogue::builtin();
    let scene =
        dth_examples::check_scene(text, "probe.toml", &catalogue).unwrap_or_else(|e| panic!("{e}"));
    catalogue
        .probe_psi(&scene)
        .unwrap_or_else(|e| panic!("{e}"))
}

fn shipped(name: &str) -> String {
    std::fs::read_to_string(manifest_dir().join("scenes").join(name)).unwrap()
}

/// Kepler (`system`, or a text) from `q`, `p` with one `dth` method.
fn scene(system: &str, q: &str, p: &str, dth: &str) -> String {
    format!(
        "[system]\n{system}\n[initial]\nq = {q}\np = {p}\n[[method]]\nkind = \"dth\"\n{dth}\n\
         [duration]\norbits = 3\n"
    )
}

/// The shipped e = 0.9 scene (robust DTH at `dtau = 0.0157`): Psi changes sign near pericentre,
/// where `H` has its 1/r singularity at the origin, so Levi-Civita is suggested; the method is
/// robust already, so the warning says it will fall back there.
#[test]
fn kepler_at_e09_is_warned_and_told_to_regularize() {
    let change = probe(&shipped("kepler-e09-robust.toml")).expect("Psi changes sign at e = 0.9");
    assert!(change.robust);
    assert!(change.psi0 > 0.0 && change.psi <= 0.0, "{change:?}");
    let r = change.regularization.as_ref().expect("Levi-Civita applies");
    assert_eq!(
        (r.preset, r.centre.as_slice()),
        (Preset::LeviCivita, &[0.0, 0.0][..])
    );
    // Near pericentre (r = 0.5 there, the apocentre at 9.5): on the way out, Psi first turns
    // negative at r = 1.25 at this dtau.
    let radius = change.state[0].1.hypot(change.state[1].1);
    assert!(radius < 2.0, "{change:?}");
    assert_eq!(
        change
            .state
            .iter()
            .map(|(n, _)| n.as_str())
            .collect::<Vec<_>>(),
        ["q1", "q2", "p1", "p2"]
    );
    let warning = change.warning();
    for part in [
        "method `dth`: Psi = (J gradH)^T HessH (J gradH) changes sign along the orbit",
        "its robust mode will fall back to discrete-gradient steps there",
        "fix: `regularize = \"levi-civita\"` under [system] (H has a 1/r singularity at q = (0.0, 0.0)",
    ] {
        assert!(warning.contains(part), "{part}\n{warning}");
    }
    // Plain DTH on the same orbit: it will break down there.
    let plain = scene(
        "name = \"kepler\"",
        "[0.5, 0.0]",
        &format!("[0.0, {}]", 1.9f64.sqrt()),
        "dtau = 0.0157",
    );
    let change = probe(&plain).expect("Psi changes sign at e = 0.9");
    assert!(!change.robust);
    assert!(
        change.warning().contains("plain DTH will break down there"),
        "{}",
        change.warning()
    );
}

/// The thesis orbit (e = 0.44) and a harmonic oscillator keep Psi's sign: no warning.
#[test]
fn the_thesis_orbit_and_an_oscillator_are_not_warned() {
    assert_eq!(probe(&shipped("thesis-kepler.toml")), None);
    assert_eq!(probe(&shipped("thesis-kepler-order8.toml")), None);
    let oscillator = "[system]\nname = \"harmonic_oscillator\"\n[initial]\nq = [1.0]\np = [0.5]\n\
                      [[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\ntime = 50\n";
    assert_eq!(probe(oscillator), None);
}

/// A pendulum in rotation: Psi = p^2 cos q + sin^2 q (m = l = g = 1) changes sign on the way
/// over the top, and no regularization applies to a 1-D system: robust mode is suggested.
#[test]
fn a_rotating_pendulum_is_told_to_use_robust_mode() {
    let text = "[system]\nname = \"pendulum\"\n[initial]\nq = [0.0]\np = [2.5]\n\
                [[method]]\nkind = \"dth\"\ndtau = 0.05\n[duration]\ntime = 100\n";
    let change = probe(text).expect("Psi changes sign over the top");
    assert_eq!(change.regularization, None);
    let warning = change.warning();
    assert!(
        warning.contains("fix: `robust = true` on method `dth`"),
        "{warning}"
    );
    // Psi turns negative where cos q < -sin^2 q / p^2: past q = pi/2, before the top.
    let q = change.state[0].1;
    let pi = std::f64::consts::PI;
    assert!(q > pi / 2.0 && q < pi, "{change:?}");
}

/// A Kepler problem given as text about the centre (1, 0): the centre is found and written as
/// the scene key. (A text has no period: the probe covers the scene's time, at most its
/// steps.)
#[test]
fn an_offset_centre_is_suggested_with_its_key() {
    let text = scene(
        "hamiltonian = \"p1^2 + p2^2 - ((q1 - 1)^2 + q2^2)^(-1/2)\"",
        "[1.5, 0.0]",
        &format!("[0.0, {}]", 1.9f64.sqrt()),
        "dtau = 0.0157\nrobust = true",
    )
    .replace("orbits = 3", "time = 50");
    let catalogue = Catalogue::builtin();
    let scene = dth_examples::check_scene(&text, "text.toml", &catalogue).unwrap();
    let change = catalogue
        .probe_psi(&scene)
        .unwrap()
        .expect("Psi changes sign");
    let r = change.regularization.expect("Levi-Civita applies");
    assert_eq!(r.centre, [1.0, 0.0]);
    assert_eq!(
        r.scene_keys(),
        "regularize = \"levi-civita\", centre = [1.0, 0.0]"
    );
}

/// The command: a warning on stderr, exit 0, the usual `ok` line; nothing for the thesis scene.
#[test]
fn dth_check_prints_the_warning_and_succeeds() {
    let dir = manifest_dir().join("scenes");
    let o = dth(
        &[
            "check",
            dir.join("kepler-e09-robust.toml").to_str().unwrap(),
        ],
        &dir,
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.starts_with("warning: method `dth`: Psi = (J gradH)^T HessH (J gradH) changes sign")
            && err.contains("`regularize = \"levi-civita\"` under [system]"),
        "{err}"
    );
    let o = dth(
        &["check", dir.join("thesis-kepler.toml").to_str().unwrap()],
        &dir,
    );
    assert_eq!((o.status.code(), stderr(&o)), (Some(0), String::new()));
}
