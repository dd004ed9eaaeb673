// inkray edit, Pose mode: click on the drawing to place a handle, drag a handle to pose the
// drawing (the server answers each drag with the posed picture, POST /api/pose), keep keys on
// a timeline, play them back, save the pose file (POST /api/pose/save). docs/editor.md.

const $ = (id) => document.getElementById(id);
const P = { on: false, handles: [], to: [], keys: [], drag: -1, busy: false, queued: false,
            updates: 0, url: null, playing: false };
window.inkrayPose = P;  // for scripts and tests

function view() { return window.inkray.view; }

function toDrawing(e) {
  const vp = $("viewport").getBoundingClientRect();
  const { s, tx, ty } = view();
  return [(e.clientX - vp.left - tx) / s - 0.5, (e.clientY - vp.top - ty) / s - 0.5];
}

function renderHandles() {
  const layer = $("pose-handles");
  layer.innerHTML = "";
  const r = 6 / view().s;
  P.to.forEach(([x, y], i) => {
    const c = document.createElementNS("http://www.w3.org/2000/svg", "circle");
    c.setAttribute("cx", x + 0.5); c.setAttribute("cy", y + 0.5); c.setAttribute("r", r);
    c.setAttribute("class", i === P.drag ? "handle active" : "handle");
    layer.appendChild(c);
  });
  $("pose-info").textContent = `${P.handles.length} handles · ${P.keys.length} keys`;
}

function dragScale() {
  // while a handle moves: a picture of at most a quarter megapixel, in full when it stops
  const [w, h] = window.inkray.size;
  return Math.min(1, Math.sqrt(250000 / (w * h)));
}

async function request() {
  // one request in flight; a drag during it sends the newest targets when it returns
  if (P.busy) { P.queued = true; return; }
  if (!P.handles.length) return;
  P.busy = true;
  const scale = P.drag >= 0 ? dragScale() : 1;
  try {
    const r = await fetch("/api/pose", { method: "POST", headers: { "Content-Type": "application/json" },
                                         body: JSON.stringify({ handles: P.handles, to: P.to, scale }) });
    if (r.ok) {
      if (P.url) URL.revokeObjectURL(P.url);
      P.url = URL.createObjectURL(await r.blob());
      $("posed").src = P.url;
      P.updates += 1;
      $("posed").dataset.updates = String(P.updates);
      $("pose-ms").textContent = `${r.headers.get("X-Inkray-Compute-Ms")} ms`;
      $("pose-error").hidden = true;
    } else {
      const e = await r.json();
      $("pose-error").textContent = e.error;
      $("pose-error").hidden = false;
    }
  } finally {
    P.busy = false;
    if (P.queued) { P.queued = false; request(); }
  }
}

function nearest([x, y]) {
  const reach = 10 / view().s;
  let best = -1, d = reach;
  P.to.forEach(([hx, hy], i) => {
    const di = Math.hypot(hx - x, hy - y);
    if (di <= d) { best = i; d = di; }
  });
  return best;
}

function onDown(e) {
  if (!P.on || e.button !== 0) return;
  e.stopPropagation();
  const p = toDrawing(e);
  P.drag = nearest(p);
  if (P.drag < 0) {
    // a handle is a point of the drawing at rest: placing one starts the pose again from rest
    P.handles.push(p);
    P.to = P.handles.map((q) => q.slice());
    P.drag = P.to.length - 1;
    P.keys = [];
    request();
  }
  $("pose-layer").setPointerCapture(e.pointerId);
  renderHandles();
}

function onMove(e) {
  if (!P.on || P.drag < 0) return;
  e.stopPropagation();
  P.to[P.drag] = toDrawing(e);
  renderHandles();
  request();
}

function onUp(e) {
  if (!P.on) return;
  e.stopPropagation();
  const moved = P.drag >= 0;
  P.drag = -1;
  renderHandles();
  if (moved) request();  // the full picture of where the handle stopped
}

// Cubic Hermite with Catmull-Rom tangents, zero at the ends (as the pose file's frames).
function at(frame) {
  const k = P.keys;
  if (k.length === 1) return k[0].to;
  const f = Math.min(Math.max(frame, k[0].frame), k[k.length - 1].frame);
  let i = 0;
  while (i < k.length - 2 && f >= k[i + 1].frame) i++;
  const tangent = (j) => (j === 0 || j === k.length - 1) ? k[j].to.map(() => [0, 0])
    : k[j].to.map((_, h) => [0, 1].map((c) => (k[j + 1].to[h][c] - k[j - 1].to[h][c]) / (k[j + 1].frame - k[j - 1].frame)));
  const h = k[i + 1].frame - k[i].frame, s = (f - k[i].frame) / h;
  const h00 = 2 * s ** 3 - 3 * s ** 2 + 1, h10 = s ** 3 - 2 * s ** 2 + s;
  const h01 = -2 * s ** 3 + 3 * s ** 2, h11 = s ** 3 - s ** 2;
  const m0 = tangent(i), m1 = tangent(i + 1);
  return k[i].to.map((p, hh) => [0, 1].map((c) => h00 * p[c] + h10 * h * m0[hh][c]
    + h01 * k[i + 1].to[hh][c] + h11 * h * m1[hh][c]));
}

function addKey() {
  const frame = Math.max(0, Math.round(+$("pose-frame").value || 0));
  P.keys = P.keys.filter((k) => k.frame !== frame);
  P.keys.push({ frame, to: P.to.map((p) => p.slice()) });
  P.keys.sort((a, b) => a.frame - b.frame);
  $("pose-frame").value = String(frame + 12);
  renderHandles();
}

async function play() {
  if (P.playing || !P.keys.length) return;
  P.playing = true;
  for (let f = P.keys[0].frame; f <= P.keys[P.keys.length - 1].frame && P.on; f++) {
    P.to = at(f).map((p) => p.slice());
    renderHandles();
    await request();
    while (P.busy) await new Promise((r) => setTimeout(r, 10));
  }
  P.playing = false;
}

async function savePose() {
  const keys = P.keys.length ? P.keys : [{ frame: 0, to: P.to }];
  const doc = { format: "inkray-pose", version: 1, handles: P.handles, keys };
  const r = await fetch("/api/pose/save", { method: "POST", headers: { "Content-Type": "application/json" },
                                            body: JSON.stringify(doc) });
  const body = await r.json();
  $("pose-saved").textContent = r.ok ? `saved ${body.path}` : body.error;
  $("pose-saved").dataset.ok = String(r.ok);
}

function toggle() {
  P.on = !P.on;
  $("pose-mode").classList.toggle("active", P.on);
  $("pose-layer").hidden = !P.on;
  $("marks").style.visibility = P.on ? "hidden" : "";  // the annotation's marks are not posed
  if (P.on) request();
  renderHandles();
}

function start() {
  const [w, h] = window.inkray.size;
  const layer = $("pose-layer");
  layer.style.width = `${w}px`;
  layer.style.height = `${h}px`;
  $("posed").style.width = `${w}px`;   // a smaller picture while dragging shows at full size
  $("posed").style.height = `${h}px`;
  $("pose-handles").setAttribute("width", w);
  $("pose-handles").setAttribute("height", h);
  layer.addEventListener("pointerdown", onDown);
  layer.addEventListener("pointermove", onMove);
  layer.addEventListener("pointerup", onUp);
  $("pose-mode").addEventListener("click", toggle);
  $("pose-key").addEventListener("click", addKey);
  $("pose-play").addEventListener("click", play);
  $("pose-save").addEventListener("click", savePose);
  $("pose-clear").addEventListener("click", () => {
    Object.assign(P, { handles: [], to: [], keys: [] });
    $("posed").removeAttribute("src");
    renderHandles();
  });
}

// the drawing's size is known once the editor has loaded its info
(function wait() { if (window.inkray && window.inkray.size[0] > 1) start(); else setTimeout(wait, 50); })();
