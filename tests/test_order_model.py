"""The learned depth-order model (inkray.relief.order_model)."""

import json

import numpy as np
import pytest

from inkray.errors import InputError
from inkray.relief.order_cues import FEATURES
from inkray.relief.order_model import MODEL_FILE, OrderModel, load_order_model


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
