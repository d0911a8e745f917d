//! One log-log figure with several series, rendered to PNG and SVG; checks that the text was
//! drawn (pixels in the title band, labels in the SVG). Set `DTH_FIGURE_DIR` to keep it.

use dth_examples::plot::{Figure, Mark, Series};

#[test]
fn log_log_figure_renders_text_and_series() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = std::env::var_os("DTH_FIGURE_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| tmp.path().to_path_buf());
    std::fs::create_dir_all(&dir).unwrap();
    // Error ~ C h^order against work ~ 1/h over three decades of h.
    let mut fig = Figure::new(
        "work-precision (synthetic)",
        "wall time [s]",
        "global error",
    )
    .with_log(true, true);
    for (name, order, c) in [
        ("order 1", 1, 1.0),
        ("order 2", 2, 3.0),
        ("order 4", 4, 10.0),
    ] {
        let pts = (0..=30).map(|i| {
            let h = 10f64.powf(-3.0 * f64::from(i) / 30.0);
            (1e-4 / h, c * h.powi(order))
        });
        fig = fig.with_series(Series::new(name, Mark::Line, pts));
    }
    fig = fig.with_series(Series::new(
        "measured",
        Mark::Points,
        [(1e-3, 1e-2), (1e-2, 1e-5), (1e-1, 1e-9)],
    ));
    let files = fig.render(&dir, "loglog").unwrap();
    assert_eq!(files.len(), 2);

    let svg = std::fs::read_to_string(dir.join("loglog.svg")).unwrap();
    for text in [
        "work-precision (synthetic)",
        "global error (log scale)",
        "order 4",
        "measured",
        "1e-6",
    ] {
        assert!(svg.contains(text), "SVG lacks `{text}`");
    }

    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(dir.join("loglog.png")).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (900, 650));
    // The title is drawn in the top band, centred: it must contain dark (glyph) pixels.
    let dark_in_title = (5..40)
        .flat_map(|y| (300..600).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let i = (y * info.width as usize + x) * 3;
            buf[i] < 100 && buf[i + 1] < 100 && buf[i + 2] < 100
        })
        .count();
    assert!(
        dark_in_title > 100,
        "no glyphs in the title band ({dark_in_title} dark pixels)"
    );
}
