"""The learned depth-order model (inkray.relief.order_model)."""

import json
from pathlib import Path

import numpy as np
import pytest

from inkray.errors import InputError
from inkray.relief.order_cues import FEATURES
from inkray.relief.order_model import MODEL_FILE, OrderModel, load_order_model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_the_shipped_model_loads_and_is_small():
    m = load_order_model()
    assert m is load_order_model()                                # read once
    assert MODEL_FILE.stat().st_size < 200_000
    assert m.feature.shape == m.threshold.shape and m.leaf.shape[0] == m.feature.shape[0]
    assert m.temperature > 0 and m.weights.shape == (len(FEATURES),)
    again = OrderModel.from_json(json.loads(MODEL_FILE.read_text()))
    assert np.array_equal(again.leaf, m.leaf) and again.temperature == m.temperature


def test_probability_is_deterministic_and_does_not_depend_on_the_naming():
    m = load_order_model()
    rng = np.random.default_rng(0)
    f = rng.normal(size=(50, 2, len(FEATURES)))
    p = m.probability(f)
    assert np.array_equal(p, m.probability(f.copy()))
    assert np.allclose(p + m.probability(f[:, ::-1]), 1.0)        # swapped rows: the other way
    assert np.all((p > 0) & (p < 1))


def test_a_one_tree_model_by_hand():
    # One depth-1 tree on feature 2: right (value 1) where it exceeds 0.5, else -1.
    m = OrderModel(feature=np.array([[2]]), threshold=np.array([[0.5]]),
                   leaf=np.array([[-1.0, 1.0]]), temperature=2.0,
                   weights=np.eye(len(FEATURES))[0] * 0.25)
    x = np.zeros((1, 2, len(FEATURES)))
    x[0, 0, 2], x[0, 0, 0] = 1.0, 2.0           # row 0: 0.5 + 1; row 1: 0 - 1
    s = ((0.25 * 2.0 + 1.0) - (-1.0)) / 2.0
    assert m.score(x)[0] == pytest.approx(s)
    assert m.probability(x)[0] == pytest.approx(1.0 / (1.0 + np.exp(-2.0 * s)))
    back = OrderModel.from_json(json.loads(json.dumps(m.to_json())))
    assert back.probability(x)[0] == m.probability(x)[0]


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(format="x"), "not an inkray-order-model"),
    (lambda d: d.update(features=["a"]), "other features"),
    (lambda d: d["leaf"].pop(), "do not fit together"),
    (lambda d: d.update(feature=[[99] * len(d["feature"][0])] * len(d["feature"])),
     "do not fit together"),
    (lambda d: d.update(weights=[1.0]), "do not fit together"),
    (lambda d: d.pop("temperature"), "malformed"),
])
def test_a_broken_model_file_is_an_input_error(change, message):
    data = load_order_model().to_json()
    change(data)
    with pytest.raises(InputError, match=message):
        OrderModel.from_json(data, where="model.json")


# -- the learned predictor through depth_order, on bundled drawings ----------------

def _learned(name):
    """``(front, back, confidence)`` of the learned model's predictions on a bundled
    drawing with its ``order`` entries removed."""
    from dataclasses import replace

    from inkray.input.constraints import constraints
    from inkray.input.loading import load_input
    from inkray.relief.completion import complete_regions
    from inkray.relief.ink_style import ink_style
    from inkray.relief.ordering import depth_order
    from inkray.segmentation import segment

    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    seg = segment(ann, drawing)
    c = complete_regions(seg.labels, names=seg.names)
    ann = replace(ann, order=[])
    model = load_order_model()
    rel, _ = depth_order(constraints(ann), seg.labels, c, seams=ann.boundaries,
                         ink=ink_style(drawing.gray), model=model)
    again, _ = depth_order(constraints(ann), seg.labels, c, seams=ann.boundaries,
                           ink=ink_style(drawing.gray), model=model)
    assert [(r.front, r.back, r.confidence) for r in rel] == \
        [(r.front, r.back, r.confidence) for r in again]            # deterministic
    return sorted((r.front_name, r.back_name, round(r.confidence, 2)) for r in rel
                  if r.source == "predicted")


#: The shipped model's predictions (``benchmarks/train_order.py``); a new model
#: changes them: update with the bench's table, never to hide a regression.
EXPECTED = {
    "balls": [("ball_big", "ball_mid", 0.0), ("ball_small", "ball_mid", 0.61)],
    "man": [("arm_left", "overalls", 0.18), ("nose", "head", 0.54),
            ("overalls", "arm_right", 0.54), ("overalls", "head", 0.84),
            ("shoe_left", "overalls", 0.04), ("shoe_left", "shoe_right", 0.18),
            ("shoe_right", "overalls", 0.16)],
    "turtle": [("foot_hind", "shell", 0.16), ("head", "shell", 0.76),
               ("leg_front", "head", 0.89), ("leg_front", "shell", 0.61)],
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_learned_predictions_on_bundled_drawings(name):
    got = _learned(name)
    want = EXPECTED[name]
    assert [(f, b) for f, b, _ in got] == [(f, b) for f, b, _ in want]
    assert [c for _, _, c in got] == pytest.approx([c for _, _, c in want], abs=0.011)


def test_weights_and_a_model_are_exclusive():
    from inkray.relief.completion import complete_regions
    from inkray.relief.ordering import WEIGHTS, predict_place

    labels = np.full((40, 60), -1, np.int32)
    labels[10:30, 10:50] = 0
    labels[:, 26:34] = 1
    c = complete_regions(labels)
    with pytest.raises(InputError, match="^weights: give cue weights or a learned model"):
        predict_place(c, c.places[0], weights=WEIGHTS, model=load_order_model())
    r = predict_place(c, c.places[0], model=load_order_model())
    assert (r.front, r.back) == (1, 0) and 0 < r.confidence < 1    # the band over the square


def test_the_learned_model_is_the_default_given_the_ink():
    from inkray.relief.completion import complete_regions
    from inkray.relief.ink_style import InkStyle
    from inkray.relief.ordering import WEIGHTS, predict_place

    yy, xx = np.mgrid[:60, :80]
    labels = np.where((yy - 30) ** 2 / 400 + (xx - 30) ** 2 / 600 < 1, 0, -1).astype(np.int32)
    labels[20:34, 36:76] = 1                                        # a bar over an ellipse
    c = complete_regions(labels)
    ink = InkStyle(width=2.0, stroke_ends=0.0)
    default = predict_place(c, c.places[0], ink=ink)
    learned = predict_place(c, c.places[0], ink=ink, model=load_order_model())
    cues = predict_place(c, c.places[0], ink=ink, weights=WEIGHTS)
    assert (default.front, default.confidence) == (learned.front, learned.confidence)
    assert default.front == cues.front == 1 and default.confidence != cues.confidence
    # A label image alone (no ink style): the weighted cues.
    bare = predict_place(c, c.places[0])
    alone = predict_place(c, c.places[0], weights=WEIGHTS)
    assert (bare.front, bare.confidence) == (alone.front, alone.confidence)


def test_isotonic_calibration_by_hand():
    # Score s = (w.x - w.y) / 2 with one weight 1 on feature 0 (no tree).
    knots = np.array([[0.0, 0.5], [1.0, 0.7], [3.0, 0.9]])
    m = OrderModel(feature=np.zeros((1, 1), np.int64), threshold=np.full((1, 1), np.inf),
                   leaf=np.zeros((1, 2)), temperature=1.0,
                   weights=np.eye(len(FEATURES))[0], calibration=knots)
    x = np.zeros((4, 2, len(FEATURES)))
    x[:, 0, 0] = [2.0, 4.0, -6.0, 10.0]                              # s = 1, 2, -3, 5
    assert m.probability(x) == pytest.approx([0.7, 0.8, 0.1, 0.9])  # linear, constant beyond
    assert np.allclose(m.probability(x) + m.probability(x[:, ::-1]), 1.0)
    back = OrderModel.from_json(json.loads(json.dumps(m.to_json())))
    assert np.array_equal(back.calibration, knots)
    for bad in ([[0.0, 0.5]], [[0.0, 0.5], [1.0, 0.4]], [[0.0, 0.5], [0.0, 0.6]],
                [[0.1, 0.5], [1.0, 0.6]], [[0.0, 0.5], [1.0, 1.0]]):
        data = m.to_json()
        data["calibration"] = bad
        with pytest.raises(InputError, match="calibration: expected knots"):
            OrderModel.from_json(data)


def test_isotonic_knots_of_the_training_script():
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from train_order import isotonic

    # Pooled blocks: {0.1}: 0 of 1, {0.2, 0.3}: 1 of 2, {0.4, 0.5, 0.6}: 3 of 3 -> (3+1)/(3+2).
    knots = isotonic(np.array([0.3, 0.1, 0.2, 0.6, 0.4, 0.5]),
                     np.array([False, False, True, True, True, True]))
    assert knots.tolist() == [[0.0, 0.5], [0.1, 0.501], [0.25, 0.501], [0.5, 0.8]]
    rng = np.random.default_rng(1)
    s = rng.uniform(0, 3, 400)
    right = rng.random(400) < 1 / (1 + np.exp(-2 * s))
    k = isotonic(s, right)
    assert np.all(np.diff(k[:, 0]) > 0) and np.all(np.diff(k[:, 1]) >= 0)
    assert 0.5 <= k[:, 1].min() and k[:, 1].max() < 1
