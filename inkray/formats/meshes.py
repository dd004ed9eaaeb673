"""Relief meshes to files: GLB, OBJ (+ MTL + PNG) and PLY, with the drawing as texture.

The relief of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014, section 6), is a
stack of region meshes that, seen from the front, reproduces the drawing;
planar texture coordinates map the drawing onto it. This module writes it in
the formats renderers open without fixes, and reads meshes (inkray's or
anyone's) back as named triangle meshes for :mod:`inkray.check`.

Scene frame of every written file: ``X`` right, ``Y`` up, ``Z`` toward the
viewer, ``units_per_pixel`` scene units per drawing pixel (default 0.001: a
1000 px tall drawing is 1 unit tall), on all three axes. ``anchor="center"``
puts the drawing's centre at the origin; ``anchor="top-left"`` puts its
top-left corner there (the drawing then covers ``X >= 0, Y <= 0``). Pixel
centres are at integer drawing coordinates (:mod:`inkray.relief`), so the
centre is pixel position ``((W - 1) / 2, (H - 1) / 2)`` and the top-left
corner ``(-0.5, -0.5)``. The
drawing plane (height 0) is ``Z = 0``. Front faces are counter-clockwise seen
from ``+Z`` (glTF's convention), so their normals point toward the viewer.
"""

import re
import threading
from pathlib import Path
from typing import NamedTuple

import numpy as np

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs
from inkray.formats.mesh_inspection import inspect_mesh_file
from inkray.input.limits import DEFAULT_LIMITS
from inkray.relief.model import Part, Relief
from inkray.view.rasterization import vertex_normals

__all__ = ["ANCHORS", "BACKS", "UPS", "FORMATS", "NamedMesh", "export_relief", "export_files", "glb_bytes",
           "mesh_counts", "pixel_coordinates", "read_meshes", "read_relief", "scene_coordinates"]

ANCHORS = ("center", "top-left")
FORMATS = (".glb", ".obj", ".ply")
#: What an open relief shows from behind: see :func:`export_relief`.
BACKS = ("double-sided", "plate", "none")
#: Up axes of OBJ and PLY files (GLB is Y up by the glTF specification).
UPS = ("y", "z")
# Z up: scene (x, y, z) -> file (x, -z, y), a rotation (the winding is kept).
_Z_UP = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])

# PLY header comments carrying what GLB keeps in its scene extras.
_PLY_PART = re.compile(r"^comment inkray part (\d+) (\S+)$")


class NamedMesh(NamedTuple):
    """One triangle mesh read from a file.

    Attributes
    ----------
    name : str
        Node, group or part name (the file's stem when the format has none).
    vertices : (n, 3) float array
        Positions in the file's frame (for inkray's files: the scene frame).
    faces : (m, 3) int array
        Vertex indices, in the file's winding.
    colors : (n, 3) uint8 array or None
        Vertex colours, where the file has them (PLY).
    normals : (n, 3) float array or None
        Vertex normals as the file stores them (GLB, PLY, OBJ), in the frame
        of ``vertices``; None where it has none.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    colors: np.ndarray = None
    normals: np.ndarray = None


def scene_coordinates(points, size, *, units_per_pixel=0.001, anchor="center"):
    """Drawing pixels ``(x, y down, z toward viewer)`` to the scene frame (y up).

    Parameters
    ----------
    points : (n, 3) array
        Positions in drawing pixels, as in :attr:`inkray.relief.model.Part.vertices`.
    size : (int, int)
        ``(width, height)`` of the drawing in pixels.
    units_per_pixel : float, optional
        Scene units per pixel, the same on every axis.
    anchor : {"center", "top-left"}, optional
        The drawing point put at the origin.

    Returns
    -------
    (n, 3) float array
        ``X`` right, ``Y`` up, ``Z`` toward the viewer.

    Examples
    --------
    >>> scene_coordinates([[99.5, 49.5, 10]], (200, 100), units_per_pixel=0.01)
    array([[0. , 0. , 0.1]])
    >>> scene_coordinates([[99.5, 49.5, 10]], (200, 100), units_per_pixel=0.01, anchor="top-left")
    array([[ 1. , -0.5,  0.1]])
    """
    _check_frame(units_per_pixel, anchor)
    p = np.asarray(points, float).reshape(-1, 3)
    x0, y0 = _origin(size, anchor)
    s = float(units_per_pixel)
    return np.stack([(p[:, 0] - x0) * s, (y0 - p[:, 1]) * s, p[:, 2] * s], axis=1)


def pixel_coordinates(points, size, *, units_per_pixel=0.001, anchor="center"):
    """Inverse of :func:`scene_coordinates`: scene frame back to drawing pixels.

    Parameters
    ----------
    points : (n, 3) array
        ``X`` right, ``Y`` up, ``Z`` toward the viewer, in scene units.
    size : (int, int)
        ``(width, height)`` of the drawing in pixels.
    units_per_pixel : float, optional
    anchor : {"center", "top-left"}, optional

    Returns
    -------
    (n, 3) float array
        ``(x, y down, z)`` in drawing pixels.

    Examples
    --------
    >>> pixel_coordinates([[0, 0, 0.1]], (200, 100), units_per_pixel=0.01)
    array([[99.5, 49.5, 10. ]])
    """
    _check_frame(units_per_pixel, anchor)
    p = np.asarray(points, float).reshape(-1, 3)
    x0, y0 = _origin(size, anchor)
    s = float(units_per_pixel)
    return np.stack([p[:, 0] / s + x0, y0 - p[:, 1] / s, p[:, 2] / s], axis=1)


def export_relief(relief, path, *, units_per_pixel=0.001, anchor="center", name=None,
                  back="double-sided", up="y", outputs=None):
    """Write a relief as GLB, OBJ (+ MTL + PNG) or PLY, chosen by ``path``'s suffix.

    - ``.glb``: one node and one mesh per part, named after it, the node at
      the part's centre (its vertices relative to it, so a part turns about
      itself in an editor); positions, vertex normals, planar UVs
      (``TEXCOORD_0``); one material (roughness 1, metallic 0) with the
      drawing embedded as PNG base-colour texture, both named ``name``, single-sided; scene
      ``extras = {"inkray": {"drawing_size": [W, H], "units_per_pixel": s,
      "anchor": anchor}}``. Indices are unsigned 32-bit; the texture sampler
      filters linearly (mipmapped) and clamps to the edge.
    - ``.obj``: a header comment ``# inkray drawing_size W H units_per_pixel
      s anchor a``; ``o``/``g`` per part, ``v``/``vt``/``vn`` and faces
      ``f v/vt/vn``; beside it ``<stem>.mtl`` and the texture
      ``<stem>_drawing.png``.
    - ``.ply``: binary little-endian, one mesh of all parts; per vertex
      position, normal, RGBA colour sampled (bilinearly) from the drawing and
      UV as ``s, t``; per face the part index ``part``; header comments
      ``comment inkray part <i> <name>`` and ``comment inkray drawing_size W H
      units_per_pixel s anchor a``.

    All files of one export are written together (or, on error, none).

    Parameters
    ----------
    relief : inkray.relief.model.Relief
        Vertices in drawing pixels (see :mod:`inkray.relief`).
    path : str or Path
        Output file; its suffix picks the format.
    units_per_pixel : float, optional
        Scene units per drawing pixel (all axes).
    anchor : {"center", "top-left"}, optional
        Drawing point put at the scene origin.
    name : str, optional
        Name of the material and the texture image (default: the file's stem),
        so that several imported reliefs keep their own.
    back : {"double-sided", "plate", "none"}, default "double-sided"
        What an open part shows from behind. ``"double-sided"``: a back of its
        own, one pixel behind its front (:func:`inkray.relief.backing.back_sheet`).
        ``"plate"``: closed by a flat plate just behind it
        (:func:`inkray.relief.backing.back_plate`). Both are watertight, seen
        from any side. ``"none"``: the surface alone. In every mode materials
        are single-sided, and faces turned more than about 84 degrees from the
        viewer (backs, walls, steep rims) show one texel of the part's paper
        (PLY: its colour) while the front shows the drawing; vertices shared
        by the two are written twice (OBJ: with two texture coordinates).
    up : {"y", "z"}, default "y"
        Up axis of OBJ and PLY files: ``"z"`` for importers that assume Z up
        (Blender's PLY importer), turning the scene so that the relief stands
        with its front toward -Y. GLB is always Y up.
    outputs : object from :func:`inkray.formats.atomic.atomic_outputs`, optional
        Write into this group (to commit the mesh with other files of one
        command); by default the export is its own group.

    Returns
    -------
    list of Path
        The files written (the mesh file first).

    Raises
    ------
    InputError
        Unknown suffix or anchor, non-positive scale, or a relief that is not
        valid (names, shapes, indices, texture size, vertices off the drawing's
        ``[-0.5, W - 0.5] x [-0.5, H - 0.5]``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from inkray.relief.model import Part, Relief
    >>> tri = Part("a", np.array([[0., 0, 0], [0, 9, 0], [9, 0, 0]]), np.array([[0, 1, 2]]))
    >>> r = Relief([tri], (10, 10), np.zeros((10, 10, 3), np.uint8))
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> [p.name for p in export_relief(r, d / "r.obj")]
    ['r.obj', 'r.mtl', 'r_drawing.png']
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"{path}: unsupported mesh type {suffix or '(none)'} "
                         f"(expected {', '.join(FORMATS)})")
    _check_frame(units_per_pixel, anchor)
    if up not in UPS or (suffix == ".glb" and up != "y"):
        raise InputError(f"up: {up!r}: expected {' or '.join(UPS)} (GLB is always y)")
    name = path.stem if name is None else str(name)
    if suffix == ".glb":
        files = {path: glb_bytes(relief, units_per_pixel=units_per_pixel, anchor=anchor,
                                 name=name, back=back)}
    else:
        relief = _backed(relief, back)
        meshes = _turned(_scene_meshes(relief, units_per_pixel, anchor), up)
        files = (_obj_files(relief, meshes, path, name, up, units_per_pixel, anchor)
                 if suffix == ".obj" else
                 {path: _ply_bytes(relief, meshes, units_per_pixel, anchor, up)})
    if outputs is None:
        with atomic_outputs() as out:
            for target, data in files.items():
                out.write_bytes(target, data)
    else:
        for target, data in files.items():
            outputs.write_bytes(target, data)
    return list(files)


def glb_bytes(relief, *, units_per_pixel=0.001, anchor="center", name="relief",
              back="double-sided"):
    """The GLB file of a relief, as bytes (what :func:`export_relief` writes to ``.glb``).

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    units_per_pixel, anchor, back
        As in :func:`export_relief`.
    name : str, default "relief"
        Material and texture name (``export_relief`` uses the file's stem).

    Returns
    -------
    bytes

    Examples
    --------
    >>> from inkray.relief.model import Part, Relief
    >>> tri = Part("a", np.array([[0., 0, 0], [0, 9, 0], [9, 0, 0]]), np.array([[0, 1, 2]]))
    >>> glb_bytes(Relief([tri], (10, 10), np.zeros((10, 10, 3), np.uint8)))[:4]
    b'glTF'
    """
    _check_frame(units_per_pixel, anchor)
    relief = _backed(relief, back)
    return _glb_bytes(relief, _scene_meshes(relief, units_per_pixel, anchor), units_per_pixel,
                      anchor, name)


def mesh_counts(relief, *, suffix=".glb", back="double-sided"):
    """``(vertices, faces)`` that :func:`export_relief` writes for ``relief``.

    The faces of the relief with its back; the vertices with those copied
    where the drawing meets the paper (GLB and PLY vertices, OBJ texture
    coordinates: an OBJ's ``v`` lines are the relief's own vertices).

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    suffix : {".glb", ".obj", ".ply"}, default ".glb"
    back : {"double-sided", "plate", "none"}, default "double-sided"

    Returns
    -------
    (int, int)

    Examples
    --------
    >>> from inkray.relief.model import Part, Relief
    >>> tri = Part("a", np.array([[0., 0, 0], [0, 9, 0], [9, 0, 0]]), np.array([[0, 1, 2]]))
    >>> r = Relief([tri], (10, 10))
    >>> mesh_counts(r, back="none"), mesh_counts(r), mesh_counts(r, suffix=".obj")
    ((3, 1), (9, 8), (6, 8))
    """
    relief = _backed(relief, back)
    vertices = faces = 0
    for part in relief.parts:
        n, f = len(part.vertices), np.asarray(part.faces, np.int64)
        source = _split_vertices(n, f, _face_kinds(part.vertices, f))[0]
        vertices += n if suffix.lower() == ".obj" else len(source)
        faces += len(f)
    return vertices, faces


def _backed(relief, back):
    """The relief checked, with its back plate when ``back`` asks for one."""
    if back not in BACKS:
        raise InputError(f"back: {back!r} is not one of {', '.join(BACKS)}")
    _check_relief(relief)
    if back == "plate":
        from inkray.relief.backing import back_plate

        relief = back_plate(relief)
    elif back == "double-sided":
        from inkray.relief.backing import back_sheet

        relief = back_sheet(relief)
    return relief


def read_meshes(path):
    """Load a GLB/glTF, OBJ or PLY file as a list of named triangle meshes.

    GLB/glTF: one mesh per node that holds triangles, named after the node,
    with the node's world transform applied. OBJ: one mesh per ``o``/``g``
    group. PLY: one mesh named after the file, or, for inkray's PLY, one per
    part (``part`` face property and ``comment inkray part`` lines). Nothing
    is merged: a GLB mesh keeps its vertices; an OBJ group or PLY part gets the
    vertices its faces use, in file order (OBJ corners whose texture or normal
    indices differ become separate vertices, as renderers see them). Points
    and lines are ignored.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    list of NamedMesh

    Raises
    ------
    InputError
        The file is missing, of another type, unreadable, or holds no
        triangles.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from inkray.relief.model import Part, Relief
    >>> tri = Part("a", np.array([[0., 0, 0], [0, 9, 0], [9, 0, 0]]), np.array([[0, 1, 2]]))
    >>> r = Relief([tri], (10, 10), np.zeros((10, 10, 3), np.uint8))
    >>> p = export_relief(r, pathlib.Path(tempfile.mkdtemp()) / "r.glb", back="none")[0]
    >>> [(m.name, len(m.vertices), len(m.faces)) for m in read_meshes(p)]
    [('a', 3, 1)]
    """
    return _load(Path(path), materials=False)[1]


def _load(path, *, materials, read=None):
    """``(scene or None, meshes)``: the file parsed once (the scene when ``materials``).

    Every file the parser asks for beside ``path`` (an MTL, a texture, a glTF
    buffer) is appended to the list ``read``, found or not.
    """
    import trimesh
    from trimesh.resolvers import FilePathResolver

    class _Recording(FilePathResolver):
        def get(self, name):
            if read is not None:
                read.append(self.absolute(name))
            return super().get(name)

    suffix = path.suffix.lower()
    if suffix not in (".glb", ".gltf", ".obj", ".ply"):
        raise InputError(f"{path}: unsupported mesh type {suffix or '(none)'} "
                         f"(expected .glb, .gltf, .obj, .ply)")
    inspect_mesh_file(path)
    scene = None
    try:
        if suffix == ".ply":
            meshes = _read_ply(path)
            if materials:
                scene = trimesh.load_scene(path, process=False)
        else:
            # OBJ: one mesh per o/g group even when groups share a material.
            options = ({"group_material": False, "split_objects": True,
                        "skip_materials": not materials} if suffix == ".obj" else {})
            scene = trimesh.load_scene(path, process=False, resolver=_Recording(str(path)),
                                       **options)
            meshes = _scene_to_named(scene)
    except InputError:
        raise
    except Exception as e:  # every parser failure means the same: not a readable mesh
        raise InputError(f"{path}: cannot read {suffix[1:].upper()}: "
                         f"{type(e).__name__}: {' '.join(str(e).split())}") from e
    meshes = [m for m in meshes if len(m.faces)]
    if not meshes:
        raise InputError(f"{path}: holds no triangles")
    if _z_up(path):
        meshes = [m._replace(vertices=m.vertices @ _Z_UP) for m in meshes]
    for m in meshes:
        if m.vertices.ndim != 2 or m.vertices.shape[1] != 3 or m.faces.ndim != 2 \
                or m.faces.shape[1] != 3:
            raise InputError(f"{path}: part {m.name!r}: not a triangle mesh (vertices "
                             f"{m.vertices.shape}, faces {m.faces.shape})")
        bad = np.flatnonzero(~np.isfinite(m.vertices).all(axis=1))
        if len(bad):
            raise InputError(f"{path}: part {m.name!r}: vertex {bad[0]} is not finite "
                             f"({', '.join(f'{x:g}' for x in m.vertices[bad[0]])})")
        out = np.flatnonzero(((m.faces < 0) | (m.faces >= len(m.vertices))).any(axis=1))
        if len(out):
            raise InputError(f"{path}: part {m.name!r}: face {out[0]} {m.faces[out[0]].tolist()} uses a "
                             f"vertex outside 0..{len(m.vertices) - 1}")
    return scene, meshes


# -- validation --------------------------------------------------------------

def _z_up(path):
    """True for inkray's OBJ and PLY files written with ``up="z"`` (their header says so)."""
    if path.suffix.lower() not in (".obj", ".ply"):
        return False
    with open(path, "rb") as fh:
        head = fh.read(4096)
    return b"inkray relief: X right, Z up" in head or b"inkray frame X right, Z up" in head


def _check_frame(units_per_pixel, anchor):
    if anchor not in ANCHORS:
        raise InputError(f"anchor: {anchor!r} is not one of {', '.join(ANCHORS)}")
    try:
        s = float(units_per_pixel)
    except (TypeError, ValueError):
        s = float("nan")
    if not (np.isfinite(s) and s > 0):
        raise InputError(f"units_per_pixel: expected a positive number, got {units_per_pixel!r}")


def _origin(size, anchor):
    w, h = size
    # Pixel centres are integers: the drawing spans [-0.5, W - 0.5] x [-0.5, H - 0.5].
    return ((w - 1) / 2.0, (h - 1) / 2.0) if anchor == "center" else (-0.5, -0.5)


def _check_relief(relief):
    w, h = relief.size
    if not (int(w) == w and int(h) == h and w > 0 and h > 0):
        raise InputError(f"relief.size: expected positive integer (width, height), "
                         f"got {relief.size}")
    tex = relief.texture
    if tex is not None:
        tex = np.asarray(tex)
        if tex.shape != (h, w, 3) or tex.dtype != np.uint8:
            raise InputError(f"relief.texture: expected a ({h}, {w}, 3) uint8 array for the "
                             f"{w}x{h} drawing, got {tex.shape} {tex.dtype}")
    if not relief.parts:
        raise InputError("relief.parts: the relief has no parts")
    seen = set()
    # Pixel centres are integers: the drawing spans [-0.5, W - 0.5]; allow
    # round-off past that edge.
    tol = 0.5 + 1e-6 * max(w, h)  # from the outermost pixel centre to the drawing's edge
    for i, part in enumerate(relief.parts):
        where = f"parts[{i}]"
        name = part.name
        if not isinstance(name, str) or not name or re.search(r"\s", name):
            raise InputError(f"{where}.name: expected a non-empty name without spaces, "
                             f"got {name!r}")
        if name in seen:
            raise InputError(f"{where}.name: duplicate part name {name!r}")
        seen.add(name)
        where = f"part {name!r}"
        v = np.asarray(part.vertices)
        f = np.asarray(part.faces)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
            raise InputError(f"{where}: vertices must be a non-empty (n, 3) array, got {v.shape}")
        if not np.issubdtype(v.dtype, np.number) or not np.all(np.isfinite(v)):
            raise InputError(f"{where}: vertices must be finite numbers")
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
            raise InputError(f"{where}: faces must be a non-empty (m, 3) array, got {f.shape}")
        if not np.issubdtype(f.dtype, np.integer):
            raise InputError(f"{where}: faces must be integers, got {f.dtype}")
        if f.min() < 0 or f.max() >= len(v):
            bad = int(np.argmax((f < 0).any(axis=1) | (f >= len(v)).any(axis=1)))
            raise InputError(f"{where}: face {bad} {f[bad].tolist()} indexes past the "
                             f"{len(v)} vertices")
        # The texture is sampled where the drawing is: a posed part may move off it.
        t = v if part.texcoords is None else np.asarray(part.texcoords, float)
        if t.shape[0] != len(v) or not np.all(np.isfinite(t[:, :2])):
            raise InputError(f"{where}: texcoords must be finite, one (x, y) per vertex")
        off = ((t[:, 0] < -tol) | (t[:, 0] > w - 1 + tol) | (t[:, 1] < -tol)
               | (t[:, 1] > h - 1 + tol))
        if off.any():
            k = int(np.argmax(off))
            what = "vertex" if part.texcoords is None else "texcoords of vertex"
            raise InputError(f"{where}: {what} {k} at pixel ({t[k, 0]:g}, {t[k, 1]:g}) lies "
                             f"outside the {w}x{h} drawing")


# -- shared geometry ---------------------------------------------------------

class _SceneMesh(NamedTuple):
    name: str
    vertices: np.ndarray  # scene frame, one row per written vertex
    faces: np.ndarray  # into the written vertices
    normals: np.ndarray  # unit, scene frame
    uv: np.ndarray  # (u, v), v up (OpenGL / OBJ convention)
    pixels: np.ndarray  # (x, y) drawing pixels, for colour sampling
    source: np.ndarray  # the part's vertex each written vertex copies (row i < n: vertex i)


#: A face whose normal makes an angle with the view direction (+Z) of more than
#: arccos(_STEEP), about 84 degrees, is a steep rim, a wall or a back: it shows the
#: part's paper. Planar texture coordinates stretch the drawing over such a face by
#: 1 / cos(angle), ten times or more, and it covers a tenth of its area or less in the
#: front view, where the drawing is already seen on the faces around it. Inflated
#: parts end in such a wall (``inkray.relief.inflation.rim_wall``) and are at most
#: 70 degrees steep inside it.
_STEEP = 0.1
_FRONT, _RIM, _BEHIND = 0, 1, 2  # faces: drawing; paper, front surface; paper, back or wall


def _scene_meshes(relief, units_per_pixel, anchor):
    """Every part in the scene frame, its vertices split where the drawing meets the paper.

    A vertex that faces of two kinds share is written once per kind: the
    drawing's copy has its planar texture coordinates, the paper's copy those
    of the part's paper texel (:func:`_paper_texels`), so that no face blends
    the two. Normals are smooth over the front surface (drawing and steep rim
    alike, as without a back) and over the back and
    walls, each on its own.
    """
    texture = _texture(relief)
    kinds = [_face_kinds(p.vertices, p.faces) for p in relief.parts]
    texels = (_paper_texels(relief, kinds, texture) if any((k != _FRONT).any() for k in kinds)
              else None)
    meshes = []
    for i, part in enumerate(relief.parts):
        px = np.asarray(part.vertices, float)
        faces = np.asarray(part.faces, np.int64)
        v = scene_coordinates(px, relief.size, units_per_pixel=units_per_pixel, anchor=anchor)
        if not np.isfinite(v).all() or np.abs(v).max(initial=0.0) > 1e30:
            raise InputError(f"units_per_pixel: {units_per_pixel:g} puts part {part.name!r} "
                             f"beyond finite 32-bit scene coordinates")
        # Flipping y turns the relief's pixel-frame winding (clockwise in x, y
        # down) into counter-clockwise seen from +Z, so faces are kept as they are.
        tex = px[:, :2] if part.texcoords is None else np.asarray(part.texcoords, float)[:, :2]
        kind = kinds[i]
        source, kept, faces = _split_vertices(len(px), faces, kind)
        original = np.asarray(part.faces, np.int64)
        n_front = _scene_normals(px, original[kind != _BEHIND])
        n_behind = _scene_normals(px, original[kind == _BEHIND])
        normals = np.where((kept == _BEHIND)[:, None], n_behind[source], n_front[source])
        pixels = tex[source]
        if texels is not None:
            pixels[kept != _FRONT] = texels[i]
        uv = np.clip(relief.uv(pixels), 0.0, 1.0)
        meshes.append(_SceneMesh(part.name, v[source], faces, normals, uv, pixels, source))
    return meshes


def _face_kinds(pixel_vertices, faces):
    """Per face: ``_FRONT`` (the drawing), ``_RIM`` (steep) or ``_BEHIND`` (turned away)."""
    q = np.asarray(pixel_vertices, float)[np.asarray(faces, np.int64)] * [1.0, -1.0, 1.0]
    n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])  # scene frame: z toward the viewer
    length = np.linalg.norm(n, axis=1)
    kind = np.full(len(n), _FRONT, np.int8)  # a face without area shows nothing
    kind[(length > 0) & (n[:, 2] < _STEEP * length)] = _RIM
    kind[(length > 0) & (n[:, 2] <= 0)] = _BEHIND
    return kind


def _split_vertices(n, faces, kind):
    """``(source, kinds, faces)``: a copy of each vertex per kind of face using it.

    Row ``i < n`` is vertex ``i`` for the first kind that uses it (the
    drawing's, when any), so a part without paper faces is written as it is;
    further copies follow, ordered by vertex, then kind.
    """
    used = np.zeros((n, 3), bool)
    used[faces, kind[:, None]] = True
    first = np.argmax(used, axis=1)  # a vertex no face uses: a drawing vertex
    extra = used.copy()
    extra[np.arange(n), first] = False
    ev, ek = np.nonzero(extra)
    index = np.full((n, 3), -1, np.int64)
    index[np.arange(n), first] = np.arange(n)
    index[ev, ek] = n + np.arange(len(ev))
    return (np.concatenate([np.arange(n), ev]), np.concatenate([first, ek]),
            index[faces, kind[:, None]])


#: Ink, as the renderer separates it: darker in its brightest channel than this
#: fraction of the paper's level.
_INK_LEVEL = 0.6
_PAPER_TOLERANCE = 24  # summed over R, G, B: a texel this close to the estimate is paper
_PAPER_PIXELS = 1 << 16  # the front view is looked at with at most this many pixels


def _paper_texels(relief, kinds, texture):
    """Per part, the drawing pixel ``(x, y)`` whose colour the part shows as its paper.

    The part's paper colour is the median colour of the drawing's non-ink
    pixels where the part is seen in the front view (at its rest place, for a
    posed part); its texel is, among the part's pixels within
    ``_PAPER_TOLERANCE`` of that colour, the one farthest from any other
    (ink, another colour, another part). The view is rasterized at most
    ``_PAPER_PIXELS`` large, each of its pixels standing for the drawing pixel
    at its centre; a part too small to cover one of them is judged by the
    drawing's pixels at its front vertices.
    """
    from scipy import ndimage

    from inkray.view.rasterization import rasterize

    h, w = texture.shape[:2]
    scale = min(1.0, float(np.sqrt(_PAPER_PIXELS / (w * h))))
    rest = [Part(p.name, np.column_stack([(p.vertices if p.texcoords is None else p.texcoords)
                                          [:, :2], np.asarray(p.vertices, float)[:, 2]]),
                 np.asarray(p.faces)[k != _BEHIND]) for p, k in zip(relief.parts, kinds)]
    raster = rasterize(Relief(rest, relief.size), scale=scale, offset=(0.0, 0.0))
    rh, rw = raster.mask.shape
    rows = np.clip(np.rint((np.arange(rh) + 0.5) / scale - 0.5), 0, h - 1).astype(np.intp)
    cols = np.clip(np.rint((np.arange(rw) + 0.5) / scale - 0.5), 0, w - 1).astype(np.intp)
    colours = texture[rows[:, None], cols[None, :]].astype(np.int64).reshape(-1, 3)
    owner = np.where(raster.mask, raster.part, -1)
    value = colours.max(axis=1)
    paper = value >= _INK_LEVEL * max(float(np.percentile(value, 95)), 1.0)
    # a pixel beside another part's is no part's safe paper
    edge = np.zeros((rh, rw), bool)
    edge[:, 1:] |= owner[:, 1:] != owner[:, :-1]
    edge[:, :-1] |= owner[:, 1:] != owner[:, :-1]
    edge[1:] |= owner[1:] != owner[:-1]
    edge[:-1] |= owner[1:] != owner[:-1]
    owner = owner.ravel()
    order = np.argsort(owner, kind="stable")
    bounds = np.searchsorted(owner[order], np.arange(-1, len(relief.parts) + 1))
    pixels = [order[bounds[i + 1]:bounds[i + 2]] for i in range(len(relief.parts))]

    def estimate(where):
        pick = where[paper[where]]
        pick = pick if len(pick) else where
        return np.median(colours[pick], axis=0)

    estimates = [estimate(px) if len(px) else None for px in pixels]
    close = np.zeros(len(owner), bool)
    for px, c in zip(pixels, estimates):
        close[px[np.abs(colours[px] - c).sum(axis=1) <= _PAPER_TOLERANCE]] = True
    depth = ndimage.distance_transform_edt((close.reshape(rh, rw) & ~edge)).ravel()
    texels = np.empty((len(relief.parts), 2))
    for i, (px, c) in enumerate(zip(pixels, estimates)):
        if c is None:  # unseen at this resolution: the drawing under its vertices
            texels[i] = _vertex_paper(rest[i], texture)
            continue
        where = px
        miss = np.abs(colours[where] - c).sum(axis=1)
        good = (miss <= _PAPER_TOLERANCE) & (depth[where] > 0)
        # deepest in the part's paper; failing that, the part's pixel nearest in colour
        k = where[np.argmax(np.where(good, depth[where], -1.0))] if good.any() else \
            where[np.argmin(miss)]
        texels[i] = (cols[k % rw], rows[k // rw])
    return texels


def _vertex_paper(part, texture):
    """The drawing pixel under a front vertex of ``part`` nearest its median non-ink colour."""
    h, w = texture.shape[:2]
    used = np.unique(np.asarray(part.faces).ravel())
    xy = np.rint(np.asarray(part.vertices, float)[used, :2] if len(used) else
                 np.asarray(part.vertices, float)[:, :2]).astype(np.intp)
    xy = np.clip(xy, 0, [w - 1, h - 1])
    colours = texture[xy[:, 1], xy[:, 0]].astype(np.int64)
    value = colours.max(axis=1)
    paper = colours[value >= _INK_LEVEL * max(float(value.max()), 1.0)]
    c = np.median(paper if len(paper) else colours, axis=0)
    return xy[int(np.argmin(np.abs(colours - c).sum(axis=1)))].astype(float)


def _turned(meshes, up):
    if up == "y":
        return meshes
    return [m._replace(vertices=m.vertices @ _Z_UP.T, normals=m.normals @ _Z_UP.T)
            for m in meshes]


def _scene_normals(pixel_vertices, faces):
    """Unit vertex normals in the scene frame (y up); +Z where a vertex has no
    area around it, since glTF requires unit normals."""
    n = vertex_normals(pixel_vertices, faces) * [1.0, -1.0, 1.0]
    n[np.linalg.norm(n, axis=1) == 0] = (0.0, 0.0, 1.0)
    return n


def _texture(relief):
    """The drawing as an RGB image (mid grey when the relief has none)."""
    w, h = relief.size
    if relief.texture is None:
        return np.full((h, w, 3), 128, np.uint8)
    return np.asarray(relief.texture, np.uint8)


def _png_bytes(image):
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG", optimize=False)
    return buf.getvalue()


# -- GLB ---------------------------------------------------------------------

_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
# Linear filtering with mipmaps; clamp, so the drawing's left edge never bleeds
# into its right edge (UVs reach exactly 0 and 1 on the border).
_SAMPLER = {"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}


def _glb_bytes(relief, meshes, units_per_pixel, anchor, name="drawing"):
    """A glTF 2.0 binary: one node per part (its vertices about their box's centre,
    the centre as the node's translation), one textured material, one buffer.

    Written directly: through a general scene exporter, encoding the drawing and
    hashing it once per part took two thirds of a 1 Mpx relief's GLB; the drawing's
    PNG is kept for the next relief of the same drawing (the editor's previews).
    """
    import json
    import struct

    from inkray._version import __version__

    blob = _GlbBuffer()
    nodes, gltf_meshes, accessors = [], [], []

    def accessor(array, kind, target):
        array = np.ascontiguousarray(array)
        entry = {"bufferView": blob.view(array.tobytes(), target),
                 "componentType": 5125 if array.dtype == np.uint32 else 5126,
                 "count": int(array.shape[0]), "type": kind,
                 "max": array.max(axis=0).reshape(-1).tolist(),
                 "min": array.min(axis=0).reshape(-1).tolist()}
        accessors.append(entry)
        return len(accessors) - 1

    for m in meshes:
        if not len(m.faces):
            continue
        centre = (m.vertices.min(axis=0) + m.vertices.max(axis=0)) / 2
        prim = {"attributes": {}, "mode": 4, "material": 0}
        prim["indices"] = accessor(np.asarray(m.faces, np.uint32).reshape(-1, 1), "SCALAR",
                                   _ELEMENT_ARRAY_BUFFER)
        prim["attributes"]["POSITION"] = accessor(
            np.asarray(m.vertices - centre, np.float32), "VEC3", _ARRAY_BUFFER)
        prim["attributes"]["NORMAL"] = accessor(np.asarray(m.normals, np.float32), "VEC3",
                                                _ARRAY_BUFFER)
        # glTF's texture coordinates run down from the image's top-left corner
        uv = np.column_stack([m.uv[:, 0], 1.0 - m.uv[:, 1]])
        prim["attributes"]["TEXCOORD_0"] = accessor(np.asarray(uv, np.float32), "VEC2",
                                                    _ARRAY_BUFFER)
        gltf_meshes.append({"name": m.name, "primitives": [prim]})
        node = {"name": m.name, "mesh": len(gltf_meshes) - 1}
        if centre.any():
            node["translation"] = [float(c) for c in centre]
        nodes.append(node)
    image = blob.view(_texture_png(_texture(relief)), None)
    w, h = relief.size
    tree = {
        "asset": {"version": "2.0", "generator": f"inkray {__version__}"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes))),
                    "extras": {"inkray": {"drawing_size": [int(w), int(h)],
                                          "units_per_pixel": float(units_per_pixel),
                                          "anchor": anchor}}}],
        "nodes": nodes, "meshes": gltf_meshes,
        # single-sided: a part's back is geometry of its own (see export_relief's back)
        "materials": [{"name": name, "doubleSided": False,
                       "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                                                "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "textures": [{"source": 0, "sampler": 0}],
        "images": [{"bufferView": image, "mimeType": "image/png", "name": name}],
        "samplers": [dict(_SAMPLER)],
        "accessors": accessors, "bufferViews": blob.views,
        "buffers": [{"byteLength": blob.size}],
    }
    text = json.dumps(tree, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = b"".join(blob.chunks)
    total = 12 + 8 + len(text) + 8 + len(body)
    return b"".join([struct.pack("<4sII", b"glTF", 2, total),
                     struct.pack("<I4s", len(text), b"JSON"), text,
                     struct.pack("<I4s", len(body), b"BIN\0"), body])


class _GlbBuffer:
    """The binary chunk: views appended at 4-byte aligned offsets."""

    def __init__(self):
        self.chunks, self.views, self.size = [], [], 0

    def view(self, data, target):
        entry = {"buffer": 0, "byteOffset": self.size, "byteLength": len(data)}
        if target is not None:
            entry["target"] = target
        self.views.append(entry)
        pad = -len(data) % 4
        self.chunks += [data, b"\0" * pad]
        self.size += len(data) + pad
        return len(self.views) - 1


_TEXTURES = {}  # digest of a drawing -> its PNG, the last few
_TEXTURES_LOCK = threading.Lock()  # batches write GLBs from several threads


def _texture_png(image):
    import hashlib

    key = hashlib.blake2b(image.tobytes(), digest_size=16).digest() + repr(image.shape).encode()
    with _TEXTURES_LOCK:
        png = _TEXTURES.get(key)
    if png is None:
        png = _png_bytes(image)
        with _TEXTURES_LOCK:
            while len(_TEXTURES) >= 4:
                _TEXTURES.pop(next(iter(_TEXTURES)))
            _TEXTURES[key] = png
    return png


# -- OBJ ---------------------------------------------------------------------

def export_files(path):
    """The files :func:`export_relief` writes for ``path``, the mesh file first.

    Examples
    --------
    >>> [p.name for p in export_files("out/r.obj")]
    ['r.obj', 'r.mtl', 'r_drawing.png']
    """
    path = Path(path)
    if path.suffix.lower() == ".obj":
        return [path, path.with_suffix(".mtl"), path.with_name(f"{path.stem}_drawing.png")]
    return [path]


def _obj_files(relief, meshes, path, name="drawing", up="y", units_per_pixel=0.001,
               anchor="center"):
    # trimesh's OBJ writer names objects only from metadata and rewrites the
    # material; a direct writer gives groups per part and stable file names.
    _, mtl_path, png_path = export_files(path)
    frame = "X right, Y up, Z toward the viewer" if up == "y" else \
        "X right, Z up, -Y toward the viewer"
    w, h = relief.size
    # the frame, as in the PLY header: backs show one texel of paper, so texture
    # coordinates alone do not place the relief
    chunks = [f"# inkray relief: {frame}\n",
              f"# inkray drawing_size {int(w)} {int(h)} units_per_pixel "
              f"{float(units_per_pixel)!r} anchor {anchor}\n",
              f"mtllib {mtl_path.name}\n"]
    base = corner = 1
    for m in meshes:
        # a vertex is written once (solids stay closed by index); where the drawing
        # meets the paper its corners take one of two texture coordinates
        own = int(np.count_nonzero(m.source == np.arange(len(m.source))))
        corners = np.stack([m.source[m.faces] + base, m.faces + corner, m.faces + corner], axis=2)
        chunks += [f"o {m.name}\ng {m.name}\nusemtl {name}\n",
                   _format_rows("v %.9g %.9g %.9g\n", m.vertices[:own]),
                   _format_rows("vt %.9g %.9g\n", m.uv),
                   _format_rows("vn %.6f %.6f %.6f\n", m.normals),
                   _format_rows("f %d/%d/%d %d/%d/%d %d/%d/%d\n", corners.reshape(-1, 9))]
        base += own
        corner += len(m.vertices)
    mtl = ["# inkray relief material: the drawing, matte",
           f"newmtl {name}",
           "Ka 0 0 0", "Kd 1 1 1", "Ks 0 0 0", "Ns 0", "d 1", "illum 1",
           "Pr 1", "Pm 0",  # PBR extension (Blender, three.js): roughness 1, metallic 0
           # No "-clamp on": trimesh reads the whole rest of the line as the file name.
           f"map_Kd {png_path.name}"]
    return {path: "".join(chunks).encode(),
            mtl_path: ("\n".join(mtl) + "\n").encode(),
            png_path: _png_bytes(_texture(relief))}


def _format_rows(line, array):
    """``line`` (a %-format of one row) applied to every row, in one formatting call."""
    return (line * len(array)) % tuple(np.asarray(array).ravel().tolist())


# -- PLY ---------------------------------------------------------------------

def _ply_bytes(relief, meshes, units_per_pixel, anchor, up="y"):
    import trimesh

    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes])
    vertices = np.concatenate([m.vertices for m in meshes])
    faces = np.concatenate([m.faces + o for m, o in zip(meshes, offsets)])
    uv = np.concatenate([m.uv for m in meshes]).astype(np.float32)
    rgb = _sample_bilinear(_texture(relief), np.concatenate([m.pixels for m in meshes]))
    rgba = np.concatenate([rgb, np.full((len(rgb), 1), 255, np.uint8)], axis=1)
    part = np.repeat(np.arange(len(meshes), dtype=np.int32), [len(m.faces) for m in meshes])
    mesh = trimesh.Trimesh(vertices, faces, process=False,
                           vertex_normals=np.concatenate([m.normals for m in meshes]),
                           vertex_colors=rgba,
                           vertex_attributes={"s": uv[:, 0], "t": uv[:, 1]},
                           face_attributes={"part": part})
    data = trimesh.exchange.ply.export_ply(mesh, encoding="binary", vertex_normal=True)
    w, h = relief.size
    comments = [f"comment inkray drawing_size {int(w)} {int(h)} units_per_pixel "
                f"{float(units_per_pixel)!r} anchor {anchor}",
                "comment inkray frame X right, Y up, Z toward the viewer" if up == "y" else
                "comment inkray frame X right, Z up, -Y toward the viewer"]
    comments += [f"comment inkray part {i} {m.name}" for i, m in enumerate(meshes)]
    head, sep, body = data.partition(b"end_header\n")
    lines = [ln for ln in head.decode("ascii").splitlines() if not ln.startswith("comment ")]
    return ("\n".join(lines[:2] + comments + lines[2:]) + "\n").encode("ascii") + sep + body


def _sample_bilinear(image, xy):
    """Colours of ``image`` at pixel positions ``xy`` (pixel ``c`` centred at ``c``)."""
    h, w = image.shape[:2]
    x = np.clip(xy[:, 0], 0, w - 1)
    y = np.clip(xy[:, 1], 0, h - 1)
    x0 = np.minimum(np.floor(x).astype(int), w - 2) if w > 1 else np.zeros(len(x), int)
    y0 = np.minimum(np.floor(y).astype(int), h - 2) if h > 1 else np.zeros(len(y), int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    img = image.astype(float)
    top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
    bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
    return np.clip(np.rint(top * (1 - fy) + bottom * fy), 0, 255).astype(np.uint8)


# -- reading -----------------------------------------------------------------

def _scene_to_named(scene):
    meshes = []
    nodes = scene.graph.geometry_nodes
    for geom_name, geom in scene.geometry.items():
        if not hasattr(geom, "faces"):
            continue
        for node in nodes.get(geom_name, []):
            transform, _ = scene.graph[node]
            v = np.asarray(geom.vertices, float)
            v = v @ transform[:3, :3].T + transform[:3, 3]
            f = np.asarray(geom.faces, np.int64)
            if np.linalg.det(transform[:3, :3]) < 0:  # a mirroring node flips the winding
                f = f[:, ::-1]
            stored = geom._cache.cache.get("vertex_normals")  # the file's, not computed
            n = None if stored is None or len(stored) != len(v) else \
                np.asarray(stored, float) @ transform[:3, :3].T
            meshes.append(NamedMesh(str(node), v, f, normals=n))
    return meshes


def _read_ply(path):
    import trimesh

    names = {}
    with open(path, "rb") as fh:
        first = fh.readline()
        if not first.startswith(b"ply"):
            raise InputError(f"{path}: not a PLY file (no 'ply' magic)")
        for raw in fh:
            line = raw.decode("ascii", "replace").strip()
            if line == "end_header":
                break
            match = _PLY_PART.match(line)
            if match:
                names[int(match.group(1))] = match.group(2)
    mesh = trimesh.load_mesh(path, file_type="ply", process=False)
    if not hasattr(mesh, "faces"):
        return []
    v = np.asarray(mesh.vertices, float)
    f = np.asarray(mesh.faces, np.int64)
    columns = mesh.metadata.get("_ply_raw", {}).get("vertex", {}).get("data")
    # binary PLY: a structured array; ASCII: a dict of columns
    fields = set(getattr(getattr(columns, "dtype", None), "names", None) or
                 (columns.keys() if isinstance(columns, dict) else ()))
    rgb = None
    if {"red", "green", "blue"} <= fields:
        rgb = np.stack([np.asarray(columns[c]).reshape(-1) for c in ("red", "green", "blue")],
                       axis=1).astype(np.uint8)
        rgb = rgb if len(rgb) == len(v) else None
    normals = None
    if {"nx", "ny", "nz"} <= fields:
        normals = np.stack([np.asarray(columns[c], float).reshape(-1) for c in ("nx", "ny", "nz")],
                           axis=1)
        normals = normals if len(normals) == len(v) else None
    raw = mesh.metadata.get("_ply_raw", {}).get("face", {}).get("data")
    part = None
    if names and raw is not None and raw.dtype.names and "part" in raw.dtype.names:
        part = np.asarray(raw["part"]).reshape(-1)
    if part is None or len(part) != len(f):
        return [NamedMesh(path.stem, v, f, rgb, normals)]
    meshes = []
    for i in sorted(set(part.tolist())):
        sub = f[part == i]
        used, inverse = np.unique(sub, return_inverse=True)
        meshes.append(NamedMesh(names.get(i, f"part{i}"), v[used], inverse.reshape(-1, 3),
                                None if rgb is None else rgb[used],
                                None if normals is None else normals[used]))
    return meshes


def read_relief(path, *, inputs=None):
    """A relief from a GLB/glTF, OBJ or PLY file.

    Geometry comes from :func:`inkray.formats.meshes.read_meshes`. inkray's files are
    placed by the frame their exporter records (GLB scene extras, PLY header
    comments; see :mod:`inkray.export`); other files with a texture by their
    texture coordinates (``x = u W - 0.5``, ``y = (1 - v) H - 0.5``: pixel
    centres at integers, as in :mod:`inkray.relief`); anything else is
    scaled so its longer side spans 512 pixels. The drawing is the GLB's
    base-colour texture or the OBJ's ``map_Kd`` (PLY carries none).

    Parameters
    ----------
    path : str or Path
    inputs : list, optional
        Receives every file read: ``path`` and the files it refers to (an
        OBJ's MTL and texture, a glTF's buffers and images), so that a
        command can refuse to write over any of them.

    Returns
    -------
    inkray.relief.model.Relief
        One part per mesh, its vertices at one position and normal merged (a
        file copies a vertex where its texture coordinates change). A
        referenced texture that is missing leaves it untextured, with a
        warning naming the file in its ``warnings``.

    Raises
    ------
    InputError
        The file is missing, unreadable, holds no triangles, or its inkray
        frame record is malformed; a texture it refers to cannot be decoded
        (cut short, not an image).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from inkray.relief.model import Part, Relief
    >>> tri = Part("a", np.array([[0., 0, 0], [0, 9, 2], [9, 0, 0]]), np.array([[0, 1, 2]]))
    >>> r = Relief([tri], (10, 10), np.zeros((10, 10, 3), np.uint8))
    >>> p = export_relief(r, pathlib.Path(tempfile.mkdtemp()) / "r.glb", back="none")[0]
    >>> back = read_relief(p)
    >>> back.size, (np.round(back.parts[0].vertices, 3) + 0.0).tolist()
    ((10, 10), [[0.0, 0.0, 0.0], [0.0, 9.0, 2.0], [9.0, 0.0, 0.0]])
    """
    path = Path(path)
    read = [path]
    scene, meshes = _load(path, materials=True, read=read)
    if inputs is not None:
        inputs.extend(read)
    z_up = _z_up(path)
    texture, pairs = None, []
    for node in scene.graph.nodes_geometry:
        transform, geom_name = scene.graph[node]
        geom = scene.geometry[geom_name]
        uv = getattr(geom.visual, "uv", None)
        if uv is not None and (np.ndim(uv) != 2 or np.shape(uv)[1] < 2
                               or len(uv) != len(geom.vertices)):
            uv = None  # malformed texture coordinates: read as untextured
        material = getattr(geom.visual, "material", None)
        image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
        if path.suffix.lower() == ".ply" or uv is None or image is None:
            continue
        if texture is None:
            try:
                texture = np.asarray(image.convert("RGB"))
            except Exception as e:  # Pillow decodes lazily: a corrupt texture fails here
                raise InputError(f"{path}: node {node}: the texture cannot be decoded "
                                 f"({type(e).__name__}: {str(e) or 'corrupt data'})") from None
            DEFAULT_LIMITS.check_pixels((texture.shape[1], texture.shape[0]), f"{path}: texture")
        v = np.asarray(geom.vertices, float) @ transform[:3, :3].T + transform[:3, 3]
        pairs.append((v @ _Z_UP if z_up else v, np.asarray(uv, float)))
    frame = _frame(scene, path)
    allv = np.concatenate([m.vertices for m in meshes])
    if frame is not None:
        size, s, anchor = frame

        def to_pixels(v):
            return pixel_coordinates(v, size, units_per_pixel=s, anchor=anchor)
    elif texture is not None:
        size = (texture.shape[1], texture.shape[0])
        to_pixels = _uv_fit(pairs, size, path)
    else:
        lo, hi = allv.min(axis=0), allv.max(axis=0)
        s = max(float(np.max(hi[:2] - lo[:2])), 1e-12) / 512
        size = tuple(max(1, int(np.ceil((hi[i] - lo[i]) / s))) for i in range(2))

        def to_pixels(v):
            # from the drawing's top-left edge at (-0.5, -0.5): pixel centres are integers
            return np.stack([(v[:, 0] - lo[0]) / s - 0.5, (hi[1] - v[:, 1]) / s - 0.5,
                             v[:, 2] / s], axis=1)
    parts, colours = [], []
    for m in meshes:
        keep, faces = _welded(m.vertices, m.faces, m.normals)
        parts.append(Part(m.name, to_pixels(m.vertices[keep]), faces))
        colours.append(None if m.colors is None else m.colors[keep])
    size = (int(size[0]), int(size[1]))
    if texture is None and path.suffix.lower() == ".ply":
        texture = _ply_colour_texture(parts, colours, size)
    return Relief(parts, size=size, texture=texture,
                  warnings=[] if texture is not None else _texture_problems(path, read[1:]))


def _welded(vertices, faces, normals=None):
    """``(keep, faces)``: the first vertex of each position (and normal), in order, and the
    faces on them.

    Files copy a vertex where its texture coordinates change (inkray's where the
    drawing meets the paper) on one smooth surface; copies with a normal of
    their own (a crease: a front and its wall) stay apart.
    """
    key = vertices if normals is None else np.column_stack([vertices, normals])
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty(len(first), np.int64)
    rank[order] = np.arange(len(first))
    return first[order], rank[inverse.reshape(-1)][faces]


def _texture_problems(path, read):
    """Warnings for referenced images that are missing; an error for one that does not decode.

    The parser drops a texture it cannot open without a word: an image read
    beside a mesh that came out untextured is looked at again here.
    """
    from PIL import Image

    out = []
    for file in read:
        if file.suffix.lower() in (".mtl", ".bin", ".gltf"):
            continue
        if not file.is_file():
            out.append(f"{file}: texture of {path} not found; rendered without it")
            continue
        try:
            with Image.open(file) as image:
                DEFAULT_LIMITS.check_pixels(image.size, f"{file}: texture")
                image.load()
        except InputError:
            raise
        except Exception as e:
            raise InputError(f"{file}: the texture of {path} cannot be decoded "
                             f"({type(e).__name__}: {' '.join(str(e).split()) or 'corrupt data'})"
                             ) from None
    return out


def _ply_colour_texture(parts, colours, size):
    """The drawing baked back from a PLY's vertex colours (its only picture), or None.

    Each pixel takes the colours of the front-most triangle over it,
    interpolated barycentrically; pixels no triangle covers are white.
    """
    from inkray.view.rasterization import rasterize

    if any(c is None for c in colours):
        return None
    raster = rasterize(Relief(parts, size))
    texture = np.full((size[1], size[0], 3), 255.0)
    hit = raster.mask
    for i, part in enumerate(parts):
        sel = hit & (raster.part == i)
        corners = colours[i][np.asarray(part.faces)[raster.face[sel]]]
        texture[sel] = np.einsum("nk,nkc->nc", raster.bary[sel], corners)
    return np.clip(np.rint(texture), 0, 255).astype(np.uint8)



def _frame(scene, path):
    """``((W, H), units_per_pixel, anchor)`` recorded by inkray's exporter, or None."""
    meta = scene.metadata or {}
    info = meta.get("inkray") or (meta.get("extras") or {}).get("inkray")
    if info is None and path.suffix.lower() in (".ply", ".obj"):
        with open(path, "rb") as fh:
            for raw in fh:
                line = raw.decode("ascii", "replace").strip()
                if line == "end_header" or line.startswith(("v ", "mtllib", "o ", "g ")):
                    break
                m = re.match(r"(?:comment|#) inkray drawing_size (\d+) (\d+) units_per_pixel "
                             r"(\S+)(?: anchor (\S+))?$", line)
                if m:
                    info = {"drawing_size": [int(m[1]), int(m[2])],
                            "units_per_pixel": float(m[3]), "anchor": m[4] or "center"}
    if info is None:
        return None
    try:
        w, h = (int(x) for x in info["drawing_size"])
        s = float(info["units_per_pixel"])
        anchor = info.get("anchor", "center")
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"{path}: extras.inkray: malformed ({e})") from e
    if w <= 0 or h <= 0 or not 0 < s < np.inf or anchor not in ("center", "top-left"):
        raise InputError(f"{path}: extras.inkray: drawing_size {info.get('drawing_size')}, "
                         f"units_per_pixel {s}, anchor {anchor!r} out of range")
    DEFAULT_LIMITS.check_pixels((w, h), f"{path}: extras.inkray.drawing_size")
    return (w, h), s, anchor


def _uv_fit(pairs, size, path):
    """Scene -> pixel map fitted to texture coordinates: x = u W - 0.5, y = (1 - v) H - 0.5."""
    v = np.concatenate([p[0] for p in pairs])
    uv = np.concatenate([p[1] for p in pairs])
    target = np.stack([uv[:, 0] * size[0] - 0.5, (1 - uv[:, 1]) * size[1] - 0.5], axis=1)
    coef = []
    for axis in range(2):
        a = np.column_stack([v[:, axis], np.ones(len(v))])
        c, *_ = np.linalg.lstsq(a, target[:, axis], rcond=None)
        coef.append(c)
    s = (abs(coef[0][0]) + abs(coef[1][0])) / 2
    if not s > 0:
        raise InputError(f"{path}: texture coordinates do not vary with position")

    def to_pixels(p):
        return np.stack([coef[0][0] * p[:, 0] + coef[0][1], coef[1][0] * p[:, 1] + coef[1][1],
                         p[:, 2] * s], axis=1)
    return to_pixels
