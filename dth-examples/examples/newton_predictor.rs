//! Why joint Newton takes 4 iterations per DTH step at the thesis settings, and what a better
//! predictor would save: `cargo run --release -p dth-examples --example newton_predictor`.
//!
//! Runs the thesis Kepler orbit (dtau = 0.06277, lambda_0 = 1, 25 points per orbit) with the
//! library stepper, then for every step replays the joint Newton iteration of
//! `dth-core/src/dth/newton.rs` with the plain energy residual (same equations, same stopping
//! rule: relative update `u <= 4 eps`, or remainder `u theta / (1 - theta) <= 4 eps` with
//! `theta < 1/2`, or stall; scaled residual <= 64 eps) from several predictors, and prints the
//! predictor errors and the iteration counts; every replay must land on the library's solution
//! (printed). The library's own count is printed first: it solves Kepler with the
//! cancellation-free residual, from the first predictor below.

use dth::dth::{integrate, DthOptions};
use dth::nalgebra::{Matrix4, Vector4};
use dth::systems::Kepler;
use dth::{j_times, Hamiltonian};

const TIGHT: f64 = 4.0 * f64::EPSILON;
const RESIDUAL: f64 = 64.0 * f64::EPSILON;
const STALL: f64 = 9.094_947_017_729_282e-13; // 2^-40

/// Two fixed-point sweeps of `z = v + (h/2) lambda J gradH(z)` from `v` (the library's
/// predictor), or `sweeps` of them.
fn predict(h: &Kepler, v: &Vector4<f64>, lambda: f64, dtau: f64, sweeps: usize) -> Vector4<f64> {
    let half = 0.5 * dtau * lambda;
    let mut z = *v;
    for _ in 0..sweeps {
        z = v + j_times(&h.gradient(&z)) * half;
    }
    z
}

/// The library's joint Newton iteration, replayed; returns iterations and the solution.
fn joint(
    h: &Kepler,
    v: &Vector4<f64>,
    energy: f64,
    dtau: f64,
    mut z: Vector4<f64>,
    mut lambda: f64,
) -> (u32, Vector4<f64>, f64) {
    let (mut last, mut previous): (Option<f64>, Option<f64>) = (None, None);
    let mut iterations = 0;
    loop {
        let d = h.derivatives(&z);
        let jg = j_times(&d.gradient);
        let move_ = jg * (0.5 * dtau * lambda);
        let f = z - v - move_;
        let r = d.value - energy;
        let scale_f = z.amax().max(v.amax()).max(move_.amax());
        let scale_r = energy
            .abs()
            .max(d.value.abs())
            .max(z.component_mul(&d.gradient).abs().sum());
        let residual = (f.amax() / scale_f).max(r.abs() / scale_r);
        let stopped = last.map(|u| {
            if u <= TIGHT {
                return true;
            }
            previous.is_some_and(|p| {
                let theta = u / p;
                (theta < 0.5 && u * theta / (1.0 - theta) <= TIGHT) || (u <= STALL && theta >= 0.5)
            })
        });
        if stopped == Some(true) && residual <= RESIDUAL {
            return (iterations, z, lambda);
        }
        if iterations >= 50 {
            return (iterations, z, lambda);
        }
        let jhess = Matrix4::from_fn(|i, j| {
            if i < 2 {
                d.hessian[(i + 2, j)]
            } else {
                -d.hessian[(i - 2, j)]
            }
        });
        let a = Matrix4::identity() - jhess * (0.5 * dtau * lambda);
        let lu = a.lu();
        let z_lambda = lu.solve(&(jg * (0.5 * dtau))).unwrap_or_default();
        let g_lambda = -(0.5 * dtau * lambda) * jg.dot(&(d.hessian * z_lambda));
        let u = lu.solve(&(-f)).unwrap_or_default();
        let dl = -(r + d.gradient.dot(&u)) / g_lambda;
        let dz = u + z_lambda * dl;
        z += dz;
        lambda += dl;
        iterations += 1;
        previous = last;
        last = Some((dz.amax() / z.amax()).max(dl.abs() / lambda.abs()));
    }
}

fn main() {
    let kepler = Kepler::thesis();
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let options = DthOptions::thesis_kepler();
    let dtau = options.dtau();
    let steps = 2000;
    let t = integrate(kepler, z0, options, steps).expect("thesis run");
    let (zs, ls, its) = (t.midpoints(), t.lambdas(), t.iterations());
    let energy = kepler.value(&z0);
    let library: f64 = its[3..].iter().map(|&i| f64::from(i)).sum::<f64>() / (steps - 2) as f64;
    println!("library joint Newton, steps 3..={steps}: {library:.3} iterations per step");

    type Predictor<'a> = (
        &'static str,
        Box<dyn Fn(usize, &Vector4<f64>) -> (Vector4<f64>, f64) + 'a>,
    );
    let psi = move |z: &Vector4<f64>| kepler.psi(z);
    let law_of_time = move |k: usize, v: &Vector4<f64>, sweeps: usize| {
        let z1 = predict(&kepler, v, ls[k], dtau, 2);
        let ratio = psi(&zs[k]) / psi(&z1);
        let l = ls[k] * ratio.cbrt();
        (predict(&kepler, v, l, dtau, sweeps), l)
    };
    // Cubic Hermite extrapolation of zbar(tau) to tau_{k+1} from zbar and its tau-derivative
    // zbar' = lambda J gradH(zbar) at tau_{k-1} and tau_k (both known from earlier steps):
    // the basis functions at s = 2 are 5, 2, -4, 4.
    let hermite = move |k: usize| {
        let d = |j: usize| j_times(&kepler.gradient(&zs[j])) * (ls[j] * dtau);
        zs[k - 1] * 5.0 + d(k - 1) * 2.0 - zs[k] * 4.0 + d(k) * 4.0
    };
    let predictors: Vec<Predictor> = vec![
        (
            "library: law-of-time lambda, 2 sweeps",
            Box::new(move |k, v| law_of_time(k, v, 2)),
        ),
        (
            "law-of-time lambda, 3 sweeps",
            Box::new(move |k, v| law_of_time(k, v, 3)),
        ),
        (
            "exact lambda_{k+1}, 2 sweeps (z error alone)",
            Box::new(move |k, v| (predict(&kepler, v, ls[k + 1], dtau, 2), ls[k + 1])),
        ),
        (
            "exact lambda_{k+1}, 4 sweeps",
            Box::new(move |k, v| (predict(&kepler, v, ls[k + 1], dtau, 4), ls[k + 1])),
        ),
        (
            "quadratic extrapolation of lambda, 2 sweeps",
            Box::new(move |k, v| {
                let l = 3.0 * ls[k] - 3.0 * ls[k - 1] + ls[k - 2];
                (predict(&kepler, v, l, dtau, 2), l)
            }),
        ),
        (
            "quadratic extrapolation of lambda, 3 sweeps",
            Box::new(move |k, v| {
                let l = 3.0 * ls[k] - 3.0 * ls[k - 1] + ls[k - 2];
                (predict(&kepler, v, l, dtau, 3), l)
            }),
        ),
        (
            "law-of-time constant c = lambda psi^(1/3) extrapolated linearly, 3 sweeps",
            Box::new(move |k, v| {
                let c = |j: usize| ls[j] * psi(&zs[j]).cbrt();
                let c1 = 2.0 * c(k) - c(k - 1);
                let z1 = predict(&kepler, v, ls[k], dtau, 2);
                let l = c1 / psi(&z1).cbrt();
                (predict(&kepler, v, l, dtau, 3), l)
            }),
        ),
        (
            "Hermite extrapolation of zbar in tau, law-of-time lambda at it, 1 sweep",
            Box::new(move |k, v| {
                let zh = hermite(k);
                let l = ls[k] * (psi(&zs[k]) / psi(&zh)).cbrt();
                (v + j_times(&kepler.gradient(&zh)) * (0.5 * dtau * l), l)
            }),
        ),
        (
            "Hermite extrapolation of zbar in tau, law-of-time lambda at it, 2 sweeps",
            Box::new(move |k, v| {
                let zh = hermite(k);
                let l = ls[k] * (psi(&zs[k]) / psi(&zh)).cbrt();
                let z1 = v + j_times(&kepler.gradient(&zh)) * (0.5 * dtau * l);
                (v + j_times(&kepler.gradient(&z1)) * (0.5 * dtau * l), l)
            }),
        ),
        (
            "Hermite zbar, exact lambda_{k+1}, 1 sweep (z error alone)",
            Box::new(move |k, v| {
                let zh = hermite(k);
                let l = ls[k + 1];
                (v + j_times(&kepler.gradient(&zh)) * (0.5 * dtau * l), l)
            }),
        ),
        (
            "Hermite zbar, law-of-time constant extrapolated linearly at it, 2 sweeps",
            Box::new(move |k, v| {
                let c = |j: usize| ls[j] * psi(&zs[j]).cbrt();
                let zh = hermite(k);
                let l = (2.0 * c(k) - c(k - 1)) / psi(&zh).cbrt();
                let z1 = v + j_times(&kepler.gradient(&zh)) * (0.5 * dtau * l);
                (v + j_times(&kepler.gradient(&z1)) * (0.5 * dtau * l), l)
            }),
        ),
        (
            "Hermite zbar, law-of-time constant extrapolated quadratically at it, 2 sweeps",
            Box::new(move |k, v| {
                let c = |j: usize| ls[j] * psi(&zs[j]).cbrt();
                let zh = hermite(k);
                let l = (3.0 * c(k) - 3.0 * c(k - 1) + c(k - 2)) / psi(&zh).cbrt();
                let z1 = v + j_times(&kepler.gradient(&zh)) * (0.5 * dtau * l);
                (v + j_times(&kepler.gradient(&z1)) * (0.5 * dtau * l), l)
            }),
        ),
        (
            "law-of-time lambda at exact zbar_{k+1} (law error alone), 4 sweeps",
            Box::new(move |k, v| {
                let l = ls[k] * (psi(&zs[k]) / psi(&zs[k + 1])).cbrt();
                (predict(&kepler, v, l, dtau, 4), l)
            }),
        ),
        (
            "extrapolated law-of-time constant at exact zbar_{k+1}, 4 sweeps",
            Box::new(move |k, v| {
                let c = |j: usize| ls[j] * psi(&zs[j]).cbrt();
                let l = (2.0 * c(k) - c(k - 1)) / psi(&zs[k + 1]).cbrt();
                (predict(&kepler, v, l, dtau, 4), l)
            }),
        ),
        (
            "quadratic extrapolation of lambda and zbar (no sweeps)",
            Box::new(move |k, _v| {
                let l = 3.0 * ls[k] - 3.0 * ls[k - 1] + ls[k - 2];
                (zs[k] * 3.0 - zs[k - 1] * 3.0 + zs[k - 2], l)
            }),
        ),
    ];
    println!(
        "{:<74} {:>11} {:>11} {:>9} {:>5}",
        "predictor", "|dz|/|z|", "|dl|/l", "it/step", "max"
    );
    for (name, p) in &predictors {
        let (mut ez, mut el, mut total, mut max) = (0.0, 0.0, 0u32, 0u32);
        let mut worst = 0.0f64;
        for k in 2..steps {
            let v = zs[k] + j_times(&kepler.gradient(&zs[k])) * (0.5 * dtau * ls[k]);
            let (zg, lg) = p(k, &v);
            ez += (zg - zs[k + 1]).amax() / zs[k + 1].amax();
            el += (lg - ls[k + 1]).abs() / ls[k + 1];
            let (it, z, l) = joint(&kepler, &v, energy, dtau, zg, lg);
            // The replay must land on the library's solution.
            worst = worst.max((z - zs[k + 1]).amax()).max((l - ls[k + 1]).abs());
            total += it;
            max = max.max(it);
        }
        let n = (steps - 2) as f64;
        println!(
            "{name:<74} {:>11.2e} {:>11.2e} {:>9.3} {max:>5}   (solution differs by {worst:.1e})",
            ez / n,
            el / n,
            f64::from(total) / n
        );
    }
}
