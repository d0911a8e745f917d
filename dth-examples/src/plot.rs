//! Line and scatter figures rendered to PNG and SVG with plotters, text through the pure-Rust
//! font path (the embedded DejaVu Sans registered as "sans-serif"; no system fonts needed).
//!
//! ```
//! use dth_examples::plot::{Figure, Mark, Series};
//! let dir = tempfile::tempdir().unwrap();
//! let fig = Figure::new("circle", "q1", "p1").with_series(Series::new(
//!     "exact",
//!     Mark::Line,
//!     (0..100).map(|i| (f64::from(i) * 0.0628).cos()).zip((0..100).map(|i| (f64::from(i) * 0.0628).sin())),
//! ));
//! let files = fig.render(dir.path(), "circle").unwrap();
//! assert!(files.iter().all(|f| f.exists()));
//! ```

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use crate::error::Error;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// Connected line.
    Line,
    /// Connected thin line (long orbits).
    ThinLine,
    /// Connected line with a dot at every point (discrete trajectories).
    LinePoints,
    /// Unconnected dots (scatter, Poincare sections).
    Points,
    /// Unconnected small dots (thousands of section points).
    SmallPoints,
}

/// One named series of `(x, y)` points.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Line or dots.
    pub mark: Mark,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// Palette index of the colour (default: the series' position in the figure), so one
    /// method keeps its colour across figures.
    pub color: Option<usize>,
    /// Points only: shade from light (first point) to full colour (last), so that the order
    /// of the points (e.g. time) is visible.
    pub shaded: bool,
}

impl Series {
    /// A series from any iterator of points.
    pub fn new(name: &str, mark: Mark, points: impl IntoIterator<Item = (f64, f64)>) -> Self {
        Series {
            name: name.to_string(),
            mark,
            points: points.into_iter().collect(),
            color: None,
            shaded: false,
        }
    }

    /// Shades the points from light to full colour in their order (see [`Series::shaded`]).
    pub fn with_shading(mut self) -> Self {
        self.shaded = true;
        self
    }

    /// Uses palette colour `i` (see [`PALETTE`]).
    pub fn with_color(mut self, i: usize) -> Self {
        self.color = Some(i);
        self
    }
}

/// A figure: title, labelled axes (optionally logarithmic), any number of series with a legend.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Title.
    pub title: String,
    /// Horizontal axis label.
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// Series, drawn in order with distinct colours.
    pub series: Vec<Series>,
    /// Logarithmic horizontal axis (non-positive x are dropped).
    pub log_x: bool,
    /// Logarithmic vertical axis (non-positive y are dropped).
    pub log_y: bool,
    /// Size in pixels (default 900 x 650).
    pub size: (u32, u32),
    /// Longer series are drawn with a uniform stride so that at most this many points are
    /// drawn (keeps SVGs small; the data files keep every point). Default 50,000.
    pub max_points_per_series: usize,
    /// Fixed horizontal range (default: the data's, padded 5%).
    pub x_range: Option<(f64, f64)>,
    /// Fixed vertical range (default: the data's, padded 5%).
    pub y_range: Option<(f64, f64)>,
    /// Where the legend goes (default [`Legend::Below`]: under the plot, where it covers no
    /// data); `None` hides it.
    pub legend: Option<Legend>,
}

/// Legend position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    /// Under the plot, one entry a line, outside the data (the default).
    Below,
    /// Upper right corner.
    UpperRight,
    /// Upper left corner.
    UpperLeft,
    /// Top, centred.
    UpperMiddle,
    /// Lower left corner.
    LowerLeft,
    /// Lower right corner.
    LowerRight,
}

/// Colour-blind-friendly palette (Okabe-Ito, then Tableau), cycled over series: 0 blue,
/// 1 vermillion, 2 green, 3 reddish purple, 4 orange, 5 sky blue, 6 black, 7 brown, 8 grey,
/// 9 olive, 10 firebrick, 11 midnight blue, 12 purple, 13 teal.
pub const PALETTE: [RGBColor; 14] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(178, 34, 34),
    RGBColor(25, 25, 112),
    RGBColor(106, 61, 154),
    RGBColor(0, 128, 128),
];

/// Registers the embedded DejaVu Sans as "sans-serif" (once per process).
fn ensure_font() -> Result<(), Error> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "the embedded DejaVu Sans font was rejected".to_string())
        })
        .clone()
        .map_err(|reason| Error::Plot {
            name: "(font)".into(),
            reason,
        })
}

fn axis_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let span = hi - lo;
    let pad = if span > 0.0 {
        0.05 * span
    } else {
        0.1 * lo.abs().max(1.0)
    };
    (lo - pad)..(hi + pad)
}

/// A tick label; `span` is the axis length (ticks within `1e-9 span` of zero print as 0,
/// since the tick generator's multiples of the step carry roundoff of that relative size).
/// On a logarithmic axis `v` is `log10` of the value, and the label is the value as a person
/// writes it: `1`, `3`, `10`, `30`, `0.03`, and `1e-6`, `3e5` beyond `[0.01, 1e5)`.
fn tick_label(v: f64, log: bool, span: f64) -> String {
    if !log && v.abs() <= 1e-9 * span {
        return "0".into();
    }
    if log {
        // Three significant digits undo the roundoff of `10^log10(x)`.
        let x: f64 = format!("{:.2e}", 10f64.powf(v)).parse().unwrap_or(f64::NAN);
        if (1e-2..1e5).contains(&x) {
            format!("{x}")
        } else {
            let e = x.log10().floor();
            let m: f64 = format!("{:.2}", x / 10f64.powf(e))
                .parse()
                .unwrap_or(f64::NAN);
            format!("{m}e{e}")
        }
    } else if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e5) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".into()
        } else {
            s.into()
        }
    }
}

/// The ticks of a logarithmic axis over `log10` values `lo..hi`: (labelled, light), in
/// `log10` units. Labelled: 1, 2, 3 and 5 of each decade over at most
/// [`LOG_DENSE_DECADES`] decades, 1 and 3 over at most [`LOG_SPARSE_DECADES`], else the powers
/// of ten (every k-th, at most about eight of them); light: 1..9 of each decade up to
/// [`LOG_SPARSE_DECADES`] decades, the powers of ten beyond.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let decades = hi - lo;
    if !(decades.is_finite() && decades > 0.0) {
        return (Vec::new(), Vec::new());
    }
    let (labelled, stride): (&[f64], i32) = if decades <= LOG_DENSE_DECADES {
        (&[1.0, 2.0, 3.0, 5.0], 1)
    } else if decades <= LOG_SPARSE_DECADES {
        (&[1.0, 3.0], 1)
    } else {
        (&[1.0], (decades / 8.0).ceil() as i32)
    };
    let light: &[f64] = if decades <= LOG_SPARSE_DECADES {
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
    } else {
        &[1.0]
    };
    let at = |mantissas: &[f64], stride: i32| -> Vec<f64> {
        let mut v = Vec::new();
        for e in (lo.floor() as i32)..=(hi.ceil() as i32) {
            if e.rem_euclid(stride) != 0 {
                continue;
            }
            for m in mantissas {
                let x = m.log10() + f64::from(e);
                if (lo..=hi).contains(&x) {
                    v.push(x);
                }
            }
        }
        v
    };
    (at(labelled, stride), at(light, 1))
}

/// Up to this many decades a log axis labels 1, 2, 3 and 5 of each.
const LOG_DENSE_DECADES: f64 = 1.5;

/// Up to this many decades a log axis labels 1 and 3 of each (beyond: powers of ten).
const LOG_SPARSE_DECADES: f64 = 5.0;

/// An axis: plotters' linear axis over `f64`, with the ticks of [`log_ticks`] when it is
/// logarithmic (its values are then `log10` of the data).
struct TickedAxis {
    inner: RangedCoordf64,
    log: bool,
}

impl TickedAxis {
    fn new(range: std::ops::Range<f64>, log: bool) -> Self {
        TickedAxis {
            inner: range.into(),
            log,
        }
    }
}

impl Ranged for TickedAxis {
    type ValueType = f64;
    type FormatOption = DefaultFormatting;

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if !self.log {
            return self.inner.key_points(hint);
        }
        let r = self.inner.range();
        let (labelled, light) = log_ticks(r.start, r.end);
        if hint.weight().allow_light_points() {
            light
        } else {
            labelled
        }
    }
}

impl Figure {
    /// An empty figure with a title and axis labels.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        Figure {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            log_x: false,
            log_y: false,
            size: (900, 650),
            max_points_per_series: 50_000,
            x_range: None,
            y_range: None,
            legend: Some(Legend::Below),
        }
    }

    /// Fixes the axis ranges.
    pub fn with_ranges(mut self, x: (f64, f64), y: (f64, f64)) -> Self {
        self.x_range = Some(x);
        self.y_range = Some(y);
        self
    }

    /// Moves (`Some`) or hides (`None`) the legend.
    pub fn with_legend(mut self, legend: Option<Legend>) -> Self {
        self.legend = legend;
        self
    }

    /// Adds a series.
    pub fn with_series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }

    /// Sets logarithmic axes (e.g. both for work-precision diagrams).
    pub fn with_log(mut self, log_x: bool, log_y: bool) -> Self {
        self.log_x = log_x;
        self.log_y = log_y;
        self
    }

    /// How many points of `s` a logarithmic axis drops, as exactly zero and as negative (the
    /// legend says so: a curve of exact zeros is otherwise invisible, or reads as a floor).
    fn dropped(&self, s: &Series) -> (usize, usize) {
        let on_log = |&(x, y): &(f64, f64)| {
            let mut v = f64::INFINITY;
            if self.log_x {
                v = v.min(x);
            }
            if self.log_y {
                v = v.min(y);
            }
            v
        };
        let zeros = s.points.iter().filter(|p| on_log(p) == 0.0).count();
        let negative = s.points.iter().filter(|p| on_log(p) < 0.0).count();
        (zeros, negative)
    }

    /// The series as drawn: logarithmic axes take `log10`, dropping non-positive values.
    fn transformed(&self) -> Vec<Vec<(f64, f64)>> {
        let tx = |v: f64| {
            if self.log_x {
                (v > 0.0).then(|| v.log10())
            } else {
                Some(v)
            }
        };
        let ty = |v: f64| {
            if self.log_y {
                (v > 0.0).then(|| v.log10())
            } else {
                Some(v)
            }
        };
        self.series
            .iter()
            .map(|s| {
                let stride = s.points.len().div_ceil(self.max_points_per_series.max(1));
                s.points
                    .iter()
                    .step_by(stride.max(1))
                    .filter_map(|&(x, y)| Some((tx(x)?, ty(y)?)))
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .collect()
            })
            .collect()
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        data: &[Vec<(f64, f64)>],
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        root.fill(&WHITE)?;
        self.draw_on(root, data, 22)?;
        root.present()?;
        Ok(())
    }

    /// Draws the chart into `area` (no background fill, no present: panels share them).
    fn draw_on<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        data: &[Vec<(f64, f64)>],
        title_size: u32,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let range =
            |fixed: Option<(f64, f64)>, log: bool, values: &mut dyn Iterator<Item = f64>| {
                match fixed {
                    Some((a, b)) if log => a.log10()..b.log10(),
                    Some((a, b)) => a..b,
                    None => axis_range(values),
                }
            };
        let xr = range(
            self.x_range,
            self.log_x,
            &mut data.iter().flatten().map(|p| p.0),
        );
        let yr = range(
            self.y_range,
            self.log_y,
            &mut data.iter().flatten().map(|p| p.1),
        );
        // A legend below the plot gets a strip of its own, one line an entry.
        let below = self.legend == Some(Legend::Below) && !self.series.is_empty();
        let (plot_area, legend_area) = if below {
            let h = area.dim_in_pixel().1;
            let strip = (self.series.len() as u32 * 20 + 14).min(h / 3);
            let (top, bottom) = area.split_vertically(h - strip);
            (top, Some(bottom))
        } else {
            (area.clone(), None)
        };
        let mut chart = ChartBuilder::on(&plot_area)
            .caption(&self.title, ("sans-serif", title_size))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(
                TickedAxis::new(xr.clone(), self.log_x),
                TickedAxis::new(yr.clone(), self.log_y),
            )?;
        let (lx, ly) = (self.log_x, self.log_y);
        let (sx, sy) = (xr.end - xr.start, yr.end - yr.start);
        let fx = move |v: &f64| tick_label(*v, lx, sx);
        let fy = move |v: &f64| tick_label(*v, ly, sy);
        let suffix = |log: bool| if log { " (log scale)" } else { "" };
        chart
            .configure_mesh()
            .x_desc(format!("{}{}", self.x_label, suffix(lx)))
            .y_desc(format!("{}{}", self.y_label, suffix(ly)))
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        let inside = |&(x, y): &(f64, f64)| xr.contains(&x) && yr.contains(&y);
        let labels: Vec<String> = self
            .series
            .iter()
            .map(|s| legend_label(s, self.dropped(s)))
            .collect();
        for (i, (s, pts)) in self.series.iter().zip(data).enumerate() {
            let color = PALETTE[s.color.unwrap_or(i) % PALETTE.len()];
            let anno = match s.mark {
                Mark::Line | Mark::ThinLine | Mark::LinePoints => {
                    // Dense lines are drawn 1 px wide: plotters' bitmap backend draws wide
                    // polylines with miter joins, which spike far out at sharp turns.
                    let width = if s.mark == Mark::ThinLine || pts.len() > 300 {
                        1
                    } else {
                        2
                    };
                    if s.mark == Mark::LinePoints {
                        chart.draw_series(
                            pts.iter()
                                .filter(|p| inside(p))
                                .map(|&p| Circle::new(p, 3, color.filled())),
                        )?;
                    }
                    let a = chart.draw_series(LineSeries::new(
                        pts.iter().copied(),
                        color.stroke_width(width),
                    ))?;
                    let dot = s.mark == Mark::LinePoints;
                    a.legend(move |(x, y)| {
                        let line = PathElement::new(vec![(0, 0), (20, 0)], color.stroke_width(2));
                        let r = if dot { 3 } else { 0 };
                        EmptyElement::at((x, y)) + line + Circle::new((10, 0), r, color.filled())
                    })
                }
                Mark::Points | Mark::SmallPoints => {
                    let r = if s.mark == Mark::Points { 2 } else { 1 };
                    let n = pts.len().max(2) - 1;
                    let shaded = s.shaded;
                    // Shade i of n: from 15% of the colour on white to the full colour.
                    let shade = move |i: usize| {
                        if !shaded {
                            return color;
                        }
                        let w = 0.15 + 0.85 * i as f64 / n as f64;
                        let mix = |c: u8| (255.0 - w * (255.0 - f64::from(c))).round() as u8;
                        RGBColor(mix(color.0), mix(color.1), mix(color.2))
                    };
                    chart
                        .draw_series(
                            pts.iter()
                                .enumerate()
                                .filter(|(_, p)| inside(p))
                                .map(move |(i, &p)| Circle::new(p, r, shade(i).filled())),
                        )?
                        .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()))
                }
            };
            anno.label(labels[i].as_str());
        }
        if let Some(strip) = legend_area {
            // Aligned with the plot's left edge (margin and y label area).
            let x0 = 95;
            for (i, s) in self.series.iter().enumerate() {
                let color = PALETTE[s.color.unwrap_or(i) % PALETTE.len()];
                let y = 10 + 20 * i as i32;
                match s.mark {
                    Mark::Points | Mark::SmallPoints => {
                        strip.draw(&Circle::new((x0 + 10, y), 4, color.filled()))?
                    }
                    _ => strip.draw(&PathElement::new(
                        vec![(x0, y), (x0 + 20, y)],
                        color.stroke_width(2),
                    ))?,
                }
                strip.draw(&Text::new(
                    labels[i].as_str(),
                    (x0 + 28, y - 8),
                    ("sans-serif", 14).into_font(),
                ))?;
            }
        } else if let (Some(legend), false) = (self.legend, self.series.is_empty()) {
            let position = match legend {
                Legend::Below | Legend::UpperRight => SeriesLabelPosition::UpperRight,
                Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
                Legend::UpperMiddle => SeriesLabelPosition::UpperMiddle,
                Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
                Legend::LowerRight => SeriesLabelPosition::LowerRight,
            };
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .position(position)
                .draw()?;
        }
        Ok(())
    }

    /// Writes `dir/stem.png` and `dir/stem.svg`; returns their paths.
    pub fn render(&self, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        let data = self.transformed();
        render_both(
            dir,
            stem,
            self.size,
            |root| self.draw(root, &data),
            |root| self.draw(root, &data),
        )
    }
}

/// The legend entry of `s`: its name, and what a logarithmic axis left out of it.
fn legend_label(s: &Series, (zeros, negative): (usize, usize)) -> String {
    let n = s.points.len();
    let mut notes = Vec::new();
    if zeros > 0 {
        notes.push(format!("{zeros} of {n} exactly 0"));
    }
    if negative > 0 {
        notes.push(format!("{negative} of {n} negative"));
    }
    if notes.is_empty() {
        s.name.clone()
    } else {
        format!(
            "{} ({}: not drawn on the log scale)",
            s.name,
            notes.join(", ")
        )
    }
}

/// A figure of several panels (thesis style "(a) ... (d)") on one canvas, with a caption on
/// top. Panels fill the grid row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// The caption over all panels.
    pub title: String,
    /// `(rows, columns)`.
    pub shape: (usize, usize),
    /// The panels (each with its own title, axes and legend).
    pub panels: Vec<Figure>,
    /// Size in pixels (default 1400 x 1250).
    pub size: (u32, u32),
}

impl Grid {
    /// A grid of `rows x cols` panels under `title`.
    pub fn new(title: &str, shape: (usize, usize), panels: Vec<Figure>) -> Self {
        Grid {
            title: title.into(),
            shape,
            panels,
            size: (1400, 1250),
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        data: &[Vec<Vec<(f64, f64)>>],
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        root.fill(&WHITE)?;
        let body = root.titled(&self.title, ("sans-serif", 26))?;
        for ((area, panel), d) in body
            .split_evenly(self.shape)
            .iter()
            .zip(&self.panels)
            .zip(data)
        {
            panel.draw_on(area, d, 18)?;
        }
        root.present()?;
        Ok(())
    }

    /// Writes `dir/stem.png` and `dir/stem.svg`; returns their paths.
    pub fn render(&self, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        let data: Vec<_> = self.panels.iter().map(Figure::transformed).collect();
        render_both(
            dir,
            stem,
            self.size,
            |root| self.draw(root, &data),
            |root| self.draw(root, &data),
        )
    }
}

type SvgArea<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type PngArea<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Renders once to SVG and once to PNG (the two backends need two monomorphized draws).
fn render_both(
    dir: &Path,
    stem: &str,
    (w, h): (u32, u32),
    draw_svg: impl FnOnce(&SvgArea<'_>) -> Result<(), DrawingAreaErrorKind<std::io::Error>>,
    draw_png: impl FnOnce(
        &PngArea<'_>,
    ) -> Result<
        (),
        DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>,
    >,
) -> Result<Vec<PathBuf>, Error> {
    ensure_font()?;
    let plot_err = |reason: String| Error::Plot {
        name: stem.to_string(),
        reason,
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        draw_svg(&root).map_err(|e| plot_err(e.to_string()))?;
    }
    let svg_path = dir.join(format!("{stem}.svg"));
    std::fs::write(&svg_path, svg).map_err(|source| Error::Io {
        what: "cannot write figure",
        path: svg_path.clone(),
        source,
    })?;

    let mut buf = vec![0u8; (w as usize) * (h as usize) * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        draw_png(&root).map_err(|e| plot_err(e.to_string()))?;
    }
    let png_path = dir.join(format!("{stem}.png"));
    write_png(&png_path, &buf, w, h).map_err(|e| match e {
        PngError::Io(source) => Error::Io {
            what: "cannot write figure",
            path: png_path.clone(),
            source,
        },
        PngError::Encode(reason) => plot_err(reason),
    })?;
    Ok(vec![png_path, svg_path])
}

enum PngError {
    Io(std::io::Error),
    Encode(String),
}

fn write_png(path: &Path, rgb: &[u8], w: u32, h: u32) -> Result<(), PngError> {
    let file = std::fs::File::create(path).map_err(PngError::Io)?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc
        .write_header()
        .map_err(|e| PngError::Encode(e.to_string()))?;
    writer
        .write_image_data(rgb)
        .map_err(|e| PngError::Encode(e.to_string()))?;
    writer.finish().map_err(|e| PngError::Encode(e.to_string()))
}

/// A filled raster with a colour bar: `values` on a grid of `cols` columns (along x) and
/// `values.len() / cols` rows (along y, the first row at the bottom), coloured on a diverging
/// scale (blue, white at the centre, red): by default symmetric about 0 (a lattice's
/// displacement against site and time), or any `low < centre < high` ([`Raster::with_scale`]:
/// a chaos indicator, white where orbits are regular). Values beyond the scale take its end
/// colours; a value that is not a number is grey (a member that did not run).
///
/// ```
/// use dth_examples::plot::Raster;
/// let dir = tempfile::tempdir().unwrap();
/// let values: Vec<f64> = (0..20).flat_map(|t| (0..10).map(move |i| (i as f64 - t as f64 * 0.3).sin())).collect();
/// let r = Raster::new("wave", "site", "t", (1.0, 10.0), (0.0, 19.0), values, 10, "q");
/// let files = r.render(dir.path(), "wave").unwrap();
/// assert!(files.iter().all(|f| f.exists()));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    title: String,
    x_label: String,
    y_label: String,
    x_range: (f64, f64),
    y_range: (f64, f64),
    values: Vec<f64>,
    cols: usize,
    colour_label: String,
    /// `(low, centre, high)`; `None`: symmetric about 0 over the values' largest magnitude.
    scale: Option<(f64, f64, f64)>,
}

impl Raster {
    /// The raster of `values` (row after row, `cols` a row) over `x_range` x `y_range`,
    /// `colour_label` naming what the colour shows.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        title: &str,
        x_label: &str,
        y_label: &str,
        x_range: (f64, f64),
        y_range: (f64, f64),
        values: Vec<f64>,
        cols: usize,
        colour_label: &str,
    ) -> Self {
        Raster {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_range,
            y_range,
            values,
            cols: cols.max(1),
            colour_label: colour_label.into(),
            scale: None,
        }
    }

    /// The values, row after row (the first row at the bottom).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The number of columns (cells along x).
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Colours from blue at `low` through white at `centre` to red at `high` (each side
    /// linear), the colour bar spanning `low..high`. A scale that is not ordered
    /// (`low < centre < high`, all finite) leaves the default.
    pub fn with_scale(mut self, low: f64, centre: f64, high: f64) -> Self {
        let ordered = low < centre && centre < high && low.is_finite() && high.is_finite();
        if ordered {
            self.scale = Some((low, centre, high));
        }
        self
    }

    /// Writes `dir/stem.png` and `dir/stem.svg`; returns their paths.
    pub fn render(&self, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, Error> {
        render_both(
            dir,
            stem,
            (900, 650),
            |root| self.draw(root),
            |root| self.draw(root),
        )
    }

    /// Blue (-1) through white (0) to red (+1); grey for a value that is not a number.
    fn colour(v: f64) -> RGBColor {
        if v.is_nan() {
            return RGBColor(170, 170, 170);
        }
        let v = v.clamp(-1.0, 1.0);
        let mix = |c: f64| (255.0 * (1.0 - v.abs()) + c * v.abs()).round() as u8;
        if v >= 0.0 {
            RGBColor(mix(200.0), mix(30.0), mix(30.0))
        } else {
            RGBColor(mix(30.0), mix(60.0), mix(200.0))
        }
    }

    /// The scale `(low, centre, high)`: the one set, or symmetric about 0 over the values.
    fn scale(&self) -> (f64, f64, f64) {
        self.scale.unwrap_or_else(|| {
            let limit = self
                .values
                .iter()
                .filter(|v| v.is_finite())
                .fold(0.0f64, |m, v| m.max(v.abs()));
            let limit = if limit > 0.0 { limit } else { 1.0 };
            (-limit, 0.0, limit)
        })
    }

    /// `v` on the scale, `-1..1` (see [`Raster::colour`]).
    fn unit((low, centre, high): (f64, f64, f64), v: f64) -> f64 {
        if v >= centre {
            (v - centre) / (high - centre)
        } else {
            (v - centre) / (centre - low)
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        root.fill(&WHITE)?;
        let (main, bar) = root.split_horizontally(790);
        let rows = self.values.len() / self.cols;
        let scale = self.scale();
        let (low, high) = (scale.0, scale.2);
        let (x0, x1) = self.x_range;
        let (y0, y1) = self.y_range;
        // A single row or column still spans its cell.
        let (x1, y1) = (
            if x1 > x0 { x1 } else { x0 + 1.0 },
            if y1 > y0 { y1 } else { y0 + 1.0 },
        );
        let mut chart = ChartBuilder::on(&main)
            .caption(&self.title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        let (sx, sy) = (x1 - x0, y1 - y0);
        let fx = move |v: &f64| tick_label(*v, false, sx);
        let fy = move |v: &f64| tick_label(*v, false, sy);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 16))
            .draw()?;
        let (dx, dy) = (sx / self.cols as f64, sy / rows.max(1) as f64);
        chart.draw_series(self.values.iter().enumerate().map(|(k, v)| {
            let (r, c) = (k / self.cols, k % self.cols);
            let (x, y) = (x0 + c as f64 * dx, y0 + r as f64 * dy);
            Rectangle::new(
                [(x, y), (x + dx, y + dy)],
                Self::colour(Self::unit(scale, *v)).filled(),
            )
        }))?;
        // The colour bar: the scale from low to high.
        let mut bar_chart = ChartBuilder::on(&bar)
            .margin_top(45)
            .margin_bottom(65)
            .margin_right(5)
            .right_y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, low..high)?;
        let fl = move |v: &f64| tick_label(*v, false, high - low);
        bar_chart
            .configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(&self.colour_label)
            .y_label_formatter(&fl)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .draw()?;
        let steps = 100;
        bar_chart.draw_series((0..steps).map(|k| {
            let a = low + (high - low) * k as f64 / steps as f64;
            let b = a + (high - low) / steps as f64;
            let mid = 0.5 * (a + b);
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                Self::colour(Self::unit(scale, mid)).filled(),
            )
        }))?;
        root.present()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_read_as_numbers() {
        assert_eq!(tick_label(-3.0, true, 5.0), "1e-3");
        // Log ticks read as the numbers they are: 1, 3, 10, 30 (not 3.2e0, 1e1, 3.2e1).
        let (labelled, _) = log_ticks(0.0, 2.0);
        let labels: Vec<String> = labelled.iter().map(|&v| tick_label(v, true, 2.0)).collect();
        assert_eq!(labels, ["1", "3", "10", "30", "100"]);
        let labels: Vec<String> = log_ticks(-0.2, 0.9)
            .0
            .iter()
            .map(|&v| tick_label(v, true, 1.1))
            .collect();
        assert_eq!(labels, ["1", "2", "3", "5"]);
        let labels: Vec<String> = log_ticks(-16.0, 0.0)
            .0
            .iter()
            .map(|&v| tick_label(v, true, 16.0))
            .collect();
        assert_eq!(
            labels,
            ["1e-16", "1e-14", "1e-12", "1e-10", "1e-8", "1e-6", "1e-4", "0.01", "1"]
        );
        assert_eq!(tick_label(3f64.log10() + 5.0, true, 1.0), "3e5");
        assert_eq!(tick_label(0.25, false, 1.0), "0.25");
        assert_eq!(tick_label(3.5e-18, false, 0.03), "0");
        assert_eq!(tick_label(1e-15, false, 1e-14), "1.0e-15");
    }

    #[test]
    fn log_axes_drop_non_positive_values() {
        let f = Figure::new("t", "x", "y")
            .with_log(true, true)
            .with_series(Series::new(
                "s",
                Mark::Line,
                [(1.0, 0.0), (10.0, 100.0), (-1.0, 1.0)],
            ));
        assert_eq!(f.transformed(), vec![vec![(1.0, 2.0)]]);
    }

    #[test]
    fn long_series_are_strided_for_drawing() {
        let mut f = Figure::new("t", "x", "y").with_series(Series::new(
            "s",
            Mark::Line,
            (0..10).map(|i| (f64::from(i), 0.0)),
        ));
        f.max_points_per_series = 4;
        let xs: Vec<f64> = f.transformed()[0].iter().map(|p| p.0).collect();
        assert_eq!(xs, [0.0, 3.0, 6.0, 9.0]);
    }
}
