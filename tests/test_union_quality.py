"""The ``--closed --union`` solid of every bundled drawing, checked as ``inkray check`` does.

``inkray check solid.ply --require
watertight,manifold,min-angle=10,shells=1,no-self-intersections``: one
watertight, manifold piece (parts floating in front of the part behind them
are joined to it) whose triangles have no angle below 10 degrees and cross
no other triangle. The solid is read back from its PLY export, as a
printer's slicer would get it.
"""

from functools import lru_cache

import pytest

from conftest import EXAMPLES, shared_drawing_names
from inkray.chain import ReliefChain
from inkray.formats.mesh_report import check_file, failed_requirements
from inkray.formats.meshes import export_relief
from inkray.input.loading import load_input


@lru_cache(maxsize=None)
def _report(name, folder):
    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    relief = ReliefChain(ann, drawing).edit(closed=True, union=True).relief
    path = folder / f"{name}.ply"
    export_relief(relief, path)
    return check_file(path), relief.warnings


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("union")


@pytest.mark.slow
@pytest.mark.parametrize("name", shared_drawing_names())
def test_union_is_one_watertight_manifold_solid(name, folder):
    report, warnings = _report(name, folder)
    assert failed_requirements(report, "watertight,manifold,shells=1") == []
    assert report["overall"]["volume"] is not None
    assert not [w for w in warnings if "separate shells" in w]


@pytest.mark.slow
@pytest.mark.parametrize("name", shared_drawing_names())
def test_a_clean_solid_gives_no_repair_warning(name, folder):
    _, warnings = _report(name, folder)
    warned = any("a slicer may have to repair the solid" in w for w in warnings)
    assert not warned, warnings


@pytest.mark.slow
@pytest.mark.parametrize("name", shared_drawing_names())
def test_union_has_no_slivers(name, folder):
    report, _ = _report(name, folder)
    assert failed_requirements(report, "min-angle=10") == []


@pytest.mark.slow
@pytest.mark.parametrize("name", shared_drawing_names())
def test_union_has_no_self_intersections(name, folder):
    report, _ = _report(name, folder)
    assert failed_requirements(report, "no-self-intersections") == []
