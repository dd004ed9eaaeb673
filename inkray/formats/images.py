"""Pictures to files: PNGs, numbered PNG frames and animated GIFs of renderings.

Colour renderings are 8-bit RGBA PNGs; depth renderings 16-bit depth PNGs in
the convention of :mod:`inkray.formats.depth_png` (0 background, 1..65535
far..near, range in the ``inkray:depth`` text chunk).
"""

from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs
from inkray.formats.depth_png import codes_png
from inkray.view.rendering import Rendering
from inkray.view.shading import over_white

__all__ = ["rendering_files", "write_renderings"]


def write_renderings(renderings, path, *, fps=12, outputs=None):
    """Write renderings as PNG(s) or an animated GIF, all files or none.

    One rendering to ``X.png`` writes ``X.png``; ``stereo`` also writes the
    views ``X-left.png`` and ``X-right.png``. Several renderings (a turntable)
    to ``X.png`` write frames ``X-000.png``, ``X-001.png``, ...; to ``X.gif``
    an animation over white. Depth maps are 16-bit greyscale PNGs whose text
    chunk ``inkray:depth`` records the depth range.

    Parameters
    ----------
    renderings : Rendering or list of Rendering
    path : str or Path
        ``.png`` or ``.gif``.
    fps : int, optional
        GIF frame rate.
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group to write into (its
        files then appear with the group's); default: a group of its own.

    Returns
    -------
    list of Path
        The files written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> img = np.zeros((2, 3, 4), np.uint8)
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "a.png"
    >>> [p.name for p in write_renderings(Rendering("shade", img, img[..., 3] > 0), out)]
    ['a.png']
    """
    from PIL import Image

    items = [renderings] if isinstance(renderings, Rendering) else list(renderings)
    path = Path(path)
    suffix = path.suffix.lower()
    if not items:
        raise InputError(f"{path}: nothing to write")
    if suffix not in (".png", ".gif"):
        raise InputError(f"-o {path}: expected .png or .gif")
    files = {}
    if suffix == ".gif":
        files[path] = [_gif_frame(r) for r in items]
    elif len(items) == 1:
        files[path] = items[0]
        for side, rgba in items[0].views.items():
            files[path.with_name(f"{path.stem}-{side}.png")] = rgba
    else:
        for k, r in enumerate(items):
            files[path.with_name(f"{path.stem}-{k:03d}.png")] = r
    if outputs is None:
        with atomic_outputs() as group:
            return write_renderings(items, path, fps=fps, outputs=group)
    for target, item in files.items():
        if isinstance(item, list):
            outputs.write_with(target, lambda f, item=item: item[0].save(
                f, format="GIF", save_all=True, append_images=item[1:],
                duration=round(1000 / fps), loop=0, optimize=False))
        elif isinstance(item, np.ndarray):
            outputs.write_with(target, lambda f, item=item: Image.fromarray(item).save(
                f, format="PNG"))
        else:
            outputs.write_bytes(target, _png_bytes(item))
    return list(files)


def rendering_files(path, *, frames=None, mode=None):
    """Every file :func:`write_renderings` writes at ``path``, known before rendering.

    Parameters
    ----------
    path : str or Path
    frames : int, optional
        The number of renderings of a turntable; None for one.
    mode : str, optional
        The renderings' mode (``stereo`` adds its two views).

    Returns
    -------
    list of Path

    Examples
    --------
    >>> [p.name for p in rendering_files("spin.png", frames=2)]
    ['spin-000.png', 'spin-001.png']
    >>> [p.name for p in rendering_files("s.png", mode="stereo")]
    ['s.png', 's-left.png', 's-right.png']
    """
    path = Path(path)
    if path.suffix.lower() == ".gif":
        return [path]
    if frames is None or frames == 1:
        views = ("left", "right") if mode == "stereo" else ()
        return [path, *(path.with_name(f"{path.stem}-{side}.png") for side in views)]
    return [path.with_name(f"{path.stem}-{k:03d}.png") for k in range(frames)]


def _gif_frame(r):
    from PIL import Image

    if r.image.ndim == 2:  # depth: 16 -> 8 bit
        return Image.fromarray((r.image >> 8).astype(np.uint8)).convert("RGB")
    return Image.fromarray(np.rint(over_white(r.image) * 255).astype(np.uint8))


def _png_bytes(r):
    import io

    from PIL import Image

    if r.depth_range is not None:
        return codes_png(r.image, r.depth_range, units="drawing pixels")
    buffer = io.BytesIO()
    Image.fromarray(r.image).save(buffer, format="PNG")
    return buffer.getvalue()
