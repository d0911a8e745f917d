//! Table 4.1 of the thesis: average absolute deviation of energy and angular momentum over
//! 10,000 steps of the Kepler experiment, ours beside the thesis's.
//!
//! The settings are the embedded default scene's (`scenes/thesis-kepler.toml`); the numbers
//! come from the same pipeline as `dth run` ([`crate::run::compute`] with the
//! `comparison_table` effect only, through [`crate::method::run_method`]).

use dth::systems::Kepler;
use serde::Serialize;

use crate::catalogue::Catalogue;
use crate::error::Error;
use crate::run::{compute, MethodSummary, RunOptions};
use crate::scene::{EffectSpec, MethodKind};

/// The thesis's values (NOTES.md): `(method, energy, angular momentum)`.
pub const THESIS: [(&str, f64, f64); 5] = [
    ("trapezoidal", 1.322e-1, 4.593e-2),
    ("midpoint", 5.969e-2, 7.387e-16),
    ("discrete_mechanics", 3.901e-15, 1.738e-15),
    ("dth_midpoints", 1.285e-14, 8.204e-4),
    ("dth_vertices", 1.750e-2, 2.221e-15),
];

/// One row of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// `trapezoidal`, `midpoint`, `discrete_mechanics`, `dth_midpoints` or `dth_vertices`.
    pub method: String,
    /// Average absolute energy deviation.
    pub energy: f64,
    /// Average absolute angular momentum deviation.
    pub angular_momentum: f64,
}

/// The table as `--json` writes it: `{"rows": [...]}`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table {
    /// Rows in the thesis's order.
    pub rows: Vec<Row>,
}

/// Computes the table with the default scene's settings.
pub fn compute_table(options: &RunOptions) -> Result<Table, Error> {
    let catalogue = Catalogue::builtin();
    let mut scene =
        crate::check_scene(crate::DEFAULT_SCENE, crate::DEFAULT_SCENE_NAME, &catalogue)?;
    scene.effects = vec![EffectSpec::ComparisonTable];
    // The table needs neither the square of initial conditions nor the figures.
    scene.ensemble = None;
    scene.thesis_figures = false;
    scene.methods.retain(|m| {
        matches!(
            m.kind,
            MethodKind::Trapezoidal
                | MethodKind::Midpoint
                | MethodKind::DiscreteMechanics
                | MethodKind::Dth
        )
    });
    let kepler = Kepler {
        mass: scene.params.get("mass").copied().unwrap_or(0.5),
        k: scene.params.get("k").copied().unwrap_or(1.0),
    };
    let results = compute(&kepler, &scene, options)?;
    let summaries: Vec<MethodSummary> = results.into_iter().map(|r| r.summary).collect();
    if let Some(s) = summaries.iter().find(|s| s.failure.is_some()) {
        let f = s
            .failure
            .as_ref()
            .map_or((0, String::new()), |f| (f.step, f.reason.clone()));
        return Err(Error::MethodFailed {
            method: s.label.clone(),
            step: f.0,
            reason: f.1,
        });
    }
    Ok(rows_from(&summaries))
}

/// The table's rows from a run's method summaries (methods without energy and angular
/// momentum statistics, or not in the thesis's table, are skipped; DTH gives two rows).
pub fn rows_from(methods: &[MethodSummary]) -> Table {
    let mut rows = Vec::new();
    for s in methods {
        let (Some(e), Some(l)) = (&s.energy, s.invariants.first()) else {
            continue;
        };
        if s.kind == "dth" {
            rows.push(Row {
                method: "dth_midpoints".into(),
                energy: e.points.mean,
                angular_momentum: l.points.mean,
            });
            if let (Some(ev), Some(lv)) = (e.vertices, l.vertices) {
                rows.push(Row {
                    method: "dth_vertices".into(),
                    energy: ev.mean,
                    angular_momentum: lv.mean,
                });
            }
        } else if THESIS.iter().any(|t| t.0 == s.kind) {
            rows.push(Row {
                method: s.kind.clone(),
                energy: e.points.mean,
                angular_momentum: l.points.mean,
            });
        }
    }
    Table { rows }
}

/// The table as markdown, ours beside the thesis's.
pub fn markdown(table: &Table) -> String {
    let mut s = String::from(
        "| method | energy (ours) | energy (thesis) | angular momentum (ours) | angular momentum (thesis) |\n\
         |---|---:|---:|---:|---:|\n",
    );
    for r in &table.rows {
        let thesis = THESIS.iter().find(|t| t.0 == r.method);
        let (te, tl) = thesis.map_or(("-".into(), "-".into()), |t| {
            (format!("{:.3e}", t.1), format!("{:.3e}", t.2))
        });
        s.push_str(&format!(
            "| {} | {:.3e} | {} | {:.3e} | {} |\n",
            r.method, r.energy, te, r.angular_momentum, tl
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_puts_thesis_values_beside_ours() {
        let t = Table {
            rows: vec![Row {
                method: "midpoint".into(),
                energy: 0.0597,
                angular_momentum: 1e-16,
            }],
        };
        let md = markdown(&t);
        assert!(
            md.contains("| midpoint | 5.970e-2 | 5.969e-2 | 1.000e-16 | 7.387e-16 |"),
            "{md}"
        );
        let json = serde_json::to_value(&t).unwrap_or_default();
        assert_eq!(json["rows"][0]["method"], "midpoint");
    }
}
