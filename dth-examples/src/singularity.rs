//! Whether a regularization applies to a system at a state: a planar or spatial autonomous `H`
//! with a `1/r`-like singularity (a Kepler centre, a primary of the restricted three-body
//! problem) near that state, which Levi-Civita (two degrees of freedom) or
//! Kustaanheimo-Stiefel (three) removes ([`regularization`]). `dth check` asks it where `Psi`
//! changes sign on a scene's orbit, and a robust run where it fell back (`crate::fallback`),
//! to suggest `regularize = "levi-civita"` or `"ks"` under `[system]`.
//!
//! Nothing symbolic is needed, so it works alike for the catalogue's `hamiltonian!` types and a
//! scene's text: the singular point is located from the derivatives at the state and then
//! tested numerically.
//!
//! **Locating the centre.** For `V = -k / |q - c|`, `grad V = k d / r^3` and
//! `Hess V = k (I - 3 d d^T / r^2) / r^3` with `d = q - c`, `r = |d|`, so
//! `Hess V d = -2 grad V`: the centre is `c = q + 2 (Hess_qq H)^-1 grad_q H`, exactly, from any
//! state. Smooth terms beside the singular one (kinetic, a perturbation, a second primary, the
//! rotating frame's `p1 q2 - p2 q1`) move this estimate by a share that shrinks with `r`, so it
//! is repeated from points closer to the estimate (each `SHRINK` of the previous distance)
//! until it moves less than `CENTRE_TOLERANCE` of the first distance.
//!
//! **Testing it.** `H` is `1/r`-like at `c` when `s(eps) = eps H(c + eps e, p)` tends to the same
//! finite, nonzero constant (`-k`) along two perpendicular directions `e`: compared at
//! `eps = r0 / 10^4` and `r0 / 10^6` (`r0` the state's distance to `c`), where the singular term
//! outweighs the smooth ones ~10^4-fold. A `1/r^2` term grows `s` 100-fold between the two, a
//! logarithm or a regular point sends it to zero, a line singularity (`1/|q1|`) has a singular
//! Hessian or differs along the two directions.

use dth::nalgebra::{DMatrix, DVector, DefaultAllocator, Dim};
use dth::{Alloc, Hamiltonian};

use crate::derive::Regularization as Preset;

/// Each refinement of the centre starts this much closer to the previous estimate.
const SHRINK: f64 = 1.0 / 16.0;

/// The centre is taken once an estimate moves it by less than this share of the state's
/// distance to it: far below the smallest `eps` of the test (`r0 / 10^6`), so that the test
/// sees the singularity and not the estimate's error.
const CENTRE_TOLERANCE: f64 = 1e-9;

/// At most this many estimates of the centre (from the state and from closer points).
const MAX_ESTIMATES: usize = 12;

/// The two distances of the test, as shares of the state's distance to the centre.
const TEST_DISTANCES: [f64; 2] = [1e-4, 1e-6];

/// `s(eps)` at the two distances must agree to this share: for `-k/r + W(q)`, `W` smooth,
/// they differ by `(eps1 - eps2) |W| / k`, ~`10^-4` where `|W| r0 / k` is near 1 (a Kepler
/// orbit) and still below this where a smooth term is 100 times the singular one at `r0`.
const SAME_STRENGTH: f64 = 0.01;

/// A regularization that applies at a state: which one and about which point.
#[derive(Debug, Clone, PartialEq)]
pub struct Regularization {
    /// Levi-Civita for two degrees of freedom, Kustaanheimo-Stiefel for three.
    pub preset: Preset,
    /// The singular point `c` in configuration space, rounded to the decimals the estimate
    /// resolves (`CENTRE_TOLERANCE`, 1e-9, of the state's distance to it): the origin is `0`.
    pub centre: Vec<f64>,
    /// `lim eps H(c + eps e)`: `-k` for a `-k/r` term.
    pub strength: f64,
}

impl Regularization {
    /// The scene's spelling of the preset: `levi-civita` or `ks`.
    pub fn name(&self) -> &'static str {
        match self.preset {
            Preset::LeviCivita => "levi-civita",
            Preset::Ks => "ks",
        }
    }

    /// `true` when the centre is the origin.
    pub fn at_origin(&self) -> bool {
        self.centre.iter().all(|c| *c == 0.0)
    }

    /// What to write under `[system]`: `regularize = "levi-civita"`, with
    /// `centre = [c1, c2]` when the centre is not the origin.
    pub fn scene_keys(&self) -> String {
        let mut keys = format!("regularize = \"{}\"", self.name());
        if !self.at_origin() {
            let c: Vec<String> = self.centre.iter().map(|x| format!("{x:?}")).collect();
            keys.push_str(&format!(", centre = [{}]", c.join(", ")));
        }
        keys
    }
}

/// In `summary.json`: `{"preset": "levi-civita", "centre": [0.0, 0.0], "scene_keys":
/// "regularize = \"levi-civita\""}`.
impl serde::Serialize for Regularization {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut s = serializer.serialize_struct("Regularization", 3)?;
        s.serialize_field("preset", self.name())?;
        s.serialize_field("centre", &self.centre)?;
        s.serialize_field("scene_keys", &self.scene_keys())?;
        s.end()
    }
}

/// "`regularize = "levi-civita"` under `[system]` (H has a 1/r singularity at q = (0, 0), which
/// Levi-Civita removes: DTH then runs through it without breaking down)".
impl std::fmt::Display for Regularization {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c: Vec<String> = self.centre.iter().map(|x| format!("{x:?}")).collect();
        let which = match self.preset {
            Preset::LeviCivita => "Levi-Civita",
            Preset::Ks => "Kustaanheimo-Stiefel",
        };
        write!(
            f,
            "`{}` under [system] (H has a 1/r singularity at q = ({}), which {which} removes: the regularized Psi keeps its sign there and DTH runs through without falling back)",
            self.scene_keys(),
            c.join(", ")
        )
    }
}

/// The regularization that applies to `h` near the state `z`, if one does (see the
/// [module docs](self)): `h` autonomous and not already regularized, with two or three
/// degrees of freedom, and a `1/r`-like singular point that the derivatives at `z` point to.
/// `None` otherwise, and wherever a derivative is not finite.
pub fn regularization<D: Dim, H: Hamiltonian<D>>(
    h: &H,
    z: &dth::nalgebra::OVector<f64, D>,
) -> Option<Regularization>
where
    DefaultAllocator: Alloc<D>,
{
    let flags = h.flags();
    if flags.time_dependent || flags.regularized {
        return None;
    }
    let n = z.len() / 2;
    let preset = match n {
        2 => Preset::LeviCivita,
        3 => Preset::Ks,
        _ => return None,
    };
    let mut at = z.clone();
    let q0 = DVector::from_iterator(n, z.iter().take(n).copied());
    let mut centre = centre_estimate(h, &at, n)?;
    let r0 = (&q0 - &centre).norm();
    if !(r0.is_finite() && r0 > 0.0) {
        return None;
    }
    let mut converged = false;
    for _ in 1..MAX_ESTIMATES {
        let q: Vec<f64> = at.iter().take(n).copied().collect();
        let q = DVector::from_vec(q);
        let closer = &centre + (&q - &centre) * SHRINK;
        for i in 0..n {
            at[i] = closer[i];
        }
        let next = centre_estimate(h, &at, n)?;
        let moved = (&next - &centre).norm();
        centre = next;
        if moved <= CENTRE_TOLERANCE * r0 {
            converged = true;
            break;
        }
    }
    if !converged {
        return None;
    }
    // The directions of the test: towards the state, and perpendicular to it in the plane of
    // its first two coordinates; the distances from the state's distance to the centre found
    // (the first estimate's may be off by a share of it).
    let r0 = (&q0 - &centre).norm();
    if !(r0.is_finite() && r0 > 0.0) {
        return None;
    }
    let e1 = (&q0 - &centre) / r0;
    let mut e2 = DVector::zeros(n);
    e2[0] = -e1[1];
    e2[1] = e1[0];
    if e2.norm() < 0.5 {
        // The state lies above the centre along q3: any direction in the plane is perpendicular.
        e2 = DVector::zeros(n);
        e2[0] = 1.0;
    }
    e2.normalize_mut();
    let mut strengths = Vec::with_capacity(4);
    for e in [&e1, &e2] {
        for share in TEST_DISTANCES {
            let eps = share * r0;
            let point = &centre + e * eps;
            for i in 0..n {
                at[i] = point[i];
            }
            strengths.push(eps * h.value(&at));
        }
    }
    let strength = strengths[strengths.len() - 1];
    let alike = strength.is_finite()
        && strength != 0.0
        && strengths
            .iter()
            .all(|s| (s - strength).abs() <= SAME_STRENGTH * strength.abs());
    if !alike {
        return None;
    }
    // To the decimals the estimate resolves, so that a centre at the origin is the origin and
    // one at -0.25 reads -0.25 (`+ 0.0` turns -0 into 0).
    let decimals = (-(CENTRE_TOLERANCE * r0).log10()).ceil().clamp(0.0, 15.0) as i32;
    let scale = 10f64.powi(decimals);
    Some(Regularization {
        preset,
        centre: centre
            .iter()
            .map(|c| (c * scale).round() / scale + 0.0)
            .collect(),
        strength,
    })
}

/// `c = q + 2 (Hess_qq H)^-1 grad_q H` at `z` (the [module docs](self)); `None` where the
/// block is singular or anything is not finite.
fn centre_estimate<D: Dim, H: Hamiltonian<D>>(
    h: &H,
    z: &dth::nalgebra::OVector<f64, D>,
    n: usize,
) -> Option<DVector<f64>>
where
    DefaultAllocator: Alloc<D>,
{
    let gradient = h.gradient(z);
    let hessian = h.hessian(z);
    let g = DVector::from_iterator(n, gradient.iter().take(n).copied());
    let block = DMatrix::from_fn(n, n, |i, j| hessian[(i, j)]);
    let x = block.lu().solve(&g)?;
    let q = DVector::from_iterator(n, z.iter().take(n).copied());
    let c = q + x * 2.0;
    c.iter().all(|v| v.is_finite()).then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dth::nalgebra::{DVector as V, Vector2, Vector4};
    use dth::runtime::RuntimeHamiltonian;

    fn text(src: &str) -> RuntimeHamiltonian {
        RuntimeHamiltonian::new(src, &[]).unwrap()
    }

    /// The thesis's Kepler problem, anywhere on an eccentric orbit: Levi-Civita about the
    /// origin, of strength -k = -1.
    #[test]
    fn kepler_is_regularized_about_the_origin() {
        let kepler = crate::systems::Kepler::thesis();
        for z in [
            Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt()),
            Vector4::new(-3.0, 4.0, 0.2, -0.1),
        ] {
            let r = regularization(&kepler, &z).unwrap();
            assert_eq!(r.preset, Preset::LeviCivita);
            assert_eq!(r.centre, [0.0, 0.0]);
            // eps (p^2 + ...) beside -1: the kinetic term at eps = 1e-6 r0.
            assert!((r.strength + 1.0).abs() < 1e-5, "{}", r.strength);
            assert_eq!(r.scene_keys(), "regularize = \"levi-civita\"");
        }
    }

    /// A centre off the origin with a perturbation beside it (a second, far attractor and a
    /// Stark field; the restricted three-body problem's rotating frame) is found, and a spatial
    /// problem gets KS.
    #[test]
    fn an_offset_centre_and_a_spatial_problem() {
        let h = text(
            "p1^2/2 + p2^2/2 - ((q1 + 0.25)^2 + (q2 - 1)^2)^(-1/2) - 0.01*((q1 - 5)^2 + q2^2)^(-1/2) + 0.1*q1",
        );
        let z = V::from_vec(vec![0.5, 1.2, 0.1, 0.3]);
        let r = regularization(&h, &z).unwrap();
        assert_eq!(r.centre, [-0.25, 1.0]);
        assert_eq!(
            r.scene_keys(),
            "regularize = \"levi-civita\", centre = [-0.25, 1.0]"
        );
        // The restricted three-body problem in the rotating frame (mu = 0.1), near the small
        // primary at (1 - mu, 0): the momentum-dependent p1 q2 - p2 q1 leaves it found.
        let h = text(
            "(p1^2 + p2^2)/2 + p1*q2 - p2*q1 - 0.9*((q1 + 0.1)^2 + q2^2)^(-1/2) - 0.1*((q1 - 0.9)^2 + q2^2)^(-1/2)",
        );
        let z = V::from_vec(vec![0.95, 0.03, -0.2, 1.1]);
        let r = regularization(&h, &z).unwrap();
        assert_eq!(r.centre, [0.9, 0.0]);
        assert!((r.strength + 0.1).abs() < 1e-5, "{}", r.strength);
        let h = text("(p1^2 + p2^2 + p3^2)/2 - 3*(q1^2 + q2^2 + q3^2)^(-1/2)");
        let z = V::from_vec(vec![0.0, 0.0, 2.0, 0.1, 0.0, 0.0]);
        let r = regularization(&h, &z).unwrap();
        assert_eq!((r.preset, r.name()), (Preset::Ks, "ks"));
        assert!((r.strength + 3.0).abs() < 1e-5, "{}", r.strength);
    }

    /// No regularization where it does not remove a singularity: a harmonic oscillator, a
    /// `1/r^2` potential, a one-dimensional system, four degrees of freedom, a time-dependent
    /// `H`.
    #[test]
    fn none_where_it_does_not_apply() {
        let z2 = V::from_vec(vec![0.5, 0.2, 0.1, 0.3]);
        for src in [
            "(p1^2 + p2^2)/2 + (q1^2 + q2^2)/2",
            "(p1^2 + p2^2)/2 - (q1^2 + q2^2)^(-1)",
            "(p1^2 + p2^2)/2 + (q1^2 + q2^2)^(1/2)",
        ] {
            assert_eq!(regularization(&text(src), &z2), None, "{src}");
        }
        let pendulum = crate::systems::Pendulum {
            m: 1.0,
            l: 1.0,
            g: 1.0,
        };
        assert_eq!(regularization(&pendulum, &Vector2::new(0.0, 2.5)), None);
        let four = text("(p1^2 + p2^2 + p3^2 + p4^2)/2 - (q1^2 + q2^2 + q3^2 + q4^2)^(-1/2)");
        let z4 = V::from_vec(vec![0.5, 0.2, 0.1, 0.3, 0.0, 1.0, 0.0, 0.0]);
        assert_eq!(regularization(&four, &z4), None);
        let forced = text("(p1^2 + p2^2)/2 - (q1^2 + q2^2)^(-1/2) + q1*cos(t)");
        let z = V::from_vec(vec![0.5, 0.2, 0.0, 0.1, 0.3, 0.0]);
        assert_eq!(regularization(&forced, &z), None);
    }
}
