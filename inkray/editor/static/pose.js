// inkray edit, Pose mode: click on the drawing to place a handle, drag a handle to pose the
// drawing, keep keys on a timeline, play them back, save the pose file (POST /api/pose/save).
// While a handle moves the page draws the posed parts itself (WebGL): the server sends the
// parts' textured meshes once (GET /api/pose/meshes) and per drag only their posed vertices
// (POST /api/pose/vertices); where a handle stops, the server's picture (POST /api/pose)
// replaces the drawn one. docs/editor.md.
import * as THREE from "three";

const $ = (id) => document.getElementById(id);
const P = { on: false, handles: [], to: [], keys: [], drag: -1, busy: false, queued: false,
            updates: 0, url: null, playing: false, drawn: 0, gl: null };
window.inkrayPose = P;  // for scripts and tests

// The posed parts as WebGL meshes: each pixel shows the highest front triangle (a depth test
// on the relief's height), its premultiplied colour over what is drawn under it; a part's
// skirt (its layer's soft edge and strokes beyond its triangles) has no height: drawn before
// the part's triangles, over the parts before it, and left for any part after it to cover.
const VERTEX = `precision highp float;
in vec3 position; in vec2 uv;
uniform vec2 size; uniform vec2 texsize; uniform vec2 height; uniform float skirt;
out vec2 at;
void main() {
  at = (uv + 0.5) / texsize;
  float t = (position.z - height.x) / max(height.y - height.x, 1e-6);
  gl_Position = vec4((position.x + 0.5) / size.x * 2.0 - 1.0, 1.0 - (position.y + 0.5) / size.y * 2.0,
                     skirt > 0.5 ? 0.95 : 0.9 - 1.8 * t, 1.0);
}`;
const FRAGMENT = `precision highp float;
uniform sampler2D map;
in vec2 at; out vec4 colour;
void main() {
  vec4 c = texture(map, at);
  if (c.a < 0.5 / 255.0) discard;  // what is transparent is not there: the part under it shows
  colour = c;
}`;

class Drawn {
  constructor(canvas) {
    this.renderer = new THREE.WebGLRenderer({ canvas, alpha: true, premultipliedAlpha: true,
                                              antialias: false, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(1);
    this.renderer.setClearColor(0x000000, 0);
    this.renderer.sortObjects = true;
    this.camera = new THREE.Camera();  // the shader places vertices itself
    this.scene = null;
    this.generation = -1;
    this.loading = null;
  }

  async load() {
    if (!this.loading) this.loading = this._load().finally(() => { this.loading = null; });
    return this.loading;
  }

  async _load() {
    const r = await fetch("/api/pose/meshes");
    if (!r.ok) throw new Error((await r.json()).error);
    const m = await r.json();
    const [w, h] = m.size;
    this.renderer.setSize(w, h, false);
    const scene = new THREE.Scene();
    const buffers = [];
    let order = 0;
    for (const part of m.parts) {
      const position = new THREE.BufferAttribute(new Float32Array(3 * part.vertices), 3);
      position.setUsage(THREE.DynamicDrawUsage);
      buffers.push(position);
      if (!part.faces.length) continue;
      const img = new Image();
      img.src = `data:image/png;base64,${part.texture.png}`;
      await img.decode();
      const map = new THREE.Texture(img);
      Object.assign(map, { flipY: false, premultiplyAlpha: true, generateMipmaps: false,
                           minFilter: THREE.LinearFilter, magFilter: THREE.LinearFilter,
                           wrapS: THREE.ClampToEdgeWrapping, wrapT: THREE.ClampToEdgeWrapping });
      map.needsUpdate = true;
      const uv = new THREE.BufferAttribute(new Float32Array(part.texcoords), 2);
      const faces = new Uint32Array(part.faces);
      // the skirt first: where the part's own triangles cover a pixel, they draw it
      for (const [skirt, index] of [[1, faces.subarray(3 * part.inner)],
                                    [0, faces.subarray(0, 3 * part.inner)]]) {
        if (!index.length) continue;
        const geometry = new THREE.BufferGeometry();
        geometry.setAttribute("position", position);
        geometry.setAttribute("uv", uv);
        geometry.setIndex(new THREE.BufferAttribute(index, 1));
        const material = new THREE.RawShaderMaterial({
          glslVersion: THREE.GLSL3, vertexShader: VERTEX, fragmentShader: FRAGMENT,
          uniforms: { map: { value: map }, size: { value: new THREE.Vector2(w, h) },
                      texsize: { value: new THREE.Vector2(...part.texture.size) },
                      height: { value: new THREE.Vector2(...m.height) }, skirt: { value: skirt } },
          transparent: true, side: THREE.DoubleSide, depthTest: true, depthWrite: true,
          depthFunc: skirt ? THREE.AlwaysDepth : THREE.LessEqualDepth,
          blending: THREE.CustomBlending, blendEquation: THREE.AddEquation,
          blendSrc: THREE.OneFactor, blendDst: THREE.OneMinusSrcAlphaFactor,
          blendSrcAlpha: THREE.OneFactor, blendDstAlpha: THREE.OneMinusSrcAlphaFactor });
        const mesh = new THREE.Mesh(geometry, material);
        mesh.frustumCulled = false;
        mesh.renderOrder = order++;
        scene.add(mesh);
      }
    }
    if (this.scene) this.scene.traverse((o) => { if (o.isMesh) { o.geometry.dispose(); o.material.dispose(); } });
    Object.assign(this, { scene, buffers, generation: +r.headers.get("X-Inkray-Generation") });
  }

  // the posed vertices (float32 x, y, height per vertex, the parts one after the other)
  draw(data) {
    let k = 0;
    for (const b of this.buffers) {
      b.array.set(data.subarray(k, k + b.array.length));
      b.needsUpdate = true;
      k += b.array.length;
    }
    if (k !== data.length) throw new Error("the posed vertices do not fit the parts' meshes");
    this.renderer.render(this.scene, this.camera);
  }
}

function glOk() {
  if (P.gl === null) {
    try { P.gl = new Drawn($("posed-gl")); } catch (e) { P.gl = false; }  // no WebGL 2: pictures
  }
  return P.gl;
}

function show(drawn) {
  $("posed-gl").hidden = !drawn;
  $("posed").hidden = drawn;
}

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

function failed(message) {
  $("pose-ms").textContent = "";
  $("pose-error").textContent = message;
  $("pose-error").hidden = false;
}

function updated(r) {
  P.updates += 1;
  $("posed").dataset.updates = String(P.updates);
  $("pose-ms").textContent = `${r.headers.get("X-Inkray-Compute-Ms")} ms`;
  $("pose-error").hidden = true;
}

// while a handle moves or the keys play: the posed vertices, drawn by the page
async function drawVertices() {
  const gl = P.gl;
  for (let attempt = 0; attempt < 2; attempt++) {
    if (gl.generation < 0) await gl.load();
    const r = await fetch("/api/pose/vertices", { method: "POST", headers: { "Content-Type": "application/json" },
                                                  body: JSON.stringify({ handles: P.handles, to: P.to }) });
    if (!r.ok) { failed((await r.json()).error); return; }
    const data = new Float32Array(await r.arrayBuffer());
    if (+r.headers.get("X-Inkray-Generation") !== gl.generation) {  // the document changed
      gl.generation = -1;
      continue;
    }
    gl.draw(data);
    show(true);
    P.drawn += 1;
    updated(r);
    return;
  }
}

// the server's picture: where a handle stops, or while it moves (or the keys play) without
// WebGL (smaller while it moves)
async function picture() {
  const scale = P.drag >= 0 ? dragScale() : 1;
  const r = await fetch("/api/pose", { method: "POST", headers: { "Content-Type": "application/json" },
                                       body: JSON.stringify({ handles: P.handles, to: P.to, scale }) });
  if (!r.ok) { failed((await r.json()).error); return; }
  const url = URL.createObjectURL(await r.blob());
  const img = $("posed");
  img.src = url;
  await img.decode().catch(() => {});
  if (P.url) URL.revokeObjectURL(P.url);
  P.url = url;
  if (P.drag < 0 || !P.gl) show(false);  // a drag begun meanwhile keeps drawing
  updated(r);
}

async function request() {
  // one request in flight; a drag during it sends the newest targets when it returns
  if (P.busy) { P.queued = true; return; }
  if (!P.handles.length) return;
  P.busy = true;
  // a drag that folds faces can take a second or more (the solve repairs them): say so
  const slow = setTimeout(() => { $("pose-ms").textContent = "solving…"; }, 300);
  try {
    if ((P.drag >= 0 || P.playing) && glOk()) await drawVertices();
    else await picture();
  } catch (e) {
    failed(String(e.message || e));
  } finally {
    clearTimeout(slow);
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
  if (P.gl) await request();  // the last frame as the server pictures it
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
  if (P.on) {
    request();
    if (glOk()) P.gl.load().catch(() => {});  // ready before the first drag
  }
  renderHandles();
}

function start() {
  const [w, h] = window.inkray.size;
  const layer = $("pose-layer");
  layer.style.width = `${w}px`;
  layer.style.height = `${h}px`;
  $("posed").style.width = `${w}px`;   // a smaller picture while dragging shows at full size
  $("posed").style.height = `${h}px`;
  const canvas = $("posed-gl");
  canvas.width = w;
  canvas.height = h;
  canvas.style.width = `${w}px`;
  canvas.style.height = `${h}px`;
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
    show(false);
    renderHandles();
  });
}

// the drawing's size is known once the editor has loaded its info
(function wait() { if (window.inkray && window.inkray.size[0] > 1) start(); else setTimeout(wait, 50); })();
