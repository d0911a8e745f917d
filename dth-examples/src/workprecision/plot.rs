//! Work-precision diagrams: error against wall time, log-log, one curve per method, as PNG and
//! SVG, drawn with the crate's [`plot`](crate::plot) module.

use std::path::{Path, PathBuf};

use crate::plot::{Figure, Mark, Series};

use super::problem::ProblemInfo;
use super::problems::dth_order;
use super::report::error_of;
use super::{Error, Record};

/// Errors below this are drawn at it (a log axis has no zero); the captions say so.
const FLOOR: f64 = 1e-17;

/// One curve: label and points `(time, error)` sorted by time.
struct Curve {
    label: String,
    points: Vec<(f64, f64)>,
}

/// Which methods a figure shows. The shared palette has 10 colours, so figures keep to 10
/// curves:
/// - DTH is shown as `dth_joint`, the default solver a user gets; `dth_joint_scaled_stall`
///   (the same equations and residual tolerance with a stall rule scaled to the energy
///   equation's conditioning) is left out of the main figures: where both converge their
///   errors agree (tables and data keep it);
/// - energy and invariant figures leave out `dth_nested` (same values as the joint solver,
///   only slower) to make room for the vertex curve of `dth_joint`;
/// - `_generated` variants go to their own figure ([`Selection::Derivatives`]), beside the
///   hand-written `dth_joint_scaled_stall` they are run with.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Selection {
    Main,
    Derivatives,
}

fn shown(method: &str, kind: &str, selection: Selection) -> bool {
    match selection {
        Selection::Main => {
            !method.ends_with("_generated")
                && method != "dth_joint_scaled_stall"
                && !(kind != "global" && method == "dth_nested")
        }
        Selection::Derivatives => {
            method.ends_with("_generated")
                || method == "dth_joint_scaled_stall"
                || method == "midpoint"
                || method == "gauss_legendre2"
        }
    }
}

fn curves(records: &[Record], system: &str, kind: &str, selection: Selection) -> Vec<Curve> {
    let mut methods: Vec<&str> = Vec::new();
    for r in records.iter().filter(|r| r.system == system) {
        if !methods.contains(&r.method) && shown(r.method, kind, selection) {
            methods.push(r.method);
        }
    }
    let mut out = Vec::new();
    for m in &methods {
        let runs: Vec<&Record> = records
            .iter()
            .filter(|r| r.system == system && r.method == *m && r.failure.is_none())
            .filter(|r| r.time.is_finite() && r.time > 0.0)
            .collect();
        let mut series = |label: String, f: &dyn Fn(&Record) -> f64| {
            let mut points: Vec<(f64, f64)> = runs
                .iter()
                .map(|r| (r.time, f(r)))
                .filter(|(_, e)| e.is_finite())
                .map(|(t, e)| (t, e.max(FLOOR)))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            if !points.is_empty() {
                out.push(Curve { label, points });
            }
        };
        let dth = m.starts_with("dth");
        let suffix = if dth && kind != "global" {
            " (midpoints)"
        } else {
            ""
        };
        series(format!("{m}{suffix}"), &|r| error_of(r, kind));
        // Vertex series for plain DTH only (above order 2 the vertices keep no invariant).
        if dth_order(m) == Some(2) && selection == Selection::Main {
            match kind {
                "energy" => series(format!("{m} (vertices)"), &|r| {
                    r.vertex_energy_error.unwrap_or(f64::NAN)
                }),
                "invariant" => series(format!("{m} (vertices)"), &|r| {
                    r.vertex_invariant_error.unwrap_or(f64::NAN)
                }),
                _ => {}
            }
        }
    }
    out
}

/// One PNG + SVG per problem and error kind (global, energy, and the invariant where there is
/// one), named `<system>_<kind>`.
pub(crate) fn diagrams(
    records: &[Record],
    infos: &[ProblemInfo],
    out: &Path,
) -> Result<Vec<PathBuf>, Error> {
    let mut files = Vec::new();
    for info in infos {
        let mut kinds = vec![
            (
                "global",
                format!("global error at T = {:.3} (phase-space norm)", info.t_end),
            ),
            (
                "energy",
                format!(
                    "max |H - H(z0)| (DTH vertices: vs. first vertex; < {FLOOR:.0e} drawn at it)"
                ),
            ),
        ];
        if let Some(name) = info.invariant {
            kinds.push((
                "invariant",
                format!("max |{name} deviation| (DTH vertices: vs. first vertex)"),
            ));
        }
        let derivatives = records
            .iter()
            .any(|r| r.system == info.name && r.method.ends_with("_generated"));
        for (kind, y_label) in kinds {
            let mut figures = vec![(
                format!("{}: {kind} error vs. wall time", info.title),
                format!("{}_{kind}", info.name),
                Selection::Main,
            )];
            if derivatives && kind == "global" {
                figures.push((
                    format!("{}: hand-written vs. generated derivatives", info.title),
                    format!("{}_derivatives_{kind}", info.name),
                    Selection::Derivatives,
                ));
            }
            for (title, stem, selection) in figures {
                let mut figure = Figure::new(
                    &title,
                    "wall time to reach T (s), median of repeats",
                    &y_label,
                )
                .with_log(true, true);
                // Tall enough for the legend of every method (up to 14 entries, below the chart).
                figure.size = (1100, 950);
                for c in curves(records, info.name, kind, selection) {
                    figure = figure.with_series(Series::new(&c.label, Mark::Line, c.points));
                }
                files.extend(figure.render(out, &stem)?);
            }
        }
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every method of the Kepler sweep (the largest), `_generated` variants included.
    const KEPLER: [&str; 18] = [
        "dth_joint",
        "dth_nested",
        "dth_joint_scaled_stall",
        "midpoint",
        "trapezoidal",
        "discrete_gradient",
        "verlet",
        "rk4",
        "gauss_legendre2",
        "dop853",
        "discrete_mechanics",
        "dth_joint_scaled_stall_generated",
        "midpoint_generated",
        "gauss_legendre2_generated",
        "dth_nested_generated",
        "dth4",
        "dth6",
        "dth8",
    ];

    /// Every method of the robust sweep (Kepler e = 0.9; plain DTH fails there, but counts
    /// here).
    const KEPLER_ROBUST: [&str; 12] = [
        "dth_joint",
        "dth8",
        "dth_robust",
        "dth8_robust",
        "midpoint",
        "trapezoidal",
        "discrete_gradient",
        "verlet",
        "rk4",
        "gauss_legendre2",
        "dop853",
        "discrete_mechanics",
    ];

    /// Every method of the regularized sweep (Kepler e = 0.9 over 100 orbits).
    const KEPLER_REGULARIZED: [&str; 7] = [
        "dth_lc",
        "dth8_lc",
        "dth_robust",
        "dth8_robust",
        "gauss_legendre2",
        "discrete_gradient",
        "dop853",
    ];

    #[test]
    fn the_default_solver_has_a_curve_in_every_main_figure() {
        for kind in ["global", "energy", "invariant"] {
            assert!(shown("dth_joint", kind, Selection::Main), "{kind}");
            assert!(shown("dth_robust", kind, Selection::Main), "{kind}");
            // Within the palette: DTH of order 2 draws midpoints and vertices on energy and
            // invariants.
            for methods in [&KEPLER[..], &KEPLER_ROBUST[..], &KEPLER_REGULARIZED[..]] {
                let curves: usize = methods
                    .iter()
                    .filter(|m| shown(m, kind, Selection::Main))
                    .map(|m| {
                        if dth_order(m) == Some(2) && kind != "global" {
                            2
                        } else {
                            1
                        }
                    })
                    .sum();
                assert!(curves <= PALETTE_SIZE, "{kind}: {curves} curves");
            }
        }
    }

    const PALETTE_SIZE: usize = crate::plot::PALETTE.len();
}
