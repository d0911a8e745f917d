//! The discrete-gradient defect `t = g(z0) + g(z1) - 2 gbar(z0, z1)` that `hamiltonian!`
//! generates (`dth_symbolic::defect`): bit-for-bit the engine's program for every kernel,
//! equal to the hand-written exact defects of `dth::systems::{Kepler, Pendulum}` to a few eps
//! of their own size (relative) down to steps of 1e-9, and the DTH stepper on a generated Kepler: the
//! cancellation-free residual is chosen by `EnergyResidual::Auto`, and `lambda` at
//! `dtau = 1e-5` equals the hand-written Kepler's to a few eps (the plain residual's noise is
//! `eps / dtau^2` relative, about 1e-6 here).

use dth::dth::{Dth, DthOptions, EnergyResidual};
use dth::nalgebra::Const;
use dth::nalgebra::{SVector, Vector2, Vector4};
use dth::systems::{Kepler, Pendulum};
use dth::Hamiltonian;
use dth_symbolic::{compile, Method};

mod everything;
use everything::{Everything, EVERYTHING};

const EPS: f64 = f64::EPSILON;

dth::hamiltonian! {
    /// `H = |p|^2 / (2 m) - k / |q|`.
    #[derive(Clone, Copy, Debug)]
    pub struct KeplerMk { pub m: f64, pub k: f64 } = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)
}

dth::hamiltonian! {
    /// The thesis's Kepler problem.
    #[derive(Clone, Copy, Debug)]
    pub struct KeplerThesis = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)
}

dth::hamiltonian! {
    /// `H = p^2 / (2 m l^2) - m g l cos q`.
    #[derive(Clone, Copy, Debug)]
    pub struct PendulumMlg { pub m: f64, pub l: f64, pub g: f64 } = p1^2/(2*m*l^2) - m*g*l*cos(q1)
}

/// The generated kernels are `Kernel::build`'s formulas written as code (the engine runs the
/// same formulas on `f64`) and the generated code performs the engine's program in order: equal bit for bit, at steps in the series branches, in the
/// closed-form branches, and at `z0 = z1`.
#[test]
fn generated_defect_performs_the_engine_program_bit_for_bit() {
    let (a, b) = (0.8, 0.3);
    let h = Everything { a, b };
    let program = compile(EVERYTHING, &["a", "b"])
        .unwrap()
        .program(Method::DiscreteGradientDefect);
    let z0 = [0.6, -0.9, 0.4, 1.1];
    for z1 in [
        [0.61, -0.85, 0.38, 1.2],
        [0.6 + 1e-12, -0.9, 0.4, 1.1],
        z0,
        [-0.3, 1.4, 0.9, -0.2],
        [2.9, -3.5, 3.1, -2.4],
    ] {
        let e = program.eval_pair(&z0, &z1, &[a, b]).unwrap();
        let (v0, v1) = (SVector::from(z0), SVector::from(z1));
        let gbar = h.discrete_gradient(&v0, &v1);
        let t = h.discrete_gradient_defect(&v0, &v1, &gbar);
        for i in 0..4 {
            assert_eq!(
                t[i].to_bits(),
                e.discrete_gradient_defect[i].to_bits(),
                "t {i} at {z1:?}: {} vs {}",
                t[i],
                e.discrete_gradient_defect[i]
            );
        }
    }
    assert!(h.flags().exact_divided_differences);
}

/// Points on and off the thesis orbit, and step directions.
const KEPLER_POINTS: [[f64; 4]; 3] = [
    [0.5, 0.0, 0.0, 1.2],
    [-0.3, 0.4, 0.7, -0.2],
    [1.5, -1.2, -0.1, 0.3],
];
const KEPLER_DIRS: [[f64; 4]; 2] = [[0.7, -0.4, 0.2, 0.9], [-0.2, 0.9, 0.5, -0.3]];

/// Kepler: the generated defect (symbolic recursion through `(.)^(-1/2)`, a sum of squares
/// and a product) against the hand-written closed form, both cancellation-free: they agree to
/// a few eps of `|t|` however small the step, while each is `O(s^2)`.
#[test]
fn kepler_defect_matches_the_hand_written_one() {
    let (hand, gen, thesis) = (
        Kepler { mass: 0.7, k: 1.3 },
        KeplerMk { m: 0.7, k: 1.3 },
        KeplerThesis,
    );
    let mut worst = 0.0f64;
    for z0 in KEPLER_POINTS.map(Vector4::from) {
        for dir in KEPLER_DIRS.map(Vector4::from) {
            for s in [1e-1, 1e-3, 1e-5, 1e-7, 1e-9] {
                let z1 = z0 + dir * s;
                for (t_hand, t_gen) in [
                    (
                        hand.discrete_gradient_defect(&z0, &z1, &hand.discrete_gradient(&z0, &z1)),
                        gen.discrete_gradient_defect(&z0, &z1, &gen.discrete_gradient(&z0, &z1)),
                    ),
                    (
                        Kepler::thesis().discrete_gradient_defect(
                            &z0,
                            &z1,
                            &Kepler::thesis().discrete_gradient(&z0, &z1),
                        ),
                        thesis.discrete_gradient_defect(
                            &z0,
                            &z1,
                            &thesis.discrete_gradient(&z0, &z1),
                        ),
                    ),
                ] {
                    // Both are accurate to a few dozen roundings of the O(s^2) terms they sum
                    // (the generated one differences f' and the gradients of subexpressions by
                    // exact rules too, so no term carries eps |g| undivided by s).
                    let size = t_hand.amax();
                    let scale = size;
                    let err = (t_hand - t_gen).amax();
                    assert!(size > 0.0 && size < 100.0 * s * s, "{t_hand} at s = {s}");
                    assert!(
                        err <= 32.0 * EPS * scale,
                        "at {z0} step {s}: {t_gen} vs {t_hand}: {:.1} eps",
                        err / (EPS * scale)
                    );
                    worst = worst.max(err / (EPS * scale));
                }
            }
        }
    }
    eprintln!("Kepler: generated vs hand-written defect, worst {worst:.2} eps of |t|");
}

/// The pendulum: `-m g l cos q` through the `cos` rule against the hand-written
/// `2 m g l sin(qm) (cos x - sinc x)`.
#[test]
fn pendulum_defect_matches_the_hand_written_one() {
    let (m, l, g) = (1.3, 0.7, 9.8);
    let hand = Pendulum {
        mass: m,
        length: l,
        gravity: g,
    };
    let gen = PendulumMlg { m, l, g };
    let mut worst = 0.0f64;
    for z0 in [[0.4, -1.1], [2.5, 0.3], [-1.0, 2.0]].map(Vector2::from) {
        for s in [1.5, 3e-1, 1e-2, 1e-4, 1e-6, 1e-8] {
            let z1 = z0 + Vector2::new(1.0, 0.5) * s;
            let t_hand = hand.discrete_gradient_defect(&z0, &z1, &hand.discrete_gradient(&z0, &z1));
            let t_gen = gen.discrete_gradient_defect(&z0, &z1, &gen.discrete_gradient(&z0, &z1));
            let size = t_hand.amax();
            // The same formula up to the order of the products: a few roundings.
            let err = (t_hand - t_gen).amax();
            assert!(size > 0.0, "at {z0} step {s}");
            assert!(
                err <= 16.0 * EPS * size,
                "at {z0} step {s}: {t_gen} vs {t_hand}"
            );
            worst = worst.max(err / (EPS * size));
        }
    }
    eprintln!("pendulum: generated vs hand-written defect, worst {worst:.2} eps of |t|");
}

/// Runs `steps` DTH steps at `dtau` from `zbar0`: whether the residual is cancellation-free,
/// and the multipliers.
fn lambdas<H: Hamiltonian<Const<D>>, const D: usize>(
    h: H,
    zbar0: SVector<f64, D>,
    dtau: f64,
    residual: EnergyResidual,
    steps: usize,
) -> (bool, Vec<f64>) {
    let options = DthOptions::new(dtau)
        .unwrap()
        .with_energy_residual(residual);
    let mut dth = Dth::new(h, zbar0, options).unwrap();
    let cancellation_free = dth.cancellation_free();
    let mut out = Vec::new();
    for _ in 0..steps {
        dth.step().unwrap();
        out.push(dth.lambda());
    }
    (cancellation_free, out)
}

/// The largest relative difference of two runs' multipliers.
fn worst(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs())
        .fold(0.0, f64::max)
}

/// End to end: with `EnergyResidual::Auto` the generated Kepler now solves its energy equation
/// in the cancellation-free form, and its `lambda` equals the hand-written Kepler's to a few
/// eps at every `dtau` from the thesis's 0.06277 down to 1e-6, where the plain residual
/// leaves noise of order `eps / dtau^2` (about 1e-6 relative at 1e-5).
#[test]
fn stepper_on_a_generated_kepler_uses_the_cancellation_free_residual() {
    let z = Vector4::new(0.5, 0.0, 0.0, 1.2);
    for dtau in [0.06277, 1e-3, 1e-5, 1e-6] {
        // The two runs round differently, so their trajectories drift apart by roundoff and
        // lambda follows them: at dtau = 0.06277 (1.5 degrees of orbit per step) the lambdas
        // drift apart by ~0.5 eps per step (9 eps after 20 steps, measured). Compare the
        // first three steps there; where the orbit barely moves in 20 steps, all 20.
        let steps = if dtau > 1e-3 { 3 } else { 20 };
        let (cf_gen, gen) = lambdas(KeplerThesis, z, dtau, EnergyResidual::Auto, steps);
        let (cf_hand, hand) = lambdas(Kepler::thesis(), z, dtau, EnergyResidual::Auto, steps);
        assert!(cf_gen && cf_hand);
        let (_, plain) = lambdas(KeplerThesis, z, dtau, EnergyResidual::Plain, steps);
        // Both solve the same equations, each to a few eps of lambda (the two Hamiltonians
        // round differently, so their difference is the sum of both errors).
        let w = worst(&gen, &hand);
        eprintln!(
            "Kepler dtau = {dtau:e}: generated vs hand-written lambda {:.2} eps (plain residual: {:.2e})",
            w / EPS,
            worst(&plain, &hand)
        );
        assert!(w <= 8.0 * EPS, "dtau {dtau}: {:.1} eps", w / EPS);
    }
}

/// The same for the pendulum (libration), through the `cos` rule.
#[test]
fn stepper_on_a_generated_pendulum_matches_the_hand_written_one() {
    let (m, l, g) = (1.3, 0.7, 9.8);
    let hand = Pendulum {
        mass: m,
        length: l,
        gravity: g,
    };
    let z = Vector2::new(0.9, 0.4);
    for dtau in [0.05, 1e-4, 1e-6] {
        let (cf_gen, gen) = lambdas(PendulumMlg { m, l, g }, z, dtau, EnergyResidual::Auto, 20);
        let (_, hand) = lambdas(hand, z, dtau, EnergyResidual::Auto, 20);
        assert!(cf_gen);
        let w = worst(&gen, &hand);
        eprintln!(
            "pendulum dtau = {dtau:e}: generated vs hand-written lambda {:.2} eps",
            w / EPS
        );
        assert!(w <= 8.0 * EPS, "dtau {dtau}: {:.1} eps", w / EPS);
    }
}

dth::hamiltonian! {
    /// A forced oscillator: time-dependent, `z = (q1, t, p1, p_t)`.
    #[derive(Clone, Copy, Debug)]
    pub struct Forced { pub a: f64, pub w: f64 } = p1^2/2 + q1^2/2 - a*q1*cos(w*t)
}

/// A generated time-dependent Hamiltonian (extended phase space) takes the cancellation-free
/// path too: at `dtau = 1e-5`, where the plain residual's noise in `lambda` is ~1e-6, the
/// steps keep `calH(zbar_k) = calH(zbar_0)` and `lambda` agrees with the plain-residual run to
/// that noise only, while two cancellation-free runs from nearby energies agree smoothly.
#[test]
fn time_dependent_generated_hamiltonian_uses_the_cancellation_free_residual() {
    let h = Forced { a: 0.3, w: 1.7 };
    // z = (q1, t, p1, p_t) with calH(zbar_0) = 0: p_t = -H.
    let (q, t, p) = (0.4f64, 0.2f64, -0.3f64);
    let pt = -(p * p / 2.0 + q * q / 2.0 - 0.3 * q * (1.7 * t).cos());
    let z = Vector4::new(q, t, p, pt);
    let (cf, cf_lambdas) = lambdas(h, z, 1e-5, EnergyResidual::Auto, 20);
    assert!(cf);
    let (_, plain) = lambdas(h, z, 1e-5, EnergyResidual::Plain, 20);
    // Both converge to the same lambdas up to the plain residual's noise (eps / dtau^2 ~ 2e-6
    // relative): a gross error in the defect would show as an O(1) relative difference.
    let w = worst(&cf_lambdas, &plain);
    eprintln!("forced oscillator dtau = 1e-5: cancellation-free vs plain lambda {w:.2e}");
    assert!(w <= 1e-4, "{w}");
    // Smoothness: the cancellation-free lambdas change by O(dtau) per step, no noise: second
    // differences are O(dtau^2) relative (~1e-10), far below the plain residual's 1e-6.
    let second = |l: &[f64]| {
        l.windows(3)
            .map(|x| (x[0] - 2.0 * x[1] + x[2]).abs() / x[1])
            .fold(0.0, f64::max)
    };
    assert!(second(&cf_lambdas) <= 1e-9, "{:e}", second(&cf_lambdas));
    // For contrast, the plain residual's lambdas are noisy at this step.
    assert!(second(&plain) > 1e-8, "{:e}", second(&plain));
}
