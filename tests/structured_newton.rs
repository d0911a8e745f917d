//! Structured Newton on chains written out through `hamiltonian!` (`tests/chains/`): the
//! generated Hessian pattern and fused nonzero evaluation against the dense Hessian, the
//! structured and dense Newton paths of every implicit peer on the same steps, and the FPUT
//! chain of 512 particles (`D = 1024`), which this test binary compiles in whatever profile it
//! is built (the dev profile under `cargo test`), stepped on a thread with a 2 MB stack.
//!
//! The chain sources are generated text; `chain_sources_are_current` checks them against
//! `dth_symbolic::sources` (regenerate with `DTH_REGENERATE_CHAINS=1 cargo test --test
//! structured_newton chain_sources_are_current`).

use dth::methods::{
    DiscreteGradient, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Trapezoidal,
};
use dth::nalgebra::{SMatrix, SVector};
use dth::Hamiltonian;

include!("chains/fput_alpha_2.rs");
include!("chains/fput_alpha_8.rs");
include!("chains/fput_alpha_32.rs");
include!("chains/toda_32.rs");
include!("chains/fput_alpha_512.rs");

/// The same Hamiltonian without its declared structure: the implicit methods take the dense
/// path on it.
#[derive(Clone, Copy)]
struct Dense<H>(H);

impl<const D: usize, H: Hamiltonian<D>> Hamiltonian<D> for Dense<H> {
    const EXACT_DIVIDED_DIFFERENCES: bool = H::EXACT_DIVIDED_DIFFERENCES;
    fn value(&self, z: &SVector<f64, D>) -> f64 {
        self.0.value(z)
    }
    fn gradient(&self, z: &SVector<f64, D>) -> SVector<f64, D> {
        self.0.gradient(z)
    }
    fn hessian(&self, z: &SVector<f64, D>) -> SMatrix<f64, D, D> {
        self.0.hessian(z)
    }
    fn discrete_gradient(&self, z0: &SVector<f64, D>, z1: &SVector<f64, D>) -> SVector<f64, D> {
        self.0.discrete_gradient(z0, z1)
    }
}

/// A seeded state of a chain of `D / 2` particles: displacements in `[-0.3, 0.3]`, momenta in
/// `[-0.5, 0.5]` (splitmix64).
fn state<const D: usize>(seed: u64) -> SVector<f64, D> {
    let mut s = seed;
    SVector::from_fn(|i, _| {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = s;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        let u = ((x ^ (x >> 31)) >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        if i < D / 2 {
            0.6 * u
        } else {
            u
        }
    })
}

#[test]
fn chain_sources_are_current() {
    use dth_symbolic::sources::{fput_alpha_fixed_ends, toda_fixed_ends};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/chains");
    let regenerate = std::env::var_os("DTH_REGENERATE_CHAINS").is_some();
    for n in [2, 4, 8, 12, 16, 32, 128, 512] {
        for (file, ty, fname, src) in [
            (
                "fput_alpha",
                "FputAlpha",
                "fput_alpha_fixed_ends",
                fput_alpha_fixed_ends(n),
            ),
            ("toda", "Toda", "toda_fixed_ends", toda_fixed_ends(n)),
        ] {
            let want = format!(
                "// Generated: `dth_symbolic::sources::{fname}({n})` written out \
                 (`tests/structured_newton.rs`\n// checks that it is current).\n\
                 dth::hamiltonian! {{ #[derive(Clone, Copy, Debug, Default)] pub struct {ty}{n} = {src} }}\n"
            );
            let path = dir.join(format!("{file}_{n}.rs"));
            if regenerate {
                std::fs::write(&path, &want).unwrap();
            }
            let got = std::fs::read_to_string(&path).unwrap();
            assert!(got == want, "{} is out of date", path.display());
        }
    }
}

/// The generated pattern is exactly the nonzero upper triangle of the symbolic Hessian, and
/// the fused evaluation writes the dense Hessian's entries bit for bit (the same program
/// outputs, pruned).
fn pattern_matches_the_hessian<const D: usize, H: Hamiltonian<D>>(h: &H, z: &SVector<f64, D>) {
    let pattern = H::HESSIAN_PATTERN.expect("generated types declare their pattern");
    // A chain: tridiagonal q-block, identity on p.
    assert_eq!(pattern.len(), 3 * (D / 2) - 1);
    let dense = h.hessian(z);
    let mut values = vec![f64::NAN; pattern.len()];
    h.hessian_nonzeros(z, &mut values);
    let mut covered = SMatrix::<bool, D, D>::from_element(false);
    for (&(i, j), &v) in pattern.iter().zip(&values) {
        assert!(i <= j && j < D, "({i}, {j})");
        assert_eq!(v.to_bits(), dense[(i, j)].to_bits(), "({i}, {j})");
        covered[(i, j)] = true;
        covered[(j, i)] = true;
    }
    for i in 0..D {
        for j in 0..D {
            if !covered[(i, j)] {
                assert_eq!(dense[(i, j)], 0.0, "({i}, {j}) outside the pattern");
            }
        }
    }
}

#[test]
fn generated_pattern_and_nonzeros_match_the_dense_hessian() {
    pattern_matches_the_hessian(&FputAlpha8, &state::<16>(1));
    pattern_matches_the_hessian(&FputAlpha32, &state::<64>(2));
    pattern_matches_the_hessian(&Toda32, &state::<64>(3));
    // The crossover (D = 8): below it the dense path, from it the structured one.
    const {
        assert!(!<FputAlpha2 as Hamiltonian<4>>::STRUCTURED_NEWTON);
        assert!(<FputAlpha8 as Hamiltonian<16>>::STRUCTURED_NEWTON);
        assert!(<FputAlpha32 as Hamiltonian<64>>::STRUCTURED_NEWTON);
        assert!(<FputAlpha512 as Hamiltonian<1024>>::STRUCTURED_NEWTON);
    };
}

/// `steps` steps of `method` on the structured type and of a fresh copy of it on the dense
/// wrapper, from the same state: the largest difference relative to the state's size, and
/// whether both took the same Newton iterations.
fn compare<const D: usize, H, M>(h: &H, method: &M, z0: SVector<f64, D>, dt: f64) -> (f64, bool)
where
    H: Hamiltonian<D> + Copy,
    M: OneStepMethod<D, H> + OneStepMethod<D, Dense<H>> + Clone,
{
    let (mut structured, mut dense) = (method.clone(), method.clone());
    let (mut a, mut b) = (z0, z0);
    let mut worst = 0.0f64;
    for _ in 0..20 {
        a = structured.step(h, &a, dt).expect("structured step");
        b = dense.step(&Dense(*h), &b, dt).expect("dense step");
        worst = worst.max((a - b).amax() / a.amax());
    }
    let same = OneStepMethod::<D, H>::newton_iterations(&structured)
        == OneStepMethod::<D, Dense<H>>::newton_iterations(&dense);
    (worst, same)
}

/// Both paths solve the same Newton systems to the same stopping rule; they differ only in
/// the order of the LU's roundings. Each Newton solve leaves an error of a few `eps` relative
/// (the stopping rule runs to the noise floor) with a condition number of `I - (dt/2) J Hess`
/// near 1 at these steps (`dt |Hess| ~ 0.1`), and 20 steps of a chain whose Lyapunov growth
/// over `t = 2` is below 10 carry it: the paths must agree to `1e-13` relative, a few hundred
/// `eps`.
#[test]
fn structured_and_dense_paths_agree_to_roundoff() {
    let z = state::<64>(11);
    let dt = 0.1;
    let checks = [
        (
            "midpoint fput",
            compare(&FputAlpha32, &ImplicitMidpoint::new(), z, dt),
        ),
        (
            "trapezoidal fput",
            compare(&FputAlpha32, &Trapezoidal::new(), z, dt),
        ),
        (
            "discrete gradient fput",
            compare(&FputAlpha32, &DiscreteGradient::new(), z, dt),
        ),
        (
            "gauss-legendre fput",
            compare(&FputAlpha32, &GaussLegendre2::new(), z, dt),
        ),
        (
            "midpoint toda",
            compare(&Toda32, &ImplicitMidpoint::new(), z, dt),
        ),
        (
            "gauss-legendre toda",
            compare(&Toda32, &GaussLegendre2::new(), z, dt),
        ),
    ];
    for (name, (worst, same_iterations)) in checks {
        eprintln!("{name}: structured and dense differ by {worst:e} relative");
        assert!(worst <= 1e-13, "{name}: paths differ by {worst:e} relative");
        // The stopping rule sees updates that differ in the last bits; an iteration more or
        // less is possible in principle, but not on these steps.
        assert!(same_iterations, "{name}: different Newton iterations");
    }
}

/// The 512-particle chain (`D = 1024`: a dense Newton matrix alone would be 8 MB) steps on a
/// thread with a 2 MB stack with every implicit peer; the discrete gradient keeps its energy
/// to roundoff over the steps (each step's `H(z1) - H(z0)` is zero up to the Newton remainder
/// and the energy difference's own rounding, a few `eps |grad H| |z1 - z0|`).
#[test]
fn the_512_particle_chain_steps_on_a_2mb_stack() {
    let run = || {
        let h = FputAlpha512;
        let z0 = state::<1024>(5);
        let dt = 0.1;
        let mut z = z0;
        let mut midpoint = ImplicitMidpoint::new();
        let mut trapezoidal = Trapezoidal::new();
        let mut gauss = GaussLegendre2::new();
        for _ in 0..5 {
            z = midpoint.step(&h, &z, dt).expect("midpoint step");
            z = trapezoidal.step(&h, &z, dt).expect("trapezoidal step");
            z = gauss.step(&h, &z, dt).expect("gauss-legendre step");
        }
        let mut dg = DiscreteGradient::new();
        let e0 = h.value(&z);
        let mut drift = 0.0f64;
        for _ in 0..20 {
            z = dg.step(&h, &z, dt).expect("discrete gradient step");
            drift = drift.max((h.value(&z) - e0).abs());
        }
        (e0, drift, z.iter().all(|v| v.is_finite()))
    };
    let (e0, drift, finite) = std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(run)
        .expect("spawn")
        .join()
        .expect("the chain steps within 2 MB of stack");
    assert!(finite);
    eprintln!("512-particle chain: discrete-gradient energy drift {drift:e}, H = {e0}");
    // `H` sums 1,537 terms of size up to ~0.2: its evaluation alone rounds at ~1e-13
    // absolute; the conserved energy stays at that level.
    assert!(
        drift <= 1e3 * f64::EPSILON * e0.abs().max(1.0),
        "energy drift {drift:e}, H = {e0}"
    );
}
