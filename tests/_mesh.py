"""Geometry helpers shared by the relief tests."""

import igl
import numpy as np


def height_at(vertices2d, faces, z, points):
    """Barycentric height of a mesh at ``points`` (k, 2) and their distance to the mesh."""
    vertices2d = np.asarray(vertices2d, float)[:, :2]
    points = np.asarray(points, float).reshape(-1, 2)
    v3 = np.column_stack([vertices2d, np.zeros(len(vertices2d))])
    p3 = np.column_stack([points, np.zeros(len(points))])
    d2, face, closest = igl.point_mesh_squared_distance(p3, v3, np.asarray(faces, np.int64))
    tri = np.asarray(faces)[face]
    a, b, c = (vertices2d[tri[:, k]] for k in range(3))
    q = closest[:, :2]
    den = (b - a)[:, 0] * (c - a)[:, 1] - (c - a)[:, 0] * (b - a)[:, 1]
    wb = ((q - a)[:, 0] * (c - a)[:, 1] - (c - a)[:, 0] * (q - a)[:, 1]) / den
    wc = ((b - a)[:, 0] * (q - a)[:, 1] - (q - a)[:, 0] * (b - a)[:, 1]) / den
    w = np.column_stack([1 - wb - wc, wb, wc])
    return (np.asarray(z)[tri] * w).sum(1), np.sqrt(d2)
