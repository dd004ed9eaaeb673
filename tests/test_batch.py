import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from inkray import cli
from inkray.batch import JOBS, find_frames, run_batch
from inkray.errors import InputError
from inkray.progress import Progress

from conftest import ROOT

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def cluster():
    """A local cluster of two worker processes, passed as --scheduler."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as c:
        yield c.scheduler_address


def _frame(folder, name, shift=0, inflation=None):
    """A small drawing (two boxes sharing a wall, a bar in front) and its annotation."""
    gray = np.full((48, 64), 255, np.uint8)
    gray[8, 6:58] = gray[40, 6:58] = 0
    gray[8:41, 6] = gray[8:41, 57] = 0
    gray[8:41, 30 + shift] = 0
    folder.mkdir(parents=True, exist_ok=True)
    Image.fromarray(gray).save(folder / f"{name}.png")
    regions = [{"name": "left", "scribbles": [[[15, 24], [20, 26]]]},
               {"name": "right", "scribbles": [[[45, 24], [48, 30]]]}]
    if inflation is not None:
        regions[1]["inflation"] = inflation
    doc = {"format": "inkray-annotations", "version": 1, "drawing": f"{name}.png",
           "size": [64, 48], "regions": regions,
           "order": [{"front": [20, 24], "back": [44, 24]}]}
    path = folder / f"{name}.inkray.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture
def shots(tmp_path):
    for k in range(3):
        _frame(tmp_path / "shots" / ("a" if k < 2 else "b"), f"f{k:03d}", shift=k)
    return tmp_path


def _run(argv):
    return cli.main(["--quiet"] + [str(a) for a in argv])


def test_frames_are_named_under_the_patterns_root(shots):
    frames = find_frames(str(shots / "shots" / "**" / "*.inkray.json"))
    assert [f.name for f in frames] == ["a/f000", "a/f001", "b/f002"]
    with pytest.raises(InputError, match="no annotation file matches"):
        find_frames(str(shots / "nothing" / "*.inkray.json"))


def test_batch_outputs_equal_the_single_commands(shots, cluster):
    out = shots / "out"
    assert _run(["batch", shots / "shots/**/*.inkray.json", "-o", out,
                 "--scheduler", cluster]) == 0
    ann = shots / "shots" / "a" / "f001.inkray.json"
    single = shots / "single"
    assert _run(["relief", ann, "-o", single / "relief.glb"]) == 0
    assert _run(["render", single / "relief.glb", "-o", single / "shaded.png"]) == 0
    assert _run(["layers", ann, "-o", single / "parts.psd"]) == 0
    assert _run(["layers", ann, "-o", single / "parts.ora"]) == 0
    assert _run(["maps", ann, "-o", single / "maps"]) == 0
    frame = out / "a" / "f001"
    produced = sorted(p.relative_to(frame).as_posix() for p in frame.rglob("*") if p.is_file())
    expected = sorted(p.relative_to(single).as_posix() for p in single.rglob("*") if p.is_file())
    assert produced == expected and len(produced) == 9
    for rel in produced:
        assert (frame / rel).read_bytes() == (single / rel).read_bytes(), rel
    report = json.loads((out / "batch-report.json").read_text())
    assert report["counts"] == {"done": 3, "skipped": 0, "failed": 0, "interrupted": 0}
    for record in report["frames"].values():
        assert record["status"] == "done" and record["error"] is None
        assert record["time"] > 0 and record["peak_memory"] > 10 * 2 ** 20
        assert 0 < record["cpu_time"]


def test_unchanged_frames_are_skipped_and_edited_ones_redone(shots, cluster):
    pattern, out = str(shots / "shots/**/*.inkray.json"), shots / "out"
    run_batch(pattern, out, jobs="relief,maps", scheduler=cluster)
    glb = out / "a" / "f000" / "relief.glb"
    stamp = glb.stat().st_mtime_ns
    again = run_batch(pattern, out, jobs="relief,maps", scheduler=cluster)
    assert again["counts"]["skipped"] == 3 and glb.stat().st_mtime_ns == stamp
    _frame(shots / "shots" / "b", "f002", shift=2, inflation=3.0)      # an edit
    (out / "a" / "f001" / "maps" / "ao.png").write_bytes(b"damaged")   # a damaged output
    edited = run_batch(pattern, out, jobs="relief,maps", scheduler=cluster)
    status = {name: r["status"] for name, r in edited["frames"].items()}
    assert status == {"a/f000": "skipped", "a/f001": "done", "b/f002": "done"}
    assert (out / "a" / "f001" / "maps" / "ao.png").read_bytes()[:4] == b"\x89PNG"
    more = run_batch(pattern, out, jobs="relief,maps,layers", scheduler=cluster)  # other jobs
    assert more["counts"]["done"] == 3


def test_a_failing_frame_is_isolated(shots, cluster, capsys):
    bad = shots / "shots" / "a" / "f009.inkray.json"
    bad.write_text('{"format": "inkray-annotations", "version": 1, "size": [64, 48], '
                   '"drawing": "f000.png", "regions": [{"name": "x", "scribbles": [[[99, 5]]]}]}')
    out = shots / "out"
    assert _run(["batch", shots / "shots/**/*.inkray.json", "-o", out, "--jobs", "relief",
                 "--scheduler", cluster]) == 1
    report = json.loads((out / "batch-report.json").read_text())
    failed = report["frames"]["a/f009"]
    assert failed["status"] == "failed" and "\n" not in failed["error"]
    assert "regions[0].scribbles[0][0]" in failed["error"]
    assert report["counts"]["done"] == 3 and not (out / "a" / "f009").exists()
    assert "a/f009" not in json.loads((out / "batch-manifest.json").read_text())["frames"]


class _InterruptAfter(Progress):
    """Ctrl-C in the middle of the batch: after ``n`` frames have finished."""

    def __init__(self, n):
        super().__init__(quiet=True)
        self.n = n

    def update(self, done, total):
        if done >= self.n:
            raise KeyboardInterrupt


def test_an_interrupted_batch_resumes_without_redoing_finished_frames(shots, cluster):
    pattern, out = str(shots / "shots/**/*.inkray.json"), shots / "out"
    with pytest.raises(KeyboardInterrupt):
        run_batch(pattern, out, jobs="relief", scheduler=cluster, progress=_InterruptAfter(1))
    report = json.loads((out / "batch-report.json").read_text())
    finished = [n for n, r in report["frames"].items() if r["status"] == "done"]
    assert len(finished) == 1 and report["counts"]["interrupted"] == 2
    resumed = run_batch(pattern, out, jobs="relief", scheduler=cluster)
    assert {n for n, r in resumed["frames"].items() if r["status"] == "skipped"} == set(finished)
    assert resumed["counts"]["done"] == 2


@pytest.mark.slow
def test_default_local_cluster_of_two_workers(shots):
    out = shots / "out"
    report = run_batch(str(shots / "shots/a/*.inkray.json"), out, jobs="relief", workers=2)
    assert report["scheduler"] == "local" and report["workers"] == 2
    assert report["counts"]["done"] == 2 and (out / "f000" / "relief.glb").is_file()


def test_bad_arguments_exit_2(shots, capsys):
    out = shots / "out"
    assert _run(["batch", shots / "shots/**/*.inkray.json", "-o", out, "--jobs", "relief,gi"]) == 2
    assert "unknown job gi" in capsys.readouterr().err
    assert _run(["batch", shots / "none/*.json", "-o", out]) == 2
    assert _run(["batch", shots / "shots/**/*.inkray.json", "-o", out, "--workers", "0"]) == 2
    assert _run(["batch", shots / "shots/**/*.inkray.json", "-o", out, "--jobs", "relief",
                 "--scheduler", "foo://nowhere"]) == 2
    assert "--scheduler foo://nowhere: cannot connect" in capsys.readouterr().err
    assert not out.exists()
    assert set(JOBS) == {"relief", "render", "layers", "maps"}


@pytest.mark.slow
def test_ctrl_c_on_the_command_line_keeps_finished_frames(tmp_path):
    for k in range(8):
        _frame(tmp_path / "shots", f"f{k:03d}", shift=k % 4)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    argv = [sys.executable, "-c", "import sys; from inkray.cli import main; sys.exit(main())",
            "--quiet", "batch", str(tmp_path / "shots/*.inkray.json"), "-o", str(out),
            "--workers", "1"]
    proc = subprocess.Popen(argv, env=env, stderr=subprocess.PIPE, text=True)
    manifest = out / "batch-manifest.json"
    deadline = time.monotonic() + 120
    while not manifest.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "interrupted" in err
    finished = set(json.loads(manifest.read_text())["frames"])
    assert 1 <= len(finished) < 8
    again = run_batch(str(tmp_path / "shots/*.inkray.json"), out, workers=1)
    assert {n for n, r in again["frames"].items() if r["status"] == "skipped"} == finished


def test_a_shot_with_keys_carries_every_other_frame_from_the_nearest_key(tmp_path, cluster):
    shot = tmp_path / "shot"
    for k in range(5):
        _frame(shot, f"f{k:03d}", shift=k)
    for k in (1, 2, 3):  # only f000 and f004 keep their annotations: the keys
        (shot / f"f{k:03d}.inkray.json").unlink()
    out = tmp_path / "out"
    report = run_batch(str(shot / "*.png"), out, jobs="relief", scheduler=cluster,
                       keys=[str(shot / "f000.inkray.json")])
    assert report["counts"]["done"] == 5
    frames = report["frames"]
    # f004 has its own annotation beside it: a key, and f003 is carried back from it.
    assert [frames[f"f{k:03d}"]["carried_from"] for k in range(5)] == \
        [None, "f000", "f001", "f004", None]
    assert frames["f002"]["key"].endswith("f000.inkray.json")
    assert frames["f003"]["key"].endswith("f004.inkray.json")
    for k in (1, 2, 3):
        folder = out / f"f{k:03d}"
        assert sorted(p.name for p in folder.iterdir()) == \
            ["annotation.inkray.json", "relief.glb", "transfer.json"]
        assert 0.5 < frames[f"f{k:03d}"]["confidence"] <= 1 and frames[f"f{k:03d}"]["check"] == []
        # The carried file is a valid annotation of its frame and names the frame's drawing.
        assert _run(["validate", folder / "annotation.inkray.json"]) == 0
        doc = json.loads((folder / "annotation.inkray.json").read_text())
        assert (folder / doc["drawing"]).resolve() == (shot / f"f{k:03d}.png").resolve()
        # The carried wall splits the boxes where the frame's wall is (it moved k pixels).
        assert doc["regions"][0]["scribbles"][0][0][0] < 30 + k < doc["regions"][1]["scribbles"][0][0][0]
    again = run_batch(str(shot / "*.png"), out, jobs="relief", scheduler=cluster,
                      keys=[str(shot / "f000.inkray.json")])
    assert again["counts"]["skipped"] == 5 and again["frames"]["f002"]["carried_from"] == "f001"
    with pytest.raises(InputError, match="is not a frame of the pattern"):
        run_batch(str(shot / "f00[1-3].png"), out, keys=[str(shot / "f000.inkray.json")])
