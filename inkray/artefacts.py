"""The artefacts: every output inkray makes, declared once for every front end.

An :class:`Artefact` names the stages of the chain it reads
(:class:`~inkray.chain.ReliefChain`, after Sýkora et al., "Ink-and-Ray", TOG
2014, and "Adding Depth to Cartoons Using Sparse Depth (In)equalities", CGF
2010), its compute step, the files it is written as (a writer per suffix,
joining an :func:`~inkray.formats.atomic.atomic_outputs` group) and the bytes
of its preview with their media type. The front ends are adapters over
:data:`ARTEFACTS`: the CLI turns its arguments into parameters, batch runs
artefacts on Dask, the editor serves previews looked up here. So one input
gives the same bytes from each.

Examples
--------
>>> from inkray.chain import ReliefChain
>>> from inkray.examples import example_path
>>> from inkray.input.loading import load_input
>>> chain = ReliefChain(*load_input(example_path("turtle")))
>>> labels = ARTEFACTS["labels"]
>>> labels.reads, labels.media_type, labels.suffixes
(('segmentation',), 'image/png', ('.png',))
>>> labels.encode(labels.make(chain))[:8]
b'\\x89PNG\\r\\n\\x1a\\n'
"""

import json
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Mapping

from inkray.errors import InputError
from inkray.formats.atomic import memory_outputs

__all__ = ["ARTEFACTS", "Artefact", "Writer", "artefact_files"]


@dataclass(frozen=True)
class Writer:
    """How an artefact's value becomes files for one output suffix.

    Attributes
    ----------
    write : callable
        ``write(value, target, *, chain, outputs, **params)`` adds the files
        to ``outputs`` and returns their paths.
    files : callable
        ``files(target, **params)``: every path ``write`` will write, known
        before any work so that targets can be checked first.
    """

    write: Callable
    files: Callable = lambda target, **params: [Path(target)]


@dataclass(frozen=True)
class Artefact:
    """One kind of output, from the chain stages it reads to its file bytes.

    Attributes
    ----------
    name : str
    reads : tuple of str
        The :class:`~inkray.chain.ReliefChain` attributes its compute step reads.
    compute : callable
        ``compute(chain, **params)``, its value. The scene artefacts
        (``composed``, ``composed-layers``, ``composed-relief``) take a
        scene's :class:`~inkray.composition.Composition` in place of a chain.
    writers : mapping of str to Writer
        By output suffix (``""`` for a folder).
    encode : callable
        ``encode(value, **params)``, the bytes of its preview.
    media_type : str
        The media type of those bytes.
    needs : str, optional
        What it needs regions for (``"a relief needs"``): without regions,
        :meth:`make` refuses it up front.
    """

    name: str
    reads: tuple
    compute: Callable
    writers: Mapping = field(default_factory=dict)
    encode: Callable = None
    media_type: str = "application/octet-stream"
    needs: str = None

    @property
    def suffixes(self):
        """The output suffixes it can be written as."""
        return tuple(self.writers)

    def check(self, annotations):
        """Refuse annotations it cannot be made of (no regions where it needs them).

        Raises
        ------
        InputError
        """
        if self.needs is not None and not annotations.regions:
            raise InputError(f"regions: {self.needs} at least one region")

    def make(self, chain, **params):
        """Its value for ``chain``.

        Raises
        ------
        InputError
            The chain's annotations cannot give it.
        """
        if self.needs is not None:
            self.check(chain.annotations)
        return self.compute(chain, **params)

    def preview(self, chain, **params):
        """The bytes of its preview for ``chain`` (``params`` go to compute and encode)."""
        return self.encode(self.make(chain, **params), **params)

    def writer(self, target):
        """The :class:`Writer` of ``target``'s suffix.

        Raises
        ------
        InputError
            No writer for that suffix; the message starts with the target.
        """
        suffix = Path(target).suffix.lower()
        if suffix not in self.writers:
            expected = ", ".join(s or "a folder (no suffix)" for s in self.writers)
            raise InputError(f"{target}: unsupported output type {suffix or '(none)'} "
                             f"(expected {expected})")
        return self.writers[suffix]

    def files(self, target, **params):
        """Every path :meth:`write` writes for ``target`` with ``params``."""
        return [Path(p) for p in self.writer(target).files(target, **params) if p is not None]

    def write(self, value, target, *, chain, outputs, **params):
        """Add the files of ``value`` at ``target`` to the group ``outputs``; their paths."""
        return self.writer(target).write(value, target, chain=chain, outputs=outputs, **params)


def artefact_files(artefact, value, target, *, chain, **params):
    """The files of ``value`` written at the relative path ``target``, as bytes in memory.

    Parameters
    ----------
    artefact : Artefact
    value
        From :meth:`Artefact.make`.
    target : str
        A relative path (``"relief.glb"``, ``"maps"``).
    chain : inkray.chain.ReliefChain
    **params
        The writer's parameters.

    Returns
    -------
    dict
        ``{relative posix path: bytes}``.
    """
    with memory_outputs() as group:
        artefact.write(value, target, chain=chain, outputs=group, **params)
    return group.files()


# -- the artefacts -----------------------------------------------------------------

def _labels_files(target, npy=None):
    from inkray.formats.labels import label_files

    return [*label_files(target), npy]


def _write_labels(seg, target, *, chain, outputs, npy=None):
    from inkray.formats.labels import write_labels

    return write_labels(seg, target, npy=npy, outputs=outputs)


def _encode_labels(seg):
    from inkray.formats.labels import labels_png

    return labels_png(seg)


def _regions(chain, *, masks=None):
    from inkray.formats.regions_report import regions_report

    return regions_report(chain.segmentation, chain.candidates, chain.completion, chain.relations,
                          predict=chain.options.predict, warnings=chain.warnings, masks=masks)


def _regions_files(target, masks=None):
    return [target, None if masks is None else Path(masks) / "region.png"]


def _write_regions(report, target, *, chain, outputs, masks=None):
    from inkray.formats.regions_report import write_regions_report

    return write_regions_report(report, target, completion=chain.completion, masks=masks,
                                outputs=outputs)


def _encode_json(doc):
    return (json.dumps(doc, indent=2, ensure_ascii=False) + "\n").encode("utf-8")


def _depth(chain, *, method=None, draft=False):
    changes = {}
    if method is not None and method != chain.options.depth_method:
        changes.update(depth_method=method, interactive=chain.options.interactive and method == "fast")
    if draft != chain.options.depth_draft:
        changes.update(depth_draft=draft)
    return (chain.edit(**changes) if changes else chain).depth_map


def _depth_files(target, npy=None, normals=None, shading=None):
    from inkray.formats.depth_png import depth_files

    return [*depth_files(target), npy, normals, shading]


def _write_depth(result, target, *, chain, outputs, npy=None, normals=None, shading=None):
    from inkray.formats.depth_png import write_depth_outputs

    return write_depth_outputs(result, target, npy=npy, normals=normals, shading=shading,
                               drawing=chain.drawing, outputs=outputs)


def _encode_depth(result, *, method=None, draft=False):
    from inkray.formats.depth_png import depth_png

    # zlib level 1 halves a 1 Mpx preview's encoding, same decoded depths; a draft
    # is read once over loopback and stored uncompressed.
    return depth_png(result.depth, compress_level=0 if draft else 1)[0]


def _relief(chain, *, depth_scale=1.0, name=None):
    relief = chain.relief
    if depth_scale != 1.0:
        from inkray.relief.backing import depth_scaled

        relief = depth_scaled(relief, depth_scale)
    if name is not None:  # one object (a union), named so that imports of several don't collide
        relief = replace(relief, parts=[replace(p, name=name) for p in relief.parts])
    return relief


def _relief_files(target, images=None, **export):
    from inkray.formats.meshes import export_files

    return [*export_files(target), *(images or {}).values()]


def _write_relief(relief, target, *, chain, outputs, images=None, **export):
    """The mesh file(s), then the renderings ``images`` ({mode: path}) of the relief."""
    from inkray.formats.images import write_renderings
    from inkray.formats.meshes import export_relief
    from inkray.view.rendering import render

    written = export_relief(relief, target, outputs=outputs, **export)
    for mode, path in (images or {}).items():
        write_renderings(render(relief, mode=mode), path, outputs=outputs)
        written.append(Path(path))
    return written


def _encode_glb(relief):
    from inkray.formats.meshes import glb_bytes

    return glb_bytes(relief)


def _shaded(chain):
    """``inkray render relief.glb``'s shaded image: the relief as read back from its GLB."""
    from inkray.formats.meshes import glb_bytes, read_relief
    from inkray.view.rendering import output_size, render

    with tempfile.TemporaryDirectory(prefix="inkray-") as folder:
        path = Path(folder) / "relief.glb"
        path.write_bytes(glb_bytes(chain.relief))
        relief = read_relief(path)
    return render(relief, mode="shade", size=output_size(relief.size), ambient=0.3)


def _write_image(image, target, *, chain, outputs):
    from inkray.formats.images import write_renderings

    return write_renderings(image, target, outputs=outputs)


def _encode_png(image):
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    return buf.getvalue()


def _layers(chain, *, pad=0, split_local=False, background=False):
    from inkray.relief.cutout import cut_out

    return cut_out(chain.completion, chain.relations, chain.drawing, pad=pad,
                   split_local=split_local, background=background)


def _write_layers(stack, target, *, chain, outputs):
    from inkray.formats.layer_files import write_layers

    return write_layers(stack, target, outputs=outputs)


def _encode_psd(stack):
    from inkray.formats.psd import psd_bytes

    return psd_bytes(stack)


def _maps(chain, *, convention="opengl", ao_radius=None):
    from inkray.formats.sprite_maps import sprite_maps

    seg = chain.segmentation
    return sprite_maps(chain.relief, seg.labels, seg.names, convention=convention,
                       ao_radius=ao_radius)


def _write_maps(maps, target, *, chain, outputs):
    from inkray.formats.sprite_maps import write_sprite_maps

    return write_sprite_maps(maps, target, outputs=outputs)


def _transfer(chain, *, frame, threshold=None):
    from inkray.transfer import CHECK, transfer_annotations

    t = transfer_annotations(chain.annotations, chain.drawing, frame,
                             key_labels=chain.segmentation.labels,
                             threshold=CHECK if threshold is None else threshold)
    t.annotations.drawing = frame.path
    return t


def _transfer_files(target, report=None, **params):
    return [target, report]


def _transfer_document(t, target):
    import os

    from inkray.formats.annotation_file import annotation_document

    drawing = t.annotations.drawing
    if drawing is not None:
        drawing = Path(os.path.relpath(Path(drawing).resolve(), Path(target).resolve().parent)).as_posix()
    return annotation_document(t.annotations, drawing=drawing)


def _write_transfer(t, target, *, chain, outputs, report=None, **params):
    from inkray.formats.annotation_file import annotation_text, transfer_report

    outputs.write_text(target, annotation_text(_transfer_document(t, target)))
    written = [Path(target)]
    if report is not None:
        doc = transfer_report(t, key=chain.annotations.source, frame=t.annotations.drawing)
        outputs.write_text(report, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
        written.append(Path(report))
    return written


def _encode_transfer(t, **params):
    from inkray.formats.annotation_file import annotation_text

    return annotation_text(_transfer_document(t, "frame.inkray.json")).encode("utf-8")


def _pose_of(chain, pose):
    """``pose``, or the pose file beside the chain's annotation file (batch)."""
    from inkray.input.pose import load_pose, pose_path

    if pose is not None:
        return pose
    source = chain.annotations.source
    path = None if source is None else pose_path(source)
    if path is None or not path.is_file():
        raise InputError(f"pose: no pose file{'' if path is None else f' {path}'} beside the "
                         f"annotation file", option="pose")
    return load_pose(path, size=chain.annotations.size)


def _posed(chain, pose):
    from inkray.view.posed import PosedDrawing

    return PosedDrawing(chain.relief, chain.completion, chain.relations, chain.drawing,
                        pose.handles, boundaries=chain.annotations.boundaries)


def _posed_image(chain, *, pose=None, frame=None):
    from inkray.view.rendering import Rendering

    pose = _pose_of(chain, pose)
    posed = _posed(chain, pose)
    rgba = posed.image(posed.at(pose, frame))
    return Rendering("pose", rgba, rgba[..., 3] > 0)


def _posed_layers(chain, *, pose=None, frame=None):
    pose = _pose_of(chain, pose)
    posed = _posed(chain, pose)
    return posed.layers(posed.at(pose, frame))


def _posed_relief(chain, *, pose=None, frame=None):
    pose = _pose_of(chain, pose)
    posed = _posed(chain, pose)
    return posed.relief(posed.at(pose, frame))


def _posed_frames(chain, *, pose=None):
    pose = _pose_of(chain, pose)
    posed = _posed(chain, pose)
    return [(f, posed.image(x)) for f, x in posed.frames(pose)]


def _write_posed_relief(relief, target, *, chain, outputs):
    from inkray.formats.meshes import export_relief

    return export_relief(relief, target, outputs=outputs)


def _animation_files(target, frames=(), fps=12):
    from inkray.formats.poses import animation_files

    return animation_files(target, frames)


def _write_animation(value, target, *, chain, outputs, frames=(), fps=12):
    from inkray.formats.poses import write_animation

    return write_animation(value, target, fps=fps, outputs=outputs)


def _encode_gif(frames):
    import io

    from PIL import Image

    from inkray.view.shading import over_white

    pictures = [Image.fromarray((over_white(rgba) * 255 + 0.5).astype("uint8")) for _, rgba in frames]
    buf = io.BytesIO()
    pictures[0].save(buf, format="GIF", save_all=True, append_images=pictures[1:], duration=83,
                     loop=0, optimize=False)
    return buf.getvalue()


def _composed_image(composition):
    from inkray.view.rendering import Rendering

    rgba = composition.image()
    return Rendering("compose", rgba, rgba[..., 3] > 0)


def _write_composed_relief(relief, target, *, chain, outputs):
    from inkray.formats.meshes import export_relief

    # vertices in scene pixels: the scene's top-left corner at the origin
    return export_relief(relief, target, anchor="top-left", outputs=outputs)


def _encode_composed_glb(relief):
    from inkray.formats.meshes import glb_bytes

    return glb_bytes(relief, anchor="top-left")


_LAYERS = Writer(_write_layers)
_POSED_RELIEF = Writer(_write_posed_relief)

#: Every artefact by name.
ARTEFACTS = {a.name: a for a in (
    Artefact("labels", reads=("segmentation",), compute=lambda chain: chain.segmentation,
             writers={".png": Writer(_write_labels, _labels_files)}, encode=_encode_labels,
             media_type="image/png"),
    Artefact("regions", reads=("segmentation", "candidates", "completion", "relations"),
             compute=_regions, writers={".json": Writer(_write_regions, _regions_files)},
             encode=_encode_json, media_type="application/json"),
    Artefact("depth", reads=("depth_map",), compute=_depth,
             writers={".png": Writer(_write_depth, _depth_files)}, encode=_encode_depth,
             media_type="image/png"),
    Artefact("relief", reads=("relief",), compute=_relief,
             writers={s: Writer(_write_relief, _relief_files) for s in (".glb", ".obj", ".ply")},
             encode=_encode_glb, media_type="model/gltf-binary", needs="a relief needs"),
    Artefact("shaded", reads=("relief",), compute=_shaded,
             writers={".png": Writer(_write_image)}, encode=_encode_png, media_type="image/png",
             needs="a relief needs"),
    Artefact("layers", reads=("completion", "relations"), compute=_layers,
             writers={".psd": _LAYERS, ".ora": _LAYERS}, encode=_encode_psd,
             media_type="image/vnd.adobe.photoshop", needs="a layer stack needs"),
    Artefact("posed", reads=("relief", "completion", "relations"), compute=_posed_image,
             writers={".png": Writer(_write_image)}, encode=lambda r, **p: _encode_png(r.image),
             media_type="image/png", needs="posing needs"),
    Artefact("posed-layers", reads=("relief", "completion", "relations"), compute=_posed_layers,
             writers={".psd": _LAYERS, ".ora": _LAYERS}, encode=lambda s, **p: _encode_psd(s),
             media_type="image/vnd.adobe.photoshop", needs="posing needs"),
    Artefact("posed-relief", reads=("relief", "completion", "relations"), compute=_posed_relief,
             writers={s: _POSED_RELIEF for s in (".glb", ".obj", ".ply")},
             encode=lambda r, **p: _encode_glb(r), media_type="model/gltf-binary",
             needs="posing needs"),
    Artefact("posed-animation", reads=("relief", "completion", "relations"),
             compute=_posed_frames,
             writers={"": Writer(_write_animation, _animation_files)},
             encode=lambda frames, **p: _encode_gif(frames), media_type="image/gif",
             needs="posing needs"),
    Artefact("composed", reads=("placed",), compute=_composed_image,
             writers={".png": Writer(_write_image)}, encode=lambda r: _encode_png(r.image),
             media_type="image/png"),
    Artefact("composed-layers", reads=("placed",), compute=lambda composition: composition.layers(),
             writers={".psd": _LAYERS, ".ora": _LAYERS}, encode=_encode_psd,
             media_type="image/vnd.adobe.photoshop"),
    Artefact("composed-relief", reads=("placed",), compute=lambda composition: composition.relief(),
             writers={s: Writer(_write_composed_relief) for s in (".glb", ".obj", ".ply")},
             encode=_encode_composed_glb, media_type="model/gltf-binary"),
    Artefact("maps", reads=("relief", "segmentation"), compute=_maps,
             writers={"": Writer(_write_maps, lambda target, **p: [Path(target) / "maps.json"])},
             needs="sprite maps need"),
    Artefact("transfer", reads=("segmentation",), compute=_transfer,
             writers={".json": Writer(_write_transfer, _transfer_files)}, encode=_encode_transfer,
             media_type="application/json", needs="carrying an annotation needs"),
)}
