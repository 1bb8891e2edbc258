// tonegate dashboard: a small single-page app over /api/v1 (hash routes, no
// build step, no external files). Every value from the API is put into the
// page as text, never as HTML.
"use strict";

const API = "/api/v1";
const STAGES = ["sphere", "taa_sobel", "taa", "luminance_stats", "histogram", "adaptation", "tonemap", "bloom_bright", "bloom_downsample", "bloom_blur", "bloom_composite", "grade_stats", "grade", "encode"];

// ---- small DOM helpers ----------------------------------------------------
function h(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else if (k === "class") e.className = v;
    else e.setAttribute(k, v === true ? "" : String(v));
  }
  for (const c of children.flat()) {
    if (c === undefined || c === null || c === false) continue;
    e.appendChild(typeof c === "string" || typeof c === "number" ? document.createTextNode(String(c)) : c);
  }
  return e;
}
const view = () => document.getElementById("view");
function show(...nodes) {
  const v = view();
  // replaceChildren would print a skipped part (null, false) as its text.
  v.replaceChildren(...nodes.flat().filter((n) => n !== undefined && n !== null && n !== false));
  v.setAttribute("data-ready", "1");
}
function num(v, digits) {
  if (v === null || v === undefined) return "–";
  if (v === Infinity) return "∞";
  if (typeof v !== "number") return String(v);
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e6)) return v.toExponential(2);
  return v.toFixed(digits === undefined ? 2 : digits);
}
function when(iso) {
  if (!iso) return "–";
  const d = new Date(iso);
  return isNaN(d) ? iso : d.toISOString().replace("T", " ").slice(0, 19) + "Z";
}
function duration(a, b) {
  if (!a || !b) return "–";
  const s = (new Date(b) - new Date(a)) / 1000;
  return s < 120 ? s.toFixed(1) + " s" : (s / 60).toFixed(1) + " min";
}
function badge(status) {
  return h("span", { class: "badge " + status }, status);
}

// ---- API access -----------------------------------------------------------
function token() { return sessionStorage.getItem("tonegate-token") || ""; }
function authHeaders() {
  const t = token();
  return t ? { Authorization: "Bearer " + t } : {};
}
async function api(path, init) {
  const r = await fetch(API + path, { ...(init || {}), headers: { ...authHeaders(), ...((init || {}).headers || {}) } });
  const text = await r.text();
  let body = null;
  // JSON.parse reads 1e999 (an infinite PSNR) as Infinity.
  try { body = text ? JSON.parse(text) : null; } catch (_) { body = { error: "bad_json", detail: text.slice(0, 200) }; }
  if (!r.ok) {
    if (r.status === 401 || r.status === 403) document.getElementById("token-box").hidden = false;
    const e = new Error((body && body.detail) || r.statusText);
    e.status = r.status;
    e.code = body && body.error;
    throw e;
  }
  return body;
}
function failure(e) {
  return h("div", { class: "error", role: "alert" }, `${e.status ? e.status + " " : ""}${e.code ? e.code + ": " : ""}${e.message}`);
}

// ---- routes ---------------------------------------------------------------
let timer = null;
function parseHash() {
  const [path, q] = (location.hash.replace(/^#/, "") || "/runs").split("?");
  return { parts: path.split("/").filter(Boolean), params: new URLSearchParams(q || "") };
}
async function route() {
  clearTimeout(timer);
  const { parts, params } = parseHash();
  view().removeAttribute("data-ready");
  for (const a of document.querySelectorAll("nav a[data-nav]")) a.classList.toggle("active", a.dataset.nav === (parts[0] || "runs"));
  try {
    if (parts[0] === "runs" && parts[1]) await runPage(+parts[1], params);
    else if (parts[0] === "trends") await trendsPage(params);
    else if (parts[0] === "tradeoff") await tradeoffPage(parts[1], params);
    else if (parts[0] === "tonemap") await tonemapPage(params);
    else if (parts[0] === "fleet") await fleetPage(params);
    else if (parts[0] === "matrix") await matrixPage(params);
    else if (parts[0] === "frames") await framesPage(parts[1], params);
    else await runsPage(params);
  } catch (e) {
    show(failure(e));
  }
}
function setParams(base, params) {
  const q = new URLSearchParams();
  for (const [k, v] of Object.entries(params)) if (v) q.set(k, v);
  const s = q.toString();
  location.hash = base + (s ? "?" + s : "");
}

// ---- runs list ------------------------------------------------------------
async function runsPage(params) {
  const filters = { status: params.get("status") || "", kind: params.get("kind") || "", adapter: params.get("adapter") || "" };
  const q = new URLSearchParams({ limit: "200" });
  for (const [k, v] of Object.entries(filters)) if (v) q.set(k, v);
  const runs = await api("/runs?" + q);
  const select = (name, options) =>
    h("select", { name, onchange: (ev) => setParams("/runs", { ...filters, [name]: ev.target.value }) },
      options.map((o) => h("option", { value: o, selected: filters[name] === o }, o || `any ${name}`)));
  const adapter = h("input", { name: "adapter", placeholder: "adapter contains…", value: filters.adapter });
  adapter.addEventListener("change", () => setParams("/runs", { ...filters, adapter: adapter.value }));
  const start = h("button", { class: "primary", onclick: startRun }, "Start a run");
  const rows = runs.map((r) =>
    h("tr", { class: "run-row", "data-status": r.status },
      h("td", {}, h("a", { href: `#/runs/${r.id}` }, `#${r.id}`)),
      h("td", {}, r.kind),
      h("td", {}, badge(r.status)),
      h("td", {}, when(r.started_at)),
      h("td", {}, duration(r.started_at, r.ended_at)),
      h("td", {}, r.adapter || "–"),
      h("td", { class: r.scenes_failed ? "bad" : "" }, r.kind === "check" ? `${r.scenes - r.scenes_failed}/${r.scenes}` : `${r.scenes}`),
      h("td", { class: r.regressions ? "bad" : "" }, String(r.regressions)),
      h("td", { class: "mono" }, (r.git_commit || "").slice(0, 10)),
      h("td", {}, r.kind === "tradeoff" ? h("a", { href: `#/tradeoff/${r.id}` }, "scatter") : r.detail ? h("span", { class: "detail", title: r.detail }, r.detail.slice(0, 60)) : "")));
  show(
    h("h1", {}, "Runs"),
    h("div", { class: "toolbar" }, select("status", ["", "passed", "failed", "error", "aborted", "running"]), select("kind", ["", "check", "tradeoff"]), adapter, start, h("span", { id: "start-msg" })),
    runs.length
      ? h("table", { class: "runs" },
          h("thead", {}, h("tr", {}, ["Run", "Kind", "Status", "Started", "Took", "Adapter", "Scenes passed", "Regressions", "Commit", ""].map((t) => h("th", {}, t)))),
          h("tbody", {}, rows))
      : h("p", { class: "empty" }, "No runs match. `tonegate check` records one; so does “Start a run”."));
  if (runs.some((r) => r.status === "running")) timer = setTimeout(route, 3000);
}
async function startRun() {
  const msg = document.getElementById("start-msg");
  try {
    const r = await api("/runs", { method: "POST", headers: { "Content-Type": "application/json" }, body: "{}" });
    // A shared history queues the run for the fleet's runners.
    location.hash = r.job ? `/fleet?job=${r.job}` : `/runs/${r.id}`;
  } catch (e) {
    msg.replaceChildren(failure(e));
  }
}

// ---- fleet: runners and the queue -------------------------------------------
function ago(iso) {
  if (!iso) return "–";
  const s = (Date.now() - new Date(iso)) / 1000;
  return s < 120 ? `${Math.max(0, s).toFixed(0)} s ago` : s < 7200 ? `${(s / 60).toFixed(0)} min ago` : when(iso);
}
async function fleetPage(params) {
  const all = params.get("all") === "1";
  const state = params.get("state") || "";
  const q = new URLSearchParams({ limit: "200" });
  if (state) q.set("state", state);
  const [runners, queue] = await Promise.all([api("/runners" + (all ? "?all=true" : "")), api("/queue?" + q)]);
  const runnerRows = runners.map((r) =>
    h("tr", { class: "runner-row", "data-state": r.state },
      h("td", {}, r.name),
      h("td", {}, badge(r.state)),
      h("td", {}, r.adapter),
      h("td", {}, r.labels.join(", ") || "–"),
      h("td", { title: r.heartbeat }, ago(r.heartbeat)),
      h("td", {}, r.job_id ? `job ${r.job_id}` : "–"),
      h("td", {}, r.host)));
  const counts = Object.entries(queue.counts).map(([k, n]) => h("span", { class: "count", "data-state": k }, `${n} ${k}`));
  const jobRows = queue.jobs.map((j) =>
    h("tr", { class: "job-row", "data-state": j.state },
      h("td", {}, `${j.id}`),
      h("td", {}, badge(j.state)),
      h("td", {}, j.suite + (j.scenes.length ? ` (${j.scenes.join(", ")}${j.scenes_total > j.scenes.length ? `, … ${j.scenes_total} in all` : ""})` : "")),
      h("td", {}, [j.want_adapter && `adapter ~ ${j.want_adapter}`, j.want_label && `label ${j.want_label}`, j.cpu && "cpu"].filter(Boolean).join(", ") || "any runner"),
      h("td", {}, when(j.queued_at)),
      h("td", {}, j.claimed_at ? duration(j.queued_at, j.claimed_at) : "–"),
      h("td", {}, String(j.attempts)),
      h("td", {}, j.run_id ? h("a", { href: `#/runs/${j.run_id}` }, `#${j.run_id}`) : "–"),
      h("td", {}, j.detail ? h("span", { class: "detail", title: j.detail }, j.detail.slice(0, 60)) : "")));
  const stateSelect = h("select", { name: "state", onchange: (ev) => setParams("/fleet", { all: all ? "1" : "", state: ev.target.value }) },
    ["", "queued", "claimed", "done", "aborted"].map((o) => h("option", { value: o, selected: state === o }, o || "any state")));
  const allBox = h("label", {}, h("input", { type: "checkbox", checked: all, onchange: (ev) => setParams("/fleet", { all: ev.target.checked ? "1" : "", state }) }), " stopped and lost runners too");
  show(
    h("h1", {}, "Fleet"),
    h("h2", {}, `Runners (${runners.length})`),
    h("div", { class: "toolbar" }, allBox),
    runners.length
      ? h("table", { class: "runners" },
          h("thead", {}, h("tr", {}, ["Runner", "State", "Adapter", "Labels", "Heartbeat", "Running", "Host"].map((t) => h("th", {}, t)))),
          h("tbody", {}, runnerRows))
      : h("p", { class: "empty" }, "No runner is registered. `tonegate runner --db postgres://…` starts one."),
    h("h2", {}, "Queue"),
    h("div", { class: "toolbar" }, stateSelect, h("span", { class: "counts" }, counts.length ? counts : "no jobs")),
    queue.jobs.length
      ? h("table", { class: "jobs" },
          h("thead", {}, h("tr", {}, ["Job", "State", "Suite", "For", "Queued", "Waited", "Attempts", "Run", ""].map((t) => h("th", {}, t)))),
          h("tbody", {}, jobRows))
      : h("p", { class: "empty" }, "No jobs. `POST /api/v1/runs` or `tonegate enqueue` queues one when the history is shared."));
  timer = setTimeout(route, 3000);
}

// ---- one run ----------------------------------------------------------------
function checkText(spec) {
  const parts = [];
  for (const [k, v] of Object.entries(spec)) if (!["set_by", "spp", "adapter"].includes(k)) parts.push(`${k} ${typeof v === "object" ? JSON.stringify(v) : v}`);
  if (spec.spp) parts.push(`at ${spec.spp} spp`);
  if (spec.adapter) parts.push(`on ${spec.adapter}`);
  return parts.join(", ");
}
async function runPage(id, params) {
  const { run, report } = await api(`/runs/${id}`);
  const head = h("div", { class: "run-head" },
    h("h1", {}, `Run #${run.id} `, badge(run.status)),
    h("dl", { class: "facts" },
      ...[["Kind", run.kind], ["Started", when(run.started_at)], ["Took", duration(run.started_at, run.ended_at)], ["Adapter", run.adapter || "–"],
        ["Driver", [run.driver, run.driver_info].filter(Boolean).join(" · ") || "–"], ["Suite", run.suite || "–"], ["Commit", run.git_commit || "–"], ["Host", run.host]]
        .flatMap(([k, v]) => [h("dt", {}, k), h("dd", {}, v)])),
    run.detail ? h("pre", { class: "error" }, run.detail) : null);
  if (run.status === "running") timer = setTimeout(route, 2000);
  if (run.kind === "tradeoff") return show(head, h("p", {}, h("a", { href: `#/tradeoff/${run.id}` }, "Open the error-against-time scatter →")));
  if (!report) return show(head, h("p", { class: "empty" }, run.status === "running" ? `Running: ${run.scenes} scene(s) recorded so far…` : "This run has no report."));
  const sceneName = params.get("scene") || (report.scenes.find((s) => s.frames.some((f) => f.artifacts && f.artifacts.length)) || report.scenes[0] || {}).scene;
  const scene = report.scenes.find((s) => s.scene === sceneName) || report.scenes[0];
  const sceneRows = report.scenes.map((s) => {
    const passed = s.checks.every((c) => c.passed !== false) && !(s.problems || []).length;
    const psnr = s.summaries.psnr, ssim = s.summaries.ssim;
    return h("tr", { class: s === scene ? "selected" : "" },
      h("td", {}, h("a", { href: `#/runs/${id}?scene=${encodeURIComponent(s.scene)}` }, s.scene)),
      h("td", {}, badge(passed ? "passed" : "failed")),
      h("td", {}, s.test), h("td", {}, String(s.spp)),
      h("td", {}, psnr ? `${num(psnr.worst)} dB (frame ${psnr.worst_frame})` : "–"),
      h("td", {}, ssim ? num(ssim.worst, 6) : "–"),
      h("td", {}, s.fps ? num(s.fps, 1) : "–"),
      h("td", {}, h("a", { href: `#/trends?scene=${encodeURIComponent(s.scene)}&adapter=${encodeURIComponent(run.adapter || "")}` }, "trend")));
  });
  const parts = [head,
    h("h2", {}, "Scenes"),
    h("table", { class: "scenes" }, h("thead", {}, h("tr", {}, ["Scene", "Result", "Test", "spp", "Worst PSNR", "Worst SSIM", "FPS", ""].map((t) => h("th", {}, t)))), h("tbody", {}, sceneRows))];
  if (report.regressions && report.regressions.length) {
    parts.push(h("h2", {}, "Performance regressions"),
      h("table", { class: "regressions" }, h("thead", {}, h("tr", {}, ["Scene", "Metric", "Value", "Median of earlier runs", "Bound", "Ratio", "Runs"].map((t) => h("th", {}, t)))),
        h("tbody", {}, report.regressions.map((g) => h("tr", { class: "bad" }, h("td", {}, g.scene), h("td", {}, g.metric), h("td", {}, num(g.value, 3)), h("td", {}, num(g.median, 3)), h("td", {}, num(g.bound, 3)), h("td", {}, num(g.ratio, 3)), h("td", {}, String(g.runs)))))));
  }
  const taa = taaComparisons(id, report);
  if (taa.length) parts.push(h("h2", { id: "taa" }, "Anti-aliasing: every TAA against no AA"), ...taa);
  if (scene) parts.push(...scenePanel(id, run, report, scene, params));
  if (report.stress) {
    const failed = report.stress.cases.filter((c) => !c.passed);
    parts.push(h("h2", {}, "Stress suite"), h("p", {}, `${report.stress.cases.length - failed.length}/${report.stress.cases.length} rows passed`, failed.length ? `; failing: ${failed.map((c) => c.name + " " + c.renderer).join(", ")}` : ""));
  }
  show(...parts);
}
// The TAA thesis's tables (docs/taa.md): the TAA scenes of one sequence side by side, best /
// worst / mean of each metric over the judged frames with frame indices, the
// PSNR gain of each over no AA frame by frame (a moving test with a no-AA
// scene), and the last frame of each variant (actual and SSIM map) beside the golden.
const VARIANTS = ["off", "clip", "edge_aware", "variance"];
function taaComparisons(id, report) {
  const groups = new Map();
  for (const s of report.scenes) {
    if (!s.taa) continue;
    const k = `${s.taa.sequence} ${s.test} ${s.spp}`;
    if (!groups.has(k)) groups.set(k, []);
    groups.get(k).push(s);
  }
  const out = [];
  for (const scenes of groups.values()) {
    if (scenes.length < 2) continue;
    scenes.sort((a, b) => VARIANTS.indexOf(a.taa.variant) - VARIANTS.indexOf(b.taa.variant));
    const stat = (s, key, higher) => {
      const v = s.frames.filter((f) => s.judged_frames.includes(f.frame)).map((f) => [f.frame, f.metrics[key]]);
      if (!v.length) return null;
      const by = (a, b) => (higher ? b[1] - a[1] : a[1] - b[1]);
      const sorted = [...v].sort(by);
      return { best: sorted[0], worst: sorted[sorted.length - 1], mean: v.reduce((t, x) => t + x[1], 0) / v.length };
    };
    const cell = (st, digits) => st ? `${num(st.best[1], digits)} @${st.best[0]} · ${num(st.worst[1], digits)} @${st.worst[0]} · ${num(st.mean, digits)}` : "–";
    const rows = scenes.map((s) => h("tr", { class: "taa-row", "data-variant": s.taa.variant },
      h("td", {}, s.taa.variant === "off" ? "no AA" : s.taa.variant, s.taa.settings ? h("div", { class: "muted" }, s.taa.settings) : ""),
      h("td", {}, h("a", { href: `#/runs/${id}?scene=${encodeURIComponent(s.scene)}` }, s.scene)),
      h("td", {}, s.test), h("td", {}, String(s.judged_frames.length)),
      h("td", {}, cell(stat(s, "psnr", true), 2)), h("td", {}, cell(stat(s, "ssim", true), 4)), h("td", {}, cell(stat(s, "flip_mean", false), 4))));
    const last = Math.min(...scenes.map((s) => s.frames.length ? s.frames[s.frames.length - 1].frame : 0));
    const art = (s, kind) => {
      const f = s.frames.find((x) => x.frame === last);
      const name = f && (f.artifacts || []).find((a) => a.endsWith(`-${kind}.png`));
      if (!name) return h("div", { class: "missing" }, `no ${kind} image`);
      const i = h("img", { src: `${API}/runs/${id}/artifacts/${encodeURIComponent(name)}`, alt: `${kind} of ${s.scene} frame ${last}`, "data-kind": kind, "data-variant": kind === "golden" ? "golden" : s.taa.variant });
      i.addEventListener("load", () => i.setAttribute("data-loaded", "1"));
      return i;
    };
    const label = (v) => (v === "off" ? "no AA" : v);
    // Frame by frame, each TAA scene's PSNR less no AA's on the same frame.
    const off = scenes.find((s) => s.taa.variant === "off");
    const psnrOf = (s, n) => { const f = s.frames.find((x) => x.frame === n); return f ? f.metrics.psnr : NaN; };
    const gains = off && scenes[0].test === "moving" ? scenes.filter((s) => s !== off).map((s) => ({
      name: s.scene,
      points: s.judged_frames.map((n) => ({ x: n, y: psnrOf(s, n) - psnrOf(off, n), label: `frame ${n}` })).filter((p) => Number.isFinite(p.y)),
    })) : [];
    const gainChart = gains.length ? [h("figure", { class: "chart-box taa-gain" }, h("figcaption", {}, `PSNR gain over no AA (${off.scene}), frame by frame: above 0, TAA helps`),
      lineChart(gains, { title: "PSNR gain over no AA", yLabel: "dB", xLabel: "frame", legend: true }))] : [];
    out.push(h("section", { class: "taa-compare", "data-test": scenes[0].test },
      h("h3", {}, `${scenes[0].test === "static" ? "Static" : "Ghosting"} test: ${scenes[0].frames.length} frames at ${scenes[0].spp} spp, each variant against the accumulation reference`),
      h("table", { class: "taa" }, h("thead", {}, h("tr", {}, ["Variant", "Scene", "Test", "Judged", "PSNR dB best @f · worst @f · mean", "SSIM best · worst · mean", "FLIP best · worst · mean"].map((t) => h("th", {}, t)))), h("tbody", {}, rows)),
      ...gainChart,
      h("div", { class: "side-by-side" },
        h("figure", {}, art(scenes[0], "golden"), h("figcaption", {}, `golden, frame ${last}`)),
        scenes.flatMap((s) => [h("figure", {}, art(s, "actual"), h("figcaption", {}, `${label(s.taa.variant)}, frame ${last}`)),
          h("figure", {}, art(s, "ssim"), h("figcaption", {}, `${label(s.taa.variant)}: SSIM map`))]))));
  }
  return out;
}

function scenePanel(id, run, report, scene, params) {
  const out = [h("h2", { id: "scene" }, `Scene ${scene.scene}`), h("p", { class: "muted" }, `plan: ${scene.plan.join(" → ")} · judged frames: ${scene.judged_frames.join(", ")}`)];
  out.push(h("table", { class: "checks" },
    h("thead", {}, h("tr", {}, ["Check", "Result", "Detail", "Bound set by"].map((t) => h("th", {}, t)))),
    h("tbody", {}, scene.checks.map((c) => h("tr", { class: c.passed === false ? "bad" : "" },
      h("td", {}, checkText(c.spec)), h("td", {}, badge(c.passed === null ? "not applied" : c.passed ? "passed" : "failed")), h("td", {}, c.detail), h("td", { class: "muted" }, c.spec.set_by || ""))))));
  for (const p of scene.problems || []) out.push(h("p", { class: "error" }, p));
  const kept = scene.frames.filter((f) => f.artifacts && f.artifacts.length);
  const frameNo = params.has("frame") ? +params.get("frame") : kept.length ? kept[0].frame : null;
  const frameRows = scene.frames.map((f) => {
    const m = f.metrics;
    return h("tr", { class: (f.failed_checks && f.failed_checks.length ? "bad " : "") + (f.frame === frameNo ? "selected" : ""), "data-frame": f.frame },
      h("td", {}, String(f.frame)), h("td", {}, num(m.psnr)), h("td", {}, num(m.ssim, 6)), h("td", {}, num(m.mse, 4)), h("td", {}, num(m.rmse, 4)),
      h("td", {}, num(m.snr)), h("td", {}, String(m.max_abs_diff)), h("td", {}, num(m.fraction_over_1lsb * 100, 3) + " %"), h("td", {}, num(m.flip_mean, 5)),
      h("td", {}, (f.failed_checks || []).map((i) => checkText(scene.checks[i].spec)).join("; ")),
      h("td", {}, f.artifacts && f.artifacts.length ? h("a", { href: `#/runs/${id}?scene=${encodeURIComponent(scene.scene)}&frame=${f.frame}` }, "compare") : ""));
  });
  out.push(h("h3", {}, "Per-frame metrics against the golden"),
    h("table", { class: "frames" }, h("thead", {}, h("tr", {}, ["Frame", "PSNR dB", "SSIM", "MSE", "RMSE", "SNR dB", "Max diff", "> 1 LSB", "FLIP", "Failed checks", ""].map((t) => h("th", {}, t)))), h("tbody", {}, frameRows)));
  if (scene.timings && scene.timings.length) {
    out.push(h("h3", {}, `GPU time per stage (${num(scene.fps, 1)} FPS with readback)`),
      h("table", { class: "timings" }, h("thead", {}, h("tr", {}, ["Stage", "Median ms", "p95 ms"].map((t) => h("th", {}, t)))),
        h("tbody", {}, scene.timings.map((t) => h("tr", {}, h("td", {}, t.name), h("td", {}, num(t.median_ms, 3)), h("td", {}, num(t.p95_ms, 3)))))));
  }
  const f = scene.frames.find((x) => x.frame === frameNo);
  if (f && f.artifacts && f.artifacts.length) out.push(comparer(id, scene.scene, f));
  else out.push(h("p", { class: "muted" }, "No images kept for this scene (a run keeps each scene's worst frame and every failing frame)."));
  return out;
}
function comparer(id, scene, f) {
  const url = (kind) => {
    const name = f.artifacts.find((a) => a.endsWith(`-${kind}.png`));
    return name ? `${API}/runs/${id}/artifacts/${encodeURIComponent(name)}` : null;
  };
  const img = (kind, extra) => {
    const src = url(kind);
    if (!src) return h("div", { class: "missing" }, `no ${kind} image`);
    const i = h("img", { src, alt: `${kind} of ${scene} frame ${f.frame}`, "data-kind": kind, ...(extra || {}) });
    i.addEventListener("load", () => i.setAttribute("data-loaded", "1"));
    return i;
  };
  const side = h("div", { class: "side-by-side" },
    ["golden", "actual", "diff", "ssim", "flip"].map((k) => h("figure", {}, img(k), h("figcaption", {}, { golden: "golden (CPU reference)", actual: "actual (this run)", diff: "|difference|: black 0, dark blue 1, blue 4, green 16, yellow 64, red 255 LSB", ssim: "SSIM map (dark = low)", flip: "FLIP error (magma: black 0, purple, orange, pale yellow 1)" }[k]))));
  const top = img("actual", { class: "top" });
  const wrap = h("div", { class: "slider-wrap" }, img("golden", { class: "bottom" }), top);
  const range = h("input", { type: "range", min: 0, max: 100, value: 50, "aria-label": "golden / actual split" });
  const apply = () => { top.style.clipPath = `inset(0 0 0 ${range.value}%)`; wrap.style.setProperty("--split", range.value + "%"); };
  range.addEventListener("input", apply);
  apply();
  return h("section", { class: "comparer", "data-frame": f.frame },
    h("h3", {}, `Frame ${f.frame}: PSNR ${num(f.metrics.psnr)} dB, SSIM ${num(f.metrics.ssim, 6)}, FLIP ${num(f.metrics.flip_mean, 5)}, max diff ${f.metrics.max_abs_diff}`),
    side,
    h("h3", {}, "Slider: golden (left) | actual (right)"),
    wrap, range);
}

// ---- adapter matrix ---------------------------------------------------------
// Scene × adapter over each adapter's newest check run: a scene that passes on
// one adapter and fails on another is marked "split" and listed first.
async function matrixPage(params) {
  const limit = params.get("limit");
  const m = await api("/matrix" + (limit ? `?limit=${encodeURIComponent(limit)}` : ""));
  if (!m.adapters.length) return show(h("h1", {}, "Adapter matrix"), h("p", { class: "empty" }, "No finished check runs yet. `tonegate check --adapter NAME` (or --backend gl) records one per adapter; `tonegate adapters` lists them."));
  const cell = (scene, column) => m.cells.find((c) => c.scene === scene && c.column === column);
  const split = new Set(m.split);
  const scenes = [...m.split, ...m.scenes.filter((s) => !split.has(s))];
  const head = h("tr", {}, h("th", {}, "Scene"), m.adapters.map((a) => h("th", { "data-adapter": a.adapter },
    h("div", { class: "name", title: a.adapter }, a.adapter), h("div", { class: "muted" }, [a.backend, `run #${a.run_id}`].filter(Boolean).join(" · ")),
    h("div", { class: "muted" }, a.flushes_subnormals === null || a.flushes_subnormals === undefined ? "subnormals: not measured" : a.flushes_subnormals ? "flushes subnormals" : "keeps subnormals"))));
  const rows = scenes.map((s) => h("tr", { class: split.has(s) ? "split" : "", "data-scene": s },
    h("td", {}, s, split.has(s) ? h("span", { class: "badge failed", title: "passes on one adapter, fails on another" }, "split") : null),
    m.adapters.map((a, i) => {
      const c = cell(s, i);
      if (!c) return h("td", { class: "muted" }, "–");
      return h("td", { class: "cell " + (c.passed ? "pass" : "fail"), "data-passed": c.passed ? "1" : "0" },
        h("a", { href: `#/runs/${c.run_id}?scene=${encodeURIComponent(s)}` }, c.passed ? "pass" : "FAIL"),
        h("div", { class: "muted" }, `${num(c.worst_psnr)} dB · FLIP ${num(c.worst_flip, 5)} · ${c.fps ? num(c.fps, 1) + " FPS" : "–"}`));
    })));
  show(h("h1", {}, "Adapter matrix"),
    h("p", { class: "muted" }, "Each adapter's newest finished check run; a cell is the scene's verdict, its worst frame's PSNR and FLIP against the golden, and its FPS with readback. A cell opens that run's comparer."),
    m.split.length ? h("p", { class: "error", role: "alert" }, `Split: ${m.split.join(", ")} pass(es) on one adapter and fail(s) on another.`) : null,
    m.adapters_total > m.adapters.length
      ? h("p", { class: "notice", "data-more": String(m.adapters_total - m.adapters.length) },
        `Showing the ${m.adapters.length} most recently run of ${m.adapters_total} adapters. `,
        h("a", { href: "#/matrix?limit=500" }, "Show up to 500"), ".")
      : null,
    h("table", { class: "matrix" }, h("thead", {}, head), h("tbody", {}, rows)));
}

// ---- trends ---------------------------------------------------------------
async function trendsPage(params) {
  const adapter = params.get("adapter") || "";
  const all = await api("/trends?metric=fps&limit=500");
  const scenes = [...new Set(all.map((p) => p.scene))].sort();
  const adapters = [...new Set(all.map((p) => p.adapter).filter(Boolean))].sort();
  const scene = params.get("scene") || scenes[0] || "";
  const controls = h("div", { class: "toolbar" },
    h("select", { name: "scene", onchange: (e) => setParams("/trends", { scene: e.target.value, adapter }) }, scenes.map((s) => h("option", { value: s, selected: s === scene }, s))),
    h("select", { name: "adapter", onchange: (e) => setParams("/trends", { scene, adapter: e.target.value }) },
      h("option", { value: "" }, "any adapter"), adapters.map((a) => h("option", { value: a, selected: a === adapter }, a))));
  if (!scene) return show(h("h1", {}, "Trends"), h("p", { class: "empty" }, "No check runs yet."));
  const q = (metric) => api(`/trends?metric=${metric}&scene=${encodeURIComponent(scene)}${adapter ? "&adapter=" + encodeURIComponent(adapter) : ""}&limit=500`);
  const [fps, psnr, ssim, flip, ...stages] = await Promise.all([q("fps"), q("psnr"), q("ssim"), q("flip_mean"), ...STAGES.map(q)]);
  // One line per adapter: runs on different hardware are not one series.
  const byAdapter = (points) => {
    const groups = new Map();
    for (const p of points) {
      const k = p.adapter || "?";
      if (!groups.has(k)) groups.set(k, []);
      groups.get(k).push({ x: p.run_id, y: p.value, regression: p.regression, change: p.change, label: `run ${p.run_id} (${p.status})` });
    }
    return [...groups].map(([name, points]) => ({ name, points }));
  };
  const chart = (title, points, yLabel, extra) => h("figure", { class: "chart-box" }, h("figcaption", {}, title), lineChart(byAdapter(points), { title, yLabel, xLabel: "run", legend: true, ...(extra || {}) }));
  const stageSeries = STAGES.map((s, i) => ({ name: s, points: stages[i].map((p) => ({ x: p.run_id, y: p.value, regression: p.regression, change: p.change, label: `run ${p.run_id} · ${p.adapter}` })) })).filter((s) => s.points.length);
  const shifts = [["FPS", fps], ["PSNR", psnr], ["SSIM", ssim], ["FLIP", flip], ...STAGES.map((s, i) => [s, stages[i]])]
    .flatMap(([name, pts]) => pts.filter((p) => p.change).map((p) => `${name} ×${p.change.toFixed(3)} at run ${p.run_id} (${p.adapter || "?"})`));
  const regressions = [...fps, ...stages.flat()].filter((p) => p.regression);
  show(h("h1", {}, `Trends · ${scene}`), controls,
    h("p", { class: "muted" }, "Red points are runs flagged as performance regressions against the median of earlier runs on the same adapter and configuration; a dashed rule is where a series' level shifted (E-Divisive change point, per adapter)."),
    shifts.length ? h("p", { class: "shifts" }, `Level shifts: ${shifts.join("; ")}`) : null,
    h("div", { class: "charts" },
      chart("FPS (with readback)", fps, "FPS", { zero: true }),
      chart("Worst-frame PSNR against the golden (dB)", psnr, "dB"),
      chart("Worst-frame SSIM", ssim, "SSIM"),
      chart("Worst-frame FLIP mean", flip, "FLIP", { zero: true }),
      h("figure", { class: "chart-box" }, h("figcaption", {}, "GPU median ms per stage"), lineChart(stageSeries, { title: "stage ms", yLabel: "ms", xLabel: "run", zero: true, legend: true }))),
    regressions.length ? h("p", { class: "bad" }, `${regressions.length} regression point(s): runs ${[...new Set(regressions.map((p) => p.run_id))].join(", ")}`) : h("p", { class: "muted" }, "No regressions flagged for this scene."));
}

// ---- tradeoff ---------------------------------------------------------------
async function tradeoffPage(idText, params) {
  let id = idText ? +idText : null;
  if (!id) {
    const runs = await api("/runs?kind=tradeoff&limit=1");
    if (!runs.length) return show(h("h1", {}, "Error against run time"), h("p", { class: "empty" }, "No tradeoff run yet: `tonegate tradeoff` records one."));
    id = runs[0].id;
  }
  const { run, points } = await api(`/tradeoff/${id}`);
  const scenes = [...new Set(points.map((p) => p.scene))];
  const scene = params.get("scene") || (scenes.includes("suite") ? "suite" : scenes[0]);
  const pts = points.filter((p) => p.scene === scene);
  const front = pts.filter((p) => p.pareto).sort((a, b) => a.ms - b.ms);
  show(h("h1", {}, `Error against run time · run #${run.id} `, badge(run.status)),
    h("div", { class: "toolbar" }, h("select", { name: "scene", onchange: (e) => setParams(`/tradeoff/${id}`, { scene: e.target.value }) }, scenes.map((s) => h("option", { value: s, selected: s === scene }, s)))),
    h("p", { class: "muted" }, `${pts.length} configurations; the Pareto front (large points, step line) is every configuration no other beats on both time and PSNR.${scene === "suite" ? " Suite: time summed over scenes, PSNR of the worst scene." : ""}`),
    h("figure", { class: "chart-box" }, scatterChart(pts.map((p) => ({ x: p.ms, y: p.psnr, label: p.label, pareto: p.pareto })), { title: "PSNR against ms", xLabel: "ms per frame (log scale)", yLabel: "PSNR dB" })),
    h("h2", {}, "Pareto front"),
    h("table", { class: "front" }, h("thead", {}, h("tr", {}, ["Configuration", "ms", "PSNR dB", "SSIM", "Adaptation rel. err"].map((t) => h("th", {}, t)))),
      h("tbody", {}, front.map((p) => h("tr", {}, h("td", {}, p.label), h("td", {}, num(p.ms)), h("td", {}, num(p.psnr)), h("td", {}, num(p.ssim, 4)), h("td", {}, num(p.log_average_rel_error)))))));
}

// ---- tone-map an upload -------------------------------------------------------
// The operators and their parameters come from the server (GET /operators, made
// from the operators' definitions), so the form offers every operator it knows.
async function tonemapPage(params) {
  let operators = [];
  try {
    operators = await api("/operators");
  } catch (e) {
    return show(h("h1", {}, "Tone-map an HDR image"), failure(e));
  }
  const file = h("input", { type: "file", name: "file", accept: ".hdr,.exr,.pfm" });
  // The image to tone-map: the chosen file, or a built-in sample fetched from the server.
  let source = null;
  file.addEventListener("change", () => { source = file.files[0] || null; if (source) run(); });
  async function useSample(name) {
    try {
      const r = await fetch(`${API}/samples/${name}.hdr`, { headers: authHeaders() });
      if (!r.ok) throw new Error(`sample ${name}: ${r.status}`);
      source = await r.blob();
      if (params.get("sheet")) contactSheet();
      else run();
    } catch (e) {
      result.replaceChildren(failure(e));
    }
  }
  const samples = h("span", { class: "samples" }, "or try a built-in image: ",
    ["sky", "interior", "night", "grid", "colours"].map((n) => h("button", { type: "button", "data-sample": n, onclick: () => useSample(n) }, n)));
  const field = (label, input) => h("label", {}, h("span", {}, label), input);
  const operator = h("select", { name: "operator" }, operators.map((o) => h("option", { value: o.name, title: o.summary }, o.name)));
  const summary = h("p", { class: "muted operator-summary" });
  // One control per parameter of the chosen operator; an empty one (or a word at
  // its default) is not sent, so the operator's own default applies.
  const paramBox = h("span", { class: "operator-params" });
  let controls = [];
  function paramControl(p) {
    const title = `${p.doc} (${p.expected})`;
    let input;
    if (p.type === "word") input = h("select", { name: p.name, title }, p.words.map((w) => h("option", { value: w, selected: w === p.default }, w)));
    else if (p.type === "flag") input = h("select", { name: p.name, title }, ["false", "true"].map((w) => h("option", { value: w, selected: String(p.default) === w }, w)));
    else input = h("input", { name: p.name, size: 7, title, placeholder: p.default === null ? "measured" : String(p.default) });
    input.addEventListener("change", later);
    controls.push({ p, input });
    return field(p.name.replace(/_/g, " "), input);
  }
  function showParams() {
    const o = operators.find((x) => x.name === operator.value);
    controls = [];
    summary.textContent = o ? o.summary : "";
    paramBox.replaceChildren(...(o ? o.params.map(paramControl) : []));
  }
  function operatorQuery(q) {
    for (const { p, input } of controls) {
      const v = input.value.trim();
      if (v === "" || ((p.type === "word" || p.type === "flag") && v === String(p.default))) continue;
      q.set(p.name, v);
    }
  }
  const bloom = h("input", { name: "bloom", type: "range", min: 0, max: 1, step: 0.05, value: 0 });
  const bloomOut = h("output", {}, "0.00");
  const gamma = h("input", { name: "gamma", placeholder: "sRGB", size: 6 });
  // PQ and HLG only for an operator that maps onto a display of known peak.
  const display = h("select", { name: "display", title: "sdr: 8-bit PNG; pq, hlg: 16-bit BT.2100 PNG (cICP), for an operator that maps onto a display of known peak" },
    ["sdr", "pq", "hlg"].map((d) => h("option", { value: d }, d)));
  function showDisplay() {
    const o = operators.find((x) => x.name === operator.value);
    const hdr = !!(o && o.hdr_output);
    for (const opt of display.options) opt.disabled = !hdr && opt.value !== "sdr";
    if (!hdr) display.value = "sdr";
  }
  const gpu = h("select", { name: "gpu" }, h("option", { value: "true" }, "GPU"), h("option", { value: "false" }, "CPU reference"));
  const result = h("div", { class: "tonemap-result" }, h("p", { class: "muted" }, "Choose an .hdr, .exr or .pfm file (or a built-in sample); the result updates as you change the settings."));
  const tonemap = (q) => api("/tonemap?" + q, { method: "POST", body: source, headers: { "Content-Type": "application/octet-stream" } });
  const resolved = (tone) => Object.entries(tone).filter(([k]) => k !== "operator").map(([k, v]) => [k.replace(/_/g, " "), num(v, 4)]);
  let pending = 0;
  async function run() {
    if (!source) return;
    bloomOut.value = (+bloom.value).toFixed(2);
    const q = new URLSearchParams({ format: "json", gpu: gpu.value, operator: operator.value });
    operatorQuery(q);
    if (+bloom.value > 0) q.set("bloom", bloom.value);
    if (gamma.value.trim()) q.set("gamma", gamma.value.trim());
    if (display.value !== "sdr") q.set("display", display.value);
    const mine = ++pending;
    result.setAttribute("aria-busy", "true");
    try {
      const r = await tonemap(q);
      if (mine !== pending) return;
      const img = h("img", { src: `data:image/png;base64,${r.image.base64}`, alt: "tone-mapped result", class: "result" });
      img.addEventListener("load", () => img.setAttribute("data-loaded", "1"));
      result.replaceChildren(img,
        h("dl", { class: "facts" }, ...[["Size", `${r.width}×${r.height}`], ["Renderer", r.adapter], ["Plan", r.plan.join(" → ")], ["Operator", r.tone.operator], ...resolved(r.tone),
          ...(r.hdr ? [["Display", `${r.hdr.display}, ${num(r.hdr.black_nits)} … ${num(r.hdr.peak_nits)} cd/m², 16-bit BT.2100`], ["MaxCLL / MaxFALL", `${num(r.hdr.max_cll, 1)} / ${num(r.hdr.max_fall, 1)} cd/m²`]] : []),
          ["Luminance", `${num(r.input.min_luminance)} … ${num(r.input.max_luminance)} (${num(r.input.dynamic_range_stops, 1)} stops)`], ["Time", `${num(r.render_ms, 1)} ms (+${num(r.queue_ms, 1)} ms queued)`]]
          .flatMap(([k, v]) => [h("dt", {}, k), h("dd", {}, v)])));
    } catch (e) {
      if (mine === pending) result.replaceChildren(failure(e));
    } finally {
      if (mine === pending) result.removeAttribute("aria-busy");
    }
  }
  // The contact sheet: the image through every operator at its defaults, one
  // after the other on the chosen renderer, each with the time the server took.
  const sheetExposure = h("input", { name: "sheet_exposure", size: 6, placeholder: "1", title: "The contact sheet's exposure for every operator that takes one (the fixed curves)" });
  async function contactSheet() {
    if (!source) return result.replaceChildren(h("p", { class: "bad" }, "Choose a file or a sample first."));
    const exposure = sheetExposure.value.trim() || params.get("exposure") || "";
    const mine = ++pending;
    const cells = operators.map((o) => h("figure", { class: "sheet-cell", "data-operator": o.name }, h("figcaption", {}, o.name, " · …")));
    const sheet = h("div", { class: "contact-sheet" }, cells);
    result.replaceChildren(h("p", { class: "muted" }, `Every operator at its defaults${exposure ? `, exposure ${exposure} where it takes one` : ""} (${gpu.value === "true" ? "GPU" : "CPU reference"}); the time is the server's for the whole job.`), sheet);
    for (const [i, o] of operators.entries()) {
      if (mine !== pending) return;
      try {
        const q = new URLSearchParams({ format: "json", gpu: gpu.value, operator: o.name });
        if (exposure && o.params.some((p) => p.name === "exposure")) q.set("exposure", exposure);
        const r = await tonemap(q);
        const img = h("img", { src: `data:image/png;base64,${r.image.base64}`, alt: o.name, title: o.summary });
        img.addEventListener("load", () => img.setAttribute("data-loaded", "1"));
        cells[i].replaceChildren(img, h("figcaption", {}, h("b", {}, o.name), ` · ${num(r.render_ms, 1)} ms`));
        cells[i].setAttribute("data-ms", r.render_ms);
      } catch (e) {
        cells[i].replaceChildren(h("figcaption", {}, o.name), failure(e));
      }
    }
    sheet.setAttribute("data-done", "1");
  }
  let debounce = null;
  const later = () => { clearTimeout(debounce); debounce = setTimeout(run, 250); };
  operator.addEventListener("change", () => { showParams(); showDisplay(); later(); });
  for (const i of [bloom, gamma, gpu, display]) i.addEventListener(i.type === "range" ? "input" : "change", later);
  if (params.get("operator") && operators.some((o) => o.name === params.get("operator"))) operator.value = params.get("operator");
  showParams();
  showDisplay();
  const wanted = [...display.options].find((o) => o.value === params.get("display"));
  if (wanted && !wanted.disabled) display.value = wanted.value;
  show(h("h1", {}, "Tone-map an HDR image"),
    h("form", { class: "tonemap-form", onsubmit: (e) => { e.preventDefault(); run(); } },
      field("HDR file", file), field("Operator", operator), paramBox,
      field("Bloom", h("span", {}, bloom, bloomOut)), field("Gamma", gamma), field("Display", display), field("Renderer", gpu), h("button", { class: "primary", type: "submit" }, "Tone-map"),
      h("button", { type: "button", name: "sheet", onclick: contactSheet, title: "The image through every operator, side by side, each with its time" }, "Contact sheet"),
      field("Sheet exposure", sheetExposure)),
    summary,
    samples,
    result);
  if (params.get("sample")) useSample(params.get("sample"));
}

// ---- start ------------------------------------------------------------------
function setupToken() {
  const box = document.getElementById("token-box");
  const input = box.querySelector("input");
  input.value = token();
  box.querySelector("button").addEventListener("click", () => {
    sessionStorage.setItem("tonegate-token", input.value.trim());
    box.hidden = true;
    route();
  });
}
window.addEventListener("hashchange", route);
window.addEventListener("DOMContentLoaded", () => { setupToken(); route(); });
