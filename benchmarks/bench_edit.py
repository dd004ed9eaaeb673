"""Benchmark of ``inkray edit``: how soon each preview is ready on opening and after an edit.

Six tables (``--tables open,edits,methods,first,reduced,path``, default the first three):

- **open**: a fresh ``inkray edit`` server on the whole annotation, asked as the
  page asks on opening (the depth draft and then, unless the draft's answer is
  the full map (``X-Inkray-Quality: full``), the depth map, beside the
  labels, the relations and then the relief); each preview's time is from the
  page's first request to the end of that preview's answer. Targets at ~1 Mpx:
  the full depth map <= 2 s, the relief <= 3 s after it. Beside the wall
  times, the server's CPU seconds (user and system, all its threads, from
  ``/proc``) spent from the first request until the depth map's answer and
  until the relief's: on a shared machine the wall times stretch with the
  load, the CPU times much less.
- **edits**: how soon each preview is ready after an edit (below).
- **methods**: the fast depth method's cold solve against the exact method's:
  in process (``inkray.depth`` with the grid factorization's symbolic plans
  cleared first; the loading of the input not counted) and whole process
  (``python -m inkray depth ANN --method M``), each the median of
  ``--repeats`` runs (at least 3), fast and exact alternating; the ratio is
  the median of the pairwise fast / exact ratios (target: below 1 on every
  drawing).

- **first**: in process (no server), the CPU seconds of the fast depth map on
  the edits table's cold document, of :meth:`ReliefChain.prepare_depth` (what
  the editor does after the relief), and of the depth map after the +arrow
  and +scribble edits, once without and once with that preparation, with
  the fronts of the fill each edit refactored.

- **reduced**: in process, the fast depth map's cold fill (the chain's labels,
  the session's fixed pixels and levels) solved on the reduced system of
  quadtree blocks (:func:`inkray.numerics.quadtree_fill.quadtree_fill`, what a
  cold solve above 0.3 Mpx does) and exactly (:class:`HarmonicFill`'s grid
  Cholesky, its symbolic plan cleared first): CPU seconds of each (median of
  ``--repeats`` runs, at least 3, alternating), the reduced system's unknowns
  against the free pixels, and the largest and the mean absolute difference
  over the free pixels, in levels (one ``order`` step is 1).

- **path**: in process, the cold open as in ``open`` (an :class:`EditSession`
  asked from two threads as the page asks), with each request's thread's
  seconds on a CPU and waiting for one (``/proc/self/task/*/schedstat``).
  The full depth map waits for the labels' segmentation, then its draft
  (on opening the fill itself, and then the full map: no full request,
  its CPU 0), then its own request: the sum of those
  three requests' CPU seconds is what the depth map takes on a machine with
  a core free for it, whatever the load (``idle estimate``); the wall
  times beside it stretch with the load. ``--no-reserve`` runs it without
  the core the depth map keeps while it computes
  (:func:`inkray.numerics.threads.reserve_core`), as before it.

The edits table: for each bundled drawing a fresh
``inkray edit ... --no-browser --port 0`` server is started and driven as the
page drives it: ``PUT /api/annotations``, then ``GET`` depth.png?quality=draft
and depth.png beside labels.png followed by relief.glb (the server computes
the depth map and the relief under separate locks). Each preview's time is from the start of the PUT
to the end of that preview's answer. The edits, in order:

- cold: the annotation without its last order entry, last scribble of its most
  scribbled region and last boundary (every stage computed; the baseline);
- +arrow: that order entry added back;
- +scribble: that scribble added back;
- +boundary: that boundary added back (drawings without one skip it);
- undo: the annotation before the last of these edits again.

Targets at ~1 Mpx: depth (the draft, the page's first answer) <= 0.15 s after an arrow, labels <=
0.3 s after a scribble, relief <= 1.0 s after an arrow, every preview <= 0.05 s
after undo. ``/ cold`` is each time against the cold time of the same preview.

With ``--repeats N`` each drawing is run on N fresh servers and every cell is
the median of the N times. ``--pause S`` waits S seconds after each edit's
previews before the next edit, as a user looks at them (the editor uses that
time to ready the depth map's factorization for the next edit).

Every table runs at the drawings' own size and upscaled to about ``--mpx``
megapixels (``--mpx 1.15`` for the size of the drawing the editor was found
slow on).

Usage::

    python benchmarks/bench_edit.py [--names turtle,frog] [--mpx 1.0] [--own-size-only | --upscaled-only]
        [--repeats 3] [--tables open,edits,methods,first,reduced,path] [--pause 0]
        [--where "in process,process"] [--no-reserve]
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
DRAFT = "depth.png?quality=draft"
PREVIEWS = ("labels.png", DRAFT, "depth.png", "relief.glb")
TARGETS = {("+arrow", DRAFT): 0.15, ("+scribble", "labels.png"): 0.3,
           ("+arrow", "relief.glb"): 1.0, ("undo", "labels.png"): 0.05,
           ("undo", DRAFT): 0.05, ("undo", "depth.png"): 0.05, ("undo", "relief.glb"): 0.05}


def _drawings():
    return sorted(p.name for p in EXAMPLES.iterdir() if (p / "drawing.inkray.json").is_file())


def _folder(name, megapixels):
    """A temporary copy of a drawing and its annotation, upscaled to ``megapixels`` (0: as is)."""
    from PIL import Image

    src = EXAMPLES / name
    doc = json.loads((src / "drawing.inkray.json").read_text())
    image_path = src / doc["drawing"]
    folder = Path(tempfile.mkdtemp(prefix=f"bench-edit-{name}-"))
    if megapixels:
        image = Image.open(image_path)
        scale = (megapixels * 1e6 / (image.width * image.height)) ** 0.5
        size = (round(image.width * scale), round(image.height * scale))
        target = folder / f"drawing{image_path.suffix if image_path.suffix != '.svg' else '.png'}"
        image.convert("RGB").resize(size, Image.LANCZOS).save(target)
        doc = _rescaled(doc, size)
        doc["drawing"] = target.name
    else:
        shutil.copy(image_path, folder / image_path.name)
    ann = folder / "drawing.inkray.json"
    ann.write_text(json.dumps(doc))
    return ann, doc


def _rescaled(doc, size):
    """Every point mapped pixel centre to pixel centre: ``p' = (p + 0.5) * new / old - 0.5``."""
    old = doc["size"]

    def point(p):
        return [min(max((p[k] + 0.5) * size[k] / old[k] - 0.5, 0.0), size[k] - 1.0) for k in (0, 1)]

    out = json.loads(json.dumps(doc))
    out["size"] = list(size)
    for r in out.get("regions", []):
        r["scribbles"] = [[point(p) for p in s] for s in r["scribbles"]]
    out["background"] = [[point(p) for p in s] for s in out.get("background", [])]
    for o in out.get("order", []):
        o["front"], o["back"] = point(o["front"]), point(o["back"])
    for e in out.get("equal", []):
        e["a"], e["b"] = point(e["a"]), point(e["b"])
    for b in out.get("boundaries", []):
        b["path"] = [point(p) for p in b["path"]]
    return out


def _edits(doc):
    """(label, document) in the order they are sent."""
    full = json.loads(json.dumps(doc))
    base = json.loads(json.dumps(doc))
    base["order"] = base.get("order", [])[:-1]
    most = max(range(len(base["regions"])), key=lambda i: len(base["regions"][i]["scribbles"]))
    scribbled = len(base["regions"][most]["scribbles"]) > 1
    if scribbled:
        base["regions"][most]["scribbles"] = base["regions"][most]["scribbles"][:-1]
    base["boundaries"] = base.get("boundaries", [])[:-1]
    arrow = dict(json.loads(json.dumps(base)), order=full.get("order", []))
    scribble = json.loads(json.dumps(arrow))
    scribble["regions"] = full["regions"]
    edits = [("cold", base)]
    if doc.get("order"):
        edits.append(("+arrow", arrow))
    if scribbled:
        edits.append(("+scribble", scribble))
    if doc.get("boundaries"):
        edits.append(("+boundary", full))
    edits.append(("undo", edits[-2][1] if len(edits) > 1 else base))
    return edits


def _request(url, method="GET", body=None):
    req = urllib.request.Request(url, data=body, method=method)
    try:
        with urllib.request.urlopen(req, timeout=600) as r:
            return r.status, r.headers, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()


def _server(ann):
    """A fresh ``inkray edit`` server on ``ann``: the process and its address."""
    code = "import sys; from inkray.cli import main; sys.exit(main())"
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONHASHSEED="0")
    # in ROOT, whose inkray the server imports (python -c puts the working folder first)
    proc = subprocess.Popen([sys.executable, "-c", code, "edit", str(ann), "--no-browser",
                             "--port", "0"], stdout=subprocess.PIPE, text=True, env=env,
                            cwd=str(ROOT))
    try:
        return proc, proc.stdout.readline().strip().rsplit(" ", 1)[1].rstrip("/")
    except IndexError:
        proc.terminate()
        proc.wait(30)
        raise


def _cpu(pid):
    """CPU seconds (user and system, all threads) of process ``pid`` so far; NaN where
    ``/proc`` is missing."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return float("nan")
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _own_cpu():
    """CPU seconds (user and system) of this process so far."""
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _full_draft(preview, headers, previews):
    """Whether the depth draft's answer was the full map, so that the page asks no more
    (the full request's time is then the draft's)."""
    return preview == DRAFT and "depth.png" in previews and \
        headers.get("X-Inkray-Quality") == "full"


def _open(name, megapixels):
    """The cold open: the page's first requests to a fresh server, timed from the first."""
    ann, doc = _folder(name, megapixels)
    proc, url = _server(ann)
    row = {"edit": "open"}
    try:
        start = time.perf_counter()
        cpu = _cpu(proc.pid)

        def fetch(previews):
            for preview in previews:
                path = preview if preview == "relations" else f"preview/{preview}"
                status, headers, body = _request(f"{url}/api/{path}")
                row[preview] = (time.perf_counter() - start if status == 200 else
                                json.loads(body).get("error", str(status)),
                                float(headers.get("X-Inkray-Compute-Ms", "nan")))
                row[f"cpu {preview}"] = (_cpu(proc.pid) - cpu, 0.0)
                if _full_draft(preview, headers, previews):
                    row["depth.png"], row["cpu depth.png"] = row[DRAFT], row[f"cpu {DRAFT}"]
                    break

        beside = threading.Thread(target=fetch, args=([DRAFT, "depth.png"],))
        beside.start()
        fetch(["labels.png", "relations", "relief.glb"])
        beside.join()
    finally:
        proc.terminate()
        proc.wait(30)
        shutil.rmtree(ann.parent, ignore_errors=True)
    return {"name": name, "size": doc["size"], "rows": [row]}


def _one(name, megapixels, pause=0.0):
    ann, doc = _folder(name, megapixels)
    proc, url = _server(ann)
    rows = []
    try:
        for k, (label, edit) in enumerate(_edits(doc)):
            if k:
                time.sleep(pause)
            start = time.perf_counter()
            status, _, body = _request(url + "/api/annotations", "PUT", json.dumps(edit).encode())
            if status != 200:
                raise RuntimeError(f"PUT {label}: {status} {body[:200]!r}")
            row = {"edit": label}

            def fetch(previews):
                for preview in previews:
                    status, headers, body = _request(f"{url}/api/preview/{preview}")
                    row[preview] = (time.perf_counter() - start if status == 200 else
                                    json.loads(body).get("error", str(status)),
                                    float(headers.get("X-Inkray-Compute-Ms", "nan")))
                    if _full_draft(preview, headers, previews):
                        row["depth.png"] = row[DRAFT]
                        break

            # as the page asks: the depth draft and then the depth map beside the
            # labels, then the relief
            beside = threading.Thread(target=fetch, args=([DRAFT, "depth.png"],))
            beside.start()
            fetch(["labels.png", "relief.glb"])
            beside.join()
            rows.append(row)
    finally:
        proc.terminate()
        proc.wait(30)
        shutil.rmtree(ann.parent, ignore_errors=True)
    return {"name": name, "size": doc["size"], "rows": rows}


def _median(runs, previews=PREVIEWS):
    """One run whose times are the medians over ``runs`` (an error where any run failed)."""
    out = runs[0]
    for k, row in enumerate(out["rows"]):
        for preview in previews:
            cells = [r["rows"][k][preview] for r in runs]
            errors = [c for c in cells if isinstance(c[0], str)]
            row[preview] = errors[0] if errors else (
                float(np.median([c[0] for c in cells])), float(np.median([c[1] for c in cells])))
    return out


def _methods(name, megapixels, repeats, where=("in process", "process")):
    """Cold seconds of the fast and the exact method, in process and whole process
    (those of ``where``): ``{(where, method): [seconds, ...]}``, the runs alternating
    fast and exact."""
    import inkray
    import inkray.segmentation  # noqa: F401 - imported before the first timed run
    from inkray.numerics import grid_cholesky

    ann_path, _ = _folder(name, megapixels)
    times = {}
    try:
        ann, drawing = inkray.load_input(ann_path)
        out = ann_path.parent / "depth.png"
        env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONHASHSEED="0")
        for _ in range(repeats):
            for method in ("fast", "exact"):
                if "in process" in where:
                    grid_cholesky._plan.cache_clear()
                    grid_cholesky._front.cache_clear()
                    start = time.perf_counter()
                    inkray.depth(ann, drawing, method=method)
                    times.setdefault(("in process", method), []).append(
                        time.perf_counter() - start)
                if "process" not in where:
                    continue
                start = time.perf_counter()
                subprocess.run([sys.executable, "-m", "inkray", "--quiet", "depth", str(ann_path),
                                "-o", str(out), "--method", method], check=True, env=env,
                               stdout=subprocess.DEVNULL, cwd=str(ROOT))
                times.setdefault(("process", method), []).append(time.perf_counter() - start)
                out.unlink()
                out.with_suffix(".json").unlink()
    finally:
        shutil.rmtree(ann_path.parent, ignore_errors=True)
    return times


def _cases(names, sizes):
    """Each drawing at each size, ``(name, megapixels)``, the sizes outermost."""
    return [(name, mpx) for mpx in sizes for name in names]


def _open_table(names, sizes, repeats, **_):
    previews = (DRAFT, "depth.png", "labels.png", "relations", "relief.glb")
    print("| drawing | size | depth draft s | depth s | labels s | relations s | relief s "
          "| relief - depth s | server CPU s by depth / relief | targets at ~1 Mpx |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, mpx in _cases(names, sizes):
        try:
            r = _median([_open(name, mpx) for _ in range(repeats)],
                        previews + ("cpu depth.png", "cpu relief.glb"))
        except (RuntimeError, OSError, IndexError) as e:
            print(f"| {name} | {'own' if not mpx else f'{mpx} Mpx'} | failed: {e} |")
            continue
        row = r["rows"][0]
        cells = [f"{row[p][0]:.3f}" if isinstance(row[p][0], float) else f"error: {row[p][0]}"
                 for p in previews]
        depth, relief = row["depth.png"][0], row["relief.glb"][0]
        after = relief - depth if isinstance(depth, float) and isinstance(relief, float) else None
        notes = []
        if mpx and after is not None:
            notes = [f"depth <= 2 {'ok' if depth <= 2 else 'MISSED'}",
                     f"relief - depth <= 3 {'ok' if after <= 3 else 'MISSED'}"]
        cpu = f"{row['cpu depth.png'][0]:.2f} / {row['cpu relief.glb'][0]:.2f}"
        print(f"| {name} | {r['size'][0]}x{r['size'][1]} | {' | '.join(cells)} | "
              f"{'-' if after is None else f'{after:.3f}'} | {cpu} | {', '.join(notes)} |",
              flush=True)


def _methods_table(names, sizes, repeats, where=("in process", "process"), **_):
    print("| drawing | size | " + " | ".join(
        f"fast s, {w} | exact s, {w} | ratio" for w in where) + " |")
    print("| --- | --- |" + " --- | --- | --- |" * len(where))
    for name, mpx in _cases(names, sizes):
        size = _folder_size(name, mpx)
        t = _methods(name, mpx, max(repeats, 3), where)
        cells = []
        for where_ in where:
            fast, exact = (float(np.median(t[(where_, m)])) for m in ("fast", "exact"))
            # the median of the pairwise ratios: pairs ran next to each other
            ratio = float(np.median(np.array(t[(where_, "fast")]) /
                                    np.array(t[(where_, "exact")])))
            cells += [f"{fast:.3f}", f"{exact:.3f}", f"**{ratio:.2f}**"]
        print(f"| {name} | {size} | {' | '.join(cells)} |", flush=True)


def _first(name, megapixels):
    """``{prepared: [(label, CPU s, refactored fronts, fronts)]}`` for the cold depth
    map, the preparation and the +arrow and +scribble edits, in process."""
    import inkray
    from inkray.chain import ChainOptions, ReliefChain
    from inkray.input.annotations import parse_annotations

    ann_path, doc = _folder(name, megapixels)
    ann, drawing = inkray.load_input(ann_path)
    edits = dict(_edits(doc))

    def annotations(d):
        a = parse_annotations(d)
        a.drawing, a.source = ann.drawing, ann.source
        return a

    cpu = _own_cpu
    out = {}
    try:
        for prepared in (False, True):
            chain = ReliefChain(annotations(edits["cold"]), drawing,
                                options=ChainOptions(interactive=True, depth_method="fast"))
            steps = [("cold", chain)]
            if prepared:
                steps.append(("prepare", chain))
            steps += [(label, None) for label in ("+arrow", "+scribble") if label in edits]
            rows = []
            for label, step in steps:
                if step is None:
                    chain = chain.edit(annotations=annotations(edits[label]))
                chain.segmentation  # the labels come first, as in the editor
                start = cpu()
                if label == "prepare":
                    chain.prepare_depth(background=False)
                else:
                    chain.depth_map
                session = chain._cache.session[1]
                fill = session._fills[False]
                rows.append((label, cpu() - start, fill.refactored_fronts, fill.fronts))
            out[prepared] = rows
            del chain, session, fill
    finally:
        shutil.rmtree(ann_path.parent, ignore_errors=True)
    return out


def _first_table(names, sizes, repeats, **_):
    print("| drawing | size | prepared | cold depth CPU s | prepare CPU s | +arrow depth CPU s "
          "(fronts) | +scribble depth CPU s (fronts) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, mpx in _cases(names, sizes):
        size = _folder_size(name, mpx)
        for prepared, rows in _first(name, mpx).items():
            cell = {label: (f"{t:.2f}" if label in ("cold", "prepare") else
                            f"{t:.2f} ({redone}/{fronts})")
                    for label, t, redone, fronts in rows}
            print(f"| {name} | {size} | {'yes' if prepared else 'no'} | "
                  + " | ".join(cell.get(k, "-") for k in ("cold", "prepare", "+arrow",
                                                          "+scribble")) + " |", flush=True)


def _reduced(name, megapixels, repeats):
    """CPU seconds of the cold fill, reduced and exact, ``{kind: [s, ...]}``, with the
    unknowns, the free pixels and the differences of the two fills."""
    import inkray
    from inkray.chain import ChainOptions, ReliefChain
    from inkray.numerics import grid_cholesky
    from inkray.numerics.harmonic_fill import HarmonicFill, settle
    from inkray.numerics.quadtree_fill import quadtree_blocks, quadtree_fill

    ann_path, _ = _folder(name, megapixels)
    try:
        ann, drawing = inkray.load_input(ann_path)
        chain = ReliefChain(ann, drawing, options=ChainOptions(interactive=True,
                                                               depth_method="fast"))
        chain.depth_map
        session = chain._cache.session[1]
        fixed, values = session._answer[0], np.zeros(session.shape)
        values[fixed] = session._answer[1]
        wx, wy = session._weights
    finally:
        shutil.rmtree(ann_path.parent, ignore_errors=True)

    cpu = _own_cpu
    times, out = {}, {}
    for _ in range(max(repeats, 3)):
        for kind in ("reduced", "exact"):
            grid_cholesky._plan.cache_clear()
            grid_cholesky._front.cache_clear()
            start = cpu()
            if kind == "reduced":
                settled, free = settle(fixed, values)
                out[kind] = quadtree_fill(wx, wy, ~free, settled)
            else:
                out[kind] = HarmonicFill(wx, wy, incremental=False).solve(fixed, values)
            times.setdefault(kind, []).append(cpu() - start)
    _, free = settle(fixed, values)
    _, _, s = quadtree_blocks(wx, wy, ~free)
    err = np.abs(out["reduced"] - out["exact"])[free]
    return times, {"free": int(free.sum()), "blocked": int((s ** 2).sum()),
                   "max": float(err.max(initial=0.0)), "mean": float(err.mean()) if err.size else 0.0}


def _reduced_table(names, sizes, repeats, **_):
    print("| drawing | size | free px | in blocks | reduced CPU s | exact CPU s | reduced / exact "
          "| max diff, levels | mean diff, levels |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, mpx in _cases(names, sizes):
        size = _folder_size(name, mpx)
        times, r = _reduced(name, mpx, repeats)
        reduced, exact = (float(np.median(times[k])) for k in ("reduced", "exact"))
        ratio = float(np.median(np.array(times["reduced"]) / np.array(times["exact"])))
        blocked = f"{r['blocked'] / r['free']:.0%}" if r["free"] else "-"
        print(f"| {name} | {size} | {r['free']} | {blocked} | {reduced:.2f} | {exact:.2f} | "
              f"**{ratio:.2f}** | {r['max']:.4f} | {r['mean']:.5f} |", flush=True)


def _sched():
    """This thread's seconds on a CPU and waiting for one so far (NaN without ``/proc``)."""
    try:
        on, waiting, _ = Path(f"/proc/self/task/{threading.get_native_id()}/schedstat") \
            .read_text().split()
    except (OSError, ValueError):
        return float("nan"), float("nan")
    return int(on) / 1e9, int(waiting) / 1e9


def _path(name, megapixels, reserve=True):
    """The cold open in process, driven as the page drives it: per request, when it
    ended (s from the first) and its thread's CPU and run-queue seconds in it."""
    import contextlib

    from inkray.editor import session as editing

    ann, _ = _folder(name, megapixels)
    kept = editing.reserve_core
    if not reserve:
        editing.reserve_core = contextlib.nullcontext
    row = {}
    try:
        session = editing.EditSession(ann)
        start = time.perf_counter()

        def fetch(requests):
            for key, ask in requests:
                before = _sched()
                try:
                    answer = ask()
                    ended = time.perf_counter() - start
                except Exception as e:  # noqa: BLE001 - reported in the table
                    answer, ended = None, f"{type(e).__name__}: {e}"
                after = _sched()
                row[key] = (ended, after[0] - before[0], after[1] - before[1])
                if key == "draft" and answer is not None and not answer.draft:
                    row["depth"] = (ended, 0.0, 0.0)  # the full map: the page asks no more
                    break

        beside = threading.Thread(target=fetch, args=([
            ("draft", lambda: session.preview("depth.png", draft=True)),
            ("depth", lambda: session.preview("depth.png"))],))
        beside.start()
        fetch([("labels", lambda: session.preview("labels.png")),
               ("relations", session.relations),
               ("relief", lambda: session.preview("relief.glb"))])
        beside.join()
        session.close()
    finally:
        editing.reserve_core = kept
        shutil.rmtree(ann.parent, ignore_errors=True)
    return row


def _path_table(names, sizes, repeats, reserve=True, **_):
    print("| drawing | size | labels CPU s | draft CPU s | depth CPU s | idle estimate s "
          "| depth s | depth run-queue s | relief s | relief - depth s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, mpx in _cases(names, sizes):
        size = _folder_size(name, mpx)
        runs = [_path(name, mpx, reserve) for _ in range(repeats)]
        failed = [r[k][0] for r in runs for k in r if isinstance(r[k][0], str)]
        if failed:
            print(f"| {name} | {size} | failed: {failed[0]} |", flush=True)
            continue

        def med(key, k):
            return float(np.median([r[key][k] for r in runs]))

        estimate = float(np.median([r["labels"][1] + r["draft"][1] + r["depth"][1]
                                    for r in runs]))
        after = float(np.median([r["relief"][0] - r["depth"][0] for r in runs]))
        print(f"| {name} | {size} | {med('labels', 1):.2f} | {med('draft', 1):.2f} | "
              f"{med('depth', 1):.2f} | **{estimate:.2f}** | {med('depth', 0):.2f} | "
              f"{med('draft', 2) + med('depth', 2):.2f} | {med('relief', 0):.2f} | "
              f"{after:.2f} |", flush=True)


def _folder_size(name, megapixels):
    ann, doc = _folder(name, megapixels)
    shutil.rmtree(ann.parent, ignore_errors=True)
    return f"{doc['size'][0]}x{doc['size'][1]}"


def _edits_table(names, sizes, repeats, pause=0.0, **_):
    print("| drawing | size | edit | labels s (/ cold) | depth draft s (/ cold) | depth s (/ cold) "
          "| relief s (/ cold) | targets at ~1 Mpx |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, mpx in _cases(names, sizes):
        try:
            r = _median([_one(name, mpx, pause) for _ in range(repeats)])
        except (RuntimeError, OSError, IndexError) as e:
            print(f"| {name} | {'own' if not mpx else f'{mpx} Mpx'} | failed: {e} |")
            continue
        cold = r["rows"][0]
        size = f"{r['size'][0]}x{r['size'][1]}"
        errors = []
        for row in r["rows"]:
            cells, notes = [], []
            for preview in PREVIEWS:
                s, _ = row[preview]
                c, _ = cold[preview]
                if isinstance(s, str):
                    if s not in errors:
                        errors.append(s)
                    cells.append(f"error {errors.index(s) + 1}")
                    continue
                ratio = f" ({s / c:.0%})" if row is not cold and isinstance(c, float) else ""
                cells.append(f"{s:.3f}{ratio}")
                target = TARGETS.get((row["edit"], preview))
                if target is not None and mpx:
                    what = "depth draft" if preview == DRAFT else preview.split(".")[0]
                    notes.append(f"{what} <= {target:g} "
                                 f"{'ok' if s <= target else 'MISSED'}")
            print(f"| {name} | {size} | {row['edit']} | {' | '.join(cells)} | "
                  f"{', '.join(notes)} |", flush=True)
        for k, error in enumerate(errors):
            print(f"| {name} | {size} | error {k + 1}: {error} |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated bundled drawings (default: all)")
    parser.add_argument("--mpx", type=float, default=1.0, help="upscale to this many Mpx (default 1)")
    parser.add_argument("--own-size-only", action="store_true", help="skip the upscaled run")
    parser.add_argument("--upscaled-only", action="store_true", help="skip the own-size run")
    parser.add_argument("--repeats", type=int, default=1,
                        help="fresh servers (and method runs, at least 3) per drawing; each cell "
                             "is the median (default 1)")
    parser.add_argument("--tables", default="open,edits,methods",
                        help="which tables, comma-separated (default open,edits,methods)")
    parser.add_argument("--pause", type=float, default=0.0,
                        help="seconds between an edit's previews and the next edit (default 0)")
    parser.add_argument("--no-reserve", action="store_true",
                        help="the path table without the core the depth map keeps")
    parser.add_argument("--where", default="in process,process",
                        help="the methods table's runs, comma-separated (default "
                             "'in process,process')")
    args = parser.parse_args()
    where = tuple(args.where.split(","))
    if not where or set(where) - {"in process", "process"}:
        parser.error(f"--where: expected 'in process' and/or 'process', got {args.where!r}")
    names = args.names.split(",") if args.names else _drawings()
    sizes = ([] if args.upscaled_only else [0.0]) + ([] if args.own_size_only else [args.mpx])
    repeats = max(args.repeats, 1)
    tables = {"open": _open_table, "edits": _edits_table, "methods": _methods_table,
              "first": _first_table, "reduced": _reduced_table, "path": _path_table}
    for k, table in enumerate(args.tables.split(",")):
        if table not in tables:
            parser.error(f"--tables: unknown table {table!r} (expected {', '.join(tables)})")
        if k:
            print()
        tables[table](names, sizes, repeats, pause=args.pause, where=where,
                      reserve=not args.no_reserve)


if __name__ == "__main__":
    main()
