//! The static `index.html` of an output folder: tables and figures by relative path, no
//! scripts, no network.

use std::fmt::Write as _;

use super::table41::thesis_cells;
use super::{deviation_cells, RunReport};
use crate::scene::{Duration, Scene};

/// Escapes text for HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn num(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else {
        format!("{x:.4e}")
    }
}

/// The page for one run.
pub fn index(scene: &Scene, report: &RunReport) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\n\
         <style>body{{font-family:sans-serif;max-width:1000px;margin:2em auto;padding:0 1em}}\
         table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #999;padding:.25em .6em;text-align:right}}\
         th{{background:#eee}}td:first-child{{text-align:left}}img{{max-width:100%;border:1px solid #ddd}}\
         .fail{{color:#b00}}.warn{{color:#a60}}</style></head><body>\n<h1>{t}</h1>\n",
        t = escape(&report.title)
    );
    if !scene.description.is_empty() {
        let _ = writeln!(h, "<p>{}</p>", escape(&scene.description));
    }
    let params: Vec<String> = report
        .params
        .iter()
        .map(|(k, v)| format!("{k} = {v}"))
        .collect();
    let _ = writeln!(
        h,
        "<p>System <b>{}</b> ({}); q = {:?}, p = {:?}, t0 = {}; duration {}{}.</p>",
        escape(&report.system),
        escape(&params.join(", ")),
        scene.q,
        scene.p,
        scene.t0,
        scene.duration,
        match scene.duration {
            Duration::Time(_) if scene.t0 != 0.0 => " after t0",
            _ => "",
        }
    );
    if let Some(r) = &scene.regularize {
        let _ = writeln!(
            h,
            "<p>Method dth runs on the Hamiltonian regularized by {} about q = {:?} (K = |u|<sup>2</sup> (H + p<sub>t</sub>)), its states mapped back: every value here is physical (t, q, p and H); the other methods run on H.</p>",
            r.map.name(),
            r.centre
        );
    }
    // The fallback column only where a method can fall back (DTH in robust mode) or did.
    let fallback = report.methods.iter().any(|m| m.reports_fallback());
    let _ = writeln!(
        h,
        "<h2>Methods</h2>\n<table><tr><th>method</th><th>kind</th><th>step</th><th>steps</th>{}<th>t end</th><th>status</th></tr>",
        if fallback { "<th>fallback steps</th>" } else { "" }
    );
    for m in &report.methods {
        let step: Vec<String> = m.step.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        let status = match (&m.failure, m.stopped_by()) {
            (None, Some(e)) => format!(
                "stopped by event <b>{}</b> at t = {}",
                escape(&e.name),
                num(e.t)
            ),
            (None, None) => "ok".to_string(),
            (Some(f), _) => format!(
                "<span class=\"fail\">failed at step {}: {}</span>",
                f.step,
                escape(&f.reason)
            ),
        };
        // A failed method's end is the last time it reached, marked as where it stopped.
        let t_end = match &m.failure {
            None => num(m.t_end),
            Some(_) => format!("<span class=\"fail\">{} (stopped)</span>", num(m.t_end)),
        };
        let fallback_cell = match (fallback, m.fallback.steps) {
            (false, _) => String::new(),
            (true, 0) => "<td>0</td>".to_string(),
            (true, _) => format!("<td>{}</td>", escape(&m.fallback.to_string())),
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td>{fallback_cell}<td>{}</td><td>{}</td></tr>",
            escape(&m.label),
            escape(&m.kind),
            escape(&step.join(", ")),
            m.steps,
            t_end,
            status
        );
    }
    h.push_str("</table>\n");
    if let Some(events) = report.events_summary() {
        let _ = writeln!(
            h,
            "<p>{} (every one located to roundoff on the method's own states: <code>LABEL_events.csv</code>).</p>",
            escape(&events)
        );
    }
    for warning in report.fallback_warnings() {
        let _ = writeln!(h, "<p class=\"warn\">Warning: {}.</p>", escape(&warning));
    }
    if let Some(i) = &report.interrupted {
        let _ = writeln!(
            h,
            "<p class=\"fail\">The run was {} (SIGINT or SIGTERM): what it computed up to there is shown.</p>",
            escape(&i.to_string())
        );
    }

    if let Some(t) = &report.table41 {
        h.push_str("<h2>Table 4.1</h2>\n<p>Average absolute deviation in energy and angular momentum of the Kepler problem over each method's run (its steps are in the table above), ours beside the thesis's (whose runs were 10,000 steps: 400 orbits at 25 points per orbit). Reference values: the initial condition (fixed-step methods), zbar_0 (DTH midpoints), the first vertex z^(0) (DTH vertices); mean over k = 1..N.</p>\n<table><tr><th>method</th><th>energy (ours)</th><th>energy (thesis)</th><th>angular momentum (ours)</th><th>angular momentum (thesis)</th></tr>\n");
        for r in &t.rows {
            let (te, tl) = thesis_cells(&r.method);
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{:.3e}</td><td>{te}</td><td>{:.3e}</td><td>{tl}</td></tr>",
                escape(&r.method),
                r.energy,
                r.angular_momentum
            );
        }
        h.push_str("</table>\n");
    }
    if let Some(why) = &report.thesis_figures_failure {
        let _ = writeln!(
            h,
            "<h2>The thesis's figures</h2>\n<p class=\"fail\">not drawn: {}</p>",
            escape(why)
        );
    }
    if !report.thesis_figures.is_empty() {
        h.push_str("<h2>The thesis's figures</h2>\n");
        for f in &report.thesis_figures {
            let _ = writeln!(
                h,
                "<figure id=\"fig{n}\"><img src=\"{s}.png\" alt=\"Figure {n}\"><figcaption><b>Figure {n}.</b> {c} (<a href=\"{s}.svg\">SVG</a>)</figcaption></figure>",
                n = escape(&f.number),
                s = escape(&f.stem),
                c = escape(&f.caption)
            );
        }
    }

    let has_stats = report
        .methods
        .iter()
        .any(|m| m.energy.is_some() || !m.invariants.is_empty());
    if has_stats {
        h.push_str("<h2>Deviations</h2>\n<p>Mean and maximum of |Q_k - Q_ref| over k = 1..N; for DTH at midpoints (reference zbar_0) and at vertices (reference the first vertex).</p>\n<table><tr><th>method</th><th>quantity</th><th>mean</th><th>max</th><th>vertices mean</th><th>vertices max</th></tr>\n");
        for m in &report.methods {
            for s in m.energy.iter().chain(&m.invariants) {
                let (mean, max) = deviation_cells(Some(s.points), num);
                let (vm, vx) = deviation_cells(s.vertices, num);
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td>{}</td><td>{mean}</td><td>{max}</td><td>{vm}</td><td>{vx}</td></tr>",
                    escape(&m.label),
                    escape(&s.name),
                );
            }
        }
        h.push_str("</table>\n");
        for m in &report.methods {
            // The quadratic invariants DTH conserves at its vertices (not the energy, which a
            // fallback node keeps too) do not hold across a fallback step.
            let at_vertices: Vec<&str> = m
                .invariants
                .iter()
                .filter(|s| s.vertices.is_some())
                .map(|s| s.name.as_str())
                .collect();
            if m.fallback.steps > 0 && !at_vertices.is_empty() {
                let _ = writeln!(
                    h,
                    "<p class=\"warn\">Note: {} of the {} steps of <b>{}</b> are fallback steps of the robust mode: discrete-gradient steps, whose nodes are not vertices of DTH segments, so the invariants DTH conserves at its vertices ({}) do not hold across them, and its vertex deviations above are not DTH's.</p>",
                    m.fallback.steps,
                    m.steps,
                    escape(&m.label),
                    escape(&at_vertices.join(", "))
                );
            }
        }
    }

    let finals: Vec<_> = report
        .methods
        .iter()
        .filter_map(|m| m.final_state.as_ref().map(|f| (m, f)))
        .collect();
    if !finals.is_empty() {
        h.push_str("<h2>Final states</h2>\n<table><tr><th>method</th><th>step</th><th>t</th><th>z</th></tr>\n");
        for (m, f) in finals {
            let z: Vec<String> = f.z.iter().map(|x| format!("{x:.10e}")).collect();
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                escape(&m.label),
                f.step,
                num(f.t),
                z.join(", ")
            );
        }
        h.push_str("</table>\n");
    }

    let figures: Vec<&String> = report
        .files
        .iter()
        .filter(|f| f.ends_with(".png"))
        .filter(|f| {
            !report
                .thesis_figures
                .iter()
                .any(|t| f.strip_suffix(".png") == Some(t.stem.as_str()))
        })
        .collect();
    if !figures.is_empty() {
        h.push_str(if report.thesis_figures.is_empty() {
            "<h2>Figures</h2>\n"
        } else {
            "<h2>Other figures</h2>\n"
        });
        for f in figures {
            let svg = f.trim_end_matches(".png");
            let _ = writeln!(
                h,
                "<figure><img src=\"{f}\" alt=\"{svg}\"><figcaption>{svg} (<a href=\"{svg}.svg\">SVG</a>)</figcaption></figure>",
                f = escape(f),
                svg = escape(svg)
            );
        }
    }
    h.push_str("<h2>Data</h2>\n<ul>\n");
    for f in report
        .files
        .iter()
        .filter(|f| f.ends_with(".csv") || f.ends_with(".json"))
    {
        let _ = writeln!(h, "<li><a href=\"{f}\">{f}</a></li>", f = escape(f));
    }
    h.push_str("</ul>\n</body></html>\n");
    h
}
