//! A Hamiltonian read from text runs as `Hamiltonian<Dyn>`, its dimension known only when the
//! text is read: DTH (joint and nested Newton), the implicit midpoint rule and the 2-stage
//! Gauss-Legendre method step it as they step the `hamiltonian!` type of the same text with
//! `Const<D>`; a time-dependent text runs in the extended phase space; the construction errors
//! are typed.
//!
//! Why the same states: both run the engine's same programs operation for operation (see
//! `typed_matches_macro.rs`), and the stepper's arithmetic is the same generic code for
//! `Const<D>` and `Dyn`; only the storage differs (heap for `Dyn`, the stack for `Const`).

#![cfg(feature = "runtime")]

// The core's counting allocator: counts the calling thread's allocations inside `count`.
#[path = "../dth-core/tests/alloc_counter/mod.rs"]
mod alloc_counter;

use dth::dth::{lift, segment_from_vertex, set_momentum_of_time, Dth, DthOptions, Solver};
use dth::methods::{
    run, DiscreteGradient, GaussLegendre2, ImplicitMidpoint, OneStepMethod, Rk4, StormerVerlet,
    Trapezoidal,
};
use dth::nalgebra::{Const, DMatrix, DVector, Dyn, SVector};
use dth::observer::{Recorder, StepKind, StepRecord};
use dth::runtime::RuntimeHamiltonian;
use dth::{Error, Hamiltonian};

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct Kepler { m: f64, k: f64 } = (p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)
}

dth::hamiltonian! {
    #[derive(Clone, Copy)]
    struct ForcedDuffing { f: f64, w: f64 } = p1^2/2 + q1^2/2 + q1^4/4 - f*q1*cos(w*t)
}

const KEPLER: &str = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)";
const FORCED_DUFFING: &str = "p1^2/2 + q1^2/2 + q1^4/4 - f*q1*cos(w*t)";
const STEPS: usize = 300;

fn kepler_text() -> RuntimeHamiltonian {
    let h = RuntimeHamiltonian::new(KEPLER, &[("m", 0.5), ("k", 1.0)]).unwrap();
    assert_eq!(h.backend(), dth::runtime::Backend::Jit);
    h
}

/// The largest difference between a fixed-size and a dynamic trajectory, relative to the
/// states' size.
fn worst<const D: usize>(a: &[SVector<f64, D>], b: &[DVector<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            assert_eq!(y.len(), D);
            (x - y).amax() / x.amax()
        })
        .fold(0.0, f64::max)
}

/// Roundoff of 300 steps on the thesis's Kepler orbit: `Const` and `Dyn` run the same
/// operations, but nalgebra's kernels for the two storages may sum in another order (a dot
/// product, a matrix-vector product), an `eps` at a time; on this non-chaotic orbit such
/// differences grow at most linearly in the steps (and by the conditioning of each Newton
/// solve, ~10 here): `eps * STEPS * 10 ~ 7e-13`, with a margin of 10.
const ROUNDOFF: f64 = 1e-11;

#[test]
fn dyn_kepler_from_text_steps_as_the_macros_fixed_size_kepler() {
    let fixed = Kepler { m: 0.5, k: 1.0 };
    let z0 = SVector::<f64, 4>::new(0.5, 0.0, 0.0, 1.2);
    let z0_dyn = DVector::from_column_slice(z0.as_slice());
    for solver in [Solver::Joint, Solver::Nested] {
        let options = DthOptions::new(0.06277).unwrap().with_solver(solver);
        let mut a = Dth::new(fixed, z0, options).unwrap();
        let mut b = Dth::new(kepler_text(), z0_dyn.clone(), options).unwrap();
        let ta = a.trajectory(STEPS).unwrap();
        let tb = b.trajectory(STEPS).unwrap();
        let w = worst(ta.midpoints(), tb.midpoints());
        assert!(w <= ROUNDOFF, "{solver:?}: midpoints differ by {w:e}");
        let w = worst(ta.vertices(), tb.vertices());
        assert!(w <= ROUNDOFF, "{solver:?}: vertices differ by {w:e}");
        let lambdas = ta.lambdas().iter().zip(tb.lambdas());
        assert!(lambdas.map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) <= ROUNDOFF);
        // The energy at the midpoints is exact to roundoff for the runtime Hamiltonian too.
        let e0 = Hamiltonian::value(b.hamiltonian(), &z0_dyn);
        for z in tb.midpoints() {
            assert!((Hamiltonian::value(b.hamiltonian(), z) - e0).abs() <= 4.0 * f64::EPSILON);
        }
    }
    // Two peers: the one-stage midpoint rule and the two-stage Gauss-Legendre method.
    fn peer<M>(mut fixed_method: M, mut dyn_method: M) -> f64
    where
        M: OneStepMethod<Const<4>, Kepler> + OneStepMethod<Dyn, RuntimeHamiltonian>,
    {
        let z0 = SVector::<f64, 4>::new(0.5, 0.0, 0.0, 1.2);
        let (mut ra, mut rb) = (Recorder::new(), Recorder::new());
        let fixed = Kepler { m: 0.5, k: 1.0 };
        run(&mut fixed_method, &fixed, &z0, 0.0, 0.15, STEPS, &mut ra).unwrap();
        let z0 = DVector::from_column_slice(z0.as_slice());
        run(
            &mut dyn_method,
            &kepler_text(),
            &z0,
            0.0,
            0.15,
            STEPS,
            &mut rb,
        )
        .unwrap();
        worst(&ra.z, &rb.z)
    }
    let w = peer(ImplicitMidpoint::new(), ImplicitMidpoint::new());
    assert!(w <= ROUNDOFF, "midpoint: {w:e}");
    let w = peer(GaussLegendre2::new(), GaussLegendre2::new());
    assert!(w <= ROUNDOFF, "gauss-legendre: {w:e}");
}

#[test]
fn time_dependent_text_runs_in_the_extended_phase_space() {
    let (f, w) = (0.3, 1.2);
    let text = RuntimeHamiltonian::new(FORCED_DUFFING, &[("f", f), ("w", w)]).unwrap();
    // (q1, t, p1, p_t): D = 4 from the text, the flag from `t`.
    assert_eq!(Hamiltonian::dim(&text), Dyn(4));
    assert!(Hamiltonian::flags(&text).time_dependent);
    let fixed = ForcedDuffing { f, w };
    let x0 = SVector::<f64, 2>::new(0.8, 0.0);
    let z0 = set_momentum_of_time(&fixed, lift(&x0, 0.25)).unwrap();
    let z0_dyn = set_momentum_of_time(&text, DVector::from_column_slice(z0.as_slice())).unwrap();
    assert_eq!(z0_dyn.as_slice(), z0.as_slice());
    let options = DthOptions::new(0.05).unwrap();
    let mut a = Dth::new(fixed, z0, options).unwrap();
    let mut b = Dth::new(text, z0_dyn, options).unwrap();
    // Time starts at the t coordinate; calH = p_t + H stays 0 at the midpoints (Theorem 1).
    assert_eq!(b.tbar(), 0.25);
    let tb = b.trajectory(STEPS).unwrap();
    let ta = a.trajectory(STEPS).unwrap();
    for z in tb.midpoints() {
        // The terms of calH are O(1): a few eps.
        assert!(Hamiltonian::value(b.hamiltonian(), z).abs() <= 8.0 * f64::EPSILON);
    }
    let w = worst(ta.midpoints(), tb.midpoints());
    assert!(w <= ROUNDOFF, "{w:e}");
    assert!((a.tbar() - b.tbar()).abs() <= ROUNDOFF * a.tbar());
}

/// A hand-written `Hamiltonian<Dyn>` of any dimension: `H = |z|^2 / 2`.
struct Quadratic(usize);

impl Hamiltonian<Dyn> for Quadratic {
    fn dim(&self) -> Dyn {
        Dyn(self.0)
    }
    fn value(&self, z: &DVector<f64>) -> f64 {
        0.5 * z.norm_squared()
    }
    fn gradient_into(&self, z: &DVector<f64>, out: &mut DVector<f64>) {
        out.copy_from(z);
    }
    fn hessian_into(&self, _: &DVector<f64>, out: &mut DMatrix<f64>) {
        out.fill_with_identity();
    }
}

#[test]
fn construction_errors_are_typed() {
    // Psi identically zero (a free particle): DTH cannot determine lambda.
    let free = RuntimeHamiltonian::new("p1^2/(2*m)", &[("m", 1.0)]).unwrap();
    assert!(Hamiltonian::flags(&free).psi_identically_zero);
    let z = DVector::from_column_slice(&[0.0, 1.0]);
    let err = Dth::new(free, z, DthOptions::new(0.06277).expect("valid dtau"))
        .err()
        .unwrap();
    assert!(matches!(err, Error::PsiIdenticallyZero), "{err:?}");
    // An odd dimension has no (q, p) split.
    let z = DVector::from_element(3, 0.5);
    let err = Dth::new(
        Quadratic(3),
        z,
        DthOptions::new(0.06277).expect("valid dtau"),
    )
    .err()
    .unwrap();
    assert!(matches!(err, Error::OddDimension { dim: 3 }), "{err:?}");
    // A state whose length is not the Hamiltonian's dimension.
    let z = DVector::from_element(6, 0.5);
    let err = Dth::new(
        Quadratic(4),
        z,
        DthOptions::new(0.06277).expect("valid dtau"),
    )
    .err()
    .unwrap();
    assert!(
        matches!(
            err,
            Error::WrongStateLength {
                what: "zbar0",
                expected: 4,
                found: 6
            }
        ),
        "{err:?}"
    );
    // The right one runs.
    let z = DVector::from_element(4, 0.5);
    let mut dth = Dth::new(
        Quadratic(4),
        z,
        DthOptions::new(0.06277).expect("valid dtau"),
    )
    .unwrap();
    dth.advance(10).unwrap();
}

/// A `Dyn` state of another length than the Hamiltonian's dimension, a Hamiltonian of odd
/// dimension, a zero or NaN `dt` given straight to a peer's `step_into` (not through `run`):
/// typed errors that name the argument, for every peer (Gauss-Legendre panicked on an odd
/// dimension, RK4 and Stormer-Verlet returned `Ok` with a state of the wrong length or NaN).
/// `run` names a wrong-length `z0` too (it said "non-finite state at step 1").
#[test]
fn peers_refuse_states_of_another_dimension() {
    fn refuses<M: OneStepMethod<Dyn, Quadratic> + Default>(mut method: M) {
        let name = M::NAME;
        let h = Quadratic(4);
        let (z4, z3) = (DVector::from_element(4, 0.5), DVector::from_element(3, 0.5));
        let wrong = |e: Result<(), Error>, what: &str, found: usize| {
            assert!(
                matches!(e, Err(Error::WrongStateLength { what: w, expected: 4, found: f })
                    if w == what && f == found),
                "{name}: {e:?}"
            );
        };
        wrong(method.step_into(&h, &z3, 0.1, &mut z3.clone()), "z", 3);
        wrong(method.step_into(&h, &z4, 0.1, &mut z3.clone()), "z1", 3);
        wrong(method.step(&h, &z3, 0.1).map(drop), "z", 3);
        let e = run(&mut method, &h, &z3, 0.0, 0.1, 5, &mut ()).unwrap_err();
        assert!(
            matches!(
                e.error,
                Error::WrongStateLength {
                    what: "z0",
                    expected: 4,
                    found: 3
                }
            ),
            "{name}: {e}"
        );
        assert_eq!(e.partial.steps, 0);
        for dt in [0.0, f64::NAN, f64::INFINITY] {
            let e = method.step(&h, &z4, dt);
            assert!(
                matches!(e, Err(Error::InvalidOption { name: "dt", .. })),
                "{name}: dt = {dt}: {e:?}"
            );
        }
        let odd = Quadratic(5);
        let z5 = DVector::from_element(5, 0.5);
        let e = method.step(&odd, &z5, 0.1);
        assert!(
            matches!(e, Err(Error::OddDimension { dim: 5 })),
            "{name}: {e:?}"
        );
        // After all that, the method steps as a fresh one.
        assert_eq!(
            method.step(&h, &z4, 0.1),
            M::default().step(&h, &z4, 0.1),
            "{name}"
        );
    }
    refuses(ImplicitMidpoint::new());
    refuses(Trapezoidal::new());
    refuses(DiscreteGradient::new());
    refuses(Rk4::new());
    refuses(StormerVerlet::new());
    refuses(GaussLegendre2::new());
}

/// The explicit peers stepped straight into a singularity of `H` (`1/q1` at `q1 = 0`): a typed
/// error, not `Ok` with a NaN state.
#[test]
fn explicit_peers_report_a_non_finite_state() {
    let h = RuntimeHamiltonian::new("p1^2/2 - 1/q1", &[]).unwrap();
    let z = DVector::from_column_slice(&[0.0, 1.0]);
    let results = [
        ("rk4", Rk4::new().step(&h, &z, 0.1)),
        ("verlet", StormerVerlet::new().step(&h, &z, 0.1)),
    ];
    for (name, e) in results {
        assert!(
            matches!(e, Err(Error::MethodNonFinite { method, what: "state", .. }) if method == name),
            "{name}: {e:?}"
        );
    }
}

/// The extended phase space's helpers and the segment solver check what they are given: a
/// `z` of another length (`set_momentum_of_time` panicked on an empty one and returned NaN
/// for a short one; `segment_from_vertex` failed with a misleading `NonFinite`), an autonomous
/// `H` (whose last coordinate `set_momentum_of_time` overwrote), a NaN energy.
#[test]
fn extended_helpers_and_segments_check_their_input() {
    let text = RuntimeHamiltonian::new(FORCED_DUFFING, &[("f", 0.1), ("w", 1.3)]).unwrap();
    for len in [0, 2, 5] {
        let e = set_momentum_of_time(&text, DVector::zeros(len));
        assert!(
            matches!(e, Err(Error::WrongStateLength { what: "z", expected: 4, found }) if found == len),
            "{e:?}"
        );
    }
    let z = set_momentum_of_time(&text, DVector::from_column_slice(&[1.0, 0.0, 0.0, 7.0])).unwrap();
    assert_eq!(Hamiltonian::value(&text, &z), 0.0);
    // Its clock is the t coordinate: another start time would disagree with it.
    let dth = Dth::new(text, z, DthOptions::thesis_kepler()).unwrap();
    assert!(matches!(
        dth.with_tbar0(1.0),
        Err(Error::InvalidOption { name: "tbar0", .. })
    ));
    let autonomous = kepler_text();
    let e = set_momentum_of_time(&autonomous, DVector::from_element(4, 0.5));
    assert!(matches!(e, Err(Error::NotTimeDependent)), "{e:?}");
    let options = DthOptions::thesis_kepler();
    let e = segment_from_vertex(
        &autonomous,
        &DVector::from_element(3, 0.5),
        -0.5,
        1.0,
        &options,
    );
    assert!(
        matches!(
            e,
            Err(Error::WrongStateLength {
                what: "vertex",
                expected: 4,
                found: 3
            })
        ),
        "{e:?}"
    );
    let vertex = DVector::from_column_slice(&[0.5, 0.0, 0.0, 1.2]);
    let e = segment_from_vertex(&autonomous, &vertex, f64::NAN, 1.0, &options);
    assert!(
        matches!(e, Err(Error::InvalidOption { name: "energy", .. })),
        "{e:?}"
    );
    // The same call with a DTH run's vertex and level solves its segment.
    let mut dth = Dth::new(autonomous, vertex, options).unwrap();
    let step = dth.step().unwrap().dth.unwrap();
    let h = dth.hamiltonian();
    let (segment, _) =
        segment_from_vertex(h, &step.vertex, dth.energy(), step.lambda, &options).unwrap();
    // The same root by two energy residuals (the stepper's cancellation-free one, the
    // segment's plain one: lambda noise ~ eps / (h lambda)^2 ~ 1e-14 relative at h = 0.06277),
    // |zbar| ~ 1: measured 3.6e-16, allowed 1e-14.
    assert!((segment.zbar - dth.zbar()).amax() <= 1e-14);
}

/// Every peer keeps a `Dyn` dimension's buffers from its first step (the implicit ones their
/// Newton buffers, Gauss-Legendre its block elimination's too; RK4 and Stormer-Verlet their
/// stage vectors): a run of 200 steps allocates exactly what a run of one step does (its start: the first
/// state's record and the method's buffers), and steps after the first allocate nothing.
#[test]
fn dyn_peer_steps_allocate_nothing() {
    fn per_step<M: OneStepMethod<Dyn, RuntimeHamiltonian>>(make: impl Fn() -> M) {
        let h = kepler_text();
        let z0 = DVector::from_column_slice(&[0.5, 0.0, 0.0, 1.2]);
        let (one, a) = alloc_counter::count(|| run(&mut make(), &h, &z0, 0.0, 0.15, 1, &mut ()));
        let (many, b) = alloc_counter::count(|| run(&mut make(), &h, &z0, 0.0, 0.15, 200, &mut ()));
        assert!(one.is_ok() && many.is_ok());
        assert_eq!(
            a,
            b,
            "{}: allocations of a 1-step and a 200-step run",
            M::NAME
        );
        let mut method = make();
        let (mut z, mut next) = (z0.clone(), z0.clone());
        method.step_into(&h, &z0, 0.15, &mut z).unwrap();
        let (_, allocations) = alloc_counter::count(|| {
            for _ in 0..100 {
                method.step_into(&h, &z, 0.15, &mut next).unwrap();
                std::mem::swap(&mut z, &mut next);
            }
        });
        assert_eq!(allocations, 0, "{}: allocations in 100 steps", M::NAME);
    }
    per_step(ImplicitMidpoint::new);
    per_step(Trapezoidal::new);
    per_step(DiscreteGradient::new);
    per_step(Rk4::new);
    per_step(StormerVerlet::new);
    per_step(GaussLegendre2::new);
    // Control: the counter is live.
    let (v, control) = alloc_counter::count(|| std::hint::black_box(vec![1u8; 16]));
    assert_eq!(control, 1);
    drop(v);
}

/// A DTH stepper over a `Dyn` dimension keeps its workspace from `Dth::new`: after its first
/// step nothing allocates, with the joint and the nested solver, a composition of order 4
/// (negative sub-steps), and the robust mode through a breakdown (Kepler at e = 0.9, where
/// `Psi < 0` on part of the orbit, stepped by fallback steps there).
#[test]
fn dyn_dth_steps_allocate_nothing() {
    let thesis = DVector::from_column_slice(&[0.5, 0.0, 0.0, 1.2]);
    let eccentric = DVector::from_column_slice(&[0.5, 0.0, 0.0, 1.9f64.sqrt()]);
    let default = DthOptions::thesis_kepler();
    let cases = [
        ("joint", default, &thesis),
        ("nested", default.with_solver(Solver::Nested), &thesis),
        ("order 4", default.with_order(4).unwrap(), &thesis),
        (
            "robust",
            default.with_dtau(0.0157).unwrap().with_robust(true),
            &eccentric,
        ),
    ];
    for (name, options, z0) in cases {
        let mut dth = Dth::new(kepler_text(), z0.clone(), options).unwrap();
        dth.advance(1).unwrap();
        let (mut steps, mut fallbacks) = (0usize, 0usize);
        let mut observe = |r: &StepRecord<Dyn>| {
            steps += 1;
            fallbacks += usize::from(r.kind == StepKind::Fallback);
        };
        let (result, allocations) = alloc_counter::count(|| dth.run(300, &mut observe));
        result.unwrap();
        assert_eq!(allocations, 0, "{name}: allocations in 300 steps");
        assert_eq!(steps, 300, "{name}");
        if options.robust() {
            // The run went through the breakdown band and out again.
            assert!(
                fallbacks > 0 && fallbacks < 300,
                "{name}: {fallbacks} fallback steps"
            );
        }
        // One step at a time, each step's record read borrowed: nothing allocates either.
        let mut stepped = dth.record();
        let (lambdas, allocations) = alloc_counter::count(|| {
            let mut lambdas = 0.0;
            for _ in 0..100 {
                dth.advance(1).unwrap();
                let record = dth.record_ref();
                lambdas += record.dth.as_ref().map_or(0.0, |d| d.lambda);
                stepped.k = record.k;
            }
            lambdas
        });
        assert_eq!(allocations, 0, "{name}: allocations in 100 single steps");
        assert!(lambdas > 0.0 && stepped.k == 401, "{name}");
        // The borrowed record is the current state's.
        let r = dth.record_ref();
        assert_eq!(
            (r.k, &r.z, r.t),
            (dth.k(), dth.zbar(), dth.tbar()),
            "{name}"
        );
        // Its multiplier is the stepper's, except after a fallback step: the record keeps
        // that step's `dt / dtau`, the stepper the multiplier of the step it takes next (the law
        // of time's where DTH resumes).
        if r.kind != StepKind::Fallback {
            assert_eq!(
                r.dth.as_ref().map(|d| d.lambda),
                Some(dth.lambda()),
                "{name}"
            );
        }
    }
}

/// Kepler `H = |p|^2 - 1/|q|` (`m = 1/2`), written by hand as a `Hamiltonian<Dyn>` that is
/// `Clone` (a [`RuntimeHamiltonian`] owns its compiled code and is not).
#[derive(Clone)]
struct DynKepler;

impl Hamiltonian<Dyn> for DynKepler {
    fn dim(&self) -> Dyn {
        Dyn(4)
    }
    fn flags(&self) -> dth::Flags {
        dth::Flags::default().with_separable(true)
    }
    fn value(&self, z: &DVector<f64>) -> f64 {
        z[2] * z[2] + z[3] * z[3] - 1.0 / z[0].hypot(z[1])
    }
    fn gradient_into(&self, z: &DVector<f64>, out: &mut DVector<f64>) {
        let r3 = z[0].hypot(z[1]).powi(3);
        out.copy_from_slice(&[z[0] / r3, z[1] / r3, 2.0 * z[2], 2.0 * z[3]]);
    }
    fn hessian_into(&self, z: &DVector<f64>, out: &mut DMatrix<f64>) {
        let r2 = z[0] * z[0] + z[1] * z[1];
        let r5 = r2 * r2 * r2.sqrt();
        out.fill(0.0);
        out[(0, 0)] = (r2 - 3.0 * z[0] * z[0]) / r5;
        out[(1, 1)] = (r2 - 3.0 * z[1] * z[1]) / r5;
        out[(0, 1)] = -3.0 * z[0] * z[1] / r5;
        out[(1, 0)] = out[(0, 1)];
        out[(2, 2)] = 2.0;
        out[(3, 3)] = 2.0;
    }
}

/// A clone of a `Dyn` DTH stepper in robust mode keeps its workspace, the fallback steps'
/// Newton buffers included (the clone allocated them again on its first fallback step, where
/// `Dth::new` had reserved them so that no step allocates), and steps as the original, bit
/// for bit (Kepler at e = 0.9: fallback steps from step 5 on). `DynKepler` takes the trait's
/// default discrete gradient, which allocates its temporaries for `Dyn`: the clone must
/// allocate exactly what the original does over the same steps.
#[test]
fn cloned_dyn_stepper_keeps_its_workspace() {
    let zbar0 = DVector::from_column_slice(&[0.5, 0.0, 0.0, 1.9f64.sqrt()]);
    let options = DthOptions::thesis_kepler().with_robust(true);
    let mut dth = Dth::new(DynKepler, zbar0, options).unwrap();
    dth.advance(1).unwrap();
    let mut clone = dth.clone();
    let ((), original) = alloc_counter::count(|| dth.advance(20).unwrap());
    let mut fallbacks = 0;
    let mut count = |r: &StepRecord<Dyn>| fallbacks += usize::from(r.kind == StepKind::Fallback);
    let ((), cloned) = alloc_counter::count(|| clone.run(20, &mut count).unwrap());
    assert!(fallbacks > 0);
    assert_eq!(
        cloned, original,
        "allocations of the clone and the original in 20 steps"
    );
    assert_eq!(clone.record_ref(), dth.record_ref());
}

/// One text compiled once drives two steppers through `&RuntimeHamiltonian` (the core's
/// `impl Hamiltonian for &H`), and each steps exactly as a stepper owning its own compiled
/// copy: the forwarding adds no arithmetic, so the states are equal bit for bit.
#[test]
fn one_compiled_text_drives_two_steppers_by_reference() {
    let shared = kepler_text();
    let z0 = DVector::from_column_slice(&[0.5, 0.0, 0.0, 1.2]);
    let options = DthOptions::thesis_kepler();
    let mut a = Dth::new(&shared, z0.clone(), options).unwrap();
    let mut b = Dth::new(&shared, z0.clone(), options.with_dtau(0.03).unwrap()).unwrap();
    a.advance(50).unwrap();
    b.advance(50).unwrap();
    let mut owned = Dth::new(kepler_text(), z0.clone(), options).unwrap();
    owned.advance(50).unwrap();
    assert_eq!(a.zbar(), owned.zbar());
    assert_eq!(a.lambda(), owned.lambda());
    let mut owned_fine =
        Dth::new(kepler_text(), z0.clone(), options.with_dtau(0.03).unwrap()).unwrap();
    owned_fine.advance(50).unwrap();
    assert_eq!(b.zbar(), owned_fine.zbar());
    // A peer on the same reference, beside them.
    let by_ref = run(
        &mut ImplicitMidpoint::new(),
        &&shared,
        &z0,
        0.0,
        0.15,
        50,
        &mut (),
    )
    .unwrap();
    let by_value = run(
        &mut ImplicitMidpoint::new(),
        &shared,
        &z0,
        0.0,
        0.15,
        50,
        &mut (),
    )
    .unwrap();
    assert_eq!(by_ref.z, by_value.z);
}
