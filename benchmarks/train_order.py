"""Train the depth-order model on generated drawings only.

Usage::

    python benchmarks/train_order.py [--count 360] [--without fade,rest] [--cache DIR] [--out inkray/relief/order_model.json]

Draws ``--count`` drawings with :func:`order_drawings.generate` (seeds
``0..count-1``; ``--without``: styles never used, a comma-separated list), runs the segmentation and the completion on each with its own
scribbles (``inkray.chain.ReliefChain``, predictions off), and measures
:func:`inkray.relief.order_cues.place_features` at the place of every
annotated ``order`` entry. The drawings with seeds ``= 4 (mod 5)`` are the
validation split; the rest train. Each of :data:`CANDIDATES` is fitted:

1. an L2-regularized logistic model on some features (penalty 10 on the
   standardized weights; the cues' weights not negative, :data:`SIGNED`), then (for some) gradient-boosted trees of depth 2
   on some features from its scores on the logistic loss (Newton steps, rate
   0.1, each feature cut at 32 quantiles of the training split, plain numpy),
   fitted on both orientations of every place (``x`` in front: label 1, the
   swapped row: label 0);
2. a calibration on the validation split: the score ``s = (F(x, y) - F(y,
   x)) / 2``, so the answer does not depend on which region is named first,
   becomes ``P(x in front) = sigmoid(t * s)`` with the temperature ``t`` of
   least log-loss (Platt scaling without offset: the two orientations are
   symmetric), or (``"isotonic"``) the isotonic regression of the share
   right on ``|s|`` (:func:`isotonic`).

The real drawings (the bundled drawings not made for inkray and the first
frames of the bundled real shots) are split in two, once, by name:
:data:`DEVELOPMENT` (looked at to decide the generator's styles and the
features, and to choose among the candidates: the candidate kept is the one
of least log-loss there, never fitted on them) and :data:`HELD_OUT` (scored
once, at the end, by ``benchmarks/bench_order.py --generated``; not read
here). The model
(``inkray/relief/order_model.json``, a few kB) is read by
:mod:`inkray.relief.order_model`. With the same count and styles the file is
the same, byte for byte; the shipped one is ``--count 240 --without fade,rest``
(the generator draws a style's chance only when the style is allowed, and
``rest`` and ``onto`` each from a stream of its own, so a drawing that does
not use ``onto`` is the one drawn before that style was added).
"""

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import minimize, minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parent))

from order_drawings import STYLES, generate  # noqa: E402

from inkray.chain import ChainOptions, ReliefChain  # noqa: E402
from inkray.errors import InputError  # noqa: E402
from inkray.input.annotations import parse_annotations  # noqa: E402
from inkray.input.drawing import drawing_from_array  # noqa: E402
from inkray.relief.ink_style import ink_style  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402
from inkray.relief.order_cues import (CUES, FEATURES, outline_lengths, place_features,  # noqa: E402
                                      region_stats)
from inkray.relief.order_model import OrderModel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "inkray" / "relief" / "order_model.json"
DEPTH, RATE, BINS, L2, LINEAR_L2 = 2, 0.1, 32, 1.0, 10.0
#: The real drawings the choice among the candidates is made on (``examples/NAME``; a shot:
#: its first frame).
DEVELOPMENT = ("balls", "donkey", "fox", "man", "shots/horse_gallop")
#: The real drawings scored once at the end, never looked at while choosing.
HELD_OUT = ("dragon", "frog", "gingerbread", "turtle", "shots/krita_walkcycle")
#: The features made as evidence that ``x`` is in front: their weights are not negative.
SIGNED = CUES + ("continuation_raw", "ink_spur", "runon")
#: ``name: keyword arguments of train``: the features of the logistic term, the number of
#: trees, the features they split on, the calibration.
_RAW = CUES + ("continuation_raw",)
_SIZES = ("log_area", "log_thickness", "share_x", "share_y", "enclosed_x", "enclosed_y",
          "hidden_x", "hidden_y", "junctions", "clarity")
CANDIDATES = {
    "cues": dict(linear=CUES, trees=0),
    "cues, raw continuation": dict(linear=_RAW, trees=0),
    "cues, raw continuation, isotonic": dict(linear=_RAW, trees=0, calibration="isotonic"),
    "cues, raw continuation, ink spur": dict(linear=_RAW + ("ink_spur",), trees=0),
    "cues, raw continuation, ink spur, isotonic": dict(linear=_RAW + ("ink_spur",), trees=0,
                                                       calibration="isotonic"),
    "cues, raw continuation, ink spur, runon, isotonic": dict(
        linear=_RAW + ("ink_spur", "runon"), trees=0, calibration="isotonic"),
    "cues, raw continuation, 30 trees on them": dict(linear=_RAW, trees=30, split=_RAW),
    "cues, raw continuation, 30 trees on them, isotonic": dict(linear=_RAW, trees=30, split=_RAW,
                                                              calibration="isotonic"),
    "cues, raw continuation, 30 trees on them and sizes": dict(linear=_RAW, trees=30,
                                                              split=_RAW + _SIZES),
    "cues, raw continuation, 100 trees on all features": dict(linear=_RAW, trees=100),
    "all features, 100 trees": dict(linear=FEATURES, trees=100),
}


@dataclass
class Samples:
    """The places of one drawing's ``order`` entries: features ``(n, 2, F)``, ``y`` (1 when
    the place's region ``a`` is in front) and the drawing's styles."""

    name: str
    features: np.ndarray
    y: np.ndarray
    styles: tuple = ()


def samples(ann, drawing, name, styles=()):
    """:class:`Samples` of one annotated drawing (entries between regions that do not touch,
    and places without cues, are left out)."""
    chain = ReliefChain(ann, drawing, options=ChainOptions(predict=False))
    return place_samples(chain.candidates, chain.relations, ink=ink_style(drawing.gray),
                         seams=[b.path for b in ann.boundaries if b.type in ("graft", "stitch")],
                         name=name, styles=styles)


def place_samples(completion, relations, *, ink, seams, name, styles=()):
    """:class:`Samples` of the places of the user's ``order`` relations."""
    labels = completion.labels
    outlines, stats = outline_lengths(labels), region_stats(labels)
    rows, ys = [], []
    for r in relations:
        if r.kind != "order" or r.place is None or r.source != "user":
            continue
        place = completion.places[r.place]
        f = place_features(completion, place, outlines=outlines, stats=stats, seams=seams, ink=ink)
        if f is not None:
            rows.append(f)
            ys.append(1.0 if r.front == place.a else 0.0)
    feats = np.asarray(rows, float).reshape(-1, 2, len(FEATURES))
    return Samples(name, feats, np.asarray(ys), tuple(styles))


def generated_samples(seed, styles=STYLES, cache=None):
    """:class:`Samples` of generated drawing ``seed`` (kept in ``cache``, a folder, if given)."""
    path = None
    if cache is not None:
        path = Path(cache) / f"gen_{seed}_{'-'.join(styles)}.npz"
        if path.exists():
            z = np.load(path)
            return Samples(f"gen_{seed}", z["features"], z["y"], tuple(str(s) for s in z["styles"]))
    g = generate(seed, styles=styles)
    try:
        s = samples(parse_annotations(g.annotation), drawing_from_array(g.gray), f"gen_{seed}",
                    g.styles)
    except InputError:
        # An entry's point segmented into a third part closes a cycle: no places from it.
        s = Samples(f"gen_{seed}", np.zeros((0, 2, len(FEATURES))), np.zeros(0), g.styles)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, features=s.features, y=s.y, styles=np.array(s.styles, dtype=str))
    return s


def _rows(batch):
    """Both orientations of every place: ``X (2n, F)``, labels ``(2n,)``."""
    if not batch:
        return np.zeros((0, len(FEATURES))), np.zeros(0)
    f = np.concatenate([s.features for s in batch])
    y = np.concatenate([s.y for s in batch])
    return np.concatenate([f[:, 0], f[:, 1]]), np.concatenate([y, 1.0 - y])


def fit_linear(X, y, *, l2=LINEAR_L2, positive=None):
    """L2-regularized logistic weights (no intercept) of rows ``X`` with labels 0/1; the
    penalty is on the weights of standardized features. ``positive``: a bool per column,
    True where the weight may not be negative."""
    scale = X.std(0) + 1e-9
    bounds = [(0.0, None) if p else (None, None)
              for p in (positive if positive is not None else [False] * X.shape[1])]
    Z, s = X / scale, 2.0 * y - 1.0

    def loss(w):
        m = s * (Z @ w)
        return (np.logaddexp(0.0, -m).sum() + l2 * w @ w,
                Z.T @ (-s * np.exp(-np.logaddexp(0.0, m))) + 2.0 * l2 * w)

    return minimize(loss, np.zeros(X.shape[1]), jac=True, method="L-BFGS-B",
                    bounds=bounds).x / scale


def fit_trees(X, y, *, trees=30, depth=DEPTH, rate=RATE, bins=BINS, l2=L2, start=None):
    """Gradient-boosted regression trees on the logistic loss, boosted from the scores
    ``start``: ``(feature, threshold, leaf)`` arrays of complete trees in heap order (node
    ``i`` has children ``2i+1``, ``2i+2``)."""
    n, m = X.shape
    cuts = [np.unique(np.quantile(X[:, k], np.linspace(0, 1, bins + 1)[1:-1])) for k in range(m)]
    binned = np.stack([np.searchsorted(cuts[k], X[:, k], side="left") for k in range(m)], 1)
    inner, leaves = 2 ** depth - 1, 2 ** depth
    feature = np.zeros((trees, inner), np.int64)
    threshold = np.full((trees, inner), np.inf)
    leaf = np.zeros((trees, leaves))
    score = np.zeros(n) if start is None else np.array(start, float)
    offsets = np.arange(m) * (bins + 1)
    for t in range(trees):
        p = 1.0 / (1.0 + np.exp(-score))
        g, h = p - y, p * (1.0 - p)
        node = np.zeros(n, np.int64)
        for i in range(inner):
            sel = node == i
            if not sel.any():
                continue
            cells = (binned[sel] + offsets).ravel()
            gs = np.bincount(cells, np.repeat(g[sel], m), m * (bins + 1)).reshape(m, bins + 1)
            hs = np.bincount(cells, np.repeat(h[sel], m), m * (bins + 1)).reshape(m, bins + 1)
            gl, hl = np.cumsum(gs, 1)[:, :-1], np.cumsum(hs, 1)[:, :-1]
            gt, ht = gs.sum(1)[:, None], hs.sum(1)[:, None]
            gain = gl ** 2 / (hl + l2) + (gt - gl) ** 2 / (ht - hl + l2) - gt ** 2 / (ht + l2)
            gain[(hl < 1.0) | (ht - hl < 1.0)] = -np.inf
            k, c = np.unravel_index(int(np.argmax(gain)), gain.shape)
            if np.isfinite(gain[k, c]) and gain[k, c] > 0 and c < len(cuts[k]):
                feature[t, i], threshold[t, i] = k, cuts[k][c]
            if i < inner // 2:  # send the node's samples on to its children
                node[sel] = 2 * i + 1 + (X[sel, feature[t, i]] > threshold[t, i])
        # Route every sample down the finished tree, then set the leaves by one Newton step.
        node = np.zeros(n, np.int64)
        for _ in range(depth):
            node = 2 * node + 1 + (X[np.arange(n), feature[t, node]] > threshold[t, node])
        node -= inner
        gsum = np.bincount(node, g, leaves)
        hsum = np.bincount(node, h, leaves)
        leaf[t] = -rate * gsum / (hsum + l2)
        score += leaf[t][node]
    return feature, threshold, leaf


def train(batch, validation, *, linear=FEATURES, trees=100, split=FEATURES, calibration="platt"):
    """An :class:`inkray.relief.order_model.OrderModel` fitted on ``batch`` and calibrated on
    ``validation`` (lists of :class:`Samples`): a logistic term on the features ``linear``,
    then ``trees`` boosted trees splitting on the features ``split``; ``calibration``
    ``"platt"`` or ``"isotonic"``."""
    X, y = _rows(batch)
    cols = [FEATURES.index(k) for k in linear]
    weights = np.zeros(len(FEATURES))
    # A cue says "x in front" by its sign: it is never read the other way round.
    weights[cols] = fit_linear(X[:, cols], y, positive=[k in SIGNED for k in linear])
    weights = np.round(weights, 7)
    if trees:
        among = np.array([FEATURES.index(k) for k in split])
        feature, threshold, leaf = fit_trees(X[:, among], y, trees=trees, start=X @ weights)
        feature = among[feature]
    else:  # the linear term alone: one stump that adds nothing
        feature, threshold, leaf = np.zeros((1, 1), np.int64), np.full((1, 1), np.inf), np.zeros((1, 2))
    # Rounded as the JSON file keeps them, so the trained and the shipped model agree.
    threshold = np.array([[float(f"{v:.7g}") for v in row] for row in threshold])
    leaf = np.round(leaf, 7)
    raw = OrderModel(feature=feature, threshold=threshold, leaf=leaf, temperature=1.0,
                     weights=weights)
    f = np.concatenate([s.features for s in validation])
    yv = np.concatenate([s.y for s in validation])
    s = raw.score(f)

    def loss(t):
        return float(np.logaddexp(0.0, -(2 * yv - 1) * t * s).sum())

    temperature = float(minimize_scalar(loss, bounds=(0.05, 5.0), method="bounded").x)
    knots = isotonic(np.abs(s), (s > 0) == (yv > 0.5)) if calibration == "isotonic" else None
    return OrderModel(feature=feature, threshold=threshold, leaf=leaf,
                      temperature=round(temperature, 4), weights=weights, calibration=knots)


def isotonic(score, right):
    """Knots ``(s, p)`` of the isotonic regression of ``right`` (bool) on ``score`` ``>= 0``
    (pool adjacent violators, equal neighbours pooled too): one knot at the mean score of
    every pooled block, its right
    share smoothed as ``(k + 1) / (n + 2)`` (so below 1) and at least 0.501, from
    ``(0, 0.5)``."""
    order = np.argsort(score, kind="stable")
    x, y = score[order], right[order].astype(float)
    blocks = []  # [sum of right, count, sum of score]
    for xi, yi in zip(x, y):
        blocks.append([yi, 1.0, xi])
        while len(blocks) > 1 and blocks[-2][0] / blocks[-2][1] >= blocks[-1][0] / blocks[-1][1]:
            last = blocks.pop()
            blocks[-1] = [a + b for a, b in zip(blocks[-1], last)]
    k, n, sx = np.array(blocks).T
    # Above one half: every score but 0 still says who is in front.
    p = np.maximum.accumulate(np.maximum((k + 1.0) / (n + 2.0), 0.501))
    knots = [(0.0, 0.5)]
    for xi, pi in zip(np.round(sx / n, 7), np.round(p, 7)):
        if xi > knots[-1][0]:
            knots.append((float(xi), float(max(pi, knots[-1][1]))))
    # A knot between two of the same value is no bend of the line.
    keep = [i for i in range(len(knots)) if i in (0, len(knots) - 1)
            or not knots[i - 1][1] == knots[i][1] == knots[i + 1][1]]
    return np.array([knots[i] for i in keep])


def log_loss(model, batch):
    """Mean log-loss and share right of ``model`` on the places of ``batch``."""
    f = np.concatenate([s.features for s in batch])
    y = np.concatenate([s.y for s in batch])
    p = np.clip(model.probability(f), 1e-9, 1 - 1e-9)
    return float(-np.mean(np.log(np.where(y > 0.5, p, 1 - p)))), float(np.mean((p > 0.5) == (y > 0.5)))


def choose(fit, val, dev):
    """The candidate of least log-loss on ``dev``: ``(name, model)``; prints each."""
    best = None
    print(f"{'candidate':<52} {'validation':>16} {'development':>16}")
    for name, candidate in CANDIDATES.items():
        model = train(fit, val, **candidate)
        (lv, rv), (ld, rd) = log_loss(model, val), log_loss(model, dev)
        print(f"{name:<52} {lv:>8.3f} {rv:>7.1%} {ld:>8.3f} {rd:>7.1%}")
        if best is None or ld < best[0]:
            best = (ld, name, model)
    return best[1], best[2]


def real_annotation(name):
    """The annotation file of a real drawing of :data:`DEVELOPMENT` or :data:`HELD_OUT`."""
    folder = ROOT / "examples" / name
    return folder / ("0001.inkray.json" if name.startswith("shots/") else "drawing.inkray.json")


def development_samples():
    """:class:`Samples` of the real drawings of :data:`DEVELOPMENT`."""
    out = []
    for name in DEVELOPMENT:
        ann, drawing = load_input(real_annotation(name))
        out.append(samples(ann, drawing, name))
    return out


def allowed_styles(without):
    """The generator's styles but those of the comma-separated list ``without``."""
    unknown = sorted(set(filter(None, without.split(","))) - set(STYLES))
    if unknown:
        raise SystemExit(f"--without: unknown style {unknown[0]!r} (expected {', '.join(STYLES)})")
    return tuple(s for s in STYLES if s not in without.split(","))


def split(pool):
    """Training and validation split of generated samples (validation: seeds = 4 mod 5)."""
    val = [s for s in pool if int(s.name.split("_")[1]) % 5 == 4]
    return [s for s in pool if s not in val], val


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=360)
    ap.add_argument("--cache", type=Path, help="folder keeping each drawing's features")
    ap.add_argument("--out", type=Path, default=MODEL)
    ap.add_argument("--without", default="", help="comma-separated styles never used")
    args = ap.parse_args(argv)
    styles = allowed_styles(args.without)
    pool = []
    for seed in range(args.count):
        pool.append(generated_samples(seed, styles=styles, cache=args.cache))
        if seed % 20 == 19:
            print(f"{seed + 1} drawings, {sum(len(s.y) for s in pool)} places", flush=True)
    fit, val = split(pool)
    print(f"{len(fit)} drawings train ({sum(len(s.y) for s in fit)} places), {len(val)} "
          f"validate ({sum(len(s.y) for s in val)} places); log-loss and right:")
    name, model = choose(fit, val, development_samples())
    print(f"kept: {name}, temperature {model.temperature}")
    args.out.write_text(json.dumps(model.to_json(), separators=(",", ":")) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
