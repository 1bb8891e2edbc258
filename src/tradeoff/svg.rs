//! The error-against-run-time scatter as a self-contained SVG: hand-written
//! because it is a hundred lines, needs no fonts or raster back end, and the
//! dashboard can embed the same file.

use super::Point;
use std::fmt::Write;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// "Nice" tick values covering [lo, hi].
fn ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let span = (hi - lo).max(1e-9);
    let raw = span / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= n as f64)
        .unwrap_or(10.0 * mag);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * step {
        out.push(t);
        t += step;
    }
    out
}

/// Scatter of time (x) against PSNR (y); the Pareto front is filled and
/// joined. Infinite PSNR (identical to the reference) is drawn at the top.
pub fn scatter(points: &[Point], title: &str) -> String {
    let (w, h) = (760.0, 460.0);
    let (left, right, top, bottom) = (64.0, 24.0, 40.0, 52.0);
    let finite: Vec<f64> = points
        .iter()
        .map(|p| p.psnr)
        .filter(|v| v.is_finite())
        .collect();
    let ymax_data = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let ymin_data = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let (ymin, ymax) = if finite.is_empty() {
        (0.0, 60.0)
    } else {
        ((ymin_data - 2.0).floor(), (ymax_data + 4.0).ceil())
    };
    let xs: Vec<f64> = points
        .iter()
        .map(|p| p.ms)
        .filter(|v| v.is_finite())
        .collect();
    let xmax = xs.iter().copied().fold(0.0, f64::max) * 1.08 + 1e-6;
    let xmin = 0.0;
    let px = |x: f64| left + (x - xmin) / (xmax - xmin) * (w - left - right);
    let py = |y: f64| {
        let y = if y.is_finite() { y } else { ymax };
        top + (ymax - y) / (ymax - ymin) * (h - top - bottom)
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {w} {h}" width="{w}" height="{h}" font-family="sans-serif" font-size="11">"#
    );
    let _ = writeln!(s, r##"<rect width="100%" height="100%" fill="#fff"/>"##);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" font-size="14" text-anchor="middle">{}</text>"#,
        w / 2.0,
        escape(title)
    );
    for t in ticks(xmin, xmax, 8) {
        let x = px(t);
        let _ = writeln!(
            s,
            r##"<line x1="{x:.1}" y1="{top}" x2="{x:.1}" y2="{:.1}" stroke="#eee"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{t}</text>"##,
            h - bottom,
            h - bottom + 16.0
        );
    }
    for t in ticks(ymin, ymax, 6) {
        let y = py(t);
        let _ = writeln!(
            s,
            r##"<line x1="{left}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#eee"/><text x="{:.1}" y="{:.1}" text-anchor="end">{t}</text>"##,
            w - right,
            left - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        r##"<rect x="{left}" y="{top}" width="{:.1}" height="{:.1}" fill="none" stroke="#888"/>"##,
        w - left - right,
        h - top - bottom
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">GPU time per frame, ms (median of timestamps)</text>"#,
        (left + w - right) / 2.0,
        h - 12.0
    );
    let _ = writeln!(
        s,
        r#"<text x="16" y="{:.1}" text-anchor="middle" transform="rotate(-90 16 {:.1})">PSNR vs 128-spp reference, dB (worst frame)</text>"#,
        (top + h - bottom) / 2.0,
        (top + h - bottom) / 2.0
    );
    let mut front: Vec<&Point> = points.iter().filter(|p| p.pareto).collect();
    front.sort_by(|a, b| a.ms.total_cmp(&b.ms));
    if front.len() > 1 {
        let path: Vec<String> = front
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(p.ms), py(p.psnr)))
            .collect();
        let _ = writeln!(
            s,
            r##"<polyline points="{}" fill="none" stroke="#d9480f" stroke-width="1.5"/>"##,
            path.join(" ")
        );
    }
    for p in points.iter().filter(|p| !p.pareto) {
        let _ = writeln!(
            s,
            r##"<circle cx="{:.1}" cy="{:.1}" r="3.5" fill="none" stroke="#555"><title>{}: {:.3} ms, {:.2} dB</title></circle>"##,
            px(p.ms),
            py(p.psnr),
            escape(&p.label),
            p.ms,
            p.psnr
        );
    }
    // Labels of the front, moved up or down until they overlap no other
    // (front points often sit a few pixels apart).
    let mut placed: Vec<(f64, f64, f64)> = Vec::new(); // (x, y, width)
    for p in &front {
        let (cx, cy) = (px(p.ms), py(p.psnr));
        let width = 6.2 * p.label.chars().count() as f64;
        let x = if cx + 7.0 + width > w - right {
            cx - 7.0 - width
        } else {
            cx + 7.0
        };
        let y = (0..12)
            .map(|k| {
                let step = 13.0 * ((k + 1) / 2) as f64;
                cy - 6.0 + if k % 2 == 0 { step } else { -step }
            })
            .find(|&y| {
                y > top + 10.0
                    && y < h - bottom
                    && placed.iter().all(|&(px_, py_, pw)| {
                        (y - py_).abs() >= 12.0 || x + width < px_ || px_ + pw < x
                    })
            })
            .unwrap_or(cy - 6.0);
        placed.push((x, y, width));
        let _ = writeln!(
            s,
            r##"<circle class="pareto" cx="{cx:.1}" cy="{cy:.1}" r="5" fill="#d9480f"><title>{}: {:.3} ms, {:.2} dB (Pareto)</title></circle><text x="{x:.1}" y="{y:.1}" fill="#d9480f">{}</text>"##,
            escape(&p.label),
            p.ms,
            p.psnr,
            escape(&p.label)
        );
    }
    let _ = writeln!(
        s,
        r##"<text x="{:.1}" y="{:.1}" text-anchor="end" fill="#d9480f">filled: Pareto front ({} of {})</text>"##,
        w - right - 6.0,
        top + 14.0,
        front.len(),
        points.len()
    );
    s.push_str("</svg>\n");
    s
}
