"""The long fuzz run of the input edge, in separate processes.

Hostile annotation files (through ``validate`` and ``relief``), drawings
(``validate``), meshes (``check`` and ``render``) and kills at random moments
of a relief (SIGTERM, SIGHUP, SIGKILL), also deep inside the finest meshing of
a big drawing, where a signal must end the command within its watchdog's
grace (2 s; longer counts as a hang). Each run is a fresh ``inkray``
process with a time limit; the table counts exit codes, internal errors,
hangs, messages that are not one line, files left behind and the largest
peak memory. The generators are in ``tests/_hostile.py`` (the test suite
runs a small sample of them in-process).

Then the limits: annotation files whose strings, escapes, lists, objects or
keys inflate memory (through ``validate``; the bound on peak memory is 12
times the file's size plus 700 MiB, see docs/errors.md), outputs aimed at every
kind of input of every command and of ``batch`` (an input whose bytes change
counts as overwritten), the documented extreme values of every option
(within the range: they must finish in time; outside: refused with exit 2),
and chunked request bodies to the editor server (peak memory of the server).

Usage::

    python benchmarks/fuzz.py [--annotations 1000] [--images 100] [--meshes 100]
                              [--reliefs 20] [--kills 20] [--deep-kills 4] [--seed 0]
                              [--timeout 60]
                              [--no-limits]
"""

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from _hostile import hostile_annotation, hostile_image, hostile_mesh  # noqa: E402


def _run(argv, timeout, cwd):
    """(exit code or 'hang', stderr, peak RSS in MiB) of one inkray process."""
    proc = subprocess.Popen([sys.executable, "-m", "inkray", "--quiet", *argv], cwd=cwd,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + timeout
    # The child's own high-water mark, read while it runs: wait4's ru_maxrss keeps
    # the parent's size at fork when the child stays smaller.
    peak = 0.0
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            err = proc.stderr.read()
            code = os.waitstatus_to_exitcode(status)
            return code, err, peak or usage.ru_maxrss / 1024
        peak = max(peak, _peak_rss(proc.pid))
        if time.monotonic() > deadline:
            proc.kill()
            _, _, usage = os.wait4(proc.pid, 0)
            return "hang", proc.stderr.read(), peak or usage.ru_maxrss / 1024
        time.sleep(0.01)


class Tally:
    def __init__(self, name):
        self.name, self.codes, self.bad, self.peak = name, Counter(), [], 0.0

    def add(self, argv, result, leftovers=()):
        code, err, peak = result
        self.codes[code] += 1
        self.peak = max(self.peak, peak)
        problems = []
        if code == "hang":
            problems.append("hang")
        elif code not in (0, 2):
            problems.append(f"exit {code}")
        if "internal error" in err or "Traceback" in err:
            problems.append("internal error")
        if code == 2 and not (err.startswith("inkray: error: ") and err.count("\n") == 1):
            problems.append("not one line")
        if leftovers:
            problems.append(f"left {len(leftovers)} files")
        if problems:
            self.bad.append((argv, problems, err.strip()[-300:]))

    def row(self):
        n = sum(self.codes.values())
        count = Counter(p for _, ps, _ in self.bad for p in ps)
        return (f"| {self.name} | {n} | {self.codes.get(0, 0)} | {self.codes.get(2, 0)} | "
                f"{count['internal error']} | {count['hang']} | "
                f"{sum(v for k, v in count.items() if k.startswith('exit'))} | "
                f"{count['not one line']} | {sum(1 for _, ps, _ in self.bad if any(p.startswith('left') for p in ps))} | "
                f"{self.peak:.0f} |")


_MIB = 1 << 20


def _inflating(work, base):
    """Annotation files just under the 64 MiB limit (and a 10 MB one) that inflate memory.

    Written a piece at a time, so that this process stays small.
    """
    doc = json.loads(base.read_text())
    head = json.dumps(doc)[:-1] + ', "_note": '
    size = 63 * _MIB
    pieces = {  # (opening, repeated piece, count, closing)
        "string-10MB": ('"', "a" * 1000, 10_000, '"'),
        "string-63MiB": ('"', "a" * 1024, size // 1024, '"'),
        "astral-63MiB": ('"\U0001F600', "a" * 1024, size // 1024 - 1, '"'),
        "escapes-63MiB": ('"', "\\\\" * 512, size // 1024, '"'),
        "quotes-63MiB": ('"', '\\"' * 512, size // 1024, '"'),
        "objects-63MiB": ("[{}", ",{}" * 341, size // 1023, "]"),
        "floats-63MiB": ("[1.5", ",1.5" * 256, size // 1024, "]"),
        "keys-3M": ('{"k":0', "".join(f',"{i}":0' for i in range(1000)), 3000, "}"),
        "unterminated-63MiB": ('"', "a" * 1024, size // 1024, ""),
    }
    for name, (first, piece, count, last) in pieces.items():
        path = work / f"inflate-{name}.inkray.json"
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(head + first)
            for k in range(count):
                # keys must differ: a running prefix per thousand
                fh.write(piece.replace(',"', f',"{k}_') if name == "keys-3M" else piece)
            fh.write(last + "}")
        yield name, path


def _inputs_unchanged(paths, before):
    return [p.name for p in paths if p.read_bytes() != before[p]]


def _onto_inputs(work, base, timeout):
    """Every command with an output aimed at one of its inputs: exit 2, no input changed."""
    t = Tally("outputs onto inputs")
    over = 0
    case = work / "onto"
    case.mkdir()
    for f in (work / "drawing.png", base):
        shutil.copy(f, case / f.name)
    ann, drawing = case / base.name, case / "drawing.png"
    layer = case / "layer.png"
    from PIL import Image
    Image.new("RGBA", (512, 512)).save(layer)
    (case / "legend.json").write_text("{}")
    _run(["relief", ann.name, "-o", "scene.obj"], 300, case)
    scene = [case / "scene.obj", case / "scene.mtl", case / "scene_drawing.png"]
    runs = [["segment", ann.name, "-o", "drawing.png"], ["depth", ann.name, "-o", "drawing.png"],
            ["depth", ann.name, "-o", "d.png", "--normals", "drawing.png"],
            ["segment", ann.name, "-o", "s.png", "--scribbles", "layer.png", "--legend",
             "legend.json", "--npy", "legend.json"],
            ["relief", ann.name, "-o", "r.glb", "--depth-png", "drawing.png"],
            ["relief", ann.name, "-o", "r2.glb", "--scribbles", "layer.png",
             "--normals-png", "layer.png"],
            ["regions", ann.name, "-o", base.name],
            ["layers", ann.name, "-o", "p.psd", "--scribbles", "layer.png"],
            ["render", "scene.obj", "-o", "scene_drawing.png"],
            ["render", "scene.obj", "-o", "scene.png", "--mode", "stereo"],
            ["check", "scene.obj", "-o", "scene.mtl"]]
    # maps into a folder whose normal.png is the drawing; batch over its own report
    maps = case / "m"
    maps.mkdir()
    shutil.copy(drawing, maps / "normal.png")
    mdoc = json.loads(ann.read_text())
    mdoc["drawing"] = "m/normal.png"
    (case / "mm.inkray.json").write_text(json.dumps(mdoc))
    runs.append(["maps", "mm.inkray.json", "-o", "m"])
    frame = case / "batch"
    (frame / "f").mkdir(parents=True)
    shutil.copy(drawing, frame / "f" / "shaded.png")
    bdoc = dict(mdoc, drawing="f/shaded.png")
    (frame / "f.inkray.json").write_text(json.dumps(bdoc))
    (frame / "batch-report.json").write_text(json.dumps(bdoc))
    runs += [["batch", "batch/*.inkray.json", "-o", "batch", "--jobs", "relief,render"],
             ["batch", "batch/batch-report.json", "-o", "batch"]]
    for argv in runs:
        files = [p for p in case.rglob("*") if p.is_file()]
        before = {p: p.read_bytes() for p in files}
        res = _run(argv, timeout, case)
        changed = _inputs_unchanged(files, before)
        if changed:
            over += 1
        t.add(argv, ("overwrote " + ",".join(changed) if changed else res[0], res[1], res[2]))
    return t, over


def _extremes(work, base, timeout):
    """The documented extreme values of every option: in range finishes, out of range exit 2."""
    t = Tally("option extremes")
    a = base.name
    glb = "ext.glb"
    _run(["relief", a, "-o", glb], 300, work)
    inside = [["relief", a, "-o", "x.glb", "--max-area", "1e8"],
              ["relief", a, "-o", "x.glb", "--epsilon", "1e5"],
              ["relief", a, "-o", "x.glb", "--epsilon", "1e-6"],
              ["relief", a, "-o", "x.glb", "--units-per-pixel", "1e-9"],
              ["relief", a, "-o", "x.glb", "--units-per-pixel", "1e6"],
              ["relief", a, "-o", "x.glb", "--depth-scale", "0.001"],
              ["relief", a, "-o", "x.glb", "--depth-scale", "10"],
              ["depth", a, "-o", "x.png", "--epsilon", "1e5"],
              ["depth", a, "-o", "x.png", "--epsilon", "1e-9"],
              ["maps", a, "-o", "xm", "--ao-radius", "1e6"],
              ["maps", a, "-o", "xm", "--ao-radius", "1"],
              ["layers", a, "-o", "x.psd", "--pad", "1000000000"],
              ["render", glb, "-o", "x.gif", "--turntable", "360", "--size", "16x16"],
              ["render", glb, "-o", "x.png", "--turntable", "3", "--angle", "60"],
              ["render", glb, "-o", "x.png", "--size", "16384x1"],
              ["render", glb, "-o", "x.png", "--mode", "gi", "--size", "4x4", "--spp", "65536"],
              ["render", glb, "-o", "x.png", "--light", "1e300", "0", "0"],
              ["render", glb, "-o", "x.png", "--mode", "stereo", "--disparity", "512"],
              ["validate", a, "--max-pixels", "1", "--max-points", "1"]]
    outside = [["relief", a, "-o", "x.glb", "--max-area", "1e9"],
               ["relief", a, "-o", "x.glb", "--epsilon", "inf"],
               ["relief", a, "-o", "x.glb", "--depth-scale", "nan"],
               ["depth", a, "-o", "x.png", "--epsilon", "1e6"],
               ["maps", a, "-o", "xm", "--ao-radius", "1e9"],
               ["maps", a, "-o", "xm", "--ao-radius", "inf"],
               ["layers", a, "-o", "x.psd", "--pad", "-1"],
               ["render", glb, "-o", "x.gif", "--turntable", "100000"],
               ["render", glb, "-o", "x.png", "--turntable", "300", "--size", "4000x4000"],
               ["render", glb, "-o", "x.png", "--size", "16384x16384"],
               ["render", glb, "-o", "x.png", "--angle", "inf", "--turntable", "2"],
               ["render", glb, "-o", "x.png", "--mode", "gi", "--spp", "65537"],
               ["render", glb, "-o", "x.png", "--ambient", "inf"],
               ["render", glb, "-o", "x.png", "--light", "0", "0", "0"],
               ["validate", a, "--max-pixels", "0"],
               ["batch", a, "-o", "xb", "--workers", "100000"],
               ["batch", a, "-o", "xb", "--jobs", ""]]
    for argv in inside:
        t.add(argv, _run(argv, timeout, work))
    for argv in outside:
        code, err, peak = _run(argv, timeout, work)
        t.add(argv, (code if code == 2 else f"accepted ({code})", err, peak))
    return t


def _editor_bodies(work, base, timeout):
    """Chunked and oversized PUTs to the editor server: its peak memory, and its answers."""
    import http.client
    import re

    t = Tally("editor: chunked bodies")
    proc = subprocess.Popen([sys.executable, "-m", "inkray", "edit", base.name, "--no-browser",
                             "--port", "0"], cwd=work, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        port = None
        deadline = time.monotonic() + 120
        while port is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            m = re.search(r"127\.0\.0\.1:(\d+)", line)
            port = int(m.group(1)) if m else None
        if port is None:
            t.add(["edit"], ("hang", "no address printed", 0.0))
            return t
        for name, mib in (("chunked 100 MiB", 100), ("chunked 1000 MiB", 1000)):
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
            status, err = None, ""
            try:
                conn.putrequest("PUT", "/api/annotations")
                conn.putheader("Transfer-Encoding", "chunked")
                conn.putheader("Content-Type", "application/json")
                conn.endheaders()
                chunk = b"[" + b"1," * (_MIB // 2 - 1) + b"1"
                for _ in range(mib):
                    conn.send(b"%x\r\n%s\r\n" % (len(chunk), chunk))
                conn.send(b"0\r\n\r\n")
                status = conn.getresponse().status
            except (OSError, http.client.HTTPException) as e:
                err = f"{type(e).__name__}: {e}"  # the server may close early: fine
            finally:
                conn.close()
            peak = _peak_rss(proc.pid)
            bad = status is not None and status >= 500
            t.add([name], ("server error" if bad else 0, err if bad else "", peak))
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    return t


def _peak_rss(pid):
    try:
        with open(f"/proc/{pid}/status") as fh:
            return next(int(line.split()[1]) / 1024 for line in fh if line.startswith("VmHWM"))
    except (OSError, StopIteration):
        return 0.0


def _leftovers(folder, before):
    return sorted(set(p.name for p in folder.iterdir()) - before)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--annotations", type=int, default=1000)
    parser.add_argument("--images", type=int, default=100)
    parser.add_argument("--meshes", type=int, default=100)
    parser.add_argument("--reliefs", type=int, default=20,
                        help="hostile annotation files also run through relief")
    parser.add_argument("--kills", type=int, default=20)
    parser.add_argument("--deep-kills", type=int, default=4,
                        help="SIGTERM/SIGHUP 5-40 s into the frog's relief at the finest "
                             "--max-area")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=60.0)
    parser.add_argument("--no-limits", dest="limits", action="store_false",
                        help="skip the limits: inflating files, outputs onto inputs, option "
                             "extremes, chunked bodies to the editor")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    work = Path(tempfile.mkdtemp(prefix="inkray-fuzz-"))
    try:
        example = ROOT / "examples" / "turtle"
        for f in example.iterdir():
            shutil.copy(f, work / f.name)
        base = work / "drawing.inkray.json"
        tallies = []

        t = Tally("annotations: validate")
        r = Tally("annotations: relief")
        for i in range(args.annotations):
            path = hostile_annotation(rng, work, base, i)
            t.add(["validate", path.name], _run(["validate", path.name], args.timeout, work))
            if i < args.reliefs:
                before = set(p.name for p in work.iterdir())
                res = _run(["relief", path.name, "-o", "out.glb"], args.timeout, work)
                left = [n for n in _leftovers(work, before) if res[0] != 0]
                r.add(["relief", path.name], res, left)
                (work / "out.glb").unlink(missing_ok=True)
        tallies += [t, r]

        t = Tally("drawings: validate")
        for i in range(args.images):
            path = hostile_image(rng, work, work / "drawing.png", i)
            t.add(["validate", "--drawing", path.name],
                  _run(["validate", base.name, "--drawing", path.name], args.timeout, work))
        tallies.append(t)

        meshes = work / "meshes"
        meshes.mkdir()
        bases = []
        for suffix in (".glb", ".obj", ".ply"):
            code, err, _ = _run(["relief", base.name, "-o", f"meshes/base{suffix}"], 300, work)
            assert code == 0, err
            bases.append(meshes / f"base{suffix}")
        c, rd = Tally("meshes: check"), Tally("meshes: render")
        for i in range(args.meshes):
            path = hostile_mesh(rng, meshes, bases, i)
            c.add(["check", path.name], _run(["check", str(path)], args.timeout, work))
            before = set(p.name for p in meshes.iterdir())
            res = _run(["render", str(path), "-o", f"meshes/o{i}.png"], args.timeout, work)
            left = [n for n in _leftovers(meshes, before) if res[0] != 0]
            rd.add(["render", path.name], res, left)
        tallies += [c, rd]

        k = Tally("kills during relief")
        out = work / "killed"
        out.mkdir()
        for i in range(args.kills):
            sig = [signal.SIGTERM, signal.SIGHUP, signal.SIGKILL][i % 3]
            proc = subprocess.Popen([sys.executable, "-m", "inkray", "--quiet", "relief",
                                     base.name, "-o", "killed/r.obj", "--max-area", "10"],
                                    cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    text=True)
            time.sleep(float(rng.uniform(0.3, 2.5)))
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=args.timeout)
            code = proc.returncode
            files = sorted(p.name for p in out.iterdir())
            complete = files == ["r.mtl", "r.obj", "r_drawing.png"]
            left = [] if (not files or complete) else files
            expected = (0, 128 + sig, -sig, -signal.SIGKILL)
            result = (code if code not in expected else 0, err if code > 0 else "", 0.0)
            k.add([sig.name], result, left)
            for p in out.iterdir():
                p.unlink()
        tallies.append(k)

        d = Tally("kills deep in meshing")
        frog = ROOT / "examples" / "frog" / "drawing.inkray.json"
        slowest = 0.0
        for i in range(args.deep_kills):
            sig = [signal.SIGTERM, signal.SIGHUP][i % 2]
            proc = subprocess.Popen([sys.executable, "-m", "inkray", "--quiet", "relief",
                                     str(frog), "-o", "killed/f.glb", "--max-area", "1.5"],
                                    cwd=work, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                    text=True)
            time.sleep(float(rng.uniform(5.0, 40.0)))
            start = time.monotonic()
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=args.timeout)
            took = time.monotonic() - start
            slowest = max(slowest, took)
            code = proc.returncode
            left = sorted(p.name for p in out.iterdir())
            ok = code in (0, 128 + sig, -signal.SIGKILL) and (code == 0 or not left)
            result = ("hang" if took > 3.0 else 0 if ok else code, err if code > 0 else "", 0.0)
            d.add([sig.name, f"{took:.1f} s"], result, [] if code == 0 else left)
            for p in out.iterdir():
                p.unlink()
        print(f"kills deep in meshing: slowest end {slowest:.1f} s after the signal", flush=True)
        tallies.append(d)

        if args.limits:
            bound = Tally("annotations: inflating memory")
            over_bound = []
            for name, path in _inflating(work, base):
                res = _run(["validate", path.name], args.timeout * 5, work)
                limit = (12 * path.stat().st_size + 700 * _MIB) / _MIB
                if res[2] > limit:
                    over_bound.append(name)
                bound.add([name], ("over the bound" if res[2] > limit else res[0], *res[1:]))
                print(f"  {name}: {path.stat().st_size / _MIB:.1f} MiB file, exit {res[0]}, "
                      f"peak {res[2]:.0f} MiB (bound {limit:.0f})", flush=True)
                path.unlink()
            onto, overwritten = _onto_inputs(work, base, args.timeout)
            tallies += [bound, onto, _extremes(work, base, args.timeout),
                        _editor_bodies(work, base, args.timeout)]
            print(f"inputs overwritten: {overwritten}; over the memory bound: {len(over_bound)}")

        print("| runs | n | exit 0 | exit 2 | internal errors | hangs | other exits | "
              "not one line | left files | peak MiB |")
        print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        for t in tallies:
            print(t.row())
        bad = [b for t in tallies for b in t.bad]
        for argv_, problems, err in bad[:20]:
            print(f"- {' '.join(map(str, argv_))}: {', '.join(problems)}: {err}")
        return 1 if bad else 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
