"""Posing: drag latency, animation time and quality on the bundled drawings.

For each drawing, at its own size and upscaled to about 1 Mpx: the largest
part is pinned by two handles (its top and bottom visible pixels), the
largest part joined to it (a limb) gets a handle at its far end, swung by 40
degrees about where it joins. Measured in process: one drag update as the
editor runs it (the handles nudged by 2 px, each way in turn: 4 warm-started
rounds on the factorization of the last drag, more where faces fold, and a
repair where they stay folded; the deformation only, then the picture; the
median and the worst of the drags), a 24-frame animation (rest to the swing,
every frame solved and drawn), the ARAP energy, the worst handle error (px),
folded triangles, holes (transparent pixels enclosed by the posed silhouette
whose place in the drawing is opaque through every part within 2.5 px, the width
of the band the picture draws a part's layer in beyond its triangles: paper
that a pose encloses, a leg closing on the other, is paper in the drawing and
no hole; in brackets the same on the fresh pose, solved from rest before the
drags, which the warm-started one can hide), open tears (paper the pose reveals beyond a cut, where two parts hidden side
by side under a third met and neither goes on under the other: transparent pixels
whose nearest posed part is nearest there, enclosed or not; the figure at rest in
brackets, 0 when the measure is sound) and visibility agreement (pixels that two or more posed
parts draw, a surface there and their layer not transparent, whose drawn part
is the one highest in the relief).
Through HTTP, as the editor's Pose mode sees it: ``inkray edit`` serves the
same (rescaled) annotation (the first request, which builds the relief and
the rig, is not counted). While a handle moves the page asks for the posed
meshes' vertices (``POST /api/pose/vertices``, the HTTP drag) and draws the
parts' textured meshes itself with WebGL (the page drag: the request and the
drawing, in headless Chromium, whose WebGL is a software rasterizer on the
CPU); the meshes come once per document (``GET /api/pose/meshes``). Beside
them: the drag as a picture (``POST /api/pose`` at most a quarter megapixel,
what the page asks without WebGL 2) and the full picture where the handle
stops. Targets: drag <= 30 ms in process and <= 60 ms through HTTP at 1 Mpx,
handles within 0.5 px, 0 folds, 0 holes, visibility 100 %. Times are medians
of 9 drags. On a machine shared with other work wall times grow with its
load; beside them the CPU time of the picture and of the editor's server per
drag (its process's CPU time over the drags, the folding first nudges' rounds
and repairs included) stand for what they cost on an idle machine.

    python benchmarks/bench_pose.py [--names man,figure,turtle] [--no-upscale] [--no-http]
        [--no-page] [--order FRONT/BACK,...]

``--order tail/body`` adds an order entry (the region ``tail`` in front of ``body``,
at the middle of their common outline) to the annotation in process, to check a
drawing whichever way the depth order model decides a relation (the HTTP run keeps
the bundled annotation).

``--sweep`` prints instead, per drawing and size, the holes and folds along a
drag: the limb swung from rest to 60 degrees in steps of 2.5, each step solved
warm from the one before (as the Pose mode's drag and an animation's frames
are), with the worst step and the steps that have holes.

``--joins`` prints instead, for every bundled drawing, how the rig joins its
parts (:mod:`inkray.relief.posing`): parts, joins by kind, the connected
pieces a drag can move (1: the whole character hangs together), and the
opaque pieces of the picture (8-connected, specks under 20 px left out) at
rest and after a pose that turns the largest part by 30 degrees about the
middle of its two pins and swings its largest limb 30 degrees more about where
it joins (a part no join reaches stays behind and comes off). The join rules'
thresholds were set looking at man, figure, turtle, rings and gingerbread
(marked "tuned"); the others are held out.
"""

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_edit import _cpu, _folder, _request, _server  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _load(name, megapixels):
    from PIL import Image

    from inkray.input.loading import load_input

    ann_path = EXAMPLES / name / "drawing.inkray.json"
    drawing = None
    if megapixels:
        src = next(p for p in (EXAMPLES / name).iterdir()
                   if p.stem == "drawing" and p.suffix in (".png", ".jpg"))
        image = Image.open(src)
        scale = (megapixels * 1e6 / (image.width * image.height)) ** 0.5
        drawing = Path(tempfile.mkdtemp()) / f"up{src.suffix}"
        image.resize((round(image.width * scale), round(image.height * scale)),
                     Image.LANCZOS).save(drawing)
    return load_input(ann_path, drawing=drawing, rescale=drawing is not None)


def _forced(ann, drawing, orders):
    """``ann`` with an order entry per ``"front/back"`` pair of region names, its points a
    contact pixel of each region in the middle of their common outline (to check a
    drawing whichever way the depth order model decides a relation)."""
    from dataclasses import replace

    from inkray.chain import ReliefChain
    from inkray.input.annotations import Order

    if not orders:
        return ann
    seg = ReliefChain(ann, drawing).segmentation
    labels, names = seg.labels, list(seg.names)
    entries = list(ann.order)
    for pair in orders:
        front, back = (names.index(n) for n in pair.split("/"))
        ys, xs = np.nonzero((labels == front) & ndimage.binary_dilation(labels == back))
        if not len(xs):
            raise SystemExit(f"--order {pair}: the two regions do not touch")
        k = np.argmin(np.hypot(xs - np.median(xs), ys - np.median(ys)))
        x, y = xs[k], ys[k]
        y0, x0 = max(y - 1, 0), max(x - 1, 0)
        by, bx = np.nonzero(labels[y0:y + 2, x0:x + 2] == back)
        entries.append(Order(front=(float(x), float(y)),
                             back=(float(x0 + bx[0]), float(y0 + by[0])),
                             index=len(entries)))
    return replace(ann, order=entries)


def _scenario(chain, rig):
    labels = chain.completion.labels
    names = chain.completion.names
    area = np.bincount(labels[labels >= 0], minlength=len(names))
    body = int(np.argmax(area))
    ys, xs = np.nonzero(ndimage.binary_erosion(labels == body, iterations=3))
    pins = np.array([[xs[np.argmin(ys)], ys.min()], [xs[np.argmax(ys)], ys.max()]], float)
    limbs = [j for j in rig.joins if j.to == names[body]]
    if not limbs:
        return pins, None, None
    limb = max(limbs, key=lambda j: area[names.index(j.part)]).part
    li = rig.names.index(limb)
    glued = np.unique(rig.glue.tocoo().col)
    glued = glued[(glued >= rig.offsets[li]) & (glued < rig.offsets[li + 1])]
    join = rig.vertices[glued].mean(axis=0)
    ys, xs = np.nonzero(ndimage.binary_erosion(labels == names.index(limb), iterations=2))
    k = np.argmax(np.hypot(xs - join[0], ys - join[1]))
    return pins, np.array([xs[k], ys[k]], float), join


def _turn(p, about, degrees):
    a = np.radians(degrees)
    r = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return about + r @ (p - about)


def _home(rig, x, faces, points, shape, *, on_face=False, rigid=False):
    """Squared distance from each point to the posed ``faces`` (rig positions ``x``) and the
    pixel (row, column) it comes from at rest through the nearest face's affine map (with
    ``on_face``, the nearest point of the face's; with ``rigid``, that point's, plus the
    offset to it turned by the face's rotation: beyond its triangles the picture's band
    carries a part's layer rigidly, not stretched as a pinched face would stretch it)."""
    import igl

    flat = np.column_stack([x, np.zeros(len(x))])
    query = np.column_stack([points, np.zeros(len(points))])
    d2, face, near = igl.point_mesh_squared_distance(query, flat, faces)
    t, home = x[faces[face]], rig.vertices[faces[face]]
    # the face's posed -> rest affine map: A = H P^-1 on the edges from corner 0
    a = np.stack([home[:, 1] - home[:, 0], home[:, 2] - home[:, 0]], axis=2) @ np.linalg.inv(
        np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]], axis=2))
    near = near[:, :2]
    q = home[:, 0] + np.einsum("kij,kj->ki", a, (near if on_face or rigid else points) - t[:, 0])
    if rigid:  # the offset beyond the face turned by its rotation (A's polar part)
        u, _, vt = np.linalg.svd(a)
        q += np.einsum("kij,kj->ki", u @ vt, np.asarray(points, float) - near)
    h, w = shape
    return (d2, np.clip(np.rint(q[:, 1]).astype(int), 0, h - 1),
            np.clip(np.rint(q[:, 0]).astype(int), 0, w - 1))


def _holes(posed, x, img, rest, *, where=False):
    """Tears: transparent pixels enclosed by the posed silhouette whose place in the drawing
    is opaque.

    A pixel is taken back to the drawing by every part whose posed mesh comes within
    ``_REACH`` px of it (else by the nearest part), through that part's nearest triangle
    (its affine map; outside the triangle, the offset from it turned as the triangle
    turns, as the picture's band draws a layer there). If one of them takes it to paper,
    the pixel is paper the pose carried (a leg closing on the other, a notch between two
    parts closing): no hole.
    """
    solid = img[..., 3] > 0
    ys, xs = np.nonzero(ndimage.binary_fill_holes(solid, structure=np.ones((3, 3))) & ~solid)
    if not len(xs):
        return 0
    rig = posed.rig
    p = np.column_stack([xs, ys]).astype(float)
    dist, paper = [], []
    for i in range(len(rig.names)):
        faces = rig.faces[rig.part_of_face == i].astype(np.int64)
        if not len(faces):
            continue
        d2, row, col = _home(rig, x, faces, p, rest.shape[:2], rigid=True)
        dist.append(np.sqrt(d2))
        paper.append(rest[row, col, 3] == 0)
    dist, paper = np.array(dist), np.array(paper)
    near = (dist <= _REACH) | (dist == dist.min(axis=0))
    hole = ~np.any(near & paper, axis=0)
    if where:  # the holes' pixels (x, y), to look at
        return np.column_stack([xs[hole], ys[hole]])
    return int(hole.sum())


# px: the parts a hole pixel is taken back to the drawing by, as far as the picture draws a
# part's layer beyond its triangles (a part whose band there reaches only paper says paper)
_REACH = 2.5


def _tears(posed, x, img, completion, *, where=False):
    """Open tears: transparent pixels of the posed picture, enclosed or not, whose nearest part
    ends there in a cut, not in an outline.

    A part's completed area ends either at its outline (drawn, or continued under a part in
    front) or, under a part in front of it, where another part's hidden area takes over and
    neither goes on under the other: a *cut* (two parts hidden side by side under an arm).
    At rest the part in front covers every cut. Paper that a pose reveals beyond an outline
    is paper (an arm swung off the body); paper beyond a cut is a tear (one of the two
    hidden parts pulled away from the other). A transparent pixel within ``_TEAR_BAND`` of
    the posed silhouette is a tear where the nearest point of the nearest posed part is, at
    rest, within a pixel of a cut of that part: its hidden pixels outside another part's
    completed area beside that part's hidden area, farther than ``_TEAR_MARGIN`` px from
    paper at rest (where a cut meets the silhouette the layers' soft edges decide, as for
    holes). Pixels beside a cut but nearer another part's outline are not counted: the
    figure is the tear's side along the cut, a lower bound of its area.
    """
    labels = completion.labels
    names = list(completion.names)
    h, w = labels.shape
    solid = img[..., 3] > 0
    band = ~solid & (ndimage.distance_transform_edt(~solid) <= _TEAR_BAND * np.sqrt(h * w))
    ys, xs = np.nonzero(band)
    if not len(xs):
        return 0
    at_rest = ndimage.distance_transform_edt(
        posed.image(posed.rig.vertices)[..., 3] > 0) > _TEAR_MARGIN
    completed = [completion.completed(r) for r in range(len(names))]
    hidden = [c & (labels != r) for r, c in enumerate(completed)]
    rig = posed.rig
    points = np.column_stack([xs, ys]).astype(float)
    best = np.full(len(xs), np.inf)
    cut = np.zeros(len(xs), bool)
    for i, name in enumerate(rig.names):
        faces = rig.faces[rig.part_of_face == i].astype(np.int64)
        if not len(faces) or name not in names:
            continue
        region = names.index(name)
        edge = np.zeros((h, w), bool)
        for other in range(len(names)):
            if other != region:  # the two hidden areas meet and neither goes on under the other
                edge |= (completed[region] & ~completed[other] & (labels != region)
                         & ndimage.binary_dilation(hidden[other] & ~completed[region]))
        edge = ndimage.binary_dilation(edge & at_rest)
        d2, row, col = _home(rig, x, faces, points, (h, w), on_face=True)
        nearer = d2 < best
        best[nearer] = d2[nearer]
        cut[nearer] = edge[row, col][nearer]
    if where:  # the tears as a mask, to look at
        out = np.zeros((h, w), bool)
        out[ys[cut], xs[cut]] = True
        return out
    return int(cut.sum())


_TEAR_BAND = 0.05  # of sqrt(H W): how far from the posed silhouette a tear is looked for
_TEAR_MARGIN = 3.0  # px: cuts nearer the paper at rest are left to the layers' soft edges


def _visibility(posed, relief, part):
    """Share of the pixels two or more parts draw (a surface there and its layer not
    transparent) where the part drawn is the highest of them; heights from the relief's own
    rasterization, what each part draws from its picture alone. Pixels where a part draws
    the soft edge of its layer beyond its triangles are left out: the relief has no height
    for it there."""
    from inkray.relief.model import Relief
    from inkray.view.posed import posed_image
    from inkray.view.rasterization import rasterize

    rest = posed.rig.relief
    depth = np.stack([rasterize(Relief([p], size=relief.size)).depth for p in relief.parts])
    edge = np.zeros(part.shape, bool)
    for k, (p, r) in enumerate(zip(relief.parts, rest.parts)):
        alone = posed_image(Relief([p], size=relief.size), Relief([r], size=rest.size),
                            posed.cutout, posed.drawing.rgb)[0]
        edge |= (alone[..., 3] > 0) & ~np.isfinite(depth[k])
        depth[k][alone[..., 3] == 0] = -np.inf
    drawn = (np.isfinite(depth).sum(axis=0) >= 2) & ~edge
    if not drawn.any():
        return 1.0
    return float(np.mean(np.argmax(depth, axis=0)[drawn] == part[drawn]))


def _http_drags(name, megapixels, handles, targets, *, page=True):
    """A drag through ``inkray edit`` as the Pose mode runs it: the times (s) of a drag
    (``POST /api/pose/vertices``), of the same in Chromium (the request and the page's
    WebGL drawing of the posed meshes; NaN without Chromium), of a drag's picture without
    WebGL (``POST /api/pose`` at most a quarter megapixel) and of the full picture where a
    handle stops (medians), the server's CPU time per drag, and the one-off time of the
    meshes (``GET /api/pose/meshes``)."""
    import shutil

    ann, _ = _folder(name, megapixels)
    proc, address = _server(ann)
    try:
        def post(route, to, **more):
            body = json.dumps({"handles": handles.tolist(), "to": to.tolist(), **more}).encode()
            start = time.perf_counter()
            status, _, data = _request(address + route, "POST", body)
            if status != 200:
                raise RuntimeError(f"POST {route}: {status} {data[:200]!r}")
            return time.perf_counter() - start

        def nudged(k):
            return targets + [[0, 0], [0, 0], [2.0 * ((-1) ** k), 1.0]]

        post("/api/pose", targets)  # builds the relief and the rig
        _idle(proc.pid)  # the editor computes its other previews in the background at first
        start = time.perf_counter()
        status, _, data = _request(address + "/api/pose/meshes", "GET", None)
        meshes = time.perf_counter() - start
        if status != 200:
            raise RuntimeError(f"GET /api/pose/meshes: {status} {data[:200]!r}")
        before = _cpu(proc.pid)
        drags = [post("/api/pose/vertices", nudged(k)) for k in range(_DRAGS)]
        cpu = (_cpu(proc.pid) - before) / _DRAGS
        # as pose.js asks without WebGL while a handle moves: at most a quarter megapixel
        w, h = json.loads(ann.read_text())["size"]
        scale = min(1.0, (250_000 / (w * h)) ** 0.5)
        pictures = [post("/api/pose", nudged(k), scale=scale) for k in range(_DRAGS)]
        full = statistics.median(post("/api/pose", targets + [[0, 0], [0, 0], [k, 0]])
                                 for k in range(3))
        drawn = _page_drags(address, handles, [nudged(k) for k in range(_DRAGS)]) if page \
            else float("nan")
    finally:
        proc.terminate()
        proc.wait(30)
        shutil.rmtree(ann.parent, ignore_errors=True)
    return dict(http=statistics.median(drags), page=drawn, http_picture=statistics.median(pictures),
                http_full=full, http_cpu=cpu, meshes=meshes)


def _page_drags(address, handles, targets):
    """Median time (s) of a drag in the editor's page in Chromium (``INKRAY_CHROMIUM``, else
    /usr/bin/chromium): the posed vertices asked for and drawn by the page's WebGL, until
    the drawn pixels can be read; NaN without Chromium or Playwright. Headless Chromium
    draws with its software rasterizer (SwiftShader) on the CPU: a GPU draws faster."""
    import os

    chromium = os.environ.get("INKRAY_CHROMIUM", "/usr/bin/chromium")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return float("nan")
    if not Path(chromium).is_file():
        return float("nan")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        try:
            page = browser.new_page(viewport={"width": 1440, "height": 1000})
            page.goto(address + "/")
            page.wait_for_function("window.inkrayPose && window.inkray.size[0] > 1",
                                   timeout=120_000)
            page.click("#pose-mode")
            page.wait_for_function("window.inkrayPose.gl && window.inkrayPose.gl.generation >= 0",
                                   timeout=600_000)
            times = page.evaluate("""async ([handles, targets]) => {
                const gl = window.inkrayPose.gl, c = gl.renderer.getContext(), px = new Uint8Array(4);
                const times = [];
                for (const to of targets) {
                  const start = performance.now();
                  const r = await fetch("/api/pose/vertices", { method: "POST",
                    headers: { "Content-Type": "application/json" }, body: JSON.stringify({ handles, to }) });
                  gl.draw(new Float32Array(await r.arrayBuffer()));
                  c.readPixels(0, 0, 1, 1, c.RGBA, c.UNSIGNED_BYTE, px);  // the drawing done
                  times.push(performance.now() - start);
                }
                return times;
            }""", [handles.tolist(), [t.tolist() for t in targets]])
        finally:
            browser.close()
    return statistics.median(times) / 1000


_DRAGS = 9


def _idle(pid, timeout=120.0):
    """Wait until a process has used no CPU for half a second (or ``timeout`` s)."""
    end = time.monotonic() + timeout
    last = _cpu(pid)
    while time.monotonic() < end:
        time.sleep(0.5)
        now = _cpu(pid)
        if now - last < 0.01:
            return
        last = now


def one(name, megapixels, http=True, orders=(), page=True):
    from inkray.chain import ReliefChain
    from inkray.view.posed import PosedDrawing, posed_image

    ann, drawing = _load(name, megapixels)
    ann = _forced(ann, drawing, orders)
    chain = ReliefChain(ann, drawing)
    relief = chain.relief
    start = time.perf_counter()
    from inkray.relief.posing import rig_relief

    rig = rig_relief(relief, chain.completion, boundaries=ann.boundaries)
    pins, tip, join = _scenario(chain, rig)
    if tip is None:
        return None
    handles = np.vstack([pins, tip])
    posed = PosedDrawing(relief, chain.completion, chain.relations, drawing, handles,
                         boundaries=ann.boundaries)
    prepare = time.perf_counter() - start
    target = np.vstack([pins, _turn(tip, join, 40.0)])
    x, _ = posed.posing.pose(target, iterations=8)
    rest = posed.image(rig.vertices)
    fresh = _holes(posed, x, posed.image(x), rest)
    drags, pictures, cpu = [], [], []
    for k in range(_DRAGS):
        nudged = target + [[0, 0], [0, 0], [2.0 * ((-1) ** k), 1.0]]
        t0 = time.perf_counter()
        x = posed.positions(nudged)
        t1 = time.perf_counter()
        c1 = time.process_time()
        img = posed.image(x)
        cpu.append(time.process_time() - c1)
        t2 = time.perf_counter()
        drags.append(t1 - t0)
        pictures.append(t2 - t1)
    x, _ = posed.posing.pose(target, iterations=8)
    error = float(np.abs(posed.posing.solver.handles @ x - target).max())
    folds = rig.folds(x)
    energy = posed.posing.solver.energy(x)
    moved = posed.relief(x)
    img, part = posed_image(moved, relief, posed.cutout, drawing.rgb)
    holes = _holes(posed, x, img, rest)
    tears = _tears(posed, x, img, chain.completion)
    tears_rest = _tears(posed, posed.rig.vertices, rest, chain.completion)
    visibility = _visibility(posed, moved, part)
    t0 = time.perf_counter()
    posed.posing.solver.reset()
    for f in range(24):
        s = f / 23.0
        y = posed.positions(np.vstack([pins, _turn(tip, join, 40.0 * s)]))
        posed.image(y)
    animation = time.perf_counter() - t0
    w, h = ann.size
    nan = float("nan")
    web = _http_drags(name, megapixels, handles, target, page=page) if http else dict(
        http=nan, page=nan, http_picture=nan, http_full=nan, http_cpu=nan, meshes=nan)
    return dict(**web, picture_cpu=statistics.median(cpu),
                name=name, size=f"{w}x{h}", vertices=len(rig.vertices), prepare=prepare,
                drag=statistics.median(drags), worst=max(drags),
                picture=statistics.median(pictures),
                animation=animation, energy=energy, error=error, folds=folds, holes=holes,
                fresh=fresh,
                tears=tears, tears_rest=tears_rest,
                visibility=visibility)


TUNED = ("man", "figure", "turtle", "rings", "gingerbread")


def _turned_pieces(chain, ann, drawing, rig):
    """Opaque 8-connected pieces of the picture at rest and turned: the largest part's two
    pins turned by 30 degrees about their middle, its largest limb's tip by 30 more about
    where it joins (parts no join reaches stay behind)."""
    from inkray.view.posed import PosedDrawing

    pins, tip, join = _scenario(chain, rig)
    handles = pins if tip is None else np.vstack([pins, tip])
    centre = pins.mean(axis=0)
    targets = np.array([_turn(p, centre, 30.0) for p in pins])
    if tip is not None:
        targets = np.vstack([targets, _turn(_turn(tip, join, 30.0), centre, 30.0)])
    posed = PosedDrawing(chain.relief, chain.completion, chain.relations, drawing, handles,
                         boundaries=ann.boundaries)

    def count(rgba):
        found, n = ndimage.label(rgba[..., 3] > 0, structure=np.ones((3, 3)))
        return int((np.bincount(found.ravel())[1:] >= _SPECK).sum())

    x, _ = posed.posing.pose(targets, iterations=8)
    return count(posed.image(posed.rig.vertices)), count(posed.image(x))


_SPECK = 20  # px: smaller opaque pieces are specks of the drawing, not parts


def joins_table():
    from collections import Counter

    from inkray.chain import ReliefChain
    from inkray.numerics.arap import pieces
    from inkray.relief.posing import rig_relief

    print("| drawing | set | parts | joins (rooted / on top / overlap / seams) | rig pieces "
          "| picture pieces at rest | turned |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    names = sorted(p.name for p in EXAMPLES.iterdir() if (p / "drawing.inkray.json").is_file())
    for name in names:
        ann, drawing = _load(name, 0.0)
        chain = ReliefChain(ann, drawing)
        rig = rig_relief(chain.relief, chain.completion, boundaries=ann.boundaries)
        kinds = Counter(j.kind for j in rig.joins)
        piece = pieces(len(rig.vertices), rig.faces, rig.glue)
        rest, turned = _turned_pieces(chain, ann, drawing, rig)
        print(f"| {name} | {'tuned' if name in TUNED else 'held out'} | {len(rig.names)} | "
              f"{kinds['rooted']} / {kinds['on top']} / {kinds['overlap']} / "
              f"{kinds['stitch'] + kinds['graft']} | {len(np.unique(piece))} | {rest} | {turned} |",
              flush=True)


def sweep(name, megapixels, orders=()):
    """The holes and folded faces at every step of a drag from rest to a 60 degree swing.

    Returns ``(size, steps, holes, folds)``: the drawing's size, the angles (degrees) and per
    step the holes and the folded faces; ``steps`` is None where no limb is joined to the
    largest part.
    """
    from inkray.chain import ReliefChain
    from inkray.relief.posing import rig_relief
    from inkray.view.posed import PosedDrawing

    ann, drawing = _load(name, megapixels)
    ann = _forced(ann, drawing, orders)
    chain = ReliefChain(ann, drawing)
    rig = rig_relief(chain.relief, chain.completion, boundaries=ann.boundaries)
    pins, tip, join = _scenario(chain, rig)
    if tip is None:
        return ann.size, None, [], []
    posed = PosedDrawing(chain.relief, chain.completion, chain.relations, drawing,
                         np.vstack([pins, tip]), boundaries=ann.boundaries)
    rest = posed.image(posed.rig.vertices)
    steps = np.arange(0.0, 60.0 + 1e-9, 2.5)
    holes, folds = [], []
    for angle in steps:
        x = posed.positions(np.vstack([pins, _turn(tip, join, angle)]))
        holes.append(_holes(posed, x, posed.image(x), rest))
        folds.append(posed.rig.folds(x))
    return ann.size, steps, holes, folds


def sweep_table(names, sizes, orders):
    """Holes and folds at every step of a drag from rest to a 60 degree swing."""
    print("| drawing | size | steps | worst holes (at degrees) | steps with holes (degrees: px) "
          "| folds |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name in names:
        for mp in sizes:
            (w, h), steps, holes, folds = sweep(name, mp, orders)
            if steps is None:
                print(f"| {name} | | | no limb joined to the largest part | | |")
                continue
            worst = int(np.argmax(holes))
            bad = ", ".join(f"{a:g}: {n}" for a, n in zip(steps, holes) if n)
            print(f"| {name} | {w}x{h} | {len(steps)} | {holes[worst]} ({steps[worst]:g}) | "
                  f"{bad or '-'} | {sum(folds)} |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", default="man,figure,turtle")
    parser.add_argument("--no-upscale", action="store_true")
    parser.add_argument("--no-http", action="store_true", help="skip the editor's route")
    parser.add_argument("--no-page", action="store_true",
                        help="skip the drag in the editor's page in Chromium")
    parser.add_argument("--joins", action="store_true", help="the joins table of every drawing")
    parser.add_argument("--sweep", action="store_true",
                        help="holes at every step of a drag from rest to a 60 degree swing")
    parser.add_argument("--order", default="", metavar="FRONT/BACK,...",
                        help="add an order entry per pair of region names (in process only)")
    args = parser.parse_args()
    if args.joins:
        return joins_table()
    orders = [o for o in args.order.split(",") if o]
    sizes = [0.0] if args.no_upscale else [0.0, 1.0]
    if args.sweep:
        return sweep_table(args.names.split(","), sizes, orders)
    print("| drawing | size | vertices | prepare s | drag ms (vs 30) | worst drag ms | picture ms (CPU) | HTTP drag "
          "ms (vs 60) | HTTP drag CPU ms | page drag ms (software WebGL) | HTTP picture ms | HTTP full ms "
          "| meshes s "
          "| 24 frames s | ARAP energy | handle err px | folds | holes (fresh) | tears (at rest) "
          "| visibility |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- "
          "| --- | --- | --- | --- | --- | --- |")
    for name in args.names.split(","):
        for mp in sizes:
            r = one(name, mp, http=not args.no_http, orders=orders, page=not args.no_page)
            if r is None:
                print(f"| {name} | | | no limb joined to the largest part |" + " |" * 16)
                continue
            print(f"| {r['name']} | {r['size']} | {r['vertices']} | {r['prepare']:.2f} | "
                  f"{1000 * r['drag']:.1f} ({r['drag'] / 0.03:.2f}x) | {1000 * r['worst']:.0f} | "
                  f"{1000 * r['picture']:.0f} "
                  f"({1000 * r['picture_cpu']:.0f}) | {1000 * r['http']:.0f} ({r['http'] / 0.06:.2f}x) | "
                  f"{1000 * r['http_cpu']:.0f} | {1000 * r['page']:.0f} | "
                  f"{1000 * r['http_picture']:.0f} | {1000 * r['http_full']:.0f} | "
                  f"{r['meshes']:.2f} | "
                  f"{r['animation']:.1f} | {r['energy']:.2f} | {r['error']:.1e} | {r['folds']} | "
                  f"{r['holes']} ({r['fresh']}) | {r['tears']} ({r['tears_rest']}) | {100 * r['visibility']:.1f} % |", flush=True)


if __name__ == "__main__":
    main()
