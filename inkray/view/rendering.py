"""Pictures of a relief: shading, normal and depth maps, stereo, global illumination.

The point of Ink-and-Ray (Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for
Adding Global Illumination Effects to Hand-Drawn Characters", TOG 2014) is the
picture: the relief, textured with the drawing's colours, is lit with global
illumination (soft shadows, self-shadowing, colour bleeding, glossy
reflections) and the drawing's ink is composited over the result with a
multiply, so the lines stay as crisp as drawn. The paper also names cheaper
uses of the same relief: 3D-like shading from its normals, normal and depth
maps for 2D compositing, and stereoscopic images; all are here.

Modes (see :func:`render`):

- ``shade``: Lambert + ambient + a small highlight from the interpolated
  normals (:mod:`inkray.rasterize`), ink multiplied on top.
- ``normals``: the front normal map (RGB = (n + 1) / 2, OpenGL convention:
  x right, y up, z toward the viewer).
- ``depth``: a 16-bit depth map, 0 = background, 1..65535 = far..near.
- ``stereo``: left/right ``shade`` views of an off-axis (sheared) camera pair
  and their red-cyan anaglyph; zero disparity at the drawing plane.
- ``gi``: a path-traced render with Mitsuba 3 (``scalar_rgb``): relief on a
  backdrop, a soft area light plus a dim sky, ink multiplied on top.
- ``enhance``: the drawing on the relief, unlit, darkened behind occluding
  edges by the high-pass of the relief's depth (Luft, Colditz and Deussen
  2006; :mod:`inkray.view.depth_enhancement`).

Frames: the light direction is given as ``(x right, y up, z toward the
viewer)``; a turntable ``yaw`` (degrees) moves an orthographic camera around
the vertical axis through the drawing's centre (positive: to the viewer's
right), the light stays with the relief.
"""

from dataclasses import dataclass, field

import numpy as np

from inkray.errors import InputError, StageError
from inkray.numerics.quantization import quantize16
from inkray.relief.model import Relief
from inkray.view.depth_enhancement import RADIUS, STRENGTH, check_enhancement, enhance
from inkray.view.rasterization import fit_view, rasterize, vertex_normals
from inkray.view.shading import over_white

__all__ = ["GI_MAX_SIDE", "MODES", "Rendering", "has_mitsuba", "output_size", "render",
           "render_turntable"]

MODES = ("shade", "normals", "depth", "stereo", "gi", "enhance")

# shade/stereo/ink: rasterized at 2x2 samples per pixel and box-filtered
# (antialiasing), up to this many output pixels; beyond, pixels are small
# enough and time and memory matter more.
_SUPERSAMPLE_MAX_PIXELS = 1 << 20
_INK_LEVEL = 0.6  # brightest channel (paper = 1) at and above which a pixel is not ink
_SPECULAR = 0.12
_SHININESS = 40.0
# Flat colours for parts whose drawing colour is (near) white: soft, distinct.
_PALETTE = np.array([[0.55, 0.75, 0.45], [0.95, 0.75, 0.35], [0.45, 0.65, 0.85],
                     [0.90, 0.55, 0.50], [0.75, 0.60, 0.85], [0.95, 0.85, 0.55],
                     [0.50, 0.80, 0.75], [0.85, 0.65, 0.45]])
_RIM = 6.0  # drawing pixels: reach of outline ink past the silhouette (half a thick stroke)
_GI_PASSES = 16  # progress granularity: spp is split over up to this many passes
GI_MAX_SIDE = 800  # default gi size: the drawing, shrunk to fit (path tracing is slow)
_BACKDROP = np.array([0.8, 0.8, 0.78])  # linear reflectance of the gi backdrop
_MIN_ALBEDO = 0.02  # gi denoising: irradiance = radiance / albedo, kept finite on black
# gi denoising: the luminance stop, in standard deviations of the noise of
# the passes' mean (4 in SVGF; 16 is measured best here: benchmarks/bench_gi.py)
_GI_SIGMA_LUMINANCE = 16.0
_LUMA = np.array([0.2126, 0.7152, 0.0722])  # linear RGB -> luminance (Rec. 709)


@dataclass
class Rendering:
    """One rendered picture.

    Attributes
    ----------
    mode : str
    image : array
        ``(h, w, 4)`` uint8 RGBA (alpha = relief coverage; opaque for ``gi``
        with a backdrop), or ``(h, w)`` uint16 for ``depth``. For ``stereo``
        the anaglyph.
    mask : (h, w) bool array
        Pixels the relief covers (for ``stereo``: in either view).
    views : dict
        ``stereo``: ``{"left": rgba, "right": rgba}``; empty otherwise.
    depth_range : (float, float) or None
        ``depth``: the view depths (drawing pixels) mapped to 1 and 65535.
    """

    mode: str
    image: np.ndarray
    mask: np.ndarray
    views: dict = field(default_factory=dict)
    depth_range: tuple = None


def has_mitsuba():
    """True when Mitsuba 3 with the ``scalar_rgb`` variant can be imported.

    Returns
    -------
    bool

    Examples
    --------
    >>> isinstance(has_mitsuba(), bool)
    True
    """
    try:
        _mitsuba()
    except StageError:
        return False
    return True


def output_size(drawing_size, *, size=None, width=None, height=None, max_side=None):
    """The image size for a drawing: given, or derived with its aspect ratio kept.

    Parameters
    ----------
    drawing_size : (int, int)
        ``(W, H)`` of the drawing.
    size : (int, int), optional
        Both sides; excludes ``width`` and ``height``.
    width, height : int, optional
        One side; the other follows the drawing's aspect ratio.
    max_side : int, optional
        With nothing given: shrink the drawing's size to fit this.

    Returns
    -------
    (int, int)

    Examples
    --------
    >>> output_size((200, 100), width=50)
    (50, 25)
    >>> output_size((2000, 1000), max_side=800)
    (800, 400)
    """
    dw, dh = (int(v) for v in drawing_size)
    for name, v in (("width", width), ("height", height)):
        if v is not None and not (isinstance(v, (int, np.integer)) and 1 <= v <= 16384):
            raise InputError(f"{name}: expected an integer in 1..16384, got {v!r}", option=name)
    if size is not None:
        if width is not None or height is not None:
            raise InputError("size: give either a size or a width and height, not both",
                             option="size")
        return int(size[0]), int(size[1])
    if width is not None and height is not None:
        return int(width), int(height)
    if width is not None:
        return int(width), max(1, round(width * dh / dw))
    if height is not None:
        return max(1, round(height * dw / dh)), int(height)
    f = min(1.0, max_side / max(dw, dh)) if max_side else 1.0
    return max(1, round(dw * f)), max(1, round(dh * f))


def render(relief, *, mode="shade", size=None, light=(-1.0, 1.0, 1.5), ambient=0.3,
           flat_colors=False, disparity=None, spp=8, backdrop=True, yaw=0.0, seed=0,
           denoise=True, progress=None, frame_yaw=None, enhance_strength=STRENGTH[0],
           enhance_radius=RADIUS[0]):
    """Render a relief seen from the front (or from ``yaw`` degrees to the side).

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    mode : {"shade", "normals", "depth", "stereo", "gi", "enhance"}, optional
    size : (int, int), optional
        ``(width, height)`` of the image; the drawing is fitted and centred.
        Default: the drawing's size (for ``gi`` shrunk to fit 800 pixels).
    light : (3,) float, optional
        Direction toward the light, ``x`` right, ``y`` up, ``z`` toward the
        viewer (default: upper left, in front).
    ambient : float, optional
        ``shade``/``stereo``: the light a surface facing away still gets (0..1).
    flat_colors : bool, optional
        Colour each part with one colour (its drawing colour, or a palette
        colour where the drawing is white) instead of the drawing's colours.
    disparity : float, optional
        ``stereo``: horizontal shift in output pixels between the views at the
        relief's highest point (zero at height 0). Default: 2% of the width.
    spp : int, optional
        ``gi``: samples per pixel. Denoised, 8 are as close to a converged
        render as 64 without (``benchmarks/bench_gi.py``).
    backdrop : bool, optional
        ``gi``: put a matte backdrop behind the relief to catch its shadows.
        Without it the background is transparent.
    yaw : float, optional
        Camera angle (degrees) around the vertical axis through the drawing's
        centre; positive moves the camera to the viewer's right.
    seed : int, optional
        ``gi``: sampler seed (renders are deterministic for a seed).
    denoise : bool, optional
        ``gi``: filter the path tracer's noise, guided by the relief's own
        normals, depth, parts and colours (:mod:`inkray.view.denoising`), so
        a few samples per pixel look like many.
    frame_yaw : float, optional
        Turned views (not ``gi``): the image holds the relief as seen from any
        yaw up to this one, so nothing is cropped (default: ``yaw``; a
        turntable passes its largest angle so every frame has one scale).
    progress : inkray.progress.Progress, optional
        ``gi`` reports its passes on it.
    enhance_strength : float, optional
        ``enhance``: how dark the surfaces behind occluding edges get, 0..10
        (default 1; 0 is the plain drawing on the relief).
    enhance_radius : float, optional
        ``enhance``: how far behind an edge the darkening reaches, in drawing
        pixels, 0.5..100 (default 8).

    Returns
    -------
    Rendering

    Raises
    ------
    InputError
        An argument is out of range.
    StageError
        ``gi`` without Mitsuba 3.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.model import Part, Relief
    >>> v = np.array([[2, 2, 3], [8, 2, 3], [8, 8, 3], [2, 8, 3]], float)
    >>> sq = Part("square", v, np.array([[0, 3, 2], [0, 2, 1]]))
    >>> r = render(Relief([sq], size=(10, 10)), mode="shade", size=(20, 20))
    >>> r.image.shape, int(r.mask.sum())
    ((20, 20, 4), 144)
    """
    relief, size, light, yaw = _check(relief, mode, size, light, ambient, disparity, spp, yaw)
    check_enhancement(enhance_strength, enhance_radius, prefix="enhance_")
    frame = _frame_width(relief, abs(yaw) if frame_yaw is None else abs(float(frame_yaw)))
    if mode == "normals":
        return _normals(relief, size, yaw, frame)
    if mode == "depth":
        return _depth(relief, size, yaw, frame)
    layers = _Layers(relief, flat_colors)
    if mode == "shade":
        rgba = _shade(relief, layers, size, yaw, light, ambient, frame=frame)
        return Rendering("shade", rgba, rgba[..., 3] > 0)
    if mode == "stereo":
        return _stereo(relief, layers, size, yaw, light, ambient, disparity)
    if mode == "enhance":
        return _enhance(relief, layers, size, yaw, frame, enhance_strength, enhance_radius)
    return _gi(relief, layers, size, yaw, light, spp, backdrop, seed, denoise, progress)


def render_turntable(relief, *, frames=24, angle=15.0, mode="shade", progress=None, **options):
    """Frames of a camera swinging around the vertical axis (small angles).

    The yaw starts frontal, swings to ``angle``, over to ``-angle`` and back,
    piecewise linearly through frames that land exactly on both extremes, so
    no two consecutive frames show one view and the sequence loops; every
    frame has the scale that holds the relief at the largest angle, so
    nothing is cropped.

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    frames : int, optional
        Number of frames (>= 1).
    angle : float, optional
        Largest yaw in degrees (0..60: a relief is meant for near-frontal views).
    mode : str, optional
        As for :func:`render`.
    progress : inkray.progress.Progress, optional
        Reports frames done.
    **options
        Passed to :func:`render` (everything but ``yaw``).

    Returns
    -------
    list of Rendering

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.model import Part, Relief
    >>> v = np.array([[2, 2, 3], [8, 2, 3], [8, 8, 3], [2, 8, 3]], float)
    >>> sq = Part("square", v, np.array([[0, 3, 2], [0, 2, 1]]))
    >>> len(render_turntable(Relief([sq], size=(10, 10)), frames=3))
    3
    """
    if not (isinstance(frames, (int, np.integer)) and frames >= 1):
        raise InputError(f"turntable: frames must be a positive integer, got {frames!r}")
    if not (np.isfinite(angle) and 0 <= angle <= 60):
        raise InputError(f"turntable: angle must be within 0..60 degrees, got {angle!r}")
    if "yaw" in options:
        raise InputError("turntable: 'yaw' is set per frame; pass 'angle' instead")
    out = []
    first = max(1, round(frames / 4))
    knots = [0, first, max(first + 1, round(3 * frames / 4)), frames]
    yaws = np.interp(np.arange(frames), knots, [0.0, angle, -angle, 0.0])
    for k, yaw in enumerate(yaws.tolist()):
        # one frame: the render's own passes; several: one tick per frame
        inner = progress if frames == 1 else None
        out.append(render(relief, mode=mode, yaw=yaw, progress=inner, frame_yaw=angle,
                          **options))
        if progress is not None:
            progress.update(k + 1, frames)
    return out


# -- validation ----------------------------------------------------------------

def _check(relief, mode, size, light, ambient, disparity, spp, yaw):
    if not isinstance(relief, Relief):
        raise InputError(f"render: expected an inkray.relief.model.Relief, got {type(relief).__name__}")
    if mode not in MODES:
        raise InputError(f"render: unknown mode {mode!r} (expected one of {', '.join(MODES)})")
    if not relief.parts or not any(len(p.faces) for p in relief.parts):
        raise InputError("render: the relief has no triangles")
    if size is None:
        size = output_size(relief.size, max_side=GI_MAX_SIDE if mode == "gi" else None)
    if (len(size) != 2 or not all(isinstance(s, (int, np.integer)) for s in size)
            or not all(1 <= s <= 16384 for s in size)):
        raise InputError(f"render: size must be two integers in 1..16384, got {size!r}")
    light = np.asarray(light, float)
    if light.shape != (3,) or not np.all(np.isfinite(light)) or not np.linalg.norm(light) > 0:
        shown = " ".join(f"{v:g}" for v in light.ravel()[:6])
        raise InputError(f"render: light {shown}: expected a non-zero, finite direction x y z "
                         f"toward the light (e.g. -1 1 1.5)")
    if not (np.isfinite(ambient) and 0 <= ambient <= 1):
        raise InputError(f"render: ambient must be within 0..1, got {ambient!r}")
    if disparity is not None and not (np.isfinite(disparity) and abs(disparity) <= size[0]):
        raise InputError(f"render: disparity must be a number of pixels within the width, "
                         f"got {disparity!r}")
    if not (isinstance(spp, (int, np.integer)) and 1 <= spp <= 65536):
        raise InputError(f"render: spp must be an integer in 1..65536, got {spp!r}")
    if not (np.isfinite(yaw) and abs(yaw) < 90):
        raise InputError(f"render: yaw must be between -90 and 90 degrees, got {yaw!r}")
    return relief, (int(size[0]), int(size[1])), light / np.linalg.norm(light), float(yaw)


# -- camera --------------------------------------------------------------------

def _yaw_view(relief, yaw):
    """Affine view of a camera turned by ``yaw`` degrees about the vertical centre axis."""
    a = np.radians(yaw)
    c, s = np.cos(a), np.sin(a)
    cx = (relief.size[0] - 1) / 2.0  # pixel centres are integers
    return np.array([[c, 0, -s, cx - c * cx], [0, 1, 0, 0], [s, 0, c, -s * cx]])


def _frame_width(relief, yaw):
    """Width in drawing pixels that holds the relief seen from every yaw up to ``yaw``.

    At least the drawing's width; symmetric about its centre (the turning axis).
    """
    w = relief.size[0]
    if yaw == 0:
        return float(w)
    cx = (w - 1) / 2.0
    v = np.concatenate([np.asarray(p.vertices, float) for p in relief.parts])
    reach = 0.0
    for a in np.radians(np.linspace(-yaw, yaw, 9)):
        x = np.cos(a) * (v[:, 0] - cx) - np.sin(a) * v[:, 2]
        reach = max(reach, float(np.abs(x).max()) + 0.5)
    return max(float(w), 2 * reach * 1.02)


def _raster(relief, size, yaw, factor=1, shear=0.0, frame=None):
    """Rasterize at ``factor`` times ``size``, fitted and centred like the final image.

    ``frame`` is the width (drawing pixels) the image must hold: wider than
    the drawing for turned views (see :func:`_frame_width`).
    """
    w, h = size
    dw, dh = relief.size
    frame = float(dw) if frame is None else frame
    scale, offset = fit_view((frame, dh), size)
    offset = (offset[0] + (frame - dw) / 2 * scale, offset[1])
    view = _yaw_view(relief, yaw)
    view[0] += shear * view[2]  # x += shear * depth: an off-axis stereo camera
    return rasterize(relief, size=(w * factor, h * factor), scale=scale * factor,
                     offset=(offset[0] * factor, offset[1] * factor), view=view)


def _rim_uv(relief, raster):
    """Texture coordinates continued past the relief's silhouette, and where they apply.

    Segmentation leaves the outer half of an outline stroke outside the
    parts. Each pixel within ``_RIM`` drawing pixels of the silhouette takes
    the coordinates of the nearest relief pixel, continued by its offset at
    the front view's scale, so that half stroke follows its part in turned
    views too (exact in the front view).
    """
    from scipy import ndimage

    m = raster.mask
    if not m.any():
        return None, np.zeros_like(m)
    dist, (ri, ci) = ndimage.distance_transform_edt(~m, return_indices=True)
    rows, cols = np.indices(m.shape)
    w, h = relief.size
    uv = raster.uv[ri, ci] + np.stack([(cols - ci) / (raster.scale * w),
                                       (ri - rows) / (raster.scale * h)], axis=-1)
    return uv, ~m & (dist <= _RIM * raster.scale)


def _supersample(size):
    return 2 if size[0] * size[1] <= _SUPERSAMPLE_MAX_PIXELS else 1


def _downsample(a, factor):
    h, w = a.shape[0] // factor, a.shape[1] // factor
    return a.reshape(h, factor, w, factor, *a.shape[2:]).mean(axis=(1, 3))


# -- colours and ink -------------------------------------------------------------

def _srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _srgb_encode(c):
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


# sRGB encoding by table lookup: ~10x faster than the power law on megapixel
# images, and within 0.1 of an 8-bit level.
_SRGB_TABLE = _srgb_encode(np.linspace(0.0, 1.0, 16384))


def _linear_to_srgb(c):
    return _SRGB_TABLE[np.rint(np.clip(c, 0.0, 1.0) * 16383).astype(np.intp)]


class _Layers:
    """The drawing split into a fill texture (ink removed) and an ink multiplier.

    Ink is what is darker, in its brightest channel, than ``_INK_LEVEL`` of
    the paper (so saturated colours are not ink); the multiplier falls
    linearly from 1 there to 0 at black, keeping the antialiased edges of the
    strokes. Under ink the fill takes the colour of the nearest non-ink pixel,
    so shading and light bounces see the colours of the regions and not the
    lines. ``fill`` is sRGB, ``albedo`` and ``part_colors`` linear.
    """

    def __init__(self, relief, flat_colors):
        from scipy import ndimage

        self.relief = relief
        tex = relief.texture
        if tex is None:
            self.fill = np.ones((1, 1, 3))
            self.ink = np.ones((1, 1))
        else:
            tex = np.asarray(tex)
            if tex.ndim == 2:
                tex = np.repeat(tex[..., None], 3, axis=2)
            tex = tex[..., :3].astype(float) / (255.0 if tex.dtype == np.uint8 else 1.0)
            value = tex.max(axis=2)  # dark in every channel: saturated colours are not ink
            paper = max(float(np.percentile(value, 95)), 1e-3)
            self.ink = np.clip(value / (paper * _INK_LEVEL), 0.0, 1.0)
            clean = self.ink >= 1.0
            if clean.any():
                idx = ndimage.distance_transform_edt(~clean, return_distances=False,
                                                     return_indices=True)
                tex = tex[idx[0], idx[1]]
            self.fill = tex
        self.albedo = _srgb_to_linear(self.fill)
        self.part_colors = (_srgb_to_linear(self._part_colors(relief)) if flat_colors
                            else None)

    def _part_colors(self, relief):
        front = rasterize(relief, size=(self.fill.shape[1], self.fill.shape[0]))
        colors = np.empty((len(relief.parts), 3))
        for i in range(len(relief.parts)):
            seen = front.part == i
            c = np.median(self.fill[seen], axis=0) if seen.any() else np.ones(3)
            colors[i] = _PALETTE[i % len(_PALETTE)] if c.min() > 0.85 else c
        return colors

    def sample(self, raster, rim=False):
        """Linear albedo (0 where empty) and ink multiplier at every pixel of a raster.

        On the relief the ink is looked up through the surface's texture
        coordinates. Elsewhere it is 1, or, with ``rim``, the outer halves of
        outline strokes are added around the silhouette (see :func:`_rim_uv`).
        """
        m = raster.mask
        albedo = np.zeros(m.shape + (3,))
        if self.part_colors is not None:
            albedo[m] = self.part_colors[raster.part[m]]
        else:
            albedo[m] = _sample(self.albedo, raster.uv[m])
        ink = np.ones(m.shape)
        ink[m] = _sample(self.ink, raster.uv[m])
        if rim:
            uv, near = _rim_uv(self.relief, raster)
            ink[near] = _sample(self.ink, uv[near], outside=1.0)
        return albedo, ink


def _sample(image, uv, outside=None):
    """Bilinear lookup of ``image`` at planar texture coordinates (v up).

    Off the image: the nearest edge pixel, or ``outside`` when given.
    """
    from scipy import ndimage

    h, w = image.shape[:2]
    rows = (1.0 - uv[:, 1]) * h - 0.5
    cols = uv[:, 0] * w - 0.5
    mode, cval = ("nearest", 0.0) if outside is None else ("constant", outside)
    if image.ndim == 2:
        return ndimage.map_coordinates(image, [rows, cols], order=1, mode=mode, cval=cval)
    return np.stack([ndimage.map_coordinates(image[..., c], [rows, cols], order=1, mode=mode,
                                             cval=cval) for c in range(image.shape[2])], 1)


# -- raster modes ------------------------------------------------------------------

def _normals(relief, size, yaw, frame=None):
    r = _raster(relief, size, yaw, frame=frame)
    n = r.normal * [1, -1, 1]  # relief frame (y down) -> OpenGL (y up)
    rgba = np.zeros(r.mask.shape + (4,), np.uint8)
    rgba[..., :3] = np.where(r.mask[..., None], np.rint((n + 1) * 127.5), 0).astype(np.uint8)
    rgba[..., 3] = np.where(r.mask, 255, 0)
    return Rendering("normals", rgba, r.mask)


def _depth(relief, size, yaw, frame=None):
    r = _raster(relief, size, yaw, frame=frame)
    img, depth_range = quantize16(r.depth, r.mask)
    return Rendering("depth", img, r.mask, depth_range=depth_range)


def _shade(relief, layers, size, yaw, light, ambient, shear=0.0, frame=None, lit=True):
    ss = _supersample(size)
    r = _raster(relief, size, yaw, ss, shear, frame)
    albedo, ink = layers.sample(r)
    lin = albedo
    if lit:
        l_dir = light * [1, -1, 1]  # user frame (y up) -> relief frame (y down)
        n = r.normal
        diffuse = np.clip(n @ l_dir, 0, None)
        half = l_dir + [0, 0, 1]
        half /= np.linalg.norm(half)
        spec = _SPECULAR * np.clip(n @ half, 0, None) ** _SHININESS
        lin = albedo * (ambient + (1 - ambient) * diffuse)[..., None] + spec[..., None]
    srgb = _linear_to_srgb(lin) * ink[..., None]
    cover = r.mask.astype(float)
    # premultiplied box filter, then un-premultiply
    rgb = _downsample(srgb * cover[..., None], ss)
    alpha = _downsample(cover, ss)
    rgb = np.divide(rgb, alpha[..., None], out=np.zeros_like(rgb), where=alpha[..., None] > 0)
    return _rgba8(rgb, alpha)


def _enhance(relief, layers, size, yaw, frame, strength, radius):
    """The drawing on the relief, unlit, darkened behind occluding edges."""
    rgba = _shade(relief, layers, size, yaw, None, 1.0, frame=frame, lit=False)
    r = _raster(relief, size, yaw, frame=frame)
    scale, _ = fit_view((relief.size[0] if frame is None else frame, relief.size[1]), size)
    rgb = enhance(rgba[..., :3] / 255.0, np.where(r.mask, r.depth, 0.0), mask=r.mask,
                  strength=strength, radius=radius, scale=scale)
    return Rendering("enhance", _rgba8(rgb, rgba[..., 3] / 255.0), rgba[..., 3] > 0)


def _rgba8(rgb, alpha):
    out = np.empty(alpha.shape + (4,), np.uint8)
    out[..., :3] = np.rint(np.clip(rgb, 0, 1) * 255)
    out[..., 3] = np.rint(np.clip(alpha, 0, 1) * 255)
    return out


def _stereo(relief, layers, size, yaw, light, ambient, disparity):
    if disparity is None:
        disparity = 0.02 * size[0]
    scale, _ = fit_view(relief.size, size)
    top = max(float(np.max(np.abs(p.vertices[:, 2]))) for p in relief.parts if len(p.vertices))
    # x shift (drawing pixels) per unit depth, half to each eye; near points
    # move right in the left view (crossed disparity: in front of the screen).
    shear = disparity / (2 * top * scale) if top > 0 else 0.0
    left = _shade(relief, layers, size, yaw, light, ambient, shear=shear)
    right = _shade(relief, layers, size, yaw, light, ambient, shear=-shear)
    # Each view over white; red from the left eye's luminance, green and blue
    # from the right eye's colour.
    lf, rf = (over_white(v) for v in (left, right))
    rgb = np.stack([lf @ [0.299, 0.587, 0.114], rf[..., 1], rf[..., 2]], axis=-1)
    alpha = np.maximum(left[..., 3], right[..., 3]) / 255.0
    return Rendering("stereo", _rgba8(rgb, alpha), alpha > 0,
                     views={"left": left, "right": right})


# -- global illumination (Mitsuba 3) ------------------------------------------------

def _mitsuba():
    try:
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
    except (ImportError, AttributeError, ValueError) as e:
        raise StageError("the 'gi' mode needs Mitsuba 3 with the scalar_rgb variant: "
                         f"pip install 'inkray[render]' ({type(e).__name__}: {e})") from e
    return mi


def _gi(relief, layers, size, yaw, light, spp, backdrop, seed, denoise, progress):
    mi = _mitsuba()
    mi.set_log_level(mi.LogLevel.Warn)
    w, h = size
    passes = min(_GI_PASSES, spp)
    counts = [spp // passes + (k < spp % passes) for k in range(passes)]
    # The ink never goes through the path tracer: it is looked up per pixel
    # (supersampled) and multiplied on top, so it is as sharp as the output.
    # With the backdrop (just behind the relief) the outer halves of outline
    # strokes are drawn on it; a transparent background keeps only the relief.
    ss = _supersample(size)
    r = _raster(relief, size, yaw, ss)
    albedo, ink = layers.sample(r, rim=backdrop)
    ink = _downsample(ink, ss)
    cover = _downsample(r.mask.astype(float), ss)
    guides = _gi_guides(r, albedo, ss, backdrop) if denoise else None
    acc = np.zeros((h, w, 4))
    moments = np.zeros((2, h, w))  # sums of n * L and n * L**2 of the passes' irradiance
    try:
        scene = mi.load_dict(_gi_scene(mi, relief, layers, size, yaw, light, backdrop))
        for k, n in enumerate(counts):
            img = np.asarray(mi.render(scene, seed=seed * _GI_PASSES + k, spp=n), float)
            acc += img * n
            if guides is not None and passes > 1:
                lum = (img[..., :3] / guides["albedo"]) @ _LUMA
                moments += [n * lum, n * lum * lum]
            if progress is not None:
                progress.update(k + 1, passes)
    except RuntimeError as e:  # Mitsuba reports its failures as RuntimeError
        raise StageError(f"gi: Mitsuba failed: {' '.join(str(e).split())}") from e
    img = acc / spp
    alpha = np.ones((h, w)) if backdrop else np.clip(img[..., 3], 0, 1)
    # without the backdrop Mitsuba's colour is premultiplied by its alpha
    lin = np.divide(img[..., :3], alpha[..., None], out=np.zeros((h, w, 3)),
                    where=alpha[..., None] > 0)
    if guides is not None:
        variance = None  # one pass shows no spread: no stop on luminance
        if passes > 1:
            mean = moments[0] / spp
            # var(one sample) = sum n_k (L_k - mean)^2 / (passes - 1); the image averages spp
            variance = np.maximum(moments[1] - spp * mean * mean, 0.0) / (passes - 1) / spp
            variance /= np.maximum(alpha, 1e-3) ** 2
        lin = _gi_denoise(lin, guides, variance, backdrop)
    return Rendering("gi", _rgba8(_linear_to_srgb(lin) * ink[..., None], alpha), cover > 0)


def _gi_guides(raster, albedo, ss, backdrop):
    """Output-resolution guides for :func:`inkray.view.denoising.atrous_denoise`.

    The albedo is box-filtered like the path tracer's pixels average it (the
    backdrop's own colour off the relief); normals likewise; a
    pixel is labelled with a part it sees at any sub-pixel (the backdrop or
    the empty background is -1), so partly covered pixels join a part.
    """
    m = raster.mask
    albedo = np.where(m[..., None], albedo, _BACKDROP if backdrop else 1.0)
    normal = np.where(m[..., None], raster.normal, [0.0, 0.0, 1.0])
    normal = _downsample(normal, ss)
    normal /= np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-9)
    h, w = m.shape[0] // ss, m.shape[1] // ss
    labels = raster.part.reshape(h, ss, w, ss).max(axis=(1, 3))
    return {"albedo": np.maximum(_downsample(albedo, ss), _MIN_ALBEDO), "normals": normal,
            "labels": labels}


def _gi_denoise(lin, guides, variance, backdrop):
    """Divide the albedo out, filter the (smooth) irradiance, multiply it back.

    Without the backdrop, pixels off the relief only hold the pixel filter's
    spill from its edge: they keep their own values.
    """
    from inkray.view.denoising import atrous_denoise

    irradiance = atrous_denoise(lin / guides["albedo"], normals=guides["normals"],
                                labels=guides["labels"], variance=variance,
                                sigma_luminance=_GI_SIGMA_LUMINANCE)
    out = irradiance * guides["albedo"]
    if not backdrop:
        out[guides["labels"] < 0] = lin[guides["labels"] < 0]
    return out


def _gi_scene(mi, relief, layers, size, yaw, light, backdrop):
    """Mitsuba scene dict. World: y up, z toward the viewer, image half-width = 1."""
    from mitsuba import ScalarTransform4f as T

    w, h = size
    scale, _ = fit_view(relief.size, size)
    k = 2.0 / w * scale  # drawing pixels -> world units (orthographic film spans x in [-1, 1])
    cx, cy = (relief.size[0] - 1) / 2.0, (relief.size[1] - 1) / 2.0
    a = np.radians(yaw)
    eye = [10 * np.sin(a), 0.0, 10 * np.cos(a)]
    scene = {
        "type": "scene",
        # hidden emitters: the sky lights the scene but leaves alpha 0 where nothing is hit
        "integrator": {"type": "path", "max_depth": 8, "hide_emitters": True},
        "sensor": {"type": "orthographic",
                   "to_world": T().look_at(origin=eye, target=[0, 0, 0], up=[0, 1, 0]),
                   "near_clip": 0.01, "far_clip": 100.0,
                   "film": {"type": "hdrfilm", "width": w, "height": h,
                            "pixel_format": "rgba", "rfilter": {"type": "gaussian"}},
                   # stratified samples: about half the noise of independent ones
                   "sampler": {"type": "multijitter"}},
        # a dim sky for soft ambient light
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.21, 0.23, 0.25]}},
    }
    # a soft, slightly warm area light toward `light`, facing the relief,
    # giving a white surface facing it a radiance of about 0.8
    dist, half = 6.0, 1.0
    pos = light * dist
    scene["sun"] = {"type": "rectangle",
                    "to_world": T().look_at(origin=pos.tolist(), target=[0, 0, 0],
                                            up=[0, 1, 0] if abs(light[1]) < 0.99 else [0, 0, 1])
                    @ T().scale([half, half, 1]),
                    "emitter": {"type": "area", "radiance": {
                        "type": "rgb",
                        "value": (0.8 * np.pi * dist ** 2 / (2 * half) ** 2
                                  * np.array([1.0, 0.97, 0.92])).tolist()}}}
    if layers.part_colors is None:
        fill = layers.albedo.astype(np.float32)
        texture = {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(fill)),
                   "filter_type": "bilinear", "wrap_mode": "clamp"}
    zmin = 0.0
    for i, p in enumerate(relief.parts):
        if not len(p.faces):
            continue
        v = np.asarray(p.vertices, float)
        zmin = min(zmin, float(v[:, 2].min()))
        world = np.stack([(v[:, 0] - cx) * k, (cy - v[:, 1]) * k, v[:, 2] * k], axis=1)
        normals = vertex_normals(v, p.faces) * [1, -1, 1]  # y down -> y up
        if layers.part_colors is None:
            color = texture
        else:
            color = {"type": "rgb", "value": layers.part_colors[i].tolist()}
        bsdf = mi.load_dict({"type": "twosided", "bsdf": {
            "type": "roughplastic", "distribution": "ggx", "alpha": 0.3,
            "diffuse_reflectance": color}})
        # Mitsuba's bitmap rows run top to bottom: v = (y + 0.5) / H, pixel
        # centres (integers) on texel centres.
        uv = np.stack([(v[:, 0] + 0.5) / relief.size[0], (v[:, 1] + 0.5) / relief.size[1]],
                      axis=1)
        scene[f"part{i}"] = _mesh(mi, f"part{i}", world, np.asarray(p.faces), normals, uv, bsdf)
    if backdrop:
        # just behind the lowest point, so the relief rests on it with contact shadows
        z = zmin * k - 1e-3
        scene["backdrop"] = {"type": "rectangle",
                             "to_world": T().translate([0, 0, z]) @ T().scale([20, 20, 1]),
                             "bsdf": {"type": "diffuse",
                                      "reflectance": {"type": "rgb",
                                                      "value": _BACKDROP.tolist()}}}
    return scene


def _mesh(mi, name, vertices, faces, normals, uv, bsdf):
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh(name, len(vertices), len(faces), props=props, has_vertex_normals=True,
                   has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    for key, data in (("vertex_positions", vertices), ("vertex_normals", normals),
                      ("vertex_texcoords", uv)):
        params[key] = type(params[key])(np.ascontiguousarray(data, np.float32).ravel())
    params["faces"] = type(params["faces"])(np.ascontiguousarray(faces, np.uint32).ravel())
    params.update()
    return mesh


