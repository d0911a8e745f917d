//! The Fermi-Pasta-Ulam-Tsingou experiment, `scenes/fput.toml`, at reduced length: to its
//! first near-recurrence (`t = 11,000`; the scene itself runs on to `t = 25,000`), with the
//! scene's own methods and steps (DTH at `dtau = 0.35`, Stormer-Verlet at FPUT's
//! `dt = 1/sqrt(8)`).
//!
//! **Reference.** E. Fermi, J. Pasta, S. Ulam (with M. Tsingou), *Studies of nonlinear
//! problems I*, Los Alamos report LA-1940 (1955), Figure 1: `N = 32`, `alpha = 1/4`, a single
//! sine wave, leapfrog with `dt^2 = 1/8`; the energy of mode 1 drains into modes 2-5 and comes
//! back almost entirely near the end of their ~30,000 computation cycles, `t ~ 1.0e4` (about
//! 150 periods `T1 = 2 pi / omega1 = 66.0` of mode 1; C. DeTar's reproduction of that figure,
//! Utah Physics 6720 notes, and the review of G. P. Berman, F. M. Izrailev, Chaos 15, 015104
//! (2005), give the same picture). Independent leapfrog runs (a short script outside this
//! crate) put the maximum of `E1` at `t = 10,200` (0.98 of `E1(0)`) with `dt = 0.1`, and at
//! `t = 10,845` (0.977) with FPUT's `dt = 1/sqrt(8)`: the step moves the recurrence by 6%.
//!
//! **What is asserted**: mode 1 first loses most of its energy
//! (below 0.2 of `E1(0)` somewhere in `3,000 <= t <= 7,000`, where the energy is in modes 2-5),
//! then returns above 0.9 of `E1(0)` in `9,000 <= t <= 11,000`, with its maximum there within
//! 10% of `t = 1.02e4` (the precision of "near the end of FPUT's figure", and wide enough for
//! the 6% the step moves it). A linear chain (`alpha = 0`) keeps `E1`
//! constant and would fail the first assertion; a method whose dynamics were wrong in the
//! cubic term would move or lose the recurrence.
//!
//! **Methods.** The recurrence is asserted for both of the scene's methods: Stormer-Verlet at
//! FPUT's step (31,000 steps) and DTH, the project's method, at `dtau = 0.35` (about 50,000
//! steps: its `lambda = dt/dtau` falls from 0.86 to about 0.5 as the energy moves into higher
//! modes). At `D = 64` the chain's generated type takes the structured Newton (banded, linear
//! in the chain's length), so DTH's run costs a few seconds in the dev profile.

use dth_examples::catalogue::Catalogue;
use dth_examples::effects::ModeEnergies;
use dth_examples::scene::{Duration, Scene, StepSpec};
use dth_examples::simulate::{compute, RunOptions};
use dth_examples::systems::FputAlpha32;

const SCENE: &str = include_str!("../scenes/fput.toml");

/// `max` of `E1 / E1(0)` over `from <= t <= to`, with its time; and the `min`.
fn extremes(rows: &[ModeEnergies], e0: f64, from: f64, to: f64) -> ((f64, f64), (f64, f64)) {
    let window = rows.iter().filter(|r| r.t >= from && r.t <= to);
    let ratio = |r: &ModeEnergies| (r.energies[0] / e0, r.t);
    let max = window
        .clone()
        .map(ratio)
        .fold(
            (f64::NEG_INFINITY, f64::NAN),
            |a, b| if b.0 > a.0 { b } else { a },
        );
    let min = window.map(ratio).fold(
        (f64::INFINITY, f64::NAN),
        |a, b| if b.0 < a.0 { b } else { a },
    );
    (max, min)
}

#[test]
fn fput_scene_starts_in_mode_one_with_fputs_amplitude() {
    let scene = dth_examples::check_scene(SCENE, "fput.toml", &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (scene.system.as_str(), scene.params["alpha"]),
        ("fput_alpha", 0.25)
    );
    // q_i = sin(i pi / 33) to the last digit written (the file holds 16-17 significant
    // digits: half an ulp of numbers below 1).
    for (i, q) in scene.q.iter().enumerate() {
        let want = ((i + 1) as f64 * std::f64::consts::PI / 33.0).sin();
        assert!((q - want).abs() <= 1.2e-16, "q{} = {q} vs {want}", i + 1);
    }
    assert!(scene.p.iter().all(|&p| p == 0.0));
}

/// The scene's methods run to `t_end`, only those labelled `labels`.
fn run(labels: &[&str], t_end: f64) -> Vec<dth_examples::simulate::MethodResult> {
    run_with(labels, t_end, |_| ())
}

/// As [`run`], with the scene changed by `edit` first.
fn run_with(
    labels: &[&str],
    t_end: f64,
    edit: impl FnOnce(&mut Scene),
) -> Vec<dth_examples::simulate::MethodResult> {
    let mut scene = dth_examples::check_scene(SCENE, "fput.toml", &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    scene.duration = Duration::Time(t_end);
    scene.methods.retain(|m| labels.contains(&m.label.as_str()));
    assert_eq!(
        scene.methods.len(),
        labels.len(),
        "the scene's methods are {labels:?}"
    );
    edit(&mut scene);
    let system = FputAlpha32 {
        alpha: scene.params["alpha"],
    };
    let results = compute(&system, &scene, &RunOptions::default().with_progress(false))
        .unwrap_or_else(|e| panic!("{e}"));
    for r in &results {
        assert!(r.failure.is_none(), "{}: {:?}", r.summary.label, r.failure);
    }
    results
}

fn modes(r: &dth_examples::simulate::MethodResult) -> &[ModeEnergies] {
    r.outputs
        .normal_modes
        .as_deref()
        .expect("the scene asks for normal_modes")
}

/// The recurrence, with FPUT's own method and step (the scene's `stormer_verlet`, `dt =
/// 1/sqrt(8)`) and with the scene's DTH: see the module documentation for the reference and
/// the windows.
#[test]
fn fput_mode_one_energy_returns_near_the_recurrence_time() {
    for result in run(&["dth", "stormer_verlet"], 11_000.0) {
        recurs(&result.summary.label, modes(&result));
    }
}

fn recurs(label: &str, rows: &[ModeEnergies]) {
    // E1(0) = omega1^2 Q1^2 / 2 with omega1 = 2 sin(pi/66), Q1 = sqrt(33/2).
    let w1 = 2.0 * (std::f64::consts::PI / 66.0).sin();
    let e0 = rows[0].energies[0];
    assert!((e0 - w1 * w1 * 33.0 / 4.0).abs() < 1e-15, "E1(0) = {e0}");
    assert_eq!(rows[0].energies.len(), 5);

    let (_, (low, t_low)) = extremes(rows, e0, 3_000.0, 7_000.0);
    assert!(
        low < 0.2,
        "{label}: E1/E1(0) stays above {low} (at t = {t_low})"
    );
    // Where mode 1 is lowest, modes 2-5 hold most of the energy.
    let at_low = rows.iter().find(|r| r.t == t_low).expect("a sampled row");
    let others: f64 = at_low.energies[1..].iter().sum();
    assert!(others > 0.7 * e0, "modes 2-5 hold {} of E1(0)", others / e0);

    let ((high, t_high), _) = extremes(rows, e0, 9_000.0, 11_000.0);
    eprintln!(
        "{label}: E1/E1(0) down to {low:.3} at t = {t_low:.0}, back to {high:.3} at t = {t_high:.0}"
    );
    assert!(
        high > 0.9,
        "{label}: E1/E1(0) returns only to {high} (at t = {t_high})"
    );
    assert!(
        (t_high - 10_200.0).abs() <= 1_020.0,
        "{label}: the recurrence peaks at t = {t_high}, not near 1.02e4"
    );
}

/// DTH (the scene's `dth`, `dtau = 0.35`) over the first stretch of the exchange, `t <= 1,000`
/// (3,300 steps). Over `750 <= t <= 1,000` mode 1 falls to about 0.72 of `E1(0)`; the
/// reference is Stormer-Verlet at `dt = 0.01` (100,000 steps, a phase error `(omega dt)^2`
/// ~ 1e-4 of the exchange), computed here. DTH and Stormer-Verlet at the scene's steps agree
/// with it to 0.02: their own phase error `(omega dt)^2` over this time for the modes that
/// carry the exchange, plus the scene's sampling of `E1` every 20 steps near its minimum.
/// DTH's energy at its midpoints stays at roundoff meanwhile.
#[test]
fn dth_drains_mode_one_like_the_reference() {
    let reference = run_with(&["stormer_verlet"], 1_000.0, |scene| {
        scene.methods[0].step = StepSpec::Fixed { dt: 0.01 };
    });
    let rows = modes(&reference[0]);
    let (_, (reference, t_reference)) = extremes(rows, rows[0].energies[0], 750.0, 1_000.0);
    eprintln!("reference: E1/E1(0) falls to {reference:.4} at t = {t_reference:.1}");
    let results = run(&["dth", "stormer_verlet"], 1_000.0);
    for r in &results {
        let label = &r.summary.label;
        let rows = modes(r);
        let e0 = rows[0].energies[0];
        let (_, (low, t_low)) = extremes(rows, e0, 750.0, 1_000.0);
        eprintln!(
            "{label}: E1/E1(0) falls to {low:.4} at t = {t_low:.0}, {} steps",
            r.summary.steps
        );
        assert!(
            (low - reference).abs() < 0.02,
            "{label}: E1/E1(0) falls to {low} (at t = {t_low}), not {reference}"
        );
    }
    let dth = results[0]
        .summary
        .energy
        .as_ref()
        .expect("the scene asks for energy_deviation");
    // H = 0.0748 is a sum of terms of size up to 0.5 (q_i^2/2 and the bonds): roundoff is a few
    // eps of those per step; 1e-13 leaves room for ~5,000 steps of it.
    eprintln!("dth: max |H - H0| = {:e}", dth.points.max);
    assert!(
        dth.points.max < 1e-13,
        "max |H - H0| at DTH's midpoints = {:e}",
        dth.points.max
    );
}
