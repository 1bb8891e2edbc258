// tonegate dashboard: the frames pages (docs/frames.md). The submissions,
// and one submission's frames to triage: each frame beside the positive it
// came closest to, with the difference, SSIM and FLIP maps, HDR images
// tone-mapped with the operator chosen here; a digest marked positive or
// negative one at a time, or every untriaged digest of the submission at
// once. Marking needs the triage token (or the server's), asked for in the
// token box. Uses app.js's helpers (h, api, show, badge, num, when, failure).
"use strict";

async function framesPage(id, params) {
  if (id) return submissionPage(+id, params);
  const rows = await api("/frames/submissions?limit=200");
  const keys = (k) => Object.entries(k || {}).map(([a, b]) => `${a}=${b}`).join(" ");
  show(
    h("h1", {}, "Frames"),
    h("p", { class: "muted" }, "Submissions of your renderer's frames (tonegate frames submit, POST /api/v1/frames/submissions), newest first."),
    rows.length
      ? h("table", { class: "submissions" },
          h("thead", {}, h("tr", {}, ["Submission", "Result", "When", "Branch", "Keys", "Frames", "Untriaged"].map((t) => h("th", {}, t)))),
          h("tbody", {}, rows.map((s) => h("tr", { class: "submission-row", "data-passed": s.passed ? "1" : "0" },
            h("td", {}, h("a", { href: `#/frames/${s.id}` }, `#${s.id}`)),
            h("td", {}, badge(s.passed ? "passed" : "failed")),
            h("td", {}, when(s.submitted_at)),
            h("td", {}, s.branch || "main line"),
            h("td", { class: "mono" }, keys(s.keys)),
            h("td", {}, String(s.frames)),
            h("td", { class: s.untriaged ? "bad" : "" }, String(s.untriaged))))))
      : h("p", { class: "empty" }, "No submissions yet. `tonegate frames submit FOLDER` makes one (docs/frames.md)."));
}

// Who is triaging is remembered in this browser; why is asked each time.
function whoBox() {
  const who = h("input", { name: "who", placeholder: "who", size: 12, value: localStorage.getItem("tonegate-who") || "" });
  who.addEventListener("change", () => localStorage.setItem("tonegate-who", who.value.trim()));
  return who;
}

// An image of the API. With a token in hand (a server with private
// reads), it is fetched with the token and shown from a blob, since an
// <img> cannot send one; otherwise the browser loads it lazily itself.
function imageOf(src, kind, alt) {
  const img = h("img", { alt, "data-kind": kind, "data-src": src, loading: "lazy" });
  img.addEventListener("load", () => img.setAttribute("data-loaded", "1"));
  img.addEventListener("error", () => img.setAttribute("data-loaded", "error"));
  if (token()) {
    fetch(src, { headers: authHeaders() })
      .then((r) => (r.ok ? r.blob() : Promise.reject(new Error(r.statusText))))
      .then((b) => { img.src = URL.createObjectURL(b); })
      .catch(() => img.setAttribute("data-loaded", "error"));
  } else {
    img.src = src;
  }
  return h("figure", {}, img, h("figcaption", {}, kind));
}

async function submissionPage(id, params) {
  const [detail, operators] = await Promise.all([api(`/frames/submissions/${id}`), api("/operators")]);
  const { submission, report } = detail;
  const all = params.get("all") === "1";
  const operator = params.get("operator") || "agx";
  const frames = report.frames.filter((f) => all || f.status !== "positive");
  const who = whoBox();
  const why = h("input", { name: "why", placeholder: "why", size: 40 });
  const msg = h("span", { id: "triage-msg" });
  const said = () => {
    if (!who.value.trim() || !why.value.trim()) throw Object.assign(new Error("say who you are and why"), { code: "bad_parameter" });
    return { who: who.value.trim(), why: why.value.trim() };
  };
  async function triage(body, path) {
    msg.replaceChildren("…");
    const r = await api(path, { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) });
    msg.replaceChildren(`${r.labelled} digest${r.labelled === 1 ? "" : "s"} marked`);
    msg.setAttribute("data-done", String(r.labelled));
    return r;
  }
  const bulk = (label) => async () => {
    try {
      await triage({ label, ...said() }, `/frames/submissions/${id}/triage`);
      for (const card of document.querySelectorAll(".frame-card[data-status=untriaged]")) card.setAttribute("data-label", label);
    } catch (e) {
      msg.replaceChildren(failure(e));
    }
  };
  const one = (f, label, card) => async () => {
    try {
      await triage({ ...said(), branch: submission.branch, actions: [{ test: f.test, digest: f.digest, label }] }, "/frames/triage");
      card.setAttribute("data-label", label);
      card.querySelector(".label").replaceChildren(badge(label));
    } catch (e) {
      msg.replaceChildren(failure(e));
    }
  };
  const opSelect = h("select", { name: "operator", onchange: (ev) => setParams(`/frames/${id}`, { all: all ? "1" : "", operator: ev.target.value }) },
    operators.map((o) => h("option", { value: o.name, selected: o.name === operator }, o.name)));
  const allBox = h("label", {}, h("input", { type: "checkbox", checked: all, onchange: (ev) => setParams(`/frames/${id}`, { all: ev.target.checked ? "1" : "", operator }) }), " frames that passed on a positive too");
  const op = `operator=${encodeURIComponent(operator)}`;
  const cards = frames.map((f) => {
    const card = h("section", { class: "frame-card", "data-test": f.test, "data-status": f.status, "data-digest": f.digest });
    const c = f.closest;
    const figures = c ? Object.entries(c.figures).map(([k, v]) => `${k} ${num(v, 4)}`).join(" · ") : "";
    card.append(
      h("h3", {}, f.test, " ", badge(f.status), h("span", { class: "label" })),
      h("p", { class: f.passed ? "muted" : "bad" }, f.detail),
      h("p", { class: "mono muted" }, `${f.file} · ${f.digest.slice(0, 16)}…`),
      c ? h("p", { class: "figures" }, figures, c.failed.length ? h("span", { class: "bad" }, ` · misses ${c.failed.join(", ")}`) : "") : null,
      h("div", { class: "side-by-side" },
        imageOf(`${API}/frames/images/${f.digest}?${op}`, "frame", `${f.test}: this frame`),
        c ? imageOf(`${API}/frames/images/${c.digest}?${op}`, "positive", `${f.test}: the closest positive`) : h("div", { class: "missing" }, "no positive yet"),
        ...(c ? ["diff", "ssim", "flip"].map((m) => imageOf(`${API}/frames/compare/${f.digest}/${c.digest}?map=${m}&${op}`, m, `${f.test}: ${m} map`)) : [])),
      h("div", { class: "toolbar" },
        h("button", { type: "button", name: "positive", onclick: one(f, "positive", card) }, "Positive"),
        h("button", { type: "button", name: "negative", onclick: one(f, "negative", card) }, "Negative")));
    return card;
  });
  const keys = Object.entries(submission.keys || {}).map(([a, b]) => `${a}=${b}`).join(" ");
  show(
    h("h1", {}, `Submission #${id} `, badge(submission.passed ? "passed" : "failed")),
    h("dl", { class: "facts" }, ...[["When", when(submission.submitted_at)], ["Branch", submission.branch || "main line"], ["Keys", keys || "–"],
      ["Frames", `${report.frames.length}, ${report.untriaged} untriaged`]].flatMap(([k, v]) => [h("dt", {}, k), h("dd", {}, v)])),
    h("div", { class: "toolbar triage" }, who, why,
      h("button", { type: "button", class: "primary", name: "all-positive", onclick: bulk("positive") }, "Every untriaged digest positive"),
      h("button", { type: "button", name: "all-negative", onclick: bulk("negative") }, "Every untriaged digest negative"), msg),
    h("div", { class: "toolbar" }, h("label", {}, "HDR shown with ", opSelect), allBox),
    frames.length ? cards : h("p", { class: "empty" }, "Every frame passed on a positive digest."));
}
