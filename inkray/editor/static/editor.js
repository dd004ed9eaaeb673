// inkray edit: the annotation on the drawing, the tools, undo/redo, and the live previews.
// Everything goes through the HTTP API (docs/editor.md); the page keeps the document it
// shows in step with the server's: an edit the server refuses is taken back.
import { ReliefView } from "/static/relief.js";
import { startShot } from "/static/shot.js";

const $ = (id) => document.getElementById(id);
const NAME = /^[A-Za-z0-9_-]+$/;
const PREVIEW_KINDS = ["labels", "depth", "relief", "relations"];
// Sizes of the marks in screen pixels, the same at every zoom.
const HIT = 8;          // a click this near an entry's line hits it
const HEAD = [13, 5.5]; // arrowhead length and half width
const DOT = 3.5;        // radius of an arrow's tail and an equal pair's ends
const CLICK = 4;        // a press that moves less than this is a click, not a drag
const HISTORY_LIMIT = 200;

const S = {
  size: [1, 1], doc: null, history: [], index: 0, generation: 0, baseText: null,
  palette: ["#ffffff"], tool: "select", region: -1, newRegion: false, selection: null,
  selectedRelation: null, hover: null, relations: [], warnings: [], errors: {}, plain: {},
  view: { s: 1, tx: 0, ty: 0 }, draft: null, drag: null, pending: null, spot: null,
  space: false, controller: null, busy: new Set(), reliefView: null, urls: {}, path: "",
  fitScale: 1, checks: [], shot: null,
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
  let m = key.match(/^regions\[(\d+)\]\.scribbles\[(\d+)\]/);
  if (m) return doc.regions[+m[1]]?.scribbles[+m[2]] || [];
  m = key.match(/^regions\[(\d+)\]/);
  if (m) return (doc.regions[+m[1]]?.scribbles || []).flat();
  m = key.match(/^(background|boundaries|order|equal)\[(\d+)\]/);
  if (!m) return [];
  const e = (doc[m[1]] || [])[+m[2]];
  if (!e) return [];
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

const hasRegions = (doc) => (doc.regions || []).length > 0;
const hasEntries = (doc) => hasRegions(doc) || (doc.order || []).length > 0 || (doc.equal || []).length > 0;

// -- talking to the server ----------------------------------------------------------

let putChain = Promise.resolve();

async function postJSON(url, body) {
  const r = await fetch(url, { method: "POST", body: JSON.stringify(body ?? {}),
                               headers: { "Content-Type": "application/json" } });
  return { ok: r.ok, answer: await r.json() };
}

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

// The exact depth map is asked for once; editing goes back to the fast method.
function fastDepth() { document.querySelector("input[name=depth-method][value=fast]").checked = true; }

// Make ``doc`` the current document: a new undo step, sent to the server, previews refreshed.
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
    S.errors.save = null;
    keepHistory();
    refresh();
    return true;
  }
  // Refused (the server kept its document): the edit is taken back, the message shown.
  S.history = S.history.filter((d) => d !== doc);
  S.index = Math.min(S.index, S.history.length - 1);
  S.doc = S.history[S.index];
  S.errors.document = { error: answer.error, paths: answer.paths };
  render();
  return false;
}

async function step(delta) {
  const i = S.index + delta;
  if (i < 0 || i >= S.history.length) return;
  S.index = i;
  S.doc = S.history[i];
  S.selection = null;
  closeNameField(false);
  fastDepth();
  if (S.region >= (S.doc.regions || []).length) S.region = (S.doc.regions || []).length - 1;
  render();
  const answer = await send(S.doc);
  if (answer.ok) { S.errors.document = null; keepHistory(); refresh(); }
}

// Undo history survives a reload: kept in the browser, by the annotation file's path.
function historyKey() { return `inkray-edit:${S.path}`; }

function keepHistory() {
  let history = S.history.slice(-HISTORY_LIMIT);
  let index = S.index - (S.history.length - history.length);
  while (history.length) {
    try {
      localStorage.setItem(historyKey(), JSON.stringify({ history, index }));
      return;
    } catch (e) {  // over the browser's quota: the oldest half goes
      const drop = Math.ceil(history.length / 2);
      if (index < drop) return;
      history = history.slice(drop);
      index -= drop;
    }
  }
}

function restoreHistory(doc) {
  try {
    const kept = JSON.parse(localStorage.getItem(historyKey()) || "null");
    if (kept && Array.isArray(kept.history) && kept.history[kept.index] &&
        JSON.stringify(kept.history[kept.index]) === JSON.stringify(doc)) {
      S.history = kept.history;
      S.history[kept.index] = doc;
      S.index = kept.index;
      return true;
    }
  } catch (e) { /* a broken entry is ignored */ }
  return false;
}

async function save() {
  await putChain;
  const text = JSON.stringify(S.doc);
  setStatus("saving");
  const r = await fetch("/api/save", { method: "POST" });
  const answer = await r.json();
  if (r.ok) {
    S.baseText = text;
    S.saved = true;
    S.errors.save = null;
    document.body.dataset.saved = answer.path;
    document.body.dataset.saveError = "";
  } else {
    S.errors.save = { error: `not saved: ${answer.error}`, paths: answer.paths || [], plain: answer.plain };
    document.body.dataset.saveError = answer.error;
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
  const doc = S.doc;
  // ``final`` false: a first answer (the depth draft) shown while the kind stays busy.
  const get = async (kind, url, use, final = true) => {
    try {
      const r = await fetch(url, { signal: controller.signal, cache: "no-store" });
      if (controller.signal.aborted || generation !== S.generation) return;
      const shown = r.headers.get("X-Inkray-Generation");
      if (shown !== null && +shown !== generation) return;  // never show an older annotation
      if (r.ok) {
        S.errors[kind] = null;
        // a draft request the server answered with the full map (on opening): nothing to follow
        if (r.headers.get("X-Inkray-Quality") === "full") final = true;
        await use(r);
        const target = kind === "relations" ? $("relations") : $(kind);
        target.dataset.generation = String(generation);
        target.dataset.quality = final ? "full" : "draft";
        const ms = r.headers.get("X-Inkray-Compute-Ms");
        if (ms !== null && $(`${kind}-ms`)) $(`${kind}-ms`).textContent = `${(+ms).toFixed(0)} ms`;
      } else {
        const answer = await r.json();
        S.errors[kind] = { error: answer.error, paths: answer.paths || [], plain: answer.plain };
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
  // Nothing to compute yet: each preview says what it waits for.
  const skip = (kind) => {
    S.errors[kind] = null;
    if (kind === "relations") { S.relations = []; S.warnings = []; }
    if (kind === "relief") S.reliefView.clear();
    if (kind === "labels" || kind === "depth") { $(kind).removeAttribute("src"); }
    const target = kind === "relations" ? $("relations") : $(kind);
    target.dataset.generation = String(generation);
    busy(kind, false);
  };
  for (const kind of PREVIEW_KINDS) busy(kind, true);
  if (!hasEntries(doc)) skip("depth");
  else {
    // The depth map (its own lock on the server) beside the rest, which goes cheapest first;
    // the fast one as a half-resolution draft first, at once, then in full (unless the
    // draft's answer is already the full map).
    (async () => {
      const depth = async (r) => setImage("depth", await r.blob());
      if (method === "fast" && !await get("depth", "/api/preview/depth.png?quality=draft", depth, false)) return;
      await get("depth", `/api/preview/depth.png?method=${method}`, depth);
    })();
  }
  if (!hasRegions(doc)) {
    for (const kind of ["labels", "relations", "relief"]) skip(kind);
    render();
    return;
  }
  (async () => {
    await get("labels", "/api/preview/labels.png", async (r) => setImage("labels", await r.blob()));
    await get("relations", "/api/relations", async (r) => {
      const answer = await r.json();
      S.relations = answer.relations;
      S.warnings = answer.warnings;
      S.errors.relations = answer.error ? { error: answer.error, paths: answer.paths, plain: answer.plain } : null;
    });
    await get("relief", "/api/preview/relief.glb", async (r) => {
      const meshes = await S.reliefView.show(await r.arrayBuffer());
      $("relief").classList.remove("stale");
      $("relief").dataset.meshes = String(meshes);
      S.reliefGeneration = generation;
    });
  })();
  render();
}

async function setImage(kind, blob) {
  const url = URL.createObjectURL(blob);
  if (S.urls[kind]) URL.revokeObjectURL(S.urls[kind]);
  S.urls[kind] = url;
  $(kind).src = url;
  $(kind).parentElement.classList.remove("stale");
  if (kind === "depth") {
    await $(kind).decode().catch(() => {});
    S.depthFlat = isFlat($(kind));
  }
}

// Whether an image has one value everywhere (a depth map nothing orders yet).
function isFlat(img) {
  const c = document.createElement("canvas");
  c.width = Math.min(img.naturalWidth, 128);
  c.height = Math.min(img.naturalHeight, 128);
  const g = c.getContext("2d");
  g.drawImage(img, 0, 0, c.width, c.height);
  const d = g.getImageData(0, 0, c.width, c.height).data;
  for (let i = 4; i < d.length; i += 4) if (d[i] !== d[0]) return false;
  return true;
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

// -- screen coordinates --------------------------------------------------------------

// Drawing pixel [x, y] (the pixel's centre) to viewport pixels, and back.
function toScreen([x, y]) {
  const { s, tx, ty } = S.view;
  return [tx + (x + 0.5) * s, ty + (y + 0.5) * s];
}

function toDrawing(e) {
  const vp = $("viewport").getBoundingClientRect();
  const { s, tx, ty } = S.view;
  return [(e.clientX - vp.left - tx) / s - 0.5, (e.clientY - vp.top - ty) / s - 0.5];
}

function viewportPoint(e) {
  const vp = $("viewport").getBoundingClientRect();
  return [e.clientX - vp.left, e.clientY - vp.top];
}

function segmentDistance(p, a, b) {
  const dx = b[0] - a[0], dy = b[1] - a[1], n = dx * dx + dy * dy;
  const t = n ? Math.min(Math.max(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / n, 0), 1) : 0;
  return Math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy);
}

function polylineDistance(p, points) {
  const pts = points.map(toScreen);
  if (pts.length === 1) return Math.hypot(p[0] - pts[0][0], p[1] - pts[0][1]);
  let best = Infinity;
  for (let i = 1; i < pts.length; i++) best = Math.min(best, segmentDistance(p, pts[i - 1], pts[i]));
  return best;
}

// Every user entry as [key, points], in drawing order (later ones are drawn on top).
function userEntries(doc) {
  const out = [];
  (doc.background || []).forEach((s, j) => out.push([`background[${j}]`, s]));
  (doc.regions || []).forEach((r, i) => r.scribbles.forEach((s, j) => out.push([`regions[${i}].scribbles[${j}]`, s])));
  (doc.boundaries || []).forEach((b, k) => out.push([`boundaries[${k}]`, b.path]));
  (doc.equal || []).forEach((e, k) => out.push([`equal[${k}]`, [e.a, e.b]]));
  (doc.order || []).forEach((o, k) => out.push([`order[${k}]`, [o.front, o.back]]));
  return out;
}

// The user's entry nearest the viewport point ``p`` within HIT screen pixels (the one drawn
// on top when two are as near), or null. Predictions are never hit: they have their controls.
function hitEntry(p) {
  let best = null, bestD = HIT;
  for (const [key, points] of userEntries(S.doc)) {
    const d = polylineDistance(p, points);
    if (d <= bestD) { best = key; bestD = d; }
  }
  return best;
}

// -- drawing the annotation ------------------------------------------------------------

function colourOf(i) { return S.palette[i + 1] || "#888"; }

function errorPaths() {
  const out = [];
  for (const e of Object.values(S.errors)) if (e) out.push(...e.paths);
  return out;
}

const ENTRY = /\b(regions|background|order|equal|boundaries)\[(\d+)\](\.scribbles\[\d+\])?/g;

function warningPaths() {
  const out = [];
  for (const w of [...(S.warnings || []), ...S.checks]) for (const m of w.matchAll(ENTRY)) out.push(m[0]);
  return out;
}

function isNamed(key, paths) {
  return paths.some((p) => key === p || key.startsWith(`${p}.`));
}

function pointsAttr(points) {
  const pts = (points.length === 1 ? [points[0], points[0]] : points).map(toScreen);
  return pts.map((p) => `${p[0].toFixed(1)},${p[1].toFixed(1)}`).join(" ");
}

function arrowHead(a, b) {
  const [ax, ay] = toScreen(a), [bx, by] = toScreen(b);
  const dx = bx - ax, dy = by - ay, n = Math.hypot(dx, dy) || 1;
  const ux = dx / n, uy = dy / n, [L, w] = HEAD;
  const cx = bx - ux * L, cy = by - uy * L;
  return `${bx},${by} ${cx - uy * w},${cy + ux * w} ${cx + uy * w},${cy - ux * w}`;
}

function dot(p, r, cls = "head") {
  const [x, y] = toScreen(p);
  return `<circle class="${cls}" cx="${x}" cy="${y}" r="${r}"/>`;
}

function badge(p, cls) {
  const [x, y] = toScreen(p);
  return `<g class="badge ${cls}"><circle cx="${x + 10}" cy="${y - 10}" r="7"/><text x="${x + 10}" y="${y - 10}">!</text></g>`;
}

function entryMarkup(key, cls, points, { colour = null, arrow = false, dots = false } = {}) {
  const bad = isNamed(key, errorPaths()), warn = !bad && isNamed(key, warningPaths());
  const classes = ["entry", cls];
  if (S.selection === key) classes.push("selected");
  if (S.hover === key) classes.push("hover");
  if (bad) classes.push("bad");
  if (warn) classes.push("warn");
  const pts = pointsAttr(points);
  const style = colour ? ` style="stroke:${colour}"` : "";
  let extra = "";
  if (arrow) extra += dot(points[0], DOT) + `<polygon class="head" points="${arrowHead(points[0], points[1])}"/>`;
  if (dots) extra += dot(points[0], DOT) + dot(points[1], DOT);
  if (bad || warn) extra += badge(points[0], bad ? "bad" : "");
  const casing = cls.startsWith("boundary") ? `<polyline class="casing" points="${pts}"/>` : "";
  return `<g class="${classes.join(" ")}" data-key="${key}"><polyline class="outline" points="${pts}"/>` +
    `${casing}<polyline class="line" points="${pts}"${style}/>${extra}</g>`;
}

// A predicted arrow, drawn under the user's entries, with its own accept (✓) and flip (⇄)
// controls beside its middle: the arrow itself is no control.
function predictionMarkup(r, k) {
  const [a, b] = r.points, pts = pointsAttr([a, b]);
  const [ax, ay] = toScreen(a), [bx, by] = toScreen(b);
  const n = Math.hypot(bx - ax, by - ay) || 1;
  const ox = -(by - ay) / n * 16, oy = (bx - ax) / n * 16;  // beside the arrow, not on it
  const mx = (ax + bx) / 2 + ox, my = (ay + by) / 2 + oy;
  const chip = (cls, x, text, title) => `<g class="chip ${cls}" data-relation="${k}"><title>${title}</title>` +
    `<rect x="${x}" y="${my - 8}" width="16" height="16" rx="3"/><text x="${x + 8}" y="${my + 0.5}" ` +
    `text-anchor="middle" dominant-baseline="central">${text}</text></g>`;
  const sel = S.selectedRelation === k ? " selected" : "";
  return `<g class="pred${sel}" data-relation="${k}"><title>predicted: ${r.front} in front of ${r.back} ` +
    `(confidence ${r.confidence.toFixed(2)})</title><polyline class="outline" points="${pts}"/>` +
    `<polyline class="line" points="${pts}"/>${dot(a, 3)}<polygon class="head" points="${arrowHead(a, b)}"/>` +
    `<text class="conf" x="${mx - 44}" y="${my + 4}">${r.confidence.toFixed(2)}</text>` +
    chip("accept", mx - 17, "✓", `accept: ${r.front} in front of ${r.back}`) +
    chip("flip", mx + 1, "⇄", `flip: ${r.back} in front of ${r.front}`) + `</g>`;
}

function renderMarks() {
  const doc = S.doc;
  let out = "";
  if ($("show-predicted").checked) {
    S.relations.forEach((r, k) => {
      if (r.source === "predicted" && r.kind === "order") out += predictionMarkup(r, k);
    });
  }
  (doc.background || []).forEach((s, j) => { out += entryMarkup(`background[${j}]`, "background", s); });
  (doc.regions || []).forEach((r, i) => r.scribbles.forEach((s, j) => {
    out += entryMarkup(`regions[${i}].scribbles[${j}]`, `region region-${i}`, s, { colour: colourOf(i) });
  }));
  (doc.boundaries || []).forEach((b, k) => {
    out += entryMarkup(`boundaries[${k}]`, `boundary boundary-${b.type}`, b.path);
  });
  (doc.equal || []).forEach((e, k) => { out += entryMarkup(`equal[${k}]`, "equal", [e.a, e.b], { dots: true }); });
  (doc.order || []).forEach((o, k) => { out += entryMarkup(`order[${k}]`, "order", [o.front, o.back], { arrow: true }); });
  if (S.spot) { const [x, y] = toScreen(S.spot); out += `<circle class="spot" cx="${x}" cy="${y}" r="14"/>`; }
  if (S.pending) out += dot(S.pending, 5, "pending");
  if (S.draft) {
    const pts = pointsAttr(S.draft.points);
    out += `<g class="draft"><polyline class="outline" points="${pts}"/><polyline class="line" points="${pts}"/></g>`;
  }
  $("marks").innerHTML = out;
}

function renderRegions() {
  const box = $("regions");
  const paths = errorPaths();
  // Rebuilt only when something shown changed: a name being typed keeps its field.
  const shown = JSON.stringify([S.doc.regions, S.region, S.palette, paths]);
  if (box.dataset.shown === shown) return;
  box.dataset.shown = shown;
  box.innerHTML = "";
  (S.doc.regions || []).forEach((r, i) => {
    const row = document.createElement("div");
    row.className = "region" + (i === S.region ? " current" : "") + (isNamed(`regions[${i}]`, paths) ? " bad" : "");
    row.dataset.index = String(i);
    row.innerHTML = `<span class="swatch" style="background:${colourOf(i)}"></span>` +
      `<input class="name" value="${escapeHtml(r.name)}" title="name (letters, digits, _ and -)">` +
      `<input class="inflation" type="number" min="0.1" max="1000" step="0.5" value="${r.inflation ?? 2}" title="inflation">` +
      `<select class="profile" title="profile">${["sqrt", "linear", "flat"].map((p) =>
        `<option${(r.profile || "sqrt") === p ? " selected" : ""}>${p}</option>`).join("")}</select>` +
      `<button class="remove" title="delete this region">×</button>`;
    row.addEventListener("click", (e) => {
      if (e.target.closest("input,select,button")) return;
      S.region = i;
      S.newRegion = false;
      setTool("region");
      zoomTo(entryPoints(S.doc, `regions[${i}]`));
    });
    row.querySelector(".name").addEventListener("focus", () => { S.region = i; renderCurrent(); });
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

function renderCurrent() {
  const el = $("current-region");
  const r = (S.doc.regions || [])[S.region];
  if (S.tool !== "region") { el.innerHTML = ""; return; }
  el.innerHTML = S.newRegion || !r ? "→ <b>new region</b>"
    : `→ <span class="swatch" style="background:${colourOf(S.region)}"></span><b>${escapeHtml(r.name)}</b>`;
}

function editRegion(i, key, value) {
  const doc = clone(S.doc);
  doc.regions[i][key] = value;
  return commit(doc);
}

function relationKey(r) {
  return r.source === "user" ? `${r.kind}[${r.entry}]` : null;
}

function renderRelations() {
  const ul = $("relations");
  const shown = JSON.stringify([S.relations, S.selection, S.selectedRelation]);
  if (ul.dataset.shown === shown) return;
  ul.dataset.shown = shown;
  ul.innerHTML = "";
  S.relations.forEach((r, k) => {
    const li = document.createElement("li");
    li.className = r.source;
    li.dataset.relation = String(k);
    const key = relationKey(r);
    if ((key && key === S.selection) || S.selectedRelation === k) li.classList.add("selected");
    const sign = r.kind === "equal" ? "=" : "in front of";
    const tag = r.source === "user" ? r.label : `predicted, ${r.confidence.toFixed(2)}`;
    li.innerHTML = `<button class="goto" data-relation="${k}" title="show it on the drawing">` +
      `${escapeHtml(r.front)} ${sign} ${escapeHtml(r.back)} <small>(${tag})</small></button>`;
    if (r.source === "predicted" && r.kind === "order") {
      li.innerHTML += `<button class="accept" data-relation="${k}" title="make it an order entry">accept</button>` +
        `<button class="flip" data-relation="${k}" title="an order entry the other way round">flip</button>`;
    }
    ul.appendChild(li);
  });
}

// Warnings of one kind are folded into one row that opens to each of them.
function warningGroup(w) {
  return w.replace(/'[^']*'/g, "…").replace(/\d+(\.\d+)?/g, "#");
}

function warningPlace(w) {
  const m = w.match(/\((\d+(?:\.\d+)?), (\d+(?:\.\d+)?)\)/);
  return m ? [+m[1], +m[2]] : null;
}

function renderWarnings() {
  const ul = $("warnings");
  const problems = [];
  for (const [kind, e] of Object.entries(S.errors)) if (e && kind !== "document" && kind !== "save") problems.push(e.error);
  const all = [...new Set(problems), ...S.checks, ...(S.warnings || [])];
  const shown = JSON.stringify([all, S.selection]);
  if (ul.dataset.shown === shown) return;
  ul.dataset.shown = shown;
  $("problem-count").textContent = all.length ? `(${all.length})` : "";
  $("problems-button").hidden = !all.length;
  $("problems-button").textContent = `⚠ ${all.length} problem${all.length === 1 ? "" : "s"}`;
  const groups = new Map();
  for (const w of all) {
    const g = warningGroup(w);
    if (!groups.has(g)) groups.set(g, []);
    groups.get(g).push(w);
  }
  const row = (w) => {
    const keys = [...w.matchAll(ENTRY)].map((m) => m[0]);
    const sel = keys.length && keys.includes(S.selection) ? " selected" : "";
    return `<li class="${sel}"><button class="goto" data-warning="${escapeHtml(w)}" title="show it on the drawing">` +
      `${escapeHtml(w)}</button></li>`;
  };
  let out = "";
  for (const [, members] of groups) {
    if (members.length === 1) { out += row(members[0]); continue; }
    const head = members[0].replace(/ at \(.*$/, "").replace(/\d+/g, "…");
    out += `<li><details><summary>${escapeHtml(head)} (${members.length})</summary><ul>` +
      members.map(row).join("") + `</ul></details></li>`;
  }
  ul.innerHTML = out;
}

// A warning's row: select the entry it names (if any) and show its place.
function gotoWarning(w) {
  const keys = [...w.matchAll(ENTRY)].map((m) => m[0]);
  const place = warningPlace(w);
  const key = keys.find((k) => entryPoints(S.doc, k).length);
  S.selection = key && !key.match(/^regions\[\d+\]$/) ? key : null;
  S.selectedRelation = null;
  S.spot = place && !S.selection ? place : null;
  if (key && key.match(/^regions\[(\d+)\]$/)) S.region = +key.match(/\d+/)[0];
  const points = key ? entryPoints(S.doc, key) : [];
  zoomTo(points.length ? points : place ? [place] : []);
  render();
}

function gotoRelation(k) {
  const r = S.relations[k];
  if (!r) return;
  const key = relationKey(r);
  S.selection = key;
  S.selectedRelation = key ? null : k;
  S.spot = null;
  zoomTo(key ? entryPoints(S.doc, key) : r.points);
  render();
}

function acceptRelation(k, flip) {
  const r = S.relations[k];
  if (!r || r.source !== "predicted") return;
  const [front, back] = flip ? [r.points[1], r.points[0]] : r.points;
  const doc = clone(S.doc);
  list(doc, "order").push({ front: clampPoint(front), back: clampPoint(back) });
  S.selectedRelation = null;
  commit(doc);
}

function escapeHtml(s) {
  return String(s).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]);
}

// The messages above the drawing (never over it): a refused edit, a failed save, a document
// that cannot be computed, in plain words where the server has them; a click shows the entries.
function renderMessages() {
  const seen = new Set();
  let out = "";
  for (const [kind, e] of Object.entries(S.errors)) {
    if (!e || seen.has(e.error)) continue;
    seen.add(e.error);
    const words = e.plain ? `${e.plain.charAt(0).toUpperCase()}${e.plain.slice(1)}.` : e.error;
    const prefix = kind === "document" || kind === "save" || e.plain ? "" : `${kind}: `;
    out += `<button class="message" data-paths="${escapeHtml(JSON.stringify(e.paths || []))}">` +
      `${escapeHtml(prefix + words)}${e.plain ? `<br><span class="detail">${escapeHtml(e.error)}</span>` : ""}</button>`;
  }
  const box = $("error");
  box.hidden = !out;
  if (box.dataset.shown !== out) { box.innerHTML = out; box.dataset.shown = out; }
}

function renderPreviewNotes() {
  const doc = S.doc;
  const depthError = S.errors.depth, reliefError = S.errors.relief;
  let depth = "";
  if (!hasEntries(doc)) depth = "No depth map yet: scribble inside the parts of the character (R), or draw an order arrow (O).";
  else if (depthError && !$("depth").getAttribute("src")) depth = `No depth map: ${depthError.plain || depthError.error}`;
  else if (S.depthFlat && $("depth").getAttribute("src")) {
    depth = "One depth everywhere: nothing says yet which part is in front. Draw an order arrow (O) " +
      "from a part in front to the part behind it.";
  }
  $("depth-note").textContent = depth;
  let relief = "";
  const model = S.reliefView && S.reliefView.model;
  if (!hasRegions(doc)) relief = "No relief yet: a relief needs at least one region. Scribble inside a part (R).";
  else if (reliefError && !model) relief = `No relief: ${reliefError.plain || reliefError.error}`;
  $("relief-note").textContent = relief;
  const stale = Boolean(reliefError && model);
  $("relief-badge").hidden = !stale;
  $("relief-badge").textContent = stale ? "last good relief: the current annotation has a problem (see above)" : "";
  $("relief").dataset.lastGood = stale ? "true" : "false";
}

function renderGuide() {
  const doc = S.doc;
  const done = { regions: (doc.regions || []).length >= 2, look: (doc.order || []).length > 0, save: !dirty() && S.saved };
  for (const li of document.querySelectorAll("#guide li")) li.classList.toggle("done", Boolean(done[li.dataset.step]));
  $("guide").hidden = S.guideClosed || (hasRegions(doc) && S.guideShownFor !== S.path) ||
    (done.regions && (done.look || done.save));
}

function render() {
  if (!S.doc) return;
  renderMarks();
  renderRegions();
  renderRelations();
  renderWarnings();
  renderMessages();
  renderPreviewNotes();
  renderCurrent();
  renderGuide();
  $("undo").disabled = S.index <= 0;
  $("redo").disabled = S.index >= S.history.length - 1;
  $("delete").disabled = !S.selection;
  $("labels").style.display = $("show-labels").checked ? "" : "none";
  $("labels").style.opacity = $("labels-opacity").value;
  $("zoom-level").textContent = `${Math.round(S.view.s * 100)}%`;
  setStatus();
}

function dirty() { return S.doc !== null && JSON.stringify(S.doc) !== S.baseText; }

function setStatus(text) {
  const el = $("status");
  const d = dirty();
  el.classList.toggle("dirty", d);
  const state = d ? "unsaved changes" : S.saved || S.baseText !== S.loadedText ? "saved" :
    S.shot && S.shot.key !== null ? "carried, not saved (saving makes it a key)" : "new file, nothing to save yet";
  el.textContent = text || [state, S.busy.size ? "computing previews…" : ""].filter(Boolean).join(" · ");
  document.body.dataset.busy = String(S.busy.size > 0);
  document.body.dataset.dirty = String(d);
}

// -- view: zoom and pan -------------------------------------------------------------------

function applyView() {
  S.atFit = false;
  const { s, tx, ty } = S.view;
  $("stage").style.transform = `translate(${tx}px, ${ty}px) scale(${s})`;
  $("zoom-level").textContent = `${Math.round(s * 100)}%`;
  placeNameField();
  renderMarks();
}

function fit() {
  const vp = $("viewport").getBoundingClientRect();
  const [w, h] = S.size;
  const s = Math.min(vp.width / w, vp.height / h) * 0.96;
  S.fitScale = s;
  S.view = { s, tx: (vp.width - w * s) / 2, ty: (vp.height - h * s) / 2 };
  S.atFit = true;
  applyView();
}

// Zoom to scale ``s`` about the viewport point (x, y) (default: its centre).
function zoomTo_(s, x, y) {
  const vp = $("viewport").getBoundingClientRect();
  if (x === undefined) { x = vp.width / 2; y = vp.height / 2; }
  const { s: s0, tx, ty } = S.view;
  const next = Math.min(Math.max(s, 0.05), 64);
  S.view = { s: next, tx: x - ((x - tx) * next) / s0, ty: y - ((y - ty) * next) / s0 };
  applyView();
}
// For scripts and tests: scale ``s`` (screen pixels per drawing pixel), centred on drawing
// point ``at`` when given.
S.setZoom = (s, at) => {
  zoomTo_(s);
  if (!at) return;
  const vp = $("viewport").getBoundingClientRect();
  S.view.tx = vp.width / 2 - (at[0] + 0.5) * S.view.s;
  S.view.ty = vp.height / 2 - (at[1] + 0.5) * S.view.s;
  applyView();
};

function zoomAt(e, factor) {
  const [x, y] = viewportPoint(e);
  zoomTo_(S.view.s * factor, x, y);
}

// Centre the view on ``points`` (drawing pixels), zoomed so that they fill about a third of it.
function zoomTo(points) {
  if (!points.length) return;
  const vp = $("viewport").getBoundingClientRect();
  const xs = points.map((p) => p[0]), ys = points.map((p) => p[1]);
  const x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
  const span = Math.max(x1 - x0, y1 - y0, 24);
  const s = Math.min(Math.max(Math.min(vp.width, vp.height) * 0.4 / span, S.fitScale), S.fitScale * 6);
  const cx = (x0 + x1) / 2 + 0.5, cy = (y0 + y1) / 2 + 0.5;
  S.view = { s, tx: vp.width / 2 - cx * s, ty: vp.height / 2 - cy * s };
  applyView();
}

// -- tools ----------------------------------------------------------------------------------

function setTool(tool) {
  S.tool = tool;
  S.draft = null;
  S.pending = null;
  for (const b of document.querySelectorAll("#tools button")) b.classList.toggle("active", b.dataset.tool === tool);
  $("viewport").className = `tool-${tool}`;
  render();
}

function onPointerDown(e) {
  if (e.target.closest("#name-field")) return;
  const vp = $("viewport");
  vp.setPointerCapture(e.pointerId);
  if (e.button === 1 || S.space || S.tool === "pan") {
    S.drag = { kind: "pan", x: e.clientX, y: e.clientY, tx: S.view.tx, ty: S.view.ty };
    vp.classList.add("panning");
    return;
  }
  if (e.button !== 0) return;
  closeNameField(true);
  const p = toDrawing(e);
  if (S.tool === "select") {
    // The user's own entries first; a prediction only through its own controls.
    const key = hitEntry(viewportPoint(e));
    const chip = key ? null : e.target.closest(".chip");
    if (chip) { acceptRelation(+chip.dataset.relation, chip.classList.contains("flip")); return; }
    S.selection = key;
    S.selectedRelation = null;
    S.spot = null;
    if (key) S.drag = { kind: "move", key, start: p, base: S.doc, moved: false };
    render();
    return;
  }
  S.draft = { tool: S.tool, points: [clampPoint(p)], x: e.clientX, y: e.clientY, shift: e.shiftKey };
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
    if (!d.moved && Math.hypot(dx, dy) * S.view.s < CLICK) return;
    d.moved = true;
    S.doc = moved(d.base, d.key, dx, dy);
    renderMarks();
    return;
  }
  if (!S.draft) {
    if (S.tool === "select") {
      const key = hitEntry(viewportPoint(e));
      $("viewport").classList.toggle("over-entry", Boolean(key));
      if (key !== S.hover) { S.hover = key; renderMarks(); }
    }
    return;
  }
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

function moved(doc, key, dx, dy) {
  const out = clone(doc);
  for (const q of entryPoints(out, key)) {
    const [x, y] = clampPoint([q[0] + dx, q[1] + dy]);
    q[0] = x; q[1] = y;
  }
  return out;
}

async function onPointerUp(e) {
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
  const click = Math.hypot(e.clientX - draft.x, e.clientY - draft.y) < CLICK;
  if (draft.tool === "boundary" && click) { await boundaryClick(end); return; }
  if (draft.tool !== "order" && draft.tool !== "equal") {
    const last = pts[pts.length - 1];
    if (last[0] !== end[0] || last[1] !== end[1]) pts.push(end);
  }
  const doc = clone(S.doc);
  if (draft.tool === "region") {
    await regionScribble(doc, pts, draft.shift);
    return;
  } else if (draft.tool === "background") {
    list(doc, "background").push(pts);
  } else if (draft.tool === "boundary") {
    S.pending = null;
    list(doc, "boundaries").push({ type: $("boundary-type").value, path: pts });
  } else {
    const [a, b] = pts;
    if (Math.hypot(a[0] - b[0], a[1] - b[1]) < 2) { renderMarks(); return; }  // a click is no arrow
    if (draft.tool === "order") list(doc, "order").push({ front: a, back: b });
    else list(doc, "equal").push({ a, b });
  }
  commit(doc);
}

// A region scribble: into the region whose part it lies in, else a new region named at once.
async function regionScribble(doc, pts, shift) {
  const regions = list(doc, "regions");
  let i = null;
  if (shift && S.region >= 0 && S.region < regions.length) i = S.region;
  else {
    const { ok, answer } = await postJSON("/api/scribble-region", { points: pts, current: S.region });
    if (ok && answer.edge && !(doc.background || []).length) {
      // Without a background scribble the drawing's edge is background: a region in the
      // paper around the character would keep little more than its own scribble.
      S.errors.document = { error: "This scribble lies on the paper around the character, which " +
        "the drawing's edge makes background: scribble it with Background (B), or add a " +
        "background scribble first.", paths: [] };
      render();
      return;
    }
    if (ok && !S.newRegion && regions.length) i = answer.region;
  }
  const fresh = i === null || i === undefined;
  if (fresh) {
    regions.push({ name: newRegionName(doc), scribbles: [] });
    i = regions.length - 1;
  }
  regions[i].scribbles.push(pts);
  S.region = i;
  S.newRegion = false;
  if (await commit(doc) && fresh) openNameField(i, pts[pts.length - 1]);
}

// The name field of a new region, at the end of its scribble: Enter or leaving it renames,
// Esc keeps the default name.
function openNameField(i, at) {
  const field = $("name-field");
  field.dataset.region = String(i);
  field.dataset.at = JSON.stringify(at);
  field.value = S.doc.regions[i].name;
  field.classList.remove("invalid");
  field.hidden = false;
  placeNameField();
  field.focus();
  field.select();
}

function placeNameField() {
  const field = $("name-field");
  if (field.hidden) return;
  const [x, y] = toScreen(JSON.parse(field.dataset.at));
  field.style.left = `${x + 12}px`;
  field.style.top = `${y + 8}px`;
}

function closeNameField(keep) {
  const field = $("name-field");
  if (field.hidden) return;
  const i = +field.dataset.region, name = field.value.trim();
  const region = (S.doc.regions || [])[i];
  if (keep && region && name !== region.name) {
    const taken = S.doc.regions.some((r, j) => j !== i && r.name === name);
    if (!NAME.test(name) || taken) {
      field.classList.add("invalid");
      field.title = taken ? `${name}: another region has this name` : "letters, digits, _ and - only";
      return false;
    }
    field.hidden = true;
    editRegion(i, "name", name);
    return true;
  }
  field.hidden = true;
  return true;
}

async function boundaryClick(p) {
  if (!S.pending) { S.pending = p; renderMarks(); return; }
  const start = S.pending;
  S.pending = null;
  const { ok, answer } = await postJSON("/api/outline-path", { from: start, to: p });
  if (!ok) {
    S.errors.document = { error: answer.error, paths: [] };
    render();
    return;
  }
  const doc = clone(S.doc);
  list(doc, "boundaries").push({ type: $("boundary-type").value, path: answer.path.map(clampPoint) });
  commit(doc);
}

function deleteSelection() {
  if (!S.selection) return;
  const doc = clone(S.doc);
  removeEntry(doc, S.selection);
  S.selection = null;
  commit(doc);
}

function nudge(dx, dy) {
  if (!S.selection) return;
  commit(moved(S.doc, S.selection, dx, dy));
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
  const arrows = { arrowleft: [-1, 0], arrowright: [1, 0], arrowup: [0, -1], arrowdown: [0, 1] };
  if (arrows[k] && S.selection) {
    e.preventDefault();
    const f = e.shiftKey ? 10 : 1;
    nudge(arrows[k][0] * f, arrows[k][1] * f);
    return;
  }
  if (e.target.closest && e.target.closest("button") && (k === "enter")) return;
  const tools = { v: "select", r: "region", b: "background", o: "order", e: "equal", g: "boundary", h: "pan" };
  if (tools[k]) setTool(tools[k]);
  if (k === "n") newRegion();
  if (k === "f") fit();
  if (k === "+" || k === "=") zoomTo_(S.view.s * 1.5);
  if (k === "-") zoomTo_(S.view.s / 1.5);
  if (k === "1") zoomTo_(1);
  if (k === "escape") {
    S.draft = null; S.pending = null; S.selection = null; S.selectedRelation = null; S.spot = null;
    $("relief-panel").classList.remove("big");
    render();
  }
}

function newRegion() {
  S.newRegion = true;  // the next region scribble starts one: a region needs a scribble
  setTool("region");
}

// -- start ------------------------------------------------------------------------------

async function discardAutosave() {
  await putChain;
  const { ok, answer } = await postJSON("/api/discard-autosave");
  if (!ok) return;
  S.generation = answer.generation;
  S.palette = answer.palette;
  document.body.dataset.generation = String(S.generation);
  const doc = await (await fetch("/api/annotations", { cache: "no-store" })).json();
  S.doc = doc;
  S.history = [doc];
  S.index = 0;
  S.baseText = JSON.stringify(doc);
  S.saved = S.exists;
  S.selection = null;
  S.region = (doc.regions || []).length ? 0 : -1;
  keepHistory();
  $("autosave-banner").hidden = true;
  refresh();
}

async function start() {
  const info = await (await fetch("/api/info", { cache: "no-store" })).json();
  const doc = await (await fetch("/api/annotations", { cache: "no-store" })).json();
  S.size = info.size;
  S.palette = info.palette;
  S.generation = info.generation;
  S.path = info.path;
  S.exists = info.exists;
  S.saved = info.saved;
  S.doc = doc;
  S.history = [doc];
  S.index = 0;
  restoreHistory(doc);
  // A restored autosave is unsaved work; a new file with nothing in it is not.
  S.loadedText = JSON.stringify(doc);
  S.baseText = info.restored ? null : S.loadedText;
  S.region = (doc.regions || []).length ? 0 : -1;
  S.guideShownFor = hasRegions(doc) ? null : S.path;
  document.body.dataset.generation = String(S.generation);
  const name = info.path.split(/[\\/]/).pop();
  $("file").textContent = name;
  $("file").title = `${info.path}\nautosave: ${info.autosave}`;
  if (info.restored) {
    $("autosave-text").textContent = `Continuing from unsaved changes kept in ${info.autosave.split(/[\\/]/).pop()} ` +
      `(${name} itself is unchanged until you save).`;
    $("autosave-banner").hidden = false;
  }
  const [w, h] = S.size;
  for (const id of ["drawing", "labels"]) { $(id).width = w; $(id).height = h; }
  $("drawing").src = "/api/drawing.png";
  S.reliefView = new ReliefView($("relief"));

  const vp = $("viewport");
  vp.addEventListener("pointerdown", onPointerDown);
  vp.addEventListener("pointermove", onPointerMove);
  vp.addEventListener("pointerup", onPointerUp);
  vp.addEventListener("pointerleave", () => { if (S.hover) { S.hover = null; renderMarks(); } });
  vp.addEventListener("wheel", (e) => { e.preventDefault(); zoomAt(e, Math.exp(-e.deltaY * 0.0015)); }, { passive: false });
  vp.addEventListener("auxclick", (e) => e.preventDefault());
  window.addEventListener("keydown", onKey);
  window.addEventListener("keyup", (e) => { if (e.key === " ") { S.space = false; vp.classList.remove("panning"); } });
  window.addEventListener("beforeunload", (e) => { if (dirty()) { e.preventDefault(); e.returnValue = ""; } });
  window.addEventListener("resize", () => S.reliefView.resize());
  new ResizeObserver(() => { if (S.atFit) fit(); }).observe(vp);  // hints come and go above it
  for (const b of document.querySelectorAll("#tools button")) b.addEventListener("click", () => setTool(b.dataset.tool));
  $("undo").addEventListener("click", () => step(-1));
  $("redo").addEventListener("click", () => step(1));
  $("delete").addEventListener("click", deleteSelection);
  $("fit").addEventListener("click", fit);
  $("zoom-in").addEventListener("click", () => zoomTo_(S.view.s * 1.5));
  $("zoom-out").addEventListener("click", () => zoomTo_(S.view.s / 1.5));
  $("zoom-level").addEventListener("click", () => zoomTo_(1));
  $("save").addEventListener("click", save);
  $("problems-button").addEventListener("click", () => {
    $("problems-panel").open = true;
    $("problems-panel").scrollIntoView({ block: "start" });
    const first = $("warnings").querySelector("button, summary");
    if (first) first.focus();
  });
  $("add-region").addEventListener("click", newRegion);
  $("guide-close").addEventListener("click", () => { S.guideClosed = true; render(); });
  $("autosave-keep").addEventListener("click", () => { $("autosave-banner").hidden = true; });
  $("autosave-discard").addEventListener("click", discardAutosave);
  $("relief-reset").addEventListener("click", () => S.reliefView.frame());
  $("relief-enlarge").addEventListener("click", () => {
    const big = $("relief-panel").classList.toggle("big");
    $("relief-enlarge").textContent = big ? "Back" : "Enlarge";
  });
  const field = $("name-field");
  field.addEventListener("keydown", (e) => {
    if (e.key === "Enter") { e.preventDefault(); closeNameField(true); }
    if (e.key === "Escape") { e.preventDefault(); field.hidden = true; }
    e.stopPropagation();
  });
  field.addEventListener("blur", () => closeNameField(true));
  for (const id of ["show-labels", "labels-opacity", "show-predicted"]) $(id).addEventListener("input", render);
  for (const r of document.querySelectorAll("input[name=depth-method]")) r.addEventListener("change", refresh);
  $("relations").addEventListener("click", (e) => {
    const b = e.target.closest("button[data-relation]");
    if (!b) return;
    if (b.classList.contains("goto")) gotoRelation(+b.dataset.relation);
    else acceptRelation(+b.dataset.relation, b.classList.contains("flip"));
  });
  $("warnings").addEventListener("click", (e) => {
    const b = e.target.closest("button[data-warning]");
    if (b) gotoWarning(b.dataset.warning);
  });
  $("error").addEventListener("click", (e) => {
    const b = e.target.closest("button.message");
    if (!b) return;
    const paths = JSON.parse(b.dataset.paths);
    S.selection = paths.find((p) => !p.match(/^regions\[\d+\]$/)) || null;
    zoomTo(paths.flatMap((p) => entryPoints(S.doc, p)));
    render();
  });
  setTool("select");
  fit();
  refresh();
  startShot(S, { render, save, dirty, setStatus });
}

start();
