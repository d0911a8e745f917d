//! Every method a scene can name runs the real integrator behind `method::run_method`, checked
//! by a property of that integrator (not by comparing with stored output).

use dth::kepler::KeplerOrbit;
use dth::nalgebra::Vector4;
use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::{compute, MethodResult, RunOptions};
use dth_examples::systems::{ForcedOscillator, Kepler};

const Z0: [f64; 4] = [0.5, 0.0, 0.0, 1.2];

fn run_kepler(methods: &str, steps: usize) -> Vec<MethodResult> {
    let text = format!(
        "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n{methods}\n\
         [duration]\nsteps = {steps}\n[[effect]]\nkind = \"final_state\"\n\
         [[effect]]\nkind = \"comparison_table\"\n"
    );
    let scene = dth_examples::check_scene(&text, "wired.toml", &Catalogue::builtin()).unwrap();
    compute(
        &Kepler::thesis(),
        &scene,
        &RunOptions::default().with_progress(false),
    )
    .unwrap()
}

fn method(kind: &str, step: &str) -> String {
    format!(
        "[[method]]\nkind = \"{kind}\"\nlabel = \"{kind}_{}\"\n{step}\n",
        step.len()
    )
}

fn final_z(r: &MethodResult) -> (f64, Vector4<f64>) {
    let f = r.summary.final_state.as_ref().unwrap();
    (f.t, Vector4::from_iterator(f.z.iter().copied()))
}

#[test]
fn both_dth_solvers_give_the_same_trajectory_with_energy_exact_at_midpoints() {
    let m = format!(
        "{}solver = \"joint\"\n{}solver = \"nested\"\n",
        method("dth", "dtau = 0.06277"),
        method("dth", "dtau = 0.06277\nlambda0 = 1.0")
    );
    let r = run_kepler(&m, 500);
    let (t1, z1) = final_z(&r[0]);
    let (t2, z2) = final_z(&r[1]);
    // Both solve the same equations to roundoff; 500 steps amplify differences of a few eps by
    // at most the orbit's mild (linear in time) error growth: 1e-10 is far above roundoff
    // growth and far below the O(dtau^2) ~ 4e-3 discretization error.
    assert!(
        (z1 - z2).amax() < 1e-10 && (t1 - t2).abs() < 1e-10,
        "{z1} {z2}"
    );
    for res in &r {
        let e = res.summary.energy.as_ref().unwrap();
        // Theorem 4: H(zbar_k) = H(zbar_0) to roundoff (|H| = 0.56: a few eps).
        assert!(e.points.max < 1e-14, "{:?}", e);
        let l = &res.summary.invariants[0];
        // Theorem 7: angular momentum exact at the vertices.
        assert!(l.vertices.unwrap().max < 1e-13, "{:?}", l);
        assert_eq!(res.summary.steps, 500);
    }
}

#[test]
fn every_peer_follows_the_exact_kepler_orbit_at_a_small_step() {
    let kinds = [
        "trapezoidal",
        "midpoint",
        "discrete_mechanics",
        "stormer_verlet",
        "rk4",
        "gauss_legendre2",
        "discrete_gradient",
        "exact",
    ];
    let m: String = kinds.iter().map(|k| method(k, "dt = 0.001")).collect();
    let r = run_kepler(&m, 3748); // one period 3.7483 at dt = 0.001
    let orbit = KeplerOrbit::new(&Kepler::thesis().reference(), &Vector4::from(Z0)).unwrap();
    for (res, kind) in r.iter().zip(kinds) {
        let (t, z) = final_z(res);
        assert!((t - 3.748).abs() < 1e-12, "{kind}: t = {t}");
        let err = (z - orbit.state_at(t)).amax();
        // Second-order methods: error ~ C dt^2; the pericentre (r = 0.5, speed 2.4) makes C of
        // order 10^2 on this orbit (the trapezoid's is 2.4e-4 at dt = 0.001). The order-4
        // ones and the exact solution are far below.
        let bound = match kind {
            "exact" => 1e-12,
            "rk4" | "gauss_legendre2" => 1e-8,
            _ => 1e-3,
        };
        assert!(err < bound, "{kind}: error {err:e} after one orbit");
    }
    // Exact invariants: midpoint and Gauss-Legendre keep L, discrete mechanics and the
    // discrete gradient keep H, all to roundoff over the orbit.
    let stats = |i: usize| &r[i].summary;
    assert!(stats(1).invariants[0].points.max < 1e-13);
    assert!(stats(5).invariants[0].points.max < 1e-13);
    assert!(stats(2).energy.as_ref().unwrap().points.max < 1e-13);
    assert!(stats(6).energy.as_ref().unwrap().points.max < 1e-13);
}

#[test]
fn dth_runs_the_forced_oscillator_in_the_extended_phase_space() {
    let text = "[system]\nname = \"forced_oscillator\"\n[initial]\nq = [1.0]\np = [0.0]\nt = 0.5\n\
                [[method]]\nkind = \"dth\"\ndtau = 0.02\n[duration]\ntime = 10.0\n\
                [[effect]]\nkind = \"final_state\"\n[[effect]]\nkind = \"energy_deviation\"\n";
    let scene = dth_examples::check_scene(text, "forced.toml", &Catalogue::builtin()).unwrap();
    let sys = ForcedOscillator {
        omega0: 1.0,
        f: 0.1,
        omega: 1.3,
    };
    let r = compute(&sys, &scene, &RunOptions::default().with_progress(false)).unwrap();
    assert!(r[0].summary.failure.is_none(), "{:?}", r[0].summary.failure);
    let f = r[0].summary.final_state.as_ref().unwrap();
    // The clock is tbar (started at t0 = 0.5) and equals the state's t coordinate.
    assert!(f.t >= 10.5 && f.t < 10.6, "{}", f.t);
    assert!((f.z[1] - f.t).abs() < 1e-12, "{:?}", f.z);
    // calH = 0 at every midpoint (paper Theorem 1, eq. 11) to roundoff.
    let e = r[0].summary.energy.as_ref().unwrap();
    assert!(e.points.max < 1e-13, "{e:?}");
    // Against a reference solution of q'' = -q + F cos(omega t) from t0 = 0.5 (classical RK4
    // with 20,000 steps, error ~1e-14): the DTH midpoint is within O(dtau^2) of it.
    let (mut q, mut p, mut t) = (1.0_f64, 0.0_f64, 0.5_f64);
    let h = (f.t - t) / 20_000.0;
    let acc = |q: f64, t: f64| -q + 0.1 * (1.3 * t).cos();
    for _ in 0..20_000 {
        let (k1q, k1p) = (p, acc(q, t));
        let (k2q, k2p) = (p + 0.5 * h * k1p, acc(q + 0.5 * h * k1q, t + 0.5 * h));
        let (k3q, k3p) = (p + 0.5 * h * k2p, acc(q + 0.5 * h * k2q, t + 0.5 * h));
        let (k4q, k4p) = (p + h * k3p, acc(q + h * k3q, t + h));
        q += h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
        p += h / 6.0 * (k1p + 2.0 * k2p + 2.0 * k3p + k4p);
        t += h;
    }
    // DTH with dtau = 0.02 and lambda ~ 1: error O(dtau^2) ~ 4e-4 over ten time units.
    let err = (f.z[0] - q).abs().max((f.z[2] - p).abs());
    assert!(err < 2e-3, "{:?} vs {q} {p}", f.z);
}
