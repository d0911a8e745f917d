//! Extended phase space (paper Theorem 1): an autonomous H lifted to calH = p_t + H must give
//! the same DTH trajectory as the reduced stepper (Corollary 1).

use dth_core::dth::{integrate, lift, set_momentum_of_time, Dth, DthOptions, Extended};
use dth_core::nalgebra::Const;
use dth_core::nalgebra::{Vector4, Vector6};
use dth_core::systems::Kepler;
use dth_core::Flags;
use dth_core::{Error, Hamiltonian};

const EPS: f64 = f64::EPSILON;

#[test]
fn extended_kepler_agrees_with_reduced_corollary_1() {
    let kepler = Kepler::thesis();
    let x0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let ext: Extended<Kepler, Const<4>> = Extended::new(kepler);
    let t0 = 0.25;
    let z0: Vector6<f64> = set_momentum_of_time(&ext, lift(&x0, t0)).expect("calH = 0");
    assert!(ext.value(&z0).abs() <= EPS, "calH(zbar_0) = 0");
    let steps = 500;
    let options = DthOptions::thesis_kepler();
    let reduced = integrate(kepler, x0, options, steps).expect("reduced run");
    let extended = integrate(ext, z0, options, steps).expect("extended run");

    let (mut dz, mut dl, mut dt, mut t_row, mut p_t, mut calh): (f64, f64, f64, f64, f64, f64) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (r, e) in reduced.iter().zip(extended.iter()) {
        let (lr, le) = (
            r.dth.map_or(f64::NAN, |d| d.lambda),
            e.dth.map_or(f64::NAN, |d| d.lambda),
        );
        dz = dz.max((r.z - Extended::<Kepler, Const<4>>::reduce(&e.z)).amax());
        dl = dl.max((lr - le).abs() / lr);
        // The stepper's tbar (started at t0) against the reduced one shifted by t0.
        dt = dt.max((e.t - (r.t + t0)).abs());
        // The t-row of the step equation is t' = lambda: the t coordinate of zbar is tbar.
        t_row = t_row.max((e.z[2] - e.t).abs() / e.t.abs().max(1.0));
        // Autonomous: p_t is constant (= -H(zbar_0)) and calH = 0 at every midpoint.
        p_t = p_t.max((e.z[5] - z0[5]).abs());
        calh = calh.max(ext.value(&e.z).abs());
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
    let ext: Extended<Kepler, Const<4>> = Extended::new(Kepler::thesis());
    let z: Vector6<f64> = lift(&Vector4::new(0.5, 0.0, 0.0, 1.2), 0.0); // p_t = 0: calH = -0.56
    let r = Dth::new(ext, z, DthOptions::thesis_kepler());
    assert!(
        matches!(r, Err(Error::ExtendedEnergyNotZero { value }) if (value + 0.56).abs() < 1e-15)
    );
}

/// The forced oscillator `H(t, q, p) = p^2/2 + q^2/2 - F q sin(w t)` in the extended phase
/// space `z = (q, t, p, p_t)`, `calH = p_t + H`.
struct Forced {
    f: f64,
    w: f64,
}

impl Forced {
    /// Exact `(q, p)` at time `t` from `q(0) = q0`, `p(0) = p0` (w != 1):
    /// `q = A cos t + B sin t + F sin(w t) / (1 - w^2)`.
    fn exact(&self, q0: f64, p0: f64, t: f64) -> (f64, f64) {
        let c = self.f / (1.0 - self.w * self.w);
        let (a, b) = (q0, p0 - c * self.w);
        (
            a * t.cos() + b * t.sin() + c * (self.w * t).sin(),
            -a * t.sin() + b * t.cos() + c * self.w * (self.w * t).cos(),
        )
    }
}

impl Hamiltonian<Const<4>> for Forced {
    fn dim(&self) -> Const<4> {
        Const
    }

    fn flags(&self) -> Flags {
        Flags::default().with_time_dependent(true)
    }

    fn value(&self, z: &Vector4<f64>) -> f64 {
        let (q, t, p, p_t) = (z[0], z[1], z[2], z[3]);
        p_t + 0.5 * p * p + 0.5 * q * q - self.f * q * (self.w * t).sin()
    }
    fn gradient_into(&self, z: &Vector4<f64>, out: &mut Vector4<f64>) {
        *out = {
            let (q, t, p) = (z[0], z[1], z[2]);
            let (s, c) = (self.w * t).sin_cos();
            Vector4::new(q - self.f * s, -self.f * q * self.w * c, p, 1.0)
        };
    }
    fn hessian_into(&self, z: &Vector4<f64>, out: &mut dth_core::nalgebra::Matrix4<f64>) {
        *out = {
            let (q, t) = (z[0], z[1]);
            let (s, c) = (self.w * t).sin_cos();
            let qt = -self.f * self.w * c;
            let tt = self.f * q * self.w * self.w * s;
            dth_core::nalgebra::Matrix4::new(
                1.0, qt, 0.0, 0.0, qt, tt, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0,
            )
        };
    }
}

/// Max error of (q, p) at the midpoints against the exact solution at the midpoint times
/// tbar_k (= the t coordinate of zbar_k), up to t = 10; and max |calH(zbar_k)|.
fn forced_errors(dtau: f64) -> (f64, f64) {
    let forced = Forced { f: 0.1, w: 0.5 };
    let (q0, p0) = (1.0, 0.0);
    let z0 = set_momentum_of_time(&forced, Vector4::new(q0, 0.0, p0, 0.0)).expect("calH = 0");
    let steps = (10.0 / dtau).ceil() as usize;
    let t = integrate(forced, z0, DthOptions::new(dtau).expect("dtau"), steps)
        .unwrap_or_else(|e| panic!("forced run: {}", e.error));
    let forced = Forced { f: 0.1, w: 0.5 };
    let mut err: f64 = 0.0;
    let mut calh: f64 = 0.0;
    for r in t.iter().take_while(|r| r.t <= 10.0) {
        let (q, p) = forced.exact(q0, p0, r.z[1]);
        err = err.max((r.z[0] - q).abs()).max((r.z[2] - p).abs());
        calh = calh.max(forced.value(&r.z).abs());
    }
    (err, calh)
}

#[test]
fn time_dependent_forced_oscillator_converges_at_second_order() {
    let dtaus = [0.1, 0.05, 0.025];
    let results: Vec<(f64, f64)> = dtaus.iter().map(|&d| forced_errors(d)).collect();
    let rates: Vec<f64> = results
        .windows(2)
        .map(|w| (w[0].0 / w[1].0).log2())
        .collect();
    println!(
        "forced oscillator, dtau {dtaus:?}: (max error, max |calH|) {results:?}; \
         rates {rates:.3?}"
    );
    // calH = 0 at every midpoint (Theorem 4 in the extended phase space): each midpoint is
    // solved to a scaled residual of 64 eps of terms of size ~1.
    for &(_, calh) in &results {
        assert!(calh <= 64.0 * EPS, "{calh:e}");
    }
    // Midpoints of a second-order scheme against the exact flow at the midpoint times.
    for r in &rates {
        assert!((r - 2.0).abs() < 0.2, "rate {r}");
    }
}
