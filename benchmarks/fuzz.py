"""The long fuzz run of the input edge, in separate processes.

Hostile annotation files (through ``validate`` and ``relief``), drawings
(``validate``), meshes (``check`` and ``render``) and kills at random moments
of a relief (SIGTERM, SIGHUP, SIGKILL). Each run is a fresh ``inkray``
process with a time limit; the table counts exit codes, internal errors,
hangs, messages that are not one line, files left behind and the largest
peak memory. The generators are in ``tests/_hostile.py`` (the test suite
runs a small sample of them in-process).

Usage::

    python benchmarks/fuzz.py [--annotations 1000] [--images 100] [--meshes 100]
                              [--reliefs 20] [--kills 20] [--seed 0] [--timeout 60]
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
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            err = proc.stderr.read()
            code = os.waitstatus_to_exitcode(status)
            return code, err, usage.ru_maxrss / 1024
        if time.monotonic() > deadline:
            proc.kill()
            _, _, usage = os.wait4(proc.pid, 0)
            return "hang", proc.stderr.read(), usage.ru_maxrss / 1024
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
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=60.0)
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
            expected = (0, 128 + sig, -sig)
            result = (code if code not in expected else 0, err if code > 0 else "", 0.0)
            k.add([sig.name], result, left)
            for p in out.iterdir():
                p.unlink()
        tallies.append(k)

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
