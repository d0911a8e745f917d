//! Conditioning of the DTH step as dtau -> 0: with the cancellation-free energy
//! residual, lambda is computed to machine precision against a double-double solve of the same
//! step for every dtau from the thesis's 0.06277 down to 1e-6; the plain residual's error
//! grows like eps / dtau^2 (the control that shows the comparison can fail).

use dth_core::nalgebra::Const;
mod hard_support;

use dth_core::dth::{integrate, Dth, DthOptions, EnergyResidual, Solver};
use dth_core::nalgebra::Vector4;
use dth_core::systems::Kepler;
use hard_support::{reference_step, Target};

const EPS: f64 = f64::EPSILON;

/// Max relative error of lambda_{k+1} over `steps` steps from each of a few midpoints spread
/// around the thesis orbit, against the double-double solve of the same step (same f64 inputs
/// zbar_k, lambda_k).
fn worst_lambda_error(dtau: f64, residual: EnergyResidual, solver: Solver, steps: usize) -> f64 {
    worst_lambda_error_of(Kepler::thesis(), dtau, residual, solver, steps)
}

/// As [`worst_lambda_error`] for any implementation of the thesis's Kepler `H` (the reference
/// solve is Kepler's in double-double).
fn worst_lambda_error_of<H: dth_core::Hamiltonian<Const<4>> + Copy>(
    system: H,
    dtau: f64,
    residual: EnergyResidual,
    solver: Solver,
    steps: usize,
) -> f64 {
    let kepler = Kepler::thesis();
    let orbit = integrate(
        kepler,
        Vector4::new(0.5, 0.0, 0.0, 1.2),
        DthOptions::thesis_kepler(),
        25,
    )
    .expect("thesis orbit");
    let options = DthOptions::new(dtau)
        .expect("valid dtau")
        .with_energy_residual(residual)
        .with_solver(solver);
    let mut worst = 0.0f64;
    // Every fourth midpoint of one orbit: pericentre (psi largest), apocentre (smallest) and
    // in between.
    for start in orbit.iter().step_by(4) {
        let mut dth = Dth::new(
            system,
            start.z,
            options
                .with_lambda0(start.dth.map_or(f64::NAN, |d| d.lambda))
                .expect("lambda > 0"),
        )
        .expect("start");
        let energy = dth.energy();
        for _ in 0..steps {
            let (z0, lambda0) = (*dth.zbar(), dth.lambda());
            let rec = dth.step().expect("step");
            let rec_lambda = rec.dth.map_or(f64::NAN, |d| d.lambda);
            let target = if dth.cancellation_free() {
                Target::Previous
            } else {
                Target::Level(energy)
            };
            let (_, lambda_ref, last) =
                reference_step(&kepler, &z0, lambda0, dtau, target, (rec.z, rec_lambda));
            // The reference's own noise is the double-double roundoff of H (~1e-32) over the
            // O(dtau^2) sensitivity of the energy equation: at most ~1e-20 at dtau = 1e-6,
            // far below the f64 errors measured here.
            assert!(last < 1e-19, "reference solve converged ({last:e})");
            let err = ((dth_core_dd_sub(rec_lambda, lambda_ref)) / rec_lambda).abs();
            worst = worst.max(err);
        }
    }
    worst
}

/// `x - y` for f64 `x` and double-double `y`, rounded.
fn dth_core_dd_sub(x: f64, y: hard_support::dd::Dd) -> f64 {
    (hard_support::dd::Dd::new(x) - y).to_f64()
}

const DTAUS: [f64; 6] = [0.06277, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6];

#[test]
fn lambda_is_machine_precision_from_thesis_dtau_down_to_1e_minus_6() {
    // Kepler has exact divided differences, so the default residual is cancellation-free.
    let options = DthOptions::thesis_kepler();
    let dth = Dth::new(Kepler::thesis(), Vector4::new(0.5, 0.0, 0.0, 1.2), options).expect("start");
    assert!(dth.cancellation_free());
    let mut errors = Vec::new();
    for dtau in DTAUS {
        let cf = worst_lambda_error(dtau, EnergyResidual::CancellationFree, Solver::Joint, 8);
        let nested = worst_lambda_error(dtau, EnergyResidual::CancellationFree, Solver::Nested, 8);
        let plain = worst_lambda_error(dtau, EnergyResidual::Plain, Solver::Joint, 8);
        println!(
            "dtau {dtau:.2e}: max relative lambda error, cancellation-free {cf:.2e} ({:.1} eps; \
             nested {:.1} eps), plain {plain:.2e}",
            cf / EPS,
            nested / EPS
        );
        let cf = cf.max(nested);
        errors.push((dtau, cf, plain));
    }
    for &(dtau, cf, _) in &errors {
        // Each residual term is computed to a few eps of its own size and the Newton stop
        // leaves a relative update of at most 4 eps: lambda to within 8 eps (relative) of the
        // exact solution of its step, independent of dtau.
        assert!(cf <= 8.0 * EPS, "dtau {dtau:e}: {cf:e}");
    }
    // Control: the plain residual, solved against its own (level) equation, loses accuracy
    // like eps / dtau^2: at 1e-4 that is far above machine precision.
    let plain_1e4 = errors[3].2;
    assert!(plain_1e4 > 1e-10, "plain residual at 1e-4: {plain_1e4:e}");
}

/// Max over k of |lambda_{k+1} - 2 lambda_k + lambda_{k-1}| / lambda_k.
fn lambda_roughness<H: dth_core::Hamiltonian<Const<D>> + Copy, const D: usize>(
    h: H,
    z0: dth_core::nalgebra::SVector<f64, D>,
    dtau: f64,
    residual: EnergyResidual,
) -> f64 {
    let options = DthOptions::new(dtau)
        .expect("valid")
        .with_energy_residual(residual);
    let t = integrate(h, z0, options, 300).unwrap_or_else(|e| panic!("{}", e.error));
    t.lambdas()
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs() / w[1])
        .fold(0.0, f64::max)
}

#[test]
fn pendulum_lambda_is_smooth_with_exact_divided_differences() {
    // No double-double pendulum here: lambda(tau) is smooth, so its second differences at
    // dtau = 1e-6 are h^2 lambda'' ~ 1e-12 (lambda ~ 1 varying on the orbit's time scale ~ 1)
    // plus the roundoff of each lambda. With the pendulum's exact divided differences
    // (sinc forms) that roundoff is ~eps; the plain residual's is ~eps / h^2 ~ 1e-4.
    let pendulum = dth_core::systems::Pendulum::normalized();
    let z0 = dth_core::nalgebra::Vector2::new(0.3, 1.0);
    let cf = lambda_roughness(pendulum, z0, 1e-6, EnergyResidual::Auto);
    let plain = lambda_roughness(pendulum, z0, 1e-6, EnergyResidual::Plain);
    println!("pendulum, dtau 1e-6: max |second difference of lambda| / lambda: exact divided differences {cf:.2e}, plain {plain:.2e}");
    assert!(cf <= 1e-11, "{cf:e}");
    assert!(plain >= 1e-7, "{plain:e}");
}

/// Kepler with its exact discrete gradient but the trait's default (plain) defect
/// `t = g0 + g1 - 2 gbar`: what a Hamiltonian generated with exact `discrete_gradient` alone
/// gives the cancellation-free residual (forced with `EnergyResidual::CancellationFree`: it does
/// not declare `EXACT_DIVIDED_DIFFERENCES`, which promises both).
#[derive(Clone, Copy)]
struct GbarOnly(Kepler);

impl dth_core::Hamiltonian<Const<4>> for GbarOnly {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn value(&self, z: &Vector4<f64>) -> f64 {
        self.0.value(z)
    }
    fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = self.0.gradient(z);
    }
    fn hessian_into(&self, z: &Vector4<f64>, out: &mut dth_core::nalgebra::Matrix4<f64>) {
        *out = self.0.hessian(z);
    }
    fn discrete_gradient_into(&self, z0: &Vector4<f64>, z1: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = self.0.discrete_gradient(z0, z1);
    }
}

#[test]
fn exact_discrete_gradient_without_exact_defect_leaves_lambda_error_like_eps_over_dtau() {
    // Why the defect needs its own cancellation-free form: with it plain, its absolute error
    // eps |grad H| enters lambda as ~eps / dtau (still far better than the plain residual's
    // eps / dtau^2).
    let mut errors = Vec::new();
    for dtau in [1e-2, 1e-4, 1e-6] {
        let e = worst_lambda_error_of(
            GbarOnly(Kepler::thesis()),
            dtau,
            EnergyResidual::CancellationFree,
            Solver::Joint,
            8,
        );
        println!("exact gbar, plain defect: dtau {dtau:.0e}: max relative lambda error {e:.2e}");
        errors.push(e);
    }
    assert!(errors[2] > 1e3 * EPS, "{errors:?}");
    assert!(
        errors[2] / errors[1] > 10.0,
        "grows as dtau shrinks: {errors:?}"
    );
}
