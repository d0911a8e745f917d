//! Work-precision diagrams: error against wall time, log-log, one curve per method, as PNG and
//! SVG.
//!
//! Self-contained until the `dth` command's shared plot module lands; the only entry point is
//! [`diagrams`], so switching the drawing to that module touches this file alone.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::problems::ProblemInfo;
use super::report::error_of;
use super::{Error, Record};

/// Errors below this are drawn at it (a log axis has no zero); the captions say so.
const FLOOR: f64 = 1e-17;
const WIDTH: u32 = 1100;
const HEIGHT: u32 = 700;
/// Width of the legend column to the right of the chart.
const LEGEND: u32 = 250;

/// One curve: label, colour, dashed or not, points `(time, error)` sorted by time.
struct Curve {
    label: String,
    color: RGBColor,
    dashed: bool,
    points: Vec<(f64, f64)>,
}

const COLORS: [RGBColor; 11] = [
    RGBColor(214, 39, 40),   // dth_joint: red
    RGBColor(255, 127, 14),  // dth_nested: orange
    RGBColor(31, 119, 180),  // midpoint
    RGBColor(44, 160, 44),   // trapezoidal
    RGBColor(148, 103, 189), // discrete_gradient
    RGBColor(140, 86, 75),   // stormer_verlet
    RGBColor(227, 119, 194), // rk4
    RGBColor(127, 127, 127), // gauss_legendre2
    RGBColor(23, 190, 207),  // dop853
    RGBColor(188, 189, 34),  // discrete_mechanics
    RGBColor(0, 0, 0),
];

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bundled DejaVu Sans is a valid TrueType font; if registration ever failed, text
        // would be missing from the PNG, which looking at the figure reveals.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

fn curves(records: &[Record], system: &str, kind: &str) -> Vec<Curve> {
    let mut methods: Vec<&str> = Vec::new();
    for r in records.iter().filter(|r| r.system == system) {
        if !methods.contains(&r.method) {
            methods.push(r.method);
        }
    }
    let mut out = Vec::new();
    for (i, m) in methods.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        let runs: Vec<&Record> = records
            .iter()
            .filter(|r| r.system == system && r.method == *m && r.failure.is_none())
            .filter(|r| r.time.is_finite() && r.time > 0.0)
            .collect();
        let mut series = |label: String, dashed: bool, f: &dyn Fn(&Record) -> f64| {
            let mut points: Vec<(f64, f64)> = runs
                .iter()
                .map(|r| (r.time, f(r)))
                .filter(|(_, e)| e.is_finite())
                .map(|(t, e)| (t, e.max(FLOOR)))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            if !points.is_empty() {
                out.push(Curve {
                    label,
                    color,
                    dashed,
                    points,
                });
            }
        };
        let dth = m.starts_with("dth");
        let suffix = if dth && kind != "global" {
            " (midpoints)"
        } else {
            ""
        };
        series(format!("{m}{suffix}"), false, &|r| error_of(r, kind));
        if dth {
            match kind {
                "energy" => series(format!("{m} (vertices)"), true, &|r| {
                    r.vertex_energy_error.unwrap_or(f64::NAN)
                }),
                "invariant" => series(format!("{m} (vertices)"), true, &|r| {
                    r.vertex_invariant_error.unwrap_or(f64::NAN)
                }),
                _ => {}
            }
        }
    }
    out
}

fn bounds(curves: &[Curve]) -> Option<((f64, f64), (f64, f64))> {
    let pts = curves.iter().flat_map(|c| c.points.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && y0.is_finite()) {
        return None;
    }
    // Pad by a factor on each side (log axes), and at least one decade in total.
    let pad = |lo: f64, hi: f64, f: f64| {
        let (lo, hi) = (lo / f, hi * f);
        if hi / lo < 10.0 {
            (lo / 3.0, hi * 3.0)
        } else {
            (lo, hi)
        }
    };
    Some((pad(x0, x1, 1.5), pad(y0, y1, 3.0)))
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    y_label: &str,
    curves: &[Curve],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let Some(((x0, x1), (y0, y1))) = bounds(curves) else {
        return Ok(());
    };
    let (chart_area, legend_area) = root.split_horizontally(WIDTH - LEGEND);
    let mut chart = ChartBuilder::on(&chart_area)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("wall time to reach T (s), median of repeats")
        .y_desc(y_label)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .draw()
        .map_err(|e| e.to_string())?;
    for c in curves {
        let width = if c.label.starts_with("dth") { 3 } else { 2 };
        let style = c.color.stroke_width(width);
        if c.dashed {
            chart
                .draw_series(DashedLineSeries::new(c.points.clone(), 8, 5, style))
                .map_err(|e| e.to_string())?;
        } else {
            chart
                .draw_series(LineSeries::new(c.points.clone(), style))
                .map_err(|e| e.to_string())?;
        }
        chart
            .draw_series(
                c.points
                    .iter()
                    .map(|&p| Circle::new(p, 3, c.color.filled())),
            )
            .map_err(|e| e.to_string())?;
    }
    // Legend in its own column, so it never covers a curve.
    let font = ("sans-serif", 15).into_font();
    for (i, c) in curves.iter().enumerate() {
        let y = 60 + 24 * i as i32;
        let style = c.color.stroke_width(3);
        let segment = if c.dashed {
            vec![(8, y), (18, y), (22, y), (32, y)]
        } else {
            vec![(8, y), (32, y)]
        };
        if c.dashed {
            for pair in segment.chunks(2) {
                legend_area
                    .draw(&PathElement::new(pair.to_vec(), style))
                    .map_err(|e| e.to_string())?;
            }
        } else {
            legend_area
                .draw(&PathElement::new(segment, style))
                .map_err(|e| e.to_string())?;
        }
        legend_area
            .draw(&Circle::new((20, y), 3, c.color.filled()))
            .map_err(|e| e.to_string())?;
        legend_area
            .draw(&Text::new(c.label.clone(), (40, y - 8), font.clone()))
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

fn plot_error(path: &Path) -> impl Fn(String) -> Error + '_ {
    move |message| Error::Plot {
        path: path.to_path_buf(),
        message,
    }
}

/// Draw `stem.png` and `stem.svg`.
fn render(
    stem: &Path,
    title: &str,
    y_label: &str,
    curves: &[Curve],
) -> Result<Vec<PathBuf>, Error> {
    register_font();
    let svg = stem.with_extension("svg");
    {
        let root = SVGBackend::new(&svg, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, title, y_label, curves).map_err(plot_error(&svg))?;
    }
    let png = stem.with_extension("png");
    let mut buffer = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, title, y_label, curves).map_err(plot_error(&png))?;
    }
    let file = std::fs::File::create(&png).map_err(|source| Error::Io {
        path: png.clone(),
        source,
    })?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), WIDTH, HEIGHT);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder
        .write_header()
        .and_then(|mut w| w.write_image_data(&buffer))
        .map_err(|e| plot_error(&png)(e.to_string()))?;
    Ok(vec![png, svg])
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
                format!("max |H - H(z0)| (below {FLOOR:.0e} drawn at it)"),
            ),
        ];
        if let Some(name) = info.invariant {
            kinds.push(("invariant", format!("max |{name} deviation|")));
        }
        for (kind, y_label) in kinds {
            let title = format!("{}: {kind} error vs. wall time", info.title);
            let c = curves(records, info.name, kind);
            let stem = out.join(format!("{}_{kind}", info.name));
            files.extend(render(&stem, &title, &y_label, &c)?);
        }
    }
    Ok(files)
}
