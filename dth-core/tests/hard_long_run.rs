//! A million DTH steps on the thesis Kepler orbit: energy at midpoints stays within
//! 1e-13 of |H(zbar_0)| and angular momentum at vertices drifts only by roundoff. Runs under
//! `cargo test` in the dev profile (measured ~4 s on the 2-core dev machine).

use dth_core::dth::{Dth, DthOptions, EnergyResidual};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::Vector4;
use dth_core::observer::StepRecord;
use dth_core::systems::Kepler;
use dth_core::Hamiltonian;

const EPS: f64 = f64::EPSILON;
const STEPS: usize = 1_000_000;

struct Drift {
    e0: f64,
    l0: Option<f64>,
    worst_energy: f64,
    mean_energy: f64,
    worst_l: f64,
    lambda_min: f64,
    lambda_max: f64,
}

fn long_run(residual: EnergyResidual, dtau: f64) -> Drift {
    let kepler = Kepler::thesis();
    let options = DthOptions::new(dtau)
        .expect("valid dtau")
        .with_energy_residual(residual);
    let mut dth = Dth::new(kepler, Vector4::new(0.5, 0.0, 0.0, 1.2), options).expect("start");
    let mut d = Drift {
        e0: dth.energy(),
        l0: None,
        worst_energy: 0.0,
        mean_energy: 0.0,
        worst_l: 0.0,
        lambda_min: f64::MAX,
        lambda_max: 0.0,
    };
    let mut observe = |r: &StepRecord<Const<4>>| {
        let de = (kepler.value(&r.z) - d.e0).abs();
        let s = r.dth.expect("a DTH record");
        d.worst_energy = d.worst_energy.max(de);
        d.mean_energy += de / STEPS as f64;
        let l = Kepler::angular_momentum(&s.vertex);
        let l0 = *d.l0.get_or_insert(l);
        d.worst_l = d.worst_l.max((l - l0).abs());
        d.lambda_min = d.lambda_min.min(s.lambda);
        d.lambda_max = d.lambda_max.max(s.lambda);
    };
    dth.run(STEPS, &mut observe).expect("a million steps");
    d
}

#[test]
fn million_steps_energy_within_1e_13_of_h0_and_vertex_angular_momentum_bounded() {
    let d = long_run(EnergyResidual::Auto, 0.06277);
    let rel = d.worst_energy / d.e0.abs();
    println!(
        "10^6 steps, dtau 0.06277 (40,000 orbits): max |H(zbar_k) - H0| / |H0| = {rel:.3e}, \
         mean {:.3e}; vertex L max drift {:.3e}; lambda in [{:.4}, {:.4}]",
        d.mean_energy / d.e0.abs(),
        d.worst_l,
        d.lambda_min,
        d.lambda_max
    );
    // Within 1e-13 relative. Each midpoint is checked against H(zbar_0) and projected
    // onto it, so the deviation is the roundoff of evaluating H (a few eps of its terms, |T|,
    // |V| <= 4 here): it does not grow with N.
    assert!(rel <= 1e-13, "{rel:e}");
    assert!(d.worst_energy <= 64.0 * EPS, "{:e}", d.worst_energy);
    // Vertex L (Theorem 7): each step changes it by roundoff (<= 16 eps, see dth_kepler), which
    // random-walks: 3 sigma of sqrt(N) steps of at most 4 eps |L| (L = 0.6) is 7e-13; a
    // systematic error (a loose Newton stop) would grow like N eps and exceed it.
    assert!(
        d.worst_l <= 3.0 * (STEPS as f64).sqrt() * 4.0 * EPS * 0.6,
        "{:e}",
        d.worst_l
    );
    // Law of time: lambda stays within the thesis orbit's range (mean 2.39).
    assert!(d.lambda_min > 0.3 && d.lambda_max < 6.0);
}

#[test]
fn million_small_steps_keep_energy_bounded_and_lambda_smooth() {
    // dtau = 1e-4: 10^6 steps reach t ~ 240 (64 orbits at mean lambda 2.4). With the
    // cancellation-free residual lambda is exact per step (hard_conditioning) and, thanks to the
    // projection onto H(zbar_0), the energy still does not random-walk (without it: 1.75e-14
    // after 15,269 steps at dtau 0.06277, growing like eps sqrt(N)).
    let d = long_run(EnergyResidual::Auto, 1e-4);
    let rel = d.worst_energy / d.e0.abs();
    println!(
        "10^6 steps, dtau 1e-4: max |H(zbar_k) - H0| / |H0| = {rel:.3e}, mean {:.3e}; \
         vertex L max drift {:.3e}",
        d.mean_energy / d.e0.abs(),
        d.worst_l
    );
    assert!(rel <= 1e-13, "{rel:e}");
    assert!(d.worst_energy <= 64.0 * EPS, "{:e}", d.worst_energy);
    assert!(
        d.worst_l <= 3.0 * (STEPS as f64).sqrt() * 4.0 * EPS * 0.6,
        "{:e}",
        d.worst_l
    );
}

#[test]
fn energy_drift_per_dtau_both_residuals() {
    // 10^5 steps at each dtau from the thesis's down to 1e-6, both energy residuals: the
    // midpoint energy stays within a few eps of H(zbar_0) (relative to |H0| = 0.56) for every
    // step size; the cancellation-free residual buys lambda's accuracy (hard_conditioning)
    // without giving up this bound.
    let kepler = Kepler::thesis();
    println!("| dtau | cancellation-free max / mean rel. dH | plain max / mean rel. dH |");
    println!("|---|---|---|");
    for dtau in [0.06277, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6] {
        let mut row = Vec::new();
        for residual in [EnergyResidual::CancellationFree, EnergyResidual::Plain] {
            let options = DthOptions::new(dtau)
                .expect("valid")
                .with_energy_residual(residual);
            let mut dth =
                Dth::new(kepler, Vector4::new(0.5, 0.0, 0.0, 1.2), options).expect("start");
            let e0 = dth.energy();
            let (mut worst, mut mean) = (0.0f64, 0.0f64);
            let n = 100_000;
            let mut observe = |r: &StepRecord<Const<4>>| {
                let de = (kepler.value(&r.z) - e0).abs() / e0.abs();
                worst = worst.max(de);
                mean += de / n as f64;
            };
            dth.run(n, &mut observe).expect("run");
            assert!(worst <= 1e-13, "dtau {dtau}, {residual:?}: {worst:e}");
            row.push((worst, mean));
        }
        println!(
            "| {dtau:.0e} | {:.2e} / {:.2e} | {:.2e} / {:.2e} |",
            row[0].0, row[0].1, row[1].0, row[1].1
        );
    }
}
