//! An ensemble scene's files: the per-member table (`ensemble.csv`, `ensemble.json`), every
//! member's section crossings (`ensemble_crossings.csv`) collected into one section figure per
//! method and section, the chaos map, and `index.html`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::member::MemberResult;
use super::step_check::REGULAR_MAX;
use crate::error::Error;
use crate::plot::{Figure, Mark, Raster, Series};
use crate::report::html::escape;
use crate::report::{write_file, write_json, EnsembleCounts as Counts, StepCheck};
use crate::scene::{component_names, Axis, Coord, EffectSpec, Members, Sampler, Scene};
use crate::simulate::Failure;

/// One row of the table: one member run with one method.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// The member's number (its place in the sampler's order).
    pub member: usize,
    /// The method's label.
    pub method: String,
    /// The system's parameters for this member.
    pub params: BTreeMap<String, f64>,
    /// Initial phase-space state (empty when the member did not run).
    pub start: Vec<f64>,
    /// Steps taken.
    pub steps: usize,
    /// Time of the last state reached.
    pub t_end: f64,
    /// Last state reached (DTH: its last midpoint).
    pub end: Vec<f64>,
    /// `max |H - H0|` over the run (`null` in JSON when not finite).
    pub energy_error: f64,
    /// Steps robust DTH took as fallback steps (0 for every other method).
    pub fallback_steps: usize,
    /// Why the run stopped early, or why the member did not run (step 0).
    pub failure: Option<Failure>,
    /// MEGNO `<Y>` (ensembles with `chaos = "megno"`).
    pub megno: Option<f64>,
    /// Benettin's maximal Lyapunov exponent estimate.
    pub lyapunov: Option<f64>,
    /// The smaller alignment index SALI.
    pub sali: Option<f64>,
}

/// `ensemble.json`: the counts, the skipped members' numbers, and the rows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table {
    /// Counts.
    pub counts: Counts,
    /// The skipped members' numbers.
    pub skipped: Vec<usize>,
    /// One row per member and method.
    pub rows: Vec<Row>,
}

/// The table of `results` (skipped members counted, not listed as rows).
/// `step_check` goes into the counts as it is.
pub fn table(scene: &Scene, results: &[MemberResult], step_check: Option<StepCheck>) -> Table {
    let mut rows = Vec::new();
    let mut counts = Counts {
        drawn: results.len(),
        skipped: 0,
        not_run: 0,
        failed_runs: 0,
        fallback_runs: 0,
        step_check,
    };
    let mut skipped = Vec::new();
    for r in results {
        if r.skipped {
            counts.skipped += 1;
            skipped.push(r.index);
            continue;
        }
        if let Some(why) = &r.not_run {
            counts.not_run += 1;
            for m in &scene.methods {
                rows.push(Row {
                    member: r.index,
                    method: m.label.clone(),
                    params: r.params.clone(),
                    start: r.start.clone().unwrap_or_default(),
                    steps: 0,
                    t_end: scene.t0,
                    end: Vec::new(),
                    energy_error: 0.0,
                    fallback_steps: 0,
                    failure: Some(Failure {
                        step: 0,
                        reason: format!("not run: {why}"),
                    }),
                    megno: None,
                    lyapunov: None,
                    sali: None,
                });
            }
            continue;
        }
        for run in &r.runs {
            counts.failed_runs += usize::from(run.failure.is_some());
            counts.fallback_runs += usize::from(run.fallback_steps > 0);
            rows.push(Row {
                member: r.index,
                method: run.method.clone(),
                params: r.params.clone(),
                start: r.start.clone().unwrap_or_default(),
                steps: run.steps,
                t_end: run.t_end,
                end: run.end.clone(),
                energy_error: run.energy_error,
                fallback_steps: run.fallback_steps,
                failure: run.failure.clone(),
                megno: run.megno,
                lyapunov: run.lyapunov,
                sali: run.sali,
            });
        }
    }
    Table {
        counts,
        skipped,
        rows,
    }
}

/// A CSV field: quoted when it holds a comma, a quote or a line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:e}"))
}

/// `ensemble.csv`: a header, then one line per row.
pub fn csv(scene: &Scene, d: usize, t: &Table) -> String {
    let names = component_names(scene.q.len(), d);
    let mut s = String::from("member,method");
    for k in scene.params.keys() {
        let _ = write!(s, ",{}", field(k));
    }
    for n in &names {
        let _ = write!(s, ",start_{n}");
    }
    s.push_str(",steps,t_end");
    for n in &names {
        let _ = write!(s, ",end_{n}");
    }
    s.push_str(",energy_error,failure_step,failure,megno,lyapunov,sali,fallback_steps\n");
    for r in &t.rows {
        let _ = write!(s, "{},{}", r.member, field(&r.method));
        for k in scene.params.keys() {
            let _ = write!(s, ",{}", opt(r.params.get(k).copied()));
        }
        for i in 0..d {
            let _ = write!(s, ",{}", opt(r.start.get(i).copied()));
        }
        let _ = write!(s, ",{},{:e}", r.steps, r.t_end);
        for i in 0..d {
            let _ = write!(s, ",{}", opt(r.end.get(i).copied()));
        }
        let _ = writeln!(
            s,
            ",{:e},{},{},{},{},{},{}",
            r.energy_error,
            r.failure
                .as_ref()
                .map_or(String::new(), |f| f.step.to_string()),
            field(r.failure.as_ref().map_or("", |f| f.reason.as_str())),
            opt(r.megno),
            opt(r.lyapunov),
            opt(r.sali),
            r.fallback_steps
        );
    }
    s
}

/// The sections of the scene (its `poincare` and `stroboscopic` effects), in order: name and
/// axes.
fn sections(scene: &Scene) -> Vec<(String, Coord, Coord)> {
    scene
        .effects
        .iter()
        .filter_map(EffectSpec::section)
        .collect()
}

/// `ensemble_crossings.csv`: every crossing of every member, method and section.
pub fn crossings_csv(results: &[MemberResult]) -> String {
    let mut s = String::from("member,method,section,t,x,y\n");
    for r in results {
        for run in &r.runs {
            for (i, c) in run.crossings.iter().enumerate() {
                for (t, x, y) in c {
                    let _ = writeln!(
                        s,
                        "{},{},{},{t:e},{x:e},{y:e}",
                        r.index,
                        field(&run.method),
                        i + 1
                    );
                }
            }
        }
    }
    s
}

/// The section figures: per section and method, every member's crossings, one colour a
/// member.
fn section_figures(scene: &Scene, results: &[MemberResult]) -> Vec<(String, Figure)> {
    let mut figs = Vec::new();
    for (i, (name, x, y)) in sections(scene).into_iter().enumerate() {
        for (mi, m) in scene.methods.iter().enumerate() {
            let mut members = 0;
            let mut points = 0;
            let mut f = Figure::new("", &x.name(), &y.name()).with_legend(None);
            for r in results {
                let Some(c) = r.runs.get(mi).and_then(|run| run.crossings.get(i)) else {
                    continue;
                };
                if c.is_empty() {
                    continue;
                }
                members += 1;
                points += c.len();
                f = f.with_series(
                    Series::new(
                        &format!("member {}", r.index),
                        Mark::SmallPoints,
                        c.iter().map(|p| (p.1, p.2)),
                    )
                    .with_color(r.index),
                );
            }
            f.title = format!(
                "{}: {name} by {}, {members} members, {points} points",
                scene.title, m.label
            );
            figs.push((format!("section{}_{}", i + 1, m.label), f));
        }
    }
    figs
}

/// The two (or one) varied axes of the sampler, for the chaos map.
fn map_axes(members: &Members) -> Vec<Axis> {
    match &members.sampler {
        Sampler::Grid { x, y } => std::iter::once(x.0.axis.clone())
            .chain(y.as_ref().map(|y| y.0.axis.clone()))
            .collect(),
        Sampler::Random { x, y, .. } => std::iter::once(x.axis.clone())
            .chain(y.as_ref().map(|y| y.axis.clone()))
            .collect(),
        Sampler::List { columns, .. } => columns.iter().take(2).cloned().collect(),
    }
}

/// The value of `axis` in a member's initial state or parameters.
fn axis_value(axis: &Axis, r: &MemberResult, d: usize) -> Option<f64> {
    match axis {
        Axis::Coord(c) => r.start.as_ref()?.get(c.index(d)?).copied(),
        Axis::Param(p) => r.params.get(p).copied(),
    }
}

/// MEGNO classes of the chaos map: upper bound (inclusive) and legend.
const CLASSES: [(f64, &str); 4] = [
    (
        REGULAR_MAX,
        "<Y> <= 2.5: regular (quasi-periodic: <Y> -> 2)",
    ),
    (5.0, "2.5 < <Y> <= 5"),
    (20.0, "5 < <Y> <= 20"),
    (f64::INFINITY, "<Y> > 20: chaotic"),
];

/// The chaos maps: per method, every member at its varied values, coloured by its MEGNO
/// class (one axis: `<Y>` against it).
fn chaos_figures(
    scene: &Scene,
    members: &Members,
    d: usize,
    results: &[MemberResult],
) -> Vec<(String, Figure)> {
    let axes = map_axes(members);
    let mut figs = Vec::new();
    for (mi, m) in scene.methods.iter().enumerate() {
        // A run that stopped early has a <Y> over a shorter time: shown as failed, not classed
        // (the table keeps its value).
        let value = |r: &MemberResult| {
            r.runs
                .get(mi)
                .filter(|run| run.failure.is_none())
                .and_then(|run| run.megno)
        };
        let title = format!(
            "{}: {}, MEGNO chaos indicator over the ensemble",
            scene.title, m.label
        );
        let f = match axes.as_slice() {
            [x, y, ..] => {
                let mut f = Figure::new(&title, &x.name(), &y.name());
                let at = |r: &MemberResult| Some((axis_value(x, r, d)?, axis_value(y, r, d)?));
                let class = |v: f64| CLASSES.iter().position(|(hi, _)| v <= *hi);
                for (ci, (_, name)) in CLASSES.iter().enumerate() {
                    let pts: Vec<(f64, f64)> = results
                        .iter()
                        .filter(|r| value(r).and_then(class) == Some(ci))
                        .filter_map(at)
                        .collect();
                    f = f.with_series(
                        Series::new(name, Mark::Points, pts).with_color([2, 4, 1, 6][ci]),
                    );
                }
                let none: Vec<(f64, f64)> = results
                    .iter()
                    .filter(|r| !r.skipped && value(r).and_then(class).is_none())
                    .filter_map(at)
                    .collect();
                if !none.is_empty() {
                    f = f.with_series(
                        Series::new("failed (stopped early) or no <Y>", Mark::Points, none)
                            .with_color(8),
                    );
                }
                f
            }
            [x] => Figure::new(&title, &x.name(), "MEGNO <Y>").with_series(Series::new(
                "<Y>",
                Mark::LinePoints,
                results
                    .iter()
                    .filter_map(|r| Some((axis_value(x, r, d)?, value(r)?))),
            )),
            [] => continue,
        };
        figs.push((format!("chaos_map_{}", m.label), f));
    }
    figs
}

/// Where the raster chaos map puts white (`<Y>` of a quasi-periodic orbit tends to 2) and
/// where its red saturates (well past the chaotic class's lower bound, 20 would wash out the
/// weakly chaotic members).
const RASTER_REGULAR: f64 = 2.0;
const RASTER_CHAOTIC: f64 = 10.0;

/// The chaos maps of a grid over two axes as rasters, per method: one cell per member at its
/// place on the grid, coloured by `<Y>` on a scale white at 2 (regular), blue towards 0
/// (periodic orbits), red from 2 to 10 and beyond (chaotic); grey where the member has no
/// `<Y>` (skipped by the energy shell, not run, or stopped early). Empty for other samplers
/// (the class scatter of [`chaos_figures`] draws those).
fn chaos_rasters(
    scene: &Scene,
    members: &Members,
    results: &[MemberResult],
) -> Vec<(String, Raster)> {
    let Sampler::Grid {
        x: (x, nx),
        y: Some((y, ny)),
    } = &members.sampler
    else {
        return Vec::new();
    };
    let (nx, ny) = (*nx, *ny);
    // Cells centred on the grid's values (at least 2 a side: validation).
    let half = |from: f64, to: f64, n: usize| 0.5 * (to - from) / (n.max(2) - 1) as f64;
    let (hx, hy) = (half(x.from, x.to, nx), half(y.from, y.to, ny));
    let mut rasters = Vec::new();
    for (mi, m) in scene.methods.iter().enumerate() {
        // Row r (y, bottom first), column c (x): the member at x index c, y index r (the grid
        // varies x slowest, so its index is c * ny + r).
        let mut values = vec![f64::NAN; nx * ny];
        for r in results {
            let megno = r
                .runs
                .get(mi)
                .filter(|run| run.failure.is_none())
                .and_then(|run| run.megno);
            if let (Some(v), true) = (megno, r.index < nx * ny) {
                let (c, row) = (r.index / ny, r.index % ny);
                values[row * nx + c] = v;
            }
        }
        let title = format!("{}: {}, MEGNO <Y> over the grid", scene.title, m.label);
        let raster = Raster::new(
            &title,
            &x.axis.name(),
            &y.axis.name(),
            (x.from - hx, x.to + hx),
            (y.from - hy, y.to + hy),
            values,
            nx,
            "MEGNO <Y> (2: regular)",
        )
        .with_scale(0.0, RASTER_REGULAR, RASTER_CHAOTIC);
        rasters.push((format!("chaos_map_{}", m.label), raster));
    }
    rasters
}

/// Writes every file of the ensemble into `dir` (`step_check` into the counts); returns
/// their names.
pub fn write(
    dir: &Path,
    scene: &Scene,
    members: &Members,
    d: usize,
    results: &[MemberResult],
    step_check: Option<StepCheck>,
) -> Result<(Vec<String>, Counts), Error> {
    let mut files = Vec::new();
    let t = table(scene, results, step_check);
    write_file(&dir.join("ensemble.csv"), csv(scene, d, &t))?;
    files.push("ensemble.csv".to_string());
    write_json(&dir.join("ensemble.json"), &t)?;
    files.push("ensemble.json".to_string());
    let mut figs = Vec::new();
    if !sections(scene).is_empty() {
        write_file(&dir.join("ensemble_crossings.csv"), crossings_csv(results))?;
        files.push("ensemble_crossings.csv".to_string());
        figs.extend(section_figures(scene, results));
    }
    if members.chaos.is_some() {
        let rasters = chaos_rasters(scene, members, results);
        if rasters.is_empty() {
            figs.extend(chaos_figures(scene, members, d, results));
        }
        for (stem, r) in rasters {
            r.render(dir, &stem)?;
            files.push(format!("{stem}.png"));
            files.push(format!("{stem}.svg"));
        }
    }
    for (stem, f) in figs {
        f.render(dir, &stem)?;
        files.push(format!("{stem}.png"));
        files.push(format!("{stem}.svg"));
    }
    Ok((files, t.counts))
}

/// `index.html` of an ensemble run: what ran, the counts, the figures and the tables.
pub fn index(scene: &Scene, counts: &Counts, files: &[String]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n\
         <style>body{{font-family:sans-serif;max-width:1000px;margin:2em auto;padding:0 1em}}\
         img{{max-width:100%;border:1px solid #ddd}}</style></head><body>\n<h1>{t}</h1>\n",
        t = escape(&scene.title)
    );
    if !scene.description.is_empty() {
        let _ = writeln!(h, "<p>{}</p>", escape(&scene.description));
    }
    let methods: Vec<&str> = scene.methods.iter().map(|m| m.label.as_str()).collect();
    let _ = writeln!(
        h,
        "<p>System <b>{}</b>; {} members drawn, {} skipped (no real solution on the energy shell), {} not run, {} method runs failed{}{}; methods {}; duration {} each.</p>",
        escape(&scene.system),
        counts.drawn,
        counts.skipped,
        counts.not_run,
        counts.failed_runs,
        counts.fallback_note(),
        escape(&counts.step_check_note()),
        escape(&methods.join(", ")),
        scene.duration
    );
    for f in files.iter().filter(|f| f.ends_with(".png")) {
        let _ = writeln!(h, "<p><img src=\"{0}\" alt=\"{0}\"></p>", escape(f));
    }
    h.push_str("<ul>\n");
    for f in files
        .iter()
        .filter(|f| !f.ends_with(".png") && !f.ends_with(".svg"))
    {
        let _ = writeln!(h, "<li><a href=\"{0}\">{0}</a></li>", escape(f));
    }
    h.push_str("</ul>\n</body></html>\n");
    h
}

#[cfg(test)]
mod raster_tests {
    use super::super::member::MemberRun;
    use super::*;
    use crate::catalogue::Catalogue;

    /// A member of a grid with `<Y>` = its index (the one method), or none.
    fn member(index: usize, megno: Option<f64>) -> MemberResult {
        MemberResult {
            index,
            params: BTreeMap::new(),
            start: Some(vec![0.0; 4]),
            not_run: None,
            skipped: megno.is_none(),
            runs: vec![MemberRun {
                method: "dth".into(),
                steps: 1,
                t_end: 1.0,
                end: vec![0.0; 4],
                energy_error: 0.0,
                fallback_steps: 0,
                failure: None,
                megno,
                lyapunov: None,
                sali: None,
                crossings: Vec::new(),
            }],
        }
    }

    #[test]
    fn each_member_is_the_cell_at_its_grid_values() {
        let text = "title = \"HH\"\n[system]\nname = \"henon_heiles\"\n[initial]\nq = [0.0, 0.0]\n\
                    p = [0.0, 0.0]\n[ensemble]\nkind = \"grid\"\nx = \"q2\"\nx_range = [-0.3, 0.3]\n\
                    x_count = 4\ny = \"p2\"\ny_range = [0.0, 0.2]\ny_count = 3\nchaos = \"megno\"\n\
                    [[method]]\nkind = \"dth\"\ndtau = 0.1\n[duration]\ntime = 1.0\n";
        let scene = crate::check_scene(text, "g.toml", &Catalogue::builtin()).unwrap();
        let members = scene.members.clone().unwrap();
        // Index 5 (x index 1, y index 2) has no <Y>: grey (NaN).
        let results: Vec<MemberResult> = (0..12)
            .map(|i| member(i, (i != 5).then_some(i as f64)))
            .collect();
        let rasters = chaos_rasters(&scene, &members, &results);
        assert_eq!(rasters.len(), 1);
        let (stem, r) = &rasters[0];
        assert_eq!(stem, "chaos_map_dth");
        assert_eq!(r.cols(), 4);
        let v = r.values();
        assert_eq!(v.len(), 12);
        for row in 0..3 {
            for c in 0..4 {
                let index = c * 3 + row;
                let cell = v[row * 4 + c];
                if index == 5 {
                    assert!(cell.is_nan());
                } else {
                    assert_eq!(cell, index as f64, "x {c}, y {row}");
                }
            }
        }
        // A random sampler draws no raster (the class scatter does).
        let random = text
            .replace("kind = \"grid\"", "kind = \"random\"")
            .replace("x_count = 4\n", "")
            .replace("y_count = 3\n", "samples = 12\n");
        let scene = crate::check_scene(&random, "r.toml", &Catalogue::builtin()).unwrap();
        let members = scene.members.clone().unwrap();
        assert!(chaos_rasters(&scene, &members, &results).is_empty());
    }
}
