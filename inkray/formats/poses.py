"""An animation of a posed drawing as files: one PNG per frame and an animated preview.

The frames of a pose (:class:`inkray.input.pose.Pose`, posed by
:mod:`inkray.view.posed`) go into a directory as ``frame-<NNNN>.png`` (the
frame number; 8-bit RGBA, the character opaque, the rest transparent) and
``preview.gif`` (the frames over white). Writes are atomic: all files or none.
"""

from pathlib import Path

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs
from inkray.formats.images import write_renderings
from inkray.view.rendering import Rendering

__all__ = ["PREVIEW", "pose_frame_name", "animation_files", "write_animation"]

#: The animated preview's name in an animation directory.
PREVIEW = "preview.gif"


def pose_frame_name(frame):
    """The file name of one frame of an animation directory.

    Examples
    --------
    >>> pose_frame_name(7)
    'frame-0007.png'
    """
    return f"frame-{int(frame):04d}.png"


def animation_files(directory, frames):
    """Every file :func:`write_animation` writes for ``frames`` (frame numbers).

    Examples
    --------
    >>> [p.name for p in animation_files("out", [0, 1])]
    ['frame-0000.png', 'frame-0001.png', 'preview.gif']
    """
    directory = Path(directory)
    return [directory / pose_frame_name(f) for f in frames] + [directory / PREVIEW]


def write_animation(frames, directory, *, fps=12, outputs=None):
    """Write an animation's frames as numbered PNGs and an animated GIF preview.

    Parameters
    ----------
    frames : list of (int, (H, W, 4) uint8 array)
        ``(frame number, RGBA picture)``.
    directory : str or Path
    fps : int, default 12
        The preview's frame rate.
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group.

    Returns
    -------
    list of Path

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> img = np.zeros((2, 2, 4), np.uint8)
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "walk"
    >>> [p.name for p in write_animation([(3, img), (4, img)], out)]
    ['frame-0003.png', 'frame-0004.png', 'preview.gif']
    """
    if not frames:
        raise InputError(f"{directory}: no frames to write")
    if not (isinstance(fps, int) and 1 <= fps <= 100):
        raise InputError(f"fps: expected a whole number within 1..100, got {fps!r}", option="fps")
    if outputs is None:
        with atomic_outputs() as group:
            return write_animation(frames, directory, fps=fps, outputs=group)
    directory = Path(directory)
    written, pictures = [], []
    for f, rgba in frames:
        picture = Rendering("pose", rgba, rgba[..., 3] > 0)
        written += write_renderings(picture, directory / pose_frame_name(f), outputs=outputs)
        pictures.append(picture)
    written += write_renderings(pictures, directory / PREVIEW, fps=fps, outputs=outputs)
    return written
