import json

import numpy as np
import pytest

from inkray.errors import InputError
from inkray.input.pose import MAX_FRAMES, load_pose, parse_pose, pose_path


def doc(**over):
    d = {"format": "inkray-pose", "version": 1, "handles": [[10, 10], [20, 10]],
         "keys": [{"frame": 0, "to": [[10, 10], [20, 10]]},
                  {"frame": 4, "to": [[10, 10], [20, 30]]},
                  {"frame": 8, "to": [[10, 10], [40, 30]]}]}
    d.update(over)
    return d


def test_keys_are_met_and_in_betweens_are_smooth():
    pose = parse_pose(doc())
    assert pose.frames == list(range(9))
    for key in pose.keys:
        assert np.allclose(pose.at(key.frame), key.to)
    # C1 at the middle key: a linear interpolation would turn a corner there
    h = 1e-5
    after = (pose.at(4 + h) - pose.at(4)) / h
    before = (pose.at(4) - pose.at(4 - h)) / h
    assert np.allclose(after, before, atol=1e-3) and np.linalg.norm(after[1]) > 1.0
    assert np.allclose(pose.at(-5), pose.keys[0].to) and np.allclose(pose.at(99), pose.keys[-1].to)


def test_one_key_is_one_pose():
    pose = parse_pose(doc(keys=[{"frame": 3, "to": [[1, 1], [2, 2]]}]))
    assert pose.frames == [3] and np.allclose(pose.at(3), [[1, 1], [2, 2]])


@pytest.mark.parametrize("change, message", [
    (dict(format="inkray-annotations"), "format: expected 'inkray-pose'"),
    (dict(version=2), "version: unsupported version 2"),
    (dict(handles=[]), "handles: a pose needs at least one handle"),
    (dict(handles=[[1, 1], [1, 1]]), "handles[1]: the same point as handles[0]"),
    (dict(handles=[[1, "a"], [2, 2]]), "handles[0][1]: expected a number"),
    (dict(keys=[]), "keys: a pose needs at least one key"),
    (dict(keys=[{"frame": 0, "to": [[1, 1]]}]), "keys[0].to: expected 2 points (one per handle), got 1"),
    (dict(keys=[{"frame": -1, "to": [[1, 1], [2, 2]]}]), "keys[0].frame: expected a whole number >= 0"),
    (dict(keys=[{"frame": 2, "to": [[1, 1], [2, 2]]}, {"frame": 2, "to": [[1, 1], [2, 2]]}]),
     "keys[1].frame: 2 does not come after keys[0].frame 2"),
    (dict(keys=[{"frame": 0, "to": [[1, 1], [2, 2]]}, {"frame": MAX_FRAMES, "to": [[1, 1], [2, 2]]}]),
     f"keys[1].frame: the animation spans {MAX_FRAMES + 1} frames"),
    (dict(keys=[{"frame": 0, "to": [[1, 1], [2, 2]], "tо": 1}]), "keys[0].tо: unknown key"),
    (dict(keys=[{"to": [[1, 1], [2, 2]]}]), "keys[0].frame: missing required key"),
    (dict(extra=1), "extra: unknown key"),
])
def test_bad_files_name_the_key_path(change, message):
    with pytest.raises(InputError) as e:
        parse_pose(doc(**change))
    assert str(e.value).startswith(message), str(e.value)
    assert "\n" not in str(e.value)


def test_handles_must_lie_on_the_drawing_and_comments_are_ignored(tmp_path):
    path = tmp_path / "a.pose.json"
    path.write_text(json.dumps(doc(_note="a comment")))
    assert len(load_pose(path, size=(50, 50)).handles) == 2
    with pytest.raises(InputError, match=r"a.pose.json: handles\[1\]: point \(20, 10\) lies outside the 15x15"):
        load_pose(path, size=(15, 15))
    path.write_text('{"format": "inkray-pose", "version": 1, "handles": [], "handles": []}')
    with pytest.raises(InputError, match="duplicate key"):
        load_pose(path)


def test_pose_path_beside_the_annotation():
    assert pose_path("x/frame3.inkray.json").name == "frame3.pose.json"
