"""Posed drawings to files: a picture, layers, a relief, or an animation's frames.

The outputs of posing an annotated drawing (:mod:`inkray.view.posed`),
chosen by the output's suffix:

- ``.png``: the posed drawing, 8-bit RGBA, the character opaque and the rest
  transparent;
- ``.psd`` / ``.ora``: the posed cut-out layers (:mod:`inkray.formats.layer_files`);
- ``.glb`` / ``.obj`` / ``.ply``: the posed relief, the rest relief's parts,
  vertices and faces with moved ``(x, y)`` and the rest texture coordinates
  (:func:`inkray.formats.meshes.export_relief`), so that poses can be blended
  vertex by vertex;
- a name without a suffix: a directory of one PNG per frame,
  ``frame-<NNNN>.png`` (the frame number), and ``preview.gif`` of them over
  white.

Single-file outputs show one frame (default the first key's). Writes are
atomic: all files or none.
"""

from pathlib import Path

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs
from inkray.formats.images import write_renderings
from inkray.formats.layer_files import LAYER_SUFFIXES, write_layers
from inkray.formats.meshes import FORMATS as MESH_SUFFIXES
from inkray.formats.meshes import export_relief
from inkray.view.rendering import Rendering

__all__ = ["POSE_SUFFIXES", "write_pose", "pose_frame_name"]

POSE_SUFFIXES = (".png",) + tuple(LAYER_SUFFIXES) + tuple(MESH_SUFFIXES)


def pose_frame_name(frame):
    """The file name of one frame of an animation directory.

    Examples
    --------
    >>> pose_frame_name(7)
    'frame-0007.png'
    """
    return f"frame-{int(frame):04d}.png"


def write_pose(posed, pose, path, *, frame=None, fps=12, iterations=4, outputs=None):
    """Pose a drawing and write the result as ``path`` (see the module docstring).

    Parameters
    ----------
    posed : inkray.view.posed.PosedDrawing
        Prepared for ``pose``'s handles.
    pose : inkray.input.pose.Pose
    path : str or Path
        ``.png``, ``.psd``, ``.ora``, ``.glb``, ``.obj``, ``.ply``, or a
        directory (no suffix).
    frame : int, optional
        The frame of a single-file output; default the first key's.
    fps : int, default 12
        The animated preview's frame rate.
    iterations : int, default 4
        Local/global rounds per frame (more where a face would fold).
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group.

    Returns
    -------
    list of Path
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix and suffix not in POSE_SUFFIXES:
        raise InputError(f"{path}: unsupported output type {suffix} (expected "
                         f"{', '.join(POSE_SUFFIXES)} or a directory)")
    if outputs is None:
        with atomic_outputs(inputs=[p for p in (pose.source,) if p is not None]) as group:
            return write_pose(posed, pose, path, frame=frame, fps=fps, iterations=iterations,
                              outputs=group)
    if not suffix:
        written = []
        pictures = []
        for f, x in posed.frames(pose, iterations=iterations):
            rgba = posed.image(x)
            picture = Rendering("pose", rgba, rgba[..., 3] > 0)
            written += write_renderings(picture, path / pose_frame_name(f), outputs=outputs)
            pictures.append(picture)
        written += write_renderings(pictures, path / "preview.gif", fps=fps, outputs=outputs)
        return written
    f = pose.keys[0].frame if frame is None else int(frame)
    if not pose.keys[0].frame <= f <= pose.keys[-1].frame:
        raise InputError(f"frame: {f} lies outside the pose's frames {pose.keys[0].frame}.."
                         f"{pose.keys[-1].frame}")
    # Earlier frames warm-start the solve, so a frame looks as it does in the animation.
    x = None
    posed.posing.solver.reset()
    for g in range(pose.keys[0].frame, f + 1):
        x = posed.positions(pose.at(g), iterations=iterations)
    if suffix == ".png":
        rgba = posed.image(x)
        return write_renderings(Rendering("pose", rgba, rgba[..., 3] > 0), path, outputs=outputs)
    if suffix in LAYER_SUFFIXES:
        return write_layers(posed.layers(x), path, outputs=outputs)
    return export_relief(posed.relief(x), path, outputs=outputs)
