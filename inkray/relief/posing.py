"""The pose rig of a relief: its parts' triangulations, joined, deformed as rigidly as possible.

Ink-and-Ray (Sýkora et al., TOG 2014, section 1) names the use this serves:
keeping "correct visibility and connectivity of individual parts during
interactive 2D shape manipulation" (Igarashi, Moscovich and Hughes,
"As-rigid-as-possible shape manipulation", SIGGRAPH 2005). Every relief part
is already a triangulation of its region completed under its occluders
(:mod:`inkray.relief.completion`), so a part moves its hidden area with it.
All parts are deformed in one as-rigid-as-possible system
(:mod:`inkray.numerics.arap`) in which parts are glued where the drawing joins
them:

- *rooted*: a smaller part whose completed outline ends under a part in front
  of it (a leg behind the body, an ear behind the head: the hidden area meets
  the visible part along one cut that is less than ``ROOT_CONTACT`` of its
  border) is glued to that part over its hidden area;
- *on top*: a smaller part lying on a larger one that surrounds it (eyes,
  buttons, a nose: the larger part's hidden area under it is bordered by the
  larger part's visible pixels along at least ``ON_TOP_CONTACT`` of its
  border), or covering only a small area of it (a head on its neck: at most
  ``JOINT_AREA`` of the smaller part's area) is glued to it where it covers it;
- *seams*: along ``stitch`` and ``graft`` boundaries both parts are glued to
  each other;
- *overlap*: where two parts overlap along one cut that neither rule above
  takes (a head on a body, a ball on the one below it, a hat's brim on its
  crown) and nothing else connects them, the smaller is glued to the larger
  over the overlap: the smallest overlaps (against the smaller part) first,
  each only if it joins two pieces the joins so far leave apart, so that a
  limb in front of the body that is rooted elsewhere stays free to swing;
  overlaps that grip (glue three vertices or more, not on one line) come
  before those that would only pin the part at a point it pivots about. Where
  the smaller part's vertices in an overlap do not grip, the larger part's
  vertices there are glued to it too. A root or a part on top that does not
  grip (an arm lying on the head over a few pixels) is taken the same way, as
  a pin: only where nothing else joins its two pieces;
- *keeping its place*: a part the drawing shows no root of (no *rooted*
  join, no seam) hangs where the overlaps guessed. It is glued over its other
  overlaps that grip too, and where it lies across a larger part (its hidden
  area crosses under the part along two cuts or more, and the part nowhere
  under it), so that it keeps its place on every part it lies on: a drag that
  bends the chain of joins between two of them (a fox's head pulling the body
  away from the tail) slides it off neither. A rooted limb lying on the body
  stays free to swing.

A part's hidden area is both its hidden layers
(:attr:`~inkray.relief.completion.Completion.beneath`): its second layer under
another part's hidden area belongs to its piece under the same occluder.

A glue row ties a vertex of one part to the barycentric point of the other
part's triangle under it at rest (for a root also the vertices up to
``_GLUE_REACH`` px beyond its area and off the other part, to the other
part's nearest triangle continued, so the corner where the two outlines meet
cannot open), so the rest shape has no glue energy. Each vertex is glued
once, and the rows are held exactly where they can be (:class:`Arap`
substitutes them), so glued parts do not drift apart and leave a crack.
Parts that crossing alone relates (interlocking rings) stay separate. A
connected piece of the rig that holds no handle stays where it is.
"""

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from inkray.errors import InputError
from inkray.numerics.arap import Arap, best_rotations, pieces, signed_areas
from inkray.relief.model import Part, Relief

__all__ = ["Rig", "Join", "Posing", "rig_relief", "front_mesh", "ROOT_CONTACT", "ON_TOP_CONTACT", "JOINT_AREA"]

#: A hidden area is a part's root when its cut to the part's visible pixels is below this share
#: of its border.
ROOT_CONTACT = 0.55
#: A part lies on top of a larger one when that one's visible pixels border this share of the
#: area under it.
ON_TOP_CONTACT = 0.6
#: A smaller part in front is also glued where it covers a hidden area of at most this share of
#: its own area (a head on a neck): a joint, not an overlap it must be free to leave.
JOINT_AREA = 0.1
#: px: a part's vertices closer than this are one vertex of the rig (the foot and the top of
#: the rim's wall, :data:`inkray.relief.inflation.WALL_INSET` apart).
_WELD = 0.05
_SEAM_REACH = 3.0  # px: vertices this close to a stitch or graft path are glued across it
_LOCATE_TOL = 1.0  # px: a point this close to a part's triangles is on the part
_GLUE_REACH = 1.5  # px: a root's vertices this far beyond its area or off the other part are glued
_GLUE_WEIGHT = 10.0
_REPAIR_REACH = 6.0  # px: around a face that still folds, faces stiffened and glue released
_STIFFER = 10.0
_REPAIRS = 3
_INJECTIVE_ROUNDS = 40  # reweighted rounds that never fold, from the last pose that folds nothing
_HANDLE_TOL = 0.01  # px: how far the rounds that never fold may leave a handle from its target


@dataclass
class Join:
    """Where part ``part`` is glued to part ``to``: ``kind`` (rooted, on top, seam), ``vertices``."""

    part: str
    to: str
    kind: str
    vertices: int


@dataclass
class Rig:
    """All parts of a relief as one 2D triangle mesh with glue rows between parts.

    Attributes
    ----------
    names : list of str
        The relief's parts.
    vertices : (n, 2) float array
        Rest positions, the parts' vertices one after the other.
    heights : (n,) float array
        The front surface's height at each vertex.
    faces : (m, 3) int array
        Front faces, into ``vertices``.
    part_of_face : (m,) int array
    offsets : (P + 1,) int array
        Part ``i``'s vertices are ``offsets[i]:offsets[i + 1]``.
    index : list of (n_i,) int arrays
        For each relief part, the rig vertex of each of its vertices (a
        closed part's back vertices share the front's).
    glue : (g, n) sparse matrix
        Rows that vanish at rest and keep joined parts together.
    joins : list of Join
    relief : inkray.relief.model.Relief
        The rest relief.
    """

    names: list
    vertices: np.ndarray
    heights: np.ndarray
    faces: np.ndarray
    part_of_face: np.ndarray
    offsets: np.ndarray
    index: list
    glue: object
    joins: list = field(default_factory=list)
    relief: Relief = None
    _rest_sign: np.ndarray = field(default=None, repr=False, compare=False)
    _faces_at: np.ndarray = field(default=None, repr=False, compare=False)

    def locate(self, points):
        """The front-most part under each point and the point as a combination of rig vertices.

        Parameters
        ----------
        points : (k, 2) float array

        Returns
        -------
        rows : (k, n) sparse matrix
            Barycentric rows (a point on no part: an empty row).
        part : (k,) int array
            The part, -1 for a point on no part.
        """
        pts = np.asarray(points, float).reshape(-1, 2)
        best_z = np.full(len(pts), -np.inf)
        part = np.full(len(pts), -1)
        rows = [None] * len(pts)
        for i in range(len(self.names)):
            faces = self.faces[self.part_of_face == i]
            hit, face, bary = _locate(self.vertices, faces, pts, _LOCATE_TOL)
            z = np.einsum("kc,kc->k", bary, self.heights[faces[face]]) if len(face) else []
            for k, ok in enumerate(hit):
                if ok and z[k] > best_z[k]:
                    best_z[k], part[k] = z[k], i
                    rows[k] = (faces[face[k]], bary[k])
        r, c, v = [], [], []
        for k, row in enumerate(rows):
            if row is not None:
                r += [k] * 3
                c += list(row[0])
                v += list(row[1])
        return sp.csr_matrix((v, (r, c)), shape=(len(pts), len(self.vertices))), part

    def posed_relief(self, positions):
        """The rest relief with every vertex moved to ``positions`` (same parts, vertices, faces).

        Parameters
        ----------
        positions : (n, 2) float array
            Rig vertices.

        Returns
        -------
        inkray.relief.model.Relief
        """
        parts = []
        for p, idx in zip(self.relief.parts, self.index):
            v = np.array(p.vertices, float)
            # A vertex welded to another (a wall's foot) keeps its small offset from it, turned
            # as a face of the rig at its rig vertex turns.
            offset = v[:, :2] - self.vertices[idx]
            v[:, :2] = positions[idx]
            welded = np.flatnonzero(np.any(offset != 0, axis=1))
            if len(welded):
                faces = self.faces[self._face_at()[idx[welded]]]
                a = best_rotations(self.vertices, faces, positions)
                c, s, o = np.cos(a), np.sin(a), offset[welded]
                v[welded, :2] += np.column_stack([c * o[:, 0] - s * o[:, 1],
                                                  s * o[:, 0] + c * o[:, 1]])
            rest = np.asarray(p.vertices, float)[:, :2] if p.texcoords is None else p.texcoords
            parts.append(Part(name=p.name, vertices=v, faces=p.faces, closed=p.closed,
                              texcoords=rest))
        return Relief(parts=parts, size=self.relief.size, texture=self.relief.texture,
                      warnings=list(self.relief.warnings))

    def _face_at(self):
        """Per rig vertex, one face holding it."""
        if self._faces_at is None:
            self._faces_at = np.zeros(len(self.vertices), np.int64)
            self._faces_at[self.faces.ravel()] = np.repeat(np.arange(len(self.faces)), 3)
        return self._faces_at

    def folds(self, positions):
        """Number of faces whose orientation flipped against the rest shape."""
        return len(self.folded(positions))

    def folded(self, positions):
        """Indices of the faces whose orientation flipped against the rest shape."""
        if self._rest_sign is None:
            self._rest_sign = np.sign(signed_areas(self.vertices, self.faces))
        return np.flatnonzero(self._rest_sign * signed_areas(positions, self.faces) <= 0)


class Posing:
    """A rig prepared for one set of handles: every drag is one warm-started solve.

    Parameters
    ----------
    rig : Rig
    handles : (k, 2) float array
        Points on the drawing.

    Attributes
    ----------
    parts : (k,) int array
        The part each handle holds (the front-most under it).
    fixed : list of str
        Parts that no handle reaches (through the glue): they stay at rest.

    Examples
    --------
    >>> from inkray.relief.completion import complete_regions
    >>> from inkray.relief.inflation import inflate_region
    >>> from inkray.relief.stitching import stitch
    >>> from inkray.relief.assembly import assemble
    >>> labels = np.full((40, 60), -1, np.int32); labels[10:30, 5:55] = 0
    >>> relief = assemble(stitch([inflate_region(labels == 0, name="bar")], [], None), size=(60, 40))
    >>> posing = Posing(rig_relief(relief, complete_regions(labels, names=["bar"])),
    ...                 [[10.0, 20.0], [50.0, 20.0]])
    >>> x, _ = posing.pose([[10.0, 20.0], [38.28, 48.28]], iterations=8)   # turned 45 degrees
    >>> np.round(posing.solver.handles @ x, 6).tolist(), posing.rig.folds(x)
    ([[10.0, 20.0], [38.28, 48.28]], 0)
    """

    def __init__(self, rig, handles):
        h = np.asarray(handles, float).reshape(-1, 2)
        rows, part = rig.locate(h)
        missing = np.flatnonzero(part < 0)
        if missing.size:
            k = int(missing[0])
            raise InputError(f"handles[{k}]: point ({h[k, 0]:g}, {h[k, 1]:g}) lies on no part of "
                             f"the character")
        self.rig = rig
        self.handles = h
        self.parts = part
        n = len(rig.vertices)
        # Pieces (faces and glue connect vertices) without a handle stay where they are.
        piece = pieces(n, rig.faces, rig.glue)
        held = np.unique(piece[rows.tocoo().col])
        fixed = ~np.isin(piece, held)
        self.fixed = [rig.names[i] for i in range(len(rig.names))
                      if fixed[rig.offsets[i]:rig.offsets[i + 1]].all()]
        self._rows, self._fixed, self._glue = rows, np.flatnonzero(fixed), rig.glue.tocsc()
        self._stiffness = np.ones(len(rig.faces))
        self._unfolded = None  # the last pose that folds nothing
        self.solver = self._arap()

    def solve(self, targets, *, iterations=4, initial=None):
        """Rig vertex positions with the handles at ``targets``.

        Parameters
        ----------
        targets : (k, 2) float array
        iterations : int, default 4
            Local/global rounds, warm-started from the previous solve.
        initial : (n, 2) float array, optional

        Returns
        -------
        (n, 2) float array
        """
        t = np.asarray(targets, float).reshape(-1, 2)
        if t.shape != self.handles.shape:
            raise InputError(f"targets: expected {len(self.handles)} points, got {len(t)}")
        return self.solver.solve(t, iterations=iterations, initial=initial)

    def pose(self, targets, *, iterations=4, max_iterations=64):
        """Like :meth:`solve`, but iterates further until no face folds.

        Where faces still fold after ``max_iterations`` rounds, the faces
        within ``_REPAIR_REACH`` of the folds are made ``_STIFFER`` times
        stiffer, the system factored again and the rounds start again from
        the last pose (if it folds nothing; else from the folded one), at most
        ``_REPAIRS`` times; the next drag keeps the repaired system, so a drag
        on costs what it did. Where that has not unfolded them (the energy's
        minimum folds them: a limb glued over the body swung against a pin),
        before the last repair the drag is solved again from the last pose, if
        it folds nothing, by ``_INJECTIVE_ROUNDS`` rounds that never flip a
        face (:meth:`inkray.numerics.arap.Arap.solve_injective`: compressed
        faces weighted stiffer, each step cut before the first flip), kept
        when they bring every handle within ``_HANDLE_TOL`` of its target (the
        last pose: the solver's, or where that folds, the last one this
        method returned that folds nothing). Otherwise (a handle pushed
        through another) the last repair releases the glue rows near the folds
        too (released glue lets joined parts part, a crack in the picture, so
        only when nothing else has unfolded them, and not where that would cut
        off a piece no handle holds).

        Returns
        -------
        positions : (n, 2) float array
        iterations : int
            Rounds spent.
        """
        t = np.asarray(targets, float).reshape(-1, 2)
        start = self.solver.pose.copy()
        unfolded = not self.rig.folds(start)
        if not unfolded and self._unfolded is not None:
            # solves since the last pose folded faces (drags by :meth:`solve`)
            start, unfolded = self._unfolded, True
        x = self.solve(t, iterations=iterations)
        spent = iterations
        for repair in range(_REPAIRS + 1):
            budget = spent + max_iterations
            while (folded := self.rig.folded(x)).size and spent < budget:
                x = self.solve(t, iterations=iterations)
                spent += iterations
            if not folded.size or repair == _REPAIRS:
                break
            if repair == _REPAIRS - 1 and unfolded:
                y = self.solver.solve_injective(t, initial=start, iterations=_INJECTIVE_ROUNDS)
                spent += _INJECTIVE_ROUNDS
                # its steps stop short of a flip, but a face left flat by round-off is folded
                if (np.abs(self.solver.handles @ y - t).max() <= _HANDLE_TOL
                        and not self.rig.folds(y)):
                    self._unfolded = y
                    return y, spent
            centres = x[self.rig.faces[folded]].mean(axis=1)
            near = _within(x, centres, _REPAIR_REACH)
            grow = np.any(near[self.rig.faces], axis=1)
            self._stiffness[grow] = np.minimum(self._stiffness[grow] * _STIFFER, _STIFFER ** _REPAIRS)
            glue = self._glue
            if repair == _REPAIRS - 1 and self._glue.shape[0]:
                touches = np.asarray(abs(self._glue[:, np.flatnonzero(near)]).sum(axis=1)).ravel()
                released = self._glue[touches == 0]
                # not where that cuts off a piece that no handle holds (it would have nothing
                # to follow)
                piece = pieces(len(x), self.rig.faces, released)
                held = np.zeros(piece.max() + 1, bool)
                held[piece[self._rows.tocoo().col]] = True
                held[piece[self._fixed]] = True
                if held.all():
                    self._glue = released
            # stiffer faces alone: the same system reweighted, not built again
            self.solver = (self._arap() if self._glue is not glue
                           else self.solver._reweighted(self._stiffness.copy()))
            x = self.solve(t, iterations=iterations, initial=start if unfolded else x)
            spent += iterations
        if not folded.size:
            self._unfolded = x
        return x, spent

    def _arap(self):
        try:
            return Arap(self.rig.vertices, self.rig.faces, handles=self._rows, glue=self._glue,
                        glue_weight=_GLUE_WEIGHT, fixed=self._fixed, stiffness=self._stiffness)
        except ValueError as e:
            raise InputError(f"handles: {e}") from None


def _within(points, centres, reach):
    """Which points lie within ``reach`` of any centre."""
    return np.isfinite(cKDTree(centres).query(points, distance_upper_bound=reach)[0])


def rig_relief(relief, completion, *, boundaries=()):
    """The rig of a relief: its parts' front faces in one mesh, glued where the drawing joins them.

    Parameters
    ----------
    relief : inkray.relief.model.Relief
        Parts named after the regions (not a union).
    completion : inkray.relief.completion.Completion
        The ordered completion the relief was built from.
    boundaries : list of inkray.input.annotations.Boundary, optional
        ``stitch`` and ``graft`` paths glue the parts that meet there.

    Returns
    -------
    Rig

    Examples
    --------
    >>> from inkray.relief.completion import complete_regions
    >>> from inkray.relief.inflation import inflate_region
    >>> from inkray.relief.stitching import stitch
    >>> from inkray.relief.assembly import assemble
    >>> labels = np.full((40, 60), -1, np.int32); labels[10:30, 5:55] = 0
    >>> c = complete_regions(labels, names=["bar"])
    >>> relief = assemble(stitch([inflate_region(labels == 0, name="bar")], [], None), size=(60, 40))
    >>> rig = rig_relief(relief, c)
    >>> rig.names, rig.glue.shape[0]
    (['bar'], 0)
    >>> rest = rig.posed_relief(rig.vertices).parts[0].vertices  # the wall's feet welded, kept
    >>> bool(np.allclose(rest, relief.parts[0].vertices))
    True
    """
    if not isinstance(relief, Relief):
        raise InputError(f"relief: expected an inkray.relief.model.Relief, got "
                         f"{type(relief).__name__}")
    names = list(completion.names)
    verts, heights, faces, part_of_face, index, offsets = [], [], [], [], [], [0]
    for i, p in enumerate(relief.parts):
        if p.name not in names:
            raise InputError(f"relief: part {p.name!r} is not a region of the drawing (a union "
                             f"of all parts cannot be posed)")
        first, inverse, top, tri = front_mesh(p)
        base = offsets[-1]
        verts.append(np.asarray(p.vertices, float)[first, :2])
        heights.append(top)
        faces.append(tri + base)
        part_of_face.append(np.full(len(tri), i))
        index.append(inverse + base)
        offsets.append(base + len(first))
    vertices = np.concatenate(verts)
    rig = Rig(names=[p.name for p in relief.parts], vertices=vertices,
              heights=np.concatenate(heights), faces=np.concatenate(faces),
              part_of_face=np.concatenate(part_of_face), offsets=np.array(offsets),
              index=index, glue=sp.csr_matrix((0, len(vertices))), relief=relief)
    # Row blocks: (glue rows, their join, whether they are the larger part's rows of an
    # overlap, reported within the smaller part's join to it).
    # spare: glue taken only where it keeps a part with no root in place (below)
    blocks, overlaps, spare = [], [], []
    region_part = {names.index(n): i for i, n in enumerate(rig.names)}
    for b, a, kind, mask in _joined_areas(completion):
        if b in region_part and a in region_part:
            pb, pa = region_part[b], region_part[a]
            # a root's corners, where its outline leaves the part in front, are glued too
            reach = _GLUE_REACH if kind == "rooted" else 0.0
            near = ndimage.distance_transform_edt(~mask) <= reach
            got = _glue_rows(rig, pb, pa, lambda xy, m=near: _inside(m, xy), reach=reach)
            grips = _grips(rig, (got, rig.names[pb]))
            if grips and kind not in ("overlap", "across"):
                blocks.append((got, Join(rig.names[pb], rig.names[pa], kind, got.shape[0]), False))
                continue
            # Where the smaller part's vertices in an overlap do not grip, the larger part's
            # glue it too (both cover an overlap alike): whether the join holds does not hang
            # on which of the two triangulations happens to put vertices there.
            held = [(got, Join(rig.names[pb], rig.names[pa], kind, got.shape[0]), False)]
            if not grips and kind in ("overlap", "across"):
                back = _glue_rows(rig, pa, pb, lambda xy, m=mask: _inside(m, xy), reach=0.0)
                held.append((back, Join(rig.names[pa], rig.names[pb], kind, back.shape[0]), True))
                grips = _grips(rig, *((g, j.part) for g, j, _ in held))
            held = [block for block in held if block[0].shape[0]]
            if not held:
                continue
            if kind == "across":  # no join of its own: only where it keeps a part in place
                if grips:
                    spare.append([(g, replace(j, kind="overlap"), back) for g, j, back in held])
                continue
            # A root or a part on top glued at a vertex or two would pivot there: like an
            # overlap that only pins, it joins only what nothing else joins.
            overlaps.append((held, grips))
    for seam in boundaries:
        if seam.type not in ("stitch", "graft"):
            continue
        path = np.asarray(seam.path, float)
        for pb in range(len(rig.names)):
            for pa in range(len(rig.names)):
                if pa == pb:
                    continue
                got = _glue_rows(rig, pb, pa, lambda xy, p=path: _near(p, xy, _SEAM_REACH),
                                 reach=0.0)
                if got.shape[0]:
                    blocks.append((got, Join(rig.names[pb], rig.names[pa], seam.type,
                                             got.shape[0]), False))
    # An overlap joins two pieces that nothing else joins: the smallest overlaps first (the
    # most joint-like), none between parts already connected, so that a limb in front of the
    # body stays free to swing where it is rooted elsewhere.
    piece = pieces(len(vertices), rig.faces,
                   sp.vstack([got for got, _, _ in blocks]) if blocks else None)
    root = list(range(piece.max() + 1))

    def find(k):
        while root[k] != k:
            root[k] = root[root[k]]
            k = root[k]
        return k

    # Overlaps that grip (glue at least three vertices not on one line) go first: one that
    # glues a vertex or two is a pin the part pivots about, taken only where nothing grips.
    overlaps.sort(key=lambda o: not o[1])
    for held, grips in overlaps:
        cols = np.concatenate([got.tocoo().col for got, _, _ in held])
        touched = {find(int(k)) for k in np.unique(piece[cols])}
        if len(touched) > 1:
            first, *others = touched
            for k in others:
                root[k] = first
            blocks += held
        elif grips:
            spare.append(held)
    # A part the drawing shows no root of keeps its place on every part it lies on (module
    # docstring): its spare overlaps and crossings that grip are glued too.
    rooted = {join.part for _, join, _ in blocks if join.kind in ("rooted", "stitch", "graft")}
    rooted |= {join.part for held, _ in overlaps for _, join, _ in held if join.kind == "rooted"}
    blocks += [block for held in spare if held[0][1].part not in rooted for block in held]
    blocks = _once_per_vertex(rig, blocks)
    if blocks:
        rig.glue = sp.vstack([got for got, _, _ in blocks]).tocsr()
    rig.joins = _reported(blocks)
    return rig


def _reported(blocks):
    """The joins as the drawing joins its parts: the larger part's rows of an overlap (the
    blocks flagged so) counted in the smaller part's join to it."""
    out, forward = [], {}
    for _, join, back in blocks:
        if not back:
            forward[(join.part, join.to, join.kind)] = len(out)
            out.append(join)
    for _, join, back in blocks:
        if back:
            k = forward.get((join.to, join.part, join.kind))
            if k is None:
                out.append(Join(join.to, join.part, join.kind, join.vertices))
            else:
                out[k] = replace(out[k], vertices=out[k].vertices + join.vertices)
    return out


def _grips(rig, *held):
    """Whether glue rows hold at least three vertices not on one line (within
    ``_LOCATE_TOL``), so that they can hold a rotation as well as a place: ``held`` are
    ``(rows, part)`` pairs, the vertices of ``part`` each one's rows glue taken together."""
    xy = []
    for rows, part in held:
        i = rig.names.index(part)
        cols = np.unique(rows.tocoo().col)
        xy.append(rig.vertices[cols[(cols >= rig.offsets[i]) & (cols < rig.offsets[i + 1])]])
    xy = np.concatenate(xy)
    if len(xy) < 3:
        return False
    spread = np.linalg.svd(xy - xy.mean(axis=0), compute_uv=False)
    return bool(spread[1] / np.sqrt(len(xy)) > _LOCATE_TOL)


def _once_per_vertex(rig, blocks):
    """Each vertex glued by its first row only (areas of two joins can share vertices): the
    rows then pivot on distinct vertices and all can be held exactly. Blocks left with no row
    are dropped; each join counts the rows kept."""
    taken = np.zeros(len(rig.vertices), bool)
    out = []
    for got, join, back in blocks:
        pb = rig.names.index(join.part)
        coo = got.tocoo()
        own = (coo.col >= rig.offsets[pb]) & (coo.col < rig.offsets[pb + 1])
        vertex = np.empty(got.shape[0], np.int64)
        vertex[coo.row[own]] = coo.col[own]
        fresh = ~taken[vertex]
        fresh &= np.unique(vertex, return_index=True)[1][np.searchsorted(
            np.unique(vertex), vertex)] == np.arange(len(vertex))
        taken[vertex[fresh]] = True
        if fresh.any():
            out.append((got[np.flatnonzero(fresh)], replace(join, vertices=int(fresh.sum())),
                        back))
    return out


def front_mesh(part):
    """A relief part's front surface as a 2D triangle mesh: one vertex per ``(x, y)``.

    A closed part's back copies its front's ``(x, y)``; both become one
    vertex, at the front's height, and only the front's faces are kept.
    Vertices closer than :data:`_WELD` px (a rim wall's foot and top) are
    one vertex too, and the wall's faces drop out as degenerate.

    Parameters
    ----------
    part : inkray.relief.model.Part

    Returns
    -------
    first : (k,) int array
        The part's front vertex at each mesh vertex.
    inverse : (n,) int array
        The mesh vertex of each vertex of the part.
    top : (k,) float array
        The front surface's height at each mesh vertex.
    faces : (m, 3) int array
        Front faces into the mesh vertices, none degenerate.

    Examples
    --------
    >>> v = np.array([[0, 0, 1], [4, 0, 1], [0, 4, 1], [0, 0, -1], [4, 0, -1], [0, 4, -1]], float)
    >>> front = front_mesh(Part("p", v, np.array([[0, 1, 2], [3, 5, 4]]), closed=True))
    >>> front[0].tolist(), front[2].tolist(), front[3].tolist()
    ([0, 2, 1], [1.0, 1.0, 1.0], [[0, 2, 1]])
    """
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64).reshape(-1, 3)
    xy, inverse = np.unique(np.round(v[:, :2], 9), axis=0, return_inverse=True)
    inverse = _weld(xy, inverse.reshape(-1))
    top = np.full(inverse.max() + 1, -np.inf)
    np.maximum.at(top, inverse, v[:, 2])
    on_top = v[:, 2] >= top[inverse] - 1e-9
    _, copy = np.unique(inverse[on_top], return_index=True)
    first = np.flatnonzero(on_top)[copy]  # each mesh vertex's first front copy
    front = f[np.all(on_top[f], axis=1)] if part.closed else f
    tri = inverse[front]
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])]
    return first, inverse, top, tri


def _weld(xy, inverse):
    """``inverse`` with the points of ``xy`` closer than :data:`_WELD` px as one point."""
    pairs = cKDTree(xy).query_pairs(_WELD, output_type="ndarray")
    if not len(pairs):
        return inverse
    graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                          shape=(len(xy), len(xy)))
    _, component = connected_components(graph, directed=False)
    # Components numbered in the order of their first point, as np.unique numbers them.
    _, first = np.unique(component, return_index=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[component][inverse]


def _joined_areas(completion):
    """``(part, to, kind, mask)``: the areas where one region is glued to another.

    ``overlap`` areas (a single cut that neither rule takes) come next, the
    smallest against the smaller part's area first, and last ``across``
    areas: a part lying across another (its hidden area crosses under the
    one in front, which nowhere crosses under it), the smaller on the larger.
    """
    labels, owner, beneath = completion.labels, completion.owner, completion.beneath
    area = np.bincount((labels[labels >= 0]).ravel(), minlength=completion.count)
    area = area + np.bincount(owner[owner >= 0].ravel(), minlength=completion.count)
    if beneath is not None:
        area = area + np.bincount(beneath[beneath >= 0].ravel(), minlength=completion.count)
    out, overlaps, crossings = [], [], []
    for b in range(completion.count):
        # both hidden layers: which of two parts hidden side by side holds a pixel in
        # ``owner`` and which beneath it does not change where either is hidden
        second = np.zeros(labels.shape, bool) if beneath is None else beneath == b
        pieces, n = _hidden_pieces(owner == b, second, labels)
        if not n:
            continue
        visible = ndimage.binary_dilation(labels == b)
        for k, sl in enumerate(ndimage.find_objects(pieces), start=1):
            grown = tuple(slice(max(s.start - 1, 0), s.stop + 1) for s in sl)
            piece = pieces[grown] == k
            contact = piece & visible[grown]
            border = piece & ~ndimage.binary_erosion(piece)
            share = contact.sum() / max(border.sum(), 1)
            cuts = ndimage.label(contact, structure=np.ones((3, 3)))[1]
            a = int(np.bincount(labels[grown][piece]).argmax())
            mask = np.zeros(labels.shape, bool)
            mask[grown] = piece
            if cuts > 1:
                crossings.append((b, a, mask))
            if cuts != 1:
                continue
            if share < ROOT_CONTACT and area[b] < area[a]:
                out.append((b, a, "rooted", mask))
            elif area[a] < area[b] and (share >= ON_TOP_CONTACT
                                        or piece.sum() <= JOINT_AREA * area[a]):
                out.append((a, b, "on top", mask))
            else:  # the smaller part glued to the larger over the overlap
                small, large = (b, a) if area[b] < area[a] else (a, b)
                overlaps.append((piece.sum() / area[small], small, large, mask))
    overlaps.sort(key=lambda o: o[0])
    # interlocking rings cross under each other: not glued
    under = {(b, a) for b, a, _ in crossings}
    across = [(b, a, mask) if area[b] < area[a] else (a, b, mask)
              for b, a, mask in crossings if (a, b) not in under]
    return (out + [(small, large, "overlap", mask) for _, small, large, mask in overlaps]
            + [(small, large, "across", mask) for small, large, mask in across])


def _hidden_pieces(first, second, labels):
    """The pieces of a part's hidden area (as ``ndimage.label``): those of its ``first``
    layer, each grown by the ``second`` layer's pixels it touches under the same
    occluder; second-layer pixels that touch none are pieces of their own. A second
    layer under another part's hidden area reaches from one occluder's pixels to the
    next, but each occluder joins it on its own."""
    pieces, n = ndimage.label(first)
    for a in np.unique(labels[second]):
        extra = second & (labels == a)
        mine = (pieces > 0) & (labels == a)
        found, k = ndimage.label(extra | mine)
        host = np.zeros(k + 1, np.int64)
        np.maximum.at(host, found[mine], pieces[mine])
        held = extra & (host[found] > 0)
        pieces[held] = host[found[held]]
        alone, m = ndimage.label(extra & ~held)
        pieces[alone > 0] = alone[alone > 0] + n
        n += m
    return pieces, n


def _glue_rows(rig, pb, pa, where, *, reach):
    """Rows tying the vertices of part ``pb`` selected by ``where`` to part ``pa`` under them
    (or within ``reach`` px of it)."""
    lo, hi = rig.offsets[pb], rig.offsets[pb + 1]
    xy = rig.vertices[lo:hi]
    pick = np.flatnonzero(where(xy))
    if not pick.size:
        return sp.csr_matrix((0, len(rig.vertices)))
    faces = rig.faces[rig.part_of_face == pa]
    # Vertices a little off the other part (where the outlines of both meet) are tied to its
    # nearest triangle's affine map continued beyond it, so the joint's corner cannot open.
    hit, face, bary = _locate(rig.vertices, faces, xy[pick], reach, extrapolate=True)
    pick, face, bary = pick[hit], face[hit], bary[hit]
    k = len(pick)
    r = np.repeat(np.arange(k), 4)
    c = np.column_stack([pick + lo, faces[face]]).ravel()
    v = np.column_stack([np.ones(k), -bary]).ravel()
    return sp.csr_matrix((v, (r, c)), shape=(k, len(rig.vertices)))


def _inside(mask, xy):
    h, w = mask.shape
    col = np.clip(np.rint(xy[:, 0]).astype(int), 0, w - 1)
    row = np.clip(np.rint(xy[:, 1]).astype(int), 0, h - 1)
    return mask[row, col]


def _near(path, xy, reach):
    if len(path) == 1:
        return np.hypot(*(xy - path[0]).T) <= reach
    a, b = path[:-1], path[1:]
    d = b - a
    t = np.clip(np.einsum("nkc,kc->nk", xy[:, None] - a, d) / np.maximum(
        np.einsum("kc,kc->k", d, d), 1e-12), 0, 1)
    foot = a + t[..., None] * d
    return np.min(np.hypot(*(xy[:, None] - foot).transpose(2, 0, 1)), axis=1) <= reach


def _locate(vertices, faces, points, tol, *, extrapolate=False):
    """Which points lie on the 2D faces (within ``tol``), their face and barycentric coordinates.

    The coordinates are the nearest point's in the nearest face, or with ``extrapolate`` the
    point's own in that face's plane (negative off the face), so that they reproduce it.
    """
    import igl

    k = len(points)
    if k == 0 or len(faces) == 0:
        return np.zeros(k, bool), np.zeros(0, np.int64), np.zeros((0, 3))
    flat = np.column_stack([vertices, np.zeros(len(vertices))])
    query = np.column_stack([points, np.zeros(k)])
    d2, face, near = igl.point_mesh_squared_distance(query, flat, faces.astype(np.int64))
    t = vertices[faces[face]]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    r = (np.asarray(points, float) if extrapolate else near[:, :2]) - t[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    l1 = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / det
    l2 = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / det
    bary = np.column_stack([1 - l1 - l2, l1, l2])
    if not extrapolate:
        bary = np.clip(bary, 0, 1)
        bary /= bary.sum(axis=1, keepdims=True)
    return d2 <= tol * tol + 1e-12, face.astype(np.int64), bary
