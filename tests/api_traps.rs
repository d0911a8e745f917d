//! The traps a new user fell into (issue 30, "no traps"), one test each: what the API does
//! now where it surprised before.

use dth::dth::{Composition, EnergyResidual, Solver};
use dth::kepler::KeplerOrbit;
use dth::methods::{
    run, DiscreteGradient, GaussLegendre2, ImplicitMidpoint, NewtonOptions, OneStepMethod, Rk4,
    StormerVerlet, Trapezoidal,
};
use dth::nalgebra::{DVector, Dyn, Vector4};
use dth::observer::StepKind;
use dth::runtime::RuntimeHamiltonian;
use dth::systems::Kepler;
use dth::{integrate, Dth, DthOptions, Error, Hamiltonian};

/// Kepler at eccentricity `e` from the thesis's pericentre `q = (0.5, 0)`.
fn kepler_start(e: f64) -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, (1.0 + e).sqrt())
}

/// `RuntimeHamiltonian`'s slice evaluations are named apart (`value_slice`, ...), so with the
/// trait in scope `h.value(&z)` on a `DVector` is the trait's (it was E0308: an inherent
/// `value(&[f64])` shadowed it). `tests/ui/api/runtime-value-on-a-slice.rs` is the old form.
#[test]
fn runtime_trait_methods_are_not_shadowed_by_slice_methods() {
    let h = RuntimeHamiltonian::new("(p1^2 + q1^2)/2 + q1^4", &[]).unwrap();
    let z = DVector::from_column_slice(&[0.5, -1.0]);
    let value: f64 = h.value(&z);
    assert_eq!(value, h.value_slice(z.as_slice()).unwrap());
    assert_eq!(value, 0.625 + 0.0625);
    let gradient: DVector<f64> = h.gradient(&z);
    let mut g = [0.0; 2];
    h.gradient_slice(z.as_slice(), &mut g).unwrap();
    assert_eq!(gradient.as_slice(), &g);
    assert_eq!(g, [0.5 + 4.0 * 0.125, -1.0]);
    let psi: f64 = h.psi(&z);
    assert_eq!(psi, h.psi_slice(z.as_slice()).unwrap());
    let d = h.derivatives(&z);
    let mut buffer = h.derivatives_buffer();
    h.derivatives_slice(z.as_slice(), &mut buffer).unwrap();
    assert_eq!((d.value, d.psi), (buffer.value(), buffer.psi()));
    assert_eq!(d.hessian.as_slice(), buffer.hessian());
    let z1 = DVector::from_column_slice(&[0.25, 1.0]);
    assert_eq!(
        h.energy_difference(&z, &z1),
        h.energy_difference_slice(z.as_slice(), z1.as_slice())
            .unwrap()
    );
}

/// `RuntimeHamiltonian`'s dimension as a `usize` is `dimension()`, and `h.dim()` is the trait's
/// `Dyn` of it, as for every `Hamiltonian<Dyn>` (an inherent `dim() -> usize` shadowed the
/// trait's). `tests/ui/api/runtime-dim-is-the-trait.rs` is the old form.
#[test]
fn runtime_dim_is_the_traits() {
    use dth::nalgebra::Dyn;
    let h = RuntimeHamiltonian::new("(p1^2 + p2^2)/2 + q1^2*q2^2", &[]).unwrap();
    let n: usize = h.dimension();
    assert_eq!(n, 4);
    let d: Dyn = h.dim();
    assert_eq!(d, Dyn(n));
    assert_eq!(Hamiltonian::dim(&h), Dyn(n));
    assert_eq!(<RuntimeHamiltonian as Hamiltonian<Dyn>>::dim(&h), Dyn(n));
    // A time-dependent text: `(q, t, p, p_t)`.
    let forced = RuntimeHamiltonian::new("p1^2/2 + q1^2/2 - q1*cos(t)", &[]).unwrap();
    assert_eq!((forced.dimension(), forced.dim()), (4, Dyn(4)));
}

/// A `Dyn` state of another length than a text Hamiltonian's dimension: every entry point that
/// takes a state refuses it with `WrongStateLength`, naming the argument, the expected and the
/// given length, before any evaluation (through the trait it was NaN, which nothing reported;
/// it now panics, so an integrator that evaluated first would panic here).
#[test]
fn wrong_length_states_are_typed_errors_at_every_entry_point() {
    let text = "(p1^2 + p2^2)/2 - (q1^2 + q2^2)^(-1/2)";
    let h = RuntimeHamiltonian::new(text, &[]).unwrap();
    let short = DVector::from_element(3, 0.5);
    let wrong = |e: &Error, what: &str| {
        assert!(
            matches!(e, Error::WrongStateLength { what: w, expected: 4, found: 3 } if *w == what),
            "{e:?}"
        );
    };
    let err = Dth::new(&h, short.clone(), DthOptions::thesis_kepler())
        .err()
        .unwrap();
    wrong(&err, "zbar0");
    let err = integrate(&h, short.clone(), DthOptions::thesis_kepler(), 10).unwrap_err();
    wrong(&err.error, "zbar0");
    assert!(err.partial.is_empty());
    let err = run(&mut Rk4::new(), &h, &short, 0.0, 0.1, 10, &mut ()).unwrap_err();
    wrong(&err.error, "z0");
    assert_eq!(err.partial.steps, 0);
    let err = ImplicitMidpoint::new().step(&h, &short, 0.1).unwrap_err();
    wrong(&err, "z");
    // Every peer, through `run` and straight.
    fn refuses<M: OneStepMethod<Dyn, RuntimeHamiltonian> + Default>(h: &RuntimeHamiltonian) {
        let short = DVector::from_element(3, 0.5);
        let err = run(&mut M::default(), h, &short, 0.0, 0.1, 10, &mut ()).unwrap_err();
        assert!(
            matches!(
                err.error,
                Error::WrongStateLength {
                    what: "z0",
                    expected: 4,
                    found: 3
                }
            ),
            "{}: {err}",
            M::NAME
        );
        let err = M::default().step(h, &short, 0.1).unwrap_err();
        assert!(
            matches!(
                err,
                Error::WrongStateLength {
                    what: "z",
                    expected: 4,
                    found: 3
                }
            ),
            "{}: {err}",
            M::NAME
        );
    }
    refuses::<ImplicitMidpoint>(&h);
    refuses::<Trapezoidal>(&h);
    refuses::<DiscreteGradient>(&h);
    refuses::<Rk4>(&h);
    refuses::<StormerVerlet<Dyn>>(&h);
    refuses::<GaussLegendre2>(&h);
    // The message says what to fix.
    assert_eq!(
        Error::from(integrate(&h, short, DthOptions::thesis_kepler(), 10).unwrap_err()).to_string(),
        "`zbar0` has length 3, but the Hamiltonian's phase space has dimension 4"
    );
    // The right length runs.
    let z0 = DVector::from_column_slice(kepler_start(0.44).as_slice());
    assert_eq!(
        integrate(&h, z0, DthOptions::thesis_kepler(), 10)
            .unwrap()
            .len(),
        11
    );
}

/// The four-dimensional Kepler text, for the panics of a wrong-length state below.
fn kepler_text() -> RuntimeHamiltonian {
    RuntimeHamiltonian::new("(p1^2 + p2^2)/2 - (q1^2 + q2^2)^(-1/2)", &[]).unwrap()
}

/// Through the trait, whose methods return an `f64` or write into `out`, a `Dyn` point of
/// another length than the text's dimension panics with what to fix (it gave NaN, which a
/// caller outside the integrators never saw reported); the slice methods return the error.
#[test]
#[should_panic(
    expected = "RuntimeHamiltonian::value: z has 3 components, the Hamiltonian's \
                           dimension is 4 (the checked RuntimeHamiltonian::value_slice returns \
                           an error instead)"
)]
fn a_wrong_length_value_through_the_trait_panics() {
    let h = kepler_text();
    let short = DVector::from_element(3, 0.5);
    assert!(h.value_slice(short.as_slice()).is_err());
    let _ = h.value(&short);
}

/// As for `value`: a point of the wrong length given to `gradient_into`.
#[test]
#[should_panic(
    expected = "RuntimeHamiltonian::gradient_into: z has 5 components, the \
                           Hamiltonian's dimension is 4 (the checked \
                           RuntimeHamiltonian::gradient_slice returns an error instead)"
)]
fn a_wrong_length_gradient_through_the_trait_panics() {
    let h = kepler_text();
    let long = DVector::from_element(5, 0.5);
    h.gradient_into(&long, &mut DVector::zeros(4));
}

/// As for `value`: the fused `derivatives_into`, the stepper's evaluation.
#[test]
#[should_panic(
    expected = "RuntimeHamiltonian::derivatives_into: z has 2 components, the \
                           Hamiltonian's dimension is 4 (the checked \
                           RuntimeHamiltonian::derivatives_slice returns an error instead)"
)]
fn a_wrong_length_derivatives_through_the_trait_panics() {
    let h = kepler_text();
    let short = DVector::from_element(2, 0.5);
    h.derivatives_into(&short, &mut dth::Derivatives::zeros(Dyn(4)));
}

/// As for `value`: a two-point method, its second point of the wrong length, named `z1`.
#[test]
#[should_panic(
    expected = "RuntimeHamiltonian::energy_difference: z1 has 3 components, the \
                           Hamiltonian's dimension is 4 (the checked \
                           RuntimeHamiltonian::energy_difference_slice returns an error \
                           instead)"
)]
fn a_wrong_length_second_point_through_the_trait_panics() {
    let h = kepler_text();
    let z0 = DVector::from_column_slice(kepler_start(0.44).as_slice());
    let _ = h.energy_difference(&z0, &DVector::from_element(3, 0.5));
}

/// `Dth::kind()` is the kind of the current record, whatever made it: a plain DTH step, a
/// robust-mode fallback step (also the one after which DTH resumes), and the last step of
/// `step_toward`, shortened to land on its time (it said `Dth` where the record said
/// `Shortened` or `Fallback`).
#[test]
fn kind_is_the_kind_of_the_record() {
    let kepler = Kepler::thesis();
    let z0 = kepler_start(0.9);
    let period = KeplerOrbit::new(&kepler, &z0).unwrap().elements().period;
    let options = DthOptions::new(0.0157).unwrap().with_robust(true);
    let mut dth = Dth::new(kepler, z0, options).unwrap();
    assert_eq!(dth.kind(), StepKind::Dth);
    let mut seen = Vec::new();
    // Ends at 24 times over an orbit: each is a landing, some inside the fallback band.
    for i in 1..=24 {
        let t_end = period * f64::from(i) / 24.0;
        loop {
            let (record, done) = dth.step_toward(t_end).unwrap();
            assert_eq!(dth.kind(), record.kind, "t = {}", record.t);
            assert_eq!(dth.kind(), dth.record_ref().kind);
            seen.push(record.kind);
            if done {
                break;
            }
        }
        let record = dth.step().unwrap();
        assert_eq!(dth.kind(), record.kind);
        seen.push(record.kind);
    }
    assert!(seen.len() > 2 * 24, "{} steps", seen.len()); // more than the landings
    for kind in [StepKind::Dth, StepKind::Fallback, StepKind::Shortened] {
        assert!(seen.contains(&kind), "{kind:?} never seen: {seen:?}");
    }
    // After a fallback step from which DTH resumes, the record (and kind) is the fallback's.
    let resumed = seen
        .windows(2)
        .any(|w| w == [StepKind::Fallback, StepKind::Dth]);
    assert!(resumed, "{seen:?}");
}

/// `step_toward(t_end)` once at `t_end` takes no step: it returns the current record and
/// `true` (it was an error), for a composed run and for the plain energy residual, whose
/// landing tolerance includes the noise of its time; a time before the current one is still
/// an error.
#[test]
fn step_toward_is_idempotent_at_its_end() {
    let plain = DthOptions::thesis_kepler().with_energy_residual(EnergyResidual::Plain);
    for options in [DthOptions::thesis_kepler().with_order(4).unwrap(), plain] {
        let mut dth = Dth::new(Kepler::thesis(), kepler_start(0.44), options).unwrap();
        // At the start: already there.
        assert_eq!(dth.step_toward(0.0).unwrap(), (dth.record(), true));
        assert_eq!(dth.k(), 0);
        let t_end = 7.3;
        let mut steps = 0;
        while !dth.step_toward(t_end).unwrap().1 {
            steps += 1;
        }
        assert!(steps > 10);
        let (k, zbar, record) = (dth.k(), *dth.zbar(), dth.record());
        assert_eq!(record.kind, StepKind::Shortened);
        for _ in 0..3 {
            assert_eq!(dth.step_toward(t_end).unwrap(), (record, true));
            assert_eq!((dth.k(), *dth.zbar()), (k, zbar));
        }
        assert!(matches!(
            dth.step_toward(t_end - 0.5),
            Err(Error::InvalidOption { name: "t_end", .. })
        ));
        assert!(matches!(
            dth.step_toward(f64::NAN),
            Err(Error::InvalidOption { name: "t_end", .. })
        ));
        // And on to a later time.
        let (next, done) = dth.step_toward(t_end + 1.0).unwrap();
        assert!(!done && next.k == k + 1 && next.t > t_end);
    }
}

/// The options' setters follow one rule (documented on `DthOptions`): a setter that takes a
/// number checks it and returns `Result` (an `InvalidOption` named after the option); one that
/// takes an enum or a `bool`, whose every value is valid, returns the options themselves.
#[test]
fn setters_that_take_a_number_check_it_and_the_others_cannot_fail() {
    let o = DthOptions::thesis_kepler();
    let numbers = [
        ("dtau", o.with_dtau(f64::NAN)),
        ("lambda0", o.with_lambda0(-1.0)),
        ("max_iterations", o.with_max_iterations(0)),
        (
            "residual_tolerance",
            o.with_residual_tolerance(f64::INFINITY),
        ),
        ("stall_tolerance", o.with_stall_tolerance(2.0)),
        ("max_lambda_ratio", o.with_max_lambda_ratio(1.0)),
        ("order", o.with_order(3)),
    ];
    for (name, result) in numbers {
        assert!(
            matches!(result, Err(Error::InvalidOption { name: n, .. }) if n == name),
            "{name}: {result:?}"
        );
    }
    let newton = NewtonOptions::default();
    assert!(matches!(
        newton.with_max_iterations(0),
        Err(Error::InvalidOption {
            name: "max_iterations",
            ..
        })
    ));
    assert!(matches!(
        newton.with_stall_tolerance(f64::NAN),
        Err(Error::InvalidOption {
            name: "stall_tolerance",
            ..
        })
    ));
    let dth = Dth::new(Kepler::thesis(), kepler_start(0.44), o).unwrap();
    assert!(matches!(
        dth.with_tbar0(f64::NAN),
        Err(Error::InvalidOption { name: "tbar0", .. })
    ));
    // The others: no `?`, the type says so (this does not compile if one returns `Result`).
    type Set = fn(DthOptions) -> DthOptions;
    type IsSet = fn(&DthOptions) -> bool;
    let infallible: [(Set, IsSet); 4] = [
        (
            |o| o.with_solver(Solver::Nested),
            |o| o.solver() == Solver::Nested,
        ),
        (
            |o| o.with_energy_residual(EnergyResidual::Plain),
            |o| o.energy_residual() == EnergyResidual::Plain,
        ),
        (|o| o.with_robust(true), |o| o.robust()),
        (
            |o| o.with_composition(Composition::KahanLi6),
            |o| o.order() == 6,
        ),
    ];
    for (set, is_set) in infallible {
        assert!(!is_set(&o) && is_set(&set(o)));
    }
}

/// The entry points have flat paths (`dth::Dth`, not only `dth::dth::Dth`), the same items.
#[test]
fn entry_points_have_flat_paths() {
    let flat: fn(Kepler, Vector4<f64>, DthOptions, usize) -> _ = dth::integrate;
    let nested: fn(Kepler, Vector4<f64>, dth::dth::DthOptions, usize) -> _ = dth::dth::integrate;
    let z0 = kepler_start(0.44);
    let run: dth::Trajectory<_> =
        flat(Kepler::thesis(), z0, DthOptions::thesis_kepler(), 5).unwrap();
    let again: dth::dth::Trajectory<_> =
        nested(Kepler::thesis(), z0, DthOptions::thesis_kepler(), 5).unwrap();
    assert_eq!(run.midpoints(), again.midpoints());
    let stepper: dth::dth::Dth<Kepler, _> = Dth::new(Kepler::thesis(), z0, o()).unwrap();
    assert_eq!(stepper.k(), 0);
    let _: Option<dth::RunError<()>> = None::<dth::dth::RunError<()>>;

    fn o() -> dth::dth::DthOptions {
        DthOptions::thesis_kepler()
    }
}
