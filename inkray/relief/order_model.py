"""A depth-order model learned from generated drawings, evaluated with numpy.

Ink-and-Ray (Sýkora et al., ACM TOG 33(2), 2014, section 4) predicts which of
two neighbouring parts is in front from the completion of illusory surfaces;
here that prediction is learned. The cues and measures of
:func:`inkray.relief.order_cues.place_features` are read by gradient-boosted
regression trees (Friedman, "Greedy function approximation: a gradient
boosting machine", Annals of Statistics 29(5), 2001) trained on line drawings
generated with a known depth order (``benchmarks/order_drawings.py``, trained
by ``benchmarks/train_order.py``; no hand-made drawing is used), and
calibrated on a held-out split of generated drawings: by Platt scaling (Platt,
"Probabilistic outputs for support vector machines", 1999) or by isotonic
regression of the right share on the score (Zadrozny and Elkan, "Transforming
classifier scores into accurate multiclass probability estimates", KDD 2002).

The trees score both orientations of a place, ``F(x, y)`` with ``x`` supposed
in front and ``F(y, x)``; ``s = (F(x, y) - F(y, x)) / 2`` and
``P(x in front) = sigmoid(temperature * s)``, or with an isotonic
calibration ``P = c(s)`` for ``s >= 0`` and ``1 - c(-s)`` below, ``c``
piecewise linear through the model's knots, so the answer does not depend
on which region is named first. The model is a small JSON file shipped in the
package (:data:`MODEL_FILE`).
"""

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.relief.order_cues import FEATURES

__all__ = ["MODEL_FILE", "OrderModel", "load_order_model"]

#: The shipped model, written by ``benchmarks/train_order.py``.
MODEL_FILE = Path(__file__).resolve().parent / "order_model.json"
_FORMAT = "inkray-order-model"


@dataclass(frozen=True, eq=False)
class OrderModel:
    """A linear term and boosted trees over :data:`inkray.relief.order_cues.FEATURES`, and a
    temperature.

    Attributes
    ----------
    feature : (T, 2**D - 1) int array
        The feature tested at every inner node of every tree, in heap order
        (node ``i`` has children ``2i+1`` and ``2i+2``).
    threshold : (T, 2**D - 1) float array
        A sample goes right where its feature exceeds the threshold (``inf``:
        always left).
    leaf : (T, 2**D) float array
        The trees' leaf values, summed into the score.
    temperature : float
        Platt scale of the antisymmetric score.
    weights : (F,) float array, optional
        A linear term ``weights @ x`` added to the trees' sum (the trees are
        boosted from it); None: none.
    calibration : (K, 2) float array, optional
        Knots ``(s, p)`` of an isotonic calibration, ``s`` increasing from 0
        and ``p`` non-decreasing from 0.5 below 1: ``P(x in front)`` for a
        score ``s >= 0``, interpolated linearly (constant beyond the last
        knot). None: Platt scaling by ``temperature``.
    """

    feature: np.ndarray
    threshold: np.ndarray
    leaf: np.ndarray
    temperature: float
    weights: np.ndarray = None
    calibration: np.ndarray = None

    def trees_score(self, X):
        """``F``: the linear term plus the sum of the trees' values at the rows of ``X`` ``(n, F)``."""
        X = np.asarray(X, float)
        linear = 0.0 if self.weights is None else X @ self.weights
        n = len(X)
        depth = int(np.log2(self.leaf.shape[1]))
        trees = np.arange(len(self.leaf))
        node = np.zeros((n, len(trees)), np.int64)
        rows = np.arange(n)[:, None]
        for _ in range(depth):
            f, t = self.feature[trees, node], self.threshold[trees, node]
            node = 2 * node + 1 + (X[rows, f] > t)
        return linear + self.leaf[trees, node - (2 ** depth - 1)].sum(1)

    def score(self, features):
        """Antisymmetric score ``s`` of ``(n, 2, F)`` features (both orientations per place)."""
        f = np.asarray(features, float)
        both = self.trees_score(f.reshape(-1, f.shape[-1])).reshape(-1, 2)
        return (both[:, 0] - both[:, 1]) / 2.0

    def probability(self, features):
        """``P(x in front)`` for every place of ``(n, 2, F)`` features (row 0: ``x``).

        Examples
        --------
        >>> import numpy as np
        >>> m = load_order_model()
        >>> f = np.zeros((1, 2, len(FEATURES)))
        >>> float(m.probability(f)[0])        # the same both ways: a coin toss
        0.5
        """
        s = self.score(features)
        if self.calibration is None:
            return 1.0 / (1.0 + np.exp(-self.temperature * s))
        knots, p = self.calibration[:, 0], self.calibration[:, 1]
        front = np.interp(np.abs(s), knots, p)
        return np.where(s >= 0, front, 1.0 - front)

    def to_json(self):
        """The model as a JSON-able dict (``inf`` thresholds as ``null``)."""
        thr = [[None if not np.isfinite(v) else float(v) for v in row] for row in self.threshold]
        return {"format": _FORMAT, "version": 1, "features": list(FEATURES),
                "temperature": float(self.temperature),
                "weights": None if self.weights is None else self.weights.tolist(),
                "calibration": None if self.calibration is None else self.calibration.tolist(),
                "feature": self.feature.tolist(),
                "threshold": thr, "leaf": self.leaf.tolist()}

    @classmethod
    def from_json(cls, data, *, where="order model"):
        """Read :meth:`to_json`'s dict; ``InputError`` when it is not a model for these features."""
        if not isinstance(data, dict) or data.get("format") != _FORMAT or data.get("version") != 1:
            raise InputError(f"{where}: not an {_FORMAT} version 1 file")
        if data.get("features") != list(FEATURES):
            raise InputError(f"{where}: features: the model was trained on other features "
                             f"than {', '.join(FEATURES)}")
        try:
            feature = np.asarray(data["feature"], np.int64)
            threshold = np.asarray([[np.inf if v is None else v for v in row]
                                    for row in data["threshold"]], float)
            leaf = np.asarray(data["leaf"], float)
            temperature = float(data["temperature"])
            weights = data.get("weights")
            weights = None if weights is None else np.asarray(weights, float)
            calibration = data.get("calibration")
            calibration = None if calibration is None else np.asarray(calibration, float)
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"{where}: malformed model ({e})") from None
        inner = leaf.shape[1] - 1 if leaf.ndim == 2 else -1
        if (feature.shape != threshold.shape or feature.ndim != 2 or feature.shape[1] != inner
                or len(leaf) != len(feature) or inner < 1 or inner & (inner + 1)
                or feature.min() < 0 or feature.max() >= len(FEATURES)
                or (weights is not None and weights.shape != (len(FEATURES),))):
            raise InputError(f"{where}: the trees' arrays do not fit together")
        if calibration is not None and (
                calibration.ndim != 2 or calibration.shape[1] != 2 or len(calibration) < 2
                or calibration[0, 0] != 0.0 or calibration[0, 1] != 0.5
                or np.any(np.diff(calibration[:, 0]) <= 0) or np.any(np.diff(calibration[:, 1]) < 0)
                or calibration[-1, 1] >= 1.0):
            raise InputError(f"{where}: calibration: expected knots (s, p) from (0, 0.5), s "
                             f"increasing, p non-decreasing below 1")
        return cls(feature=feature, threshold=threshold, leaf=leaf, temperature=temperature,
                   weights=weights, calibration=calibration)


@lru_cache(maxsize=1)
def load_order_model():
    """The shipped :class:`OrderModel` (read once).

    Examples
    --------
    >>> m = load_order_model()
    >>> m.leaf.shape[1] == 2 * m.feature.shape[1] + 1 - m.feature.shape[1]     # complete trees
    True
    """
    return OrderModel.from_json(json.loads(MODEL_FILE.read_text(encoding="utf-8")),
                                where=MODEL_FILE.name)
