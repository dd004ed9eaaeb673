"""Atomic output groups: all or nothing, targets checked before any work."""

import os

import numpy as np
import pytest
from PIL import Image

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs, check_targets, write_text


def test_all_or_nothing(tmp_path):
    with atomic_outputs() as out:
        out.write_text(tmp_path / "a.txt", "A")
        out.write_bytes(tmp_path / "sub" / "b.bin", b"B")
    assert (tmp_path / "a.txt").read_text() == "A"
    assert (tmp_path / "sub" / "b.bin").read_bytes() == b"B"

    with pytest.raises(RuntimeError):
        with atomic_outputs() as out:
            out.write_text(tmp_path / "c.txt", "C")
            out.write_with(tmp_path / "d.npy", lambda f: np.save(f, np.zeros(3)))
            assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "sub"]
            raise RuntimeError("stage failed half way")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "sub"]  # no c, no d, no temps


def test_replace_keeps_old_file_until_done_and_modes(tmp_path):
    target = tmp_path / "r.json"
    write_text(target, "old")
    os.chmod(target, 0o640)
    with pytest.raises(KeyError):
        with atomic_outputs() as out:
            out.write_text(target, "new")
            assert target.read_text() == "old"  # not visible before commit
            raise KeyError
    assert target.read_text() == "old"
    write_text(target, "new")
    assert target.read_text() == "new" and os.stat(target).st_mode & 0o777 == 0o640


def test_writer_callbacks_write_real_files(tmp_path):
    with atomic_outputs() as out:
        out.write_with(tmp_path / "img.png",
                       lambda f: Image.fromarray(np.zeros((2, 3), np.uint8)).save(f, format="PNG"))
    assert Image.open(tmp_path / "img.png").size == (3, 2)


def test_targets_checked_before_work(tmp_path):
    drawing = tmp_path / "drawing.png"
    drawing.write_bytes(b"x")
    with pytest.raises(InputError, match="is an input of this command"):
        check_targets([tmp_path / "sub" / ".." / "drawing.png"], inputs=[drawing])
    with pytest.raises(InputError, match="written twice by this command"):
        check_targets([tmp_path / "d.png", tmp_path / "./d.png"])
    with pytest.raises(InputError, match="is a directory; expected a file name"):
        check_targets([tmp_path])
    with pytest.raises(InputError, match=r"cannot be created \(.*drawing.png is not a directory\)"):
        check_targets([drawing / "out.png"])
    if os.path.isdir("/proc/self"):
        with pytest.raises(InputError, match="/proc/x.glb: cannot write in /proc"):
            check_targets(["/proc/x.glb"])
    check_targets([tmp_path / "new" / "deeper" / "ok.png"], inputs=[drawing])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drawing.png"]  # the probe left nothing


def test_group_refuses_an_input_and_writes_nothing(tmp_path):
    source = tmp_path / "a.inkray.json"
    source.write_text("{}")
    with pytest.raises(InputError, match="is an input"):
        with atomic_outputs(inputs=[source]) as out:
            out.write_text(tmp_path / "legend.txt", "x")
            out.write_text(source, "overwritten")
    assert source.read_text() == "{}" and not (tmp_path / "legend.txt").exists()


def test_failed_commit_leaves_no_temporaries(tmp_path):
    (tmp_path / "blocker").write_text("a file where a folder should be")
    with pytest.raises(InputError, match="cannot be written"):
        with atomic_outputs() as out:
            out.write_text(tmp_path / "first.txt", "1")
            out._pending[tmp_path / "blocker" / "x.txt"] = b"2"  # fails at commit time
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]


def test_outputs_get_normal_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        write_text(tmp_path / "a.txt", "x")
    finally:
        os.umask(old)
    assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o644
