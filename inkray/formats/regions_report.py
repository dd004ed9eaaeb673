"""The regions report: completed regions, their depth order and overlap places as JSON.

``inkray regions`` writes it (Ink-and-Ray, Sýkora et al., TOG 2014, sections
4-5: completion under occluders and local depth order)::

    {"format": "inkray-regions", "version": 1, "size": [W, H], "predict": true,
     "regions": [{"name", "label", "visible_area", "completed_area", "neighbours",
                  "mask" (with masks)}, ...],
     "relations": [{"front", "back", "where": [x, y], "source": "user" | "predicted",
                    "confidence", "place", "entry": "order[i]" | null}, ...],
     "equal": [{"a", "b", "where", "place", "entry"}, ...],
     "places": [{"index", "a", "b", "where", "site"}, ...],
     "warnings": [...]}

With masks, each completed region is also written as an 8-bit PNG
``MASKS/NAME.png`` (255 inside).
"""

import json
from pathlib import Path

import numpy as np

from inkray.formats.atomic import atomic_outputs

__all__ = ["predicted_relations", "regions_report", "write_regions_report", "read_regions_report"]


def regions_report(segmentation, candidates, completion, relations, *, predict=True,
                   warnings=(), masks=None):
    """The report as a JSON-ready dict.

    Parameters
    ----------
    segmentation : inkray.segmentation.Segmentation
    candidates : inkray.relief.completion.Completion
        Before the depth order (its neighbours and places).
    completion : inkray.relief.completion.Completion
        After the depth order (the completed areas).
    relations : list of inkray.relief.ordering.Relation
    predict : bool, default True
        Whether the relations include predictions (recorded).
    warnings : sequence of str
    masks : str or pathlib.Path, optional
        Folder of the mask PNGs (recorded per region).

    Returns
    -------
    dict
    """
    labels, names = segmentation.labels, segmentation.names
    visible = np.bincount(labels[labels >= 0], minlength=len(names))
    invented = np.bincount(completion.owner[completion.owner >= 0], minlength=len(names))
    masks = Path(masks) if masks is not None else None

    def point(p):
        return [round(float(v), 2) for v in p]

    return {
        "format": "inkray-regions", "version": 1,
        "size": [int(labels.shape[1]), int(labels.shape[0])],
        "predict": bool(predict),
        "regions": [{"name": n, "label": i, "visible_area": int(visible[i]),
                     "completed_area": int(visible[i] + invented[i]),
                     "neighbours": [names[j] for j in candidates.neighbours[i]],
                     **({"mask": str(masks / f"{n}.png")} if masks is not None else {})}
                    for i, n in enumerate(names)],
        "relations": [{"front": r.front_name, "back": r.back_name, "where": point(r.where),
                       "source": r.source, "confidence": float(f"{r.confidence:.4g}"),
                       "place": r.place, "entry": None if r.entry is None else f"order[{r.entry}]"}
                      for r in relations if r.kind == "order"],
        "equal": [{"a": r.front_name, "b": r.back_name, "where": point(r.where), "place": r.place,
                   "entry": f"equal[{r.entry}]"} for r in relations if r.kind == "equal"],
        "places": [{"index": p.index, "a": names[p.a], "b": names[p.b], "where": point(p.where),
                    "site": p.site} for p in candidates.places],
        "warnings": list(warnings),
    }


def predicted_relations(relations, *, below=1.0):
    """The predicted order relations as lines of text, the least sure first.

    Where a prediction is unsure is where an ``order`` arrow helps most; a
    confidence of 0.5 or more was right 97 % of the time on the bundled
    drawings (``benchmarks/bench_order.py``, leave-one-out).

    Parameters
    ----------
    relations : list of inkray.relief.ordering.Relation
    below : float, default 1.0
        Only predictions with a confidence below this.

    Returns
    -------
    list of str
        ``"head over body at (168, 273): confidence 0.42"``.

    Examples
    --------
    >>> from inkray.relief.ordering import Relation
    >>> r = Relation(front=1, back=0, front_name="head", back_name="body", where=(168.0, 273.0),
    ...              source="predicted", confidence=0.4213, place=0)
    >>> predicted_relations([r])
    ['head over body at (168, 273): confidence 0.42']
    """
    guesses = sorted((r for r in relations if r.source == "predicted" and r.kind == "order"
                      and r.confidence < below),
                     key=lambda r: (r.confidence, r.place))
    return [f"{r.front_name} over {r.back_name} at ({r.where[0]:.0f}, {r.where[1]:.0f}): "
            f"confidence {r.confidence:.2f}" for r in guesses]


def write_regions_report(report, path, *, completion=None, masks=None, outputs=None):
    """Write the report (and, with ``masks``, each completed region as ``MASKS/NAME.png``).

    Parameters
    ----------
    report : dict
        From :func:`regions_report`.
    path : str or pathlib.Path
    completion : inkray.relief.completion.Completion, optional
        Needed with ``masks``.
    masks : str or pathlib.Path, optional
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group to join.

    Returns
    -------
    list of pathlib.Path
    """
    from PIL import Image

    if outputs is None:
        with atomic_outputs() as group:
            return write_regions_report(report, path, completion=completion, masks=masks,
                                        outputs=group)
    written = []
    if masks is not None:
        for i, region in enumerate(report["regions"]):
            target = Path(masks) / f"{region['name']}.png"
            mask = np.where(completion.completed(i), 255, 0).astype(np.uint8)
            outputs.write_with(target, lambda f, mask=mask: Image.fromarray(mask).save(
                f, format="PNG"))
            written.append(target)
    outputs.write_text(path, json.dumps(report, indent=2, ensure_ascii=False) + "\n")
    return [Path(path)] + written


def read_regions_report(path):
    """Read a regions report.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    dict

    Raises
    ------
    InputError
        Not a JSON regions report.
    """
    from inkray.errors import InputError

    try:
        report = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise InputError(f"{path}: cannot read the regions report ({e})") from None
    if not isinstance(report, dict) or report.get("format") != "inkray-regions":
        raise InputError(f"{path}: format: expected \"inkray-regions\"")
    return report
