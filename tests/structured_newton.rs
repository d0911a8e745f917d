//! Structured Newton on chains written out through `hamiltonian!` (`tests/chains/`): the
//! generated Hessian pattern and fused nonzero evaluation against the dense Hessian, the
//! structured and dense Newton paths of every implicit peer on the same steps, and the FPUT
//! chain of 512 particles (`D = 1024`), which this test binary compiles in whatever profile it
//! is built (the dev profile under `cargo test`), stepped on a thread with a 2 MB stack. The
//! same for DTH (joint and nested Newton, composition, robust mode): structured and dense steps
//! agree to roundoff, and the 512-particle chain keeps its energy at the midpoints.
//!
//! The chain sources are generated text; `chain_sources_are_current` checks them against
//! `dth_symbolic::sources` (regenerate with `DTH_REGENERATE_CHAINS=1 cargo test --test
//! structured_newton chain_sources_are_current`).

use dth::dth::{Dth, DthOptions, Solver};
use dth::methods::{
    DiscreteGradient, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Trapezoidal,
};
use dth::nalgebra::Const;
use dth::nalgebra::{SMatrix, SVector};
use dth::Flags;
use dth::{Derivatives, Hamiltonian};

include!("chains/fput_alpha_2.rs");
include!("chains/fput_alpha_4.rs");
include!("chains/fput_alpha_8.rs");
include!("chains/fput_alpha_32.rs");
include!("chains/toda_32.rs");
include!("chains/fput_alpha_512.rs");

/// The same Hamiltonian without its declared structure: the implicit methods and DTH take the
/// dense path on it (every evaluation forwarded, so the two paths differ only in their linear
/// algebra and in which generated programs evaluate a point).
#[derive(Clone, Copy)]
struct Dense<H>(H);

impl<const D: usize, H: Hamiltonian<Const<D>>> Hamiltonian<Const<D>> for Dense<H> {
    fn dim(&self) -> Const<D> {
        Const
    }
    fn flags(&self) -> Flags {
        Flags::default().with_exact_divided_differences(self.0.flags().exact_divided_differences)
    }
    fn value(&self, z: &SVector<f64, D>) -> f64 {
        self.0.value(z)
    }
    fn gradient_into(&self, z: &SVector<f64, D>, out: &mut SVector<f64, D>) {
        self.0.gradient_into(z, out)
    }
    fn hessian_into(&self, z: &SVector<f64, D>, out: &mut SMatrix<f64, D, D>) {
        self.0.hessian_into(z, out)
    }
    fn psi(&self, z: &SVector<f64, D>) -> f64 {
        self.0.psi(z)
    }
    fn derivatives_into(&self, z: &SVector<f64, D>, out: &mut Derivatives<Const<D>>) {
        self.0.derivatives_into(z, out)
    }
    fn discrete_gradient_into(
        &self,
        z0: &SVector<f64, D>,
        z1: &SVector<f64, D>,
        out: &mut SVector<f64, D>,
    ) {
        self.0.discrete_gradient_into(z0, z1, out)
    }
    fn discrete_gradient_defect_into(
        &self,
        z0: &SVector<f64, D>,
        z1: &SVector<f64, D>,
        gbar: &SVector<f64, D>,
        out: &mut SVector<f64, D>,
    ) {
        self.0.discrete_gradient_defect_into(z0, z1, gbar, out)
    }
    fn energy_difference(&self, z0: &SVector<f64, D>, z1: &SVector<f64, D>) -> f64 {
        self.0.energy_difference(z0, z1)
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
fn pattern_matches_the_hessian<const D: usize, H: Hamiltonian<Const<D>>>(
    h: &H,
    z: &SVector<f64, D>,
) {
    let pattern = h
        .hessian_pattern()
        .expect("generated types declare their pattern");
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
    // The crossover of a separable type (D = 16): below it the dense path, from it the
    // structured one.
    {
        assert!(!Hamiltonian::<Const<4>>::flags(&FputAlpha2).structured_newton);
        assert!(!Hamiltonian::<Const<8>>::flags(&FputAlpha4).structured_newton);
        assert!(Hamiltonian::<Const<16>>::flags(&FputAlpha8).structured_newton);
        assert!(Hamiltonian::<Const<64>>::flags(&FputAlpha32).structured_newton);
        assert!(Hamiltonian::<Const<1024>>::flags(&FputAlpha512).structured_newton);
    };
}

/// `steps` steps of `method` on the structured type and of a fresh copy of it on the dense
/// wrapper, from the same state: the largest difference relative to the state's size, and
/// whether both took the same Newton iterations.
fn compare<const D: usize, H, M>(h: &H, method: &M, z0: SVector<f64, D>, dt: f64) -> (f64, bool)
where
    H: Hamiltonian<Const<D>> + Copy,
    M: OneStepMethod<Const<D>, H> + OneStepMethod<Const<D>, Dense<H>> + Clone,
{
    let (mut structured, mut dense) = (method.clone(), method.clone());
    let (mut a, mut b) = (z0, z0);
    let mut worst = 0.0f64;
    for _ in 0..20 {
        a = structured.step(h, &a, dt).expect("structured step");
        b = dense.step(&Dense(*h), &b, dt).expect("dense step");
        worst = worst.max((a - b).amax() / a.amax());
    }
    let same = OneStepMethod::<Const<D>, H>::newton_iterations(&structured)
        == OneStepMethod::<Const<D>, Dense<H>>::newton_iterations(&dense);
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

/// `steps` DTH steps on the structured type and on the dense wrapper from the same midpoint:
/// the largest difference of the midpoints relative to their size and of the multipliers
/// relative to lambda, whether both took the same Newton iterations, and the largest
/// energy error at the structured run's midpoints relative to the size of the terms of `H`.
fn compare_dth<const D: usize, H>(
    h: H,
    z0: SVector<f64, D>,
    options: DthOptions,
    steps: usize,
) -> (f64, f64, bool, f64)
where
    H: Hamiltonian<Const<D>> + Copy,
{
    let mut a = Dth::new(h, z0, options).expect("structured start");
    let mut b = Dth::new(Dense(h), z0, options).expect("dense start");
    let e0 = h.value(&z0);
    // The size of the terms of `H(z0)`, whose roundings the computed energy carries.
    let scale = e0.abs().max(z0.component_mul(&h.gradient(&z0)).abs().sum());
    let (mut dz, mut dl, mut same, mut energy) = (0.0f64, 0.0f64, true, 0.0f64);
    for _ in 0..steps {
        let (ra, rb) = (
            a.step().expect("structured DTH step"),
            b.step().expect("dense DTH step"),
        );
        same &= ra.iterations == rb.iterations && ra.factorizations == rb.factorizations;
        dz = dz.max((a.zbar() - b.zbar()).amax() / a.zbar().amax());
        dl = dl.max((a.lambda() - b.lambda()).abs() / a.lambda());
        energy = energy.max((h.value(a.zbar()) - e0).abs() / scale);
    }
    (dz, dl, same, energy)
}

/// DTH on both paths, joint and nested Newton, order 2 and a composed order 4 (five sub-steps,
/// two of them backwards), FPUT and Toda: the same step equations solved to the same stopping
/// rule, differing only in the LU's rounding order and in the evaluation programs (the fused
/// `derivatives` against `value`, `gradient`, `psi`), each a few `eps` relative per step.
/// `lambda` is solved cancellation-free to about one `eps`, `zbar` to a few `eps |zbar|`;
/// 20 steps of `dtau = 0.1` (`t ~ 2` to `10` with composition) of chains whose Lyapunov growth
/// there is below 10 carry that to at most a few hundred `eps`: `1e-13` relative. The energy
/// at the midpoints is at its evaluation roundoff: a few `eps` of the size of its terms (each
/// midpoint is projected onto `H = H(zbar_0)`).
#[test]
fn dth_structured_and_dense_paths_agree_to_roundoff() {
    let z = state::<64>(17);
    let base = DthOptions::new(0.1).expect("dtau");
    for (name, options) in [
        ("joint", base),
        ("nested", base.with_solver(Solver::Nested)),
        ("joint order 4", base.with_order(4).expect("order")),
        (
            "nested order 4",
            base.with_solver(Solver::Nested)
                .with_order(4)
                .expect("order"),
        ),
    ] {
        for (system, (dz, dl, same, energy)) in [
            ("fput", compare_dth(FputAlpha32, z, options, 20)),
            ("toda", compare_dth(Toda32, z, options, 20)),
        ] {
            eprintln!(
                "DTH {name} {system}: zbar differ by {dz:e}, lambda by {dl:e} relative; \
                 energy error {energy:e}"
            );
            assert!(dz <= 1e-13, "{name} {system}: zbar differ by {dz:e}");
            assert!(dl <= 1e-13, "{name} {system}: lambda differ by {dl:e}");
            assert!(same, "{name} {system}: different Newton iterations");
            assert!(
                energy <= 8.0 * f64::EPSILON,
                "{name} {system}: energy error {energy:e} of the terms' size"
            );
        }
    }
}

/// Steps of [`dth_keeps_the_energy_of_the_512_particle_chain_on_a_2mb_stack`]: the `10^4` the
/// guarantee is stated for (`t ~ 1000`). In the dev profile (opt-level 1) one structured DTH step
/// at `D = 1024` costs about 0.4 ms on an idle core, so the test takes about 4 s; the release
/// bench `step_vs_size` repeats the run with `DTH_LONG_RUN=1` (`dth_long_run`).
const CHAIN_STEPS: usize = 10_000;

/// DTH, joint Newton, cancellation-free, on the FPUT chain of 512 particles (`D = 1024`) on a
/// thread with a 2 MB stack (the dense path alone would need 16 MB: the Hessian and the LU):
/// energy at every midpoint at roundoff. `H` sums 1,537 terms; each midpoint is checked and
/// projected against `H(zbar_0)`, so the energy error stays at the evaluation roundoff, a few
/// `eps` of the size of the terms of `H`, without drift.
#[test]
fn dth_keeps_the_energy_of_the_512_particle_chain_on_a_2mb_stack() {
    let run = || {
        let h = FputAlpha512;
        let z0 = state::<1024>(5);
        let options = DthOptions::new(0.1).expect("dtau");
        let mut dth = Dth::new(h, z0, options).expect("start");
        let e0 = h.value(&z0);
        let scale = e0.abs().max(z0.component_mul(&h.gradient(&z0)).abs().sum());
        let mut drift = 0.0f64;
        for _ in 0..CHAIN_STEPS {
            dth.step().expect("DTH step");
            drift = drift.max((h.value(dth.zbar()) - e0).abs());
        }
        (scale, drift, dth.tbar())
    };
    let (scale, drift, t) = std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(run)
        .expect("spawn")
        .join()
        .expect("DTH steps the 512-particle chain within 2 MB of stack");
    eprintln!("512-particle chain, DTH to t = {t}: energy error {drift:e}, terms {scale}");
    assert!(t > 0.05 * CHAIN_STEPS as f64, "t = {t}");
    assert!(
        drift <= 16.0 * f64::EPSILON * scale,
        "energy error {drift:e}, terms of H {scale}"
    );
}

dth::hamiltonian! {
    /// Four uncoupled Kepler problems of the thesis (`m = 1/2`, `k = 1`; `D = 16`, the
    /// separable types' crossover: structured Newton), each of eccentricity 0.9 from the start
    /// below, where `Psi` changes sign along the orbit.
    #[derive(Clone, Copy, Debug, Default)]
    pub struct FourKeplers = p1^2 + p2^2 + p3^2 + p4^2 + p5^2 + p6^2 + p7^2 + p8^2
        - (q1^2 + q2^2)^(-1/2) - (q3^2 + q4^2)^(-1/2) - (q5^2 + q6^2)^(-1/2) - (q7^2 + q8^2)^(-1/2)
}

/// The robust mode on both paths: four Kepler problems of eccentricity 0.9 (two copies of a
/// pair whose second is rotated by a right angle, so all four `Psi` agree and their sum changes
/// sign as each alone does)
/// break DTH down near every pericentre; the fallback steps (the discrete-gradient peer, itself
/// structured here) carry the run through, at order 2 and composed at order 4. Both paths take
/// the same decisions (the same steps fall back), and the trajectories agree to the roundoff
/// that near-pericentre steps amplify: each step's `eps`-level difference grows with every
/// pericentre passage (measured: about 10x per orbit, from 4e-16 at the first passage): over
/// these steps (two orbits, two passages) `1e-11` relative, a factor ~10 over the `9e-13`
/// measured at order 2.
#[test]
fn robust_mode_and_composition_work_on_the_structured_path() {
    assert!(Hamiltonian::<Const<16>>::flags(&FourKeplers).structured_newton);
    let v = 1.9f64.sqrt();
    let z0 = SVector::<f64, 16>::from_column_slice(&[
        0.5, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 0.5, 0.0, v, -v, 0.0, 0.0, v, -v, 0.0,
    ]);
    let e0 = FourKeplers.value(&z0);
    let base = DthOptions::new(0.0157).expect("dtau").with_robust(true);
    for (name, options, steps) in [
        ("order 2", base, 240),
        ("order 4", base.with_order(4).expect("order"), 60),
    ] {
        let mut a = Dth::new(FourKeplers, z0, options).expect("structured start");
        let mut b = Dth::new(Dense(FourKeplers), z0, options).expect("dense start");
        let (mut fallbacks, mut dz, mut energy) = (0, 0.0f64, 0.0f64);
        for _ in 0..steps {
            let ra = a.step().expect("structured robust step");
            let rb = b.step().expect("dense robust step");
            assert_eq!(ra.kind, rb.kind, "{name}: the paths took different steps");
            fallbacks += usize::from(ra.kind == dth::observer::StepKind::Fallback);
            dz = dz.max((a.zbar() - b.zbar()).amax() / a.zbar().amax());
            energy = energy.max((FourKeplers.value(a.zbar()) - e0).abs());
        }
        eprintln!("robust {name}: {fallbacks} fallback steps, paths differ by {dz:e}, energy error {energy:e}");
        assert!(fallbacks > 0, "{name}: no breakdown was crossed");
        assert!(dz <= 1e-11, "{name}: paths differ by {dz:e}");
        // Energy at every midpoint, fallback steps included (projected onto H = E), to a few
        // eps of the size of H's terms near pericentre (1 / r_min = 20).
        assert!(energy <= 1e-13, "{name}: energy error {energy:e}");
    }
}
