"""The relief: the plain data every stage after stitching exchanges.

A relief is a stack of region meshes in drawing coordinates (Sýkora et al.,
"Ink-and-Ray", TOG 2014, section 6): seen from the front it reproduces the
drawing, and planar texture coordinates map the drawing onto it.

Coordinates of :attr:`Part.vertices` are drawing pixels: ``x`` the column,
``y`` the row (growing downward), ``z`` the height toward the viewer, in
pixels. As in the annotation format, pixel centres are at integer
coordinates, so the drawing covers ``[-0.5, W - 0.5] x [-0.5, H - 0.5]``.
Faces are oriented so their normals point toward the viewer on the
front surface (counter-clockwise as seen by the viewer, i.e. clockwise in the
``(x, y)`` image plane, since ``y`` grows downward). Exporters convert to their
own frame (e.g. y up, +z toward the viewer).
"""

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Part", "Relief"]


@dataclass
class Part:
    """One region's mesh.

    Attributes
    ----------
    name : str
        The region's name.
    vertices : (n, 3) float array
        ``[x, y, z]`` in drawing pixels.
    faces : (m, 3) int array
    closed : bool
        True when the part is a closed solid (front and back).
    texcoords : (n, 2) float array or None
        Where on the drawing (pixels) each vertex takes its colour; None: at
        its own ``(x, y)``. A posed part keeps its rest positions here.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    closed: bool = False
    texcoords: np.ndarray = None


@dataclass
class Relief:
    """A bas-relief: its parts and the drawing they are textured with.

    Attributes
    ----------
    parts : list of Part
    size : (int, int)
        ``(width, height)`` of the drawing in pixels.
    texture : (H, W, 3) uint8 array or None
        The drawing's colours.
    warnings : list of str
        What the assembly could not do as asked (e.g. parts of a union that
        stay separate shells).
    """

    parts: list = field(default_factory=list)
    size: tuple = (0, 0)
    texture: np.ndarray = None
    warnings: list = field(default_factory=list)

    def uv(self, vertices):
        """Planar texture coordinates: ``(x, y)`` -> ``((x + 0.5) / W, 1 - (y + 0.5) / H)``.

        Pixel centres (integers) land on texel centres, the drawing's outer
        edges on 0 and 1.

        Parameters
        ----------
        vertices : (n, 2 or 3) array

        Returns
        -------
        (n, 2) float array
        """
        v = np.asarray(vertices, float)
        w, h = self.size
        return np.stack([(v[:, 0] + 0.5) / w, 1.0 - (v[:, 1] + 0.5) / h], axis=1)
