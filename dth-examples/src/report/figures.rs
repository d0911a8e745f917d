//! The figures of a scene's effects: energy and invariant deviations, the time law, Poincare
//! sections, phase plots, normal-mode energies and ensembles, one PNG and one SVG each.

use std::path::Path;

use crate::effects::{DeviationStats, ModeEnergies, Series, SpaceTimeRow};
use crate::error::Error;
use crate::plot::{Figure, Mark, Raster, Series as PlotSeries};
use crate::scene::{Coord, EffectSpec, Scene};
use crate::simulate::MethodResult;

/// Draws the figures of the scene's effects (PNG and SVG) into `dir`; returns their names.
pub fn write(
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
    let mut seen_modes = false;
    let mut files = Vec::new();
    for spec in &scene.effects {
        match spec {
            EffectSpec::EnergyDeviation { .. } if !seen_energy => {
                seen_energy = true;
                let f = deviation_figure(
                    &format!("{}: energy deviation", scene.title),
                    "|H - H0|",
                    results
                        .iter()
                        .filter_map(|r| Some((r, r.outputs.energy.as_ref()?))),
                    " (midpoints)",
                );
                figs.push(("energy_deviation".into(), f));
            }
            EffectSpec::Invariants { .. } if !seen_invariants => {
                seen_invariants = true;
                for (j, name) in invariant_names.iter().enumerate() {
                    let f = deviation_figure(
                        &format!("{}: {name} deviation", scene.title),
                        &format!("|{name} - {name}0|"),
                        results
                            .iter()
                            .filter_map(|r| Some((r, r.outputs.invariants.as_ref()?.get(j)?))),
                        "",
                    );
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
                        let l = &series_name(r);
                        ft = ft.with_series(PlotSeries::new(
                            l,
                            Mark::Line,
                            rows.iter().map(|p| (p.0 as f64, p.1)),
                        ));
                        if rows.iter().any(|p| p.2.is_some()) {
                            fl = fl.with_series(PlotSeries::new(
                                l,
                                Mark::Line,
                                rows.iter()
                                    .filter_map(|p| p.2.map(|lambda| (p.0 as f64, lambda))),
                            ));
                        }
                    }
                }
                figs.push(("time_law_t".into(), ft));
                if !fl.series.is_empty() {
                    figs.push(("time_law_lambda".into(), fl));
                }
            }
            EffectSpec::Poincare { .. } | EffectSpec::Stroboscopic { .. } => {
                let Some((name, x, y)) = spec.section() else {
                    continue;
                };
                let mut f = Figure::new(&format!("{}: {name}", scene.title), &x.name(), &y.name());
                for r in results {
                    if let Some(c) = r.outputs.poincare.get(poincare_i) {
                        f = f.with_series(PlotSeries::new(
                            &series_name(r),
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
                            &series_name(r),
                            Mark::Line,
                            pts.iter().map(|&(_, x, y)| (x, y)),
                        ));
                    }
                }
                phase_i += 1;
                figs.push((format!("phase{phase_i}"), f));
            }
            EffectSpec::NormalModes { .. } if !seen_modes => {
                seen_modes = true;
                for r in results {
                    if let Some(rows) = &r.outputs.normal_modes {
                        figs.push((
                            format!("normal_modes_{}", r.summary.label),
                            mode_energy_figure(&scene.title, r, rows),
                        ));
                    }
                }
            }
            EffectSpec::SpaceTime { .. } => {
                for r in results {
                    if let Some(rows) = &r.outputs.space_time {
                        let stem = format!("space_time_{}", r.summary.label);
                        if let Some(raster) =
                            space_time_figure(&scene.title, r, rows, scene.q.len())
                        {
                            raster.render(dir, &stem)?;
                            files.push(format!("{stem}.png"));
                            files.push(format!("{stem}.svg"));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    // Scenes with the thesis's figures draw their ensembles as Figures 4.10-4.13 instead.
    if let (Some(e), false) = (&scene.ensemble, scene.thesis_figures) {
        for r in results {
            let Some(members) = &r.ensemble else { continue };
            let (ix, iy) = (e.x, e.y);
            let idx = |c: Coord, z: &[f64]| c.index(z.len()).and_then(|i| z.get(i).copied());
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
    for (stem, f) in figs {
        f.render(dir, &stem)?;
        files.push(format!("{stem}.png"));
        files.push(format!("{stem}.svg"));
    }
    Ok(files)
}

/// A log-scale figure of deviation series against `t`: per method its states' series
/// (labelled with `points_suffix` when it also has vertices) and its vertices' series.
fn deviation_figure<'r>(
    title: &str,
    y_label: &str,
    series: impl Iterator<Item = (&'r MethodResult, &'r (DeviationStats, Series, Series))>,
    points_suffix: &str,
) -> Figure {
    let mut f = Figure::new(title, "t", y_label).with_log(false, true);
    for (r, (_, points, vertices)) in series {
        let label = &series_name(r);
        let name = if vertices.is_empty() {
            label.clone()
        } else {
            format!("{label}{points_suffix}")
        };
        f = f.with_series(PlotSeries::new(
            &name,
            Mark::Line,
            points.iter().map(|p| (p.1, p.2)),
        ));
        if !vertices.is_empty() {
            f = f.with_series(PlotSeries::new(
                &format!("{label} (vertices)"),
                Mark::Line,
                vertices.iter().map(|p| (p.1, p.2)),
            ));
        }
    }
    f
}

/// The most rows the space-time raster draws (a figure of 650 pixels shows no more): of more
/// samples every k-th is drawn. Not their mean: a displacement that oscillates faster than a
/// row would average to nothing. The CSV keeps every sample.
const SPACE_TIME_ROWS: usize = 200;

/// The `space_time` raster of one method's run: site against `t`, colour = displacement;
/// `None` without samples. `sites` is the chain's `n`.
fn space_time_figure(
    title: &str,
    r: &MethodResult,
    rows: &[SpaceTimeRow],
    sites: usize,
) -> Option<Raster> {
    let stride = rows.len().div_ceil(SPACE_TIME_ROWS).max(1);
    let drawn: Vec<&SpaceTimeRow> = rows.iter().step_by(stride).collect();
    let (first, last) = (drawn.first()?, drawn.last()?);
    let cols = first.q.len();
    let values: Vec<f64> = drawn.iter().flat_map(|row| row.q.iter().copied()).collect();
    Some(Raster::new(
        &format!("{title}: displacement, {}", series_name(r)),
        "site i",
        "t",
        (0.5, sites as f64 + 0.5),
        (first.t, last.t),
        values,
        cols,
        "q_i",
    ))
}

/// The energies `E_1..E_k` of the normal modes against `t`, one line per mode (FPUT's
/// Figure 1), for one method.
fn mode_energy_figure(title: &str, r: &MethodResult, rows: &[ModeEnergies]) -> Figure {
    let k = rows.first().map_or(0, |r| r.energies.len());
    let mut f = Figure::new(
        &format!("{title}: normal-mode energies, {}", series_name(r)),
        "t",
        "E_k",
    );
    for mode in 0..k {
        f = f.with_series(PlotSeries::new(
            &format!("mode {}", mode + 1),
            Mark::Line,
            rows.iter().map(|row| (row.t, row.energies[mode])),
        ));
    }
    f
}

/// A method's name in a figure's legend: its label, marked when the method stopped early (a
/// figure of it ends there).
fn series_name(r: &MethodResult) -> String {
    match &r.failure {
        Some(f) => format!("{} (stopped: failed at step {})", r.summary.label, f.step),
        None => r.summary.label.clone(),
    }
}
