"""Every rule of the annotation format (docs/format.md) broken once, the key path checked."""

import json

import numpy as np
import pytest

from conftest import shared_drawing_names, SHARED
from inkray.input.annotations import (decode_annotations, load_annotations, parse_annotations,
                                      rescale_annotations)
from inkray.input.limits import Limits
from inkray.errors import InputError


def _error(doc):
    with pytest.raises(InputError) as e:
        parse_annotations(doc)
    return str(e.value)


def test_minimal_doc_parses_into_typed_objects(minimal_doc):
    ann = parse_annotations(minimal_doc)
    assert ann.size == (10, 8)
    assert [r.name for r in ann.regions] == ["a", "b"]
    assert ann.regions[0].inflation == 2.0 and ann.regions[0].profile == "sqrt"
    assert ann.regions[1].inflation == 1.5 and ann.regions[1].profile == "linear"
    assert ann.regions[0].scribbles[0].shape == (2, 2)
    assert ann.order[0].front == (2.0, 2.0) and ann.order[0].back == (7.0, 6.0)
    assert ann.order[0].index == 0
    assert ann.equal[0].a == (1.0, 1.0)
    assert ann.boundaries[0].type == "graft" and ann.boundaries[0].path.shape == (2, 2)
    assert len(ann.background) == 1
    assert ann.region_index("b") == 1


def test_only_required_keys():
    ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [3, 4]})
    assert ann.regions == [] and ann.order == [] and ann.background == [] and ann.drawing is None


@pytest.mark.parametrize("mutate, path, words", [
    # top level
    (lambda d: d.pop("format"), "format", "missing required key"),
    (lambda d: d.update(format="inkray"), "format", "inkray-annotations"),
    (lambda d: d.pop("version"), "version", "missing required key"),
    (lambda d: d.update(version=2), "version", "unsupported version 2"),
    (lambda d: d.update(version="1"), "version", "integer 1"),
    (lambda d: d.update(version=True), "version", "integer 1"),
    (lambda d: d.pop("size"), "size", "missing required key"),
    (lambda d: d.update(size=[10]), "size", "[width, height]"),
    (lambda d: d.update(size=[10, 0]), "size[1]", "positive integer"),
    (lambda d: d.update(size=[10.5, 8]), "size[0]", "positive integer"),
    (lambda d: d.update(drawing=3), "drawing", "path string"),
    (lambda d: d.update(drawing=""), "drawing", "path string"),
    (lambda d: d.update(regoins=[]), "regoins", "unknown key"),
    # regions
    (lambda d: d.update(regions={}), "regions", "expected a list"),
    (lambda d: d["regions"].__setitem__(1, "b"), "regions[1]", "expected an object"),
    (lambda d: d["regions"][1].pop("name"), "regions[1].name", "missing required key"),
    (lambda d: d["regions"][1].update(name=7), "regions[1].name", "expected a string"),
    (lambda d: d["regions"][1].update(name="left leg"), "regions[1].name", "letters, digits"),
    (lambda d: d["regions"][1].update(name="a"), "regions[1].name", "duplicate region name 'a'"),
    (lambda d: d["regions"][0].pop("scribbles"), "regions[0].scribbles", "missing required key"),
    (lambda d: d["regions"][0].update(scribbles=[]), "regions[0].scribbles", "at least one"),
    (lambda d: d["regions"][0].update(scribbles=[[]]), "regions[0].scribbles[0]", "at least one point"),
    (lambda d: d["regions"][0].update(scribbles=[[[1, 1], [1]]]), "regions[0].scribbles[0][1]", "[x, y]"),
    (lambda d: d["regions"][0].update(scribbles=[[[1, "2"]]]), "regions[0].scribbles[0][0][1]", "expected a number"),
    (lambda d: d["regions"][0].update(scribbles=[[[1, 1], [12, 3]]]), "regions[0].scribbles[0][1]",
     "point (12, 3) lies outside the 10x8 drawing"),
    (lambda d: d["regions"][0].update(scribbles=[[[-0.6, 1]]]), "regions[0].scribbles[0][0]", "outside"),
    (lambda d: d["regions"][0].update(inflation=0), "regions[0].inflation", "positive number"),
    (lambda d: d["regions"][0].update(inflation="2"), "regions[0].inflation", "positive number"),
    (lambda d: d["regions"][0].update(profile="round"), "regions[0].profile", "unknown profile"),
    (lambda d: d["regions"][0].update(colour="red"), "regions[0].colour", "unknown key"),
    # background
    (lambda d: d.update(background=[[1, 1]]), "background[0][0]", "[x, y]"),
    (lambda d: d.update(background=[[[1, 9]]]), "background[0][0]", "outside the 10x8"),
    # order / equal
    (lambda d: d["order"][0].pop("back"), "order[0].back", "missing required key"),
    (lambda d: d["order"][0].update(front=[2, 2, 2]), "order[0].front", "[x, y]"),
    (lambda d: d["order"][0].update(back=[2, 2]), "order[0]", "same point"),
    (lambda d: d["order"].append([1, 2]), "order[1]", "expected an object"),
    (lambda d: d["order"][0].update(depth=1), "order[0].depth", "unknown key"),
    (lambda d: d["equal"][0].pop("b"), "equal[0].b", "missing required key"),
    (lambda d: d["equal"][0].update(a=[100, 1]), "equal[0].a", "outside"),
    # boundaries
    (lambda d: d["boundaries"][0].update(type="seam"), "boundaries[0].type", "unknown boundary type"),
    (lambda d: d["boundaries"][0].pop("type"), "boundaries[0].type", "missing required key"),
    (lambda d: d["boundaries"][0].update(path=[[4, 4]]), "boundaries[0].path", "at least 2 points"),
    (lambda d: d["boundaries"][0].update(path=[[4, 4], [50, 5]]), "boundaries[0].path[1]", "outside"),
])
def test_each_rule_is_enforced_with_key_path(minimal_doc, mutate, path, words):
    mutate(minimal_doc)
    message = _error(minimal_doc)
    assert message.startswith(path + ":"), message
    assert words in message, message
    assert "\n" not in message


def test_non_finite_and_top_level_type():
    assert _error([]).startswith("(top level): expected an object")
    doc = {"format": "inkray-annotations", "version": 1, "size": [4, 4],
           "order": [{"front": [float("nan"), 1], "back": [1, 1]}]}
    assert _error(doc).startswith("order[0].front[0]: expected a number")


def test_comment_keys_are_ignored(minimal_doc):
    minimal_doc["_comment"] = "drawn by hand"
    minimal_doc["regions"][0]["_note"] = "x"
    assert len(parse_annotations(minimal_doc).regions) == 2


def test_points_on_the_last_pixel_are_inside(minimal_doc):
    minimal_doc["order"][0]["front"] = [9, 7]
    assert parse_annotations(minimal_doc).order[0].front == (9.0, 7.0)


def test_load_reports_file_level_problems(tmp_path, minimal_doc):
    p = tmp_path / "a.inkray.json"
    with pytest.raises(InputError, match="no such annotation file"):
        load_annotations(p)
    p.write_text("{not json")
    with pytest.raises(InputError, match=r"not valid JSON: .* \(line 1, column 2\)"):
        load_annotations(p)
    p.write_bytes(b"\xff\xfe{}")
    with pytest.raises(InputError, match="not UTF-8"):
        load_annotations(p)
    p.write_text('{"format": "inkray-annotations", "format": "x"}')
    with pytest.raises(InputError, match="format: duplicate key"):
        load_annotations(p)
    p.write_text('{"format": NaN}')
    with pytest.raises(InputError, match="NaN is not valid JSON"):
        load_annotations(p)
    p.write_text(json.dumps(minimal_doc))
    ann = load_annotations(p)
    assert ann.drawing == tmp_path / "d.png" and ann.source == p


def test_rescale_maps_pixel_centres(minimal_doc):
    ann = parse_annotations(minimal_doc)
    big = rescale_annotations(ann, (20, 16))
    assert big.size == (20, 16)
    assert big.order[0].front == (4.5, 4.5)  # (2 + .5) * 2 - .5
    np.testing.assert_allclose(big.regions[0].scribbles[0][0], [2.5, 2.5])
    np.testing.assert_allclose(big.boundaries[0].path[1], [10.5, 10.5])
    assert ann.order[0].front == (2.0, 2.0)  # the original is untouched


@pytest.mark.parametrize("name", shared_drawing_names())
def test_every_shared_annotation_file_loads(name):
    ann = load_annotations(SHARED / name / "drawing.inkray.json")
    assert ann.drawing.is_file()
    assert len(ann.regions) > 0 and len(ann.order) > 0


# -- bounded memory and file names ---------------------------------------------------

def _peak_of(code):
    """Peak resident memory (bytes) of a fresh interpreter running ``code``."""
    import subprocess
    import sys

    code += "; import resource; print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
    out = subprocess.run([sys.executable, "-c", code], check=True, timeout=300,
                         capture_output=True, text=True).stdout
    return int(out.split()[-1]) * 1024


def test_a_long_string_costs_a_small_multiple_of_its_size(tmp_path, minimal_doc):
    # the pre-scan once kept a backtracking mark per character: 1.3 GB for 10 MB
    doc = dict(minimal_doc, _note="a" * 10_000_000)
    path = tmp_path / "long.inkray.json"
    path.write_text(json.dumps(doc))
    base = tmp_path / "base.inkray.json"
    base.write_text(json.dumps(minimal_doc))
    code = ("from inkray.input.annotations import load_annotations; "
            "load_annotations({!r})")
    idle = _peak_of(code.format(str(base)))
    peak = _peak_of(code.format(str(path)))
    assert peak - idle < 8 * path.stat().st_size


@pytest.mark.parametrize("text", ['"' + "\\\\" * 200_000 + '"', '"' + '\\"' * 200_000 + '"',
                                  '"' + "a" * 400_000])
def test_the_pre_scan_skips_strings_whatever_their_escapes(minimal_doc, text):
    raw = json.dumps(minimal_doc)[:-1] + ', "_note": ' + text + "}"
    if text.endswith('"'):
        assert decode_annotations(raw)["_note"] == json.loads(text)
    else:
        with pytest.raises(InputError, match="not valid JSON"):
            decode_annotations(raw)


def test_too_many_json_values_are_refused_with_their_place(minimal_doc):
    limits = Limits(total_points=10, entries=1)
    raw = json.dumps(dict(minimal_doc, _note=[{}] * (limits.values + 1)))
    with pytest.raises(InputError, match=r"_note\[\d+\]: more than 130 JSON values"):
        decode_annotations(raw, limits=limits)


@pytest.mark.parametrize("name", ["a\x00b.png", "a\ud800b.png"])
def test_a_drawing_name_no_file_can_have_is_one_line(minimal_doc, name):
    with pytest.raises(InputError, match=r"^drawing: .* is not a file name"):
        parse_annotations(dict(minimal_doc, drawing=name))
