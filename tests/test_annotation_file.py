import json

import numpy as np

from inkray.formats.annotation_file import annotation_document, annotation_text, transfer_report
from inkray.input.annotations import load_annotations, parse_annotations
from inkray.transfer import EntryCheck, Transfer

from conftest import EXAMPLES


def test_every_bundled_annotation_reads_back_to_the_same_records():
    for path in sorted(EXAMPLES.glob("*/drawing.inkray.json")) + \
            sorted(EXAMPLES.glob("shots/*/0001.inkray.json")):
        ann = load_annotations(path)
        text = annotation_text(annotation_document(ann, drawing="d.png"))
        again = parse_annotations(json.loads(text))
        assert again.size == ann.size and json.loads(text)["drawing"] == "d.png"
        for a, b in zip(ann.regions, again.regions, strict=True):
            assert (a.name, a.inflation, a.profile) == (b.name, b.inflation, b.profile)
            for s, t in zip(a.scribbles, b.scribbles, strict=True):
                assert np.allclose(s, t, atol=0.005)
        for a, b in zip(ann.order + ann.equal, again.order + again.equal, strict=True):
            assert np.allclose(np.r_[getattr(a, "front", getattr(a, "a", None))],
                               np.r_[getattr(b, "front", getattr(b, "a", None))], atol=0.005)
        assert [b.type for b in ann.boundaries] == [b.type for b in again.boundaries]
        assert len(ann.background) == len(again.background)
        # Same records, same bytes.
        assert annotation_text(annotation_document(again, drawing="d.png")) == text


def test_points_are_written_one_polyline_per_line():
    ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [20, 20],
                             "regions": [{"name": "a", "scribbles": [[[1.234, 2], [3, 4.5678]]]}],
                             "order": [{"front": [1, 1], "back": [5, 5]}]})
    text = annotation_text(annotation_document(ann))
    assert '        [[1.23, 2], [3, 4.57]]\n' in text
    assert '    {"front": [1, 1], "back": [5, 5]}\n' in text


def test_the_report_lists_every_entry_and_the_ones_to_check():
    t = Transfer(annotations=None, confidence=0.8, warnings=["order[1]: moved 14 px, match 0.41: "
                                                             "check it"],
                 entries=[EntryCheck("regions[0]", 3.0, 0.97, False, "head"),
                          EntryCheck("order[1]", 14.2, 0.4123, True)])
    doc = transfer_report(t, key="k.inkray.json", frame="f.png")
    assert doc["format"] == "inkray-transfer-report" and doc["confidence"] == 0.8
    assert [e["check"] for e in doc["entries"]] == [False, True]
    assert doc["entries"][1]["match"] == 0.412 and doc["check"] == t.warnings
