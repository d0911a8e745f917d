//! A Hamiltonian read from text (`dth::runtime::Typed`) steps exactly as the `hamiltonian!`
//! type of the same text: DTH and peer integrators give bit-identical trajectories.
//!
//! Why bits and not roundoff: both run the engine's same programs, operation for operation
//! (the macro emits them as Rust, the runtime compiles them with Cranelift, which neither
//! reassociates nor fuses float arithmetic, and calls the same Rust functions for `exp`, `cos`,
//! ...: `dth-runtime`'s crate docs), and the stepper's own arithmetic is the same code for
//! both types. The view only copies values (the Hessian's two triangles are one output).

#![cfg(feature = "runtime")]

use dth::dth::{integrate, set_momentum_of_time, DthOptions};
use dth::methods::{run, ImplicitMidpoint, OneStepMethod, StormerVerlet};
use dth::nalgebra::Const;
use dth::nalgebra::SVector;
use dth::observer::StepRecord;
use dth::runtime::{RuntimeError, RuntimeHamiltonian, Typed};
use dth::{Error, Hamiltonian};

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Kepler { m: f64, k: f64 } = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct DoublePendulum { m1: f64, m2: f64, l1: f64, l2: f64, g: f64 } =
        (m2*l2^2*p1^2 + (m1 + m2)*l1^2*p2^2 - 2*m2*l1*l2*p1*p2*cos(q1 - q2))
            / (2*m2*l1^2*l2^2*(m1 + m2*sin(q1 - q2)^2))
        - (m1 + m2)*g*l1*cos(q1) - m2*g*l2*cos(q2)
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct ForcedDuffing { f: f64, w: f64 } = p1^2/2 + q1^2/2 + q1^4/4 - f*q1*cos(w*t)
}

const KEPLER: &str = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";
const DOUBLE_PENDULUM: &str = "(m2*l2^2*p1^2 + (m1 + m2)*l1^2*p2^2 - 2*m2*l1*l2*p1*p2*cos(q1 - q2))
    / (2*m2*l1^2*l2^2*(m1 + m2*sin(q1 - q2)^2))
    - (m1 + m2)*g*l1*cos(q1) - m2*g*l2*cos(q2)";
const FORCED_DUFFING: &str = "p1^2/2 + q1^2/2 + q1^4/4 - f*q1*cos(w*t)";

fn view<const D: usize, const TD: bool, const SEP: bool>(
    src: &str,
    params: &[(&str, f64)],
) -> Typed<D, TD, SEP> {
    let runtime = RuntimeHamiltonian::new(src, params).unwrap();
    assert_eq!(runtime.backend(), dth::runtime::Backend::Jit);
    Typed::new(runtime).unwrap()
}

fn bits<const D: usize>(zs: &[SVector<f64, D>]) -> Vec<[u64; D]> {
    zs.iter().map(|z| z.map(f64::to_bits).into()).collect()
}

/// DTH midpoints and vertices of `steps` steps from `zbar0`, compared bit for bit.
fn same_dth<const D: usize>(
    a: impl Hamiltonian<Const<D>>,
    b: impl Hamiltonian<Const<D>>,
    zbar0: SVector<f64, D>,
    dtau: f64,
    steps: usize,
) {
    let options = DthOptions::new(dtau).unwrap().with_lambda0(1.0).unwrap();
    let ra = integrate(a, zbar0, options, steps).unwrap();
    let rb = integrate(b, zbar0, options, steps).unwrap();
    assert_eq!(ra.midpoints().len(), steps + 1);
    assert_eq!(bits(ra.midpoints()), bits(rb.midpoints()));
    assert_eq!(bits(ra.vertices()), bits(rb.vertices()));
}

/// The states of 200 steps of a peer method from `z0`.
fn states<const D: usize, H: Hamiltonian<Const<D>>, M: OneStepMethod<Const<D>, H>>(
    mut method: M,
    h: &H,
    z0: SVector<f64, D>,
    dt: f64,
) -> Vec<SVector<f64, D>> {
    let mut zs = Vec::new();
    let mut record = |r: &StepRecord<Const<D>>| zs.push(r.z);
    run(&mut method, h, &z0, 0.0, dt, 200, &mut record).unwrap();
    assert_eq!(zs.len(), 201);
    zs
}

/// A peer method's states, compared bit for bit.
fn same_peer<const D: usize, A, B, M>(method: M, a: &A, b: &B, z0: SVector<f64, D>, dt: f64)
where
    A: Hamiltonian<Const<D>>,
    B: Hamiltonian<Const<D>>,
    M: OneStepMethod<Const<D>, A> + OneStepMethod<Const<D>, B> + Clone,
{
    let za = states(method.clone(), a, z0, dt);
    let zb = states(method, b, z0, dt);
    assert_eq!(bits(&za), bits(&zb));
}

#[test]
fn kepler_steps_bit_identically() {
    let params = [("m", 0.5), ("k", 1.0)];
    let runtime: Typed<4, false, true> = view(KEPLER, &params);
    let generated = Kepler { m: 0.5, k: 1.0 };
    let zbar0 = SVector::<f64, 4>::new(0.5, 0.0, 0.0, 1.2);
    same_dth(generated, runtime.clone(), zbar0, 0.06277, 300);
    same_peer(ImplicitMidpoint::new(), &generated, &runtime, zbar0, 0.05);
    // SEPARABLE declared: the separable-only method runs.
    same_peer(StormerVerlet::new(), &generated, &runtime, zbar0, 0.05);
}

#[test]
fn double_pendulum_steps_bit_identically() {
    // The scene `double-pendulum.toml`: released from rest at (0.5, -0.3).
    let params = [
        ("m1", 1.0),
        ("m2", 1.0),
        ("l1", 1.0),
        ("l2", 1.0),
        ("g", 1.0),
    ];
    let runtime: Typed<4> = view(DOUBLE_PENDULUM, &params);
    let generated = DoublePendulum {
        m1: 1.0,
        m2: 1.0,
        l1: 1.0,
        l2: 1.0,
        g: 1.0,
    };
    let zbar0 = SVector::<f64, 4>::new(0.5, -0.3, 0.0, 0.0);
    same_dth(generated, runtime.clone(), zbar0, 0.05, 200);
    same_peer(ImplicitMidpoint::new(), &generated, &runtime, zbar0, 0.05);
}

#[test]
fn time_dependent_steps_bit_identically_in_the_extended_phase_space() {
    // As the scene `forced-oscillator.toml`, with a quartic term.
    let runtime: Typed<4, true, true> = view(FORCED_DUFFING, &[("f", 0.1), ("w", 1.3)]);
    let generated = ForcedDuffing { f: 0.1, w: 1.3 };
    // (q1, t, p1, p_t) with calH = 0.
    let zbar0 =
        set_momentum_of_time(&generated, SVector::<f64, 4>::new(1.0, 0.0, 0.0, 0.0)).unwrap();
    assert_eq!(
        zbar0[3].to_bits(),
        set_momentum_of_time(&runtime, zbar0).unwrap()[3].to_bits()
    );
    same_dth(generated, runtime, zbar0, 0.05, 200);
}

#[test]
fn a_view_that_contradicts_the_text_is_a_typed_error() {
    let h = || RuntimeHamiltonian::new(KEPLER, &[("m", 0.5), ("k", 1.0)]).unwrap();
    assert!(matches!(
        Typed::<6>::new(h()),
        Err(RuntimeError::DimensionMismatch {
            expected: 6,
            found: 4
        })
    ));
    assert!(matches!(
        Typed::<4, true>::new(h()),
        Err(RuntimeError::FlagMismatch {
            flag: "TIME_DEPENDENT",
            declared: true,
            derived: false
        })
    ));
    let coupled = RuntimeHamiltonian::new("p1^2/2 + q1^2*p1^2", &[]).unwrap();
    assert!(matches!(
        Typed::<2, false, true>::new(coupled),
        Err(RuntimeError::FlagMismatch {
            flag: "SEPARABLE",
            ..
        })
    ));
    let free = RuntimeHamiltonian::new("p1^2/2", &[]).unwrap();
    assert!(matches!(
        Typed::<2>::new(free),
        Err(RuntimeError::FlagMismatch {
            flag: "PSI_IDENTICALLY_ZERO",
            ..
        })
    ));
}

/// A non-finite value reaches the stepper as it is, and the stepper's typed error reports it:
/// at `q1 = 0`, `H = p1^2/2 + sqrt(q1)` is finite but its gradient is not.
#[test]
fn a_non_finite_value_is_the_steppers_typed_error() {
    let h: Typed<2> = view("p1^2/2 + sqrt(q1)", &[]);
    let zbar0 = SVector::<f64, 2>::new(0.0, 1.0);
    assert!(h.value(&zbar0).is_finite());
    assert!(!h.gradient(&zbar0)[0].is_finite());
    let options = DthOptions::new(0.05).unwrap().with_lambda0(1.0).unwrap();
    let err = integrate(h, zbar0, options, 10).unwrap_err();
    assert!(
        matches!(err.error, Error::NonFinite { step: 0, .. }),
        "{:?}",
        err.error
    );
}
