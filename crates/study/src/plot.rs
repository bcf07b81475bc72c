//! Log-log line plots as standalone SVG documents (no fonts or system libraries needed: the
//! text is SVG text rendered by the viewer). One figure holds a grid of panels that share one
//! legend; each panel has decade ticks on both axes and optional horizontal reference lines
//! (e.g. the 1 % and 0.1 % accuracy targets).

use std::fmt::Write;

/// One line of markers.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// The legend entry; series with the same label share a colour across panels.
    pub label: String,
    /// (x, y) points; non-positive or non-finite ones are left out on a log scale.
    pub points: Vec<(f64, f64)>,
}

/// One panel of the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// The panel's heading.
    pub title: String,
    /// The caption of the (logarithmic) x axis.
    pub x_label: String,
    /// The caption of the (logarithmic) y axis.
    pub y_label: String,
    /// In legend order; the same label gets the same colour in every panel.
    pub series: Vec<Series>,
    /// Horizontal reference lines (y, label).
    pub lines: Vec<(f64, String)>,
}

const COLOURS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
];
const PANEL_W: f64 = 420.0;
const PANEL_H: f64 = 300.0;
const MARGIN: [f64; 4] = [36.0, 20.0, 48.0, 64.0]; // top, right, bottom, left

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Decades [lo, hi] covering the positive values (at least one decade wide).
fn decades(values: impl Iterator<Item = f64>) -> Option<(i32, i32)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return None;
    }
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    Some((a, b.max(a + 1)))
}

fn tick_label(k: i32) -> String {
    match k {
        0 => "1".into(),
        1 => "10".into(),
        -1 => "0.1".into(),
        _ => format!("1e{k}"),
    }
}

/// The figure: panels in a grid of `columns` columns, one legend on top.
pub fn svg(title: &str, panels: &[Panel], columns: usize) -> String {
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    let mut labels: Vec<&str> = Vec::new();
    for p in panels {
        for s in &p.series {
            if !labels.contains(&s.label.as_str()) {
                labels.push(&s.label);
            }
        }
    }
    let legend_h = 24.0;
    let top = 30.0 + legend_h;
    let (width, height) = (columns as f64 * PANEL_W, top + rows as f64 * PANEL_H + 8.0);
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="DejaVu Sans, Arial, sans-serif" font-size="12">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{}" y="20" text-anchor="middle" font-size="15">{}</text>"#,
        width / 2.0,
        escape(title)
    );
    let mut x = 16.0;
    for (i, label) in labels.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let _ = writeln!(
            out,
            r#"<line x1="{x}" y1="{y}" x2="{x2}" y2="{y}" stroke="{colour}" stroke-width="2"/><circle cx="{cx}" cy="{y}" r="3.5" fill="{colour}"/><text x="{tx}" y="{ty}">{}</text>"#,
            escape(label),
            y = 38.0,
            x2 = x + 24.0,
            cx = x + 12.0,
            tx = x + 30.0,
            ty = 42.0
        );
        x += 40.0 + 7.5 * label.chars().count() as f64;
    }
    for (k, panel) in panels.iter().enumerate() {
        let (col, row) = (k % columns, k / columns);
        let origin = (col as f64 * PANEL_W, top + row as f64 * PANEL_H);
        draw_panel(&mut out, panel, origin, &labels);
    }
    out.push_str("</svg>\n");
    out
}

fn draw_panel(out: &mut String, panel: &Panel, (ox, oy): (f64, f64), labels: &[&str]) {
    let [mt, mr, mb, ml] = MARGIN;
    let (x0, y0) = (ox + ml, oy + mt);
    let (w, h) = (PANEL_W - ml - mr, PANEL_H - mt - mb);
    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" text-anchor="middle" font-size="13">{}</text>"#,
        x0 + w / 2.0,
        oy + 20.0,
        escape(&panel.title)
    );
    let xs = panel
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = panel
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .chain(panel.lines.iter().map(|l| l.0));
    let (Some((xa, xb)), Some((ya, yb))) = (decades(xs), decades(ys)) else {
        let _ = writeln!(
            out,
            r#"<text x="{}" y="{}" text-anchor="middle" fill="grey">no data</text>"#,
            x0 + w / 2.0,
            y0 + h / 2.0
        );
        return;
    };
    let px = |v: f64| x0 + (v.log10() - xa as f64) / (xb - xa) as f64 * w;
    let py = |v: f64| y0 + h - (v.log10() - ya as f64) / (yb - ya) as f64 * h;
    let _ = writeln!(
        out,
        r##"<rect x="{x0}" y="{y0}" width="{w}" height="{h}" fill="none" stroke="#444"/>"##
    );
    for k in xa..=xb {
        let x = px(10f64.powi(k));
        let _ = writeln!(
            out,
            r##"<line x1="{x}" y1="{y0}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">{}</text>"##,
            y0 + h,
            y0 + h + 16.0,
            tick_label(k)
        );
    }
    for k in ya..=yb {
        let y = py(10f64.powi(k));
        let _ = writeln!(
            out,
            r##"<line x1="{x0}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">{}</text>"##,
            x0 + w,
            x0 - 6.0,
            y + 4.0,
            tick_label(k)
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        x0 + w / 2.0,
        y0 + h + 34.0,
        escape(&panel.x_label)
    );
    let _ = writeln!(
        out,
        r#"<text x="{x}" y="{y}" text-anchor="middle" transform="rotate(-90 {x} {y})">{}</text>"#,
        escape(&panel.y_label),
        x = ox + 16.0,
        y = y0 + h / 2.0
    );
    for (y, label) in &panel.lines {
        if *y > 0.0 {
            let yy = py(*y);
            let _ = writeln!(
                out,
                r##"<line x1="{x0}" y1="{yy}" x2="{}" y2="{yy}" stroke="#888" stroke-dasharray="5,4"/><text x="{}" y="{}" text-anchor="end" fill="#666" font-size="11">{}</text>"##,
                x0 + w,
                x0 + w - 4.0,
                yy - 4.0,
                escape(label)
            );
        }
    }
    for series in &panel.series {
        let i = labels.iter().position(|l| *l == series.label).unwrap_or(0);
        let colour = COLOURS[i % COLOURS.len()];
        let pts: Vec<(f64, f64)> = series
            .points
            .iter()
            .filter(|(a, b)| a.is_finite() && b.is_finite() && *a > 0.0 && *b > 0.0)
            .map(|&(a, b)| (px(a), py(b)))
            .collect();
        if pts.len() > 1 {
            let path: Vec<String> = pts.iter().map(|(a, b)| format!("{a:.1},{b:.1}")).collect();
            let _ = writeln!(
                out,
                r#"<polyline points="{}" fill="none" stroke="{colour}" stroke-width="1.5"/>"#,
                path.join(" ")
            );
        }
        for (a, b) in pts {
            let _ = writeln!(
                out,
                r#"<circle cx="{a:.1}" cy="{b:.1}" r="3.5" fill="{colour}"/>"#
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_has_its_panels_points_and_legend() {
        let panel = |t: &str| Panel {
            title: t.into(),
            x_label: "time [s]".into(),
            y_label: "relative error".into(),
            series: vec![
                Series {
                    label: "direct".into(),
                    points: vec![(1e-3, 1e-2), (1e-2, 1e-3), (0.0, 1.0)],
                },
                Series {
                    label: "dd <1e-6>".into(),
                    points: vec![(2e-3, 2e-2)],
                },
            ],
            lines: vec![(1e-2, "1 %".into())],
        };
        let text = svg("errors & times", &[panel("a"), panel("b"), panel("c")], 2);
        assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
        assert_eq!(
            text.matches("<polyline").count(),
            3,
            "one line per multi-point series"
        );
        // 3 finite points per panel (the x = 0 one dropped) + 2 legend markers.
        assert_eq!(text.matches("<circle").count(), 3 * 3 + 2);
        assert!(text.contains("errors &amp; times") && text.contains("dd &lt;1e-6&gt;"));
        let empty = Panel {
            series: vec![],
            lines: vec![],
            ..panel("empty")
        };
        assert!(svg("t", &[empty], 1).contains("no data"));
    }
}
