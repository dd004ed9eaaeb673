"""The regions report and the predicted relations listed for the user."""

import numpy as np

from inkray import cli
from inkray.relief.ordering import Relation

from conftest import EXAMPLES


def _relation(front, back, confidence, source="predicted", place=0, kind="order"):
    return Relation(front=0, back=1, front_name=front, back_name=back, where=(10.4, 20.6),
                    source=source, confidence=confidence, place=place, kind=kind)


def test_predicted_relations_least_sure_first():
    from inkray.formats.regions_report import predicted_relations

    rel = [_relation("head", "body", 0.9, place=0), _relation("arm", "body", 0.1, place=1),
           _relation("eye", "head", 1.0, source="user", place=2),
           _relation("a", "b", 0.05, kind="equal", place=3)]
    assert predicted_relations(rel) == ["arm over body at (10, 21): confidence 0.10",
                                        "head over body at (10, 21): confidence 0.90"]
    assert predicted_relations(rel, below=0.5) == ["arm over body at (10, 21): confidence 0.10"]


def test_validate_and_regions_list_the_predictions(tmp_path, capsys):
    ann = EXAMPLES / "figure" / "drawing.inkray.json"
    code = cli.main(["--quiet", "validate", str(ann)])
    out = capsys.readouterr().out
    assert code == 0 and "predicted" not in out          # without --predict: no work done
    code = cli.main(["--quiet", "validate", str(ann), "--predict"])
    out = capsys.readouterr().out.splitlines()
    assert code == 0 and out[1].startswith("1 predicted order relations, least sure first")
    assert out[2].startswith("  head over arm_near at (") and ": confidence 0." in out[2]
    code = cli.main(["--quiet", "regions", str(ann), "-o", str(tmp_path / "r.json")])
    listed = capsys.readouterr().out.splitlines()
    assert code == 0 and listed[1:] == out[1:]
    report = (tmp_path / "r.json").read_text()
    assert '"source": "predicted"' in report and '"confidence"' in report
    conf = float(out[2].rsplit(" ", 1)[1])
    assert 0 < conf < 1 and np.isfinite(conf)
