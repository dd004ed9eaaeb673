import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
# Every drawing of the project's shared set is bundled under examples/, with
# its attribution (examples/SOURCES.md): the tests need nothing outside the clone.
SHARED = EXAMPLES


def shared_drawing_names():
    return sorted(p.name for p in SHARED.iterdir() if (p / "drawing.inkray.json").is_file())


@pytest.fixture
def shared_drawings():
    """Folder of the bundled drawings, one folder each with drawing.inkray.json."""
    return SHARED


@pytest.fixture
def examples_dir():
    return EXAMPLES


@pytest.fixture
def minimal_doc():
    """A small valid annotation document (10x8 drawing) as a dict."""
    return json.loads(json.dumps({
        "format": "inkray-annotations", "version": 1, "drawing": "d.png", "size": [10, 8],
        "regions": [{"name": "a", "scribbles": [[[1, 1], [3, 2]]]},
                    {"name": "b", "scribbles": [[[7, 6]]], "inflation": 1.5, "profile": "linear"}],
        "background": [[[0, 0], [9, 0]]],
        "order": [{"front": [2, 2], "back": [7, 6]}],
        "equal": [{"a": [1, 1], "b": [2, 2]}],
        "boundaries": [{"type": "graft", "path": [[4, 4], [5, 5]]}],
    }))
