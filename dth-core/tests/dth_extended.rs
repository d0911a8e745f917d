//! Extended phase space (paper Theorem 1): an autonomous H lifted to calH = p_t + H must give
//! the same DTH trajectory as the reduced stepper (Corollary 1).

use dth_core::dth::{integrate, lift, set_momentum_of_time, Dth, DthOptions, Extended};
use dth_core::nalgebra::{Vector4, Vector6};
use dth_core::systems::Kepler;
use dth_core::{Error, Hamiltonian};

const EPS: f64 = f64::EPSILON;

#[test]
fn extended_kepler_agrees_with_reduced_corollary_1() {
    let kepler = Kepler::thesis();
    let x0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let ext: Extended<Kepler, 4, 6> = Extended::new(kepler);
    let t0 = 0.25;
    let z0: Vector6<f64> = set_momentum_of_time(&ext, lift(&x0, t0));
    assert!(ext.value(&z0).abs() <= EPS, "calH(zbar_0) = 0");
    let steps = 500;
    let options = DthOptions::default();
    let reduced = integrate(kepler, x0, options, steps).expect("reduced run");
    let extended = integrate(ext, z0, options, steps).expect("extended run");

    let (mut dz, mut dl, mut dt, mut t_row, mut p_t, mut calh): (f64, f64, f64, f64, f64, f64) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (r, e) in reduced.iter().zip(extended.iter()) {
        dz = dz.max((r.zbar - Extended::<Kepler, 4, 6>::reduce(&e.zbar)).amax());
        dl = dl.max((r.lambda - e.lambda).abs() / r.lambda);
        // The stepper's tbar (started at t0) against the reduced one shifted by t0.
        dt = dt.max((e.tbar - (r.tbar + t0)).abs());
        // The t-row of the step equation is t' = lambda: the t coordinate of zbar is tbar.
        t_row = t_row.max((e.zbar[2] - e.tbar).abs() / e.tbar.abs().max(1.0));
        // Autonomous: p_t is constant (= -H(zbar_0)) and calH = 0 at every midpoint.
        p_t = p_t.max((e.zbar[5] - z0[5]).abs());
        calh = calh.max(ext.value(&e.zbar).abs());
    }
    println!(
        "extended vs reduced over {steps} steps: |dz| {dz:.2e}, rel |dlambda| {dl:.2e}, \
         |dtbar| {dt:.2e}; |t - tbar| {t_row:.2e}; |dp_t| {p_t:.2e}; |calH| {calh:.2e}"
    );
    // Same equations, different rounding (calH = p_t + H vs H - E): per-step differences at
    // the 64 eps level random-walk and are sheared by Kepler's flow (joint-vs-nested test):
    // bound 64 eps N^(3/2).
    let bound = 64.0 * EPS * (steps as f64).powf(1.5);
    assert!(dz < bound && dl < bound, "{dz:e} {dl:e} vs {bound:e}");
    // Times: tbar ~ 200 here; same bound relative to it.
    assert!(dt < bound * 200.0, "{dt:e}");
    // t coordinate and tbar follow the same recurrence t_{k+1} = t_k + h (l_k + l_{k+1}) / 2,
    // one through Newton (to roundoff per step) and one by accumulation: ~eps N relative.
    assert!(t_row < 16.0 * EPS * steps as f64, "{t_row:e}");
    // p_t's row has zero right-hand side: it moves only by Newton roundoff (~eps |p_t| per
    // step, random walk).
    assert!(p_t < 16.0 * EPS * (steps as f64).sqrt(), "{p_t:e}");
    assert!(calh < 64.0 * EPS * 4.0, "{calh:e}");
}

#[test]
fn extended_start_must_have_zero_calh() {
    let ext: Extended<Kepler, 4, 6> = Extended::new(Kepler::thesis());
    let z: Vector6<f64> = lift(&Vector4::new(0.5, 0.0, 0.0, 1.2), 0.0); // p_t = 0: calH = -0.56
    let r = Dth::new(ext, z, DthOptions::default());
    assert!(
        matches!(r, Err(Error::ExtendedEnergyNotZero { value }) if (value + 0.56).abs() < 1e-15)
    );
}
