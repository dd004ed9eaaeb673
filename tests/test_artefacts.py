"""The table of artefacts: one declaration, the same bytes from the CLI, batch and the editor."""

import json

import pytest

from inkray import cli
from inkray.artefacts import ARTEFACTS, artefact_files
from inkray.batch import JOB_FILES, run_frame
from inkray.chain import ReliefChain
from inkray.editor.session import EditSession
from inkray.errors import InputError
from inkray.examples import example_path
from inkray.input.annotations import parse_annotations
from inkray.input.loading import load_input


@pytest.fixture(scope="module")
def turtle_chain():
    return ReliefChain(*load_input(example_path("turtle")))


def test_every_artefact_is_declared_whole():
    for name, artefact in ARTEFACTS.items():
        assert artefact.name == name and artefact.reads and artefact.writers
        assert all(s == "" or s.startswith(".") for s in artefact.suffixes)
    for job, made in JOB_FILES.items():  # batch's jobs are artefacts of the table
        assert all(name in ARTEFACTS for name, _ in made), job


def test_the_relief_is_the_same_bytes_from_the_cli_batch_and_the_editor(tmp_path, capsys):
    ann = example_path("turtle")
    assert cli.main(["relief", str(ann), "-o", str(tmp_path / "relief.glb"), "--quiet"]) == 0
    from_cli = (tmp_path / "relief.glb").read_bytes()
    from_batch = run_frame(str(ann), ("relief",))["files"]["relief.glb"]
    from_editor = EditSession(ann).preview("relief.glb").body
    assert from_cli == from_batch == from_editor


def test_files_in_memory_are_the_files_on_disk(turtle_chain, tmp_path):
    labels = ARTEFACTS["labels"]
    seg = labels.make(turtle_chain)
    in_memory = artefact_files(labels, seg, "labels.png", chain=turtle_chain)
    assert sorted(in_memory) == ["labels.json", "labels.png"]
    assert in_memory["labels.png"] == labels.encode(seg)
    legend = json.loads(in_memory["labels.json"])
    assert sorted(legend["regions"]) == sorted(seg.names)


def test_the_regions_guard_is_the_artefacts_own():
    empty = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [8, 8]})
    needs = {name for name, a in ARTEFACTS.items() if a.needs}
    assert needs == {"relief", "shaded", "layers", "maps", "transfer", "posed", "posed-layers",
                     "posed-relief", "posed-animation"}
    for name in needs:
        with pytest.raises(InputError, match=r"^regions: .* at least one region$"):
            ARTEFACTS[name].check(empty)
    ARTEFACTS["labels"].check(empty)  # labels and depth need no region


def test_an_unknown_suffix_names_the_target_and_what_is_expected():
    with pytest.raises(InputError, match=r"^x\.stl: unsupported output type \.stl "
                                         r"\(expected \.glb, \.obj, \.ply\)$"):
        ARTEFACTS["relief"].files("x.stl")
    assert ARTEFACTS["maps"].files("maps")[0].as_posix() == "maps/maps.json"
    assert [p.name for p in ARTEFACTS["depth"].files("d.png", npy="d.npy")] == \
        ["d.png", "d.json", "d.npy"]


def test_compose_writes_the_scene_artefacts_of_the_table(tmp_path, capsys):
    from inkray.composition import compose
    from inkray.input.scene import load_scene

    rings = example_path("rings")
    scene = tmp_path / "two.scene.json"
    scene.write_text(json.dumps({"format": "inkray-scene", "version": 1, "size": [640, 200],
                                 "drawings": [{"annotation": str(rings), "at": [159.5, 99.5]},
                                              {"annotation": str(rings), "at": [479.5, 99.5],
                                               "rotate": 10}]}))
    composition = compose(load_scene(scene))
    for name, target in (("composed", "s.png"), ("composed-layers", "s.ora"),
                         ("composed-relief", "s.glb")):
        artefact = ARTEFACTS[name]
        assert artefact.needs is None      # a scene has no regions of its own to check
        assert cli.main(["compose", str(scene), "-o", str(tmp_path / target), "--quiet"]) == 0
        files = artefact_files(artefact, artefact.make(composition), target, chain=composition)
        assert files == {target: (tmp_path / target).read_bytes()}
