//! `robust = true` on a `dth` method: a scene whose orbit breaks down (Kepler at e = 0.9,
//! where `Psi` changes sign) stops with a typed breakdown without it, and runs through with it,
//! energy still at roundoff at every midpoint (fallback nodes included).

use dth_examples::catalogue::Catalogue;
use dth_examples::simulate::{compute, MethodResult, RunOptions};
use dth_examples::systems::Kepler;

/// Kepler e = 0.9 from pericentre `q = (0.5, 0)`: `p2 = sqrt(1.9)` (thesis H, `m = 1/2`,
/// `k = 1`), at `dtau = 0.0157`, where DTH breaks down at step 19.
fn run(robust: &str) -> MethodResult {
    let text = format!(
        "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, {}]\n\
         [[method]]\nkind = \"dth\"\ndtau = 0.0157\n{robust}\n\
         [duration]\nsteps = 2000\n[[effect]]\nkind = \"comparison_table\"\n",
        1.9f64.sqrt()
    );
    let scene = dth_examples::check_scene(&text, "robust.toml", &Catalogue::builtin())
        .unwrap_or_else(|e| panic!("{e}"));
    let mut results = compute(
        &Kepler::thesis(),
        &scene,
        &RunOptions::default().with_progress(false),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    results.remove(0)
}

#[test]
fn robust_mode_runs_through_a_breakdown_that_stops_plain_dth() {
    let plain = run("");
    let failure = plain.failure.expect("plain DTH breaks down on this orbit");
    assert!(
        matches!(
            failure.cause,
            dth_examples::driver::FailureCause::Integrator(dth::Error::Breakdown { .. })
        ),
        "{failure}"
    );
    assert!(!plain.summary.step.contains_key("robust"));

    let robust = run("robust = true");
    assert!(robust.failure.is_none(), "{:?}", robust.failure);
    assert_eq!(robust.summary.steps, 2000);
    assert_eq!(robust.summary.step["robust"], true);
    // Energy at every midpoint and fallback node is H(zbar_0) = 1.9 - 1/0.5 = -0.1 to
    // roundoff: a few eps of the O(1) terms 1.9 and 2 (the library's own tests bound it the
    // same way), here 1e-14 = 45 eps.
    let energy = robust
        .summary
        .energy
        .expect("comparison_table was asked for");
    assert!(energy.points.max <= 1e-14, "{:e}", energy.points.max);
}

#[test]
fn robust_is_a_key_of_dth_only() {
    let text = "[system]\nname = \"kepler\"\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.2]\n\
                [[method]]\nkind = \"midpoint\"\ndt = 0.1\nrobust = true\n\
                [duration]\nsteps = 10\n";
    let err = dth_examples::check_scene(text, "bad.toml", &Catalogue::builtin())
        .expect_err("robust on midpoint")
        .to_string();
    assert!(
        err.contains(
            "bad.toml:9:10: `robust` is a key of method `dth` only: `midpoint` takes `dt`"
        ),
        "{err}"
    );
}
