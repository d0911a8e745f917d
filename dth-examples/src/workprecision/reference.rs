//! Reference solutions: exact where known, otherwise 2-stage Gauss-Legendre at a tiny step with
//! cubic Hermite interpolation between its steps.

use dth::methods::{run, GaussLegendre2};
use dth::nalgebra::Const;
use dth::nalgebra::SVector;
use dth::observer::Recorder;
use dth::{j_times, Hamiltonian};

use super::{Error, ReferenceCheck};

/// The state of the exact (or converged) solution at any time in `[0, T]`.
pub(crate) struct Reference<const D: usize> {
    at: Box<dyn Fn(f64) -> SVector<f64, D>>,
    pub check: ReferenceCheck,
}

impl<const D: usize> Reference<D> {
    /// An exact solution.
    pub fn exact(system: &'static str, at: impl Fn(f64) -> SVector<f64, D> + 'static) -> Self {
        Reference {
            at: Box::new(at),
            check: ReferenceCheck {
                system,
                kind: "exact",
                step: 0.0,
                estimated_error: 0.0,
            },
        }
    }

    /// The reference state at time `t`.
    pub fn at(&self, t: f64) -> SVector<f64, D> {
        (self.at)(t)
    }
}

/// Stored states and slopes of a fixed-step run, interpolated by cubic Hermite polynomials
/// (error `h^4 max|z''''| / 384`, far below a 4th-order method's own error at that step).
struct Dense<const D: usize> {
    step: f64,
    z: Vec<SVector<f64, D>>,
    f: Vec<SVector<f64, D>>,
}

impl<const D: usize> Dense<D> {
    fn at(&self, t: f64) -> SVector<f64, D> {
        let last = self.z.len() - 2;
        let x = t / self.step;
        // Clamp: callers ask for times in [0, T]; T itself may exceed the last grid time by
        // an ulp.
        let i = (x.floor().max(0.0) as usize).min(last);
        let s = x - i as f64;
        let (h00, h10) = ((1.0 + 2.0 * s) * (1.0 - s).powi(2), s * (1.0 - s).powi(2));
        let (h01, h11) = (s * s * (3.0 - 2.0 * s), s * s * (s - 1.0));
        self.z[i] * h00
            + self.f[i] * (h10 * self.step)
            + self.z[i + 1] * h01
            + self.f[i + 1] * (h11 * self.step)
    }
}

/// The largest error accepted for a computed reference at `T`: 100 times below the smallest
/// global error the harness reports as meaningful (1e-10, a decade below the 1e-9 target).
const REFERENCE_TOLERANCE: f64 = 1e-12;

/// Gauss-Legendre 2 at `step` (rounded so that `T` is a whole number of steps), checked by
/// Richardson's estimate against the run at twice the step: for a 4th-order method the error of
/// the finer run is about `|z_2h(T) - z_h(T)| / 15`.
pub(crate) fn gauss_legendre_reference<H: Hamiltonian<Const<D>>, const D: usize>(
    system: &'static str,
    hamiltonian: &H,
    z0: &SVector<f64, D>,
    t_end: f64,
    step: f64,
) -> Result<Reference<D>, Error> {
    let fail = |message: String| Error::Reference { system, message };
    let n = (t_end / step).ceil().max(2.0) as usize;
    let n = n + n % 2; // even, so the coarse run has whole steps
    let h = t_end / n as f64;
    let mut fine = Recorder::new();
    run(
        &mut GaussLegendre2::new(),
        hamiltonian,
        z0,
        0.0,
        h,
        n,
        &mut fine,
    )
    .map_err(|e| fail(format!("fine run: {}", e.error)))?;
    let coarse = run(
        &mut GaussLegendre2::new(),
        hamiltonian,
        z0,
        0.0,
        2.0 * h,
        n / 2,
        &mut (),
    )
    .map_err(|e| fail(format!("coarse run: {}", e.error)))?;
    let last = fine.z[n];
    let estimated_error = (coarse.z - last).norm() / 15.0;
    // NaN fails too.
    if estimated_error.is_nan() || estimated_error > REFERENCE_TOLERANCE {
        return Err(fail(format!(
            "not converged: estimated error {estimated_error:.3e} at step {h:.3e} exceeds \
             {REFERENCE_TOLERANCE:e}"
        )));
    }
    let f = fine
        .z
        .iter()
        .map(|z| j_times(&hamiltonian.gradient(z)))
        .collect();
    let dense = Dense {
        step: h,
        z: fine.z,
        f,
    };
    Ok(Reference {
        at: Box::new(move |t| dense.at(t)),
        check: ReferenceCheck {
            system,
            kind: "gauss_legendre2",
            step: h,
            estimated_error,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use dth::nalgebra::Vector2;
    use dth::systems::HarmonicOscillator;

    #[test]
    fn hermite_reference_matches_the_oscillator_between_steps() {
        // q = cos t, p = -sin t for m = k = 1. GL2 at h = 2 pi / 4000 has error ~ h^4 t / 2880
        // ~ 1e-15 per unit time; Hermite adds ~ h^4 / 384 ~ 1e-14.
        let h = HarmonicOscillator { mass: 1.0, k: 1.0 };
        let t_end = 10.0;
        let r = gauss_legendre_reference(
            "oscillator",
            &h,
            &Vector2::new(1.0, 0.0),
            t_end,
            std::f64::consts::TAU / 4000.0,
        )
        .unwrap();
        for t in [0.0, 0.123_456, 3.3, 7.777_777, t_end] {
            let z = r.at(t);
            let err = (z - Vector2::new(t.cos(), -t.sin())).norm();
            assert!(err < 1e-12, "t = {t}: error {err:e}");
        }
        assert!(r.check.estimated_error < 1e-13);
    }
}
