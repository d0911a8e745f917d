//! The macro's Kepler agrees with the hand-written `dth::systems::Kepler` to roundoff, in both
//! forms, and its flags are right.

use dth::nalgebra::Const;
use dth::nalgebra::Vector4;
use dth::systems::Kepler;
use dth::Hamiltonian;

dth::hamiltonian! {
    /// `H = |p|^2 / (2 m) - k / |q|` with run-time parameters.
    #[derive(Clone, Copy, Debug)]
    pub struct KeplerMk { pub m: f64, pub k: f64 } = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)
}

/// Points on and off the thesis orbit (r from 0.3 to 2, every quadrant).
fn points() -> Vec<Vector4<f64>> {
    vec![
        Vector4::new(0.5, 0.0, 0.0, 1.2),
        Vector4::new(-0.3, 0.4, 0.7, -0.2),
        Vector4::new(1.5, -1.2, -0.1, 0.3),
        Vector4::new(-0.2, -0.25, 2.0, 1.0),
    ]
}

/// |a - b| <= 8 eps * scale: both sides evaluate the same few-term formulas in a different
/// order (the generated code uses 1/r^2 and sqrt(r^2) where the hand-written one uses hypot),
/// so they differ by a few roundings of the largest term, `scale`.
fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 8.0 * f64::EPSILON * scale
}

fn check(h: &impl Hamiltonian<Const<4>>, reference: &Kepler) {
    for z in points() {
        let r = z[0].hypot(z[1]);
        let (mine, refd) = (h.derivatives(&z), reference.derivatives(&z));
        let scale = 1.0 / r + z.fixed_rows::<2>(2).norm_squared() / reference.mass;
        assert!(close(mine.value, refd.value, scale), "value at {z}");
        assert!(close(h.value(&z), refd.value, scale), "value() at {z}");
        for i in 0..4 {
            let gs = 1.0 / (r * r) + 2.0 * z[i].abs() / reference.mass;
            assert!(
                close(mine.gradient[i], refd.gradient[i], gs),
                "grad {i} at {z}"
            );
            assert_eq!(mine.gradient[i], h.gradient(&z)[i]);
            for j in 0..4 {
                let hs = 3.0 / (r * r * r) + 1.0 / reference.mass;
                assert!(
                    close(mine.hessian[(i, j)], refd.hessian[(i, j)], hs),
                    "hess {i}{j} at {z}"
                );
                assert_eq!(mine.hessian[(i, j)], h.hessian(&z)[(i, j)]);
            }
        }
        // Psi sums products of gradient and Hessian entries: scale by |grad|^2 |Hess|.
        let ps = refd.gradient.norm_squared() * (3.0 / (r * r * r) + 1.0 / reference.mass);
        assert!(
            close(mine.psi, refd.psi, 4.0 * ps),
            "psi at {z}: {} vs {}",
            mine.psi,
            refd.psi
        );
        assert_eq!(mine.psi, h.psi(&z));
    }
}

#[test]
fn expression_form_matches_the_thesis_kepler() {
    let h = dth::hamiltonian!(p1 ^ 2 + p2 ^ 2 - (q1 ^ 2 + q2 ^ 2) ^ (-1 / 2));
    check(&h, &Kepler::thesis());
}

#[test]
fn item_form_reads_parameters_at_run_time() {
    let reference = Kepler { mass: 0.8, k: 2.5 };
    check(&KeplerMk { m: 0.8, k: 2.5 }, &reference);
}

#[test]
fn delimiters_and_flags() {
    fn flags<const D: usize, H: Hamiltonian<Const<D>>>(h: &H) -> (bool, bool, bool) {
        let f = h.flags();
        (f.time_dependent, f.separable, f.psi_identically_zero)
    }
    let a = dth::hamiltonian![p1 ^ 2 + p2 ^ 2 - (q1 ^ 2 + q2 ^ 2) ^ (-1 / 2)];
    let b = dth::hamiltonian! { p1^2 + p2^2 - (q1^2+q2^2)^(-1/2) };
    assert_eq!(flags::<4, _>(&a), (false, true, false));
    assert_eq!(flags::<4, _>(&b), (false, true, false));
    assert_eq!(
        flags::<2, _>(&dth::hamiltonian!(q1 * p1)),
        (false, false, false)
    );
    assert_eq!(
        flags::<2, _>(&dth::hamiltonian!(p1 ^ 2 / 2)),
        (false, true, true)
    );
    // Extended phase space (q1, t, p1, p_t): T(p) + V(q, t) is still separable there.
    assert_eq!(
        flags::<4, _>(&dth::hamiltonian!(p1 ^ 2 / 2 + q1 * cos(t))),
        (true, true, false)
    );
    assert_eq!(
        flags::<4, _>(&dth::hamiltonian!(p1 ^ 2 * t + q1)),
        (true, false, false)
    );
}

dth::hamiltonian! {
    /// A unit struct: no parameters, no braces.
    #[derive(Clone, Copy, Debug, Default)]
    pub struct Pendulum = p1^2/2 - cos(q1)
}

#[test]
fn item_form_without_parameters_is_a_unit_struct() {
    let z = dth::nalgebra::Vector2::new(0.3, -0.4);
    // H = p^2/2 - cos q: two terms of size <= 1, a couple of roundings each.
    let expected = 0.08 - 0.3f64.cos();
    assert!((Pendulum.value(&z) - expected).abs() <= 4.0 * f64::EPSILON);
    assert_eq!(Pendulum.hessian(&z)[(0, 0)], 0.3f64.cos());
}
