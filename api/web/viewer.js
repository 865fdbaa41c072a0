// OpenGraph web viewer: a bird's-eye view of the map (instance points coloured by
// SemanticKITTI class, lane graph, road segments) with find, locate and route over the JSON API.
// Served by `opengraph serve` at /viewer.js; no external resources.
"use strict";

const errorsEl = document.getElementById("errors");
function recordError(msg) {
  const d = document.createElement("div");
  d.textContent = String(msg);
  errorsEl.appendChild(d);
  document.body.dataset.errors = String(errorsEl.childElementCount);
}
window.addEventListener("error", (e) => recordError(e.message));
window.addEventListener("unhandledrejection", (e) => recordError(e.reason));

const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
const statusEl = document.getElementById("status");
const resultsEl = document.getElementById("results");
const detailsEl = document.getElementById("details");
const legendEl = document.getElementById("legend");
const qEl = document.getElementById("q");
const modeEl = document.getElementById("mode");

const state = {
  view: null,
  centres: new Map(), // id -> [x, y] ground centre of its points
  scale: 1, cx: 0, cy: 0,
  highlighted: [], // instance ids, best first
  segments: [], // highlighted segment ids
  markers: [], // [x, y] positions (locate)
  route: null, // [x0, y0, x1, y1, ...]
  selected: null,
};

function setStatus(text) { statusEl.textContent = text; }

async function api(method, path, body) {
  const opts = { method, headers: {} };
  if (body !== undefined) {
    opts.headers["Content-Type"] = "application/json";
    opts.body = JSON.stringify(body);
  }
  const resp = await fetch(path, opts);
  const data = await resp.json();
  if (!resp.ok) {
    const msg = data && data.error ? data.error.message : resp.statusText;
    throw new Error(msg);
  }
  return data;
}

// ---- drawing ----

function resize() {
  const r = canvas.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.max(1, Math.round(r.width * dpr));
  canvas.height = Math.max(1, Math.round(r.height * dpr));
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  draw();
}

function toScreen(x, y) {
  const r = canvas.getBoundingClientRect();
  return [(x - state.cx) * state.scale + r.width / 2, r.height / 2 - (y - state.cy) * state.scale];
}

function toGround(sx, sy) {
  const r = canvas.getBoundingClientRect();
  return [(sx - r.width / 2) / state.scale + state.cx, (r.height / 2 - sy) / state.scale + state.cy];
}

function fit(minx, miny, maxx, maxy, margin) {
  const r = canvas.getBoundingClientRect();
  const w = Math.max(maxx - minx, 1), h = Math.max(maxy - miny, 1);
  state.scale = Math.min(r.width / (w * margin), r.height / (h * margin));
  state.cx = (minx + maxx) / 2;
  state.cy = (miny + maxy) / 2;
}

function polyline(pts, close) {
  ctx.beginPath();
  for (let i = 0; i + 1 < pts.length; i += 2) {
    const [sx, sy] = toScreen(pts[i], pts[i + 1]);
    if (i === 0) ctx.moveTo(sx, sy); else ctx.lineTo(sx, sy);
  }
  if (close) ctx.closePath();
}

function draw() {
  const r = canvas.getBoundingClientRect();
  ctx.clearRect(0, 0, r.width, r.height);
  const v = state.view;
  if (!v) return;
  // segments
  for (const s of v.segments) {
    const hi = state.segments.includes(s.id);
    polyline(s.outline, true);
    ctx.fillStyle = hi ? "rgba(0, 170, 255, 0.18)" : "rgba(0, 0, 0, 0.03)";
    ctx.fill();
    ctx.lineWidth = hi ? 2.5 : 1;
    ctx.strokeStyle = hi ? "#0090e0" : "rgba(0, 0, 0, 0.25)";
    ctx.stroke();
  }
  // lanes
  ctx.lineWidth = 1.5;
  ctx.strokeStyle = "rgba(60, 60, 60, 0.6)";
  for (const l of v.lanes) { polyline(l, false); ctx.stroke(); }
  // points: surfaces first, faint
  const size = Math.max(1.2, Math.min(3, state.scale * 0.25));
  for (const pass of [true, false]) {
    for (const inst of v.instances) {
      if (inst.surface !== pass) continue;
      ctx.fillStyle = v.colours[inst.semantic_class] || "#808080";
      ctx.globalAlpha = pass ? 0.25 : 0.9;
      const p = inst.points;
      for (let i = 0; i + 1 < p.length; i += 2) {
        const [sx, sy] = toScreen(p[i], p[i + 1]);
        ctx.fillRect(sx - size / 2, sy - size / 2, size, size);
      }
    }
  }
  ctx.globalAlpha = 1;
  // route
  if (state.route && state.route.length >= 4) {
    ctx.lineWidth = 4;
    ctx.strokeStyle = "rgba(30, 90, 255, 0.85)";
    polyline(state.route, false);
    ctx.stroke();
  }
  // locate markers
  for (const [i, m] of state.markers.entries()) {
    const [sx, sy] = toScreen(m[0], m[1]);
    ctx.beginPath();
    ctx.arc(sx, sy, 9, 0, 2 * Math.PI);
    ctx.fillStyle = i === 0 ? "#0090e0" : "rgba(0, 144, 224, 0.5)";
    ctx.fill();
    label(sx, sy, String(i + 1), "#fff");
  }
  // highlighted instances: rings with their rank
  for (const [i, id] of state.highlighted.entries()) {
    const c = state.centres.get(id);
    if (!c) continue;
    const [sx, sy] = toScreen(c[0], c[1]);
    ring(sx, sy, 11, i === 0 ? "#e00000" : "#ff8c00", 3);
    label(sx + 14, sy - 12, String(i + 1), "#000");
  }
  if (state.selected !== null) {
    const c = state.centres.get(state.selected);
    if (c) {
      const [sx, sy] = toScreen(c[0], c[1]);
      ring(sx, sy, 15, "#7a00cc", 2);
    }
  }
}

function ring(sx, sy, r, colour, width) {
  ctx.beginPath();
  ctx.arc(sx, sy, r, 0, 2 * Math.PI);
  ctx.lineWidth = width;
  ctx.strokeStyle = colour;
  ctx.stroke();
}

function label(sx, sy, text, colour) {
  ctx.font = "bold 12px system-ui, sans-serif";
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillStyle = colour;
  ctx.fillText(text, sx, sy);
}

// ---- interaction ----

let drag = null;
canvas.addEventListener("mousedown", (e) => {
  drag = { x: e.offsetX, y: e.offsetY, cx: state.cx, cy: state.cy, moved: false };
  canvas.classList.add("dragging");
});
window.addEventListener("mousemove", (e) => {
  if (!drag) return;
  const r = canvas.getBoundingClientRect();
  const dx = e.clientX - r.left - drag.x, dy = e.clientY - r.top - drag.y;
  if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
  state.cx = drag.cx - dx / state.scale;
  state.cy = drag.cy + dy / state.scale;
  draw();
});
window.addEventListener("mouseup", (e) => {
  if (!drag) return;
  const wasClick = !drag.moved;
  drag = null;
  canvas.classList.remove("dragging");
  const r = canvas.getBoundingClientRect();
  if (wasClick && e.target === canvas) pick(e.clientX - r.left, e.clientY - r.top);
});
canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  const before = toGround(e.offsetX, e.offsetY);
  state.scale *= Math.exp(-e.deltaY * 0.0015);
  state.scale = Math.min(Math.max(state.scale, 0.05), 200);
  const after = toGround(e.offsetX, e.offsetY);
  state.cx += before[0] - after[0];
  state.cy += before[1] - after[1];
  draw();
}, { passive: false });
window.addEventListener("resize", resize);

function pick(sx, sy) {
  let best = null, bestD = 10;
  for (const inst of state.view.instances) {
    if (inst.surface) continue;
    const c = state.centres.get(inst.id);
    if (!c) continue;
    const [px, py] = toScreen(c[0], c[1]);
    const d = Math.hypot(px - sx, py - sy);
    if (d < bestD) { bestD = d; best = inst.id; }
  }
  if (best !== null) select(best);
}

function esc(s) {
  return String(s).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
}

async function select(id) {
  state.selected = id;
  draw();
  for (const el of resultsEl.querySelectorAll(".result")) {
    el.classList.toggle("selected", Number(el.dataset.id) === id);
  }
  try {
    const d = await api("GET", `/api/instances/${id}`);
    const p = d.properties || {};
    const rels = (d.related || []).slice(0, 12).map((r) =>
      `<li>${esc(r.outgoing ? r.relation : "(" + r.relation + ")")} ${esc(r.caption || "")} <span class="small">#${r.id}, ${r.distance_m === null ? "" : Number(r.distance_m).toFixed(1) + " m"}</span></li>`).join("");
    detailsEl.innerHTML = `<h3>#${d.id} ${esc(p.label || p.caption || "")}</h3>
      ${p.label ? `<div>${esc(p.caption || "")}</div>` : ""}
      <div class="small">${p.colour ? `${esc(p.colour)} · ` : ""}${p.material ? `${esc(p.material)} · ` : ""}<span class="swatch" style="background:${state.view.colours[p.semantic_class] || "#808080"}"></span>${esc(p.semantic_class || "")}
      ${d.segment ? ` · segment #${d.segment.id} (${esc(d.segment.kind || "")})` : ""}
      ${p.point_count !== undefined ? ` · ${p.point_count} points` : ""}</div>
      ${rels ? `<div class="small" style="margin-top:6px">relations</div><ul>${rels}</ul>` : ""}`;
    detailsEl.dataset.id = String(d.id);
  } catch (err) {
    detailsEl.textContent = `#${id}: ${err.message}`;
  }
}

function showResults(title, rows) {
  resultsEl.innerHTML = `<h3>${esc(title)}</h3>` + rows.join("");
  for (const el of resultsEl.querySelectorAll(".result[data-id]")) {
    el.addEventListener("click", () => {
      const id = Number(el.dataset.id);
      const c = state.centres.get(id);
      if (c) { state.cx = c[0]; state.cy = c[1]; state.scale = Math.max(state.scale, 4); }
      select(id);
    });
  }
}

function finish(n) {
  document.body.dataset.highlighted = String(n);
  document.body.dataset.state = "done";
  draw();
}

function focusOn(points) {
  if (!points.length) return;
  const xs = points.map((p) => p[0]), ys = points.map((p) => p[1]);
  fit(Math.min(...xs) - 15, Math.min(...ys) - 15, Math.max(...xs) + 15, Math.max(...ys) + 15, 1.1);
}

async function run() {
  const text = qEl.value.trim();
  if (!text) return;
  const mode = modeEl.value;
  document.body.dataset.state = "busy";
  setStatus(`${mode}…`);
  state.highlighted = []; state.segments = []; state.markers = []; state.route = null;
  try {
    if (mode === "find") {
      const a = await api("POST", "/api/find", { text, k: 5 });
      state.highlighted = a.results.map((r) => r.id);
      showResults(`${a.results.length} found`, a.results.map((r, i) => {
        const ev = (r.evidence || []).map((e) => `${e.relation.replace("_", " ")} ${e.anchor_caption} (${e.distance_m} m)`).join("; ");
        return `<div class="result" data-id="${r.id}"><b>${i + 1}.</b> ${r.label ? `<b>${esc(r.label)}</b>: ` : ""}${esc(r.caption)}
          <div class="meta"><span class="swatch" style="background:${state.view.colours[r.semantic_class] || "#808080"}"></span>${esc(r.semantic_class)} · #${r.id} · score ${r.score.toFixed(2)}${r.segment ? " · " + esc(r.segment[1]) : ""}</div>
          ${ev ? `<div class="meta">${esc(ev)}</div>` : ""}</div>`;
      }));
      focusOn(state.highlighted.map((id) => state.centres.get(id)).filter(Boolean));
      setStatus(`${a.results.length} results`);
      finish(state.highlighted.length);
    } else if (mode === "locate") {
      const a = await api("POST", "/api/locate", { text, k: 3 });
      state.segments = a.results.map((r) => r.segment);
      state.markers = a.results.map((r) => r.position);
      showResults(`${a.results.length} places`, a.results.map((r, i) =>
        `<div class="result"><b>${i + 1}.</b> ${esc(r.kind.replace(/_/g, " "))} #${r.segment}
         <div class="meta">score ${r.score.toFixed(2)} · ${(r.evidence || []).map((e) => esc(e.landmark || e.phrase || "")).filter(Boolean).join(", ")}</div></div>`));
      focusOn(state.markers);
      setStatus(`${a.results.length} places`);
      finish(state.segments.length);
    } else if (mode === "ask") {
      const a = await api("POST", "/api/ask", { question: text, max_steps: 4 });
      const ids = [];
      for (const st of a.steps) {
        for (const r of (st.result && st.result.results) || []) {
          if (typeof r.id === "number" && !ids.includes(r.id)) ids.push(r.id);
        }
      }
      state.highlighted = ids.slice(0, 10);
      showResults(a.answer ? "answer" : "no answer", [
        `<div class="result">${esc(a.answer || a.stopped || "")}<div class="meta">${esc(a.model)}</div></div>`,
        ...a.steps.map((st) => `<div class="result"><div class="meta">${esc(st.tool)} ${esc(JSON.stringify(st.arguments))}${st.is_error ? " (error)" : ""}</div></div>`),
      ]);
      focusOn(state.highlighted.map((id) => state.centres.get(id)).filter(Boolean));
      setStatus(`${a.steps.length} tool calls`);
      finish(state.highlighted.length);
    } else {
      const m = text.replace(/^from\s+/i, "").split(/\s+to\s+/i);
      if (m.length < 2) throw new Error('say "from A to B"');
      const a = await api("POST", "/api/route", { from: m[0], to: m.slice(1).join(" to ") });
      state.route = a.plan.route.polyline.flat();
      const ends = [a.plan.from, a.plan.to];
      state.highlighted = ends.filter((e) => e.kind === "Instance" && e.node !== null).map((e) => e.node);
      const how = [a.start, a.goal].map((x) => (x.result && (x.result.caption || (x.result.kind || "").replace(/_/g, " "))) || x.spec || "");
      showResults(`route ${a.plan.route.length_m.toFixed(0)} m`, ends.map((e, i) =>
        `<div class="result" ${e.node !== null && e.kind === "Instance" ? `data-id="${e.node}"` : ""}><b>${i === 0 ? "from" : "to"}</b> ${esc(how[i])}
         <div class="meta">${esc(e.kind)} #${e.node} · ${esc(e.spec)}</div></div>`));
      focusOn(a.plan.route.polyline);
      setStatus(`route of ${a.plan.route.length_m.toFixed(0)} m`);
      finish(state.highlighted.length + (state.route.length ? 1 : 0));
    }
  } catch (err) {
    setStatus(`error: ${err.message}`);
    resultsEl.textContent = err.message;
    document.body.dataset.state = "error";
    draw();
  }
}

document.getElementById("go").addEventListener("click", run);
qEl.addEventListener("keydown", (e) => { if (e.key === "Enter") run(); });

async function main() {
  const v = await api("GET", "/api/view");
  state.view = v;
  for (const inst of v.instances) {
    const p = inst.points;
    if (p.length < 2) continue;
    let x = 0, y = 0;
    for (let i = 0; i + 1 < p.length; i += 2) { x += p[i]; y += p[i + 1]; }
    state.centres.set(inst.id, [x / (p.length / 2), y / (p.length / 2)]);
  }
  const classes = [...new Set(v.instances.map((i) => i.semantic_class))].sort();
  legendEl.innerHTML = classes.map((c) => `<span style="white-space:nowrap;margin-right:8px"><span class="swatch" style="background:${v.colours[c] || "#808080"}"></span>${esc(c)}</span>`).join(" ");
  resize();
  fit(v.bounds[0], v.bounds[1], v.bounds[2], v.bounds[3], 1.05);
  draw();
  setStatus(`${v.instances.length} instances, ${v.segments.length} segments`);
  document.body.dataset.state = "ready";
  const params = new URLSearchParams(location.search);
  if (params.get("q")) {
    qEl.value = params.get("q");
    const mode = params.get("mode");
    if (mode && ["find", "locate", "route", "ask"].includes(mode)) modeEl.value = mode;
    await run();
  }
}

main().catch((err) => { recordError(err.message); setStatus(`error: ${err.message}`); document.body.dataset.state = "error"; });
