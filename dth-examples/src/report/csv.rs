//! CSV files: one per effect and method, `LABEL_<effect>.csv`, plus the ensemble's.
//!
//! Every file that holds states has a `t` column. The trajectory's `row` column says what
//! each row's state is: `midpoint` (a DTH step's midpoint `zbar`, at the midpoint's time:
//! the points DTH's energy is exact at), `vertex` (DTH's initial state, the first vertex of
//! its path) or `step` (the state after a step of a fixed-step method or of a fallback
//! step, and a fixed-step method's initial state). Rows have the header's number of cells:
//! a value a row does not have (DTH's `lambda` on a fixed-step row, the vertex of DTH's last,
//! shortened step) is an empty cell. A trajectory at chosen times (`every_time`, `times`)
//! has a row at each of them: the method's own state landed on there (a DTH midpoint of a
//! step shortened onto the time, `step_kind` `shortened`; `step` is the index of the step it
//! shortens), the same times for every method.
//!
//! A scene with events writes `LABEL_events.csv` per method: one row per event that fired
//! (`event`, its located `t`, the state there, `action` `record` or `stop`).
//!
//! Each trajectory is also written as `LABEL_trajectory.npy` ([`super::npy`]) for readers that
//! do not parse CSV: a `rows x (3 + D)` array of the CSV's numeric columns in its order,
//! `step, t, <state>, lambda` (`lambda` NaN for fixed-step methods); `step_kind` and `row`
//! are in the CSV only. The trajectories are the arrays a reader loads whole; the other
//! series are small and stay CSV only.

use std::fmt::Write as _;
use std::path::Path;

use super::write_file;
use crate::effects::{Series, TrajectoryRow};
use crate::error::Error;
use crate::fallback::kind_name;
use crate::scene::{component_names, EffectSpec, Scene};
use crate::simulate::MethodResult;
use dth::observer::StepKind;

/// Writes the CSV files of every method's effects into `dir`; returns their names.
pub fn write(dir: &Path, scene: &Scene, results: &[MethodResult]) -> Result<Vec<String>, Error> {
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
            let mut s = format!(
                "step,t,{},lambda,step_kind,row\n",
                component_names(scene.q.len(), d).join(",")
            );
            for r in rows {
                let _ = write!(s, "{},{:e}", r.step, r.t);
                for x in &r.z {
                    let _ = write!(s, ",{x:e}");
                }
                let _ = writeln!(
                    s,
                    ",{},{},{}",
                    r.lambda.map_or(String::new(), |v| format!("{v:e}")),
                    kind_name(r.kind),
                    row_kind(r)
                );
            }
            put(format!("{l}_trajectory.csv"), s, &mut files)?;
            // The same rows as an array for readers that do not parse CSV: the numeric
            // columns in the CSV's order (`lambda` NaN where the CSV cell is empty).
            let width = d + 3;
            let mut values = Vec::with_capacity(rows.len() * width);
            for r in rows {
                values.push(r.step as f64);
                values.push(r.t);
                values.extend_from_slice(&r.z);
                values.push(r.lambda.unwrap_or(f64::NAN));
            }
            let name = format!("{l}_trajectory.npy");
            super::npy::write(&dir.join(&name), rows.len(), width, &values)?;
            files.push(name);
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
        if !scene.events.is_empty() {
            // Every event that fired, at its located time; a header only when none did.
            let d = r.summary.events.first().map_or(0, |e| e.z.len());
            let mut s = format!(
                "event,t,{},action\n",
                component_names(scene.q.len(), d).join(",")
            );
            for e in &r.summary.events {
                let _ = write!(s, "{},{:e}", e.name, e.t);
                for x in &e.z {
                    let _ = write!(s, ",{x:e}");
                }
                let _ = writeln!(s, ",{}", if e.stopped { "stop" } else { "record" });
            }
            put(format!("{l}_events.csv"), s, &mut files)?;
        }
        if let Some(rows) = &o.time_law {
            let mut s = String::from("step,t,lambda\n");
            for (k, t, lambda) in rows {
                let lambda = lambda.map_or(String::new(), |v| format!("{v:e}"));
                let _ = writeln!(s, "{k},{t:e},{lambda}");
            }
            put(format!("{l}_time_law.csv"), s, &mut files)?;
        }
        let sections = scene.effects.iter().filter_map(EffectSpec::section);
        for (i, (c, (_, x, y))) in o.poincare.iter().zip(sections).enumerate() {
            let (x, y) = (x.name(), y.name());
            let mut s = format!("t,{x},{y}\n");
            for (t, x, y) in c {
                let _ = writeln!(s, "{t:e},{x:e},{y:e}");
            }
            put(format!("{l}_poincare{}.csv", i + 1), s, &mut files)?;
        }
        if let Some(rows) = &o.normal_modes {
            let k = rows.first().map_or(0, |r| r.energies.len());
            let columns: Vec<String> = (1..=k).map(|k| format!("E{k}")).collect();
            let mut s = format!("step,t,{}\n", columns.join(","));
            for r in rows {
                let _ = write!(s, "{},{:e}", r.step, r.t);
                for e in &r.energies {
                    let _ = write!(s, ",{e:e}");
                }
                s.push('\n');
            }
            put(format!("{l}_normal_modes.csv"), s, &mut files)?;
        }
        if let Some(rows) = &o.space_time {
            let sites = scene.q.len();
            let columns = rows.first().map_or(0, |r| r.q.len());
            let names: Vec<String> = crate::effects::site_groups(sites, columns)
                .map(|g| match g.len() {
                    1 => format!("q{}", g.start + 1),
                    _ => format!("q{}-q{}", g.start + 1, g.end),
                })
                .collect();
            let mut s = format!("t,{}\n", names.join(","));
            for r in rows {
                let _ = write!(s, "{:e}", r.t);
                for q in &r.q {
                    let _ = write!(s, ",{q:e}");
                }
                s.push('\n');
            }
            put(format!("{l}_space_time.csv"), s, &mut files)?;
        }
        if let Some(members) = &r.ensemble {
            let d = members
                .iter()
                .find_map(|m| m.end.as_ref().ok().map(|e| e.1.len()))
                .unwrap_or(0);
            let mut s = format!(
                "x0,y0,t,{},failure,fallback_steps\n",
                component_names(scene.q.len(), d).join(",")
            );
            for m in members {
                let _ = write!(s, "{:e},{:e}", m.x0, m.y0);
                match &m.end {
                    Ok((t, z)) => {
                        let _ = write!(s, ",{t:e}");
                        for x in z {
                            let _ = write!(s, ",{x:e}");
                        }
                        s.push(',');
                    }
                    Err(f) => {
                        let _ = write!(
                            s,
                            ",{}step {}: {}",
                            ",".repeat(d + 1),
                            f.step,
                            f.reason.replace(',', ";")
                        );
                    }
                }
                let _ = writeln!(s, ",{}", m.fallback_steps);
            }
            put(format!("{l}_ensemble.csv"), s, &mut files)?;
        }
        for (i, (pts, (x, y))) in o.phase.iter().zip(phase_axes(scene)).enumerate() {
            // `t` first, unless it is one of the plot's axes already.
            let with_t = x != "t" && y != "t";
            let mut s = if with_t {
                format!("t,{x},{y}\n")
            } else {
                format!("{x},{y}\n")
            };
            for (t, x, y) in pts {
                if with_t {
                    let _ = write!(s, "{t:e},");
                }
                let _ = writeln!(s, "{x:e},{y:e}");
            }
            put(format!("{l}_phase{}.csv", i + 1), s, &mut files)?;
        }
    }
    Ok(files)
}

/// The `(x, y)` coordinate names of the scene's phase plots, in scene order: the columns of
/// their CSV files (`q1,p1`, `t,q1`).
fn phase_axes(scene: &Scene) -> Vec<(String, String)> {
    scene
        .effects
        .iter()
        .filter_map(|e| match e {
            EffectSpec::PhasePlot { x, y, .. } => Some((x.name(), y.name())),
            _ => None,
        })
        .collect()
}

/// What a trajectory row's state is (the `row` column, see the module docs).
fn row_kind(r: &TrajectoryRow) -> &'static str {
    match (r.step, r.kind) {
        (0, StepKind::Dth | StepKind::Shortened) => "vertex",
        (_, StepKind::Dth | StepKind::Shortened) => "midpoint",
        _ => "step",
    }
}

fn csv_series(header: &str, a: &Series, b: &Series) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{header}");
    for (i, &(k, t, d)) in a.iter().enumerate() {
        let _ = write!(s, "{k},{t:e},{d:e}");
        if let Some(&(_, tv, dv)) = b.get(i) {
            let _ = write!(s, ",{tv:e},{dv:e}");
        } else if !b.is_empty() {
            // No vertex for this row (DTH's last step, shortened to end on time): empty
            // cells, so that every row has the header's columns.
            s.push_str(",,");
        }
        s.push('\n');
    }
    s
}
