//! Shared helpers of the `hard_*` tests: double-double arithmetic, a high-precision
//! reference solve of one DTH step on Kepler, and a close gravitating pair far from the origin.
#![allow(dead_code)]

#[path = "../../../dth-symbolic/src/double_double.rs"]
pub mod dd;
pub mod pair;

use dd::Dd;
use dth_core::nalgebra::{Matrix4, Vector4};
use dth_core::systems::Kepler;
use dth_core::Hamiltonian;

/// `H` in double-double.
pub fn kepler_value(k: &Kepler, z: &[Dd; 4]) -> Dd {
    let r = (z[0] * z[0] + z[1] * z[1]).sqrt();
    (z[2] * z[2] + z[3] * z[3]) / Dd::new(2.0 * k.mass) - Dd::new(k.k) / r
}

/// `grad H` in double-double.
pub fn kepler_gradient(k: &Kepler, z: &[Dd; 4]) -> [Dd; 4] {
    let r2 = z[0] * z[0] + z[1] * z[1];
    let kr3 = Dd::new(k.k) / (r2 * r2.sqrt());
    let m = Dd::new(k.mass);
    [kr3 * z[0], kr3 * z[1], z[2] / m, z[3] / m]
}

/// `J v` in double-double.
fn j(v: &[Dd; 4]) -> [Dd; 4] {
    [v[2], v[3], -v[0], -v[1]]
}

fn to_dd(z: &Vector4<f64>) -> [Dd; 4] {
    [z[0].into(), z[1].into(), z[2].into(), z[3].into()]
}

/// What the energy equation of the reference step targets.
#[derive(Clone, Copy, Debug)]
pub enum Target {
    /// `H(zbar_{k+1}) = H(zbar_k)`: the step equation of the paper (eq. 30) and of the
    /// cancellation-free residual.
    Previous,
    /// `H(zbar_{k+1}) = E` for the given `E` (the plain residual).
    Level(f64),
}

/// Solve one DTH step from the midpoint `z0` (f64 input, taken as exact) with multiplier
/// `lambda0` and step `h` in double-double: `z - z0 = (h/2) J (lambda g(z) + lambda0 g(z0))`,
/// energy per `target`. Newton with an f64 Jacobian (block elimination with the
/// cancellation-free `g_lambda`, as in the stepper) and double-double residuals: each
/// iteration gains ~15 digits until the residuals' own ~1e-32 roundoff. Returns `(z, lambda)`
/// and the last relative update of `lambda`.
pub fn reference_step(
    kepler: &Kepler,
    z0: &Vector4<f64>,
    lambda0: f64,
    h: f64,
    target: Target,
    guess: (Vector4<f64>, f64),
) -> ([Dd; 4], Dd, f64) {
    let zd0 = to_dd(z0);
    let g0 = kepler_gradient(kepler, &zd0);
    let e = match target {
        Target::Previous => kepler_value(kepler, &zd0),
        Target::Level(e) => Dd::new(e),
    };
    let mut z = to_dd(&guess.0);
    let mut lambda = Dd::new(guess.1);
    let half_h = Dd::new(0.5 * h);
    let mut last = f64::INFINITY;
    for _ in 0..12 {
        let g = kepler_gradient(kepler, &z);
        let mut s = [Dd::default(); 4];
        for i in 0..4 {
            s[i] = lambda * g[i] + Dd::new(lambda0) * g0[i];
        }
        let js = j(&s);
        let mut f = Vector4::zeros();
        for i in 0..4 {
            f[i] = (z[i] - zd0[i] - half_h * js[i]).to_f64();
        }
        let r = (kepler_value(kepler, &z) - e).to_f64();
        // f64 linearization at the rounded iterate.
        let zf = Vector4::new(z[0].to_f64(), z[1].to_f64(), z[2].to_f64(), z[3].to_f64());
        let lf = lambda.to_f64();
        let gf = kepler.gradient(&zf);
        let hess = kepler.hessian(&zf);
        let jm = Matrix4::new(
            0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0,
        );
        let a = Matrix4::identity() - jm * hess * (0.5 * h * lf);
        let lu = a.lu();
        let jg = jm * gf;
        let z_lambda = lu
            .solve(&(jg * (0.5 * h)))
            .expect("A is nonsingular near the solution");
        let g_lambda = -(0.5 * h * lf) * jg.dot(&(hess * z_lambda));
        let u = lu.solve(&(-f)).expect("A is nonsingular near the solution");
        let dl = -(r + gf.dot(&u)) / g_lambda;
        let dz = u + z_lambda * dl;
        for i in 0..4 {
            z[i] = z[i] + Dd::new(dz[i]);
        }
        lambda = lambda + Dd::new(dl);
        last = (dl / lf).abs();
    }
    (z, lambda, last)
}
