//! Running a validated scene on a concrete system: every method through the one seam
//! ([`crate::method::run_method`]), observers only for the requested effects, then CSV, JSON,
//! figures and `index.html` written into a staging folder moved into place at the end.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use dth::nalgebra::SVector;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::catalogue::SceneSystem;
use crate::effects::{DeviationStats, EffectOutputs, Effects, FinalState, Series};
use crate::error::Error;
use crate::method::{run_method, Observer, StepView, Stop};
use crate::output::Staging;
use crate::plot::{Figure, Mark, Series as PlotSeries};
use crate::scene::{Coord, Duration, EffectSpec, Ensemble, MethodSpec, Scene, StepSpec};

/// How to run.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct RunOptions {
    /// Show progress bars (indicatif; they hide themselves when stderr is not a terminal).
    /// Default `true`.
    pub progress: bool,
    /// Safety cap on the steps of a run whose duration is a time or a number of orbits.
    /// Default 100,000,000.
    pub max_steps: usize,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            progress: true,
            max_steps: 100_000_000,
        }
    }
}

impl RunOptions {
    /// Sets [`RunOptions::progress`].
    pub fn with_progress(mut self, progress: bool) -> Self {
        self.progress = progress;
        self
    }
}

/// A method that failed mid-run: the step and why (what came before is kept).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Failure {
    /// The step that failed.
    pub step: usize,
    /// Why.
    pub reason: String,
}

/// The summary of one method's run (it goes into `summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MethodSummary {
    /// Label (file prefix).
    pub label: String,
    /// Method name.
    pub kind: String,
    /// `dt`, or `dtau` / `lambda0` / solver for DTH.
    pub step: BTreeMap<String, serde_json::Value>,
    /// Steps taken.
    pub steps: usize,
    /// Final physical time.
    pub t_end: f64,
    /// Set when the method failed mid-run.
    pub failure: Option<Failure>,
    /// States observed by effects (0 when the scene requests none).
    pub observer_calls: usize,
    /// Numbers stored by effects (0 when the scene requests none).
    pub stored_values: usize,
    /// Energy deviation statistics (`energy_deviation` or `comparison_table`).
    pub energy: Option<DeviationStats>,
    /// Invariant deviation statistics (`invariants` or `comparison_table`).
    pub invariants: Vec<DeviationStats>,
    /// `final_state`.
    pub final_state: Option<FinalState>,
}

/// One member of an ensemble after its run.
#[derive(Debug, Clone, PartialEq)]
pub struct EnsembleMember {
    /// Initial value of the ensemble's `x` coordinate.
    pub x0: f64,
    /// Initial value of the ensemble's `y` coordinate.
    pub y0: f64,
    /// Final time and state, or why the member failed.
    pub end: Result<(f64, Vec<f64>), Failure>,
}

/// One method's results in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodResult {
    /// Summary.
    pub summary: MethodSummary,
    /// Everything the effects produced.
    pub outputs: EffectOutputs,
    /// The scene's ensemble (thesis Figures 4.10-4.13), when it has one.
    pub ensemble: Option<Vec<EnsembleMember>>,
}

/// Keeps only the last state of a run.
struct LastState<const D: usize>(Option<(f64, SVector<f64, D>)>);

impl<const D: usize> Observer<D> for LastState<D> {
    fn observe(&mut self, view: &StepView<'_, D>) {
        self.0 = Some((view.t, *view.z));
    }
}

pub(crate) fn coord_index<const D: usize>(c: Coord) -> Option<usize> {
    match c {
        Coord::Q(i) => Some(i),
        Coord::P(i) => Some(D / 2 + i),
        Coord::T => None,
    }
}

fn run_ensemble<const D: usize, S: SceneSystem<D>>(
    system: &S,
    m: &MethodSpec,
    e: &Ensemble,
    z0: &SVector<f64, D>,
    t0: f64,
) -> Result<Vec<EnsembleMember>, Error> {
    let (Some(ix), Some(iy)) = (coord_index::<D>(e.x), coord_index::<D>(e.y)) else {
        return Ok(Vec::new());
    };
    let mut members = Vec::with_capacity(e.per_side * e.per_side);
    let h = 2.0 * e.half_width / (e.per_side - 1) as f64;
    for i in 0..e.per_side {
        for j in 0..e.per_side {
            let mut z = *z0;
            z[ix] += -e.half_width + i as f64 * h;
            z[iy] += -e.half_width + j as f64 * h;
            if S::TIME_DEPENDENT {
                // Keep calH = 0 for the shifted state.
                z[D - 1] = 0.0;
                z[D - 1] = -system.value(&z);
            }
            let mut last = LastState(None);
            let end = run_method(m, system, z, t0, Stop::Steps(e.steps), &mut last)?;
            let end = match (end, last.0) {
                (Ok(_), Some((t, zf))) => Ok((t, zf.iter().copied().collect())),
                (Err(f), _) => Err(Failure {
                    step: f.step,
                    reason: f.reason,
                }),
                (Ok(_), None) => Err(Failure {
                    step: 0,
                    reason: "the method reported no state".into(),
                }),
            };
            members.push(EnsembleMember {
                x0: z[ix],
                y0: z[iy],
                end,
            });
        }
    }
    Ok(members)
}

/// What a run produced (`summary.json` is this, serialized).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// Scene title.
    pub title: String,
    /// System name.
    pub system: String,
    /// Parameters used.
    pub params: BTreeMap<String, f64>,
    /// Where the output is (empty when computed without writing).
    pub out: PathBuf,
    /// Per method.
    pub methods: Vec<MethodSummary>,
    /// Files written, relative to `out`.
    pub files: Vec<String>,
    /// Table 4.1 (scenes with `thesis_figures = true`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub table41: Option<crate::table41::Table>,
    /// The thesis's figures (scenes with `thesis_figures = true`), in its order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub thesis_figures: Vec<crate::thesis::ThesisFigure>,
}

impl RunReport {
    /// Mean and max deviations of every method as a markdown table (empty when no method
    /// has statistics, i.e. no `energy_deviation`, `invariants` or `comparison_table`).
    pub fn deviation_markdown(&self) -> String {
        let mut s = String::new();
        for m in &self.methods {
            for d in m.energy.iter().chain(&m.invariants) {
                if s.is_empty() {
                    s.push_str("| method | quantity | mean | max | vertices mean | vertices max |\n|---|---|---:|---:|---:|---:|\n");
                }
                let (vm, vx) = d.vertices.map_or(("-".to_string(), "-".to_string()), |v| {
                    (format!("{:.3e}", v.mean), format!("{:.3e}", v.max))
                });
                let _ = writeln!(
                    s,
                    "| {} | {} | {:.3e} | {:.3e} | {vm} | {vx} |",
                    m.label, d.name, d.points.mean, d.points.max
                );
            }
        }
        s
    }

    /// The methods that failed mid-run.
    pub fn failures(&self) -> impl Iterator<Item = &MethodSummary> {
        self.methods.iter().filter(|m| m.failure.is_some())
    }
}

/// The initial phase-space point: `(q, p)`, or `(q, t0, p, p_t)` with `calH(z0) = 0` for a
/// time-dependent system (NOTES.md, extended phase space).
pub fn initial_state<const D: usize, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
) -> Result<SVector<f64, D>, Error> {
    let n = scene.q.len();
    let expected = if S::TIME_DEPENDENT { 2 * n + 2 } else { 2 * n };
    if D != expected || scene.p.len() != n {
        return Err(Error::Registration {
            name: scene.system.clone(),
            reason: format!(
                "the implementation has phase-space dimension D = {D}, but the scene's q and p have lengths {} and {} (expected D = {expected})",
                n,
                scene.p.len()
            ),
        });
    }
    let mut z = SVector::<f64, D>::zeros();
    let half = D / 2;
    for i in 0..n {
        z[i] = scene.q[i];
        z[half + i] = scene.p[i];
    }
    if S::TIME_DEPENDENT {
        z[n] = scene.t0;
        z[D - 1] = 0.0;
        z[D - 1] = -system.value(&z);
    }
    Ok(z)
}

fn stop_for<const D: usize, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    z0: &SVector<f64, D>,
    options: &RunOptions,
) -> Result<Stop, Error> {
    Ok(match scene.duration {
        Duration::Steps(n) => Stop::Steps(n),
        Duration::Time(t) => Stop::Time {
            t_end: scene.t0 + t,
            max_steps: options.max_steps,
        },
        Duration::Orbits(k) => {
            let period = system.period(z0).ok_or_else(|| Error::NotAvailable {
                what: "duration in orbits for system",
                name: scene.system.clone(),
                reason:
                    "the initial state has no orbit period (e.g. unbound): use `steps` or `time`"
                        .into(),
            })?;
            Stop::Time {
                t_end: scene.t0 + k * period,
                max_steps: options.max_steps,
            }
        }
    })
}

/// Progress as an observer: moves the bar every 1024 steps (nothing else per step).
pub(crate) struct Progress(pub(crate) ProgressBar);

impl<const D: usize> Observer<D> for Progress {
    #[inline(always)]
    fn observe(&mut self, view: &StepView<'_, D>) {
        if view.step.is_multiple_of(1024) {
            self.0.set_position(view.step as u64);
        }
    }
}

pub(crate) fn progress_bar(m: &MethodSpec, stop: Stop, options: &RunOptions) -> ProgressBar {
    if !options.progress {
        return ProgressBar::hidden();
    }
    let len = match (stop, m.step) {
        (Stop::Steps(n), _) => Some(n as u64),
        (Stop::Time { t_end, .. }, StepSpec::Fixed { dt }) => Some((t_end / dt).ceil() as u64),
        _ => None,
    };
    let (bar, template) = match len {
        Some(n) => (
            ProgressBar::new(n),
            "{prefix:>20} [{bar:40}] {pos}/{len} steps {elapsed}",
        ),
        None => (
            ProgressBar::new_spinner(),
            "{prefix:>20} {spinner} {pos} steps {elapsed}",
        ),
    };
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix(m.label.clone());
    bar
}

fn step_summary(step: StepSpec) -> BTreeMap<String, serde_json::Value> {
    let mut m = BTreeMap::new();
    match step {
        StepSpec::Fixed { dt } => {
            m.insert("dt".into(), dt.into());
        }
        StepSpec::Dth {
            dtau,
            lambda0,
            solver,
        } => {
            m.insert("dtau".into(), dtau.into());
            m.insert("lambda0".into(), lambda0.into());
            m.insert("solver".into(), format!("{solver:?}").to_lowercase().into());
        }
    }
    m
}

/// Runs every method of `scene` on `system` and keeps the results in memory (no files).
/// Effects not requested are not constructed.
pub fn compute<const D: usize, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    options: &RunOptions,
) -> Result<Vec<MethodResult>, Error> {
    let z0 = initial_state(system, scene)?;
    let stop = stop_for(system, scene, &z0, options)?;
    let mut results = Vec::new();
    for m in &scene.methods {
        let bar = progress_bar(m, stop, options);
        let (end, outputs, calls, stored) = match Effects::new(system, &scene.effects) {
            Some(mut effects) => {
                let end = run_method(
                    m,
                    system,
                    z0,
                    scene.t0,
                    stop,
                    &mut (Progress(bar.clone()), &mut effects),
                )?;
                let (calls, stored) = (effects.observer_calls(), effects.stored_values());
                (end, effects.finish(), calls, stored)
            }
            None => {
                let end = run_method(m, system, z0, scene.t0, stop, &mut Progress(bar.clone()))?;
                (end, EffectOutputs::default(), 0, 0)
            }
        };
        bar.finish_and_clear();
        let (steps, t_end, failure) = match end {
            Ok(e) => (e.steps, e.t, None),
            Err(f) => (
                f.step.saturating_sub(1),
                f64::NAN,
                Some(Failure {
                    step: f.step,
                    reason: f.reason,
                }),
            ),
        };
        let summary = MethodSummary {
            label: m.label.clone(),
            kind: m.kind.name().to_string(),
            step: step_summary(m.step),
            steps,
            t_end,
            failure,
            observer_calls: calls,
            stored_values: stored,
            energy: outputs.energy.as_ref().map(|e| e.0.clone()),
            invariants: outputs
                .invariants
                .as_ref()
                .map(|v| v.iter().map(|i| i.0.clone()).collect())
                .unwrap_or_default(),
            final_state: outputs.final_state.clone(),
        };
        let ensemble = match &scene.ensemble {
            Some(e) => Some(run_ensemble(system, m, e, &z0, scene.t0)?),
            None => None,
        };
        results.push(MethodResult {
            summary,
            outputs,
            ensemble,
        });
    }
    Ok(results)
}

/// Runs `scene` on `system` and writes the output folder `out` (see [`crate::output`] for
/// the rules: staged, moved into place only on success, replaces only dth output folders).
///
/// A method that fails mid-run does not abort the run: its results up to the failing step
/// are written, and the failure is in [`RunReport::failures`] (the `dth` command then exits
/// with code 1 after writing).
pub fn run_system<const D: usize, S: SceneSystem<D>>(
    system: &S,
    scene: &Scene,
    out: &Path,
    options: &RunOptions,
) -> Result<RunReport, Error> {
    let staging = Staging::new(out)?;
    let results = compute(system, scene, options)?;
    let dir = staging.path().to_path_buf();
    let mut files = write_outputs(&dir, scene, &results, system.invariant_names())?;
    let methods: Vec<MethodSummary> = results.into_iter().map(|r| r.summary).collect();
    let (table41, thesis_figures) = if scene.thesis_figures {
        let z0 = initial_state(system, scene)?;
        let figures = crate::thesis::figures(system, scene, &z0, &dir, options)?;
        for f in &figures {
            files.push(format!("{}.png", f.stem));
            files.push(format!("{}.svg", f.stem));
        }
        let table = crate::table41::rows_from(&methods);
        let json = serde_json::to_string_pretty(&table).map_err(|e| Error::Io {
            what: "cannot serialize",
            path: dir.join("table41.json"),
            source: std::io::Error::other(e),
        })?;
        write_file(&dir.join("table41.json"), json)?;
        files.push("table41.json".into());
        (Some(table), figures)
    } else {
        (None, Vec::new())
    };
    let mut report = RunReport {
        title: scene.title.clone(),
        system: scene.system.clone(),
        params: scene.params.clone(),
        out: out.to_path_buf(),
        methods,
        files: Vec::new(),
        table41,
        thesis_figures,
    };
    files.push("summary.json".into());
    files.push("index.html".into());
    report.files = files;
    let html = crate::html::index(scene, &report);
    write_file(&dir.join("index.html"), html)?;
    let json = serde_json::to_string_pretty(&report).map_err(|e| Error::Io {
        what: "cannot serialize",
        path: dir.join("summary.json"),
        source: std::io::Error::other(e),
    })?;
    write_file(&dir.join("summary.json"), json)?;
    report.out = staging.commit()?;
    Ok(report)
}

fn write_file(path: &Path, contents: impl AsRef<[u8]>) -> Result<(), Error> {
    std::fs::write(path, contents).map_err(|source| Error::Io {
        what: "cannot write",
        path: path.to_path_buf(),
        source,
    })
}

fn csv_series(header: &str, a: &Series, b: &Series) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{header}");
    for (i, &(k, t, d)) in a.iter().enumerate() {
        let _ = write!(s, "{k},{t:e},{d:e}");
        if let Some(&(_, tv, dv)) = b.get(i) {
            let _ = write!(s, ",{tv:e},{dv:e}");
        }
        s.push('\n');
    }
    s
}

fn coord_names(scene: &Scene, d: usize) -> Vec<String> {
    let n = scene.q.len();
    let mut names: Vec<String> = (1..=n).map(|i| format!("q{i}")).collect();
    let extended = d == 2 * n + 2;
    if extended {
        names.push("t_ext".into());
    }
    names.extend((1..=n).map(|i| format!("p{i}")));
    if extended {
        names.push("p_t".into());
    }
    names
}

fn write_outputs(
    dir: &Path,
    scene: &Scene,
    results: &[MethodResult],
    invariant_names: &[&str],
) -> Result<Vec<String>, Error> {
    let mut files = Vec::new();
    let put = |name: String, contents: String, files: &mut Vec<String>| {
        write_file(&dir.join(&name), contents)?;
        files.push(name);
        Ok::<(), Error>(())
    };
    for r in results {
        let l = &r.summary.label;
        let o = &r.outputs;
        if let Some(rows) = &o.trajectory {
            let d = rows.first().map_or(0, |r| r.z.len());
            let mut s = format!("step,t,{},lambda\n", coord_names(scene, d).join(","));
            for r in rows {
                let _ = write!(s, "{},{:e}", r.step, r.t);
                for x in &r.z {
                    let _ = write!(s, ",{x:e}");
                }
                let _ = writeln!(
                    s,
                    ",{}",
                    r.lambda.map_or(String::new(), |v| format!("{v:e}"))
                );
            }
            put(format!("{l}_trajectory.csv"), s, &mut files)?;
        }
        if let Some((_, a, b)) = &o.energy {
            if !a.is_empty() {
                let header = if b.is_empty() {
                    "step,t,energy_deviation"
                } else {
                    "step,t,energy_deviation,vertex_t,vertex_energy_deviation"
                };
                put(
                    format!("{l}_energy.csv"),
                    csv_series(header, a, b),
                    &mut files,
                )?;
            }
        }
        if let Some(v) = &o.invariants {
            for (stats, a, b) in v {
                if !a.is_empty() {
                    let name = &stats.name;
                    let header = if b.is_empty() {
                        format!("step,t,{name}_deviation")
                    } else {
                        format!("step,t,{name}_deviation,vertex_t,vertex_{name}_deviation")
                    };
                    put(
                        format!("{l}_{name}.csv"),
                        csv_series(&header, a, b),
                        &mut files,
                    )?;
                }
            }
        }
        if let Some(rows) = &o.time_law {
            let mut s = String::from("step,t,lambda\n");
            for (k, t, lambda) in rows {
                let _ = writeln!(s, "{k},{t:e},{lambda:e}");
            }
            put(format!("{l}_time_law.csv"), s, &mut files)?;
        }
        for (i, c) in o.poincare.iter().enumerate() {
            let mut s = String::from("t,x,y\n");
            for (t, x, y) in c {
                let _ = writeln!(s, "{t:e},{x:e},{y:e}");
            }
            put(format!("{l}_poincare{}.csv", i + 1), s, &mut files)?;
        }
        if let Some(members) = &r.ensemble {
            let d = members
                .iter()
                .find_map(|m| m.end.as_ref().ok().map(|e| e.1.len()))
                .unwrap_or(0);
            let mut s = format!("x0,y0,t,{},failure\n", coord_names(scene, d).join(","));
            for m in members {
                let _ = write!(s, "{:e},{:e}", m.x0, m.y0);
                match &m.end {
                    Ok((t, z)) => {
                        let _ = write!(s, ",{t:e}");
                        for x in z {
                            let _ = write!(s, ",{x:e}");
                        }
                        s.push_str(",\n");
                    }
                    Err(f) => {
                        let _ = writeln!(
                            s,
                            ",{}step {}: {}",
                            ",".repeat(d + 1),
                            f.step,
                            f.reason.replace(',', ";")
                        );
                    }
                }
            }
            put(format!("{l}_ensemble.csv"), s, &mut files)?;
        }
        for (i, pts) in o.phase.iter().enumerate() {
            let mut s = String::from("x,y\n");
            for (x, y) in pts {
                let _ = writeln!(s, "{x:e},{y:e}");
            }
            put(format!("{l}_phase{}.csv", i + 1), s, &mut files)?;
        }
    }
    files.extend(write_figures(dir, scene, results, invariant_names)?);
    Ok(files)
}

fn write_figures(
    dir: &Path,
    scene: &Scene,
    results: &[MethodResult],
    invariant_names: &[&str],
) -> Result<Vec<String>, Error> {
    let mut figs: Vec<(String, Figure)> = Vec::new();
    let mut poincare_i = 0;
    let mut phase_i = 0;
    let mut seen_energy = false;
    let mut seen_invariants = false;
    let mut seen_time_law = false;
    for spec in &scene.effects {
        match spec {
            EffectSpec::EnergyDeviation { .. } if !seen_energy => {
                seen_energy = true;
                let mut f = Figure::new(
                    &format!("{}: energy deviation", scene.title),
                    "t",
                    "|H - H0|",
                )
                .with_log(false, true);
                for r in results {
                    if let Some((_, a, b)) = &r.outputs.energy {
                        let name = if b.is_empty() {
                            r.summary.label.clone()
                        } else {
                            format!("{} (midpoints)", r.summary.label)
                        };
                        f = f.with_series(PlotSeries::new(
                            &name,
                            Mark::Line,
                            a.iter().map(|p| (p.1, p.2)),
                        ));
                        if !b.is_empty() {
                            f = f.with_series(PlotSeries::new(
                                &format!("{} (vertices)", r.summary.label),
                                Mark::Line,
                                b.iter().map(|p| (p.1, p.2)),
                            ));
                        }
                    }
                }
                figs.push(("energy_deviation".into(), f));
            }
            EffectSpec::Invariants { .. } if !seen_invariants => {
                seen_invariants = true;
                for (j, name) in invariant_names.iter().enumerate() {
                    let mut f = Figure::new(
                        &format!("{}: {name} deviation", scene.title),
                        "t",
                        &format!("|{name} - {name}0|"),
                    )
                    .with_log(false, true);
                    for r in results {
                        if let Some((_, a, b)) =
                            r.outputs.invariants.as_ref().and_then(|v| v.get(j))
                        {
                            f = f.with_series(PlotSeries::new(
                                &r.summary.label,
                                Mark::Line,
                                a.iter().map(|p| (p.1, p.2)),
                            ));
                            if !b.is_empty() {
                                f = f.with_series(PlotSeries::new(
                                    &format!("{} (vertices)", r.summary.label),
                                    Mark::Line,
                                    b.iter().map(|p| (p.1, p.2)),
                                ));
                            }
                        }
                    }
                    figs.push((format!("invariant_{name}"), f));
                }
            }
            EffectSpec::TimeLaw { .. } if !seen_time_law => {
                seen_time_law = true;
                let mut ft = Figure::new(&format!("{}: time law", scene.title), "step k", "t");
                let mut fl = Figure::new(
                    &format!("{}: lambda = dt/dtau", scene.title),
                    "step k",
                    "lambda",
                );
                for r in results {
                    if let Some(rows) = &r.outputs.time_law {
                        let l = &r.summary.label;
                        ft = ft.with_series(PlotSeries::new(
                            l,
                            Mark::Line,
                            rows.iter().map(|p| (p.0 as f64, p.1)),
                        ));
                        if rows.iter().any(|p| p.2.is_finite()) {
                            fl = fl.with_series(PlotSeries::new(
                                l,
                                Mark::Line,
                                rows.iter().map(|p| (p.0 as f64, p.2)),
                            ));
                        }
                    }
                }
                figs.push(("time_law_t".into(), ft));
                if !fl.series.is_empty() {
                    figs.push(("time_law_lambda".into(), fl));
                }
            }
            EffectSpec::Poincare {
                coordinate,
                value,
                x,
                y,
                ..
            } => {
                let mut f = Figure::new(
                    &format!(
                        "{}: Poincare section {} = {value}",
                        scene.title,
                        coordinate.name()
                    ),
                    &x.name(),
                    &y.name(),
                );
                for r in results {
                    if let Some(c) = r.outputs.poincare.get(poincare_i) {
                        f = f.with_series(PlotSeries::new(
                            &r.summary.label,
                            Mark::Points,
                            c.iter().map(|p| (p.1, p.2)),
                        ));
                    }
                }
                poincare_i += 1;
                figs.push((format!("poincare{poincare_i}"), f));
            }
            EffectSpec::PhasePlot { x, y, .. } => {
                let mut f = Figure::new(
                    &format!("{}: {} against {}", scene.title, y.name(), x.name()),
                    &x.name(),
                    &y.name(),
                );
                for r in results {
                    if let Some(pts) = r.outputs.phase.get(phase_i) {
                        f = f.with_series(PlotSeries::new(
                            &r.summary.label,
                            Mark::Line,
                            pts.iter().copied(),
                        ));
                    }
                }
                phase_i += 1;
                figs.push((format!("phase{phase_i}"), f));
            }
            _ => {}
        }
    }
    // Scenes with the thesis's figures draw their ensembles as Figures 4.10-4.13 instead.
    if let (Some(e), false) = (&scene.ensemble, scene.thesis_figures) {
        for r in results {
            let Some(members) = &r.ensemble else { continue };
            let (ix, iy) = (e.x, e.y);
            let idx = |c: Coord, z: &[f64]| match c {
                Coord::Q(i) => z.get(i).copied(),
                Coord::P(i) => z.get(z.len() / 2 + i).copied(),
                Coord::T => None,
            };
            let finals = members.iter().filter_map(|m| {
                let z = &m.end.as_ref().ok()?.1;
                Some((idx(ix, z)?, idx(iy, z)?))
            });
            let f = Figure::new(
                &format!(
                    "{}: {}, square of initial conditions after {} steps",
                    scene.title, r.summary.label, e.steps
                ),
                &ix.name(),
                &iy.name(),
            )
            .with_series(PlotSeries::new(
                "initial",
                Mark::Points,
                members.iter().map(|m| (m.x0, m.y0)),
            ))
            .with_series(PlotSeries::new(
                &format!("after {} steps", e.steps),
                Mark::Points,
                finals,
            ));
            figs.push((format!("ensemble_{}", r.summary.label), f));
        }
    }
    let mut files = Vec::new();
    for (stem, f) in figs {
        f.render(dir, &stem)?;
        files.push(format!("{stem}.png"));
        files.push(format!("{stem}.svg"));
    }
    Ok(files)
}
