// inkray edit: the annotation on the drawing, the tools, undo/redo, and the live previews.
// Everything goes through the HTTP API (docs/editor.md); the page keeps the document it
// shows in step with the server's: an edit the server refuses is taken back.
import { ReliefView } from "/static/relief.js";

const $ = (id) => document.getElementById(id);
const SVGNS = "http://www.w3.org/2000/svg";
const NAME = /^[A-Za-z0-9_-]+$/;
const PREVIEW_KINDS = ["labels", "depth", "relief", "relations"];

const S = {
  size: [1, 1], doc: null, history: [], index: 0, generation: 0, savedText: null,
  palette: ["#ffffff"], tool: "select", region: -1, selection: null,
  relations: [], errors: {}, view: { s: 1, tx: 0, ty: 0 }, draft: null, drag: null,
  space: false, controller: null, busy: new Set(), reliefView: null, urls: {},
};
window.inkray = S;  // for scripts and tests: the document and state the page shows

// -- the document ------------------------------------------------------------------

const clone = (x) => JSON.parse(JSON.stringify(x));
const round = (v) => Math.round(v * 10) / 10;

function clampPoint([x, y]) {
  const [w, h] = S.size;
  return [round(Math.min(Math.max(x, 0), w - 1)), round(Math.min(Math.max(y, 0), h - 1))];
}

// The points of an entry, by its key (regions[1].scribbles[0], order[2], ...), as references.
function entryPoints(doc, key) {
  let m = key.match(/^regions\[(\d+)\]\.scribbles\[(\d+)\]$/);
  if (m) return doc.regions[+m[1]].scribbles[+m[2]];
  m = key.match(/^(background|boundaries|order|equal)\[(\d+)\]$/);
  if (!m) return [];
  const e = doc[m[1]][+m[2]];
  if (m[1] === "background") return e;
  if (m[1] === "boundaries") return e.path;
  if (m[1] === "order") return [e.front, e.back];
  return [e.a, e.b];
}

function removeEntry(doc, key) {
  let m = key.match(/^regions\[(\d+)\]\.scribbles\[(\d+)\]$/);
  if (m) {
    const region = doc.regions[+m[1]];
    region.scribbles.splice(+m[2], 1);
    if (region.scribbles.length === 0) {  // a region needs a scribble: it goes with its last
      doc.regions.splice(+m[1], 1);
      if (S.region >= doc.regions.length) S.region = doc.regions.length - 1;
    }
    return;
  }
  m = key.match(/^(regions|background|boundaries|order|equal)\[(\d+)\]$/);
  if (m) doc[m[1]].splice(+m[2], 1);
}

function list(doc, key) {
  if (!Array.isArray(doc[key])) doc[key] = [];
  return doc[key];
}

function newRegionName(doc) {
  const names = new Set((doc.regions || []).map((r) => r.name));
  for (let i = 1; ; i++) if (!names.has(`part${i}`)) return `part${i}`;
}

// -- talking to the server ----------------------------------------------------------

let putChain = Promise.resolve();

function send(doc) {
  const body = JSON.stringify(doc);
  const done = putChain.then(async () => {
    const r = await fetch("/api/annotations", { method: "PUT", body,
                                                 headers: { "Content-Type": "application/json" } });
    const answer = await r.json();
    if (!r.ok) return { ok: false, error: answer.error, paths: answer.paths || [] };
    S.generation = answer.generation;
    S.palette = answer.palette;
    document.body.dataset.generation = String(S.generation);
    return { ok: true };
  });
  putChain = done.catch(() => {});
  return done;
}

// Make ``doc`` the current document: a new undo step, sent to the server, previews refreshed.
// The exact depth map is asked for once; editing goes back to the fast method.
function fastDepth() { document.querySelector("input[name=depth-method][value=fast]").checked = true; }

async function commit(doc) {
  fastDepth();
  S.history = S.history.slice(0, S.index + 1);
  S.history.push(doc);
  S.index = S.history.length - 1;
  S.doc = doc;
  render();
  const answer = await send(doc);
  if (answer.ok) {
    S.errors.document = null;
    refresh();
    return;
  }
  // Refused (the server kept its document): the edit is taken back, the message shown.
  S.history = S.history.filter((d) => d !== doc);
  S.index = Math.min(S.index, S.history.length - 1);
  S.doc = S.history[S.index];
  S.errors.document = { error: answer.error, paths: answer.paths };
  render();
}

async function step(delta) {
  const i = S.index + delta;
  if (i < 0 || i >= S.history.length) return;
  S.index = i;
  S.doc = S.history[i];
  S.selection = null;
  fastDepth();
  if (S.region >= (S.doc.regions || []).length) S.region = (S.doc.regions || []).length - 1;
  render();
  const answer = await send(S.doc);
  if (answer.ok) { S.errors.document = null; refresh(); }
}

async function save() {
  await putChain;
  const text = JSON.stringify(S.doc);
  setStatus("saving");
  const r = await fetch("/api/save", { method: "POST" });
  const answer = await r.json();
  if (r.ok) {
    S.savedText = text;
    document.body.dataset.saved = answer.path;
  } else {
    S.errors.document = { error: answer.error, paths: [] };
  }
  render();
}

// Every preview of the newest generation; older answers are dropped, unfinished ones aborted.
function refresh() {
  if (S.controller) S.controller.abort();
  const controller = new AbortController();
  S.controller = controller;
  const generation = S.generation;
  const method = document.querySelector("input[name=depth-method]:checked").value;
  for (const kind of PREVIEW_KINDS) busy(kind, true);
  // ``final`` false: a first answer (the depth draft) shown while the kind stays busy.
  const get = async (kind, url, use, final = true) => {
    try {
      const r = await fetch(url, { signal: controller.signal, cache: "no-store" });
      if (controller.signal.aborted || generation !== S.generation) return;
      const shown = r.headers.get("X-Inkray-Generation");
      if (shown !== null && +shown !== generation) return;  // never show an older annotation
      if (r.ok) {
        S.errors[kind] = null;
        await use(r);
        const target = kind === "relations" ? $("relations") : $(kind);
        target.dataset.generation = String(generation);
        target.dataset.quality = final ? "full" : "draft";
        const ms = r.headers.get("X-Inkray-Compute-Ms");
        if (ms !== null && $(`${kind}-ms`)) $(`${kind}-ms`).textContent = `${(+ms).toFixed(0)} ms`;
      } else {
        const answer = await r.json();
        S.errors[kind] = { error: answer.error, paths: answer.paths || [] };
        if (kind !== "relations") markStale(kind, generation);
        final = true;  // the full answer would be the same error
      }
      if (final) busy(kind, false);
      render();
      return !final;
    } catch (e) {
      if (e.name !== "AbortError") {
        S.errors[kind] = { error: String(e), paths: [] };
        busy(kind, false);
        render();
      }
      return false;
    }
  };
  // The depth map (its own lock on the server) beside the rest, which goes cheapest first;
  // the fast one as a half-resolution draft first, at once, then in full.
  (async () => {
    const depth = async (r) => setImage("depth", await r.blob());
    if (method === "fast" && !await get("depth", "/api/preview/depth.png?quality=draft", depth, false)) return;
    await get("depth", `/api/preview/depth.png?method=${method}`, depth);
  })();
  (async () => {
    await get("labels", "/api/preview/labels.png", async (r) => setImage("labels", await r.blob()));
    await get("relations", "/api/relations", async (r) => {
      const answer = await r.json();
      S.relations = answer.relations;
      S.warnings = answer.warnings;
      S.errors.relations = answer.error ? { error: answer.error, paths: answer.paths } : null;
    });
    await get("relief", "/api/preview/relief.glb", async (r) => {
      const meshes = await S.reliefView.show(await r.arrayBuffer());
      $("relief").classList.remove("stale");
      $("relief").dataset.meshes = String(meshes);
    });
  })();
}

function setImage(kind, blob) {
  const url = URL.createObjectURL(blob);
  if (S.urls[kind]) URL.revokeObjectURL(S.urls[kind]);
  S.urls[kind] = url;
  $(kind).src = url;
  $(kind).parentElement.classList.remove("stale");
}

function markStale(kind, generation) {
  const el = kind === "relief" ? $("relief") : $(kind).parentElement;
  el.classList.add("stale");
  (kind === "relief" ? $("relief") : $(kind)).dataset.generation = String(generation);
}

function busy(kind, on) {
  if (on) S.busy.add(kind); else S.busy.delete(kind);
  const el = $(`busy-${kind}`);
  if (el) el.textContent = on ? "computing…" : "";
  setStatus();
}

// -- drawing the annotation ------------------------------------------------------------

function colourOf(i) { return S.palette[i + 1] || "#888"; }

function badPaths() {
  const out = [];
  for (const e of Object.values(S.errors)) if (e) out.push(...e.paths);
  return out;
}

function isBad(key, paths) {
  return paths.some((p) => key === p || key.startsWith(`${p}.`));
}

function polyline(points) {
  const pts = points.length === 1 ? [points[0], points[0]] : points;
  return pts.map((p) => `${p[0]},${p[1]}`).join(" ");
}

function arrowHead(a, b) {
  const dx = b[0] - a[0], dy = b[1] - a[1], n = Math.hypot(dx, dy) || 1;
  const ux = dx / n, uy = dy / n, L = 13 / S.view.s, w = 5.5 / S.view.s;
  const bx = b[0] - ux * L, by = b[1] - uy * L;
  return `${b[0]},${b[1]} ${bx - uy * w},${by + ux * w} ${bx + uy * w},${by - ux * w}`;
}

function dot(p, r) { return `<circle class="head" cx="${p[0]}" cy="${p[1]}" r="${r / S.view.s}"/>`; }

function entryMarkup(key, cls, points, { colour = null, arrow = false, dots = false } = {}) {
  const paths = badPaths();
  const classes = ["entry", cls];
  if (S.selection === key) classes.push("selected");
  if (isBad(key, paths)) classes.push("bad");
  const pts = polyline(points);
  const style = colour ? ` style="stroke:${colour}"` : "";
  let extra = "";
  if (arrow) extra += dot(points[0], 3.5) + `<polygon class="head" points="${arrowHead(points[0], points[1])}"/>`;
  if (dots) extra += dot(points[0], 3.5) + dot(points[1], 3.5);
  return `<g class="${classes.join(" ")}" data-key="${key}"><polyline class="hit" points="${pts}"/>` +
    `<polyline class="outline" points="${pts}"/><polyline class="line" points="${pts}"${style}/>${extra}</g>`;
}

function renderMarks() {
  const doc = S.doc;
  const [w, h] = S.size;
  const svg = $("marks");
  svg.setAttribute("viewBox", `-0.5 -0.5 ${w} ${h}`);
  svg.setAttribute("width", w);
  svg.setAttribute("height", h);
  let out = "";
  (doc.background || []).forEach((s, j) => { out += entryMarkup(`background[${j}]`, "background", s); });
  (doc.regions || []).forEach((r, i) => r.scribbles.forEach((s, j) => {
    out += entryMarkup(`regions[${i}].scribbles[${j}]`, `region region-${i}`, s, { colour: colourOf(i) });
  }));
  (doc.boundaries || []).forEach((b, k) => {
    out += entryMarkup(`boundaries[${k}]`, `boundary boundary-${b.type}`, b.path);
  });
  (doc.equal || []).forEach((e, k) => { out += entryMarkup(`equal[${k}]`, "equal", [e.a, e.b], { dots: true }); });
  (doc.order || []).forEach((o, k) => { out += entryMarkup(`order[${k}]`, "order", [o.front, o.back], { arrow: true }); });
  if ($("show-predicted").checked) {
    S.relations.forEach((r, k) => {
      if (r.source !== "predicted" || r.kind !== "order") return;
      const [a, b] = r.points, pts = polyline([a, b]);
      const mx = (a[0] + b[0]) / 2, my = (a[1] + b[1]) / 2;
      out += `<g class="pred" data-relation="${k}"><title>predicted: ${r.front} in front of ${r.back} ` +
        `(confidence ${r.confidence.toFixed(2)}); click to accept, Shift+click to flip</title>` +
        `<polyline class="hit" points="${pts}"/><polyline class="outline" points="${pts}"/>` +
        `<polyline class="line" points="${pts}"/>${dot(a, 3)}<polygon class="head" points="${arrowHead(a, b)}"/>` +
        `<text class="conf" x="${mx + 6 / S.view.s}" y="${my - 6 / S.view.s}" font-size="${12 / S.view.s}" ` +
        `style="font-size:${12 / S.view.s}px;stroke-width:${3 / S.view.s}px">${r.confidence.toFixed(2)}</text></g>`;
    });
  }
  if (S.draft) {
    const d = S.draft;
    out += `<g class="draft"><polyline class="outline" points="${polyline(d.points)}"/>` +
      `<polyline class="line" points="${polyline(d.points)}"/></g>`;
  }
  svg.innerHTML = out;
}

function renderRegions() {
  const box = $("regions");
  const paths = badPaths();
  // Rebuilt only when something shown changed: a name being typed keeps its field.
  const shown = JSON.stringify([S.doc.regions, S.region, S.palette, paths]);
  if (box.dataset.shown === shown) return;
  box.dataset.shown = shown;
  box.innerHTML = "";
  (S.doc.regions || []).forEach((r, i) => {
    const row = document.createElement("div");
    row.className = "region" + (i === S.region ? " current" : "") + (isBad(`regions[${i}]`, paths) ? " bad" : "");
    row.dataset.index = String(i);
    row.innerHTML = `<span class="swatch" style="background:${colourOf(i)}"></span>` +
      `<input class="name" value="${r.name}" title="name (letters, digits, _ and -)">` +
      `<input class="inflation" type="number" min="0.1" max="1000" step="0.5" value="${r.inflation ?? 2}" title="inflation">` +
      `<select class="profile" title="profile">${["sqrt", "linear", "flat"].map((p) =>
        `<option${(r.profile || "sqrt") === p ? " selected" : ""}>${p}</option>`).join("")}</select>` +
      `<button class="remove" title="delete this region">×</button>`;
    row.addEventListener("click", (e) => {
      if (e.target.closest("input,select,button")) return;
      S.region = i;
      setTool("region");
    });
    row.querySelector(".name").addEventListener("change", (e) => editRegion(i, "name", e.target.value.trim()));
    row.querySelector(".inflation").addEventListener("change", (e) => editRegion(i, "inflation", +e.target.value));
    row.querySelector(".profile").addEventListener("change", (e) => editRegion(i, "profile", e.target.value));
    row.querySelector(".remove").addEventListener("click", () => {
      const doc = clone(S.doc);
      doc.regions.splice(i, 1);
      if (S.region >= doc.regions.length) S.region = doc.regions.length - 1;
      S.selection = null;
      commit(doc);
    });
    box.appendChild(row);
  });
}

function editRegion(i, key, value) {
  const doc = clone(S.doc);
  doc.regions[i][key] = value;
  commit(doc);
}

function renderRelations() {
  const ul = $("relations");
  ul.innerHTML = "";
  S.relations.forEach((r, k) => {
    const li = document.createElement("li");
    li.className = r.source;
    const sign = r.kind === "equal" ? "=" : "in front of";
    const tag = r.source === "user" ? r.label : `predicted, ${r.confidence.toFixed(2)}`;
    li.innerHTML = `<span class="what">${r.front} ${sign} ${r.back} <small>(${tag})</small></span>`;
    if (r.source === "predicted" && r.kind === "order") {
      li.innerHTML += `<button class="accept" data-relation="${k}" title="make it an order entry">accept</button>` +
        `<button class="flip" data-relation="${k}" title="an order entry the other way round">flip</button>`;
    }
    ul.appendChild(li);
  });
  $("warnings").innerHTML = (S.warnings || []).map((w) => `<li>${escapeHtml(w)}</li>`).join("");
}

function acceptRelation(k, flip) {
  const r = S.relations[k];
  if (!r || r.source !== "predicted") return;
  const [front, back] = flip ? [r.points[1], r.points[0]] : r.points;
  const doc = clone(S.doc);
  list(doc, "order").push({ front: clampPoint(front), back: clampPoint(back) });
  commit(doc);
}

function escapeHtml(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
}

function render() {
  if (!S.doc) return;
  renderMarks();
  renderRegions();
  renderRelations();
  // Every distinct message once, with the preview (or the edit) it came from.
  const lines = [];
  for (const [kind, e] of Object.entries(S.errors)) {
    if (!e || lines.some((l) => l.endsWith(e.error))) continue;
    lines.push(kind === "document" ? e.error : `${kind}: ${e.error}`);
  }
  const box = $("error");
  box.hidden = lines.length === 0;
  box.textContent = lines.join("\n");
  $("undo").disabled = S.index <= 0;
  $("redo").disabled = S.index >= S.history.length - 1;
  $("delete").disabled = !S.selection;
  $("labels").style.display = $("show-labels").checked ? "" : "none";
  $("labels").style.opacity = $("labels-opacity").value;
  setStatus();
}

function dirty() { return S.doc !== null && JSON.stringify(S.doc) !== S.savedText; }

function setStatus(text) {
  const el = $("status");
  el.classList.toggle("dirty", dirty());
  el.textContent = text || [dirty() ? "unsaved changes" : "saved",
                            S.busy.size ? "computing previews…" : ""].filter(Boolean).join(" · ");
  document.body.dataset.busy = String(S.busy.size > 0);
}

// -- view: zoom and pan -------------------------------------------------------------------

function applyView() {
  const { s, tx, ty } = S.view;
  $("stage").style.transform = `translate(${tx}px, ${ty}px) scale(${s})`;
  renderMarks();
}

function fit() {
  const vp = $("viewport").getBoundingClientRect();
  const [w, h] = S.size;
  const s = Math.min(vp.width / w, vp.height / h) * 0.96;
  S.view = { s, tx: (vp.width - w * s) / 2, ty: (vp.height - h * s) / 2 };
  applyView();
}

function toDrawing(e) {
  const vp = $("viewport").getBoundingClientRect();
  const { s, tx, ty } = S.view;
  return [(e.clientX - vp.left - tx) / s - 0.5, (e.clientY - vp.top - ty) / s - 0.5];
}

function zoomAt(e, factor) {
  const vp = $("viewport").getBoundingClientRect();
  const x = e.clientX - vp.left, y = e.clientY - vp.top;
  const { s, tx, ty } = S.view;
  const next = Math.min(Math.max(s * factor, 0.05), 40);
  S.view = { s: next, tx: x - ((x - tx) * next) / s, ty: y - ((y - ty) * next) / s };
  applyView();
}

// -- tools ----------------------------------------------------------------------------------

function setTool(tool) {
  S.tool = tool;
  S.draft = null;
  for (const b of document.querySelectorAll("#tools button")) b.classList.toggle("active", b.dataset.tool === tool);
  $("viewport").className = `tool-${tool}`;
  render();
}

function onPointerDown(e) {
  const vp = $("viewport");
  vp.setPointerCapture(e.pointerId);
  if (e.button === 1 || S.space || S.tool === "pan") {
    S.drag = { kind: "pan", x: e.clientX, y: e.clientY, tx: S.view.tx, ty: S.view.ty };
    vp.classList.add("panning");
    return;
  }
  if (e.button !== 0) return;
  const p = toDrawing(e);
  if (S.tool === "select") {
    const pred = e.target.closest(".pred");
    if (pred) { acceptRelation(+pred.dataset.relation, e.shiftKey); return; }
    const entry = e.target.closest(".entry");
    S.selection = entry ? entry.dataset.key : null;
    if (entry) S.drag = { kind: "move", key: entry.dataset.key, start: p, base: S.doc, moved: false };
    render();
    return;
  }
  S.draft = { tool: S.tool, points: [clampPoint(p)] };
  if (S.tool === "order" || S.tool === "equal") S.draft.points.push(clampPoint(p));
  renderMarks();
}

function onPointerMove(e) {
  const d = S.drag;
  if (d && d.kind === "pan") {
    S.view.tx = d.tx + e.clientX - d.x;
    S.view.ty = d.ty + e.clientY - d.y;
    applyView();
    return;
  }
  const p = toDrawing(e);
  if (d && d.kind === "move") {
    const dx = p[0] - d.start[0], dy = p[1] - d.start[1];
    if (!d.moved && Math.hypot(dx, dy) * S.view.s < 3) return;
    d.moved = true;
    const doc = clone(d.base);
    for (const q of entryPoints(doc, d.key)) {
      const [x, y] = clampPoint([q[0] + dx, q[1] + dy]);
      q[0] = x; q[1] = y;
    }
    S.doc = doc;
    renderMarks();
    return;
  }
  if (!S.draft) return;
  const q = clampPoint(p);
  const pts = S.draft.points;
  if (S.draft.tool === "order" || S.draft.tool === "equal") {
    pts[1] = q;
  } else {
    const last = pts[pts.length - 1];
    if (Math.hypot(q[0] - last[0], q[1] - last[1]) * S.view.s >= 4) pts.push(q);
  }
  renderMarks();
}

function onPointerUp(e) {
  const d = S.drag;
  S.drag = null;
  $("viewport").classList.remove("panning");
  if (d && d.kind === "move") {
    if (d.moved) { const doc = S.doc; S.doc = d.base; commit(doc); }
    return;
  }
  if (!S.draft) return;
  const draft = S.draft;
  S.draft = null;
  const pts = draft.points;
  const end = clampPoint(toDrawing(e));
  if (draft.tool !== "order" && draft.tool !== "equal") {
    const last = pts[pts.length - 1];
    if (last[0] !== end[0] || last[1] !== end[1]) pts.push(end);
  }
  const doc = clone(S.doc);
  if (draft.tool === "region") {
    let i = S.region;
    if (i < 0 || i >= list(doc, "regions").length) {
      doc.regions.push({ name: newRegionName(doc), scribbles: [] });
      i = doc.regions.length - 1;
      S.region = i;
    }
    doc.regions[i].scribbles.push(pts);
  } else if (draft.tool === "background") {
    list(doc, "background").push(pts);
  } else if (draft.tool === "boundary") {
    if (pts.length < 2) { renderMarks(); return; }  // a click is no path
    list(doc, "boundaries").push({ type: $("boundary-type").value, path: pts });
  } else {
    const [a, b] = pts;
    if (Math.hypot(a[0] - b[0], a[1] - b[1]) < 2) { renderMarks(); return; }  // a click is no arrow
    if (draft.tool === "order") list(doc, "order").push({ front: a, back: b });
    else list(doc, "equal").push({ a, b });
  }
  commit(doc);
}

function deleteSelection() {
  if (!S.selection) return;
  const doc = clone(S.doc);
  removeEntry(doc, S.selection);
  S.selection = null;
  commit(doc);
}

function onKey(e) {
  if (e.target.closest && e.target.closest("input,select,textarea")) return;
  const k = e.key.toLowerCase();
  if ((e.ctrlKey || e.metaKey) && k === "z") { e.preventDefault(); step(e.shiftKey ? 1 : -1); return; }
  if ((e.ctrlKey || e.metaKey) && k === "y") { e.preventDefault(); step(1); return; }
  if ((e.ctrlKey || e.metaKey) && k === "s") { e.preventDefault(); save(); return; }
  if (e.ctrlKey || e.metaKey || e.altKey) return;
  if (k === " ") { S.space = true; $("viewport").classList.add("panning"); e.preventDefault(); return; }
  if (k === "delete" || k === "backspace") { deleteSelection(); return; }
  const tools = { v: "select", r: "region", b: "background", o: "order", e: "equal", g: "boundary", h: "pan" };
  if (tools[k]) setTool(tools[k]);
  if (k === "f") fit();
  if (k === "escape") { S.draft = null; S.selection = null; render(); }
}

// -- start ------------------------------------------------------------------------------

async function start() {
  const info = await (await fetch("/api/info", { cache: "no-store" })).json();
  const doc = await (await fetch("/api/annotations", { cache: "no-store" })).json();
  S.size = info.size;
  S.palette = info.palette;
  S.generation = info.generation;
  S.doc = doc;
  S.history = [doc];
  S.index = 0;
  S.savedText = info.saved ? JSON.stringify(doc) : null;
  S.region = (doc.regions || []).length ? 0 : -1;
  document.body.dataset.generation = String(S.generation);
  $("file").textContent = info.path.split(/[\\/]/).pop();
  $("file").title = `${info.path}\nautosave: ${info.autosave}`;
  const [w, h] = S.size;
  for (const id of ["drawing", "labels"]) { $(id).width = w; $(id).height = h; }
  $("drawing").src = "/api/drawing.png";
  S.reliefView = new ReliefView($("relief"));

  const vp = $("viewport");
  vp.addEventListener("pointerdown", onPointerDown);
  vp.addEventListener("pointermove", onPointerMove);
  vp.addEventListener("pointerup", onPointerUp);
  vp.addEventListener("wheel", (e) => { e.preventDefault(); zoomAt(e, Math.exp(-e.deltaY * 0.0015)); }, { passive: false });
  vp.addEventListener("auxclick", (e) => e.preventDefault());
  window.addEventListener("keydown", onKey);
  window.addEventListener("keyup", (e) => { if (e.key === " ") { S.space = false; vp.classList.remove("panning"); } });
  window.addEventListener("beforeunload", (e) => { if (dirty()) { e.preventDefault(); e.returnValue = ""; } });
  window.addEventListener("resize", () => S.reliefView.resize());
  for (const b of document.querySelectorAll("#tools button")) b.addEventListener("click", () => setTool(b.dataset.tool));
  $("undo").addEventListener("click", () => step(-1));
  $("redo").addEventListener("click", () => step(1));
  $("delete").addEventListener("click", deleteSelection);
  $("fit").addEventListener("click", fit);
  $("save").addEventListener("click", save);
  $("add-region").addEventListener("click", () => {
    S.region = -1;  // the next region scribble starts it: a region needs a scribble
    setTool("region");
  });
  for (const id of ["show-labels", "labels-opacity", "show-predicted"]) $(id).addEventListener("input", render);
  for (const r of document.querySelectorAll("input[name=depth-method]")) r.addEventListener("change", refresh);
  $("relations").addEventListener("click", (e) => {
    const b = e.target.closest("button[data-relation]");
    if (b) acceptRelation(+b.dataset.relation, b.classList.contains("flip"));
  });
  setTool("select");
  fit();
  refresh();
}

start();
