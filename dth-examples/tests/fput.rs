//! The Fermi-Pasta-Ulam-Tsingou experiment, `scenes/fput.toml`, run to its first
//! near-recurrence with the scene's own methods and steps (DTH at `dtau = 0.35`, Stormer-Verlet
//! at FPUT's `dt = 1/sqrt(8)`); the scene itself runs on to `t = 25,000`.
//!
//! **Reference.** E. Fermi, J. Pasta, S. Ulam (with M. Tsingou), *Studies of nonlinear
//! problems I*, Los Alamos report LA-1940 (1955), Figure 1: `N = 32`, `alpha = 1/4`, a single
//! sine wave, leapfrog with `dt^2 = 1/8`; the energy of mode 1 drains into modes 2-5 and comes
//! back almost entirely near the end of their ~30,000 computation cycles, `t ~ 1.0e4` (about
//! 150 periods `T1 = 2 pi / omega1 = 66.0` of mode 1; C. DeTar's reproduction of that figure,
//! Utah Physics 6720 notes, and the review of G. P. Berman, F. M. Izrailev, Chaos 15, 015104
//! (2005), give the same picture). An independent leapfrog run at `dt = 0.1` (ten times finer
//! than FPUT's) puts the maximum of `E1` at `t = 10,200`, at 0.98 of its initial value.
//!
//! **What is asserted**, for every method of the scene: mode 1 first loses most of its energy
//! (below 0.2 of `E1(0)` somewhere in `3,000 <= t <= 7,000`, where the energy is in modes 2-5),
//! then returns above 0.9 of `E1(0)` in `9,000 <= t <= 11,000`, with its maximum there at
//! `t = 1.02e4 +- 700` (seven periods of mode 1). A linear chain (`alpha = 0`) keeps `E1`
//! constant and would fail the first assertion; a method whose dynamics were wrong in the
//! cubic term would move or lose the recurrence.
//!
//! **Cost.** About 31,000 steps per method at `N = 32` (`D = 64`); DTH solves its joint Newton
//! system through the chain's declared Hessian pattern, so the run takes a few seconds in the
//! dev profile.

use dth_examples::catalogue::Catalogue;
use dth_examples::effects::ModeEnergies;
use dth_examples::scene::Duration;
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
        .fold((f64::NEG_INFINITY, f64::NAN), |a, b| if b.0 > a.0 { b } else { a });
    let min = window
        .map(ratio)
        .fold((f64::INFINITY, f64::NAN), |a, b| if b.0 < a.0 { b } else { a });
    (max, min)
}

#[test]
fn fput_scene_starts_in_mode_one_with_fputs_amplitude() {
    let scene = dth_examples::check_scene(SCENE, "fput.toml", &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((scene.system.as_str(), scene.params["alpha"]), ("fput_alpha", 0.25));
    // q_i = sin(i pi / 33) to the last digit written (the file holds 16-17 significant
    // digits: half an ulp of numbers below 1).
    for (i, q) in scene.q.iter().enumerate() {
        let want = ((i + 1) as f64 * std::f64::consts::PI / 33.0).sin();
        assert!((q - want).abs() <= 1.2e-16, "q{} = {q} vs {want}", i + 1);
    }
    assert!(scene.p.iter().all(|&p| p == 0.0));
}

#[test]
fn fput_mode_one_energy_returns_near_the_recurrence_time() {
    let mut scene = dth_examples::check_scene(SCENE, "fput.toml", &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    // Reduced length: to just past the first recurrence.
    scene.duration = Duration::Time(11_000.0);
    let system = FputAlpha32 {
        alpha: scene.params["alpha"],
    };
    let results = compute(&system, &scene, &RunOptions::default().with_progress(false))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(results.len(), 2);
    for r in &results {
        let label = &r.summary.label;
        assert!(r.failure.is_none(), "{label}: {:?}", r.failure);
        let rows = r
            .outputs
            .normal_modes
            .as_ref()
            .expect("the scene asks for normal_modes");
        // E1(0) = omega1^2 Q1^2 / 2 with omega1 = 2 sin(pi/66), Q1 = sqrt(33/2).
        let w1 = 2.0 * (std::f64::consts::PI / 66.0).sin();
        let e0 = rows[0].energies[0];
        assert!((e0 - w1 * w1 * 33.0 / 4.0).abs() < 1e-15, "{label}: E1(0) = {e0}");
        assert_eq!(rows[0].energies.len(), 5);

        let (_, (low, t_low)) = extremes(rows, e0, 3_000.0, 7_000.0);
        assert!(low < 0.2, "{label}: E1/E1(0) stays above {low} (at t = {t_low})");
        // Where mode 1 is lowest, modes 2-5 hold most of the energy.
        let at_low = rows.iter().find(|r| r.t == t_low).expect("a sampled row");
        let others: f64 = at_low.energies[1..].iter().sum();
        assert!(others > 0.7 * e0, "{label}: modes 2-5 hold {} of E1(0)", others / e0);

        let ((high, t_high), _) = extremes(rows, e0, 9_000.0, 11_000.0);
        assert!(
            high > 0.9,
            "{label}: E1/E1(0) returns only to {high} (at t = {t_high})"
        );
        assert!(
            (t_high - 10_200.0).abs() <= 700.0,
            "{label}: the recurrence peaks at t = {t_high}, not near 1.02e4"
        );
        eprintln!("{label}: E1 drops to {low:.3} (t = {t_low:.0}), returns to {high:.3} (t = {t_high:.0})");
    }
}
