//! Regularized DTH on eccentric Kepler orbits, the Rust half of the side-by-side benchmark
//! against REBOUND's IAS15 (docs/performance.md). The whole comparison, both sides in one
//! run, is `python3 dth-examples/benches/ias15_kepler.py`, which builds and runs this binary.
//!
//! Thesis units (`H = p1^2 + p2^2 - 1/r`: `m = 1/2`, `k = 1`, `mu = 2`), start at pericentre
//! `q = (0.5, 0)`, `p = (0, sqrt(1 + e))`, 100 orbits. The Hamiltonian is regularized by
//! Levi-Civita at compile time (`#[regularize(levi_civita)]`): in the fictitious time `s` the
//! state `(u, P)` is an oscillator of angular frequency `sqrt(p_t) = sqrt(-E) = sqrt(1 - e)`, and
//! one orbit is half its period, `pi / sqrt(1 - e)`. So `dtau` is given as steps per orbit,
//! `n`, and `dtau = pi / (n sqrt(1 - e))`: the same `n` is the same resolution of the
//! oscillator at every `e`.
//!
//! For each `e` and each order (2, 4, 6, 8), and for DTH-8 solved in double-double (from
//! `KeplerLc::start_double_double` with `Solve::start_low`: every step's equation solved
//! beyond double precision, about 18% more per step), the ladder `n = 8, 11, 16, 23, 32, ...` (factors of
//! `sqrt 2`) is run until the error reaches the target on two consecutive rungs (so a lucky
//! cancellation on one rung is not taken for convergence) or the run's cost passes a cap; the
//! first of the two is reported, its wall time the median of `--repeats` runs. The error is the
//! max-norm of `(q, p)` at the run's end (the `t` coordinate, `T` to rounding) against the
//! exact state at `T` given with `--reference e=q1,q2,p1,p2` (the Python script passes the
//! exact solution through the start, computed with mpmath), or else against Kepler's equation
//! solved in doubles (`dth::kepler::KeplerOrbit`), which at e >= 0.99 is itself off by more
//! than the target after 100 orbits. With `--match e=ERR` the same is done, on the
//! same ladder, for the error `ERR` at that `e` (the Python script passes IAS15's own error, so
//! the two can be compared at the same accuracy where neither reaches the target).
//!
//! `cargo run --release -p dth-examples --example regularized_vs_ias15 -- [--json] [--quick]
//! [--repeats N] [--target ERR] [--orbits N] [--match e=ERR ...] [--reference e=z ...]`: a table on stdout; with `--json`, one JSON object
//! a line instead (what the Python script reads). The ladder's every rung goes to stderr.

use std::error::Error;
use std::process::ExitCode;
use std::time::Instant;

use dth::kepler::KeplerOrbit;
use dth::nalgebra::{Vector4, Vector6};
use dth::regularize::LeviCivita;
use dth::systems::Kepler;
use dth::{solve, DthOptions, Hamiltonian, Method};
use serde_json::json;

dth::hamiltonian! {
    /// The thesis's Kepler problem, regularized by Levi-Civita at compile time: the state is
    /// `(u1, u2, t, P1, P2, p_t)`.
    #[regularize(levi_civita)]
    #[derive(Clone, Copy, Debug)]
    struct KeplerLc = p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)
}

const ECCENTRICITIES: [f64; 4] = [0.44, 0.9, 0.99, 0.999];
/// `(order, double_double)`: DTH of orders 2-8 from a start in doubles, and DTH-8 solved in
/// double-double from its start in double-double (`start_double_double`, `start_low`).
const VARIANTS: [(u32, bool); 5] = [(2, false), (4, false), (6, false), (8, false), (8, true)];

struct Settings {
    json: bool,
    repeats: usize,
    target: f64,
    orbits: f64,
    /// No rung beyond this many steps in the whole run.
    max_steps: f64,
    /// `(e, error)`: also find the cheapest rung reaching this error at this `e` (the peer's).
    matches: Vec<(f64, f64)>,
    /// `(e, z)`: the exact state at `T` for this `e`, measured against instead of
    /// [`KeplerOrbit`].
    references: Vec<(f64, Vector4<f64>)>,
}

/// One regularized DTH run: its end's error against Kepler's equation, steps, Newton
/// iterations and wall time.
#[derive(Clone, Copy, Debug)]
struct Run {
    error: f64,
    t_end: f64,
    steps: usize,
    newton: u64,
    seconds: f64,
}

fn pericentre(e: f64) -> Vector4<f64> {
    Vector4::new(0.5, 0.0, 0.0, (1.0 + e).sqrt())
}

/// `2 pi sqrt(a^3 / mu)`, `mu = 2`, `a = -1 / (2E)`.
fn period(energy: f64) -> f64 {
    let a = -1.0 / (2.0 * energy);
    std::f64::consts::TAU * (a * a * a / 2.0).sqrt()
}

fn run_once(
    z0: &Vector4<f64>,
    reference: &dyn Fn(f64) -> Vector4<f64>,
    t_end: f64,
    dtau: f64,
    (order, double_double): (u32, bool),
) -> Result<Run, Box<dyn Error>> {
    let options = DthOptions::new(dtau)?.with_order(order)?;
    let clock = Instant::now();
    // The start's energy in double-double, rounded once (`KeplerLc::physical_energy`): the
    // plain sum rounds `p2^2` first, which at e = 0.999 is 1e-13 of `E = e - 1`, and the
    // regularized orbit's period, which follows `p_t = -E`, is as accurate as `E` (after 100
    // orbits: 2e-6 at pericentre). Solved in double-double, the start keeps the energy's low
    // part too, and the state's.
    let run = if double_double {
        let (w0, low) = KeplerLc.start_double_double(z0, 0.0)?;
        solve(&KeplerLc, w0, Method::Dth(options)).start_low(low)
    } else {
        solve(&KeplerLc, KeplerLc.start(z0, 0.0)?, Method::Dth(options))
    };
    let solution = run.until(t_end).save_every(usize::MAX).run()?;
    let w = *solution.end_state().ok_or("the run saved no end state")?;
    let seconds = clock.elapsed().as_secs_f64();
    let (z, t) = LeviCivita::physical(&Vector6::from(w));
    let error = (z - reference(t)).amax();
    Ok(Run {
        error,
        t_end: t,
        steps: solution.steps,
        newton: solution.newton_iterations,
        seconds,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            dth_examples::cli::print_error(e.as_ref());
            ExitCode::FAILURE
        }
    }
}

fn parse_args() -> Result<Settings, Box<dyn Error>> {
    let mut settings = Settings {
        json: false,
        repeats: 5,
        target: 1e-10,
        orbits: 100.0,
        max_steps: 1.5e5,
        matches: Vec::new(),
        references: Vec::new(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = |name: &str| -> Result<String, Box<dyn Error>> {
            args.next()
                .ok_or_else(|| format!("{name} needs a value").into())
        };
        match arg.as_str() {
            "--json" => settings.json = true,
            "--quick" => {
                settings.repeats = 1;
                settings.max_steps = 2e4;
            }
            "--repeats" => settings.repeats = value("--repeats")?.parse::<usize>()?.max(1),
            "--target" => settings.target = value("--target")?.parse()?,
            "--orbits" => settings.orbits = value("--orbits")?.parse()?,
            "--match" => {
                let v = value("--match")?;
                let (e, err) = v.split_once('=').ok_or("--match takes e=error")?;
                settings.matches.push((e.parse()?, err.parse()?));
            }
            "--reference" => {
                let v = value("--reference")?;
                let (e, z) = v.split_once('=').ok_or("--reference takes e=q1,q2,p1,p2")?;
                let z = z
                    .split(',')
                    .map(str::parse)
                    .collect::<Result<Vec<f64>, _>>()?;
                if z.len() != 4 {
                    return Err("--reference takes e=q1,q2,p1,p2 (four numbers)".into());
                }
                settings
                    .references
                    .push((e.parse()?, Vector4::from_column_slice(&z)));
            }
            other => return Err(format!("unknown argument {other:?}").into()),
        }
    }
    Ok(settings)
}

fn run() -> Result<(), Box<dyn Error>> {
    let settings = parse_args()?;
    if !settings.json {
        println!(
            "regularized DTH (Levi-Civita, macro), {} orbits, target {:.0e}, median of {}",
            settings.orbits, settings.target, settings.repeats
        );
        println!(
            "{:>6} {:>5} {:>7} {:>10} {:>9} {:>9} {:>10} {:>10}",
            "e", "order", "n/orbit", "dtau", "steps", "Newton", "error", "time [ms]"
        );
    }
    for e in ECCENTRICITIES {
        let z0 = pericentre(e);
        // T from the plain sum's energy (the Python script computes the same T bit for bit).
        let energy = Kepler::thesis().value(&z0);
        let t_end = settings.orbits * period(energy);
        let orbit = KeplerOrbit::new(&Kepler::thesis(), &z0)?;
        // Half a period of the u-oscillator (angular frequency sqrt(-E)) is one orbit.
        let orbit_s = std::f64::consts::PI / (-energy).sqrt();
        // The state at the run's end time `t` (T to rounding): the given exact one at T moved
        // by the orbit's own change from T to t, or else Kepler's equation in doubles.
        let given = settings
            .references
            .iter()
            .find(|(m, _)| *m == e)
            .map(|(_, z)| *z);
        let reference = |t: f64| match given {
            Some(z) => z + (orbit.state_at(t) - orbit.state_at(t_end)),
            None => orbit.state_at(t),
        };
        if settings.json {
            println!(
                "{}",
                json!({
                    "kind": "orbit", "e": e, "energy": energy, "period": period(energy),
                    "t_end": t_end, "z0": z0.as_slice(),
                    "kepler_orbit_end": orbit.state_at(t_end).as_slice(),
                })
            );
        }
        // The target, and the peer's own error at this e when given (`--match e=err`).
        let mut goals = vec![("target", settings.target)];
        if let Some(&(_, err)) = settings.matches.iter().find(|(m, _)| *m == e) {
            goals.push(("match", err));
        }
        for variant in VARIANTS {
            let (order, double_double) = variant;
            let arithmetic = if double_double { " double-double" } else { "" };
            // Rungs n = 8 * 2^(k/2) steps per orbit. Per goal: the first of two consecutive
            // rungs reaching it.
            let mut found: Vec<Option<(f64, Run)>> = vec![None; goals.len()];
            let mut confirmed = vec![false; goals.len()];
            let mut best: Option<(f64, Run)> = None;
            let mut failure = None;
            for k in 0.. {
                let n = (8.0 * 2f64.powf(k as f64 / 2.0)).round();
                if n * settings.orbits > settings.max_steps {
                    break;
                }
                let dtau = orbit_s / n;
                let run = match run_once(&z0, &reference, t_end, dtau, variant) {
                    Ok(run) => run,
                    Err(err_box) => {
                        let mut err = err_box.to_string();
                        let mut source = std::error::Error::source(&*err_box);
                        while let Some(s) = source {
                            err = format!("{err}: {s}");
                            source = s.source();
                        }
                        eprintln!("e = {e}, order {order}{arithmetic}, n = {n}: {err}");
                        failure = Some(format!("n = {n}: {err}"));
                        for (g, f) in found.iter_mut().enumerate() {
                            if !confirmed[g] {
                                *f = None;
                            }
                        }
                        continue;
                    }
                };
                eprintln!(
                    "e = {e}, order {order}{arithmetic}, n = {n:>5} (dtau {dtau:.4e}): error {:.3e}, {} steps, {} Newton, {:.2} ms",
                    run.error,
                    run.steps,
                    run.newton,
                    run.seconds * 1e3
                );
                if best.as_ref().is_none_or(|(_, b)| run.error < b.error) {
                    best = Some((n, run));
                }
                for (g, &(_, goal)) in goals.iter().enumerate() {
                    if confirmed[g] {
                        continue;
                    }
                    if run.error <= goal {
                        if found[g].is_some() {
                            confirmed[g] = true;
                        } else {
                            found[g] = Some((n, run));
                        }
                    } else {
                        found[g] = None;
                    }
                }
                if confirmed.iter().all(|&c| c) {
                    break;
                }
            }
            for (g, &(label, goal)) in goals.iter().enumerate() {
                // An unconfirmed find on the last rung counts (the cap stopped the ladder).
                let reached = found[g].is_some();
                let Some((n, first)) = found[g].or(best) else {
                    let why = failure.clone().unwrap_or_else(|| "no rung ran".into());
                    if settings.json {
                        println!(
                            "{}",
                            json!({"kind": "dth", "goal": label, "e": e, "order": order,
                                   "double_double": double_double, "failed": why})
                        );
                    } else {
                        println!("{e:>6} {order:>5}{arithmetic} failed: {why}");
                    }
                    continue;
                };
                let dtau = orbit_s / n;
                let mut times = vec![first.seconds];
                for _ in 1..settings.repeats {
                    times.push(run_once(&z0, &reference, t_end, dtau, variant)?.seconds);
                }
                let seconds = median(times);
                if settings.json {
                    println!(
                        "{}",
                        json!({
                            "kind": "dth", "goal": label, "goal_error": goal, "e": e,
                            "order": order, "double_double": double_double,
                            "steps_per_orbit": n, "dtau": dtau,
                            "reached": reached, "error": first.error, "t_end": first.t_end,
                            "steps": first.steps, "newton": first.newton, "seconds": seconds,
                        })
                    );
                } else {
                    println!(
                        "{e:>6} {order:>5} {n:>7} {dtau:>10.4e} {:>9} {:>9} {:>10.2e}{} {:>10.3} {label}{arithmetic}",
                        first.steps,
                        first.newton,
                        first.error,
                        if reached { " " } else { "*" },
                        seconds * 1e3
                    );
                }
            }
        }
    }
    if !settings.json {
        println!("* target not reached below the step cap: the best error of the ladder");
    }
    Ok(())
}
