//! Events (`dth_core::event`): located to roundoff on the method's own states, at the method's
//! order against the exact crossing time, recorded without changing the run, or ending it.

use dth_core::event::Event;
use dth_core::kepler::KeplerOrbit;
use dth_core::nalgebra::{Const, Vector4};
use dth_core::observer::{Observer, StepRecord};
use dth_core::solve::{solve, Method, Solution};
use dth_core::systems::Kepler;
use dth_core::{DthOptions, Error};

/// The thesis orbit, from its pericentre `r = 0.5` (e = 0.44, apocentre 1.286).
fn z0() -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, 1.2)
}

fn r(z: &Vector4<f64>) -> f64 {
    z[0].hypot(z[1])
}

/// The exact time at which the orbit from the pericentre first reaches the radius `radius`
/// on its way out: Kepler's equation, `r = a (1 - e cos E)`, `t = (E - e sin E) / n`.
fn exact_time_out(radius: f64) -> f64 {
    let orbit = KeplerOrbit::new(&Kepler::thesis(), &z0()).unwrap();
    let el = orbit.elements();
    let (a, e) = (el.semi_major_axis, el.eccentricity);
    let big_e = ((1.0 - radius / a) / e).acos();
    (big_e - e * big_e.sin()) * el.period / std::f64::consts::TAU
}

/// The speed `|dq/dt| = 2 |p|` (`m = 1/2`) bounds `|dr/dt|`.
fn speed(z: &Vector4<f64>) -> f64 {
    2.0 * z[2].hypot(z[3])
}

fn methods(h: f64) -> Vec<(Method, u32)> {
    vec![
        (Method::Dth(DthOptions::new(h).unwrap()), 2),
        (
            Method::Dth(DthOptions::new(h).unwrap().with_order(4).unwrap()),
            4,
        ),
        (
            Method::Dth(DthOptions::new(h).unwrap().with_robust(true)),
            2,
        ),
        (Method::Midpoint { dt: h }, 2),
        (Method::GaussLegendre2 { dt: h }, 4),
        (Method::Rk4 { dt: h }, 4),
        (Method::StormerVerlet { dt: h }, 2),
        (Method::DiscreteGradient { dt: h }, 2),
    ]
}

/// The run of `method` from the pericentre that stops where `r > 1` turns true.
fn stopped_going_out(method: Method) -> Solution<Const<4>> {
    let out = Event::new("out", |_t, z: &Vector4<f64>| 1.0 - r(z)).stop();
    solve(&Kepler::thesis(), z0(), method)
        .until(10.0)
        .event(out)
        .run()
        .unwrap()
}

#[test]
fn a_stop_event_ends_the_run_where_its_condition_turns_true() {
    let t_exact = exact_time_out(1.0);
    for h in [0.04, 0.02] {
        for (method, _) in methods(h) {
            let run = stopped_going_out(method);
            let name = run.method;
            assert_eq!(run.stopped, Some(0), "{name}");
            assert_eq!(run.events.len(), 1, "{name}");
            let fired = &run.events[0];
            // The run's last state is the event's, bit for bit.
            assert_eq!(run.end_time(), Some(fired.t), "{name}");
            assert_eq!(run.end_state(), Some(&fired.z), "{name}");
            // Located to roundoff: the bracket is within 8 eps |t|, across which r moves by at
            // most the speed times that; r itself is computed to a few eps.
            let bound = 2.0 * 8.0 * f64::EPSILON * fired.t * speed(&fired.z) + 4.0 * f64::EPSILON;
            assert!(
                (r(&fired.z) - 1.0).abs() <= bound,
                "{name} h = {h}: r = {} at the event",
                r(&fired.z)
            );
            assert!(
                r(&fired.z) >= 1.0 - bound,
                "{name}: the condition holds there"
            );
            // Within the method's error of the exact crossing (a loose check: the largest, the
            // midpoint rule's at h = 0.04, is 1.4e-2; the order is measured below).
            assert!((fired.t - t_exact).abs() < 3e-2, "{name}: t = {}", fired.t);
        }
    }
}

#[test]
fn the_event_time_converges_at_the_method_order() {
    let t_exact = exact_time_out(1.0);
    let time_at = |method: Method| stopped_going_out(method).events[0].t;
    for ((coarse, order), (fine, _)) in methods(0.04).into_iter().zip(methods(0.02)) {
        let (e1, e2) = (
            (time_at(coarse) - t_exact).abs(),
            (time_at(fine) - t_exact).abs(),
        );
        // Halving the step divides the error by 2^p; 0.7 of it leaves room for the
        // higher-order terms at these steps, well above roundoff (errors >= 1e-9).
        let ratio = e1 / e2;
        assert!(
            ratio > 0.7 * 2f64.powi(order as i32),
            "{} (order {order}): time errors {e1:.2e} -> {e2:.2e}, ratio {ratio:.2}",
            coarse.name()
        );
    }
}

/// Keeps what the run showed: the states and the events.
#[derive(Default)]
struct Seen {
    steps: Vec<(f64, Vector4<f64>)>,
    events: Vec<(usize, f64)>,
}

impl Observer<Const<4>> for Seen {
    fn on_step(&mut self, r: &StepRecord<Const<4>>) {
        self.steps.push((r.t, r.z));
    }
    fn on_event(&mut self, event: usize, r: &StepRecord<Const<4>>) {
        self.events.push((event, r.t));
    }
}

#[test]
fn a_recorded_event_fires_each_time_and_leaves_the_run_unchanged() {
    let kepler = Kepler::thesis();
    let period = KeplerOrbit::new(&kepler, &z0()).unwrap().elements().period;
    let t_end = 3.3 * period;
    for (method, _) in methods(0.02) {
        let mut plain = Seen::default();
        solve(&kepler, z0(), method)
            .until(t_end)
            .observer(&mut plain)
            .run()
            .unwrap();
        // The apocentre, where q2 turns negative (counterclockwise from the pericentre); and
        // the pericentre, where it turns positive: two events, numbered in order.
        let mut seen = Seen::default();
        let run = solve(&kepler, z0(), method)
            .until(t_end)
            .event(Event::new("apocentre", |_t, z: &Vector4<f64>| z[1]))
            .event(Event::new("pericentre", |_t, z: &Vector4<f64>| -z[1]))
            .observer(&mut seen)
            .run()
            .unwrap();
        let name = run.method;
        assert_eq!(run.stopped, None);
        assert_eq!(
            seen.steps, plain.steps,
            "{name}: the run is the same, bit for bit"
        );
        // Apocentres at (j + 1/2) T, pericentres at j T; q2 = 0 at the start, where the
        // condition q2 > 0 does not hold yet, and holds just after: a crossing at t = 0.
        let expected: Vec<(usize, f64)> = vec![
            (1, 0.0),
            (0, 0.5 * period),
            (1, period),
            (0, 1.5 * period),
            (1, 2.0 * period),
            (0, 2.5 * period),
            (1, 3.0 * period),
        ];
        let fired: Vec<(usize, f64)> = run.events.iter().map(|f| (f.event, f.t)).collect();
        assert_eq!(fired.len(), expected.len(), "{name}: {fired:?}");
        assert_eq!(seen.events, fired, "{name}: the observer saw each event");
        for ((i, t), (j, te)) in fired.iter().zip(&expected) {
            assert_eq!(i, j, "{name}");
            // The methods' phase error: the largest here, the midpoint rule's at dt = 0.02, is
            // 1.1e-2 at T/2 and grows about linearly with t (the order is measured above).
            let tolerance = 2e-2 * (1.0 + te / period);
            assert!(
                (t - te).abs() < tolerance,
                "{name}: event {i} at {t}, exact {te}"
            );
        }
        for f in &run.events {
            assert!(
                f.z[1].abs() < 1e-12,
                "{name}: q2 = {:e} at the event",
                f.z[1]
            );
        }
    }
}

#[test]
fn a_stop_ends_the_chosen_times_too() {
    let kepler = Kepler::thesis();
    let t_exact = exact_time_out(1.0); // about 0.85
    let times: Vec<f64> = (1..=10).map(|j| 0.1 * j as f64).collect();
    for (method, _) in methods(0.02) {
        let out = Event::new("out", |_t, z: &Vector4<f64>| 1.0 - r(z)).stop();
        let run = solve(&kepler, z0(), method)
            .save_at(times.iter().copied())
            .event(out)
            .run()
            .unwrap();
        let name = run.method;
        let stop = run.events[0].t;
        assert!((stop - t_exact).abs() < 1e-2, "{name}");
        // The chosen times before the stop, and the stop itself.
        let kept: Vec<f64> = times.iter().copied().filter(|&t| t < stop).collect();
        assert_eq!(run.len(), kept.len() + 1, "{name}: {:?}", run.t);
        assert_eq!(run.end_time(), Some(stop), "{name}");
    }
}

#[test]
fn events_work_in_a_run_of_steps_and_a_true_start_waits_for_a_crossing() {
    let kepler = Kepler::thesis();
    let period = KeplerOrbit::new(&kepler, &z0()).unwrap().elements().period;
    let t_out = exact_time_out(0.6);
    // r < 0.6 holds at the start (r = 0.5): it fires when the orbit comes back in, at T - t_out.
    let run = solve(&kepler, z0(), Method::Dth(DthOptions::new(0.01).unwrap()))
        .steps(400)
        .event(Event::new("in", |_t, z: &Vector4<f64>| r(z) - 0.6))
        .run()
        .unwrap();
    assert!(
        run.end_time().unwrap() > 1.5 * period,
        "two orbits and more"
    );
    let first = run.events[0].t;
    assert!((first - (period - t_out)).abs() < 1e-3, "first at {first}");
    assert!((run.events[1].t - (2.0 * period - t_out)).abs() < 2e-3);
}

#[test]
fn a_nan_condition_is_an_error_that_keeps_the_run() {
    let kepler = Kepler::thesis();
    for (method, _) in methods(0.02) {
        let bad = Event::new(
            "bad",
            |t, _z: &Vector4<f64>| if t > 1.0 { f64::NAN } else { 1.0 },
        );
        let failed = solve(&kepler, z0(), method)
            .until(3.0)
            .event(bad)
            .run()
            .unwrap_err();
        assert!(
            matches!(&failed.error, Error::EventNotANumber { name, t } if name == "bad" && *t > 1.0),
            "{}: {:?}",
            method.name(),
            failed.error
        );
        assert!(
            failed.partial.end_time().unwrap() > 0.9,
            "what was computed is kept"
        );
        assert!(failed.error.to_string().contains("event `bad`"));
    }
}
