"""Benchmark: depth-order prediction on drawings it was not tuned on, and the fast re-solve.

Usage::

    python benchmarks/bench_order.py [--drawings fox,man] [--no-resolve]
    python benchmarks/bench_order.py --generated 360 [--without fade,rest] [--cache DIR] [--styles] [--real A.inkray.json]
    python benchmarks/bench_order.py --timing [--drawings fox,man]

``--generated N`` (the learned model's protocol): train on N generated drawings
only (``benchmarks/train_order.py``: the model of
:mod:`inkray.relief.order_model`, the candidate chosen on the development
drawings, and the same four-cue logistic as below fitted on the same
generated drawings), then test on the real drawings: the bundled drawings
not made for inkray and the first frames of the bundled real shots, split
once by name into ``train_order.DEVELOPMENT`` (looked at while deciding the
generator's styles and the features, and choosing the candidate; never
fitted on) and ``train_order.HELD_OUT`` (with the annotations given with
``--real``: scored only here). Per drawing, per set and per confidence bin:
right, right at confidence 0.5 or more, and the share of relations reaching
0.5 (per bin, and over all real drawings: right against the probability the
predictor stated for its answers, whether its confidence is over-stated), for
the learned model, the logistic fitted on the generated drawings,
and the shipped logistic (:data:`inkray.relief.ordering.WEIGHTS`, fitted on
all bundled drawings, so not held out: shown for reference); then the
prediction time of every place at about 1 Mpx (the fox upscaled,
:func:`inkray.relief.ordering.depth_order` with an empty memo, the learned
model and the weighted cues), and each against its target. ``--styles``
adds what each generator style does: the model trained on the generated
drawings that do not use the style, against one trained on as many drawings
drawn with every style, each scored on the development and the held-out
drawings' places (without the consistency step). ``--without`` names styles
never drawn (``--without fade,rest``: the drawings the shipped model was trained
on). The table of the run is in
docs/regions.md. ``--cache`` keeps each generated drawing's features (about
1 s a drawing to make again).

``--timing``: only the prediction time of every place
(:func:`inkray.relief.ordering.depth_order`, empty memo, median of 5 wall and
CPU seconds, learned model and weighted cues) of the drawings (default
:data:`REAL`) at their size and upscaled to about 1 Mpx, the worst wall
median at 1 Mpx against :data:`TARGET_TIME`.

Leave-one-out over the bundled drawings (``examples/*/drawing.inkray.json``):
for each drawing, the predictor is fitted on all the *other* drawings only:
the cue weights of :func:`inkray.relief.ordering.predict_place` by
L2-regularized logistic regression on their annotated ``order`` entries,
the junction radius, the radius (in stroke widths) and the stroke-end scale
of the ``continuation`` cue and the regularization chosen from a small grid
by an inner leave-one-out over those drawings (least log-loss). The held-out drawing's ink style (stroke
width, stroke ends) is measured on its image, not fitted.
Then the held-out drawing's order entries are removed and predicted (with
the global consistency step of :func:`inkray.relief.ordering.depth_order`).
A prediction is right when the entry's front region is the predicted front
region at the entry's place; entries between regions that never touch have
no place and are not counted.

Prints one row per drawing (entries, right, accuracy, what was chosen
without it), the overall accuracy, the accuracy per confidence bin of the
held-out predictions, and the model fitted on all drawings (the values of
:data:`inkray.relief.ordering.WEIGHTS`, ``JUNCTION_RADIUS`` and
``STROKE_END_SCALE``); last, each
measurement against its target (90 % leave-one-out, 95 % at confidence 0.5
or more, 0.2 s per re-solve) as a ratio. Then, unless ``--no-resolve``, the fast depth
method's re-solve time at 512x512 (the bundled turtle with its scribbles)
after one entry is added between two regions, and after one whose points
lie in one region (the region is cut into two parts), against the 0.2 s
target.
"""

import argparse
import itertools
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from inkray.chain import ChainOptions, ReliefChain
from inkray.depthmap.estimation import DepthSession
from inkray.input.constraints import constraints
from inkray.input.loading import load_input
from inkray.input.scribbles import seed_image
from inkray.relief.ink_style import ink_style
from inkray.relief.order_cues import CUES, contact_continuation, order_cues, outline_lengths
from inkray.relief.ordering import WEIGHTS, depth_order

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
GRID = {"junction_radius": (25.0, 40.0, 80.0), "continuation_widths": (6.0, 8.0, 10.0),
        "stroke_end_scale": (3.0, 10.0, 30.0), "regularization": (0.1, 1.0)}
BINS = (0.0, 0.25, 0.5, 0.75, 1.0)
TARGET = 0.2  # seconds for one fast re-solve after adding an entry
TARGET_ACCURACY = 0.90  # leave-one-out, all counted entries
TARGET_SURE = 0.95  # accuracy of the predictions with confidence >= 0.5
#: The bundled drawings not made for inkray (the default of ``--timing``).
REAL = ("balls", "donkey", "dragon", "fox", "frog", "gingerbread", "man", "turtle")
TARGET_REAL = 0.85  # right, on the real drawings
TARGET_REACH = 0.60  # share of the relations reaching confidence 0.5
TARGET_TIME = 0.3  # seconds to predict every place at 1 Mpx


class _Drawing:
    """One drawing's candidates, its annotated relations and their cues."""

    def __init__(self, folder, annotation=None):
        self.name = folder.name
        ann, drawing = load_input(annotation or folder / "drawing.inkray.json")
        self.drawing = drawing
        chain = ReliefChain(ann, drawing, options=ChainOptions(predict=False))
        self.annotations = ann
        self.labels = chain.segmentation.labels
        self.completion = chain.candidates
        orders = [r for r in chain.relations if r.kind == "order"]
        self.truth = [r for r in orders if r.place is not None]
        self.apart = len(orders) - len(self.truth)
        self.seams = [b.path for b in ann.boundaries if b.type in ("graft", "stitch")]
        self._outlines = outline_lengths(self.labels)
        self.ink = ink_style(drawing.gray)
        self._cues = {}
        self._continuation = {}

    def cues(self, params):
        """``(X, y)``: the cues of the entries' places (rows; None where the place has
        no cue) and +1 where the entry's front is the place's region ``a``, else -1;
        ``params`` is ``(junction_radius, continuation_widths, stroke_end_scale)``."""
        radius, widths, scale = params
        places = [self.completion.places[r.place] for r in self.truth]
        if radius not in self._cues:
            # Without the ink: the continuation (0 here) is measured apart, once per width.
            rows = [order_cues(self.completion, p, outlines=self._outlines, seams=self.seams,
                               junction_radius=radius) for p in places]
            self._cues[radius] = [None if c is None else [c[k] for k in CUES] for c in rows]
        if widths not in self._continuation:
            self._continuation[widths] = [
                contact_continuation(self.labels, p, ink=self.ink, seams=self.seams,
                                     continuation_widths=widths) for p in places]
        owns = np.array(self._continuation[widths]) * self.ink.clarity(scale)
        column = CUES.index("continuation")
        rows = [None if row is None else row[:column] + [o] + row[column + 1:]
                for row, o in zip(self._cues[radius], owns)]
        y = np.array([1.0 if r.front == p.a else -1.0 for r, p in zip(self.truth, places)])
        return rows, y

    def score(self, weights, params, model=None):
        """``[(right, confidence)]`` per counted entry, predicted with its order entries
        removed (a missing prediction is wrong with confidence 0); ``weights=None``: the
        learned ``model``."""
        radius, widths, scale = params
        ann = replace(self.annotations, order=[])
        rel, _ = depth_order(constraints(ann), self.labels, self.completion,
                             seams=ann.boundaries, weights=weights, junction_radius=radius,
                             ink=self.ink, continuation_widths=widths, stroke_end_scale=scale,
                             model=model)
        pred = {r.place: (r.front, r.confidence) for r in rel if r.source == "predicted"}
        return [(pred.get(r.place, (None, 0.0))[0] == r.front, pred.get(r.place, (None, 0.0))[1])
                for r in self.truth]


def _fit(drawings, params, lam):
    """Cue weights by L2-regularized logistic regression on the drawings' entries."""
    X, y = [], []
    for d in drawings:
        rows, labels = d.cues(params)
        for row, label in zip(rows, labels):
            if row is not None:
                X.append(row)
                y.append(label)
    X, y = np.asarray(X), np.asarray(y)

    def loss(w):
        m = y * (X @ w)
        return (np.logaddexp(0.0, -m).sum() + lam * w @ w,
                X.T @ (-y * np.exp(-np.logaddexp(0.0, m))) + 2.0 * lam * w)

    w = minimize(loss, np.zeros(len(CUES)), jac=True, method="L-BFGS-B").x
    return {k: round(float(v), 3) for k, v in zip(CUES, w)}


def _log_loss(drawings, weights, params):
    """Logistic loss of the drawings' entries under ``weights`` (a place without cues
    counts as a coin toss)."""
    w = np.array([weights[k] for k in CUES])
    loss = 0.0
    for d in drawings:
        rows, labels = d.cues(params)
        for row, label in zip(rows, labels):
            loss += np.logaddexp(0.0, -label * np.dot(row, w)) if row is not None else np.log(2.0)
    return loss


def _choose(drawings):
    """``((junction radius, continuation widths, stroke-end scale), lambda)`` of the grid
    with the least inner leave-one-out log-loss over ``drawings`` (smoother than the
    count of right entries, so less swayed by one entry)."""
    def inner(choice):
        params, lam = choice
        return sum(_log_loss([d], _fit([o for o in drawings if o is not d], params, lam), params)
                   for d in drawings)
    params = itertools.product(GRID["junction_radius"], GRID["continuation_widths"],
                               GRID["stroke_end_scale"])
    return min(itertools.product(params, GRID["regularization"]), key=inner)


def leave_one_out(drawings):
    """Per drawing: (what was chosen, [(right, confidence)]) scored without its own entries."""
    results = {}
    for held in drawings:
        others = [d for d in drawings if d is not held]
        params, lam = _choose(others)
        weights = _fit(others, params, lam)
        chosen = dict(zip(("junction_radius", "continuation_widths", "stroke_end_scale"), params))
        results[held.name] = ({**chosen, "regularization": lam, **weights},
                              held.score(weights, params))
    return results


def report(drawings, results):
    print(f"{'drawing':<12} {'entries':>7} {'apart':>5} {'right':>5} {'accuracy':>8}  chosen on the others")
    total = right = 0
    scored = []
    for d in drawings:
        params, s = results[d.name]
        ok = sum(r for r, _ in s)
        total += len(s)
        right += ok
        scored += s
        acc = f"{ok / len(s):.1%}" if s else "-"
        chosen = " ".join(f"{k}={v:g}" for k, v in params.items())
        print(f"{d.name:<12} {len(s):>7} {d.apart:>5} {ok:>5} {acc:>8}  {chosen}")
    print(f"{'all':<12} {total:>7} {sum(d.apart for d in drawings):>5} {right:>5} "
          f"{right / max(total, 1):>8.1%}")
    print()
    print(f"{'confidence':<12} {'entries':>7} {'right':>5} {'accuracy':>8}")
    for lo, hi in zip(BINS[:-1], BINS[1:]):
        inbin = [ok for ok, c in scored if lo <= c < hi or (hi == 1.0 and c == 1.0)]
        acc = f"{sum(inbin) / len(inbin):.1%}" if inbin else "-"
        print(f"{f'{lo:.2f}-{hi:.2f}':<12} {len(inbin):>7} {sum(inbin):>5} {acc:>8}")
    sure = [ok for ok, c in scored if c >= 0.5]
    if sure:
        print(f"{'>= 0.50':<12} {len(sure):>7} {sum(sure):>5} {sum(sure) / len(sure):>8.1%}")
    return right / max(total, 1), sum(sure) / max(len(sure), 1)


def bench_resolve():
    """Fast re-solve after one added entry, at 512x512 (the turtle with its scribbles)."""
    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    gray = drawing.gray.astype(np.float64)
    edits = (("between regions (head over shell)", (60.0, 250.0), (200.0, 250.0)),
             ("inside one region (shell split)", (330.0, 190.0), (250.0, 330.0)))
    print()
    head = f"{'added entry (turtle 512x512)':<36} {'first solve':>11} {'re-solve':>9} " \
           f"{'target':>7} {'re-solve / target':>18}"
    print(head)
    print("-" * len(head))
    worst = 0.0
    for what, front, back in edits:
        s = DepthSession(gray, seeds=seed_image(ann))
        for o in ann.order:
            s.add(o.front, o.back)
        t = time.perf_counter()
        s.solve()
        first = time.perf_counter() - t
        s.add(front, back)
        t = time.perf_counter()
        s.solve()
        again = time.perf_counter() - t
        print(f"{what:<36} {first:>10.3f}s {again:>8.3f}s {TARGET:>6.1f}s {again / TARGET:>18.2f}")
        worst = max(worst, again)
    return worst


def _real_drawings(names, extra=()):
    """The real drawings ``names`` (``examples/NAME``, a shot's first frame) and the
    ``extra`` annotation files."""
    import train_order

    return ([_Drawing(EXAMPLES / n, annotation=train_order.real_annotation(n)) for n in names]
            + [_Drawing(Path(p).parent, annotation=p) for p in extra])


def _cue_rows(batch):
    """Both orientations of the four cues (the first columns of the features) and labels."""
    X, y = [], []
    for s in batch:
        X += [s.features[:, 0, :len(CUES)], s.features[:, 1, :len(CUES)]]
        y += [2 * s.y - 1, 1 - 2 * s.y]
    return np.concatenate(X), np.concatenate(y)


def _fit_rows(X, y, lam):
    """L2-regularized logistic weights of the cues on rows ``X`` with labels +-1."""
    def loss(w):
        m = y * (X @ w)
        return (np.logaddexp(0.0, -m).sum() + lam * w @ w,
                X.T @ (-y * np.exp(-np.logaddexp(0.0, m))) + 2.0 * lam * w)

    w = minimize(loss, np.zeros(X.shape[1]), jac=True, method="L-BFGS-B").x
    return {k: round(float(v), 3) for k, v in zip(CUES, w)}


def _summary(scored):
    """(right share, right share at confidence >= 0.5, share reaching 0.5, counts)."""
    n = max(len(scored), 1)
    sure = [ok for ok, c in scored if c >= 0.5]
    return (sum(ok for ok, _ in scored) / n, sum(sure) / max(len(sure), 1), len(sure) / n,
            len(scored), len(sure))


def bench_generated(args):
    """Train on generated drawings, test on the real ones (see the module docstring)."""
    import train_order

    styles = train_order.allowed_styles(args.without)
    pool = [train_order.generated_samples(seed, styles=styles, cache=args.cache)
            for seed in range(args.generated)]
    fit, val = train_order.split(pool)
    start = time.perf_counter()
    chosen, model = train_order.choose(fit, val, train_order.development_samples())
    took = time.perf_counter() - start
    cues = _fit_rows(*_cue_rows(fit), 1.0)
    print(f"trained on {len(fit)} generated drawings ({sum(len(s.y) for s in fit)} places), "
          f"calibrated on {len(val)} ({sum(len(s.y) for s in val)} places), every candidate "
          f"in {took:.1f} s: kept {chosen!r}, temperature {model.temperature}")
    print(f"four-cue logistic fitted on the same generated drawings: {cues}\n")
    default = (40.0, 6.0, 10.0)
    predictors = (("learned", None, model), ("cues, generated", cues, None),
                  ("cues, shipped*", WEIGHTS, None))
    sets = (("development", _real_drawings(train_order.DEVELOPMENT)),
            ("held out", _real_drawings(train_order.HELD_OUT, args.real)))
    head = f"{'drawing':<22} {'entries':>7}" + "".join(
        f" | {name:>15}: right  sure  >=0.5" for name, _, _ in predictors)
    print(head)
    print("-" * len(head))
    scored = {}
    for what, drawings in sets:
        scored[what] = {name: [] for name, _, _ in predictors}
        for d in drawings:
            line = f"{d.name:<22} {len(d.truth):>7}"
            for name, weights, m in predictors:
                s = d.score(weights, default, model=m)
                scored[what][name] += s
                acc, sure, reach, _, k = _summary(s)
                line += f" | {'':>15}  {acc:>5.0%} {f'{sure:.0%}' if k else '-':>5} {reach:>6.0%}"
            print(line)
        _total_line(f"all {what}", scored[what], predictors)
    scored["all"] = {name: scored["development"][name] + scored["held out"][name]
                     for name, _, _ in predictors}
    _total_line("all", scored["all"], predictors)
    print("* the shipped logistic was fitted on all bundled drawings, the real shots excepted\n")
    for what in ("development", "held out", "all"):
        print(f"{what + ', confidence':<22}" + "".join(f" | {name:>15}: entries right stated"
                                                        for name, _, _ in predictors))
        for lo, hi in zip(BINS[:-1], BINS[1:]):
            line = f"{f'{lo:.2f}-{hi:.2f}':<22}"
            for name, _, _ in predictors:
                inbin = [(ok, c) for ok, c in scored[what][name]
                         if lo <= c < hi or (hi == 1.0 and c == 1.0)]
                # "stated": the mean probability the predictor gave its answer, (1 + c) / 2.
                acc, stated = ((f"{np.mean([ok for ok, _ in inbin]):.0%}",
                                f"{np.mean([(1 + c) / 2 for _, c in inbin]):.0%}")
                               if inbin else ("-", "-"))
                line += f" | {'':>15}  {len(inbin):>7} {acc:>5} {stated:>6}"
            print(line)
        print()
    seconds = bench_time_1mpx(model)
    print()
    print(f"{'target (learned model)':<40} {'measured':>9} {'target':>7} {'measured / target':>18}")
    for what in ("development", "held out"):
        acc, sure, reach, _, _ = _summary(scored[what]["learned"])
        for name, measured, target, ratio in (
                ("right", f"{acc:.1%}", f"{TARGET_REAL:.0%}", acc / TARGET_REAL),
                ("right at confidence >= 0.5", f"{sure:.1%}", f"{TARGET_SURE:.0%}",
                 sure / TARGET_SURE),
                ("relations reaching 0.5", f"{reach:.1%}", f"{TARGET_REACH:.0%}",
                 reach / TARGET_REACH)):
            print(f"{what + ': ' + name:<40} {measured:>9} {target:>7} {ratio:>18.2f}")
    print(f"{'prediction at 1 Mpx (median of 3)':<40} {f'{seconds:.3f} s':>9} "
          f"{f'{TARGET_TIME:g} s':>7} {seconds / TARGET_TIME:>18.2f}")
    if args.styles:
        bench_styles(pool, sets, train_order.CANDIDATES[chosen])


def _total_line(label, scored, predictors):
    line = f"{label:<22} {len(scored[predictors[0][0]]):>7}"
    for name, _, _ in predictors:
        acc, sure, reach, _, _ = _summary(scored[name])
        line += f" | {'':>15}  {acc:>5.1%} {sure:>5.1%} {reach:>6.1%}"
    print(line)


def bench_styles(pool, sets, candidate):
    """Each generator style left out of training, against as many drawings with every style,
    scored on the development and on the held-out drawings."""
    import train_order

    places = []
    for _, drawings in sets:
        real = [train_order.place_samples(d.completion, d.truth, ink=d.ink, seams=d.seams,
                                          name=d.name) for d in drawings]
        places.append((np.concatenate([s.features for s in real]),
                       np.concatenate([s.y for s in real])))

    def scored(batch):
        fit, val = train_order.split(batch)
        model = train_order.train(fit, val, **candidate)
        out = []
        for f, y in places:
            p = model.probability(f)
            out += list(_summary(list(zip(((p > 0.5) == (y > 0.5)).tolist(),
                                          np.abs(2 * p - 1).tolist())))[:3])
        return out

    print(f"\ngenerator styles, scored on the places of the real drawings' entries "
          f"(development {len(places[0][1])}, held out {len(places[1][1])}; no consistency "
          f"step): right, sure, >= 0.5")
    print(f"{'trained on':<28} {'drawings':>8} {'development':>21} {'held out':>21}")
    rng = np.random.default_rng(0)

    def row(what, count, values, note=""):
        print(f"{what:<28} {count:>8} " + " ".join(f"{v:>6.1%}" for v in values[:3]) + "  "
              + " ".join(f"{v:>6.1%}" for v in values[3:]) + note)

    for style in (None,) + tuple(s for s in train_order.STYLES
                                 if any(s in d.styles for d in pool)):
        if style is None:
            row("every style, all drawings", len(pool), scored(pool))
            continue
        batch = [s for s in pool if style not in s.styles]
        # As many drawings with every style, three random draws, averaged: the spread between
        # draws is the noise of this table.
        runs = np.array([scored([pool[i] for i in np.sort(rng.choice(len(pool), len(batch),
                                                                      replace=False))])
                         for _ in range(3)])
        row("  every style, as many (3x)", len(batch), runs.mean(0),
            f"   right {runs[:, 0].min():.0%}-{runs[:, 0].max():.0%} / "
            f"{runs[:, 3].min():.0%}-{runs[:, 3].max():.0%}")
        row(f"without {style}", len(batch), scored(batch))


def _prepared(name, upscaled):
    """``(size, annotations, labels, completion, ink)`` of a bundled drawing with its
    ``order`` entries removed, at its size or upscaled to about 1 Mpx (Lanczos)."""
    from PIL import Image

    from inkray.input.annotations import rescale_annotations
    from inkray.input.drawing import drawing_from_array

    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    if upscaled:
        image = Image.open(ann.drawing).convert("RGB")
        scale = (1e6 / (image.width * image.height)) ** 0.5
        size = (round(image.width * scale), round(image.height * scale))
        drawing = drawing_from_array(np.asarray(image.resize(size, Image.LANCZOS)))
        ann = rescale_annotations(ann, size)
    ann = replace(ann, order=[])
    chain = ReliefChain(ann, drawing, options=ChainOptions(predict=False))
    labels, completion = chain.segmentation.labels, chain.candidates
    return labels.shape[::-1], ann, labels, completion, ink_style(drawing.gray)


def _prediction_times(prepared, model, repeats):
    """Median ``(wall, cpu)`` seconds of :func:`depth_order` predicting every place (empty
    memo), with ``model`` (None: the weighted cues)."""
    _, ann, labels, completion, ink = prepared
    wall, cpu = [], []
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        depth_order([], labels, completion, seams=ann.boundaries, ink=ink, model=model)
        wall.append(time.perf_counter() - w)
        cpu.append(time.process_time() - c)
    return float(np.median(wall)), float(np.median(cpu))


def bench_time_1mpx(model, repeats=3):
    """Median wall seconds of predicting every place of the fox upscaled to about 1 Mpx."""
    prepared = _prepared("fox", True)
    (width, height), completion = prepared[0], prepared[3]
    (learned, learned_cpu), (cues, cues_cpu) = (_prediction_times(prepared, m, repeats)
                                                for m in (model, None))
    print(f"\nfox at {width}x{height}, {len(completion.places)} places, prediction "
          f"(median of {repeats}, wall / CPU): learned {learned:.3f} / {learned_cpu:.3f} s, "
          f"weighted cues {cues:.3f} / {cues_cpu:.3f} s")
    return learned


def bench_timing(names, repeats=5):
    """The prediction time of every place of each drawing, at its size and at about 1 Mpx:
    median wall and CPU seconds, learned model and weighted cues; the worst at 1 Mpx
    against :data:`TARGET_TIME`."""
    from inkray.relief.order_model import load_order_model

    model = load_order_model()
    print(f"{'drawing':<12} {'size':>10} {'places':>6} {'learned wall / CPU s':>21} "
          f"{'cues wall / CPU s':>18}")
    worst = 0.0
    for name in names:
        for upscaled in (False, True):
            prepared = _prepared(name, upscaled)
            (width, height), completion = prepared[0], prepared[3]
            learned, cues = (_prediction_times(prepared, m, repeats) for m in (model, None))
            print(f"{name:<12} {f'{width}x{height}':>10} {len(completion.places):>6} "
                  f"{learned[0]:>10.3f} / {learned[1]:.3f} {cues[0]:>8.3f} / {cues[1]:.3f}")
            if upscaled:
                worst = max(worst, learned[0], cues[0])
    print(f"\nworst wall median at 1 Mpx {worst:.3f} s, target {TARGET_TIME:g} s, "
          f"ratio {worst / TARGET_TIME:.2f}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drawings", help="comma-separated folder names under examples/ (default all)")
    ap.add_argument("--no-resolve", action="store_true", help="skip the fast re-solve timing")
    ap.add_argument("--generated", type=int, help="train on this many generated drawings, "
                    "test on the real ones")
    ap.add_argument("--cache", type=Path, help="folder keeping each generated drawing's features")
    ap.add_argument("--real", action="append", default=[], type=Path,
                    help="the annotation of one more real drawing (e.g. a shot's first frame), "
                         "repeatable")
    ap.add_argument("--styles", action="store_true", help="with --generated: each style left out")
    ap.add_argument("--without", default="", help="with --generated: comma-separated styles "
                    "never drawn")
    ap.add_argument("--timing", action="store_true", help="only the prediction time of the "
                    "drawings (--drawings, default the real ones) at their size and at 1 Mpx")
    args = ap.parse_args(argv)
    if args.timing:
        bench_timing(args.drawings.split(",") if args.drawings else REAL)
        return
    if args.generated:
        import sys

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        bench_generated(args)
        return
    folders = sorted(p.parent for p in EXAMPLES.glob("*/drawing.inkray.json"))
    if args.drawings:
        wanted = args.drawings.split(",")
        folders = [f for f in folders if f.name in wanted]
    drawings = [_Drawing(f) for f in folders]
    accuracy, sure = report(drawings, leave_one_out(drawings))
    (radius, widths, scale), lam = _choose(drawings)
    print(f"\nfitted on all drawings: JUNCTION_RADIUS = {radius:g}, CONTINUATION_WIDTHS = "
          f"{widths:g}, STROKE_END_SCALE = {scale:g}, regularization {lam:g}, "
          f"WEIGHTS = {_fit(drawings, (radius, widths, scale), lam)}")
    rows = [("leave-one-out accuracy", f"{accuracy:.1%}", f"{TARGET_ACCURACY:.0%}",
             accuracy / TARGET_ACCURACY),
            ("accuracy, confidence >= 0.5", f"{sure:.1%}", f"{TARGET_SURE:.0%}", sure / TARGET_SURE)]
    if not args.no_resolve:
        worst = bench_resolve()
        rows.append(("fast re-solve, worst", f"{worst:.3f} s", f"{TARGET:g} s", worst / TARGET))
    print()
    print(f"{'target':<30} {'measured':>9} {'target':>7} {'measured / target':>18}")
    for name, measured, target, ratio in rows:
        print(f"{name:<30} {measured:>9} {target:>7} {ratio:>18.2f}")


if __name__ == "__main__":
    main()
