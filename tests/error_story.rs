//! One error story (issue 30): every public fallible call converts into `dth::Error` with `?`,
//! and into an application's `anyhow::Error`, where the typed error is found again by a
//! downcast. The failures are real ones: a DTH breakdown, a Newton that cannot converge, a
//! text that does not compile, a writer that refuses.

use std::io;

use dth::methods::{run, ImplicitMidpoint, NewtonOptions, Rk4};
use dth::nalgebra::{DVector, Vector4, U4};
use dth::runtime::{RuntimeError, RuntimeHamiltonian, Typed};
use dth::systems::Kepler;
use dth::{integrate, Dth, DthOptions, Error, RunError, Trajectory};

/// Kepler at e = 0.9: Psi changes sign between pericentre and apocentre, and plain DTH breaks
/// down at step 19 (`dth::dth`'s module example).
fn eccentric() -> (Kepler, Vector4<f64>, DthOptions) {
    let options = DthOptions::new(0.0157).unwrap();
    (
        Kepler::thesis(),
        Vector4::new(0.5, 0.0, 0.0, 1.9f64.sqrt()),
        options,
    )
}

/// A writer that refuses every write.
struct Refuses;

impl io::Write for Refuses {
    fn write(&mut self, _: &[u8]) -> io::Result<usize> {
        Err(io::Error::new(io::ErrorKind::StorageFull, "disk full"))
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// Each public fallible call of a user's first program, chained with `?` in a function that
/// returns `dth::Error`: options, the stepper, a run, a peer's run, a text Hamiltonian and its
/// typed view, writing the trajectory.
fn every_call_with_question_mark(out: impl io::Write) -> Result<f64, Error> {
    let z0 = Vector4::new(0.5, 0.0, 0.0, 1.2);
    let options = DthOptions::new(0.06277)?.with_order(4)?;
    let mut dth = Dth::new(Kepler::thesis(), z0, options)?;
    dth.advance(5)?;
    dth.run(5, &mut ())?;
    let trajectory = dth.trajectory(5)?;
    let again = integrate(Kepler::thesis(), z0, options, 10)?;
    let end = run(
        &mut Rk4::new(),
        &Kepler::thesis(),
        &z0,
        0.0,
        0.05,
        10,
        &mut (),
    )?;
    let text =
        RuntimeHamiltonian::new("(p1^2 + p2^2)/(2*m) - (q1^2 + q2^2)^(-1/2)", &[("m", 0.5)])?;
    let typed = Typed::<4>::new(text)?;
    let on_text = integrate(typed, z0, options, 10)?;
    trajectory.write_csv(out)?;
    let solved = dth::solve(&Kepler::thesis(), z0, dth::Method::Rk4 { dt: 0.05 })
        .until(0.5)
        .run()?;
    Ok(again.midpoint_times()[10] + end.t + on_text.midpoint_times()[10] + solved.steps as f64)
}

#[test]
fn every_public_fallible_call_converts_into_dth_error() {
    let mut csv = Vec::new();
    let t = every_call_with_question_mark(&mut csv).unwrap();
    assert!(t > 0.0);
    assert!(String::from_utf8(csv).unwrap().starts_with("k,tbar,lambda"));
    // The writer's failure arrives as `Error::Io`, the `io::Error` kept whole.
    let err = every_call_with_question_mark(Refuses).unwrap_err();
    let Error::Io(io) = &err else {
        panic!("{err:?}")
    };
    let io = io.downcast_ref::<io::Error>().unwrap();
    assert_eq!(io.kind(), io::ErrorKind::StorageFull);
    assert_eq!(err.to_string(), "disk full");
}

#[test]
fn a_failed_run_converts_into_its_error_and_keeps_the_partial_run_until_then() {
    let (kepler, z0, options) = eccentric();
    fn breakdown(kepler: Kepler, z0: Vector4<f64>, options: DthOptions) -> Result<(), Error> {
        integrate(kepler, z0, options, 1_000)?;
        Ok(())
    }
    let err = breakdown(kepler, z0, options).unwrap_err();
    assert!(
        matches!(err, Error::Breakdown { step: 19, psi, .. } if psi < 0.0),
        "{err:?}"
    );
    // The partial run stays reachable for those who match on the RunError.
    let RunError { error, partial } = integrate(kepler, z0, options, 1_000).unwrap_err();
    assert_eq!(error, err);
    assert_eq!(partial.len(), 19);
    // A peer's run: its Newton limited to one iteration fails at the first step.
    let newton = NewtonOptions::default().with_max_iterations(1).unwrap();
    let peer = || -> Result<(), Error> {
        run(
            &mut ImplicitMidpoint::with_newton(newton),
            &kepler,
            &Vector4::new(0.5, 0.0, 0.0, 1.2),
            0.0,
            0.1,
            10,
            &mut (),
        )?;
        Ok(())
    };
    let err = peer().unwrap_err();
    assert!(
        matches!(
            err,
            Error::MethodNotConverged {
                method: "midpoint",
                step: 1,
                ..
            }
        ),
        "{err:?}"
    );
}

/// An application's error type: `?` on a failed run gives an `anyhow::Error` whose chain holds
/// the typed `dth::Error` (the `RunError`'s source), and the `RunError` itself with its
/// partial trajectory.
#[test]
fn question_mark_into_anyhow_downcasts_to_dth_error() {
    let (kepler, z0, options) = eccentric();
    let app = || -> anyhow::Result<usize> {
        let run = integrate(kepler, z0, options, 1_000)?;
        Ok(run.len())
    };
    let err = app().unwrap_err();
    let typed = err
        .chain()
        .find_map(|e| e.downcast_ref::<Error>())
        .expect("dth::Error in the chain");
    assert!(
        matches!(typed, Error::Breakdown { step: 19, .. }),
        "{typed:?}"
    );
    assert!(matches!(
        err.root_cause().downcast_ref::<Error>(),
        Some(Error::Breakdown { .. })
    ));
    let run = err.downcast_ref::<RunError<Trajectory<U4>>>().unwrap();
    assert_eq!(run.partial.len(), 19);
    // A report of the chain says the breakdown once, not once per link.
    let breakdown = typed.to_string();
    for report in [format!("{err:#}"), format!("{err:?}")] {
        assert_eq!(report.matches(&breakdown).count(), 1, "{report}");
    }

    // Through `dth::Error` first, the anyhow error is the `dth::Error` itself.
    let app = || -> anyhow::Result<usize> {
        let run: Result<_, Error> = integrate(kepler, z0, options, 1_000).map_err(Error::from);
        Ok(run?.len())
    };
    let err = app().unwrap_err();
    assert!(matches!(
        err.downcast_ref::<Error>(),
        Some(Error::Breakdown { step: 19, .. })
    ));
}

/// The driver's failed run: `?` into `anyhow::Error` downcasts to the `dth::Error` and to the
/// `RunError` with its partial `Solution`, whose `failure` is that error.
#[test]
fn a_failed_solve_into_anyhow_downcasts_too() {
    let (kepler, z0, options) = eccentric();
    let app = || -> anyhow::Result<usize> {
        let run = dth::solve(&kepler, z0, dth::Method::Dth(options))
            .steps(1_000)
            .run()?;
        Ok(run.len())
    };
    let err = app().unwrap_err();
    let typed = err.chain().find_map(|e| e.downcast_ref::<Error>());
    assert!(
        matches!(typed, Some(Error::Breakdown { step: 19, .. })),
        "{typed:?}"
    );
    let run = err
        .downcast_ref::<RunError<dth::Solution<U4>>>()
        .expect("the RunError with its partial solution");
    assert_eq!(run.partial.len(), 19);
    assert_eq!(run.partial.failure.as_ref(), typed);
}

/// A text Hamiltonian's errors: `?` into `dth::Error` (`Error::Hamiltonian`, which displays as
/// the runtime error and downcasts to it) and into `anyhow::Error`.
#[test]
fn runtime_errors_convert_too() {
    let build = |text: &str| -> Result<RuntimeHamiltonian, Error> {
        Ok(RuntimeHamiltonian::new(text, &[])?)
    };
    let err = build("p1^2 + x1").unwrap_err();
    let Error::Hamiltonian(shared) = &err else {
        panic!("{err:?}")
    };
    let runtime = shared.downcast_ref::<RuntimeError>().unwrap();
    assert!(
        matches!(runtime, RuntimeError::Expression(_)),
        "{runtime:?}"
    );
    assert_eq!(err.to_string(), runtime.to_string());
    // The wrong view of a right text, and an evaluation at a point of the wrong length.
    let view = || -> Result<(), Error> {
        let h = RuntimeHamiltonian::new("(p1^2 + q1^2)/2", &[])?;
        h.value_slice(&[1.0, 0.0])?;
        Typed::<4>::new(h)?;
        Ok(())
    };
    let err = view().unwrap_err();
    let Error::Hamiltonian(shared) = &err else {
        panic!("{err:?}")
    };
    assert!(matches!(
        shared.downcast_ref::<RuntimeError>(),
        Some(RuntimeError::DimensionMismatch {
            expected: 4,
            found: 2
        })
    ));
    let evaluate = || -> anyhow::Result<f64> {
        let h = RuntimeHamiltonian::new("(p1^2 + q1^2)/2", &[])?;
        Ok(h.value_slice(&[1.0, 0.0, 0.0])?)
    };
    let err = evaluate().unwrap_err();
    assert!(matches!(
        err.downcast_ref::<RuntimeError>(),
        Some(RuntimeError::WrongLength {
            expected: 2,
            found: 3,
            ..
        })
    ));
    // The stepper refuses a `Dyn` state of another length than the text's, by `?` too.
    let start = || -> Result<(), Error> {
        let h = RuntimeHamiltonian::new("(p1^2 + q1^2)/2", &[])?;
        Dth::new(
            h,
            DVector::from_element(4, 0.5),
            DthOptions::thesis_kepler(),
        )?;
        Ok(())
    };
    assert!(matches!(
        start(),
        Err(Error::WrongStateLength {
            what: "zbar0",
            expected: 2,
            found: 4
        })
    ));
}
