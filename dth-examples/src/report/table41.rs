//! Table 4.1 of the thesis: average absolute deviation of energy and angular momentum over a
//! run of the Kepler experiment, ours beside the thesis's (`dth::kepler::THESIS_TABLE_4_1`).
//!
//! The rows come from a run's method summaries ([`rows_from`]): the statistics of the
//! `comparison_table` (or `energy_deviation` and `invariants`) effect, the same pipeline as
//! `dth run`.

use dth::kepler::{Table41Row, THESIS_TABLE_4_1};
use serde::Serialize;

use crate::simulate::MethodSummary;

/// The thesis's row for `method` (`trapezoidal`, ..., `dth_vertices`), if it has one.
pub fn thesis(method: &str) -> Option<Table41Row> {
    THESIS_TABLE_4_1.into_iter().find(|r| r.method == method)
}

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
        } else if thesis(&s.kind).is_some() {
            rows.push(Row {
                method: s.kind.clone(),
                energy: e.points.mean,
                angular_momentum: l.points.mean,
            });
        }
    }
    Table { rows }
}

/// The thesis's energy and angular momentum for `method`, formatted as in the table (`-` where
/// the thesis has no such row).
pub fn thesis_cells(method: &str) -> (String, String) {
    thesis(method).map_or(("-".into(), "-".into()), |t| {
        (
            format!("{:.3e}", t.energy),
            format!("{:.3e}", t.angular_momentum),
        )
    })
}

/// The table as markdown, ours beside the thesis's.
pub fn markdown(table: &Table) -> String {
    let mut s = String::from(
        "| method | energy (ours) | energy (thesis) | angular momentum (ours) | angular momentum (thesis) |\n\
         |---|---:|---:|---:|---:|\n",
    );
    for r in &table.rows {
        let (te, tl) = thesis_cells(&r.method);
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
