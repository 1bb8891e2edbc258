// Hand-written SVG charts: a line chart over runs and an error-against-time
// scatter with its Pareto front. Hand-written rather than a vendored library
// because the dashboard must work offline with no build step, the charts need
// only axes, lines, points and tooltips (~200 lines), and the DOM they make
// (svg.chart > path.series, circle.point, circle.regression) is what the
// browser tests look for.
"use strict";

const SVG_NS = "http://www.w3.org/2000/svg";

function svgEl(tag, attrs, text) {
  const e = document.createElementNS(SVG_NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, String(v));
  if (text !== undefined) e.textContent = text;
  return e;
}

// Round axis ticks: about `n` steps of 1, 2 or 5 times a power of ten.
function ticks(lo, hi, n) {
  if (!(hi > lo)) { hi = lo + 1; lo = lo - 1; }
  const raw = (hi - lo) / n;
  const p = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * p).find((s) => s >= raw);
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) out.push(+v.toPrecision(12));
  return out;
}

function fmt(v) {
  if (v === Infinity) return "∞";
  if (v === -Infinity) return "−∞";
  const a = Math.abs(v);
  if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(2);
  return +v.toPrecision(5) + "";
}

const PALETTE = ["#4e79a7", "#f28e2b", "#59a14f", "#b07aa1", "#76b7b2", "#edc948", "#ff9da7", "#9c755f", "#bab0ac", "#e15759"];

// series: [{name, points: [{x, y, label, regression, change}]}]; infinite y values are
// drawn on a band above the plot and labelled ∞.
function lineChart(series, opts) {
  const W = opts.width || 640, H = opts.height || 260;
  const m = { l: 64, r: 12, t: 24, b: 36 };
  const svg = svgEl("svg", { class: "chart", viewBox: `0 0 ${W} ${H}`, width: W, height: H, role: "img" });
  svg.appendChild(svgEl("title", {}, opts.title || "chart"));
  const all = series.flatMap((s) => s.points);
  const finite = all.filter((p) => Number.isFinite(p.y));
  const hasInf = all.some((p) => p.y === Infinity);
  if (all.length === 0) {
    svg.appendChild(svgEl("text", { x: W / 2, y: H / 2, "text-anchor": "middle", class: "empty" }, "no data"));
    return svg;
  }
  let x0 = Math.min(...all.map((p) => p.x)), x1 = Math.max(...all.map((p) => p.x));
  if (x0 === x1) { x0 -= 1; x1 += 1; }
  let y0 = finite.length ? Math.min(...finite.map((p) => p.y)) : 0;
  let y1 = finite.length ? Math.max(...finite.map((p) => p.y)) : 1;
  const pad = (y1 - y0) * 0.08 || Math.abs(y1) * 0.05 || 1;
  y0 -= pad; y1 += pad;
  if (opts.zero && y0 > 0) y0 = 0;
  const top = m.t + (hasInf ? 16 : 0);
  const X = (x) => m.l + ((x - x0) / (x1 - x0)) * (W - m.l - m.r);
  const Y = (y) => (y === Infinity ? m.t + 4 : top + (1 - (y - y0) / (y1 - y0)) * (H - top - m.b));
  const axes = svgEl("g", { class: "axes" });
  for (const t of ticks(y0, y1, 5)) {
    axes.appendChild(svgEl("line", { x1: m.l, x2: W - m.r, y1: Y(t), y2: Y(t), class: "grid" }));
    axes.appendChild(svgEl("text", { x: m.l - 6, y: Y(t) + 4, "text-anchor": "end" }, fmt(t)));
  }
  if (hasInf) axes.appendChild(svgEl("text", { x: m.l - 6, y: m.t + 8, "text-anchor": "end" }, "∞"));
  const xt = ticks(x0, x1, Math.min(8, Math.max(1, Math.round(x1 - x0)))).filter((t) => Number.isInteger(t));
  for (const t of xt) axes.appendChild(svgEl("text", { x: X(t), y: H - m.b + 16, "text-anchor": "middle" }, String(t)));
  axes.appendChild(svgEl("text", { x: (m.l + W - m.r) / 2, y: H - 4, "text-anchor": "middle", class: "label" }, opts.xLabel || ""));
  axes.appendChild(svgEl("text", { x: 12, y: m.t - 8, class: "label" }, opts.yLabel || ""));
  svg.appendChild(axes);
  series.forEach((s, i) => {
    const colour = PALETTE[i % PALETTE.length];
    const pts = s.points.slice().sort((a, b) => a.x - b.x);
    const d = pts.map((p, k) => `${k ? "L" : "M"}${X(p.x).toFixed(1)},${Y(p.y).toFixed(1)}`).join("");
    svg.appendChild(svgEl("path", { d, class: "series", stroke: colour, "data-series": s.name }));
    for (const p of pts) {
      if (p.change) {
        // A level shift (E-Divisive) begins at this run: a dashed rule.
        const l = svgEl("line", { x1: X(p.x).toFixed(1), x2: X(p.x).toFixed(1), y1: top, y2: H - m.b, class: "change", stroke: colour, "stroke-dasharray": "4 3", "data-series": s.name });
        l.appendChild(svgEl("title", {}, `${s.name}: level shift at run ${p.x}, new level ×${p.change.toFixed(3)} of the old`));
        svg.appendChild(l);
      }
      const c = svgEl("circle", {
        cx: X(p.x).toFixed(1), cy: Y(p.y).toFixed(1), r: p.regression ? 5 : 3,
        class: p.regression ? "point regression" : "point", fill: p.regression ? "#d62728" : colour,
      });
      c.appendChild(svgEl("title", {}, `${s.name} · ${p.label || "run " + p.x}: ${fmt(p.y)}${p.regression ? " · REGRESSION" : ""}`));
      svg.appendChild(c);
    }
  });
  if (series.length > 1 || opts.legend) {
    const g = svgEl("g", { class: "legend" });
    let x = m.l;
    series.forEach((s, i) => {
      g.appendChild(svgEl("rect", { x, y: 4, width: 10, height: 10, fill: PALETTE[i % PALETTE.length] }));
      const t = svgEl("text", { x: x + 14, y: 13 }, s.name);
      g.appendChild(t);
      x += 24 + s.name.length * 6.8;
    });
    svg.appendChild(g);
  }
  return svg;
}

// points: [{x (ms), y (PSNR dB), label, pareto}]; x on a log scale (the
// configurations span an order of magnitude); the front is a step line.
function scatterChart(points, opts) {
  const W = opts.width || 720, H = opts.height || 420;
  const m = { l: 64, r: 16, t: 16, b: 40 };
  const svg = svgEl("svg", { class: "chart scatter", viewBox: `0 0 ${W} ${H}`, width: W, height: H, role: "img" });
  svg.appendChild(svgEl("title", {}, opts.title || "scatter"));
  const pts = points.filter((p) => Number.isFinite(p.x) && p.x > 0 && Number.isFinite(p.y));
  if (!pts.length) {
    svg.appendChild(svgEl("text", { x: W / 2, y: H / 2, "text-anchor": "middle", class: "empty" }, "no data"));
    return svg;
  }
  const lx0 = Math.log10(Math.min(...pts.map((p) => p.x)) * 0.9), lx1 = Math.log10(Math.max(...pts.map((p) => p.x)) * 1.1);
  let y0 = Math.min(...pts.map((p) => p.y)), y1 = Math.max(...pts.map((p) => p.y));
  const pad = (y1 - y0) * 0.08 || 1;
  y0 -= pad; y1 += pad;
  const X = (x) => m.l + ((Math.log10(x) - lx0) / (lx1 - lx0 || 1)) * (W - m.l - m.r);
  const Y = (y) => m.t + (1 - (y - y0) / (y1 - y0)) * (H - m.t - m.b);
  const axes = svgEl("g", { class: "axes" });
  for (const t of ticks(y0, y1, 6)) {
    axes.appendChild(svgEl("line", { x1: m.l, x2: W - m.r, y1: Y(t), y2: Y(t), class: "grid" }));
    axes.appendChild(svgEl("text", { x: m.l - 6, y: Y(t) + 4, "text-anchor": "end" }, fmt(t)));
  }
  for (let e = Math.floor(lx0); e <= Math.ceil(lx1); e++) {
    for (const mult of [1, 2, 5]) {
      const v = mult * Math.pow(10, e);
      if (Math.log10(v) < lx0 || Math.log10(v) > lx1) continue;
      axes.appendChild(svgEl("line", { x1: X(v), x2: X(v), y1: m.t, y2: H - m.b, class: "grid" }));
      axes.appendChild(svgEl("text", { x: X(v), y: H - m.b + 14, "text-anchor": "middle" }, fmt(v)));
    }
  }
  axes.appendChild(svgEl("text", { x: (m.l + W - m.r) / 2, y: H - 6, "text-anchor": "middle", class: "label" }, opts.xLabel || ""));
  axes.appendChild(svgEl("text", { x: 12, y: m.t + 4, class: "label" }, opts.yLabel || ""));
  svg.appendChild(axes);
  const front = pts.filter((p) => p.pareto).sort((a, b) => a.x - b.x);
  if (front.length) {
    let d = `M${X(front[0].x)},${Y(front[0].y)}`;
    for (let i = 1; i < front.length; i++) d += `H${X(front[i].x)}V${Y(front[i].y)}`;
    svg.appendChild(svgEl("path", { d, class: "front" }));
  }
  for (const p of pts) {
    const c = svgEl("circle", { cx: X(p.x), cy: Y(p.y), r: p.pareto ? 5 : 3, class: p.pareto ? "point pareto" : "point" });
    c.appendChild(svgEl("title", {}, `${p.label}: ${fmt(p.x)} ms, ${fmt(p.y)} dB`));
    svg.appendChild(c);
  }
  front.forEach((p, i) => {
    svg.appendChild(svgEl("text", { x: X(p.x) + 7, y: Y(p.y) + (i % 2 ? 12 : -6), class: "pareto-label" }, p.label));
  });
  return svg;
}
