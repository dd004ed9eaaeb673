"""Mesh-quality report for relief meshes (``inkray check``).

The relief meshes of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for
Adding Global Illumination Effects to Hand-Drawn Characters" (TOG 2014) go to
global-illumination renderers, which need well-shaped, manifold, consistently
oriented triangles (and closed solids for the closed variant). This module
measures that, per part and overall, for any triangle mesh.

Topology (boundaries, manifoldness, orientation, watertightness, duplicate
faces, self-intersections) is measured after welding vertices at identical
positions, since files commonly split vertices where normals or UVs differ;
faces that use one welded vertex twice count as degenerate and are left out
of it. A face is degenerate when its height is below ``1e-6`` of its longest
edge (this includes zero-area faces); angle and aspect-ratio statistics are
over the other faces. Aspect ratio is ``longest edge * perimeter /
(4 sqrt(3) area)``: 1 for an equilateral triangle, larger for worse shapes.
Self-intersections are tested exactly in double precision
(:mod:`inkray.numerics.tri_intersection`): faces that cross or touch a face
they share no edge with (faces sharing one corner count when one folds over
the other, not for touching at it).
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

__all__ = ["REQUIREMENTS", "BOUNDS", "check_file", "failed_requirements", "format_report",
           "mesh_quality", "parse_requirements", "quality_report"]

# Requirement name -> (what a part must satisfy, as a predicate on its metrics).
REQUIREMENTS = {
    "watertight": lambda q: q["watertight"],
    "manifold": lambda q: q["edge_manifold"] and q["vertex_manifold"],
    "edge-manifold": lambda q: q["edge_manifold"],
    "vertex-manifold": lambda q: q["vertex_manifold"],
    "oriented": lambda q: q["consistently_oriented"],
    "no-self-intersections": lambda q: q["self_intersecting_faces"] == 0,
    "no-degenerate": lambda q: q["degenerate_faces"] == 0,
    "no-duplicates": lambda q: q["duplicate_faces"] == 0,
}

#: Requirements with a bound, written ``name=value``: (metric, comparison).
BOUNDS = {
    "min-angle": ("min_angle_deg", ">="),
    "max-aspect": ("max_aspect_ratio", "<="),
    "shells": ("shells", "<="),
}

_DEGENERATE = 1e-6  # height / longest edge below which a face is degenerate


def mesh_quality(vertices, faces, *, self_intersections=True):
    """Quality metrics of one triangle mesh.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    self_intersections : bool, optional
        Count self-intersecting faces (exactly, in double precision: see
        :mod:`inkray.numerics.tri_intersection`); ``None`` in the result
        when False.

    Returns
    -------
    dict
        ``vertices``, ``faces``, ``unreferenced_vertices``, ``welded_vertices``
        (distinct positions among the referenced vertices),
        ``min_angle_deg``, ``mean_min_angle_deg`` (mean over faces of their
        smallest angle), ``max_aspect_ratio``, ``mean_aspect_ratio``,
        ``degenerate_faces``, ``duplicate_faces`` (faces repeating another's
        three vertices, in any order), ``boundary_edges``, ``boundary_loops``,
        ``non_manifold_edges`` (edges of more than two faces),
        ``edge_manifold``, ``non_manifold_vertices`` (vertices whose faces
        form more than one fan), ``vertex_manifold``, ``watertight`` (every
        edge has exactly two faces), ``inconsistent_edges`` (two-face edges
        both faces traverse the same way), ``consistently_oriented``,
        ``self_intersecting_faces``, ``volume`` (signed, positive for outward
        normals; ``None`` unless watertight and consistently oriented),
        ``shells`` (connected pieces: faces joined through shared edges or
        vertices). Statistics over no faces are ``None``.

    Raises
    ------
    InputError
        Arrays of the wrong shape, non-finite vertices, indices out of range.

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> q = mesh_quality(v, f)
    >>> q["watertight"], q["consistently_oriented"], round(q["volume"], 4)
    (True, True, 0.1667)
    """
    v, f = _check_mesh(vertices, faces)
    referenced = np.flatnonzero(np.bincount(f.reshape(-1), minlength=len(v)))
    welded, inverse = _weld(v[referenced])
    index = np.full(len(v), -1, np.int64)
    index[referenced] = inverse
    wf = index[f]

    shape = _shape_stats(v[f])
    repeated = (wf[:, 0] == wf[:, 1]) | (wf[:, 1] == wf[:, 2]) | (wf[:, 0] == wf[:, 2])
    degenerate = shape.pop("degenerate") | repeated
    topo_faces = wf[~repeated]
    topo = _topology(topo_faces, len(welded))
    watertight = len(topo_faces) > 0 and topo["boundary_edges"] == 0 \
        and topo["non_manifold_edges"] == 0
    oriented = topo["inconsistent_edges"] == 0
    volume = None
    if watertight and oriented:
        t = welded[topo_faces]
        volume = float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6.0)
    duplicates = int(len(topo_faces) - _distinct_rows(np.sort(topo_faces, axis=1))[1].sum())
    if self_intersections:
        crossing = _self_intersecting_faces(welded, topo_faces)
    else:
        crossing = None
    return {
        "vertices": int(len(v)),
        "faces": int(len(f)),
        "unreferenced_vertices": int(len(v) - len(referenced)),
        "welded_vertices": int(len(welded)),
        **shape,
        "degenerate_faces": int(degenerate.sum()),
        "duplicate_faces": int(duplicates),
        "boundary_edges": topo["boundary_edges"],
        "boundary_loops": topo["boundary_loops"],
        "non_manifold_edges": topo["non_manifold_edges"],
        "edge_manifold": topo["non_manifold_edges"] == 0,
        "non_manifold_vertices": topo["non_manifold_vertices"],
        "vertex_manifold": topo["non_manifold_vertices"] == 0,
        "watertight": bool(watertight),
        "inconsistent_edges": topo["inconsistent_edges"],
        "consistently_oriented": bool(oriented),
        "self_intersecting_faces": crossing,
        "volume": volume,
        "shells": _shells(topo_faces, len(welded)),
    }


def quality_report(meshes, *, self_intersections=True):
    """Quality report of named meshes: each part and the whole.

    Parameters
    ----------
    meshes : list of (name, vertices, faces)
        E.g. from :func:`inkray.formats.meshes.read_meshes`.
    self_intersections : bool, optional
        Passed to :func:`mesh_quality`.

    Returns
    -------
    dict
        ``{"parts": [{"name": ..., **metrics}], "overall": {...}}``. Overall
        counts are sums over parts, flags hold when they hold for every part,
        ``min_angle_deg`` is the minimum and ``max_aspect_ratio`` the maximum,
        the means are weighted by the parts' (non-degenerate) faces, and
        ``volume`` is the sum when every part has one. Intersections between
        different parts are not counted (layers of a relief may touch).

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> r = quality_report([("a", v, [[0, 1, 2]]), ("b", v + 2, [[0, 1, 2]])])
    >>> r["overall"]["faces"], r["overall"]["boundary_loops"], r["overall"]["watertight"]
    (2, 2, False)
    """
    parts = []
    for mesh in meshes:
        name, vertices, faces = mesh[:3]  # NamedMesh or (name, vertices, faces)
        parts.append({"name": str(name),
                      **mesh_quality(vertices, faces, self_intersections=self_intersections)})
    return {"parts": parts, "overall": _overall(parts)}


def check_file(path, *, self_intersections=True):
    """Read a GLB/glTF, OBJ or PLY file and return its :func:`quality_report`.

    Parameters
    ----------
    path : str or Path
    self_intersections : bool, optional

    Returns
    -------
    dict
        The report, with ``"file"`` (the path as given) added.

    Raises
    ------
    InputError
        The file cannot be read as a triangle mesh.

    Examples
    --------
    >>> check_file("missing.glb")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    inkray.errors.InputError: missing.glb: no such file
    """
    from inkray.formats.meshes import read_meshes

    report = quality_report(read_meshes(path), self_intersections=self_intersections)
    return {"file": str(path), **report}


def failed_requirements(report, requirements):
    """Requirements that some part of a report does not meet.

    Parameters
    ----------
    report : dict
        From :func:`quality_report` or :func:`check_file`.
    requirements : iterable of str
        Names from :data:`REQUIREMENTS`, or ``name=value`` with a name from
        :data:`BOUNDS`: ``min-angle=10`` (smallest angle at least 10
        degrees), ``max-aspect=20``, ``shells=1`` (at most one piece).

    Returns
    -------
    list of (str, list of str)
        Each failed requirement with the names of the parts failing it, in
        the order the requirements were given.

    Raises
    ------
    InputError
        An unknown requirement name.

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> failed_requirements(quality_report([("a", v, [[0, 1, 2]])]), ["manifold", "watertight"])
    [('watertight', ['a'])]
    """
    failed = []
    for req in parse_requirements(requirements):
        bad = [p["name"] for p in report["parts"] if not _meets(p, req)]
        if bad:
            failed.append((req, bad))
    return failed


def _meets(part, requirement):
    if "=" not in requirement:
        return REQUIREMENTS[requirement](part)
    name, value = requirement.split("=")
    key, comparison = BOUNDS[name]
    x = part[key]
    if x is None:
        return False
    return x >= float(value) if comparison == ">=" else x <= float(value)


def parse_requirements(requirements):
    """Requirement names from ``"a,b"`` or a list, checked against :data:`REQUIREMENTS`.

    Parameters
    ----------
    requirements : str or iterable of str
        Comma-separated names (spaces and empty items ignored) or a list;
        bounds as ``name=value`` (:data:`BOUNDS`).

    Returns
    -------
    list of str

    Raises
    ------
    InputError
        An unknown name.

    Examples
    --------
    >>> parse_requirements("watertight, manifold, min-angle=10")
    ['watertight', 'manifold', 'min-angle=10']
    """
    from inkray.errors import InputError

    if isinstance(requirements, str):
        requirements = requirements.split(",")
    names = [r.replace(" ", "") for r in requirements if r.strip()]
    for name in names:
        key, _, value = name.partition("=")
        if key in BOUNDS:
            try:
                bound = float(value)
            except ValueError:
                bound = float("nan")
            if not np.isfinite(bound) or bound < 0:
                raise InputError(f"require: {key} needs a bound, e.g. {key}="
                                 f"{'10' if key == 'min-angle' else '1'}; got {name!r}",
                                 option="require")
        elif name not in REQUIREMENTS:
            raise InputError(f"require: unknown requirement {name!r} "
                             f"(expected {', '.join(REQUIREMENTS)}, or "
                             f"{', '.join(k + '=N' for k in BOUNDS)})", option="require")
    return names


def format_report(report):
    """The report as text: one line per part, then the overall line.

    Parameters
    ----------
    report : dict
        From :func:`quality_report` or :func:`check_file`.

    Returns
    -------
    str

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> print(format_report(quality_report([("a", v, [[0, 1, 2]])])))  # doctest: +ELLIPSIS
    a: 3 vertices, 1 faces; min angle 45.0 deg, mean min angle 45.0 deg; ...
    overall (1 parts): ...
    """
    lines = []
    if "file" in report:
        lines.append(f"{report['file']}:")
    for part in report["parts"]:
        lines.append(f"{part['name']}: {_describe(part)}")
    lines.append(f"overall ({report['overall']['parts']} parts): {_describe(report['overall'])}")
    return "\n".join(lines)


def _describe(q):
    def num(x, fmt):
        return "n/a" if x is None else format(x, fmt)

    def flag(ok, yes, no):
        return yes if ok else no

    crossing = q["self_intersecting_faces"]
    return "; ".join([
        f"{q['vertices']} vertices, {q['faces']} faces",
        f"min angle {num(q['min_angle_deg'], '.1f')} deg, "
        f"mean min angle {num(q['mean_min_angle_deg'], '.1f')} deg",
        f"aspect ratio max {num(q['max_aspect_ratio'], '.2f')}, "
        f"mean {num(q['mean_aspect_ratio'], '.2f')}",
        f"{q['degenerate_faces']} degenerate, {q['duplicate_faces']} duplicate faces",
        f"{q['boundary_loops']} boundary loops ({q['boundary_edges']} edges)",
        flag(q["edge_manifold"], "edge-manifold",
             f"NOT edge-manifold ({q['non_manifold_edges']} edges)"),
        flag(q["vertex_manifold"], "vertex-manifold",
             f"NOT vertex-manifold ({q['non_manifold_vertices']} vertices)"),
        flag(q["watertight"], "watertight", "open"),
        flag(q["consistently_oriented"], "consistently oriented",
             f"NOT consistently oriented ({q['inconsistent_edges']} edges)"),
        "self-intersections not checked" if crossing is None
        else f"{crossing} self-intersecting faces",
        f"volume {num(q['volume'], '.6g')}",
        f"{q['shells']} shell{'' if q['shells'] == 1 else 's'}",
    ])


# -- measurements -------------------------------------------------------------

def _check_mesh(vertices, faces):
    from inkray.errors import InputError

    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise InputError(f"mesh: vertices must be an (n, 3) array, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise InputError(f"mesh: vertex {int(np.argmax(~np.isfinite(v).all(axis=1)))} "
                         f"is not finite")
    f = f.reshape(-1, 3) if f.size == 0 else f
    if f.ndim != 2 or f.shape[1] != 3 or not (f.size == 0 or np.issubdtype(f.dtype, np.integer)):
        raise InputError(f"mesh: faces must be an (m, 3) integer array, got {f.shape} {f.dtype}")
    f = f.astype(np.int64)
    bad = (f < 0).any(axis=1) | (f >= len(v)).any(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise InputError(f"mesh: face {k} {f[k].tolist()} indexes past the {len(v)} vertices")
    return v, f


def _shape_stats(tri):
    """Angles, aspect ratios and the degenerate mask of triangles ``(m, 3, 3)``."""
    edges = np.stack([tri[:, 2] - tri[:, 1], tri[:, 0] - tri[:, 2], tri[:, 1] - tri[:, 0]], axis=1)
    length = np.linalg.norm(edges, axis=2)  # length[:, k]: the side opposite corner k
    area = 0.5 * np.linalg.norm(np.cross(edges[:, 2], -edges[:, 1]), axis=1)
    longest = length.max(axis=1)
    degenerate = ~(2.0 * area > _DEGENERATE * longest ** 2)
    ok = ~degenerate
    if not ok.any():
        return {"min_angle_deg": None, "mean_min_angle_deg": None, "max_aspect_ratio": None,
                "mean_aspect_ratio": None, "degenerate": degenerate}
    a, b, c = (length[ok, k] for k in range(3))
    # The smallest angle is opposite the shortest side; law of cosines.
    sides = np.sort(np.stack([a, b, c], axis=1), axis=1)
    s, m, lg = sides[:, 0], sides[:, 1], sides[:, 2]
    cos_min = np.clip((m ** 2 + lg ** 2 - s ** 2) / (2 * m * lg), -1.0, 1.0)
    min_angle = np.degrees(np.arccos(cos_min))
    aspect = longest[ok] * (a + b + c) / (4.0 * np.sqrt(3.0) * area[ok])
    return {"min_angle_deg": float(min_angle.min()), "mean_min_angle_deg": float(min_angle.mean()),
            "max_aspect_ratio": float(aspect.max()), "mean_aspect_ratio": float(aspect.mean()),
            "degenerate": degenerate}


def _topology(faces, n_vertices):
    """Edge and vertex topology of faces over welded vertices."""
    m = len(faces)
    if m == 0:
        return {"boundary_edges": 0, "boundary_loops": 0, "non_manifold_edges": 0,
                "non_manifold_vertices": 0, "inconsistent_edges": 0}
    start = faces.reshape(-1)
    end = np.roll(faces, -1, axis=1).reshape(-1)  # half-edge k of face i: corner k -> k+1
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    keys, edge_of, count = np.unique(lo * n_vertices + hi, return_inverse=True,
                                     return_counts=True)
    edge_of = edge_of.reshape(-1)
    direction = np.where(start < end, 1, -1)
    net = np.bincount(edge_of, weights=direction, minlength=len(keys))
    boundary = count == 1
    inconsistent = (count == 2) & (np.abs(net) == 2)

    # Boundary loops: connected components of the boundary edges.
    b_lo, b_hi = keys[boundary] // n_vertices, keys[boundary] % n_vertices
    loops = 0
    if len(b_lo):
        used, idx = np.unique(np.concatenate([b_lo, b_hi]), return_inverse=True)
        k = len(b_lo)
        graph = coo_matrix((np.ones(k), (idx[:k], idx[k:])), shape=(len(used), len(used)))
        loops = connected_components(graph, directed=False)[0]

    # Vertex fans: corners of one vertex are joined when their faces share an
    # edge at that vertex (graph node: that end of that edge); more than one
    # group of corners at a vertex means its faces meet only at the vertex.
    edge_in = edge_of  # edge from corner k to k+1
    edge_out = edge_of.reshape(m, 3)[:, [2, 0, 1]].reshape(-1)  # edge from corner k-1 to k
    edge_hi = keys % n_vertices
    end_in = 2 * edge_in + (start == edge_hi[edge_in])
    end_out = 2 * edge_out + (start == edge_hi[edge_out])
    corners = np.arange(3 * m)
    graph = coo_matrix((np.ones(6 * m), (np.concatenate([corners, corners]),
                                         3 * m + np.concatenate([end_in, end_out]))),
                       shape=(3 * m + 2 * len(keys),) * 2)
    n_groups, label = connected_components(graph, directed=False)
    group_vertex = np.full(n_groups, -1, np.int64)
    group_vertex[label[:3 * m]] = start
    fans = np.bincount(group_vertex[group_vertex >= 0], minlength=n_vertices)
    return {"boundary_edges": int(boundary.sum()), "boundary_loops": int(loops),
            "non_manifold_edges": int((count > 2).sum()),
            "non_manifold_vertices": int((fans > 1).sum()),
            "inconsistent_edges": int(inconsistent.sum())}


def _shells(faces, n_vertices):
    """Connected pieces of the faces over welded vertices."""
    if len(faces) == 0:
        return 0
    graph = coo_matrix((np.ones(2 * len(faces)), (np.r_[faces[:, 0], faces[:, 1]],
                                                  np.r_[faces[:, 1], faces[:, 2]])),
                       shape=(n_vertices, n_vertices))
    _, label = connected_components(graph, directed=False)
    return int(len(np.unique(label[faces[:, 0]])))


def _distinct_rows(rows):
    """Lexicographic order of ``rows`` and, along it, where a new distinct row starts."""
    order = np.lexsort(rows.T[::-1])
    ordered = rows[order]
    first = np.ones(len(rows), bool)
    first[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    return order, first


def _weld(points):
    """Distinct positions and, per point, the index of its position."""
    order, first = _distinct_rows(points)
    inverse = np.empty(len(points), np.int64)
    inverse[order] = np.cumsum(first) - 1
    return points[order][first], inverse


def _self_intersecting_faces(vertices, faces):
    from inkray.numerics.tri_intersection import self_intersecting_faces

    return int(self_intersecting_faces(vertices, faces).sum())


def _overall(parts):
    def total(key):
        return int(sum(p[key] for p in parts))

    def weighted_mean(key):
        pairs = [(p[key], p["faces"] - p["degenerate_faces"]) for p in parts if p[key] is not None]
        weight = sum(w for _, w in pairs)
        return float(sum(x * w for x, w in pairs) / weight) if weight else None

    def extreme(key, pick):
        values = [p[key] for p in parts if p[key] is not None]
        return float(pick(values)) if values else None

    counts = ("vertices", "faces", "unreferenced_vertices", "welded_vertices",
              "degenerate_faces", "duplicate_faces", "boundary_edges", "boundary_loops",
              "non_manifold_edges", "non_manifold_vertices", "inconsistent_edges", "shells")
    flags = ("edge_manifold", "vertex_manifold", "watertight", "consistently_oriented")
    crossing = [p["self_intersecting_faces"] for p in parts]
    volumes = [p["volume"] for p in parts]
    return {
        "parts": len(parts),
        **{k: total(k) for k in counts},
        **{k: all(p[k] for p in parts) for k in flags},
        "min_angle_deg": extreme("min_angle_deg", min),
        "mean_min_angle_deg": weighted_mean("mean_min_angle_deg"),
        "max_aspect_ratio": extreme("max_aspect_ratio", max),
        "mean_aspect_ratio": weighted_mean("mean_aspect_ratio"),
        "self_intersecting_faces": None if None in crossing else int(sum(crossing)),
        "volume": None if None in volumes or not parts else float(sum(volumes)),
    }
