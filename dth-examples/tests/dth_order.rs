//! DTH of order 4-8 through scenes (`order = N` on a `dth` method): the thesis orbit at order
//! 8 ends exactly at `T` with a global error below 1e-9, and `order` is validated.

use dth_examples::catalogue::Catalogue;
use dth_examples::scene::StepSpec;
use dth_examples::simulate::{compute, RunOptions};
use dth_examples::system::SceneSystem;
use dth_examples::systems::Kepler;
use dth_examples::Error;

const SCENE: &str = include_str!("../scenes/thesis-kepler-order8.toml");

#[test]
fn order_8_on_the_thesis_orbit_ends_at_t_within_1e_9() {
    let scene =
        dth_examples::check_scene(SCENE, "thesis-kepler-order8.toml", &Catalogue::builtin())
            .expect("valid scene");
    assert!(matches!(
        scene.methods[0].step,
        StepSpec::Dth { order: 8, .. }
    ));
    let kepler = Kepler::thesis();
    let results =
        compute(&kepler, &scene, &RunOptions::default().with_progress(false)).expect("runs");
    let z0 = dth::nalgebra::Vector4::new(0.5, 0.0, 0.0, 1.2);
    let t_end = 3.0 * kepler.period(&z0).expect("bound orbit");
    let exact = kepler.exact_solution(&z0, t_end).expect("elliptic");
    let error_of = |label: &str| {
        let r = results
            .iter()
            .find(|r| r.summary.label == label)
            .expect(label);
        let f = r.outputs.final_state.as_ref().expect("final_state");
        let z = dth::nalgebra::Vector4::from_column_slice(&f.z);
        (
            f.t,
            (z - exact).norm(),
            r.summary.energy.as_ref().map(|e| e.points.max),
        )
    };
    let (t, error, energy) = error_of("dth8");
    println!(
        "dth8: t = {t}, error {error:e}, energy {energy:?}; dth2: {:?}",
        error_of("dth2")
    );
    // The run ends on T: to the roundoff of the time sum (Kepler's energy residual is
    // cancellation-free, so lambda carries no eps / h^2 noise).
    assert!(
        (t - t_end).abs() <= 1e-9 * t_end,
        "ends at {t}, T = {t_end}"
    );
    assert!(
        (t - t_end).abs() <= 4.0 * f64::EPSILON * t_end,
        "ends at {t}, T = {t_end}"
    );
    assert!(error <= 1e-9, "global error {error:e}");
    // Energy at every midpoint: |H| = 0.56 with terms of size 2, a few eps.
    assert!(
        energy.is_some_and(|e| e <= 4.0 * f64::EPSILON),
        "{energy:?}"
    );
    // Plain DTH at the same dtau ends at T too, and is far less accurate.
    let (t2, error2, _) = error_of("dth2");
    assert!((t2 - t_end).abs() <= 4.0 * f64::EPSILON * t_end);
    assert!(error2 > 1e3 * error, "{error2:e}");
    // Its summary says which order ran.
    let summary = &results[0].summary;
    assert_eq!(summary.step.get("order"), Some(&serde_json::json!(8)));
}

#[test]
fn order_is_checked_where_it_is_written() {
    let bad = SCENE.replace("order = 8", "order = 5");
    let err = dth_examples::check_scene(&bad, "s.toml", &Catalogue::builtin()).unwrap_err();
    let message = err.to_string();
    assert!(matches!(err, Error::Scene(_)), "{err:?}");
    assert!(
        message.contains("s.toml:19:9: `order` = 5: expected 2, 4, 6 or 8"),
        "{message}"
    );
    // A peer method has no order.
    let bad = SCENE.replace(
        "kind = \"gauss_legendre2\"\ndt = 0.05",
        "kind = \"gauss_legendre2\"\ndt = 0.05\norder = 4",
    );
    let message = dth_examples::check_scene(&bad, "s.toml", &Catalogue::builtin())
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("`order` is a key of method `dth` only: `gauss_legendre2` takes `dt`"),
        "{message}"
    );
}
