//! The thesis's Kepler figures (Shibberu 1992, Section 4.2, Figures 4.1-4.15), drawn for a
//! scene with `thesis_figures = true` (the embedded default scene).
//!
//! The scene supplies the methods and their steps (the thesis: trapezoidal, midpoint and
//! discrete mechanics with `dt = 0.15`, DTH with `dtau = 0.06277`: 25 points per orbit), the
//! duration (the thesis: 10,000 steps, 400 orbits) and the square of initial conditions (its
//! `[ensemble]`). Figures 4.14 and 4.15 refine those steps as the thesis did, by
//! [`FIG_4_14_REFINEMENT`] over one orbit (the thesis: `dtau / 8 = 0.007846`, 200 points per
//! orbit) and by [`FIG_4_15_REFINEMENT`] over [`FIG_4_15_ORBITS`] orbits (`dt / 4`,
//! `dtau / 4`: 100 points per orbit). Titles and captions state the points per orbit, steps
//! and orbits of the runs actually made.
//!
//! Poincare sections are the thesis's (Section 4.2): no interpolation; the first state on the
//! upper side of `q2 = 0` after an upward crossing is projected onto the plane, i.e. its
//! `(q1, p1)` is plotted. DTH is shown at its midpoints `zbar_k` (the thesis: "midpoint values
//! were used for the DTH trajectories").

use dth::nalgebra::{DefaultAllocator, Dim, OVector};
use dth::Alloc;
use std::path::Path;

use dth::observer::{Observer, StepRecord};
use serde::Serialize;

use crate::driver::{MethodFailure, Stop};
use crate::error::Error;
use crate::method::run_method;
use crate::plot::{Figure, Grid, Legend, Mark, Series};
use crate::scene::{thousands, MethodKind, MethodSpec, Scene, StepSpec};
use crate::simulate::{ensemble_starts, progress_bar, stop_for, Progress, RunOptions};
use crate::system::SceneSystem;

/// Figure 4.14 divides the scene's `dtau` by this (the thesis: `0.06277 / 8 = 0.007846`).
pub const FIG_4_14_REFINEMENT: f64 = 8.0;
/// Figure 4.15 divides every method's step by this (the thesis: `dt / 4`, `dtau / 4`).
pub const FIG_4_15_REFINEMENT: f64 = 4.0;
/// Figure 4.15: orbits.
pub const FIG_4_15_ORBITS: f64 = 3500.0;

/// The name and palette colour a method of the thesis's figures
/// ([`MethodKind::THESIS_FIGURES`]) keeps in every figure.
fn style(kind: MethodKind) -> (&'static str, usize) {
    match kind {
        MethodKind::Exact => ("exact", 6),
        MethodKind::Trapezoidal => ("trapezoidal", 1),
        MethodKind::Midpoint => ("midpoint", 0),
        MethodKind::DiscreteMechanics => ("discrete mechanics", 2),
        MethodKind::Dth => ("DTH (midpoints)", 3),
        other => (other.name(), 7),
    }
}

/// One figure written: its thesis number, file stem (`.png` and `.svg`) and caption.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ThesisFigure {
    /// `"4.1"` ... `"4.15"`.
    pub number: String,
    /// File stem.
    pub stem: String,
    /// Caption (the thesis's, with what we chose where it is silent).
    pub caption: String,
}

/// A state `(t, q1, q2, p1, p2)`.
type State = (f64, [f64; 4]);

/// Stores every state (a few 10^4 for the figures' runs).
struct Record(Vec<State>);

fn state<D: Dim>(r: &StepRecord<D>) -> State
where
    DefaultAllocator: Alloc<D>,
{
    let h = r.z.len() / 2;
    (r.t, [r.z[0], r.z[1], r.z[h], r.z[h + 1]])
}

impl<D: Dim> Observer<D> for Record
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, r: &StepRecord<D>) {
        self.0.push(state(r));
    }
}

/// The thesis's section `q2 = 0`: after an upward crossing (`q2 < 0`, then `q2 >= 0`), the
/// state past the plane, projected: `(q1, p1)`. Stores only the crossings.
///
/// It also measures the precession: the direction of each pericentre (a local minimum of
/// `r = |q|` among the states), unwrapped from one pericentre to the next.
#[derive(Default)]
struct Section {
    previous_q2: Option<f64>,
    points: Vec<(f64, f64)>,
    /// The last two radii and the last angle.
    last: Option<(f64, f64, f64)>,
    /// First pericentre angle, the unwrapped latest one, and how many were seen.
    pericentres: Option<(f64, f64, usize)>,
}

impl Section {
    fn push(&mut self, s: &State) {
        let [q1, q2, p1, _] = s.1;
        if self.previous_q2.is_some_and(|q| q < 0.0) && q2 >= 0.0 {
            self.points.push((q1, p1));
        }
        self.previous_q2 = Some(q2);
        let (r, angle) = (q1.hypot(q2), q2.atan2(q1));
        if let Some((r2, r1, angle1)) = self.last {
            if r1 < r2 && r1 <= r {
                self.pericentres = Some(match self.pericentres {
                    None => (angle1, angle1, 1),
                    Some((first, latest, n)) => {
                        let turn = std::f64::consts::TAU;
                        let d = (angle1 - latest).rem_euclid(turn);
                        let d = if d > 0.5 * turn { d - turn } else { d };
                        (first, latest + d, n + 1)
                    }
                });
            }
            self.last = Some((r1, r, angle));
        } else {
            self.last = Some((r, r, angle));
        }
    }

    /// Mean precession per orbit in degrees (pericentre advance), once two pericentres were
    /// seen.
    fn precession_degrees(&self) -> Option<f64> {
        match self.pericentres {
            Some((first, latest, n)) if n >= 2 => {
                Some((latest - first).to_degrees() / (n - 1) as f64)
            }
            _ => None,
        }
    }
}

impl<D: Dim> Observer<D> for Section
where
    DefaultAllocator: Alloc<D>,
{
    fn on_step(&mut self, r: &StepRecord<D>) {
        self.push(&state(r));
    }
}

fn section_of(states: &[State]) -> Vec<(f64, f64)> {
    let mut s = Section::default();
    for x in states {
        s.push(x);
    }
    s.points
}

fn failed(spec: &MethodSpec, what: &str, failure: MethodFailure) -> Error {
    Error::MethodFailed {
        method: format!("{} ({what})", spec.label),
        failure,
    }
}

/// Points per orbit of a run of `states` (`(states - 1)` steps over its time span).
fn points_per_orbit(states: &[State], period: f64) -> f64 {
    match (states.first(), states.last()) {
        (Some(a), Some(b)) if b.0 > a.0 => (states.len() - 1) as f64 * period / (b.0 - a.0),
        _ => f64::NAN,
    }
}

/// The polar angle of `q` swept from the first state to time `t_end`, in degrees: the
/// unwrapped angle through the states, interpolated linearly between the two around `t_end`.
fn swept_degrees(states: &[State], t_end: f64) -> f64 {
    let angle = |s: &State| s.1[1].atan2(s.1[0]);
    let turn = std::f64::consts::TAU;
    let mut swept = 0.0;
    for w in states.windows(2) {
        let d = (angle(&w[1]) - angle(&w[0])).rem_euclid(turn);
        let d = if d > 0.5 * turn { d - turn } else { d };
        if w[1].0 >= t_end {
            swept += d * (t_end - w[0].0) / (w[1].0 - w[0].0);
            break;
        }
        swept += d;
    }
    swept.to_degrees()
}

/// A copy of `spec` with its step divided by `factor` (more points per orbit).
fn refined(spec: &MethodSpec, factor: f64) -> MethodSpec {
    let mut step = spec.step;
    match &mut step {
        StepSpec::Fixed { dt } => *dt /= factor,
        StepSpec::Dth { dtau, .. } => *dtau /= factor,
    }
    MethodSpec {
        step,
        ..spec.clone()
    }
}

/// `(lo, hi)` of values, padded by 5%.
fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = 0.05 * (hi - lo).max(1e-12);
    (lo - pad, hi + pad)
}

/// Ranges with equal spans for both axes (circles look round on square panels).
fn equal_spans(x: (f64, f64), y: (f64, f64)) -> ((f64, f64), (f64, f64)) {
    let half = 0.5 * (x.1 - x.0).max(y.1 - y.0);
    let (cx, cy) = (0.5 * (x.0 + x.1), 0.5 * (y.0 + y.1));
    ((cx - half, cx + half), (cy - half, cy + half))
}

const PANELS: [(&str, usize, usize); 3] = [
    ("(a) q1 vs p1", 0, 2),
    ("(b) q2 vs p2", 1, 3),
    ("(c) q1 vs q2", 0, 1),
];
const NAMES: [&str; 4] = ["q1", "q2", "p1", "p2"];

/// Writes Figures 4.1-4.15 into `dir`.
///
/// # Errors
/// A method that fails in any of the figures' runs ([`Error::MethodFailed`]), a system without
/// a period for this initial state, or a figure that cannot be written.
pub fn figures<D: Dim, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    z0: &OVector<f64, D>,
    dir: &Path,
    options: &RunOptions,
) -> Result<Vec<ThesisFigure>, Error>
where
    DefaultAllocator: Alloc<D>,
{
    let period = system.period(z0).ok_or_else(|| Error::NotAvailable {
        what: "thesis figures for system",
        name: scene.system.clone(),
        reason: "the initial state has no orbit period".into(),
    })?;
    let specs: Vec<(&MethodSpec, &str, usize)> = MethodKind::THESIS_FIGURES
        .iter()
        .filter_map(|&kind| {
            let (name, color) = style(kind);
            scene
                .methods
                .iter()
                .find(|m| m.kind == kind)
                .map(|m| (m, name, color))
        })
        .collect();
    let stop = stop_for(system, scene, z0, options)?;
    let mut out = Vec::new();
    let mut emit = |number: &str, stem: &str, caption: String| {
        out.push(ThesisFigure {
            number: number.into(),
            stem: stem.into(),
            caption,
        })
    };

    // The long runs (Figures 4.1-4.9): every state of every method.
    let mut runs: Vec<(&MethodSpec, &str, usize, Vec<State>)> = Vec::new();
    for &(spec, name, color) in &specs {
        let bar = progress_bar(spec, scene.t0, stop, options);
        let mut observers = (Progress(bar.clone()), Record(Vec::new()));
        let end = run_method(spec, system, z0.clone(), scene.t0, stop, &mut observers)?;
        bar.finish_and_clear();
        end.map_err(|f| failed(spec, "thesis Figures 4.1-4.9", f))?;
        runs.push((spec, name, color, observers.1 .0));
    }

    // Figures 4.1-4.4: one orbit of each coordinate against t (and one step more, so that the
    // return to the start is visible), the exact solution as a smooth curve.
    // Points per orbit of the runs (the thesis: 25 for every method), and how far each method
    // gets in one period (the thesis's observation on Figures 4.1-4.4: "the trapezoidal method
    // has not completed an orbit; the midpoint method has begun a second").
    let moving: Vec<_> = runs
        .iter()
        .filter(|r| r.0.kind != MethodKind::Exact)
        .collect();
    let ppo = moving
        .iter()
        .map(|r| points_per_orbit(&r.3, period))
        .sum::<f64>()
        / moving.len().max(1) as f64;
    let swept: Vec<String> = moving
        .iter()
        .map(|r| format!("{} {:.2}", r.1, swept_degrees(&r.3, scene.t0 + period)))
        .collect();
    let orbit_note = format!(
        " Polar angle of q swept in one period (degrees; 360 is one orbit): {}.",
        swept.join(", ")
    );
    let t_end = scene.t0 + period * (1.0 + 1.0 / ppo);
    let exact: Vec<State> = (0..=400)
        .filter_map(|i| {
            let t = (t_end - scene.t0) * f64::from(i) / 400.0;
            let z = system.exact_solution(z0, t)?;
            let h = z.len() / 2;
            Some((scene.t0 + t, [z[0], z[1], z[h], z[h + 1]]))
        })
        .collect();
    for (c, name) in NAMES.iter().enumerate() {
        let mut f = Figure::new(
            &format!(
                "Figure 4.{}: Kepler problem, {name} vs t, {ppo:.0} points per orbit, 1 orbit",
                c + 1
            ),
            "t",
            name,
        )
        // Legends where the curves are not (checked by eye on the thesis orbit).
        .with_legend(Some(
            [
                Legend::LowerLeft,
                Legend::UpperRight,
                Legend::UpperLeft,
                Legend::UpperMiddle,
            ][c],
        ));
        for (spec, label, color, states) in &runs {
            if spec.kind == MethodKind::Exact {
                continue;
            }
            f = f.with_series(
                Series::new(
                    label,
                    Mark::LinePoints,
                    states
                        .iter()
                        .take_while(|s| s.0 <= t_end)
                        .map(|s| (s.0, s.1[c])),
                )
                .with_color(*color),
            );
        }
        // The exact curve last and thin, so it shows on top of the methods that follow it.
        f = f.with_series(
            Series::new("exact", Mark::ThinLine, exact.iter().map(|s| (s.0, s.1[c]))).with_color(6),
        );
        let stem = format!("fig4_{}", c + 1);
        f.render(dir, &stem)?;
        emit(
            &format!("4.{}", c + 1),
            &stem,
            format!(
                "Kepler problem, {ppo:.0} points per orbit, 1 orbit: {name} against t (plotted to one step past the period {period:.4}).{orbit_note}"
            ),
        );
    }

    // Figures 4.5-4.9: per method, 400 orbits in three planes and the q2 = 0 section. Ranges
    // are shared by all five figures so the annuli can be compared.
    let all = || runs.iter().flat_map(|r| r.3.iter());
    let ranges: Vec<((f64, f64), (f64, f64))> = PANELS
        .iter()
        .map(|&(_, i, j)| {
            let r = (span(all().map(|s| s.1[i])), span(all().map(|s| s.1[j])));
            if (i, j) == (0, 1) {
                equal_spans(r.0, r.1)
            } else {
                r
            }
        })
        .collect();
    let sections: Vec<Vec<(f64, f64)>> = runs.iter().map(|r| section_of(&r.3)).collect();
    let section_range = (
        span(sections.iter().flatten().map(|p| p.0)),
        span(sections.iter().flatten().map(|p| p.1)),
    );
    let orbits = runs
        .first()
        .and_then(|r| r.3.last())
        .map_or(0.0, |s| (s.0 - scene.t0) / period);
    for (n, ((spec, label, color, states), section)) in runs.iter().zip(&sections).enumerate() {
        let mut panels: Vec<Figure> = PANELS
            .iter()
            .zip(&ranges)
            .map(|(&(title, i, j), &(rx, ry))| {
                Figure::new(title, NAMES[i], NAMES[j])
                    .with_series(
                        Series::new(
                            label,
                            Mark::ThinLine,
                            states.iter().map(|s| (s.1[i], s.1[j])),
                        )
                        .with_color(*color),
                    )
                    .with_ranges(rx, ry)
                    .with_legend(None)
            })
            .collect();
        panels.push(
            Figure::new("(d) q1 vs p1, q2 = 0", "q1", "p1")
                .with_series(
                    Series::new(label, Mark::Points, section.iter().copied()).with_color(*color),
                )
                .with_ranges(section_range.0, section_range.1)
                .with_legend(None),
        );
        let number = 5 + n;
        let ppo = points_per_orbit(states, period);
        let what = match spec.kind {
            MethodKind::Exact => "exact orbit".to_string(),
            MethodKind::Trapezoidal => "trapezoidal method".into(),
            MethodKind::Midpoint => "midpoint method".into(),
            MethodKind::DiscreteMechanics => "discrete mechanics".into(),
            _ => "DTH dynamics (midpoints)".into(),
        };
        let title = format!(
            "Figure 4.{number}: Kepler problem, {what}, {ppo:.0} points per orbit, {orbits:.0} orbits"
        );
        let stem = format!("fig4_{number}");
        Grid::new(&title, (2, 2), panels).render(dir, &stem)?;
        emit(
            &format!("4.{number}"),
            &stem,
            format!(
                "Kepler problem, {what}, {ppo:.0} points per orbit, {} steps ({orbits:.0} orbits): (a) q1 vs p1, (b) q2 vs p2, (c) q1 vs q2, (d) q1 vs p1 at q2 = 0 ({} crossings, projected without interpolation).",
                states.len() - 1,
                section.len()
            ),
        );
    }

    // Figures 4.10-4.13: the square of initial conditions after a few steps.
    if let Some(e) = &scene.ensemble {
        let methods = runs.iter().filter(|r| r.0.kind != MethodKind::Exact);
        for (n, (spec, label, color, _)) in (10..).zip(methods) {
            let mut initial = Vec::new();
            let mut last = Vec::new();
            let mut crossing = Vec::new();
            for z in ensemble_starts(system, e, z0)? {
                let mut record = Record(Vec::new());
                run_method(
                    spec,
                    system,
                    z,
                    scene.t0,
                    Stop::steps(e.steps).with_interrupt(options.interrupt),
                    &mut record,
                )?
                .map_err(|f| failed(spec, "thesis Figures 4.10-4.13", f))?;
                if let (Some(a), Some(b)) = (record.0.first(), record.0.last()) {
                    initial.push(a.1);
                    last.push(b.1);
                }
                crossing.extend(section_of(&record.0).first().copied());
            }
            let mut panels: Vec<Figure> = PANELS
                .iter()
                .map(|&(title, i, j)| {
                    Figure::new(&format!("{title} (grey: initial)"), NAMES[i], NAMES[j])
                        .with_series(
                            Series::new(
                                "initial",
                                Mark::Points,
                                initial.iter().map(|s| (s[i], s[j])),
                            )
                            .with_color(8),
                        )
                        .with_series(
                            Series::new(
                                &format!("after {} steps", e.steps),
                                Mark::Points,
                                last.iter().map(|s| (s[i], s[j])),
                            )
                            .with_color(*color),
                        )
                        .with_legend(None)
                })
                .collect();
            panels.push(
                Figure::new(
                    &if crossing.is_empty() {
                        format!(
                            "(d) q1 vs p1, q2 = 0: no member crossed within {} steps",
                            e.steps
                        )
                    } else {
                        "(d) q1 vs p1, q2 = 0 (first upward crossing)".to_string()
                    },
                    "q1",
                    "p1",
                )
                .with_series(
                    Series::new(
                        "first upward crossing of q2 = 0",
                        Mark::Points,
                        crossing.iter().copied(),
                    )
                    .with_color(*color),
                )
                .with_legend(None),
            );
            let title = format!(
                "Figure 4.{n}: Kepler problem, {label}: {}x{} initial conditions after {} steps",
                e.per_side, e.per_side, e.steps
            );
            let stem = format!("fig4_{n}");
            Grid::new(&title, (2, 2), panels).render(dir, &stem)?;
            emit(
                &format!("4.{n}"),
                &stem,
                format!(
                    "Kepler problem, {label}: a square of {}x{} initial conditions (side {} in the {}-{} plane around the scene's initial state; the thesis does not give its size) after {} steps: (a) q1 vs p1 (grey: the initial square), (b) q2 vs p2, (c) q1 vs q2, (d) the first upward crossing of q2 = 0 within those steps, projected ({} of {} members crossed).",
                    e.per_side,
                    e.per_side,
                    2.0 * e.half_width,
                    e.x.name(),
                    e.y.name(),
                    e.steps,
                    crossing.len(),
                    e.per_side * e.per_side
                ),
            );
        }
    }

    // Figure 4.14: DTH's time coordinate at a refined step over one orbit.
    let dth = runs.iter().find_map(|r| {
        let fine = refined(r.0, FIG_4_14_REFINEMENT);
        match fine.step {
            StepSpec::Dth { dtau, .. } => Some((r.0, r.1, r.2, fine, dtau)),
            StepSpec::Fixed { .. } => None,
        }
    });
    if let Some((spec, label, color, fine, dtau)) = dth {
        let ppo_fine = ppo * FIG_4_14_REFINEMENT;
        let mut record = Record(Vec::new());
        let stop =
            Stop::time(scene.t0 + period, options.max_steps).with_interrupt(options.interrupt);
        run_method(&fine, system, z0.clone(), scene.t0, stop, &mut record)?
            .map_err(|f| failed(spec, "thesis Figure 4.14", f))?;
        let pts: Vec<(f64, f64)> = record
            .0
            .iter()
            .enumerate()
            .map(|(k, s)| (k as f64 * dtau, s.0))
            .collect();
        let (tau_end, t_last) = pts.last().copied().unwrap_or((1.0, 1.0));
        let f = Figure::new(
            &format!(
                "Figure 4.14: Kepler problem, {ppo_fine:.0} points per orbit, 1 orbit (dtau = {dtau:.6})"
            ),
            "tau",
            "t",
        )
        .with_series(
            Series::new(
                &format!("{label}: tbar_k vs tau_k = k dtau"),
                Mark::Line,
                pts.iter().copied(),
            )
            .with_color(color),
        )
        .with_series(
            Series::new(
                "uniform time (straight line)",
                Mark::ThinLine,
                [(0.0, scene.t0), (tau_end, t_last)],
            )
            .with_color(8),
        )
        .with_legend(Some(Legend::UpperLeft));
        f.render(dir, "fig4_14")?;
        emit(
            "4.14",
            "fig4_14",
            format!(
                "Kepler problem, {ppo_fine:.0} points per orbit (dtau = {dtau:.6}), 1 orbit: the DTH time coordinate t against tau ({} steps). Even at this small step t(tau) is visibly nonlinear: time runs fast near apocentre (small Psi) and slow near pericentre.",
                pts.len() - 1
            ),
        );
    }

    // Figure 4.15: q2 = 0 sections at a refined step over many orbits.
    let mut panels = Vec::new();
    let mut counts = Vec::new();
    let stop = Stop::time(scene.t0 + FIG_4_15_ORBITS * period, options.max_steps)
        .with_interrupt(options.interrupt);
    let factor = FIG_4_15_REFINEMENT;
    let (ppo_fine, orbits_fine) = (ppo * factor, thousands(FIG_4_15_ORBITS));
    let mut sections = Vec::new();
    for (spec, label, color, _) in runs.iter().filter(|r| r.0.kind != MethodKind::Exact) {
        let fine = refined(spec, factor);
        let bar = progress_bar(&fine, scene.t0, stop, options);
        let mut observers = (Progress(bar.clone()), Section::default());
        run_method(&fine, system, z0.clone(), scene.t0, stop, &mut observers)?
            .map_err(|f| failed(spec, "thesis Figure 4.15", f))?;
        bar.finish_and_clear();
        let section = observers.1;
        let precession = section.precession_degrees().unwrap_or(f64::NAN);
        sections.push((*label, *color, section.points, precession));
    }
    let rx = span(sections.iter().flat_map(|s| s.2.iter().map(|p| p.0)));
    // (the exact orbit does not precess: its section is a single point)
    let ry = span(sections.iter().flat_map(|s| s.2.iter().map(|p| p.1)));
    for (i, (label, color, points, precession)) in sections.iter().enumerate() {
        counts.push(format!(
            "{label}: {} crossings, pericentre advance {precession:.3} degrees per orbit",
            points.len()
        ));
        panels.push(
            Figure::new(
                &format!(
                    "({}) {label}: precession {precession:.3} deg/orbit",
                    ['a', 'b', 'c', 'd'][i % 4]
                ),
                "q1",
                "p1",
            )
            .with_series(
                Series::new(label, Mark::SmallPoints, points.iter().copied())
                    .with_color(*color)
                    .with_shading(),
            )
            .with_ranges(rx, ry)
            .with_legend(None),
        );
    }
    Grid::new(
        &format!("Figure 4.15: Kepler problem, Poincare sections q2 = 0, {ppo_fine:.0} points per orbit, {orbits_fine} orbits (light: early, dark: late)"),
        (2, 2),
        panels,
    )
    .render(dir, "fig4_15")?;
    emit(
        "4.15",
        "fig4_15",
        format!(
            "Kepler problem, Poincare sections (q1 vs p1 at q2 = 0, projected), {ppo_fine:.0} points per orbit (dt / {factor}, dtau / {factor}), {orbits_fine} orbits; same axes in every panel; points shaded from light (first orbits) to dark (last orbits), so a section that precesses once around shows one smooth gradient; the pericentre advance per orbit is measured from the direction of successive pericentres (local minima of |q|). {}.",
            counts.join("; ")
        ),
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swept_angle_of_one_circle_is_360_degrees() {
        let states: Vec<State> = (0..=100)
            .map(|k| {
                let a = std::f64::consts::TAU * f64::from(k) / 100.0;
                (f64::from(k), [a.cos(), a.sin(), 0.0, 0.0])
            })
            .collect();
        assert!((swept_degrees(&states, 100.0) - 360.0).abs() < 1e-9);
        assert!((swept_degrees(&states, 50.0) - 180.0).abs() < 1e-9);
        // Between states: linear in time.
        assert!((swept_degrees(&states, 50.5) - 181.8).abs() < 1e-9);
        assert!((points_per_orbit(&states, 100.0) - 100.0).abs() < 1e-12);
    }
}
