"""Region completion with illusory surfaces.

A part ``B`` of a drawing that is partly hidden by a neighbouring part ``A``
is completed under ``A`` as in Ink-and-Ray (Sýkora et al., "Ink-and-Ray:
Bas-Relief Meshes for Adding Global Illumination Effects to Hand-Drawn
Characters", ACM TOG 33(2), 2014, section 4), following Geiger, Pao and
Rubin, "Salient and multiple illusory surfaces" (CVPR 1998): on the pixels of
``A`` solve the Laplace equation with value 1 next to ``B`` and 0 next to
anything else; the pixels with value > 0.5 belong to the completed ``B'``.

Every region is treated as a possible occluder of each of its neighbours, so
the result holds *candidate* completions in both directions of every pair;
:mod:`inkray.order` decides who is in front where, and
:meth:`Completion.ordered` keeps only the hidden parts under the region that
is in front. The Laplacian of one occluder does not depend on ``B``: it is
factored once and all its neighbours are solved as right-hand sides of that
one factorization, on the occluder's bounding box only.

Because the values of all neighbours and of "anything else" sum to one at
every pixel, at most one neighbour exceeds 0.5 there, so a pixel of ``A``
completes at most one region; the candidates fit in one ``owner`` image.
Where no value exceeds 0.5 a few pixels of ``A`` between two hidden parts
belong to ``A`` alone; the ordered completion gives such narrow gaps to a
part hidden beside them (:func:`close_gaps`), so that what a posed part
uncovers is always some part's completed area.

Where a graft cuts two parts apart across the paper (a thigh folded against
a frog's body), the silhouette at the graft's end has no junction: it is the
outline of either part as much as the other's. Along it, as far as it keeps
bending outward as an outline does (:func:`shared_outlines`), it counts as the
hidden part's own outline, both in the diffusion (value 1) and in the
continued outline; the body under the thigh reaches the rump's silhouette
instead of stopping half-way across the thigh.
"""

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from scipy import ndimage

from inkray.errors import InputError, StageError
from inkray.numerics.multigrid import multigrid_solve
from inkray.numerics.spd import nested_dissection, spd_factor
from inkray.numerics.threads import thread_imap, thread_map
from inkray.relief.cutout import stack_order

__all__ = ["Completion", "Place", "complete_regions", "continue_outline", "close_gaps",
           "shared_outlines", "check_labels", "GAP"]

#: The widest strip of an occluder beside a part hidden under it that the ordered completion
#: gives to that part (:func:`close_gaps`), as a share of the image's size ``sqrt(H W)``: the
#: diffusion is the same at every resolution, so its strips widen with the drawing
#: (6 px at 1 Mpx).
GAP = 0.006
#: Grid systems of more pixels than this are not factored whole: with one right-hand side
#: they are solved by multigrid conjugate gradients (the factorization's answer to
#: rounding), an occluder with several neighbours coarse to fine (``complete_regions``).
#: The bundled drawings at their own size stay below it but for the four largest.
COARSE_ABOVE = 60_000

#: A silhouette shared at a graft's end is followed while it bends outward at least as much
#: as a circle of radius ``SHARED_RADIUS`` times ``sqrt(H W)``: it stops where it straightens
#: (a limb's own outline running on from a round shoulder) or bends inward.
SHARED_RADIUS = 4.0
_SHARED_SCALE = 0.01  # the silhouette's curvature is read at this scale (share of sqrt(H W))
_SHARED_NEAR = 0.03   # a graft's end this close to the silhouette (share of sqrt(H W)) is on it
_ROUNDING = 2.0  # px: width over which a continued outline turns into its closing offset
_OUTSIDE = -2  # beyond the image frame: no neighbour (zero normal derivative there)
_STEPS = ((0, 1), (1, 0), (0, -1), (-1, 0))


@dataclass
class Place:
    """One overlap area of two neighbouring regions: where an order applies.

    A place is a connected component (8-connectivity) of the pixels of ``a``
    that may hide ``b``, the pixels of ``b`` that may hide ``a`` (the
    candidate invented pixels of both directions) and the pixels on both
    sides of their common outline. Two rings that cross twice have two places.

    Attributes
    ----------
    index : int
        Position in :attr:`Completion.places`.
    a, b : int
        The two regions, ``a < b``.
    box : (y0, y1, x0, x1)
        Bounding box of the place in the image (end exclusive).
    mask : (y1 - y0, x1 - x0) bool array
        The place inside ``box``.
    contact : (y1 - y0, x1 - x0) bool array
        The pixels of the place that touch the other region (4-neighbours).
    where : (x, y)
        A contact pixel near the middle of the contact, for reports.
    junctions : list of (x, y)
        Points where the outline between ``a`` and ``b`` ends at a third
        label (another region or the background): the T- or Y-junctions.
    site : int
        Places that touch each other (e.g. the three places around a triple
        junction) share a site; depth order must be acyclic within a site.
    """

    index: int
    a: int
    b: int
    box: tuple
    mask: np.ndarray
    contact: np.ndarray
    where: tuple
    junctions: list = field(default_factory=list)
    site: int = -1

    def full_mask(self, shape):
        """The place as an (H, W) bool mask of an image of ``shape``."""
        out = np.zeros(shape, bool)
        y0, y1, x0, x1 = self.box
        out[y0:y1, x0:x1] = self.mask
        return out

    def distance(self, point):
        """Euclidean distance in pixels from ``point`` ``(x, y)`` to the place."""
        ys, xs = np.nonzero(self.mask)
        y0, _, x0, _ = self.box
        return float(np.min(np.hypot(xs + x0 - point[0], ys + y0 - point[1])))


@dataclass
class Completion:
    """Regions completed under their neighbours.

    Attributes
    ----------
    labels : (H, W) int32 array
        The segmentation: ``-1`` background, ``0..R-1`` regions.
    names : list of str
        ``names[i]`` is the name of region ``i``.
    owner : (H, W) int32 array
        For a pixel of region ``A``, the region ``B`` whose hidden part it is
        (invented pixel of ``B'``), else ``-1``. The region that hides an
        invented pixel is therefore ``labels`` there. In the result of
        :func:`complete_regions` these are candidates for every neighbour;
        after :meth:`ordered` only those under a region in front remain.
    neighbours : list of list of int
        ``neighbours[i]``: the regions sharing an outline with region ``i``
        (4-neighbourhood), ascending.
    places : list of Place
        The overlap areas of all neighbouring pairs.
    beneath : (H, W) int32 array or None
        A second hidden layer under ``owner``: where the continued outline of
        one of two regions hidden side by side under ``labels`` reaches under
        the other's hidden part, the one lower in the layer stack, else ``-1``
        (see :meth:`ordered`). At rest ``owner`` covers it; when ``owner``'s
        part moves away in a pose, it shows. None before the order.
    shared : dict
        ``(front, back)``: the paper pixels along the silhouette of ``front``
        that continue the outline of ``back`` grafted to it, a (k, 2) int
        array of (row, column) (see :func:`shared_outlines`); empty without
        grafts.
    """

    labels: np.ndarray
    names: list
    owner: np.ndarray
    neighbours: list
    places: list
    beneath: np.ndarray = None
    shared: dict = field(default_factory=dict)

    @property
    def count(self):
        """Number of regions ``R``."""
        return len(self.names)

    def visible(self, region):
        """(H, W) bool mask of the visible pixels of ``region``."""
        return self.labels == region

    def completed(self, region):
        """(H, W) bool mask of the completed region: visible ∪ invented (both hidden layers)."""
        out = (self.labels == region) | (self.owner == region)
        if self.beneath is not None:
            out |= self.beneath == region
        return out

    def hidden_by(self, region):
        """(H, W) int32 image: the region hiding each invented pixel of ``region``, else -1."""
        return np.where(self.owner == region, self.labels, -1).astype(np.int32)

    def ordered(self, relations, *, curvature=True, memo=None, gap=None):
        """Keep only the hidden parts under a region that is in front of them.

        Parameters
        ----------
        relations : list of inkray.relief.ordering.Relation
            Relations of kind ``"order"`` with a place keep the invented
            pixels of ``back`` under ``front`` inside that place; everything
            else invented is dropped (a pair without order, or an ``equal``,
            hides nothing).
        curvature : bool, default True
            Reshape each kept hidden part so that the outline of ``back``
            continues with its curvature, not only its direction (see
            :func:`continue_outline`); the diffusion alone joins the two ends
            of a curved outline with a nearly straight line.
        memo : dict, optional
            Reshaped parts by ``(front, back, place)``, filled and reused:
            pass the same dict to every call on this completion and a
            changed order reshapes only the parts it adds.
        gap : float, optional
            Close the gaps up to this width (px) that an occluder's pixels
            leave beside the parts hidden under it (:func:`close_gaps`);
            default ``GAP`` times ``sqrt(H W)``; 0 leaves them.

        Returns
        -------
        Completion
            A copy with ``owner`` reduced (and reshaped) and, with
            ``curvature``, ``beneath``: where the continued outline of one of
            two parts hidden side by side under one occluder reaches under the
            other, both parts keep the pixels, the one lower in the layer
            stack as a second layer; ``places`` are those of the candidates.

        Examples
        --------
        >>> import numpy as np
        >>> labels = np.full((20, 30), -1, np.int32)
        >>> labels[5:15, 5:25] = 0; labels[:, 12:16] = 1
        >>> c = complete_regions(labels)
        >>> int(c.ordered([]).completed(0).sum()) == int((labels == 0).sum())
        True
        """
        owner = np.full(self.owner.shape, -1, np.int32)
        kept, seen = [], set()
        for r in relations:
            # Two relations can speak of one place (an entry and a prediction):
            # its piece is kept, and reshaped, once.
            if r.kind != "order" or r.place is None or (r.front, r.back, r.place) in seen:
                continue
            seen.add((r.front, r.back, r.place))
            p = self.places[r.place]
            y0, y1, x0, x1 = p.box
            win = (slice(y0, y1), slice(x0, x1))
            piece = p.mask & (self.labels[win] == r.front) & (self.owner[win] == r.back)
            owner[win][piece] = r.back
            kept.append((r.front, r.back, p, piece))
        if curvature:
            memo = {} if memo is None else memo
            todo = {(front, back, p.index): (front, back, p.box, piece)
                    for front, back, p, piece in kept
                    if piece.any() and (front, back, p.index) not in memo}
            # Each reshaping reads only the labels; applied below in the relations' order.
            memo.update(zip(todo, thread_map(
                lambda args: _continuation(self._outlined(args[0], args[1]), *args),
                list(todo.values()))))
            for front, back, p, piece in kept:
                found = memo.get((front, back, p.index))
                if piece.any() and found is not None:  # None: no outline of its own to continue
                    _apply_continuation(owner, back, found)
        if gap is None or gap > 0:
            close_gaps(self.labels, owner, {(front, back) for front, back, _, piece in kept
                                            if piece.any()}, width=gap)
        beneath = np.full(owner.shape, -1, np.int32)
        if curvature:
            continued = [(front, back, memo.get((front, back, p.index)))
                         for front, back, p, piece in kept if piece.any()]
            _second_layers(self.labels, owner, beneath, continued, relations, self.count)
        return replace(self, owner=owner, beneath=beneath)


    def _outlined(self, front, back):
        """The labels with the silhouette of ``front`` that continues ``back``'s outline
        given to ``back`` (the labels themselves when there is none)."""
        run = self.shared.get((front, back))
        if run is None:
            return self.labels
        labels = self.labels.copy()
        labels[run[:, 0], run[:, 1]] = back
        return labels


def _second_layers(labels, owner, beneath, continued, relations, count):
    """Keep a hidden part's continuation where it reaches under another part hidden beside it.

    Under one occluder two hidden parts (a body and the tail behind an arm) meet where
    the diffusion gives each pixel to one of them; the outline of each was continued
    (:func:`continue_outline`) beyond that cut, under the other's part, but ``owner``
    holds one region per pixel. Where a continuation reaches under the other part, both
    are kept: the one higher in the layer stack (:func:`inkray.relief.cutout.stack_order`)
    in ``owner``, the other as its second layer in ``beneath`` (both modified in place).
    When either part moves away in a pose, what lay under it is the other's continued
    part, not paper.

    ``continued`` holds ``(front, back, found)`` per kept hidden part, ``found`` the
    :func:`_continuation` of ``back`` under ``front`` (or None).
    """
    rank = None
    for front, back, found in continued:
        if found is None:
            continue
        window, _, grown = found
        own, under = owner[window], beneath[window]
        over = grown & (own >= 0) & (own != back) & (under < 0)
        for other in np.unique(own[over]):
            if rank is None:
                order, _ = stack_order(count, relations)
                rank = {r: k for k, r in enumerate(order)}
            at = over & (own == other)
            if rank[int(other)] > rank[back]:
                under[at] = back
            else:
                own[at], under[at] = back, other
    _keep_attached(labels, owner, beneath)


def _keep_attached(labels, owner, beneath):
    """Drop the second-layer pixels cut off from their region (both arrays in place).

    Another part's second layer can take the pixels that joined a continuation to the
    rest of its region; an island left behind would be a piece of the region that no
    join holds. Where the region holding it in ``owner`` had taken it over from the one
    beneath, that one gets it back.
    """
    layered = beneath >= 0
    for region in np.union1d(beneath[layered], owner[layered]):
        mine = (beneath == region) | ((owner == region) & (beneath >= 0))
        pieces, _ = ndimage.label((labels == region) | (owner == region) | (beneath == region))
        cut = mine & ~np.isin(pieces, np.unique(pieces[labels == region]))
        if cut.any():
            taken = cut & (owner == region)
            owner[taken] = beneath[taken]
            beneath[cut] = -1


def close_gaps(labels, owner, hidden, *, width=None):
    """Give the pixels of an occluder in a narrow gap beside a part hidden under it to that part.

    The completion leaves to an occluder ``A`` alone its pixels where no
    neighbour's diffusion value reaches the threshold: a strip a few pixels
    wide where two parts hidden under ``A`` (an arm's root and the body,
    under a head) end short of each other, or where a hidden part ends short
    of another region's outline. At rest ``A`` covers such a strip; when
    ``A`` or the part beside it moves in a pose (an arm rooted in the head
    swung away), the strip belongs to no part and the picture has a hole. A
    pixel of ``A`` goes to a part hidden under ``A`` when it lies within
    ``width / 2`` (rounded to whole pixels) of that hidden part and in a gap
    between the other regions' completed areas (what their closing by a disk
    of that radius adds). Of several such parts it goes to one the others are in
    front of (``(front, back)`` in ``hidden``), else to the nearest: what a
    part in front uncovers as it moves is the part behind it. A hidden
    part's outline that faces only ``A`` stays as the completion continued it.

    Parameters
    ----------
    labels : (H, W) int array
    owner : (H, W) int32 array
        The hidden parts (as :attr:`Completion.owner`); modified in place.
    hidden : set of (int, int)
        ``(front, back)`` pairs: ``back`` has a hidden part under ``front``.
        Only these parts grow, each under its own occluder.
    width : float, optional
        The widest gap closed, in pixels; default ``GAP`` times ``sqrt(H W)``.

    Returns
    -------
    int
        The number of pixels given to a hidden part.

    Examples
    --------
    Two bars hidden under a square end 2 px short of each other; the gap
    closes but for its rounded ends, and nothing grows beyond it:

    >>> import numpy as np
    >>> labels = np.full((30, 40), -1, np.int32)
    >>> labels[5:25, 10:30] = 2                         # the square in front
    >>> labels[10:20, :10] = 0; labels[10:20, 30:] = 1  # two bars behind it
    >>> owner = np.full(labels.shape, -1, np.int32)
    >>> owner[10:20, 10:19] = 0; owner[10:20, 21:30] = 1
    >>> close_gaps(labels, owner, {(2, 0), (2, 1)}, width=6)
    16
    >>> bool((owner[11:19, 10:30] >= 0).all()), int((owner >= 0).sum())
    (True, 196)
    """
    width = GAP * np.sqrt(labels.size) if width is None else float(width)
    if width <= 0:
        return 0
    r = max(int(round(width / 2.0)), 1)  # whole pixels: the disk keeps its shape
    reach = float(r)
    h, w = labels.shape
    disk = np.hypot(*np.mgrid[-r:r + 1, -r:r + 1]) <= reach
    under = {}
    for front, back in hidden:
        under.setdefault(front, set()).add(back)
    given = 0
    for a in sorted(under):
        ys, xs = np.nonzero((labels == a) & np.isin(owner, sorted(under[a])))
        if ys.size == 0:
            continue
        pad = 2 * r + 2  # the closing and the distances near the hidden parts see all they need
        win = (slice(max(ys.min() - pad, 0), min(ys.max() + pad + 1, h)),
               slice(max(xs.min() - pad, 0), min(xs.max() + pad + 1, w)))
        lab, own = labels[win], owner[win]
        free = (lab == a) & (own < 0)
        if not free.any():
            continue
        # The gaps: what closing the other regions' completed areas adds to a's pixels.
        others = ((lab >= 0) & (lab != a)) | (own >= 0)
        gaps = free & ndimage.binary_closing(np.pad(others, r + 1), disk)[r + 1:-r - 1, r + 1:-r - 1]
        backs = [b for b in sorted(under[a]) if (own == b).any()]
        candidate, distance = [], []
        for b in backs:
            d = _distance_within(~((lab == a) & (own == b)), reach)  # from its part under a
            # b's parts hidden under other occluders stay apart: the rig joins each on its own
            apart = ndimage.binary_dilation((lab != a) & (own == b), np.ones((3, 3), bool))
            candidate.append(gaps & (d <= reach) & ~apart)
            distance.append(d)
        candidate, distance = np.array(candidate), np.array(distance)
        # A part with another candidate behind it is in front there: it comes second.
        in_front = np.zeros(candidate.shape, bool)
        for i, b in enumerate(backs):
            for j, c in enumerate(backs):
                if i != j and (b, c) in hidden:
                    in_front[i] |= candidate[j]
        score = np.where(candidate, distance + np.where(in_front, 2.0 * width + 1.0, 0.0), np.inf)
        take = candidate.any(axis=0)
        own[take] = np.asarray(backs)[np.argmin(score, axis=0)[take]]
        given += int(take.sum())
    return given


def _distance_within(free, reach):
    """The distance transform of ``free`` where it is at most ``reach``, computed on the
    box of the zeros grown by ``reach`` (inf beyond it)."""
    ys, xs = np.nonzero(~free)
    if ys.size == 0:
        return ndimage.distance_transform_edt(free)
    pad = int(np.ceil(reach)) + 1
    box = (slice(max(ys.min() - pad, 0), ys.max() + pad + 1),
           slice(max(xs.min() - pad, 0), xs.max() + pad + 1))
    out = np.full(free.shape, np.inf)
    out[box] = ndimage.distance_transform_edt(free[box])
    return out


def continue_outline(labels, owner, front, back, box, piece, *, margin=0.25, band=1.5):
    """Reshape the hidden part of ``back`` under ``front`` to continue its curved outline.

    ``phi``, the signed distance to the outline of ``back`` (positive inside;
    only where that outline meets something other than ``front``), is known
    around ``front``. A signed distance satisfies ``lap phi = -k`` with ``k``
    the curvature of its level sets, so ``phi`` is extended into ``front``'s
    pixels near the hidden part by the Poisson equation ``lap phi = k_mean``,
    with ``k_mean`` the mean discrete Laplacian of the known ``phi`` within
    ``band`` pixels of the outline, Dirichlet values from the known pixels and
    no condition where the window cuts ``front``. The zero level is the
    continued outline: straight outlines continue straight and circles as
    circles, where the plain diffusion joins the two ends with a chord.

    Parameters
    ----------
    labels : (H, W) int array
    owner : (H, W) int32 array
        Modified in place: the old ``piece`` is replaced by the new one,
        never over a pixel another region already owns.
    front, back : int
        The occluder and the hidden region.
    box : (y0, y1, x0, x1)
        Where ``piece`` lies in the image.
    piece : bool array
        The hidden part from the diffusion, inside ``box``.
    margin : float, default 0.25
        How far the new part may reach beyond the old one, as a fraction of
        the old part's smaller side (plus 3 pixels).
    band : float, default 1.5
        Distance from the outline within which the curvature is measured
        (only within ``margin`` of the old part: the outline that enters
        ``front``, not its far side).

    Returns
    -------
    bool
        Whether the part was reshaped (False when ``back`` has no outline of
        its own near the part, e.g. it is enclosed by ``front``).

    Examples
    --------
    >>> import numpy as np
    >>> yy, xx = np.mgrid[:120, :120]
    >>> disk = (yy - 60) ** 2 + (xx - 60) ** 2 <= 40 ** 2
    >>> labels = np.where(disk, 0, -1).astype(np.int32); labels[:, 48:72] = 1
    >>> owner = np.where((labels == 1) & (yy > 25) & (yy < 95), 0, -1).astype(np.int32)
    >>> continue_outline(labels, owner, 1, 0, (0, 120, 0, 120), owner == 0)
    True
    >>> hidden = disk & (labels == 1)          # the truth: the disk under the band
    >>> bool(((owner == 0) != hidden).sum() < 0.01 * hidden.sum())
    True
    """
    found = _continuation(labels, front, back, box, piece, margin=margin, band=band)
    if found is not None:
        _apply_continuation(owner, back, found)
    return found is not None


def _continuation(labels, front, back, box, piece, *, margin=0.25, band=1.5):
    """``(window, old, grown)`` of :func:`continue_outline`, or None: it reads no ``owner``."""
    h, w = labels.shape
    py, px = np.nonzero(piece)
    py, px = py + box[0], px + box[2]
    m = int(np.ceil(margin * min(np.ptp(py) + 1, np.ptp(px) + 1))) + 3
    # The window holds every pixel within the margin of the old part (and the rounding).
    wm = m + 2
    wy0, wy1 = max(py.min() - wm, 0), min(py.max() + 1 + wm, h)
    wx0, wx1 = max(px.min() - wm, 0), min(px.max() + 1 + wm, w)
    # Distances are taken on a larger window so that the outline just outside still counts.
    oy0, oy1 = max(wy0 - m, 0), min(wy1 + m, h)
    ox0, ox1 = max(wx0 - m, 0), min(wx1 + m, w)
    outer = labels[oy0:oy1, ox0:ox1]
    mine = outer == back
    other = (outer != back) & (outer != front)
    if not (mine & ndimage.binary_dilation(other)).any():
        return None  # no outline of its own here: nothing to continue
    # Half-pixel offsets keep the spacing even across the outline (0.5 | -0.5).
    phi = np.where(mine, ndimage.distance_transform_edt(~other) - 0.5,
                   0.5 - ndimage.distance_transform_edt(~mine))
    near = np.zeros(outer.shape, bool)
    near[py - oy0, px - ox0] = True
    near = ndimage.distance_transform_edt(~near) <= 2 * m
    kappa = _outline_curvature(mine, other, near)
    # psi = phi - kappa phi^2 / 2 is (R^2 - r^2) / 2R for a circle of radius R = 1/kappa, whose
    # Laplacian is exactly -2 kappa; capped at its maximum so that it stays monotone in phi.
    bend = kappa != 0
    cap = np.divide(1.0, kappa, out=np.zeros_like(kappa), where=bend)
    phi = np.where(kappa > 0, np.minimum(phi, cap), np.where(kappa < 0, np.maximum(phi, cap), phi))
    psi = phi - 0.5 * kappa * phi * phi
    win = (slice(wy0 - oy0, wy1 - oy0), slice(wx0 - ox0, wx1 - ox0))
    psi, hidden = psi[win], outer[win] == front
    x = np.nan_to_num(_poisson_extension(psi, hidden, -2.0 * kappa[win]), nan=-1.0)
    old = np.zeros(hidden.shape, bool)
    old[py - wy0, px - wx0] = True
    # Outlines that diverge under the occluder (an ear's sides splaying into the head) never
    # close: the continuation is closed by the diffusion's part grown by the margin, a rounded
    # offset of its shape (not by the window, whose cut would be a straight line), with a
    # smooth minimum so that the two outlines meet without a corner.
    bound = np.where(old, ndimage.distance_transform_edt(old),
                     0.5 - ndimage.distance_transform_edt(~old)) + m + 0.5 * _ROUNDING
    grown = hidden & (_smooth_min(x, bound, _ROUNDING) > 0)
    # Only pieces attached to the visible region are its continuation.
    comp, _ = ndimage.label(grown)
    touching = ndimage.binary_dilation(labels[wy0:wy1, wx0:wx1] == back) & grown
    grown = np.isin(comp, np.unique(comp[touching])) & grown
    return (slice(wy0, wy1), slice(wx0, wx1)), old, grown


def _smooth_min(a, b, k):
    """``min(a, b)`` with the corner where ``a == b`` rounded over a width ``k`` (polynomial)."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b * (1 - h) + a * h - k * h * (1 - h)


def _apply_continuation(owner, back, found):
    """Replace the old hidden part by the grown one, never over another region's pixel."""
    window, old, grown = found
    region = owner[window]
    region[old] = -1
    region[grown & (region < 0)] = back


def check_labels(labels, *, names=None):
    """Validate a label image and its region names.

    Parameters
    ----------
    labels : (H, W) integer array
        ``-1`` background, ``0..R-1`` regions.
    names : list of str, optional
        One name per region; default ``region0``, ``region1``, ...

    Returns
    -------
    labels : (H, W) int32 array
    names : list of str

    Raises
    ------
    InputError
        Not a 2-D integer image, a label below -1, or fewer names than labels.

    Examples
    --------
    >>> import numpy as np
    >>> check_labels(np.array([[-1, 0], [1, 1]]))[1]
    ['region0', 'region1']
    """
    a = np.asarray(labels)
    if a.ndim != 2 or a.size == 0:
        raise InputError(f"labels: expected a non-empty (H, W) image, got shape {a.shape}")
    if a.dtype.kind not in "iu":
        raise InputError(f"labels: expected an integer image, got {a.dtype}")
    if a.min() < -1:
        y, x = np.argwhere(a < -1)[0]
        raise InputError(f"labels: pixel ({x}, {y}) has label {a[y, x]} (expected -1 or >= 0)")
    count = int(a.max()) + 1
    if names is None:
        names = [f"region{i}" for i in range(count)]
    names = list(names)
    if len(names) < count:
        raise InputError(f"names: {len(names)} names for labels up to {count - 1}")
    return a.astype(np.int32), names


def complete_regions(labels, *, names=None, threshold=0.5, reach=4.0,
                     coarse_above=COARSE_ABOVE, grafts=(), progress=None):
    """Complete every region under each of its neighbours (illusory surfaces).

    For each region ``A`` the Laplace equation is solved on ``A``'s pixels,
    once per neighbour ``B``: value 1 at pixels outside ``A`` that belong to
    ``B``, 0 at pixels outside ``A`` of any other region or the background,
    no condition at the image frame (zero normal derivative). Pixels where
    ``B``'s value exceeds ``threshold`` are candidate hidden pixels of ``B``.

    Parameters
    ----------
    labels : (H, W) integer array
        ``-1`` background, ``0..R-1`` regions (as
        :func:`inkray.segmentation.segment` produces).
    names : list of str, optional
        Region names; default ``region0``, ``region1``, ...
    threshold : float, default 0.5
        Diffusion value above which a pixel joins the completed region; must
        lie in [0.5, 1) so that a pixel completes at most one region.
    reach : float or None, default 4.0
        Solve only on the pixels of ``A`` within ``reach`` times the extent
        of each contact (plus 8 pixels) of that contact, with value 0 beyond:
        a contact of extent ``L`` cannot raise the value above 0.5 farther
        than about ``L / 2`` from it (at a straight edge the 0.5 level is the
        half circle over the contact), so a large occluder with small
        neighbours costs only the area around them. ``None`` solves on all
        of ``A``.
    coarse_above : int or None, default ``COARSE_ABOVE`` (60,000)
        An occluder with several neighbours and more pixels to solve than
        this is solved at half resolution first (itself coarse to fine while
        above it), then again at full resolution only within 8 pixels of
        where the half-resolution result changes owner or of its outline,
        with the half-resolution values as boundary values there (at 1 Mpx
        the frog's body, 377,000 pixels, takes 0.8 s of CPU instead of 1.9 s;
        the owner differs on a few pixels along the 0.5 level). One
        neighbour's values are solved whole (by multigrid above the same
        size: the same owners). ``None`` solves every occluder at full
        resolution.
    grafts : sequence of (k, 2) arrays, optional
        Paths ``(x, y)`` in pixels that cut two parts apart across the paper
        (the annotations' ``graft`` boundaries). Where one ends on the
        silhouette, the silhouette it shares counts as either part's outline
        under the other (:func:`shared_outlines`): value 1 for that part.
    progress : inkray.progress.Progress, optional
        Receives ``update(done, R)`` after each occluder.

    Returns
    -------
    Completion
        Candidate completions of every pair in both directions, the places
        (overlap areas) of every neighbouring pair, and the ``shared``
        outlines.

    Raises
    ------
    InputError
        A malformed label image or threshold.
    StageError
        When a Laplace system cannot be factored.

    Examples
    --------
    A square behind a vertical band continues straight under it:

    >>> import numpy as np
    >>> labels = np.full((40, 60), -1, np.int32)
    >>> labels[10:30, 10:50] = 0          # the square (here a rectangle)
    >>> labels[:, 26:34] = 1              # the band in front of it
    >>> c = complete_regions(labels, names=["square", "band"])
    >>> bool((c.completed(0) == (np.arange(40)[:, None] >= 10) & (np.arange(40)[:, None] < 30)
    ...       & (np.arange(60) >= 10) & (np.arange(60) < 50)).all())
    True
    """
    labels, names = check_labels(labels, names=names)
    if not 0.5 <= threshold < 1:
        raise InputError(f"threshold: {threshold} must lie in [0.5, 1)")
    count = len(names)
    owner = np.full(labels.shape, -1, np.int32)
    boxes = ndimage.find_objects(labels + 1, max_label=count)
    # Each occluder writes only its own pixels of ``owner``: two at a time (SuperLU lets
    # go of the GIL while it factors); the result does not depend on it. An error of the
    # progress (a superseded edit) stops the regions not yet started.
    shared = shared_outlines(labels, grafts) if len(grafts) else {}
    # per occluder: its labels with the silhouette it shares given to the part it continues
    outlined = {}
    for (front, back), run in shared.items():
        outlined.setdefault(front, labels.copy())[run[:, 0], run[:, 1]] = back

    def complete_under(a):
        if boxes[a] is not None:
            _complete_under(outlined.get(a, labels), a, boxes[a], owner, threshold, reach,
                            coarse_above)

    # The largest occluders first, so that the two workers end about together.
    pixels = np.bincount(labels.ravel() + 1, minlength=count + 1)[1:]
    largest_first = sorted(range(count), key=lambda a: -pixels[a])
    for done, _ in enumerate(thread_imap(complete_under, largest_first), 1):
        if progress is not None:
            progress.update(done, count)
    neighbours = _neighbours(labels, count)
    places = _places(labels, owner)
    return Completion(labels=labels, names=names, owner=owner, neighbours=neighbours,
                      places=places, shared=shared)


def shared_outlines(labels, grafts, *, radius=SHARED_RADIUS):
    """The silhouettes that continue a grafted neighbour's outline.

    A graft cuts two parts apart across the paper, with no stroke between
    them (a thigh folded against a frog's body). Where its path ends on the
    silhouette there is no junction: the silhouette is the outline of either
    part as much as the other's. From that end it is followed along each
    part while it bends outward, as the outline it continues does (a round
    rump); it stops where it straightens or bends inward (a limb's
    own outline running on from a round shoulder, the notch where a
    donkey's leg leaves its rump, a foot's toes) and where the part ends.
    The silhouette's curvature is that of the filled character smoothed by
    a Gaussian of 1 % of ``sqrt(H W)`` (at least 4 px), read on the paper
    beside the part and averaged along it over the same width.

    Parameters
    ----------
    labels : (H, W) int array
        ``-1`` background, ``0..R-1`` parts.
    grafts : sequence of (k, 2) arrays
        Graft paths ``(x, y)`` in pixels; a path whose middle does not lie
        between two parts is skipped.
    radius : float, default ``SHARED_RADIUS``
        The silhouette stops at a curvature below ``1 / (radius sqrt(H W))``.

    Returns
    -------
    dict
        ``(front, back)``: (k, 2) int array of (row, column), the paper
        pixels along the silhouette of ``front`` that continue the outline
        of ``back``; pairs without such a stretch are left out.

    Examples
    --------
    A disk cut in two across by a graft: the lower half's silhouette
    continues the upper half's outline all round, the upper half's the
    lower's:

    >>> import numpy as np
    >>> yy, xx = np.mgrid[:100, :100]
    >>> labels = np.where(np.hypot(yy - 50, xx - 50) < 40, 0, -1).astype(np.int32)
    >>> labels[(labels == 0) & (yy >= 50)] = 1
    >>> shared = shared_outlines(labels, [np.array([[10.0, 50.0], [90.0, 50.0]])])
    >>> sorted(shared), all(len(run) > 100 for run in shared.values())
    ([(0, 1), (1, 0)], True)
    """
    labels = np.asarray(labels)
    size = np.sqrt(labels.size)
    # Below 4 px the smoothing leaves the pixels' stair-steps in the curvature.
    scale, near = max(_SHARED_SCALE * size, 4.0), _SHARED_NEAR * size
    todo = [(path, pair) for path in (np.asarray(p, float).reshape(-1, 2) for p in grafts)
            for pair in [_grafted_pair(labels, path)] if pair is not None]
    if not todo:
        return {}
    solid = ndimage.binary_fill_holes(labels >= 0)
    # Read on a grid coarsened to 4 px of smoothing: the same bends at a fraction of the cost.
    step = max(int(scale // 4), 1)
    curvature = _level_curvature(ndimage.gaussian_filter(_block_mean(solid, step),
                                                         scale / step)) / step
    boxes = ndimage.find_objects(labels + 1)
    out = {}
    for path, pair in todo:
        ends = [(x, y) for x, y in path[[0, -1]] if _within(~solid, x, y, near)]
        if not ends:
            continue
        for front, back in (pair, pair[::-1]):
            box = tuple(slice(max(b.start - 1, 0), b.stop + 1) for b in boxes[front])
            beside = ~solid[box] & ndimage.binary_dilation(labels[box] == front)
            py, px = np.nonzero(beside)
            cy, cx = (py + box[0].start) // step, (px + box[1].start) // step
            # Averaged along the silhouette: the pixels' stair-steps are no bends.
            cells = np.zeros(curvature.shape, np.float32)
            cells[cy, cx] = 1.0
            along = (ndimage.gaussian_filter(cells * curvature, scale / step)[cy, cx]
                     / np.maximum(ndimage.gaussian_filter(cells, scale / step)[cy, cx], 1e-12))
            follow = np.zeros(beside.shape, bool)
            follow[py, px] = along >= 1.0 / (radius * size)
            pieces, _ = ndimage.label(follow, np.ones((3, 3), bool))
            start = np.zeros(py.size, bool)
            for x, y in ends:
                start |= np.hypot(px + box[1].start - x, py + box[0].start - y) <= near
            keep = np.unique(pieces[py[start], px[start]])
            ry, rx = np.nonzero(np.isin(pieces, keep[keep > 0]))
            if ry.size:
                found = np.column_stack([ry + box[0].start, rx + box[1].start])
                old = out.get((front, back))
                out[(front, back)] = found if old is None else np.unique(
                    np.vstack([old, found]), axis=0)
    return out


def _block_mean(mask, step):
    """``mask`` averaged over ``step`` x ``step`` blocks (the last ones cut by the edge
    padded with its own values), float32."""
    h, w = mask.shape
    a = np.pad(mask.astype(np.float32), ((0, -h % step), (0, -w % step)), mode="edge")
    return a.reshape(a.shape[0] // step, step, a.shape[1] // step, step).mean(axis=(1, 3))


def _within(mask, x, y, reach):
    """Whether a pixel of ``mask`` lies within ``reach`` px of the point ``(x, y)``."""
    h, w = mask.shape
    r = int(np.ceil(reach))
    yi, xi = int(round(y)), int(round(x))
    y0, y1, x0, x1 = max(yi - r, 0), min(yi + r + 1, h), max(xi - r, 0), min(xi + r + 1, w)
    if y0 >= y1 or x0 >= x1:
        return False
    yy, xx = np.mgrid[y0:y1, x0:x1]
    return bool((mask[y0:y1, x0:x1] & (np.hypot(xx - x, yy - y) <= reach)).any())


def _grafted_pair(labels, path):
    """The two parts (ascending) on either side of a graft path's middle, or None."""
    h, w = labels.shape
    seg = np.diff(path, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    if lengths.sum() == 0:
        return None
    # The point half-way along the path and the parts within a few pixels of it.
    k = int(np.searchsorted(np.cumsum(lengths), lengths.sum() / 2))
    k = min(k, len(seg) - 1)
    before = np.cumsum(lengths)[k] - lengths[k]
    t = (lengths.sum() / 2 - before) / max(lengths[k], 1e-12)
    x, y = path[k] + t * seg[k]
    r = 6
    yi, xi = int(round(y)), int(round(x))
    window = labels[max(yi - r, 0):min(yi + r + 1, h), max(xi - r, 0):min(xi + r + 1, w)]
    pair = np.unique(window[window >= 0])
    return (int(pair[0]), int(pair[1])) if pair.size == 2 else None


def _level_curvature(u):
    """Curvature (1/px, convex > 0) of the level sets of ``u``, which grows inward."""
    gy, gx = np.gradient(u)
    norm = np.hypot(gx, gy)
    norm[norm == 0] = 1.0
    ny, nx = gy / norm, gx / norm
    return -(np.gradient(nx, axis=1) + np.gradient(ny, axis=0))


def _complete_under(labels, a, box, owner, threshold, reach, coarse_above):
    """Solve all neighbours of occluder ``a`` with one factorization; write into ``owner``."""
    h, w = labels.shape
    y0, y1 = max(box[0].start - 1, 0), min(box[0].stop + 1, h)
    x0, x1 = max(box[1].start - 1, 0), min(box[1].stop + 1, w)
    # The grown box holds every in-image neighbour of a's pixels; the padding marks the frame.
    crop = np.pad(labels[y0:y1, x0:x1], 1, constant_values=_OUTSIDE)
    if reach is not None:
        crop = _within_reach(crop, a, reach)
    inside = _solvable(crop, a)
    n = int(inside.sum())
    if n == 0:
        return
    nbrs = np.unique(crop[np.pad(ndimage.binary_dilation(inside[1:-1, 1:-1]), 1) & ~inside])
    nbrs = nbrs[nbrs >= 0]
    if nbrs.size == 0:
        return
    # Harmonic interpolation of each neighbour's indicator over a's pixels: unit
    # weights between pixels inside the frame (no flux across it), every pixel
    # that is not a's fixed at 1 for its own label's column and 0 elsewhere.
    u = _values(crop, inside, a, nbrs, threshold, coarse_above)
    best = np.argmax(u, axis=1)
    top = u[np.arange(n), best]
    won = top > threshold
    ys, xs = np.nonzero(inside)
    ys, xs = ys[won] - 1 + y0, xs[won] - 1 + x0
    owner[ys, xs] = nbrs[best[won]]


def _solvable(crop, a):
    """The pixels of ``a`` in ``crop`` but those of components that touch nothing
    but the frame (they have no boundary value)."""
    inside = crop == a
    comp, ncomp = ndimage.label(inside)
    dirichlet = np.zeros(crop.shape, np.int32)
    for dy, dx in _STEPS:
        nb = np.roll(crop, (-dy, -dx), axis=(0, 1))
        dirichlet += inside & (nb != a) & (nb != _OUTSIDE)
    touching = ndimage.sum(dirichlet, comp, index=np.arange(1, ncomp + 1)) > 0
    return inside & np.r_[False, touching][comp]


def _harmonic(crop, inside, a, nbrs, values=None):
    """The harmonic values (n, k) on the ``inside`` pixels (see ``_dirichlet_system``)."""
    system, rhs = _dirichlet_system(crop, inside, nbrs, values)
    try:
        return _grid_solve(system, rhs, *np.nonzero(inside))
    except np.linalg.LinAlgError as e:  # a singular system would be a bug in the frame handling
        raise StageError(f"completion under region {a}: cannot factor the Laplacian "
                         f"({e})") from None


def _grid_solve(system, rhs, ys, xs):
    """``system^-1 rhs`` for a positive definite ``system`` on the pixels ``(ys, xs)``.

    Above ``COARSE_ABOVE`` pixels, one right-hand side is solved by
    multigrid conjugate gradients to a relative residual of 1e-10 (the
    frog's body continued under its hind leg at 1 Mpx, 177,000 pixels: 0.3 s of CPU
    against 0.8 s, answers 1e-8 apart). Otherwise, on pixels that fill at
    least a quarter of their box, a nested dissection of the grid factors
    faster than SuperLU's minimum degree (those 177,000 pixels: 1.5 s against
    2.6 s); on thin sets (a band along an outline) the minimum degree fills
    less.
    """
    if ys.size > COARSE_ABOVE and (rhs.ndim == 1 or rhs.shape[1] == 1):
        try:
            return multigrid_solve(system, rhs, ys, xs)
        except np.linalg.LinAlgError:
            pass  # factored below
    if ys.size < 0.25 * (np.ptp(ys) + 1) * (np.ptp(xs) + 1):
        return spd_factor(system).solve(rhs)
    order, out = nested_dissection(system, ys, xs), np.empty_like(rhs)
    out[order] = spd_factor(system[order][:, order], ordered=True).solve(rhs[order])
    return out


_BAND = 8  # pixels solved again at full resolution on each side of a coarse owner change


def _values(crop, inside, a, nbrs, threshold, coarse_above):
    """The harmonic values (n, k) on the ``inside`` pixels: coarse to fine above
    ``coarse_above`` with several neighbours (one neighbour's large system is solved
    whole by multigrid, as fast, see ``_grid_solve``)."""
    if coarse_above is not None and int(inside.sum()) > coarse_above and len(nbrs) > 1:
        return _coarse_to_fine(crop, inside, a, nbrs, threshold, coarse_above)
    return _harmonic(crop, inside, a, nbrs)


def _coarse_to_fine(crop, inside, a, nbrs, threshold, coarse_above):
    """The harmonic values of ``_harmonic``, solved at half resolution and refined
    at full resolution near the owner changes and the outline.

    The coarse grid's cell is ``a`` where three or four of its pixels are,
    else the largest other label among them (neighbours keep their contacts,
    thin ones included). Its values, interpolated bilinearly, decide the owner of the
    pixels farther than ``_BAND`` from where they change owner and from the
    outline, and are the boundary values of the full-resolution solve on the
    others: there the errors of the coarse grid (largest where the boundary
    values jump, at the ends of each contact) are solved away.
    """
    h, w = crop.shape[0] - 2, crop.shape[1] - 2
    core = np.pad(crop[1:-1, 1:-1], ((0, h % 2), (0, w % 2)), constant_values=_OUTSIDE)
    blocks = np.stack([core[0::2, 0::2], core[0::2, 1::2], core[1::2, 0::2], core[1::2, 1::2]])
    other = np.where(blocks == a, _OUTSIDE, blocks).max(axis=0)
    small = np.pad(np.where((blocks == a).sum(axis=0) >= 3, a, other), 1, constant_values=_OUTSIDE)
    coarse = _solvable(small, a)
    values_c = np.zeros(small.shape + (len(nbrs),))
    values_c[..., :] = small[..., None] == nbrs
    if coarse.any():  # itself coarse to fine while it is large
        values_c[coarse] = _values(small, coarse, a, nbrs, threshold, coarse_above)
    # The frame's cells take the values of the nearest cell within it (no flux across it).
    _, (iy, ix) = ndimage.distance_transform_edt(small == _OUTSIDE, return_indices=True)
    values_c = values_c[iy, ix]
    ys, xs = np.nonzero(inside)
    at = [(ys - 1) / 2.0 + 0.75, (xs - 1) / 2.0 + 0.75]  # pixel centres on the padded coarse grid
    u = np.column_stack([ndimage.map_coordinates(values_c[..., k], at, order=1, mode="nearest")
                         for k in range(len(nbrs))])
    owner = np.full(crop.shape, -1, np.int32)
    owner[ys, xs] = np.where(u.max(axis=1) > threshold, np.argmax(u, axis=1), -1)
    # Seeds of the band: pixels of a beside one of a with another owner, and those of
    # a's cells that the coarse grid does not solve (the outline, thin necks).
    change = inside & ~np.pad(coarse[1:-1, 1:-1].repeat(2, axis=0).repeat(2, axis=1)[:h, :w], 1)
    for dy, dx in _STEPS[:2]:
        differ = ((owner[:-dy or None, :-dx or None] != owner[dy:, dx:])
                  & inside[:-dy or None, :-dx or None] & inside[dy:, dx:])
        change[:-dy or None, :-dx or None] |= differ
        change[dy:, dx:] |= differ
    band = inside & (ndimage.distance_transform_edt(~change) <= _BAND)
    if band.any():
        row = np.full(crop.shape, -1, np.int64)
        row[ys, xs] = np.arange(ys.size)

        def values(yy, xx):  # the coarse values inside, the indicators outside
            r = row[yy, xx]
            return np.where(r[:, None] >= 0, u[r], crop[yy, xx][:, None] == nbrs)

        fine = _harmonic(crop, band, a, nbrs, values)
        u[band[ys, xs]] = fine
    return u


def _dirichlet_system(crop, inside, nbrs, values=None):
    """The grid Laplacian on the ``inside`` pixels, the others fixed: ``(A, B)``.

    ``A`` (n, n) couples the inside pixels in raster order (unit weights
    between 4-neighbours inside the frame); column ``k`` of ``B`` (n, k) is
    what the fixed pixels of label ``nbrs[k]`` (value 1, every other label 0)
    bring to each row, or, where ``values`` is given, the fixed pixels'
    values there (``values(ys, xs)``, an (m, k) array for m pixels). Built on the inside pixels only: the Laplacian of
    the whole box, then cut down, cost as much as factoring it at 1 Mpx.
    """
    n = int(inside.sum())
    index = np.full(crop.shape, -1, np.int64)
    index[inside] = np.arange(n)
    ys, xs = np.nonzero(inside)  # the frame padding keeps every neighbour in the array
    degree = np.zeros(n)
    rows, cols = [np.arange(n)], [np.arange(n)]
    fixed_rows, fixed_cols = [], []
    col_of = {int(b): k for k, b in enumerate(nbrs)}
    rhs_values = None if values is None else np.zeros((n, len(nbrs)))
    for dy, dx in _STEPS:
        q = crop[ys + dy, xs + dx]
        linked = q != _OUTSIDE
        degree += linked
        j = index[ys + dy, xs + dx]
        coupled = linked & (j >= 0)
        rows.append(np.flatnonzero(coupled))
        cols.append(j[coupled])
        if values is not None:
            fixed = np.flatnonzero(linked & (j < 0))
            np.add.at(rhs_values, fixed, values(ys[fixed] + dy, xs[fixed] + dx))
            continue
        for b, k in col_of.items():
            hit = np.flatnonzero(linked & (j < 0) & (q == b))
            fixed_rows.append(hit)
            fixed_cols.append(np.full(len(hit), k))
    r, c = np.concatenate(rows), np.concatenate(cols)
    v = np.concatenate([degree, -np.ones(len(r) - n)])
    system = sp.csc_matrix((v, (r, c)), shape=(n, n))
    if values is not None:
        return system, rhs_values
    fr, fc = np.concatenate(fixed_rows), np.concatenate(fixed_cols)
    rhs = np.zeros((n, len(nbrs)))
    np.add.at(rhs, (fr, fc), 1.0)
    return system, rhs


_CUT = -3  # a pixel of the occluder beyond reach: value 0, like "anything else"


def _within_reach(crop, a, reach):
    """Mark the pixels of ``a`` farther than ``reach`` contact extents from every contact as cut."""
    inside = crop == a
    keep = np.zeros(crop.shape, bool)
    iy, ix = np.nonzero(inside)  # the frame padding keeps every neighbour in the array
    # The contacts of every neighbour at once: the pixels of a beside one of its pixels.
    found = [(crop[iy + dy, ix + dx], iy, ix) for dy, dx in _STEPS]
    nb, cy, cx = (np.concatenate(t) for t in zip(*found))
    hit = nb >= 0
    nb, cy, cx = nb[hit], cy[hit], cx[hit]
    order = np.argsort(nb, kind="stable")
    nb, cy, cx = nb[order], cy[order], cx[order]
    starts = np.flatnonzero(np.r_[True, nb[1:] != nb[:-1]]) if nb.size else []
    for s0, e0 in zip(starts, np.r_[starts[1:], nb.size]):
        ys, xs = cy[s0:e0], cx[s0:e0]
        extent = max(np.ptp(ys), np.ptp(xs)) + 1
        d = int(np.ceil(reach * extent)) + 8
        wy0, wy1 = max(ys.min() - d, 0), min(ys.max() + d + 1, crop.shape[0])
        wx0, wx1 = max(xs.min() - d, 0), min(xs.max() + d + 1, crop.shape[1])
        if np.hypot(wy1 - wy0, wx1 - wx0) <= d:  # the whole window is within reach
            keep[wy0:wy1, wx0:wx1] = True
            continue
        free = np.ones((wy1 - wy0, wx1 - wx0), bool)
        free[ys - wy0, xs - wx0] = False
        keep[wy0:wy1, wx0:wx1] |= ndimage.distance_transform_edt(free) <= d
    out = crop.copy()
    out[inside & ~keep] = _CUT
    return out


def _pairs(labels):
    """Pixel pairs of 4-neighbours with two different region labels.

    Returns the two labels and the positions of both pixels, for horizontal
    and vertical neighbours together.
    """
    out = []
    for (p, q) in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
                   ((slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
        la, lb = labels[p], labels[q]
        diff = (la != lb) & (la >= 0) & (lb >= 0)
        ys, xs = np.nonzero(diff)
        dy, dx = (0, 1) if p[0] == slice(None) else (1, 0)
        out.append((la[diff], lb[diff], ys, xs, ys + dy, xs + dx))
    return [np.concatenate(k) for k in zip(*out)]


def _neighbours(labels, count):
    la, lb = _pairs(labels)[:2]
    nb = [set() for _ in range(count)]
    for a, b in set(zip(la.tolist(), lb.tolist())):
        nb[a].add(b)
        nb[b].add(a)
    return [sorted(s) for s in nb]


def _places(labels, owner):
    """Connected overlap areas of every neighbouring pair, with their junctions and sites."""
    la, lb, ya, xa, yb, xb = _pairs(labels)
    lo, hi = np.minimum(la, lb), np.maximum(la, lb)
    count = int(labels.max()) + 1
    key_of = lambda a, b: a * count + b  # noqa: E731 -- one pair as one integer
    # Every pixel of the zone of a pair: both contact pixels and the candidate invented pixels.
    keys = [key_of(lo, hi), key_of(lo, hi)]
    ys, xs = [ya, yb], [xa, xb]
    iy, ix = np.nonzero(owner >= 0)
    il, io = labels[iy, ix], owner[iy, ix]
    keys.append(key_of(np.minimum(il, io), np.maximum(il, io)))
    ys.append(iy)
    xs.append(ix)
    keys, ys, xs = (np.concatenate(k) for k in (keys, ys, xs))
    contact_keys = key_of(lo, hi)
    junctions = _junction_points(labels)
    places = []
    if keys.size == 0:
        return places
    order = np.argsort(keys, kind="stable")
    keys, ys, xs = keys[order], ys[order], xs[order]
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    ends = np.r_[starts[1:], len(keys)]
    for s, e in zip(starts, ends):
        k = int(keys[s])
        a, b = divmod(k, count)
        py, px = ys[s:e], xs[s:e]
        y0, y1, x0, x1 = py.min(), py.max() + 1, px.min(), px.max() + 1
        zone = np.zeros((y1 - y0, x1 - x0), bool)
        zone[py - y0, px - x0] = True
        contact = np.zeros_like(zone)
        sel = contact_keys == k
        contact[ya[sel] - y0, xa[sel] - x0] = True
        contact[yb[sel] - y0, xb[sel] - x0] = True
        comp, n = ndimage.label(zone, structure=np.ones((3, 3)))
        pair_junctions = junctions.get((a, b), [])
        for c in range(1, n + 1):
            m = comp == c
            cy, cx = np.nonzero(m)
            mask = m[cy.min():cy.max() + 1, cx.min():cx.max() + 1]
            ctc = (contact & m)[cy.min():cy.max() + 1, cx.min():cx.max() + 1]
            box = (int(y0 + cy.min()), int(y0 + cy.max() + 1),
                   int(x0 + cx.min()), int(x0 + cx.max() + 1))
            places.append(Place(index=len(places), a=a, b=b, box=box, mask=mask, contact=ctc,
                                where=_middle(ctc if ctc.any() else mask, box),
                                junctions=[j for j in pair_junctions if _inside(j, m, y0, x0)]))
    _assign_sites(places, labels.shape)
    return places


def _middle(mask, box):
    """The pixel of ``mask`` nearest to its centroid, as image ``(x, y)``."""
    ys, xs = np.nonzero(mask)
    i = np.argmin((ys - ys.mean()) ** 2 + (xs - xs.mean()) ** 2)
    return (int(xs[i] + box[2]), int(ys[i] + box[0]))


def _inside(point, mask, y0, x0):
    x, y = point
    r, c = int(round(y)) - y0, int(round(x)) - x0
    win = mask[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2]
    return bool(win.any())


def _junction_points(labels):
    """Junction points per pair: centres of clusters of 2x2 blocks holding a, b and a third label.

    Returns a dict ``{(a, b): [(x, y), ...]}`` with ``a < b``; a point lies at
    the common corner of the block's four pixels.
    """
    q = np.stack([labels[:-1, :-1], labels[:-1, 1:], labels[1:, :-1], labels[1:, 1:]])
    s = np.sort(q, axis=0)
    distinct = 1 + (s[1:] != s[:-1]).sum(axis=0)
    by, bx = np.nonzero(distinct >= 3)
    if by.size == 0:
        return {}
    blocks = s[:, by, bx]
    # The distinct regions of each block: the sorted values that differ from the one before.
    first = np.r_[np.ones((1, by.size), bool), blocks[1:] != blocks[:-1]] & (blocks >= 0)
    pairs = [(j, k) for j in range(4) for k in range(j + 1, 4)]
    a = np.concatenate([blocks[j][first[j] & first[k]] for j, k in pairs])
    b = np.concatenate([blocks[k][first[j] & first[k]] for j, k in pairs])
    block = np.concatenate([np.flatnonzero(first[j] & first[k]) for j, k in pairs])
    out = {}
    # Per pair, its blocks in raster order; clusters numbered as ``ndimage.label`` numbers them.
    order = np.lexsort((block, b, a))
    a, b, block = a[order], b[order], block[order]
    starts = np.flatnonzero(np.r_[True, (a[1:] != a[:-1]) | (b[1:] != b[:-1])])
    for s0, e0 in zip(starts, np.r_[starts[1:], a.size]):
        py, px = by[block[s0:e0]], bx[block[s0:e0]]
        y0, x0 = py.min(), px.min()
        img = np.zeros((py.max() - y0 + 1, px.max() - x0 + 1), bool)
        img[py - y0, px - x0] = True
        comp, n = ndimage.label(img, structure=np.ones((3, 3)))
        c = comp[py - y0, px - x0]
        count = np.bincount(c, minlength=n + 1)[1:]
        cy = np.bincount(c, weights=py.astype(float), minlength=n + 1)[1:] / count
        cx = np.bincount(c, weights=px.astype(float), minlength=n + 1)[1:] / count
        out[(int(a[s0]), int(b[s0]))] = [(float(x) + 0.5, float(y) + 0.5) for y, x in zip(cy, cx)]
    return out


def _assign_sites(places, shape):
    """Label touching places with a common site (8-connectivity of their union)."""
    union = np.zeros(shape, bool)
    for p in places:
        y0, y1, x0, x1 = p.box
        union[y0:y1, x0:x1] |= p.mask
    sites, _ = ndimage.label(union, structure=np.ones((3, 3)))
    for p in places:
        ys, xs = np.nonzero(p.mask)
        p.site = int(sites[ys[0] + p.box[0], xs[0] + p.box[2]]) - 1


def _outline_curvature(mine, other, near):
    """Signed curvature (1/px, convex > 0) of the nearest outline stretch of ``mine``, per pixel.

    Each 8-connected stretch of outline pixels (pixels of ``mine`` next to
    ``other``) within ``near`` is fitted with a circle (algebraic fit, which
    degrades gracefully to a line); every pixel gets the curvature of the
    stretch nearest to it, so the two edges of a curved band keep their
    opposite curvatures. All zeros when there is no stretch.
    """
    edge = np.zeros(mine.shape, bool)
    inward = np.zeros(mine.shape + (2,))
    for dy, dx in _STEPS:
        nb = np.roll(other, (-dy, -dx), axis=(0, 1))
        edge |= mine & nb
        inward[mine & nb] -= (dy, dx)
    edge &= near
    edge[[0, -1], :] = False
    edge[:, [0, -1]] = False
    comp, n = ndimage.label(edge, structure=np.ones((3, 3)))
    curvatures = np.zeros(n + 1)
    for k in range(1, n + 1):
        y, x = np.nonzero(comp == k)
        if y.size < 5:
            continue
        my, mx = y.mean(), x.mean()
        yc, xc = y - my, x - mx
        a = np.column_stack([xc ** 2 + yc ** 2, xc, yc, np.ones(y.size)])
        big, d, e, f = np.linalg.svd(a, full_matrices=False)[2][-1]
        if abs(big) < 1e-12:
            curvature = 0.0
        else:
            radius2 = (d * d + e * e) / (4 * big * big) - f / big
            curvature = 1.0 / np.sqrt(radius2) if radius2 > 0 else 0.0
            centre = np.array([-e / (2 * big), -d / (2 * big)])  # (dy, dx) from the mean point
            if inward[y, x].sum(axis=0) @ centre < 0:
                curvature = -curvature
        curvatures[k] = curvature
    if n == 0:
        return np.zeros(mine.shape)
    nearest = ndimage.distance_transform_edt(comp == 0, return_distances=False, return_indices=True)
    return curvatures[comp[nearest[0], nearest[1]]]


def _poisson_extension(values, hidden, source, *, extrapolate=True):
    """Solve ``lap x = source`` on ``hidden`` with ``x = values`` on the other pixels.

    ``source`` is a number or an array like ``values``.

    Where ``hidden`` reaches the edge of the array the second difference
    across the edge is set to ``source / 2`` (instead of holding the solution
    flat), so linear functions, and quadratics that bend equally in both
    directions such as ``r^2``, are reproduced exactly however the window
    cuts the domain. Pieces of ``hidden`` that touch no other pixel have no
    data and stay NaN. Should the edge rows make the system singular (thin
    slivers along the edge), the edge is held flat instead.

    Returns the full array: ``values`` outside ``hidden``, the solution inside.
    """
    comp, count = ndimage.label(hidden)
    anchored = ndimage.binary_dilation(~hidden) & hidden
    hidden = np.isin(comp, np.unique(comp[anchored])) & hidden if count else hidden
    out = np.where(hidden | (comp == 0), values, np.nan)
    if not hidden.any():
        return out
    if extrapolate and _cornered(hidden):
        extrapolate = False  # singular: no need to factor it to find out
    try:
        out[hidden] = _poisson_solve(values, hidden, source, extrapolate)
    except RuntimeError:
        if not extrapolate:
            raise
        out[hidden] = _poisson_solve(values, hidden, source, False)
    return out


def _cornered(hidden):
    """Whether the edge rows of :func:`_poisson_solve` make its system singular at a corner.

    Where ``hidden`` holds the pixel diagonal to a corner of the array and its
    two neighbours on the edges, the Laplacian row of that pixel is the sum of
    their two second-difference rows.
    """
    hh, ww = hidden.shape
    if hh < 3 or ww < 3:
        return False
    return any(hidden[(y, y - dy, y), (x, x, x - dx)].all()
               for y, dy in ((1, 1), (hh - 2, -1)) for x, dx in ((1, 1), (ww - 2, -1)))


def _poisson_solve(values, hidden, source, extrapolate):
    hh, ww = hidden.shape
    source = np.broadcast_to(np.asarray(source, float), hidden.shape)[hidden]
    n = int(hidden.sum())
    index = np.full((hh, ww), -1, np.int64)
    index[hidden] = np.arange(n)
    y, x = np.nonzero(hidden)
    rows, cols, coef = [], [], []
    rhs = np.zeros(n)
    edge = np.zeros(n, bool)
    for dy, dx in _STEPS if extrapolate else ():
        # Pixels whose step (dy, dx) leaves the array: x_p - 2 x_{p-d} + x_{p-2d} = source / 2,
        # the second difference of a solution that bends equally in both directions.
        out = ~edge & ((y + dy < 0) | (y + dy >= hh) | (x + dx < 0) | (x + dx >= ww))
        ok = out & (y - 2 * dy >= 0) & (y - 2 * dy < hh) & (x - 2 * dx >= 0) & (x - 2 * dx < ww)
        rhs[ok] = source[ok] / 2.0
        for k, c in ((0, 1.0), (1, -2.0), (2, 1.0)):
            yy, xx = y[ok] - k * dy, x[ok] - k * dx
            j = index[yy, xx]
            me = np.flatnonzero(ok)
            rows.append(me[j >= 0])
            cols.append(j[j >= 0])
            coef.append(np.full(int((j >= 0).sum()), c))
            np.subtract.at(rhs, me[j < 0], c * values[yy[j < 0], xx[j < 0]])
        edge |= ok
    inner = np.flatnonzero(~edge)
    rows.append(inner)
    cols.append(inner)
    coef.append(np.full(inner.size, -4.0))
    rhs[inner] = source[inner]
    for dy, dx in _STEPS:
        yy = np.clip(y[inner] + dy, 0, hh - 1)
        xx = np.clip(x[inner] + dx, 0, ww - 1)
        inside = (y[inner] + dy == yy) & (x[inner] + dx == xx)
        j = index[yy, xx]
        link = inside & (j >= 0)
        rows.append(inner[link])
        cols.append(j[link])
        coef.append(np.ones(int(link.sum())))
        # A step off the array from a pixel without room to extrapolate: mirror (no flux).
        flat = ~inside
        rows.append(inner[flat])
        cols.append(inner[flat])
        coef.append(np.ones(int(flat.sum())))
        fixed = inside & (j < 0)
        rhs[inner[fixed]] -= values[yy[fixed], xx[fixed]]
    r, c, v = (np.concatenate(t) for t in (rows, cols, coef))
    system = sp.csc_matrix((v, (r, c)), shape=(n, n))
    if not edge.any():  # symmetric negative definite: SuperLU's symmetric mode, 0.7x the time
        return _grid_solve(-system, -rhs, y, x)
    # Symmetric but for the edge rows: the minimum-degree order of A^T + A fills
    # less than COLAMD's on these grids (1.6 s against 1.95 s on 177,000 pixels), and
    # where the pixels fill a quarter of their box a nested dissection less still, with
    # the diagonal as pivot (the donkey's seven such systems at 1 Mpx: 0.28 s of CPU
    # against 0.40 s, answers 1e-13 apart).
    if y.size < 0.25 * (np.ptp(y) + 1) * (np.ptp(x) + 1):
        return sla.splu(system, permc_spec="MMD_AT_PLUS_A").solve(rhs)
    order, out = nested_dissection(system + system.T, y, x), np.empty(n)
    out[order] = sla.splu(system[order][:, order], permc_spec="NATURAL",
                          diag_pivot_thresh=0.0).solve(rhs[order])
    return out
