//! The log-log figure of `docs/performance.md` ("Cost against system size"): one implicit-midpoint
//! step against the number of particles, structured and dense Newton, and one DTH step
//! (structured), FPUT-alpha and Toda, read from the medians criterion stored for the
//! `step_vs_size` bench.
//!
//! ```sh
//! cargo bench -p dth-examples --bench step_vs_size -- --noplot
//! cargo run -p dth-examples --example step_vs_size_plot -- docs/figures
//! ```

use std::path::{Path, PathBuf};

use dth_examples::plot::{Figure, Mark, Series};

/// The median of one criterion benchmark, in microseconds, if it was run.
fn median_us(criterion: &Path, group: &str, function: &str) -> Option<f64> {
    let path = criterion
        .join(group)
        .join(function)
        .join("new")
        .join("estimates.json");
    let text = std::fs::read_to_string(path).ok()?;
    let json: serde_json::Value = serde_json::from_str(&text).ok()?;
    Some(json["median"]["point_estimate"].as_f64()? / 1e3)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "docs/figures".into()),
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/criterion");
    let sizes = [2usize, 4, 8, 12, 16, 32, 128, 512];
    let mut figure = Figure::new(
        "Implicit midpoint and DTH step against chain length",
        "particles N (D = 2N)",
        "time per step [us]",
    )
    .with_log(true, true);
    for (color, (chain, label)) in [("fput", "FPUT-alpha"), ("toda", "Toda")]
        .into_iter()
        .enumerate()
    {
        for (function, path) in [("structured", "structured (banded)"), ("dense", "dense LU")] {
            let points: Vec<(f64, f64)> = sizes
                .iter()
                .filter_map(|&n| {
                    median_us(&root, &format!("midpoint_{chain}_{n}"), function)
                        .map(|t| (n as f64, t))
                })
                .collect();
            if points.is_empty() {
                return Err(format!(
                    "no criterion data for {chain} {function} under {}: run the bench first",
                    root.display()
                )
                .into());
            }
            figure = figure.with_series(
                Series::new(&format!("{label}, {path}"), Mark::LinePoints, points)
                    .with_color(2 * color + usize::from(function == "dense")),
            );
        }
        let points: Vec<(f64, f64)> = sizes
            .iter()
            .filter_map(|&n| {
                median_us(&root, &format!("dth_{chain}_{n}"), "structured").map(|t| (n as f64, t))
            })
            .collect();
        if !points.is_empty() {
            figure = figure.with_series(
                Series::new(
                    &format!("{label}, DTH (structured)"),
                    Mark::LinePoints,
                    points,
                )
                .with_color(7 + color),
            );
        }
    }
    // The reference slope 1 (time linear in N), through the structured FPUT point at N = 8.
    if let Some(t8) = median_us(&root, "midpoint_fput_8", "structured") {
        figure = figure.with_series(
            Series::new(
                "slope 1 (linear in N)",
                Mark::ThinLine,
                [(2.0, t8 / 4.0), (512.0, t8 * 64.0)],
            )
            .with_color(6),
        );
    }
    std::fs::create_dir_all(&out)?;
    for path in figure.render(&out, "step_vs_size")? {
        println!("{}", path.display());
    }
    Ok(())
}
