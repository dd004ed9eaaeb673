"""The ``inkray`` command line.

Exit codes: 0 ok, 1 failed on valid input, 2 bad input or usage. Errors are
one line on stderr (``--debug`` shows the traceback). Every command validates
its whole input before it writes anything, and writes through
:func:`inkray.formats.atomic.atomic_outputs`.
"""

import argparse
import atexit
import contextlib
import os
import signal
import sys
import threading
import time
import traceback
import warnings
from pathlib import Path

from inkray._version import __version__
from inkray.errors import InkrayError, InputError, Notice
from inkray.input.limits import DEFAULT_LIMITS, Limits
from inkray.progress import Progress

__all__ = ["main"]


class _UsageError(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, instead of usage + message
        command = self.prog.partition(" ")[2]
        raise _UsageError(f"{command + ': ' if command else ''}{message} "
                          f"(see '{self.prog} --help')")


def _add_input(p):
    p.add_argument("annotation", metavar="ANN", help="annotation file (.inkray.json)")
    p.add_argument("--drawing", metavar="PATH", help="drawing file (overrides the 'drawing' key)")
    p.add_argument("--rescale", action="store_true",
                   help="scale the annotation when the drawing's size differs from its 'size'")
    p.add_argument("--scribbles", metavar="PNG",
                   help="scribble layer: transparent PNG, one flat colour per region")
    p.add_argument("--legend", metavar="JSON",
                   help="colour legend for --scribbles: {\"#rrggbb\": \"name\", ...}")
    p.add_argument("--max-pixels", type=int, default=DEFAULT_LIMITS.pixels, metavar="N",
                   help=f"largest drawing in pixels (default: {DEFAULT_LIMITS.pixels})")
    p.add_argument("--max-points", type=int, default=DEFAULT_LIMITS.points, metavar="N",
                   help=f"most points in one scribble or path (default: {DEFAULT_LIMITS.points}; "
                        f"the file's total may be 50 times that)")


def _limits(args):
    try:
        return Limits(pixels=args.max_pixels, points=args.max_points,
                      total_points=max(DEFAULT_LIMITS.total_points, 50 * args.max_points))
    except InputError as e:
        raise InputError(f"--max-{str(e).partition('.')[2].partition(':')[0]}: expected a "
                         f"positive integer") from None


def _load(args):
    from inkray.input.loading import load_input

    return load_input(args.annotation, drawing=args.drawing, rescale=args.rescale,
                      scribble_layer=args.scribbles, legend=args.legend, limits=_limits(args))


def _chain(args, progress, targets=(), **options):
    """The chain of the command's input: every command is a view of one.

    ``targets`` (every file the command will write) are checked against the
    inputs and for writability once the input is loaded, before any work.
    """
    from inkray.chain import ChainOptions, ReliefChain
    from inkray.formats.atomic import check_targets

    ann, drawing = _load(args)
    check_targets(targets, inputs=_inputs(args, ann))
    return ReliefChain(ann, drawing, options=ChainOptions(**options), progress=progress)


def _inputs(args, ann):
    return [args.annotation, ann.drawing, args.scribbles,
            args.legend if isinstance(args.legend, str) else None, getattr(args, "frame_drawing", None)]


def _group(args, chain):
    from inkray.formats.atomic import atomic_outputs

    return atomic_outputs(inputs=_inputs(args, chain.annotations))


def _warn(warnings):
    for warning in warnings:
        text = warning.worded(_flag) if isinstance(warning, Notice) else warning
        print(f"inkray: warning: {text}", file=sys.stderr)


def _check_output(path, allowed):
    suffix = Path(path).suffix.lower()
    if suffix not in allowed:
        raise InputError(f"-o {path}: unsupported output type {suffix or '(none)'} "
                         f"(expected {', '.join(allowed)})")


def _in_range(flag, value, low, high, what):
    """Finite numbers within a documented range: larger ones make non-finite geometry."""
    if not low <= value <= high:  # also false for NaN
        raise InputError(f"{flag} {value:g}: expected a {what} within {low:g}..{high:g}")


# -- commands ----------------------------------------------------------------

def _cmd_validate(args, progress):
    import json

    from inkray.chain import ChainOptions, ReliefChain
    from inkray.validation import Problem, validate

    chain = None
    try:
        ann, drawing = _load(args)
    except InputError as e:
        if not args.json:
            raise
        problems = [Problem.from_message("error", _one_line(e.worded(_flag)))]
        ann = None
    else:
        chain = ReliefChain(ann, drawing, options=ChainOptions(), progress=progress)
        problems = validate(chain)
    errors = [p for p in problems if p.severity == "error"]
    if args.json:
        doc = {"file": str(args.annotation), "ok": not errors,
               "problems": [p.as_dict() for p in problems]}
        if ann is not None:
            doc.update(drawing=str(drawing.path), size=list(ann.size),
                       counts={"regions": len(ann.regions), "background": len(ann.background),
                               "order": len(ann.order), "equal": len(ann.equal),
                               "boundaries": len(ann.boundaries)})
        if not errors and chain is not None:
            doc["predicted"] = [
                {"front": r.front_name, "back": r.back_name, "where": list(r.where),
                 "confidence": round(float(r.confidence), 4)}
                for r in sorted(chain.relations, key=lambda r: (r.confidence, r.place or 0))
                if r.source == "predicted" and r.kind == "order"]
        print(json.dumps(doc, indent=2, ensure_ascii=False))
        return 2 if errors else 0
    for p in problems:
        print(f"inkray: {p.severity}: {_one_line(p.message)}", file=sys.stderr)
    if errors:
        if len(errors) > 1:
            print(f"inkray: error: {args.annotation}: {len(errors)} problems", file=sys.stderr)
        return 2
    w, h = ann.size
    print(f"{args.annotation}: ok: {w}x{h} drawing {drawing.path}, {len(ann.regions)} regions, "
          f"{len(ann.background)} background scribbles, {len(ann.order)} order, "
          f"{len(ann.equal)} equal, {len(ann.boundaries)} boundaries")
    if args.predict:
        _print_predictions(chain.relations)
    return 0


def _print_predictions(relations):
    """The predicted order relations, least sure first: where an arrow helps most."""
    from inkray.formats.regions_report import predicted_relations

    lines = predicted_relations(relations)
    print(f"{len(lines)} predicted order relations, least sure first (draw an order arrow "
          f"where a prediction is wrong):")
    for line in lines:
        print(f"  {line}")


def _produce(args, progress, name, target, *, options=None, params=None, write=None,
             warn=None, stage=None, before=None):
    """Make the artefact ``name`` of the command's input and write it at ``target``.

    The CLI's adapter over :data:`inkray.artefacts.ARTEFACTS`: the output's
    type and every target are checked before any work, the chain is built
    with ``options``, the value computed with ``params``, ``warn(chain,
    value)``'s warnings printed, and the files written together with
    ``write``. Returns ``(chain, value, written paths)``.
    """
    from inkray.artefacts import ARTEFACTS

    artefact = ARTEFACTS[name]
    try:
        files = artefact.files(target, **(write or {}))
    except InputError as e:
        raise InputError(f"-o {e}") from None
    chain = _chain(args, progress, targets=files, **(options or {}))
    artefact.check(chain.annotations)
    if before is not None:
        before(chain)
    with progress.stage(stage) if stage else contextlib.nullcontext():
        value = artefact.make(chain, **(params or {}))
    if warn is not None:
        _warn(warn(chain, value))
    with progress.stage("write"), _group(args, chain) as group:
        written = artefact.write(value, target, chain=chain, outputs=group, **(write or {}))
    progress.summary()
    return chain, value, written


def _cmd_segment(args, progress):
    if args.npy is not None and Path(args.npy).suffix.lower() != ".npy":
        raise InputError(f"--npy {args.npy}: expected a .npy file")
    _, seg, written = _produce(args, progress, "labels", args.output, write=dict(npy=args.npy),
                               warn=lambda chain, seg: seg.warnings)
    extra = f" and {args.npy}" if args.npy is not None else ""
    print(f"{written[0]}: {len(seg.names)} regions and background (legend {written[1]}{extra}), "
          f"{len(seg.warnings)} warnings")
    return 0


def _cmd_regions(args, progress):
    def check_names(chain):
        if args.masks is None:
            return
        for i, region in enumerate(chain.annotations.regions):
            if len(f"{region.name}.png".encode()) > 255:
                raise InputError(f"regions[{i}].name: {len(region.name)} characters are too many "
                                 f"for a file name in --masks (at most 251)")

    chain, report, _ = _produce(args, progress, "regions", args.output,
                                options=dict(predict=not args.no_predict),
                                params=dict(masks=args.masks), write=dict(masks=args.masks),
                                warn=lambda chain, report: report["warnings"], before=check_names)
    predicted = sum(r["source"] == "predicted" for r in report["relations"])
    print(f"{args.output}: {len(report['regions'])} regions, {len(report['relations'])} order "
          f"relations ({predicted} predicted), {len(report['warnings'])} warnings"
          + (f"; masks in {args.masks}/" if args.masks is not None else ""))
    _print_predictions(chain.relations)
    return 0


def _cmd_depth(args, progress):
    _check_output(args.output, (".png",))
    for flag, path, allowed in (("--npy", args.npy, (".npy",)), ("--normals", args.normals, (".png",)),
                                ("--shading", args.shading, (".png",))):
        if path is not None and Path(path).suffix.lower() not in allowed:
            raise InputError(f"{flag} {path}: unsupported output type (expected {allowed[0]})")
    # beyond 1e5 the QP's KKT residual no longer meets its tolerance (measured on the turtle)
    _in_range("--epsilon", args.epsilon, 1e-9, 1e5, "depth step")
    chain, result, written = _produce(
        args, progress, "depth", args.output,
        options=dict(depth_method=args.method, depth_epsilon=args.epsilon),
        write=dict(npy=args.npy, normals=args.normals, shading=args.shading))
    d = result.depth
    ann = chain.annotations
    print(f"{args.output}: {args.method} depth of {len(ann.order)} order and {len(ann.equal)} equal "
          f"entries, range {float(d.min()):.4g} .. {float(d.max()):.4g} "
          f"(wrote {', '.join(str(p) for p in written)})")
    return 0


def _cmd_relief(args, progress):
    _check_output(args.output, (".glb", ".obj", ".ply"))
    _in_range("--units-per-pixel", args.units_per_pixel, 1e-9, 1e6, "scene units per pixel")
    _in_range("--max-area", args.max_area, 1e-3, 1e8, "triangle area in px^2")
    if args.epsilon is not None:
        _in_range("--epsilon", args.epsilon, 1e-6, 1e5, "depth step in px")
    _in_range("--depth-scale", args.depth_scale, 1e-3, 10, "factor on every height")
    up = args.up or "y"
    if up != "y" and Path(args.output).suffix.lower() == ".glb":
        raise InputError(f"--up {up}: a GLB file is always Y up (glTF); --up is for OBJ and PLY")
    out = Path(args.output)
    images = {}
    for flag, mode in (("depth_png", "depth"), ("normals_png", "normals")):
        value = getattr(args, flag)
        if value is not None:
            target = Path(value) if isinstance(value, str) else out.with_name(f"{out.stem}-{mode}.png")
            _check_output(target, (".png",))
            images[mode] = target
    _, relief, written = _produce(
        args, progress, "relief", out,
        options=dict(predict=not args.no_predict, max_area=args.max_area, epsilon=args.epsilon,
                     closed=args.closed, union=args.union),
        params=dict(depth_scale=args.depth_scale, name=out.stem if args.union else None),
        write=dict(units_per_pixel=args.units_per_pixel, anchor=args.anchor, back=args.back,
                   up=up, images=images),
        warn=lambda chain, relief: chain.warnings)
    from inkray.formats.meshes import mesh_counts

    vertices, faces = mesh_counts(relief, suffix=out.suffix, back=args.back)  # what the file holds
    print(f"{out}: {len(relief.parts)} parts, {vertices} vertices, {faces} faces "
          f"({', '.join(str(w) for w in written[1:]) or 'no extra files'})")
    return 0


def _cmd_render(args, progress):
    from inkray.formats.atomic import atomic_outputs, check_targets
    from inkray.formats.images import rendering_files, write_renderings
    from inkray.formats.meshes import read_relief
    from inkray.view.depth_enhancement import check_enhancement
    from inkray.view.rendering import (GI_MAX_SIDE, GI_QUALITY, check_turntable, output_size,
                                       render, render_turntable)

    _check_output(args.output, (".png", ".gif") if args.turntable else (".png",))

    size = None
    if args.size is not None:
        try:
            size = tuple(int(v) for v in args.size.lower().split("x"))
        except ValueError:
            size = ()
        if len(size) != 2:
            raise InputError(f"--size {args.size}: expected WIDTHxHEIGHT in whole pixels "
                             f"(e.g. 800x600)")
    if args.turntable is not None:
        check_turntable(frames=args.turntable, angle=args.angle)
    check_enhancement(args.enhance_strength, args.enhance_radius, prefix="enhance_")
    if args.quality is not None and args.mode != "gi":
        raise InputError(f"--quality {args.quality}: only for --mode gi")
    quality = args.quality or ("draft" if args.turntable is not None else "final")
    spp = args.spp if args.spp is not None else GI_QUALITY[quality]
    check_targets([args.output], inputs=[args.mesh])
    inputs = []
    with progress.stage("read"):
        relief = read_relief(args.mesh, inputs=inputs)
    _warn(relief.warnings)
    size = output_size(relief.size, size=size, width=args.width, height=args.height,
                       max_side=GI_MAX_SIDE if args.mode == "gi" else None)
    if args.turntable is not None:
        check_turntable(frames=args.turntable, angle=args.angle, size=size)
    check_targets(rendering_files(args.output, frames=args.turntable, mode=args.mode),
                  inputs=inputs)
    options = dict(mode=args.mode, size=size, ambient=args.ambient,
                   flat_colors=args.flat_colors, disparity=args.disparity, spp=spp,
                   backdrop=not args.no_backdrop, seed=args.seed, denoise=args.denoise,
                   progress=progress, enhance_strength=args.enhance_strength,
                   enhance_radius=args.enhance_radius)
    if args.light is not None:
        options["light"] = args.light
    with progress.stage(f"render {args.mode} {size[0]}x{size[1]}"):
        if args.turntable is not None:
            frames = render_turntable(relief, frames=args.turntable, angle=args.angle,
                                      **options)
        else:
            frames = render(relief, **options)
    with progress.stage("write"), atomic_outputs(inputs=inputs) as group:
        written = write_renderings(frames, args.output, outputs=group)
    progress.summary()
    print(f"{args.mesh}: {args.mode} -> {', '.join(str(p) for p in written)}")
    return 0


def _cmd_check(args, progress):
    from inkray.formats.mesh_report import check_file, failed_requirements, format_report, parse_requirements
    from inkray.formats.atomic import atomic_outputs, check_targets

    if args.output:
        _check_output(args.output, (".json",))
        check_targets([args.output], inputs=[args.mesh])
    required = parse_requirements(args.require or "")
    with progress.stage("check"):
        report = check_file(args.mesh)
    if args.output:
        import json

        with atomic_outputs(inputs=[args.mesh]) as group:
            group.write_text(args.output, json.dumps(report, indent=2) + "\n")
    print(format_report(report))
    failed = failed_requirements(report, required)
    for req, parts in failed:
        print(f"inkray: check: requirement '{req}' failed for {', '.join(parts)}", file=sys.stderr)
    return 1 if failed else 0


def _cmd_demo(args, progress):
    from inkray.artefacts import ARTEFACTS
    from inkray.chain import ChainOptions, ReliefChain
    from inkray.examples import example_path
    from inkray.formats.atomic import atomic_outputs
    from inkray.formats.images import write_renderings
    from inkray.input.loading import load_input
    from inkray.view.rendering import GI_MAX_SIDE, GI_QUALITY, has_mitsuba, output_size, render

    path = example_path(args.example)
    out = Path(args.output)
    print(f"demo: {args.example} -> {out}/")
    ann, drawing = load_input(path)
    chain = ReliefChain(ann, drawing, options=ChainOptions(), progress=progress)
    w, h = ann.size
    print(f"{path}: ok: {w}x{h} drawing {drawing.path}, {len(ann.regions)} regions, "
          f"{len(ann.order)} order, {len(ann.equal)} equal, {len(ann.boundaries)} boundaries")
    depth = _beside(lambda: ARTEFACTS["depth"].make(chain.edit(progress=Progress(quiet=True))))
    made = {name: ARTEFACTS[name].make(chain) for name in ("regions", "labels", "relief")}
    relief = made["relief"]
    _warn(chain.warnings)
    with progress.stage("depth"):
        made["depth"] = depth()
    with progress.stage("render shade"):
        shaded = render(relief, mode="shade")
    gi = None
    if has_mitsuba():
        size = output_size(relief.size, max_side=GI_MAX_SIDE)
        with progress.stage(f"render gi {size[0]}x{size[1]}"):
            spp = args.spp if args.spp is not None else GI_QUALITY["draft"]
            gi = render(relief, mode="gi", size=size, spp=spp, progress=progress)
    else:
        print("demo: Mitsuba 3 is not installed, so no GI render (pip install 'inkray[render]')")
    with atomic_outputs() as group:
        written = []
        for name, file in (("labels", "labels.png"), ("depth", "depth.png"),
                           ("regions", "regions.json"), ("relief", "relief.glb")):
            written += ARTEFACTS[name].write(made[name], out / file, chain=chain, outputs=group)
        written += write_renderings(shaded, out / "shaded.png", outputs=group)
        if gi is not None:
            written += write_renderings(gi, out / "gi.png", outputs=group)
    progress.summary()
    print(f"demo: done; {len(written)} files in {out}/: "
          f"{', '.join(sorted({p.name for p in written}))}")
    return 0


def _cmd_layers(args, progress):
    if args.pad < 0:
        raise InputError(f"--pad {args.pad}: expected a whole number of pixels >= 0")
    _, stack, _ = _produce(args, progress, "layers", args.output,
                           options=dict(predict=not args.no_predict),
                           params=dict(pad=args.pad, split_local=args.split_local,
                                       background=args.background),
                           warn=lambda chain, stack: chain.warnings + stack.warnings,
                           stage="layers")
    split = f", {len(stack.splits)} split" if stack.split and stack.splits else ""
    print(f"{args.output}: {len(stack.layers)} layers back to front: "
          f"{', '.join(layer.name for layer in stack.layers)}{split}")
    return 0


def _cmd_transfer(args, progress):
    from inkray.input.drawing import load_drawing

    if Path(args.output).suffix.lower() != ".json":
        raise InputError(f"-o {args.output}: expected an annotation file (.inkray.json)")
    if args.report is not None and Path(args.report).suffix.lower() != ".json":
        raise InputError(f"--report {args.report}: expected a .json file")
    _in_range("--threshold", args.threshold, 0.0, 1.0, "match score")
    frame = load_drawing(args.frame_drawing, limits=_limits(args))
    _, t, written = _produce(args, progress, "transfer", args.output,
                             params=dict(frame=frame, threshold=args.threshold),
                             write=dict(report=args.report), stage="transfer",
                             warn=lambda chain, t: t.warnings)
    checks = sum(e.flagged for e in t.entries)
    print(f"{args.output}: {len(t.entries)} entries carried to {args.frame_drawing}, match "
          f"{t.confidence:.2f}, {checks} to check"
          + (f" (report {args.report})" if args.report is not None else ""))
    return 0


def _cmd_pose(args, progress):
    from inkray.artefacts import ARTEFACTS
    from inkray.formats.atomic import check_targets
    from inkray.input.pose import load_pose

    suffix = Path(args.output).suffix.lower()
    name = ("posed-animation" if not suffix else "posed" if suffix == ".png" else
            "posed-layers" if suffix in (".psd", ".ora") else "posed-relief")
    pose = load_pose(args.pose, limits=_limits(args))
    single = name != "posed-animation"
    if not single and args.frame is not None:
        raise InputError(f"--frame {args.frame}: a folder gets every frame; give a file name "
                         f"(.png, .psd, ...) for one frame")
    write = {} if single else dict(frames=pose.frames, fps=args.fps)
    try:
        files = ARTEFACTS[name].files(args.output, **write)
    except InputError as e:
        raise InputError(f"-o {e}") from None
    check_targets(files, inputs=[args.pose])
    _, value, written = _produce(args, progress, name, args.output,
                                 options=dict(predict=not args.no_predict),
                                 params=dict(pose=pose, **(dict(frame=args.frame) if single else {})),
                                 write=write, warn=lambda chain, value: chain.warnings,
                                 stage="pose")
    what = f"{len(pose.frames)} frames and {written[-1].name}" if not single else \
        f"{len(pose.handles)} handles, frame {args.frame if args.frame is not None else pose.keys[0].frame}"
    print(f"{args.output}: posed ({what})")
    return 0


def _cmd_compose(args, progress):
    from inkray.artefacts import ARTEFACTS
    from inkray.composition import compose
    from inkray.formats.atomic import atomic_outputs, check_targets
    from inkray.formats.layer_files import LAYER_SUFFIXES
    from inkray.input.scene import load_scene

    suffix = Path(args.output).suffix.lower()
    name = "composed" if suffix == ".png" else \
        "composed-layers" if suffix in LAYER_SUFFIXES else "composed-relief"
    artefact = ARTEFACTS[name]
    expected = ("composed", "composed-layers", "composed-relief")
    _check_output(args.output, tuple(s for n in expected for s in ARTEFACTS[n].suffixes))
    try:
        limits = Limits(pixels=args.max_pixels)
    except InputError:
        raise InputError(f"--max-pixels {args.max_pixels}: expected a positive integer") from None
    scene = load_scene(args.scene, limits=limits)
    inputs = [args.scene] + [p for d in scene.drawings for p in (d.annotation, d.pose) if p]
    check_targets(artefact.files(args.output), inputs=inputs)
    composition = compose(scene, progress=progress)
    with progress.stage("compose"):
        value = artefact.make(composition)
    with progress.stage("write"), atomic_outputs(inputs=inputs) as group:
        artefact.write(value, args.output, chain=composition, outputs=group)
    progress.summary()
    print(f"{args.output}: {len(scene.drawings)} drawings composed")
    return 0


def _cmd_batch(args, progress):
    from inkray.batch import run_batch

    try:
        report = run_batch(args.pattern, args.output, jobs=args.jobs, scheduler=args.scheduler,
                           workers=args.workers, progress=progress, keys=args.key or ())
    except KeyboardInterrupt:
        print(f"inkray: interrupted; finished frames are kept in {args.output}/ and skipped "
              f"when the batch runs again", file=sys.stderr)
        return 130
    counts = report["counts"]
    print(f"{args.output}/: {counts['done']} done, {counts['skipped']} skipped, "
          f"{counts['failed']} failed (report {Path(args.output) / 'batch-report.json'})")
    return 1 if counts["failed"] else 0


def _cmd_maps(args, progress):
    from inkray.view.ambient_occlusion import MAX_RADIUS

    if args.ao_radius is not None:
        _in_range("--ao-radius", args.ao_radius, 1, MAX_RADIUS, "radius in pixels")
    out = Path(args.output)
    if out.suffix:
        raise InputError(f"-o {out}: expected a folder (no suffix)")
    _, maps, written = _produce(args, progress, "maps", out,
                                params=dict(convention=args.convention, ao_radius=args.ao_radius),
                                warn=lambda chain, maps: chain.warnings, stage="maps")
    print(f"{out}/: {args.convention} normals, height, ambient occlusion and part IDs of "
          f"{len(maps.names)} regions ({', '.join(p.name for p in written)})")
    return 0


def _beside(compute):
    """Start ``compute()`` in a forked process when there is a core to spare.

    Returns a function that waits for the result (or computes it here, where
    there is no fork or no second core). The demo's depth map (the 2010
    method) shares nothing with the relief, so it runs beside it.
    """
    import multiprocessing
    import os

    if "fork" not in multiprocessing.get_all_start_methods() or (os.cpu_count() or 1) < 2:
        return compute
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)

    def child():
        try:
            send.send((True, compute()))
        except BaseException as e:  # re-raised in the parent
            send.send((False, e))

    worker = context.Process(target=child, daemon=True)
    worker.start()
    send.close()

    def result():
        try:
            ok, value = receive.recv()
        except EOFError:
            raise InkrayError("the depth map's worker process ended without a result") from None
        finally:
            worker.join()
        if not ok:
            raise value
        return value

    return result


def _cmd_edit(args, progress):
    from inkray.editor.server import serve
    from inkray.editor.session import EditSession

    if Path(args.annotation).suffix.lower() in (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp",
                                                ".webp"):
        from inkray.editor.shot import open_shot

        if args.drawing is not None:
            raise InputError(f"--drawing: {args.annotation} is a frame of a shot, whose "
                             f"annotation is carried from its keys; leave --drawing out")
        session = open_shot(args.annotation)
    else:
        session = EditSession(args.annotation, drawing=args.drawing)
    if session.restored:
        print(f"inkray edit: restored unsaved changes from {session.autosave} "
              f"({args.annotation} is unchanged until you save)", file=sys.stderr)
    try:
        serve(session, host=args.host, port=args.port, open_browser=not args.no_browser)
    except KeyboardInterrupt:
        pass
    return 0


_COMMANDS = {
    "validate": (_cmd_validate, "check an annotation file and its drawing"),
    "segment": (_cmd_segment, "segment the drawing into regions from the scribbles"),
    "regions": (_cmd_regions, "complete regions under occluders and predict depth order"),
    "depth": (_cmd_depth, "depth map from sparse depth (in)equalities"),
    "relief": (_cmd_relief, "bas-relief mesh (GLB, OBJ or PLY)"),
    "render": (_cmd_render, "render a relief mesh"),
    "check": (_cmd_check, "mesh-quality report"),
    "layers": (_cmd_layers, "layered cut-out (PSD or OpenRaster), parts completed where hidden"),
    "maps": (_cmd_maps, "sprite maps: normal, height, ambient occlusion, part IDs"),
    "transfer": (_cmd_transfer, "carry a key frame's annotation to another frame of the shot"),
    "compose": (_cmd_compose, "several annotated drawings, placed and posed, in one picture "
                              "(PNG), layer stack (PSD/ORA) or relief (GLB/OBJ/PLY)"),
    "pose": (_cmd_pose, "pose the drawing by moving handles (PNG, PSD/ORA, GLB/OBJ/PLY or frames)"),
    "batch": (_cmd_batch, "run jobs on many frames on Dask (local or a cluster)"),
    "demo": (_cmd_demo, "run the main job on a bundled example"),
    "edit": (_cmd_edit, "annotate in the browser with live depth and relief previews"),
}


def _parser():
    def flags(default):
        common = argparse.ArgumentParser(add_help=False)
        common.add_argument("--debug", action="store_true", default=default, help="show tracebacks")
        common.add_argument("--quiet", action="store_true", default=default,
                            help="no progress output")
        common.add_argument("--timings", action="store_true", default=default,
                            help="print the time of every stage at the end")
        return common

    # Subcommands must not reset a flag given before the command name.
    common = flags(argparse.SUPPRESS)
    parser = _Parser(prog="inkray", parents=[flags(False)],
                     description="Depth maps and bas-relief meshes from hand-drawn line drawings.")
    parser.add_argument("--version", action="version", version=f"inkray {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    p = {}
    for name, (_, help_) in _COMMANDS.items():
        p[name] = sub.add_parser(name, help=help_, description=help_, parents=[common])
    for name in ("validate", "segment", "regions", "depth", "relief", "layers", "maps", "pose"):
        _add_input(p[name])
    p["validate"].add_argument("--json", action="store_true",
                               help="print the result as JSON on stdout (problems with "
                                    "severity, key and message)")
    for name in ("segment", "regions", "depth", "relief"):
        p[name].add_argument("-o", "--output", required=True, metavar="PATH", help="output file")
    rl = p["relief"]
    rl.add_argument("--closed", action="store_true",
                    help="closed solids: every part mirrored to the back")
    rl.add_argument("--union", action="store_true",
                    help="with --closed: one watertight solid, the union of the parts, named "
                         "after the output file")
    rl.add_argument("--no-predict", action="store_true",
                    help="use only the annotation's order entries, predict nothing")
    rl.add_argument("--max-area", type=float, default=50.0, metavar="PX2",
                    help="largest triangle area in px^2, the mesh resolution (default: 50)")
    rl.add_argument("--epsilon", type=float, metavar="PX",
                    help="depth step between a part and the part behind, in drawing pixels "
                         "(default: 0.4%% of the drawing's longer side)")
    rl.add_argument("--units-per-pixel", type=float, default=0.001, metavar="S",
                    help="scene units per drawing pixel (default: 0.001)")
    rl.add_argument("--anchor", choices=("center", "top-left"), default="center",
                    help="drawing point at the scene origin (default: center)")
    rl.add_argument("--back", choices=("double-sided", "plate", "none"), default="double-sided",
                    help="what open parts show from behind: double-sided materials (GLB), a "
                         "flat plate closing every part, or nothing (default: double-sided)")
    rl.add_argument("--up", choices=("y", "z"),
                    help="up axis of OBJ and PLY files: z for importers that assume Z up, "
                         "such as Blender's PLY importer (default: y; GLB is always y)")
    rl.add_argument("--depth-scale", type=float, default=1.0, metavar="S",
                    help="multiply every height by S: below 1 a shallower relief, every depth "
                         "order kept (default: 1)")
    rl.add_argument("--depth-png", nargs="?", const=True, metavar="PNG",
                    help="also write a 16-bit front depth image (default name: OUT-depth.png)")
    rl.add_argument("--normals-png", nargs="?", const=True, metavar="PNG",
                    help="also write a front normal map (default name: OUT-normals.png)")
    p["validate"].add_argument("--predict", action="store_true",
                               help="also list the predicted order "
                                    "relations with their confidence")
    p["regions"].add_argument("--masks", metavar="DIR",
                              help="also write each completed region as DIR/NAME.png")
    p["regions"].add_argument("--no-predict", action="store_true",
                              help="use only the annotation's order entries, predict nothing")
    p["segment"].add_argument("--npy", metavar="NPY",
                              help="also write the labels as an int32 array (-1 background)")
    p["depth"].add_argument("--method", choices=("exact", "fast"), default="exact",
                            help="exact QP or the interactive approximation (default: exact)")
    p["depth"].add_argument("--epsilon", type=float, default=1.0, metavar="E",
                            help="depth step of an order entry, in the depth map's own unit "
                                 "(default: 1)")
    p["depth"].add_argument("--npy", metavar="NPY", help="also write the float depth (.npy)")
    p["depth"].add_argument("--normals", metavar="PNG", help="also write a normal map")
    p["depth"].add_argument("--shading", metavar="PNG",
                            help="also write a Lambert-shaded preview")
    r = p["render"]
    r.add_argument("mesh", metavar="MESH", help="mesh file (GLB, OBJ or PLY)")
    r.add_argument("-o", "--output", required=True, metavar="PNG",
                   help="output image (.png; with --turntable also .gif)")
    r.add_argument("--mode", choices=("shade", "normals", "depth", "stereo", "gi", "enhance"),
                   default="shade", help="what to render (default: shade)")
    r.add_argument("--size", metavar="WxH", help="image size (default: the drawing's; "
                   "gi: shrunk to fit 800)")
    r.add_argument("--width", type=int, metavar="PX", help="image width, height to match")
    r.add_argument("--height", type=int, metavar="PX", help="image height, width to match")
    r.add_argument("--light", nargs=3, type=float, metavar=("X", "Y", "Z"),
                   help="direction toward the light, x right, y up, z toward the viewer "
                        "(default: -1 1 1.5, upper left)")
    r.add_argument("--ambient", type=float, default=0.3,
                   help="shade/stereo: light on surfaces facing away, 0..1 (default: 0.3)")
    r.add_argument("--flat-colors", action="store_true",
                   help="one colour per part instead of the drawing's colours")
    r.add_argument("--quality", choices=("draft", "final"),
                   help="gi: draft (4 samples per pixel, denoised: a preview) or final (64, "
                        "denoised: converged, no blotches on smooth surfaces) (default: final; "
                        "with --turntable draft)")
    r.add_argument("--spp", type=int, help="gi: samples per pixel (default: the --quality's)")
    r.add_argument("--no-backdrop", action="store_true",
                   help="gi: no backdrop behind the relief (transparent background)")
    r.add_argument("--seed", type=int, default=0, help="gi: sampler seed (default: 0)")
    r.add_argument("--denoise", action=argparse.BooleanOptionalAction, default=True,
                   help="gi: filter the path tracer's noise guided by the relief's normals, "
                        "depth, parts and colours (default: on)")
    r.add_argument("--disparity", type=float, metavar="PX",
                   help="stereo: disparity of the highest point in pixels (default: 2%% of "
                        "the width)")
    r.add_argument("--enhance-strength", type=float, default=1.0, metavar="S",
                   help="enhance: how dark surfaces get behind occluding edges, 0..10 "
                        "(default: 1)")
    r.add_argument("--enhance-radius", type=float, default=8.0, metavar="PX",
                   help="enhance: reach of the darkening behind an edge in drawing pixels, "
                        "0.5..100 (default: 8)")
    r.add_argument("--turntable", type=int, metavar="N",
                   help="N frames swinging around the vertical axis: X-000.png ... or a GIF")
    r.add_argument("--angle", type=float, default=15.0,
                   help="turntable: largest angle in degrees (default: 15)")
    p["check"].add_argument("mesh", metavar="MESH", help="mesh file (GLB, OBJ or PLY)")
    p["check"].add_argument("-o", "--output", metavar="JSON", help="write the report as JSON")
    p["check"].add_argument("--require", metavar="LIST",
                            help="exit 1 unless every part meets these, comma-separated: "
                                 "watertight, manifold, edge-manifold, vertex-manifold, oriented, "
                                 "no-self-intersections, no-degenerate, no-duplicates; bounds "
                                 "min-angle=DEG, max-aspect=N, shells=N")
    ly = p["layers"]
    ly.add_argument("-o", "--output", required=True, metavar="PATH",
                    help="output file (.psd or .ora)")
    ly.add_argument("--pad", type=int, default=0, metavar="PX",
                    help="continue each part PX pixels further under the parts in front of it "
                         "(default: 0)")
    ly.add_argument("--split-local", action="store_true",
                    help="split a part that is over another at one place and under it at "
                         "another (interlocking) into two layers at the crossing")
    ly.add_argument("--background", action="store_true",
                    help="add a bottom layer: the drawing around the character, paper under it")
    ly.add_argument("--no-predict", action="store_true",
                    help="use only the annotation's order entries, predict nothing")
    p["maps"].add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    co = p["compose"]
    co.add_argument("scene", metavar="SCENE", help="scene file (.scene.json)")
    co.add_argument("-o", "--output", required=True, metavar="PATH",
                    help="the scene as a picture (.png), layers (.psd, .ora) or a relief "
                         "(.glb, .obj, .ply)")
    co.add_argument("--max-pixels", type=int, default=DEFAULT_LIMITS.pixels, metavar="N",
                    help=f"largest scene and drawing in pixels (default: {DEFAULT_LIMITS.pixels})")
    po = p["pose"]
    po.add_argument("pose", metavar="POSE", help="pose file (.pose.json)")
    po.add_argument("-o", "--output", required=True, metavar="PATH",
                    help="posed picture (.png), layers (.psd, .ora), relief (.glb, .obj, .ply), "
                         "or a folder: one PNG per frame and preview.gif")
    po.add_argument("--frame", type=int, metavar="N",
                    help="the frame of a single-file output (default: the first key's)")
    po.add_argument("--fps", type=int, default=12, metavar="N",
                    help="frame rate of the folder's preview.gif (default: 12)")
    po.add_argument("--no-predict", action="store_true",
                    help="use only the annotated depth order (no predicted relations)")
    p["maps"].add_argument("--convention", choices=("opengl", "directx"), default="opengl",
                           help="normal map's green channel: opengl y up (Godot, Unity, Blender) "
                                "or directx y down (Unreal) (default: opengl)")
    p["maps"].add_argument("--ao-radius", type=float, metavar="PX",
                           help="ambient occlusion radius, 1..1e6 (default: 3%% of the longer side)")
    tr = p["transfer"]
    _add_input(tr)
    tr.add_argument("frame_drawing", metavar="FRAME", help="the frame's drawing (same size as the key's)")
    tr.add_argument("-o", "--output", required=True, metavar="PATH",
                    help="the frame's annotation file (.inkray.json)")
    tr.add_argument("--report", metavar="JSON",
                    help="also write every entry's movement and match score")
    tr.add_argument("--threshold", type=float, default=0.6, metavar="S",
                    help="name entries matching worse than S (0..1) as to check (default: 0.6)")
    b = p["batch"]
    b.add_argument("pattern", metavar="PATTERN",
                   help="annotation files, a glob in quotes ('shots/**/*.inkray.json'); with "
                        "--key the shot's drawings ('shot/*.png')")
    b.add_argument("--key", action="append", metavar="ANN",
                   help="a key frame's annotation (repeatable): every frame without one is "
                        "annotated by carrying the nearest key to it frame by frame")
    b.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    b.add_argument("--jobs", default="relief,render,layers,maps", metavar="LIST",
                   help="comma-separated jobs per frame: relief, render, layers, maps, pose "
                        "(X.pose.json beside X.inkray.json) (default: relief,render,layers,maps)")
    b.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler (tcp://host:8786); default: a local cluster")
    b.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    p["demo"].add_argument("-o", "--output", default="inkray-demo", metavar="DIR",
                           help="output folder (default: inkray-demo)")
    p["demo"].add_argument("--example", default="turtle", help="bundled example (default: turtle)")
    p["demo"].add_argument("--spp", type=int,
                           help="samples per pixel of the GI render, denoised (default: render's "
                                "--quality draft, 4)")
    ed = p["edit"]
    ed.add_argument("annotation", metavar="ANN",
                    help="annotation file (.inkray.json); a new one is started when missing. "
                         "A drawing (FRAME.png) opens a frame of a shot: its folder's frames, "
                         "the annotation carried from the nearest key (FRAME.inkray.json)")
    ed.add_argument("--drawing", metavar="PATH",
                    help="drawing file (needed for a new annotation; overrides the 'drawing' key)")
    ed.add_argument("--host", default="127.0.0.1",
                    help="address to serve on (default: 127.0.0.1, this machine only)")
    ed.add_argument("--port", type=int, default=8765, help="port (default: 8765; 0: any free)")
    ed.add_argument("--no-browser", action="store_true", help="do not open a browser")
    return parser


#: Commands that wait in Python while their work runs elsewhere (so a signal is
#: handled at once) and clean up after themselves (a Dask cluster, a server):
#: the watchdog's kill would skip that.
_UNWIND_THEMSELVES = {"batch", "edit"}


def _run(argv, progress=None, *, watchdog=False):
    args = _parser().parse_args(argv)
    if progress is None:
        progress = Progress(quiet=args.quiet, timings=args.timings)
    if watchdog and args.command not in _UNWIND_THEMSELVES:
        _arm_watchdog()
    return _COMMANDS[args.command][0](args, progress)


def main(argv=None):
    """Run the ``inkray`` command line; returns the exit code.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 ok, 1 failed on valid input, 2 bad input or usage.
    """
    return _main(argv)


def _main(argv=None, *, watchdog=False):
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    try:
        with _terminate_as_interrupt(), warnings.catch_warnings():
            if not debug:  # library warnings are not one line; inkray's own are printed
                warnings.simplefilter("ignore")
            return _run(argv, watchdog=watchdog)
    except SystemExit as e:  # --help and --version
        return e.code if isinstance(e.code, int) else 0
    except _UsageError as e:
        print(f"inkray: error: {_one_line(e)}", file=sys.stderr)
        return 2
    except InkrayError as e:
        if debug:
            traceback.print_exc()
        text = e.worded(_flag) if isinstance(e, InputError) else e
        print(f"inkray: error: {_one_line(text)}", file=sys.stderr)
        return e.exit_code
    except _Terminated as e:
        print(f"inkray: terminated; nothing was written", file=sys.stderr)
        return 128 + e.signum
    except KeyboardInterrupt:
        print("inkray: interrupted; nothing was written", file=sys.stderr)
        return 130
    except MemoryError:
        print("inkray: error: out of memory (try a smaller drawing)", file=sys.stderr)
        return 1
    except Exception as e:  # a bug: still one line unless --debug
        if debug:
            traceback.print_exc()
        print(f"inkray: internal error: {type(e).__name__}: {_one_line(e)} "
              f"(run with --debug for the traceback)", file=sys.stderr)
        return 1


class _Terminated(BaseException):
    """SIGTERM or SIGHUP, raised where the process is, so every output group unwinds."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def _terminate_as_interrupt():
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise _Terminated(signum)

    signums = [signal.SIGTERM] + ([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])
    previous = {n: signal.signal(n, handler) for n in signums}
    try:
        yield
    finally:
        for n, h in previous.items():
            signal.signal(n, h)


#: Seconds a signalled command has to end before its watchdog kills it.
_GRACE = 2.0


def _arm_watchdog(grace=_GRACE):
    """Kill the process if it has not ended ``grace`` s after SIGTERM, SIGHUP or SIGINT.

    Python runs a signal handler only between bytecodes, so a command inside one
    long native call (a sparse factorization, a triangulation) would ignore the
    signal until the call returns, minutes on a big drawing; so would the exit's
    wait for worker threads still inside such calls. A forked process learns of
    the signal through the interpreter's wakeup file (written by the C handler
    at once) and sends SIGKILL after the grace period, waiting while output
    files are being written into place. Outputs are only written at the end, so
    a kill before that leaves nothing behind. The watchdog lives as long as the
    process: it ends when its pipe does.
    """
    if not hasattr(os, "fork") or threading.current_thread() is not threading.main_thread():
        return
    from inkray.formats.atomic import COMMITTING

    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    sys.stdout.flush()
    sys.stderr.flush()
    parent = os.getpid()
    child = os.fork()
    if child == 0:  # pragma: no cover (runs in the forked process)
        _watch(read_end, write_end, parent, grace, COMMITTING)
    os.close(read_end)
    signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)

    def reap():  # at a normal exit, after the wait for threads
        signal.set_wakeup_fd(-1)
        os.close(write_end)
        os.waitpid(child, 0)

    atexit.register(reap)


def _watch(read_end, write_end, parent, grace, committing):  # pragma: no cover
    try:
        os.close(write_end)
        for n in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)):
            if n is not None:  # a signal to the process group is the parent's to handle
                signal.signal(n, signal.SIG_IGN)
        if not os.read(read_end, 1):
            os._exit(0)  # the command ended
        os.set_blocking(read_end, False)
        deadline = time.monotonic() + grace
        while time.monotonic() < deadline or committing[0]:
            time.sleep(0.02)
            try:
                if os.read(read_end, 4096) == b"":
                    os._exit(0)
            except BlockingIOError:
                pass
        os.write(2, b"inkray: killed: still busy %g s after the signal; nothing was written\n"
                 % grace)
        os.kill(parent, signal.SIGKILL)
    finally:
        os._exit(0)


#: Library parameters whose flag is not their name with dashes.
_FLAGS = {"limits.pixels": "--max-pixels", "limits.points": "--max-points",
          "frames": "--turntable"}


def _flag(parameter):
    """The flag of a library parameter an error names (``split_local`` -> ``--split-local``)."""
    return _FLAGS.get(parameter, "--" + parameter.replace("_", "-"))


def _one_line(e):
    """The message on one line, control characters escaped (a file name may hold any)."""
    text = " ".join(str(e).split())
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def entry():
    """Console-script entry point."""
    sys.exit(_main(watchdog=True))
