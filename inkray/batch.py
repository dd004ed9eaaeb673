"""Batches of frames on Dask: one chain per frame, skip what is unchanged, isolate failures.

A scene is many frames, each an annotation file with its drawing. ``inkray
batch 'shots/**/*.inkray.json' -o OUT/`` runs the chosen jobs on every frame
as one task of a Dask cluster (Rocklin, "Dask: parallel computation with
blocked algorithms and task scheduling", SciPy 2015): a local cluster of
worker processes by default, an existing cluster when a scheduler address is
given. Each task builds one :class:`inkray.chain.ReliefChain` and asks it for
what the jobs need, so the jobs of a frame share its segmentation,
completion and meshes; it returns the files' bytes, and this process writes
them, a frame's files all together or none
(:func:`inkray.formats.atomic.atomic_outputs`).

The frame whose annotation is ``ROOT/a/b.inkray.json`` (``ROOT`` the
pattern's folder before its first wildcard) writes into ``OUT/a/b/``:

========  =====================================================================
job       files (the bytes of the single command with its defaults)
========  =====================================================================
relief    ``relief.glb`` (``inkray relief ANN -o relief.glb``)
render    ``shaded.png`` (``inkray render relief.glb -o shaded.png``)
layers    ``parts.psd``, ``parts.ora`` (``inkray layers ANN -o parts.psd``, ``.ora``)
maps      ``maps/`` (``inkray maps ANN -o maps``)
pose      ``posed.png`` (``inkray pose ANN X.pose.json -o posed.png``, the pose
          file ``X.pose.json`` beside ``X.inkray.json``; not run by default)
========  =====================================================================

``OUT/batch-manifest.json`` records, per finished frame, a content hash of
its inputs (annotation and drawing bytes), the jobs and inkray's version, and
a hash of every output; a frame whose record matches and whose outputs are
intact is skipped, so an interrupted batch resumes where it stopped.
``OUT/batch-report.json`` holds per frame its status (``done``, ``skipped``,
``failed``, ``interrupted``), ``time`` (seconds), ``cpu_time`` (seconds of
CPU its worker process used), ``peak_memory`` (bytes of resident memory of
its worker process while it ran) and ``error`` (one line). A failed frame does not stop the others; the batch then exits 1.

Shots: ``inkray batch 'shot/*.png' --key shot/0001.inkray.json -o OUT``
takes drawings. A frame with an annotation (a ``--key`` whose drawing it is,
or ``<frame>.inkray.json`` beside it) is a key; every other frame is
annotated by carrying the nearest key's annotation to it frame by frame
(:mod:`inkray.transfer`: forward from an earlier key, backward from a later
one, never in one jump), then the jobs run on it. Its folder also gets the
carried ``annotation.inkray.json`` and ``transfer.json`` (every entry's match;
those to check), and its report record the key, the frame it was carried from,
its ``confidence`` and the entries to ``check``. Each carrying step is a Dask
task that waits only for the step before it, so the chains from different
keys, and every frame's jobs, run side by side.
"""

import contextlib
import glob
import hashlib
import json
import os
import resource
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from inkray._version import __version__
from inkray.errors import InkrayError, InputError
from inkray.formats.atomic import atomic_outputs, write_text
from inkray.progress import Progress

__all__ = ["JOBS", "JOB_FILES", "Frame", "find_frames", "run_batch", "run_frame", "plan_shot"]

#: The jobs a batch can run per frame, in the order they are done: the artefacts
#: (:data:`inkray.artefacts.ARTEFACTS`) each writes, and where in the frame's folder.
JOB_FILES = {
    "relief": (("relief", "relief.glb"),),
    "render": (("shaded", "shaded.png"),),
    "layers": (("layers", "parts.psd"), ("layers", "parts.ora")),
    "maps": (("maps", "maps"),),
    "pose": (("posed", "posed.png"),),
}
#: The jobs run when none are named; ``pose`` needs ``X.pose.json`` beside ``X.inkray.json``.
JOBS = ("relief", "render", "layers", "maps")
MANIFEST = "batch-manifest.json"
REPORT = "batch-report.json"
_SUFFIXES = (".inkray.json", ".json")
_IMAGES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp", ".svg")
CARRIED = "annotation.inkray.json"
TRANSFER = "transfer.json"


@dataclass(frozen=True)
class Frame:
    """One frame of a batch.

    Attributes
    ----------
    annotation : str
        The annotation file.
    name : str
        Its path under the pattern's root, without ``.inkray.json``; its
        outputs go to ``OUT/<name>/``.
    """

    annotation: str
    name: str


@dataclass
class _Outcome:
    status: str
    time: float = 0.0
    cpu_time: float = 0.0
    peak_memory: int = None
    error: str = None
    outputs: list = field(default_factory=list)
    shot: dict = None

    def record(self, frame):
        return {"annotation": frame.annotation, "status": self.status,
                "time": round(self.time, 3), "cpu_time": round(self.cpu_time, 3),
                "peak_memory": self.peak_memory,
                "error": self.error, "outputs": self.outputs, **(self.shot or {})}


def find_frames(pattern):
    """The frames of a glob pattern (``**`` spans folders), sorted by name.

    Parameters
    ----------
    pattern : str
        E.g. ``"shots/**/*.inkray.json"``; a plain file name is one frame.

    Returns
    -------
    list of Frame

    Raises
    ------
    InputError
        Nothing matches, or two files would write into one folder.

    Examples
    --------
    >>> [f.name for f in find_frames("examples/t*/drawing.inkray.json")]  # doctest: +SKIP
    ['turtle/drawing']
    """
    matches = sorted(p for p in glob.glob(pattern, recursive=True) if os.path.isfile(p))
    if not matches:
        raise InputError(f"{pattern}: no annotation file matches")
    parts = Path(pattern).parts
    fixed = [p for p in parts[:next((i for i, p in enumerate(parts) if glob.has_magic(p)),
                                    len(parts) - 1)]]
    root = Path(*fixed) if fixed else Path(".")
    frames, seen = [], {}
    for match in matches:
        rel = Path(match).relative_to(root).as_posix()
        name = next((rel[:-len(s)] for s in _SUFFIXES + _IMAGES if rel.lower().endswith(s)), rel)
        if name in seen:
            raise InputError(f"{match}: writes into the same folder as {seen[name]} ({name}/)")
        seen[name] = match
        frames.append(Frame(annotation=str(match), name=name))
    return sorted(frames, key=lambda f: f.name)


def run_frame(annotation, jobs):
    """Run ``jobs`` on one annotation file; the files' bytes by path under the frame's folder.

    This is one batch task; it never raises for the frame's own problems.

    Parameters
    ----------
    annotation : str
    jobs : sequence of str
        Among :data:`JOBS`.

    Returns
    -------
    dict
        ``{"status": "done" | "failed", "files": {relative path: bytes},
        "time": seconds, "cpu_time": seconds of CPU, "peak_memory": bytes,
        "error": one line or None}``.
    """
    _reset_peak_memory()
    start, cpu = time.perf_counter(), time.process_time()
    try:
        files = _frame_files(annotation, jobs)
        status, error = "done", None
    except MemoryError:
        files, status, error = {}, "failed", "out of memory"
    except InkrayError as e:
        files, status, error = {}, "failed", _one_line(e)
    except Exception as e:  # a bug on one frame must not stop the batch
        files, status, error = {}, "failed", f"internal error: {type(e).__name__}: {_one_line(e)}"
    return {"status": status, "files": files, "time": time.perf_counter() - start,
            "cpu_time": time.process_time() - cpu, "peak_memory": _peak_memory(), "error": error}


def run_batch(pattern, output, *, jobs=JOBS, scheduler=None, workers=None, progress=None,
              keys=()):
    """Run the jobs on every frame of ``pattern`` on Dask and write ``output``.

    Parameters
    ----------
    pattern : str
        Glob of annotation files (``**`` spans folders).
    output : str or Path
        The output folder.
    jobs : sequence of str, default all of :data:`JOBS`
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); default a
        local cluster of worker processes.
    workers : int, optional
        Worker processes of the local cluster; default one per core.
    progress : inkray.progress.Progress, optional
    keys : sequence of str, optional
        Key annotation files: ``pattern`` then matches the shot's drawings, and
        every frame without an annotation is carried from the nearest key.

    Returns
    -------
    dict
        The report (also written as ``output/batch-report.json``).

    Raises
    ------
    InputError
        A bad pattern, job list or worker count.
    KeyboardInterrupt
        After writing the report and the manifest of the frames finished.
    """
    jobs = _check_jobs(jobs)
    if workers is not None and (int(workers) != workers or workers < 1):
        raise InputError(f"--workers {workers}: expected a whole number >= 1")
    progress = progress if progress is not None else Progress(quiet=True)
    frames = find_frames(pattern)
    out = Path(output)
    if out.exists() and not out.is_dir():
        raise InputError(f"-o {out}: exists and is not a folder")
    plan = plan_shot(frames, keys) if keys else None
    if plan is not None:
        frames = [Frame(annotation=step["annotation"] or step["drawing"], name=name)
                  for name, step in plan.items()]
    inputs = {str(Path(f.annotation).resolve()) for f in frames}
    if plan is not None:
        inputs |= {str(Path(step["drawing"]).resolve()) for step in plan.values()}
    manifest = _read_manifest(out)
    keys = ({f.name: _frame_key(f.annotation, jobs) for f in frames} if plan is None
            else {name: _shot_key(plan, name, jobs) for name in plan})
    outcomes, todo = {}, []
    for f in frames:
        if _unchanged(out / f.name, manifest.get(f.name), keys[f.name]):
            outcomes[f.name] = _Outcome("skipped", outputs=sorted(manifest[f.name]["outputs"]))
            if plan is not None:
                outcomes[f.name].shot = _shot_record(plan, f.name, _read_transfer(out / f.name))
        else:
            todo.append(f)
    results = (_dask_results(todo, jobs, scheduler, workers) if plan is None
               else _shot_results(plan, todo, jobs, scheduler, workers, out))
    with progress.stage(f"batch: {len(todo)} of {len(frames)} frames"):
        progress.update(len(frames) - len(todo), len(frames))
        try:
            for frame, result in results:
                outcomes[frame.name] = _finish(out, frame, result, inputs, manifest, keys)
                if plan is not None:
                    outcomes[frame.name].shot = _shot_record(plan, frame.name,
                                                             result.get("transfer"))
                if outcomes[frame.name].status == "failed" and not progress.quiet:
                    print(f"inkray: {frame.annotation}: {outcomes[frame.name].error}",
                          file=progress.stream)
                progress.update(len(outcomes), len(frames))
        except KeyboardInterrupt:
            for f in frames:
                outcomes.setdefault(f.name, _Outcome("interrupted"))
            report = _report(frames, outcomes, jobs, scheduler, workers)
            _write_report(out, report)
            raise
    report = _report(frames, outcomes, jobs, scheduler, workers)
    _write_report(out, report)
    return report


# -- one frame -------------------------------------------------------------------

def _frame_files(annotation, jobs):
    """The bytes of every output of ``jobs``, each made as its single command makes it."""
    from inkray.input.loading import load_input

    ann, drawing = load_input(annotation)
    return _chain_files(ann, drawing, jobs, where=annotation)


def _chain_files(ann, drawing, jobs, *, where):
    from inkray.artefacts import ARTEFACTS, artefact_files
    from inkray.chain import ChainOptions, ReliefChain

    made = [(ARTEFACTS[name], target) for job in jobs for name, target in JOB_FILES[job]]
    for artefact, _ in made:
        try:
            artefact.check(ann)
        except InputError as e:
            raise InputError(f"{where}: {e}") from None
    chain = ReliefChain(ann, drawing, options=ChainOptions())
    files, values = {}, {}
    for artefact, target in made:
        if artefact.name not in values:
            values[artefact.name] = artefact.make(chain)
        files.update(artefact_files(artefact, values[artefact.name], target, chain=chain))
    return files


def _reset_peak_memory():
    # Linux: writing 5 to clear_refs resets the peak resident set size (VmHWM).
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass


def _peak_memory():
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, bytes on macOS
    return int(peak if sys.platform == "darwin" else peak * 1024)


# -- the batch -------------------------------------------------------------------

@contextlib.contextmanager
def _client(scheduler, workers):
    """A Dask client of the given scheduler or of a local cluster of worker processes."""
    import dask
    from distributed import Client, LocalCluster

    cluster = None
    if scheduler is None:
        n = workers or os.cpu_count() or 1
        # Dask sets MALLOC_TRIM_THRESHOLD_ in its workers so that they hand freed
        # memory back at once; glibc then maps every large numpy array afresh,
        # which made a frame about 30 % slower here. None unsets it.
        unset = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
        with dask.config.set(unset):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   dashboard_address=":0")
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=10)
        except (OSError, ValueError) as e:
            raise InputError(f"--scheduler {scheduler}: cannot connect ({_one_line(e)})") from None
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _task_key(what, path):
    return f"inkray-{what}-{_digest(str(path).encode())}-{time.monotonic_ns()}"


def _gather(client, futures):
    """(frame, result) of every future of ``futures`` ({future: frame}) as it finishes."""
    from distributed import as_completed

    try:
        for future in as_completed(futures):
            try:
                result = future.result()
            except Exception as e:  # the worker process died (killed, out of memory)
                result = {"status": "failed", "files": {}, "time": 0.0, "cpu_time": 0.0,
                          "peak_memory": None,
                          "error": f"worker lost: {type(e).__name__}: {_one_line(e)}"}
            future.release()
            yield futures[future], result
    finally:
        client.cancel(list(futures))


def _dask_results(frames, jobs, scheduler, workers):
    """(frame, result) of every frame as it finishes, on the given or a local cluster."""
    if not frames:
        return
    with _client(scheduler, workers) as client:
        futures = {client.submit(run_frame, f.annotation, tuple(jobs), pure=False,
                                 key=_task_key("frame", f.annotation)): f for f in frames}
        yield from _gather(client, futures)


# -- shots: frames carried from keys ------------------------------------------------

def plan_shot(frames, keys):
    """Which key each frame of a shot is carried from, and through which frame.

    Parameters
    ----------
    frames : list of Frame
        The shot's drawings in order (:func:`find_frames` of a drawing pattern).
    keys : sequence of str
        Key annotation files; each one's drawing must be one of ``frames``.
        A frame with ``<frame>.inkray.json`` beside it is a key as well.

    Returns
    -------
    dict
        By frame name, in order: ``{"drawing", "annotation" (its own, or
        None), "key" (the key annotation it is carried from), "source" (the
        neighbouring frame it is carried from, None for a key)}``.

    Raises
    ------
    InputError
        A key whose drawing is not a frame of the pattern, or two keys of one frame.
    """
    from inkray.input.annotations import load_annotations

    index = {str(Path(f.annotation).resolve()): i for i, f in enumerate(frames)}
    own = {}
    for key in keys:
        ann = load_annotations(key)
        drawing = None if ann.drawing is None else str(Path(ann.drawing).resolve())
        if drawing not in index:
            raise InputError(f"--key {key}: its drawing {ann.drawing} is not a frame of the pattern")
        if index[drawing] in own:
            raise InputError(f"--key {key}: frame {frames[index[drawing]].name} already has the key "
                             f"{own[index[drawing]]}")
        own[index[drawing]] = str(key)
    for i, f in enumerate(frames):
        beside = Path(f.annotation).with_suffix(".inkray.json")
        if i not in own and beside.is_file():
            own[i] = str(beside)
    if not own:
        raise InputError("--key: no key frame among the frames")
    plan = {}
    for i, f in enumerate(frames):
        if i in own:
            plan[f.name] = {"drawing": f.annotation, "annotation": own[i], "key": own[i],
                            "source": None}
            continue
        # The nearest key; an earlier one on a tie (carried forward).
        k = min(own, key=lambda j: (abs(j - i), j > i))
        step = 1 if k < i else -1
        plan[f.name] = {"drawing": f.annotation, "annotation": None, "key": own[k],
                        "source": frames[i - step].name}
    return plan


def _chain_of(plan, name):
    """The frames from ``name``'s key to ``name``, key first."""
    path = [name]
    while plan[path[-1]]["source"] is not None:
        path.append(plan[path[-1]]["source"])
    return path[::-1]


def _shot_key(plan, name, jobs):
    """Hash of what a shot frame depends on: the key and every drawing on its way."""
    files = [plan[name]["key"]] + [plan[n]["drawing"] for n in _chain_of(plan, name)]
    return _files_key(files, jobs, drawing_of=plan[name]["key"])


def _shot_record(plan, name, transfer):
    step = plan[name]
    record = {"key": step["key"], "carried_from": step["source"]}
    if step["source"] is not None and transfer is not None:
        record.update(confidence=transfer["confidence"], check=transfer["check"],
                      transfer_time=transfer.get("time"))
    return record


def _read_transfer(folder):
    try:
        return json.loads((folder / TRANSFER).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _shot_results(plan, todo, jobs, scheduler, workers, out):
    """(frame, result) of every frame to do, carrying annotations key to frame as needed."""
    if not todo:
        return
    needed = set()
    for f in todo:
        needed.update(_chain_of(plan, f.name))
    with _client(scheduler, workers) as client:
        states, futures = {}, {}

        def state(name):  # the carried (or key) annotation of a frame, as a future
            if name not in states:
                step = plan[name]
                if step["source"] is None:
                    states[name] = client.submit(key_state, step["annotation"], pure=False,
                                                 key=_task_key("key", step["annotation"]))
                else:
                    states[name] = client.submit(carry_state, state(step["source"]),
                                                 step["drawing"], pure=False,
                                                 key=_task_key("carry", step["drawing"]))
            return states[name]

        for f in todo:
            step = plan[f.name]
            if step["source"] is None:
                future = client.submit(run_frame, step["annotation"], tuple(jobs), pure=False,
                                       key=_task_key("frame", step["annotation"]))
            else:
                drawing = os.path.relpath(Path(step["drawing"]).resolve(),
                                          (out / f.name).resolve())
                future = client.submit(run_carried, state(f.name), tuple(jobs),
                                       Path(drawing).as_posix(), pure=False,
                                       key=_task_key("jobs", step["drawing"]))
            futures[future] = f
        yield from _gather(client, futures)


def key_state(annotation):
    """A key frame as carrying starts from it: its annotation, drawing and labels.

    One batch task; errors travel in the state (``"error"``) to the frames
    carried from it.
    """
    from inkray.input.loading import load_input
    from inkray.segmentation import segment

    try:
        ann, drawing = load_input(annotation)
        return {"annotations": ann, "drawing": drawing, "labels": segment(ann, drawing).labels,
                "error": None, "transfer": None}
    except InkrayError as e:
        return {"error": f"key {annotation}: {_one_line(e)}"}


def carry_state(previous, drawing_path):
    """The state of the next frame: ``previous``'s annotation carried to ``drawing_path``."""
    from inkray.formats.annotation_file import transfer_report
    from inkray.input.drawing import load_drawing
    from inkray.transfer import transfer_annotations

    if previous["error"] is not None:
        return previous
    start, cpu = time.perf_counter(), time.process_time()
    try:
        frame = load_drawing(drawing_path)
        prior = None if previous["transfer"] is None else \
            {e["key"]: e["match"] for e in previous["transfer"]["entries"]}
        t = transfer_annotations(previous["annotations"], previous["drawing"], frame,
                                 key_labels=previous["labels"], prior=prior)
    except InkrayError as e:
        return {"error": f"carrying to {drawing_path}: {_one_line(e)}"}
    t.annotations.drawing = Path(drawing_path)
    report = transfer_report(t, frame=drawing_path)
    report["time"] = round(time.perf_counter() - start, 3)
    return {"annotations": t.annotations, "drawing": frame, "labels": t.labels, "error": None,
            "transfer": report}


def run_carried(state, jobs, drawing):
    """Run ``jobs`` on a carried frame; like :func:`run_frame`, plus the carried annotation
    (``annotation.inkray.json``, its ``drawing`` key ``drawing``) and ``transfer.json``."""
    from inkray.formats.annotation_file import annotation_document, annotation_text

    _reset_peak_memory()
    start, cpu = time.perf_counter(), time.process_time()
    files, status, error = {}, "failed", state["error"]
    if error is None:
        try:
            files = _chain_files(state["annotations"], state["drawing"], jobs,
                                 where=str(state["drawing"].path))
            files[CARRIED] = annotation_text(annotation_document(state["annotations"],
                                                                 drawing=drawing)).encode()
            files[TRANSFER] = (json.dumps(state["transfer"], indent=1) + "\n").encode()
            status = "done"
        except MemoryError:
            files, error = {}, "out of memory"
        except InkrayError as e:
            files, error = {}, _one_line(e)
        except Exception as e:  # a bug on one frame must not stop the batch
            files, error = {}, f"internal error: {type(e).__name__}: {_one_line(e)}"
    return {"status": status, "files": files, "time": time.perf_counter() - start,
            "cpu_time": time.process_time() - cpu, "peak_memory": _peak_memory(), "error": error,
            "transfer": state.get("transfer")}


def _finish(out, frame, result, inputs, manifest, keys):
    """Write a finished frame's files and its manifest record; its outcome."""
    outcome = _Outcome(result["status"], time=result["time"], cpu_time=result["cpu_time"],
                       peak_memory=result["peak_memory"], error=result["error"])
    if outcome.status != "done":
        return outcome
    folder = out / frame.name
    targets = {folder / rel: data for rel, data in sorted(result["files"].items())}
    clash = next((t for t in targets if str(t.resolve()) in inputs), None)
    if clash is not None:
        outcome.status, outcome.error = "failed", f"{clash}: would overwrite an input"
        return outcome
    with atomic_outputs() as group:
        for target, data in targets.items():
            group.write_bytes(target, data)
    outcome.outputs = sorted(result["files"])
    manifest[frame.name] = {"key": keys[frame.name],
                            "outputs": {rel: _digest(data) for rel, data in
                                        sorted(result["files"].items())}}
    write_text(out / MANIFEST, json.dumps({"format": "inkray-batch-manifest", "version": 1,
                                           "frames": dict(sorted(manifest.items()))},
                                          indent=1) + "\n")
    return outcome


def _unchanged(folder, record, key):
    if not record or record.get("key") != key:
        return False
    for rel, digest in record.get("outputs", {}).items():
        try:
            if _digest((folder / rel).read_bytes()) != digest:
                return False
        except OSError:
            return False
    return True


def _frame_key(annotation, jobs):
    """Hash of what a frame's outputs depend on: inkray, the jobs, the input files' bytes."""
    return _files_key([annotation], jobs, drawing_of=annotation)


def _files_key(files, jobs, *, drawing_of):
    """Hash of inkray, the jobs, the bytes of ``files`` and of ``drawing_of``'s drawing."""
    from inkray.input.annotations import load_annotations

    try:
        drawing = load_annotations(drawing_of).drawing
    except InkrayError:
        drawing = None  # the task reports the problem
    h = hashlib.blake2b(digest_size=16)
    h.update(json.dumps({"inkray": __version__, "jobs": list(jobs)}).encode())
    inputs = list(files) + ([drawing] if drawing is not None else [])
    if "pose" in jobs:
        from inkray.input.pose import pose_path

        inputs.append(pose_path(drawing_of))
    for path in inputs:
        try:
            data = Path(path).read_bytes()
        except OSError:
            data = b""  # the task reports the missing file
        h.update(len(data).to_bytes(8, "little") + data)
    return h.hexdigest()


def _read_manifest(out):
    path = out / MANIFEST
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        frames = data["frames"]
        if data.get("format") != "inkray-batch-manifest" or not isinstance(frames, dict):
            raise ValueError("not a batch manifest")
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"{path}: unreadable manifest ({_one_line(e)}); delete it to start "
                         f"over") from None
    return frames


def _report(frames, outcomes, jobs, scheduler, workers):
    records = {f.name: outcomes[f.name].record(f) for f in frames}
    counts = {s: sum(r["status"] == s for r in records.values())
              for s in ("done", "skipped", "failed", "interrupted")}
    return {"format": "inkray-batch-report", "version": 1, "jobs": list(jobs),
            "scheduler": scheduler or "local",
            "workers": workers if scheduler is None else None,
            "counts": counts, "frames": records}


def _write_report(out, report):
    write_text(out / REPORT, json.dumps(report, indent=1, ensure_ascii=False) + "\n")


def _check_jobs(jobs):
    jobs = [j.strip() for j in (jobs.split(",") if isinstance(jobs, str) else jobs)]
    unknown = [j for j in jobs if j not in JOB_FILES]
    if unknown or not jobs:
        bad = unknown[0] if unknown else "(none)"
        raise InputError(f"--jobs {','.join(jobs)}: unknown job {bad} "
                         f"(expected some of {','.join(JOB_FILES)})")
    return tuple(j for j in JOB_FILES if j in jobs)


def _digest(data):
    return hashlib.blake2b(data, digest_size=16).hexdigest()


def _one_line(e):
    return " ".join(str(e).split())
