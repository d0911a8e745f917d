//! Scenes with `[system] regularize`: method `dth` runs on the regularized `K`, and everything
//! the scene reports is physical. The restricted three-body scene's close approaches need no
//! fallback step regularized (hundreds unregularized), with the Jacobi constant at roundoff at
//! every midpoint; the final state is the regularized run's end mapped back; the physical law
//! of time holds exactly; and every mistake in the keys is an error at its place in the file.

use dth::nalgebra::{DVector, Vector4, Vector6};
use dth::observer::StepRecord;
use dth::regularize::{KustaanheimoStiefel, LeviCivita};
use dth::runtime::RuntimeHamiltonian;
use dth::{solve, DthOptions, Method};
use dth_examples::catalogue::Catalogue;
use dth_examples::driver::FailureCause;
use dth_examples::method::run_method;
use dth_examples::runtime_system::TextSystem;
use dth_examples::scene::{translated, Scene};
use dth_examples::simulate::{compute, initial_state, stop_for, MethodResult, RunOptions};
use dth_examples::system::SceneSystem;
use dth_examples::systems::Kepler;

/// The shipped restricted three-body scene.
const THREE_BODY: &str = include_str!("../scenes/three-body-close-approach.toml");
/// The shipped Kepler scene at e = 0.99.
const KEPLER_E099: &str = include_str!("../scenes/kepler-e099-regularized.toml");

fn scene(text: &str) -> Scene {
    dth_examples::check_scene(text, "scene.toml", &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"))
}

fn options() -> RunOptions {
    RunOptions::default().with_progress(false)
}

/// The scene's methods run on its text Hamiltonian (at `Dyn`, as every regularized scene).
fn run(scene: &Scene) -> Vec<MethodResult> {
    let system = TextSystem::build(scene).unwrap_or_else(|e| panic!("{e}"));
    compute(&system, scene, &options()).unwrap_or_else(|e| panic!("{e}"))
}

/// The three-body scene with only its `dth` method, `dth_keys` replacing `dtau = 0.02`, and
/// without the regularization when `regularized` is false.
fn three_body(regularized: bool, dth_keys: &str) -> String {
    let mut text = THREE_BODY.replace("dtau = 0.02", dth_keys);
    if !regularized {
        text = text
            .replace("regularize = \"levi-civita\"\n", "")
            .replace("centre = [0.99, 0.0]\n", "");
    }
    // Only the first method (`dth`).
    let cut = text.find("[[method]]\nkind = \"gauss_legendre2\"").unwrap();
    let end = text.find("[duration]").unwrap();
    text.replace_range(cut..end, "");
    text
}

/// Plain DTH at `dtau` on `k` from `w0` until the physical time `t_end`, through the library
/// (not the scene): the end state and the steps taken.
fn by_hand(k: &RuntimeHamiltonian, w0: &[f64], dtau: f64, t_end: f64) -> (DVector<f64>, usize) {
    let run = solve(
        k,
        DVector::from_column_slice(w0),
        Method::Dth(DthOptions::new(dtau).unwrap()),
    )
    .until(t_end)
    .save_every(usize::MAX)
    .run()
    .unwrap();
    (run.end_state().unwrap().clone(), run.steps)
}

/// `H` of the restricted three-body scene at `z = (q, p)`, and the size of its roundoff there:
/// its terms, and what a rounding of each component (eps |z_i|) changes it by,
/// `|dH/dz_i| |z_i|`. The latter dominates near the small primary: `q` is stored about the
/// barycentre, so `q - c` (and with it `r2`) is known to eps |q| ~ 1e-16 at best, which the
/// term `mu / r2` turns into `mu eps |q| / r2^2`.
fn jacobi(z: &[f64]) -> (f64, f64) {
    let (q1, q2, p1, p2) = (z[0], z[1], z[2], z[3]);
    let r1 = (q1 + 0.01).hypot(q2);
    let r2 = (q1 - 0.99).hypot(q2);
    let kinetic = (p1 * p1 + p2 * p2) / 2.0;
    let h = kinetic + q2 * p1 - q1 * p2 - 0.99 / r1 - 0.01 / r2;
    let terms = kinetic + (q2 * p1).abs() + (q1 * p2).abs() + 0.99 / r1 + 0.01 / r2;
    let (c1, c2) = (0.99 / r1.powi(3), 0.01 / r2.powi(3));
    let gradient = [
        -p2 + c1 * (q1 + 0.01) + c2 * (q1 - 0.99),
        p1 + (c1 + c2) * q2,
        p1 + q2,
        p2 - q1,
    ];
    let sensitivity: f64 = gradient.iter().zip(z).map(|(g, x)| (g * x).abs()).sum();
    (h, terms + sensitivity)
}

/// The restricted three-body problem with close approaches to the small primary (down to
/// r2 ~ 1e-3): unregularized, plain DTH breaks down and robust DTH falls back hundreds of
/// times; regularized about the small primary, robust DTH never falls back (at least 10x fewer
/// fallback steps: none) and plain DTH completes, with the Jacobi constant at roundoff at every
/// midpoint.
#[test]
fn three_body_close_approaches_need_no_fallback_when_regularized() {
    let plain = run(&scene(&three_body(false, "dtau = 0.001")));
    let failure = plain[0].failure.as_ref().expect("plain DTH breaks down");
    assert!(
        matches!(
            failure.cause,
            FailureCause::Integrator(dth::Error::Breakdown { .. })
        ),
        "{failure}"
    );
    let unregularized = run(&scene(&three_body(false, "dtau = 0.001\nrobust = true")));
    let unregularized = &unregularized[0].summary;
    assert!(unregularized.failure.is_none(), "{unregularized:?}");
    let regularized = run(&scene(&three_body(true, "dtau = 0.02\nrobust = true")));
    let regularized = &regularized[0].summary;
    assert!(regularized.failure.is_none(), "{regularized:?}");
    assert!(
        unregularized.fallback.steps > 0
            && 10 * regularized.fallback.steps <= unregularized.fallback.steps,
        "fallback steps: {} regularized, {} unregularized",
        regularized.fallback.steps,
        unregularized.fallback.steps
    );
    assert_eq!(regularized.fallback.steps, 0);

    // Plain DTH on the regularized K: every midpoint, in physical coordinates, has the Jacobi
    // constant of the start to roundoff. K = |u|^2 (H + p_t) is solved to roundoff of its own
    // terms, which are |u|^2 times those of H and p_t = -E (near the primary mu/r2 |u|^2 = mu:
    // |u|^2 = r2 takes the singular term's size away), so |H - E| = |K| / |u|^2 is roundoff
    // relative to the terms of H and |E|, whatever r2; mapping back and storing q about the
    // barycentre round each component once more, which H turns into its sensitivity
    // |dH/dz_i| eps |z_i| (`jacobi`). A few roundings of each (the Newton stop, K's evaluation,
    // the map back, H's evaluation here) stay within 8 eps of that scale (measured: 0.7 eps).
    let scene = scene(&three_body(true, "dtau = 0.02"));
    let system = TextSystem::build(&scene).unwrap();
    let z0 = initial_state(&system, &scene).unwrap();
    let stop = stop_for(&system, &scene, &z0, &options()).unwrap();
    let (energy, _) = jacobi(z0.as_slice());
    let (mut worst, mut closest, mut steps) = (0.0_f64, f64::INFINITY, 0);
    let mut observe = |r: &StepRecord<dth::nalgebra::Dyn>| {
        let (h, scale) = jacobi(r.z.as_slice());
        worst = worst.max((h - energy).abs() / (scale + energy.abs()));
        closest = closest.min((r.z[0] - 0.99).hypot(r.z[1]));
        steps += 1;
    };
    let end = run_method(&scene.methods[0], &system, z0, 0.0, stop, &mut observe)
        .unwrap()
        .unwrap();
    assert_eq!(end.t, 5.0, "the run ends at the physical time asked");
    assert!(closest < 2e-3, "closest approach r2 = {closest}");
    assert!(
        worst < 8.0 * f64::EPSILON,
        "relative Jacobi error {worst:e} ({:.1} eps) over {steps} midpoints",
        worst / f64::EPSILON
    );
}

/// The final state a regularized scene reports is the end of the same DTH run on `K` mapped
/// back (`q = c + q(u)`, `p = A(u) P / (2 |u|^2)`), at the physical end time; its energy error
/// is that of the physical `H`.
#[test]
fn the_final_state_is_the_regularized_end_mapped_back() {
    let scene = scene(THREE_BODY);
    let results = run(&scene);
    let dth = &results[0].summary;
    let reported = dth.final_state.as_ref().expect("final_state was asked for");

    let source = scene.hamiltonian.as_ref().unwrap().source.as_str();
    let k =
        RuntimeHamiltonian::levi_civita(&translated(source, &[0.99, 0.0]).unwrap(), &[]).unwrap();
    let z0 = Vector4::new(1.04 - 0.99, 0.0, 0.0, 1.09);
    // The energy as the scene computes it: the text's H, about the centre, at the start about
    // the centre, in double-double.
    let energy = k.physical_energy_slice(z0.as_slice()).unwrap();
    let w0 = LeviCivita::start(&z0, 0.0, energy).unwrap();
    let (w, steps) = by_hand(&k, w0.as_slice(), 0.02, 5.0);
    let (z, t) = LeviCivita::physical(&Vector6::from_column_slice(w.as_slice()));
    let expected = [z[0] + 0.99, z[1], z[2], z[3]];
    // The same run (same K, start and steps), so the same numbers.
    assert_eq!(reported.z, expected);
    assert_eq!((reported.t, t, dth.t_end), (5.0, 5.0, 5.0));
    assert_eq!(reported.step, steps);
    // The energy error is of the physical H: at the final state it is one of the deviations
    // the statistics cover.
    let (h, _) = jacobi(&reported.z);
    let stats = dth.energy.as_ref().expect("energy_deviation was asked for");
    assert!((h - energy).abs() <= stats.points.max, "{h} {energy}");
}

/// The law of time the scene reports is physical: `lambda = dt/dtau = |u|^2 lambda_K`, for
/// which the DTH relation between consecutive midpoint times, `t_{k+1} - t_k = dtau
/// (lambda_{k+1} + lambda_k) / 2`, is the t-row of the step equation of `K` (`dK/dp_t =
/// |u|^2`), exact up to the rounding of the sums.
#[test]
fn the_law_of_time_is_physical() {
    let scene = scene(THREE_BODY);
    let system = TextSystem::build(&scene).unwrap();
    let z0 = initial_state(&system, &scene).unwrap();
    let stop = stop_for(&system, &scene, &z0, &options()).unwrap();
    let mut records: Vec<(f64, f64, dth::observer::StepKind)> = Vec::new();
    let mut observe = |r: &StepRecord<dth::nalgebra::Dyn>| {
        records.push((r.t, r.dth.as_ref().unwrap().lambda, r.kind));
    };
    run_method(&scene.methods[0], &system, z0, 0.0, stop, &mut observe)
        .unwrap()
        .unwrap();
    let dtau = 0.02;
    let mut worst = 0.0_f64;
    for pair in records.windows(2) {
        let ((t0, l0, _), (t1, l1, kind)) = (pair[0], pair[1]);
        // The last step is shortened in tau to land on T: its dtau is its own.
        if kind == dth::observer::StepKind::Shortened {
            continue;
        }
        // Rounding of t (up to 5) in each sum, relative to the step.
        let off = ((t1 - t0) - dtau * (l1 + l0) / 2.0).abs();
        worst = worst.max(off / (16.0 * f64::EPSILON * t1.max(1.0)));
    }
    assert!(worst <= 1.0, "law of time off by {worst} x 16 eps t");
    // lambda follows r2 (0.05 at the start, ~1e-3 at the closest approaches).
    let smallest = records.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
    assert!(smallest < 0.1 * records[0].1, "{smallest} {}", records[0].1);
}

/// The shipped Kepler scene at e = 0.99: plain (robust, never falling back) and order 8 DTH
/// run 10 orbits to the physical end time with the energy of the physical H at roundoff, and
/// the orbit closes where it started (the pericentre, after whole periods).
#[test]
fn kepler_e099_scene_runs_without_fallback() {
    let scene = scene(KEPLER_E099);
    for r in run(&scene) {
        let s = &r.summary;
        assert!(s.failure.is_none(), "{s:?}");
        assert_eq!(s.fallback.steps, 0, "{}", s.label);
        // At the end time to the rounding of the t coordinate's sum over ~1,000 steps.
        let t_end = 15707.963267948966;
        assert!(
            (s.t_end - t_end).abs() <= 1e-12 * t_end,
            "{}: {}",
            s.label,
            s.t_end
        );
        // |H - E| against the terms |p|^2 + 1/r: at pericentre 1.99 + 2, eps of which is
        // 9e-16; 4e-15 = 18 eps.
        let energy = s.energy.as_ref().unwrap().points.max;
        assert!(energy < 4e-15, "{}: {energy:e}", s.label);
        // Order 8 is back at pericentre after 10 orbits (order 2 at ~100 steps per orbit
        // keeps the orbit's shape but drifts in phase).
        if s.label == "dth_order8" {
            let z = &s.final_state.as_ref().unwrap().z;
            let off = (z[0] - 0.5).abs().max(z[1].abs());
            assert!(off < 1e-6, "{}: {z:?}", s.label);
        }
    }
}

/// Kustaanheimo-Stiefel in a scene: an inclined Kepler orbit at e = 0.99 about a centre off the
/// origin, its final state the KS run's end mapped back.
#[test]
fn a_ks_scene_about_a_centre_runs_in_space() {
    let (c, v) = ([0.25, -0.5, 1.0], 1.99f64.sqrt());
    let text = format!(
        "[system]\nhamiltonian = \"p1^2 + p2^2 + p3^2 - ((q1 - 0.25)^2 + (q2 + 0.5)^2 + (q3 - 1.0)^2)^(-1/2)\"\n\
         regularize = \"ks\"\ncentre = [0.25, -0.5, 1.0]\n\
         [initial]\nq = [0.75, -0.5, 1.0]\np = [0.0, {}, {}]\n\
         [[method]]\nkind = \"dth\"\ndtau = 0.3\n[duration]\ntime = 3141.592653589793\n\
         [[effect]]\nkind = \"final_state\"\n[[effect]]\nkind = \"energy_deviation\"\n",
        v * 0.7f64.cos(),
        v * 0.7f64.sin()
    );
    let scene = scene(&text);
    let results = run(&scene);
    let s = &results[0].summary;
    assert!(s.failure.is_none(), "{s:?}");
    let z0 = Vector6::new(0.5, 0.0, 0.0, 0.0, v * 0.7f64.cos(), v * 0.7f64.sin());
    let source = scene.hamiltonian.as_ref().unwrap().source.as_str();
    let k =
        RuntimeHamiltonian::kustaanheimo_stiefel(&translated(source, &c).unwrap(), &[]).unwrap();
    // The energy as the scene computes it: the text's H, about the centre, at the start about
    // the centre, in double-double.
    let energy = k.physical_energy_slice(z0.as_slice()).unwrap();
    let w0 = KustaanheimoStiefel::start(&z0, 0.0, energy).unwrap();
    let (w, _) = by_hand(&k, w0.as_slice(), 0.3, 3141.592653589793);
    let w = dth::nalgebra::SVector::<f64, 10>::from_column_slice(w.as_slice());
    let (z, _) = KustaanheimoStiefel::physical(&w);
    let reported = &s.final_state.as_ref().unwrap().z;
    // The same K and start, so the same run; the centre is added back.
    for i in 0..6 {
        let expected = if i < 3 { z[i] + c[i] } else { z[i] };
        assert_eq!(reported[i], expected, "component {i}");
    }
    assert!(s.energy.as_ref().unwrap().points.max < 4e-15);
}

/// Each mistake in `regularize` and `centre` is an error at its place in the file, saying what
/// was expected.
#[test]
fn bad_regularizations_are_scene_errors_at_their_place() {
    let base = |system: &str, q: &str, p: &str| {
        format!(
            "[system]\n{system}\n[initial]\nq = {q}\np = {p}\n\
             [[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\nsteps = 10\n"
        )
    };
    let kepler = "hamiltonian = \"p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)\"";
    let cases: Vec<(String, &str)> = vec![
        (
            base(
                &format!("{kepler}\nregularize = \"levi_civita\""),
                "[1.0, 0.0]",
                "[0.0, 1.0]",
            ),
            "r.toml:3:14: unknown regularization `levi_civita`: expected \"levi-civita\" (planar, n = 2) or \"ks\"",
        ),
        (
            base(
                "hamiltonian = \"p1^2 - 1/q1\"\nregularize = \"levi-civita\"",
                "[1.0]",
                "[0.5]",
            ),
            "r.toml:3:14: `levi-civita` regularizes a Hamiltonian of n = 2 degrees of freedom, and `H = p1^2 - 1/q1` has n = 1",
        ),
        (
            base(
                "hamiltonian = \"p1^2 + p2^2 + p3^2 + p4^2 - (q1^2 + q2^2 + q3^2 + q4^2)^(-1/2)\"\nregularize = \"ks\"",
                "[1.0, 0.0, 0.0, 0.0]",
                "[0.0, 1.0, 0.0, 0.0]",
            ),
            "r.toml:3:14: `ks` regularizes a Hamiltonian of n = 3 degrees of freedom, and `H = p1^2 + p2^2 + p3^2 + p4^2 - (q1^2 + q2^2 + q3^2 + q4^2)^(-1/2)` has n = 4",
        ),
        (
            base(
                &format!("{kepler}\nregularize = \"ks\""),
                "[1.0, 0.0]",
                "[0.0, 1.0]",
            ),
            "has n = 2: use \"levi-civita\"",
        ),
        (
            base(
                &format!("{kepler}\nregularize = \"levi-civita\"\ncentre = [0.5]"),
                "[1.0, 0.0]",
                "[0.0, 1.0]",
            ),
            "r.toml:4:10: `centre` has 1 value, but `H = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)` has n = 2 degrees of freedom: expected 2",
        ),
        (
            base(
                &format!("{kepler}\nregularize = \"levi-civita\"\ncentre = [0.5, 0.0]"),
                "[0.5, 0.0]",
                "[0.0, 1.0]",
            ),
            "r.toml:6:5: initial `q` = [0.5, 0.0] is the centre of the regularization",
        ),
        (
            base(&format!("{kepler}\ncentre = [0.5, 0.0]"), "[1.0, 0.0]", "[0.0, 1.0]"),
            "r.toml:3:10: `centre` is the centre of a regularization: give `regularize`",
        ),
        (
            base(
                "name = \"henon_heiles\"\nregularize = \"levi-civita\"",
                "[0.1, 0.0]",
                "[0.0, 0.1]",
            ),
            "r.toml:3:14: `regularize` rewrites a Hamiltonian's text, and `henon_heiles` is a catalogue system compiled from Rust without one: give its H as `hamiltonian",
        ),
        (
            base(
                "hamiltonian = \"p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2) + q1*cos(t)\"\nregularize = \"levi-civita\"",
                "[1.0, 0.0]",
                "[0.0, 1.0]",
            ),
            "r.toml:3:14: `H = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2) + q1*cos(t)` cannot be regularized by levi-civita: ",
        ),
        (
            base(&format!("{kepler}\nregularize = \"levi-civita\""), "[1.0, 0.0]", "[0.0, 1.0]")
                .replace("kind = \"dth\"\ndtau = 0.1", "kind = \"midpoint\"\ndt = 0.1"),
            "r.toml:3:14: `regularize` applies to method `dth` (the peers run on H itself), and the scene has none",
        ),
    ];
    for (text, expected) in cases {
        let err = dth_examples::check_scene(&text, "r.toml", &Catalogue::builtin())
            .expect_err(&text)
            .to_string();
        assert!(
            err.contains(expected),
            "{err}\n--- expected ---\n{expected}"
        );
    }
}

/// A regularized scene runs its peers on the physical `H`: a fixed-step method beside
/// regularized DTH lands on the physical end time with its own energy error.
#[test]
fn peers_run_on_the_physical_h() {
    let scene = scene(THREE_BODY);
    let results = run(&scene);
    let peer = &results[1].summary;
    assert_eq!(peer.kind, "gauss_legendre2");
    assert!(peer.failure.is_none());
    assert_eq!((peer.steps, peer.t_end), (10_000, 5.0));
    // Fixed steps of 5e-4 through approaches to r2 ~ 1e-3 do not keep H.
    assert!(peer.energy.as_ref().unwrap().points.max > 1e-3);
}

/// A catalogue system with a text regularizes as the text does: `name = "kepler"` with
/// `regularize` runs DTH on the same `K` as the shipped e = 0.99 scene's text (its final
/// state bit for bit; the catalogue's text is the compiled Kepler to the bit), with no
/// fallback, while everything else is the compiled system's: a duration in `orbits` (its
/// period), the `invariants` effect (angular momentum) and method `exact`, which the text
/// scene has not. Order 8 is back at pericentre after 10 orbits to 1e-9 of the exact solution.
#[test]
fn a_catalogue_kepler_regularizes_as_its_text_does() {
    let (q, p) = ("[0.5, 0.0]", "[0.0, 1.4106735979665885]");
    let catalogue = format!(
        "[system]\nname = \"kepler\"\nregularize = \"levi-civita\"\n[initial]\nq = {q}\np = {p}\n\
         [[method]]\nkind = \"dth\"\ndtau = 0.05\norder = 8\n\
         [[method]]\nkind = \"exact\"\ndt = 1.0\n\
         [duration]\norbits = 10\n\
         [[effect]]\nkind = \"final_state\"\n[[effect]]\nkind = \"invariants\"\n\
         [[effect]]\nkind = \"energy_deviation\"\n"
    );
    let dir = tempfile::tempdir().unwrap();
    let catalogue = scene(&catalogue);
    let report = Catalogue::builtin()
        .run(&catalogue, dir.path(), &options())
        .unwrap_or_else(|e| panic!("{e}"));
    let [dth, exact] = &report.methods[..] else {
        panic!("{:?}", report.methods)
    };
    assert!(dth.failure.is_none(), "{dth:?}");
    assert_eq!(dth.fallback.steps, 0);
    assert_eq!(dth.step["regularize"], "levi-civita");
    let (z, z_exact) = (
        &dth.final_state.as_ref().unwrap().z,
        &exact.final_state.as_ref().unwrap().z,
    );
    let off = z
        .iter()
        .zip(z_exact)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(off < 1e-9, "{z:?} against {z_exact:?}");
    // |H - E| against the terms |p|^2 + 1/r (3.99 at pericentre, eps of which is 9e-16).
    assert!(dth.energy.as_ref().unwrap().points.max < 4e-15, "{dth:?}");
    // The angular momentum: quadratic in (u, P), so kept by DTH's vertices too.
    let l = &dth.invariants[0];
    assert_eq!(l.name, "angular_momentum");
    assert!(l.points.max < 1e-12, "{l:?}");
    // The text scene to the same end time: 10 of the catalogue's periods.
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.4106735979665885);
    let t_end = 10.0 * Kepler::thesis().period(&z0).unwrap();
    let text = format!(
        "[system]\nhamiltonian = \"p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)\"\nregularize = \"levi-civita\"\n\
         [initial]\nq = {q}\np = {p}\n[[method]]\nkind = \"dth\"\ndtau = 0.05\norder = 8\n\
         [duration]\ntime = {t_end:?}\n[[effect]]\nkind = \"final_state\"\n"
    );
    let text = run(&scene(&text));
    assert_eq!(text[0].summary.final_state.as_ref().unwrap().z, *z);
}

/// A regularized scene takes the start's energy in double-double: Kepler at e = 0.999, where
/// the plain sum `|p|^2 - 1/r` keeps only 13 digits of `E = -0.001` and the regularized orbit's
/// period follows `E`, ends 10 orbits within 1e-8 of the exact solution (measured 7.7e-10;
/// with the plain sum's energy 2.1e-7: a rounding of `|p|^2 = 1.999`, up to 2.2e-16, is up to
/// 2.2e-13 of `E`, which shifts the period by up to 3.3e-13 of 49,673 and the state at the
/// pericentre, moving at 2.8, by up to 4.6e-8 per orbit). The exact state at `T` is
/// `kepler_state` of
/// `dth-examples/benches/ias15_kepler.py` (Kepler's equation at 50 digits for the start as
/// stored).
#[test]
fn a_regularized_scene_takes_the_start_energy_to_full_precision() {
    let p = 1.999f64.sqrt();
    let z0 = Vector4::new(0.5, 0.0, 0.0, p);
    let energy = p * p - 2.0;
    let a = -1.0 / (2.0 * energy);
    let t_end = 10.0 * (2.0 * std::f64::consts::PI * (a * a * a / 2.0).sqrt());
    let exact_at_t_end = [
        0.49999999999998884,
        1.494935065549687e-07,
        -2.1146861822134545e-07,
        1.4138599647772445,
    ];
    // 128 steps per orbit: an orbit is half a period of the u-oscillator, sqrt(-E) its
    // angular frequency.
    let dtau = std::f64::consts::PI / (128.0 * (-energy).sqrt());
    let text = format!(
        "[system]\nhamiltonian = \"p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)\"\nregularize = \"levi-civita\"\n\
         [initial]\nq = [0.5, 0.0]\np = [0.0, {p:?}]\n[[method]]\nkind = \"dth\"\ndtau = {dtau:?}\norder = 8\n\
         [duration]\ntime = {t_end:?}\n[[effect]]\nkind = \"final_state\"\n"
    );
    let results = run(&scene(&text));
    let end = results[0].summary.final_state.as_ref().unwrap();
    // The run ends at T to a few ulps: the exact state moved by the orbit's own change.
    let orbit = dth::kepler::KeplerOrbit::new(&dth::systems::Kepler::thesis(), &z0).unwrap();
    let moved = orbit.state_at(end.t) - orbit.state_at(t_end);
    let error = (0..4)
        .map(|i| (end.z[i] - (exact_at_t_end[i] + moved[i])).abs())
        .fold(0.0, f64::max);
    println!("error {error:e}");
    assert!(error < 1e-8, "error {error:e} at t = {}", end.t);
}

/// A parabolic start (E = H(z0) zero to roundoff) is refused with its reason: `K`'s `Psi` is
/// proportional to `E` for Kepler, so its sign is noise (it failed at step 1 with "a
/// non-physical root with lambda = -1"). The method fails at step 0; the scene's other
/// methods run.
#[test]
fn a_parabolic_start_is_refused_with_its_reason() {
    let text = format!(
        "[system]\nhamiltonian = \"p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)\"\nregularize = \"levi-civita\"\n\
         [initial]\nq = [0.5, 0.0]\np = [0.0, {:?}]\n\
         [[method]]\nkind = \"dth\"\ndtau = 0.05\n[[method]]\nkind = \"midpoint\"\ndt = 0.01\n\
         [duration]\ntime = 1.0\n",
        2f64.sqrt()
    );
    let results = run(&scene(&text));
    let failure = results[0].summary.failure.as_ref().expect("refused");
    assert_eq!(failure.step, 0, "{failure:?}");
    assert!(failure.reason.contains("parabolic orbit"), "{failure:?}");
    assert!(results[1].summary.failure.is_none());
}

/// `double_double = true` on a regularized scene's `dth` method runs as the library's run
/// started in double-double (`Solve::start_low`): Kepler at e = 0.999, DTH-8 at 91 steps per
/// orbit over 100 orbits ends within 1e-10 of the exact state at `T` (measured 1.3e-11; the
/// same scene from doubles 1.8e-9, which the test also requires to miss: what it shows is the
/// difference), on `T` itself, and says so in its summary. The exact state is
/// `dth-examples/benches/ias15_kepler.py`'s `kepler_state(0.999, T)` (Kepler's equation at 50
/// digits for the start as stored). Without `[system] regularize` the key is an error at its
/// method.
#[test]
fn a_scene_solved_in_double_double_reaches_1e_10_at_e0999() {
    let p = 1.999f64.sqrt();
    let energy = p * p - 2.0;
    let a = -1.0 / (2.0 * energy);
    let t_end = 100.0 * (2.0 * std::f64::consts::PI * (a * a * a / 2.0).sqrt());
    assert_eq!(t_end, 4967294.132900526);
    let exact = [
        0.49999999999888106,
        1.4955934453998533e-06,
        -2.1156175047818246e-06,
        1.413859964774112,
    ];
    let dtau = std::f64::consts::PI / (91.0 * (-energy).sqrt());
    let text = |keys: &str| {
        format!(
            "[system]\nhamiltonian = \"p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)\"\nregularize = \"levi-civita\"\n\
             [initial]\nq = [0.5, 0.0]\np = [0.0, {p:?}]\n[[method]]\nkind = \"dth\"\ndtau = {dtau:?}\norder = 8\n{keys}\
             [duration]\ntime = {t_end:?}\n[[effect]]\nkind = \"final_state\"\n"
        )
    };
    let error = |keys: &str| {
        let results = run(&scene(&text(keys)));
        let summary = &results[0].summary;
        let said = summary.step.get("double_double") == Some(&serde_json::Value::Bool(true));
        assert_eq!(said, !keys.is_empty(), "{:?}", summary.step);
        let end = summary.final_state.as_ref().unwrap();
        assert_eq!(end.t, t_end);
        (0..4)
            .map(|i| (end.z[i] - exact[i]).abs())
            .fold(0.0, f64::max)
    };
    let dd = error("double_double = true\n");
    assert!(dd <= 1e-10, "in double-double: {dd:e}");
    let doubles = error("");
    assert!(doubles > 1e-10, "from doubles: {doubles:e}");
    let plain = text("double_double = true\n").replace("regularize = \"levi-civita\"\n", "");
    let err = dth_examples::check_scene(&plain, "s.toml", &Catalogue::builtin()).unwrap_err();
    assert!(
        err.to_string()
            .contains("`double_double` solves a regularized run in double-double"),
        "{err}"
    );
}
