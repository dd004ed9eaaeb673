"""CLI contract: exit codes, one-line errors, nothing written on failure."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from PIL import Image

from inkray import cli
from inkray.errors import InputError


@pytest.fixture
def annotated(tmp_path, minimal_doc):
    drawing = np.full((8, 10), 255, np.uint8)
    drawing[1:, 5] = 0  # a line between the regions
    Image.fromarray(drawing).save(tmp_path / "d.png")
    path = tmp_path / "a.inkray.json"
    path.write_text(json.dumps(minimal_doc))
    return path


def _run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_validate_ok(annotated, capsys):
    code, out, err = _run(capsys, "validate", str(annotated), "--quiet")
    assert code == 0 and err == ("inkray: warning: equal[0]: both points lie in region 'a'; a "
                                 "region is not ordered against itself here\n")
    assert "ok: 10x8 drawing" in out and "2 regions" in out and "1 order" in out


def test_validate_bad_key_path_exit_2_one_line(annotated, minimal_doc, capsys):
    minimal_doc["regions"][1]["scribbles"] = [[[1, 1], [13, 2]]]
    annotated.write_text(json.dumps(minimal_doc))
    code, out, err = _run(capsys, "validate", str(annotated))
    assert code == 2
    assert err == ("inkray: error: regions[1].scribbles[0][1]: point (13, 2) lies outside "
                   "the 10x8 drawing\n")
    assert "Traceback" not in err


def test_usage_errors_exit_2_one_line(capsys):
    for argv in (["nonsense"], ["segment", "a.json"], [], ["validate"]):
        code, out, err = _run(capsys, *argv)
        assert code == 2, argv
        assert err.count("\n") == 1 and err.startswith("inkray: error: "), err
    code, _, err = _run(capsys, "segment", "a.json")
    assert err.startswith("inkray: error: segment: the following arguments are required: -o")


def test_messages_escape_control_characters(tmp_path, capsys):
    code, _, err = _run(capsys, "validate", str(tmp_path / "a\x1b[31mred.inkray.json"))
    assert code == 2 and "\x1b" not in err and "\\x1b[31mred" in err, err


def test_limits_from_the_command_line(annotated, capsys):
    w, h = 10, 8
    code, _, err = _run(capsys, "validate", str(annotated), "--max-pixels", str(w * h - 1))
    assert code == 2 and f"exceeds the limit of {w * h - 1} (raise it with --max-pixels)" in err
    code, _, err = _run(capsys, "validate", str(annotated), "--max-points", "0")
    assert code == 2 and err == "inkray: error: --max-points: expected a positive integer\n"


def test_help_and_version(capsys):
    assert _run(capsys, "--help")[0] == 0
    code, out, _ = _run(capsys, "--version")
    assert code == 0 and out.startswith("inkray ")


def test_wrong_output_suffix_is_rejected_before_work(annotated, tmp_path, capsys):
    code, _, err = _run(capsys, "relief", str(annotated), "-o", str(tmp_path / "x.stl"))
    assert code == 2 and "unsupported output type .stl" in err
    assert not (tmp_path / "x.stl").exists()


def test_input_error_exits_2_in_one_line(monkeypatch, capsys):
    def bad(args, progress):
        raise InputError("order[3]: front and back round to the same pixel (4, 5)")
    monkeypatch.setitem(cli._COMMANDS, "check", (bad, "x"))
    code, _, err = _run(capsys, "check", "m.glb")
    assert code == 2
    assert err == "inkray: error: order[3]: front and back round to the same pixel (4, 5)\n"


def test_internal_error_is_one_line_and_debug_shows_traceback(monkeypatch, capsys):
    def boom(args, progress):
        raise ZeroDivisionError("division by zero")
    monkeypatch.setitem(cli._COMMANDS, "check", (boom, "x"))
    code, _, err = _run(capsys, "check", "m.glb")
    assert code == 1 and err.count("\n") == 1 and "internal error: ZeroDivisionError" in err
    code, _, err = _run(capsys, "--debug", "check", "m.glb")
    assert code == 1 and "Traceback" in err
    code, _, err = _run(capsys, "check", "--debug", "m.glb")
    assert "Traceback" in err


def test_flags_before_the_command_are_kept():
    args = cli._parser().parse_args(["--quiet", "validate", "a.json"])
    assert args.quiet is True and args.debug is False
    args = cli._parser().parse_args(["validate", "--debug", "a.json"])
    assert args.debug is True and args.quiet is False


def test_demo_runs_the_whole_job(tmp_path, capsys):
    from inkray.view.rendering import has_mitsuba

    code, out, err = _run(capsys, "--quiet", "demo", "-o", str(tmp_path / "demo"), "--spp", "2")
    assert code == 0, err
    assert "warning" not in err  # the showcase is clean
    assert "turtle" in out and "ok:" in out and "demo: done" in out
    written = {p.name for p in (tmp_path / "demo").iterdir()}
    expected = {"labels.png", "labels.json", "depth.png", "depth.json", "regions.json",
                "relief.glb", "shaded.png"} | ({"gi.png"} if has_mitsuba() else set())
    assert expected <= written, expected - written
    code, _, err = _run(capsys, "demo", "--example", "unicorn")
    assert code == 2 and "no such bundled example" in err


def test_console_script_exit_code(annotated):
    exe = os.path.join(os.path.dirname(sys.executable), "inkray")
    if not os.path.exists(exe):
        pytest.skip("the inkray console script is not installed in this environment")
    r = subprocess.run([exe, "validate", str(annotated.parent / "missing.json")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.strip().endswith("no such annotation file")


# -- property-based: malformed JSON never gives a traceback -------------------

_json = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=12),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(
        st.sampled_from(["format", "version", "size", "regions", "name", "scribbles", "order",
                         "front", "back", "equal", "a", "b", "boundaries", "type", "path",
                         "background", "drawing", "inflation", "profile", "x"]),
        children, max_size=6),
    max_leaves=25)


def _mutations(doc):
    """Structured documents that are almost valid: one subtree replaced."""
    keys = ["format", "version", "size", "regions", "order", "equal", "boundaries", "background"]
    return st.tuples(st.sampled_from(keys), _json).map(lambda kv: {**doc, kv[0]: kv[1]})


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_validate_never_crashes_on_malformed_json(tmp_path, minimal_doc, data, capsys):
    Image.fromarray(np.full((8, 10), 255, np.uint8)).save(tmp_path / "d.png")
    doc = data.draw(_json | _mutations(minimal_doc) | st.binary(max_size=40))
    path = tmp_path / "fuzz.inkray.json"
    if isinstance(doc, bytes):
        path.write_bytes(doc)
    else:
        path.write_text(json.dumps(doc))
    code = cli.main(["validate", str(path)])
    out, err = capsys.readouterr()
    assert code in (0, 2)
    if code == 2:
        assert err.startswith("inkray: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err and "internal error" not in err


def test_an_output_never_overwrites_an_input(annotated, tmp_path, capsys):
    before = annotated.read_bytes()
    drawing = (tmp_path / "d.png").read_bytes()
    cases = [
        (["segment", str(annotated), "-o", str(tmp_path / "a.inkray.png")], "is an input"),
        (["segment", str(annotated), "-o", str(tmp_path / "d.png")], "is an input"),
        (["depth", str(annotated), "-o", str(tmp_path / "x.png"), "--normals",
          str(tmp_path / "x.png")], "written twice"),
        (["segment", str(annotated), "-o", str(tmp_path / "dir.png")], "is a directory"),
        (["relief", str(annotated), "-o", "/proc/x.glb"], "cannot write in /proc"),
    ]
    (tmp_path / "dir.png").mkdir()
    for argv, message in cases:
        if argv[-1].startswith("/proc") and not os.path.isdir("/proc/self"):
            continue
        code, _, err = _run(capsys, *argv)
        assert code == 2 and message in err and err.count("\n") == 1, (argv, err)
    assert annotated.read_bytes() == before and (tmp_path / "d.png").read_bytes() == drawing
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.inkray.json", "d.png", "dir.png"]


def test_sigterm_during_work_leaves_nothing_behind(tmp_path):
    import signal
    import time

    from inkray.examples import example_path

    out = tmp_path / "out"
    out.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "inkray", "relief", str(example_path("donkey")),
                             "-o", str(out / "r.obj"), "--max-area", "5"],
                            stderr=subprocess.PIPE, text=True)
    time.sleep(2.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode in (128 + signal.SIGTERM, -signal.SIGKILL, 0), err
    if proc.returncode:
        assert "nothing was written" in err and list(out.iterdir()) == []


def test_sigterm_inside_a_long_native_call_ends_the_command_within_its_grace(tmp_path):
    """A signal the interpreter cannot act on until a native call returns (LAPACK's
    SVD of a 4000x4000 matrix: minutes) still ends the command: its watchdog
    kills it after the grace period."""
    import signal
    import time

    script = ("import numpy as np\n"
              "from inkray import cli\n"
              "cli._arm_watchdog(grace=1.0)\n"
              "a = np.random.default_rng(0).random((4000, 4000))\n"
              "with cli._terminate_as_interrupt():\n"
              "    print('busy', flush=True)\n"
              "    np.linalg.svd(a)\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline() == "busy\n"
    time.sleep(0.3)  # inside the match
    start = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == -signal.SIGKILL
    assert "killed: still busy 1 s after the signal; nothing was written" in err
    assert time.monotonic() - start < 30


def test_watchdog_lets_a_finished_command_go(tmp_path):
    """No signal, no kill: the command's own exit code, and the watchdog gone with it."""
    script = ("from inkray import cli\n"
              "cli._arm_watchdog(grace=0.1)\n"
              "raise SystemExit(3)\n")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 3 and proc.stderr == ""


def test_validate_reports_every_problem_at_once(annotated, minimal_doc, capsys):
    minimal_doc["regions"][0]["scribbles"].append([[5, 2], [5, 6]])  # on the ink line
    minimal_doc["background"].append([[5, 3], [5, 5]])               # on the ink line too
    annotated.write_text(json.dumps(minimal_doc))
    code, out, err = _run(capsys, "validate", str(annotated))
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert lines[0].startswith("inkray: error: regions[0].scribbles[1]: the scribble lies "
                               "entirely on ink (from pixel (5, 2))")
    assert lines[1].startswith("inkray: error: background[1]: the scribble lies entirely on ink")
    assert lines[-1].endswith(": 2 problems")
    code, out, _ = _run(capsys, "validate", str(annotated), "--json", "--quiet")
    doc = json.loads(out)
    assert code == 2 and doc["ok"] is False
    assert [p["key"] for p in doc["problems"]] == ["regions[0].scribbles[1]", "background[1]"]


def test_validate_finds_what_relief_would_reject(annotated, minimal_doc, capsys):
    blank = annotated.parent / "blank.png"
    Image.fromarray(np.full((8, 10), 255, np.uint8)).save(blank)
    code, _, err = _run(capsys, "validate", str(annotated), "--drawing", str(blank))
    assert code == 2 and "inkray: error: drawing: blank" in err
    minimal_doc["equal"] = []
    minimal_doc["order"] = [{"front": [2, 2], "back": [7, 6]}, {"front": [7, 5], "back": [2, 3]}]
    annotated.write_text(json.dumps(minimal_doc))
    code, out, _ = _run(capsys, "validate", str(annotated), "--json", "--quiet")
    problems = [p for p in json.loads(out)["problems"] if p["severity"] == "error"]
    assert code == 2 and len(problems) == 1 and "order[0]" in problems[0]["message"]
    assert "order[1]" in problems[0]["message"]


def test_validate_json_on_a_file_that_does_not_parse(tmp_path, capsys):
    bad = tmp_path / "bad.inkray.json"
    bad.write_text('{"format": "inkray-annotations", "version": 1, "size": [10, 8], "size": [1, 1]}')
    code, out, err = _run(capsys, "validate", str(bad), "--json")
    doc = json.loads(out)
    assert code == 2 and doc["ok"] is False and err == ""
    assert doc["problems"][0]["key"] == str(bad) and "duplicate key" in doc["problems"][0]["message"]


def test_progress_draws_only_on_a_terminal_and_timings_only_when_asked():
    import io

    from inkray.progress import Progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    piped, terminal = io.StringIO(), Terminal()
    for stream in (piped, terminal):
        p = Progress(stream=stream)
        p._TICK = 0.01
        with p.stage("inflate"):
            p.update(1, 4)
            import time
            time.sleep(0.1)
        p.summary()
    assert piped.getvalue() == ""
    assert "inflate [######" in terminal.getvalue() and "25%" in terminal.getvalue()
    assert "timings" not in terminal.getvalue()
    p = Progress(stream=piped, timings=True)
    with p.stage("segment"):
        pass
    p.summary()
    assert piped.getvalue().startswith("timings:\n  segment")


def test_numbers_that_would_make_non_finite_geometry_are_refused(annotated, tmp_path, capsys):
    for flag, value in (("--units-per-pixel", "1e300"), ("--epsilon", "1e300"),
                        ("--epsilon", "nan"), ("--max-area", "inf")):
        code, _, err = _run(capsys, "relief", str(annotated), "-o", str(tmp_path / "r.glb"),
                            flag, value)
        assert code == 2 and err.startswith(f"inkray: error: {flag} ") and "within" in err, err
    assert not (tmp_path / "r.glb").exists()


def test_masks_of_a_region_with_a_long_name(annotated, minimal_doc, tmp_path, capsys):
    minimal_doc["regions"][0]["name"] = "a" * 300
    minimal_doc["order"] = minimal_doc["equal"] = []
    annotated.write_text(json.dumps(minimal_doc))
    code, _, err = _run(capsys, "regions", str(annotated), "-o", str(tmp_path / "r.json"),
                        "--masks", str(tmp_path / "masks"))
    assert code == 2 and "regions[0].name: 300 characters are too many" in err, err
    assert not (tmp_path / "masks").exists() and not (tmp_path / "r.json").exists()


# -- inputs are never overwritten; extreme option values are refused up front --------

@pytest.fixture
def obj_relief(tmp_path):
    """An OBJ relief beside its MTL and texture, as `inkray relief -o scene.obj` writes it."""
    from inkray.formats.meshes import export_relief
    from inkray.relief.model import Part, Relief

    grid = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0)), -1).reshape(-1, 2)
    faces = np.array([[i, i + 1, i + 6] for i in range(29) if i % 6 != 5])
    part = Part("a", np.column_stack([grid, np.ones(len(grid))]), faces)
    texture = np.random.default_rng(3).integers(0, 255, (6, 6, 3), dtype=np.uint8)
    export_relief(Relief([part], (6, 6), texture), tmp_path / "scene.obj")
    return tmp_path / "scene.obj"


def _files(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def test_render_never_writes_over_the_meshs_texture(obj_relief, capsys):
    before = _files(obj_relief.parent)
    code, _, err = _run(capsys, "render", str(obj_relief), "-o",
                        str(obj_relief.parent / "scene_drawing.png"))
    assert code == 2 and "is an input of this command" in err and err.count("\n") == 1
    assert _files(obj_relief.parent) == before


def test_render_never_writes_a_stereo_view_over_the_texture(obj_relief, capsys):
    png = obj_relief.parent / "scene_drawing.png"
    png.rename(obj_relief.parent / "v-left.png")
    mtl = obj_relief.with_suffix(".mtl")
    mtl.write_text(mtl.read_text().replace("scene_drawing.png", "v-left.png"))
    before = _files(obj_relief.parent)
    code, _, err = _run(capsys, "render", str(obj_relief), "-o", str(obj_relief.parent / "v.png"),
                        "--mode", "stereo")
    assert code == 2 and "v-left.png: is an input" in err
    assert _files(obj_relief.parent) == before


def test_a_texture_cut_short_is_an_error_naming_it(obj_relief, capsys):
    png = obj_relief.parent / "scene_drawing.png"
    png.write_bytes(png.read_bytes()[:40])  # the header only: the OBJ reader drops it silently
    out = obj_relief.parent / "out.png"
    code, _, err = _run(capsys, "render", str(obj_relief), "-o", str(out))
    assert code == 2 and f"{png}: the texture of {obj_relief} cannot be decoded" in err
    assert not out.exists()


def test_a_missing_texture_is_a_warning_naming_it(obj_relief, capsys):
    png = obj_relief.parent / "scene_drawing.png"
    png.unlink()
    out = obj_relief.parent / "out.png"
    code, _, err = _run(capsys, "--quiet", "render", str(obj_relief), "-o", str(out))
    assert code == 0 and f"warning: {png}: texture of {obj_relief} not found" in err
    assert out.is_file()


@pytest.mark.parametrize("argv, message", [
    (["--turntable", "100000"], "--turntable: 100000: expected 1..360 frames"),
    (["--turntable", "300", "--size", "4000x4000"], "more than 268435456 pixels"),
    (["--turntable", "3", "--angle", "inf"], "--angle: inf: expected 0..60 degrees"),
    (["--quality", "final"], "--quality final: only for --mode gi"),
])
def test_render_extremes_are_refused_up_front(obj_relief, capsys, argv, message):
    out = obj_relief.parent / ("o.gif" if "--turntable" in argv else "o.png")
    code, _, err = _run(capsys, "render", str(obj_relief), "-o", str(out), *argv)
    assert code == 2 and message in err and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize("radius", ["inf", "nan", "0.5", "1e9"])
def test_maps_ao_radius_out_of_range_is_refused_before_the_relief(annotated, capsys, radius,
                                                                  monkeypatch):
    import inkray.chain

    def no_relief(self):
        raise AssertionError("the relief was built before the radius was checked")

    monkeypatch.setattr(inkray.chain.ReliefChain, "relief", property(no_relief))
    out = annotated.parent / "maps"
    code, _, err = _run(capsys, "maps", str(annotated), "-o", str(out), "--ao-radius", radius)
    assert code == 2 and err.startswith("inkray: error: --ao-radius ") and "1..1e+06" in err
    assert not out.exists()


def test_gi_renders_final_quality_unless_told(obj_relief, monkeypatch, capsys):
    from inkray.view import rendering

    seen = []
    monkeypatch.setattr(rendering, "_gi", lambda *a: seen.append(a[5]) or rendering._depth(
        a[0], a[2], a[3]))
    out = obj_relief.parent / "g.png"
    for argv, spp in (([], rendering.GI_QUALITY["final"]),
                      (["--quality", "draft"], rendering.GI_QUALITY["draft"]),
                      (["--spp", "3"], 3)):
        assert _run(capsys, "--quiet", "render", str(obj_relief), "-o", str(out), "--mode", "gi",
                    "--size", "8x8", *argv)[0] == 0
        assert seen[-1] == spp
    assert rendering.GI_QUALITY["final"] > rendering.GI_QUALITY["draft"]


def test_the_demos_turtle_builds_without_a_warning():
    from inkray.chain import ReliefChain
    from inkray.examples import example_path
    from inkray.input.loading import load_input

    chain = ReliefChain(*load_input(example_path("turtle")))
    chain.relief
    assert chain.warnings == []


def test_relief_summary_counts_what_the_file_holds(annotated, tmp_path, capsys):
    import re

    import trimesh

    for back in ("none", "plate"):
        path = tmp_path / f"r-{back}.ply"
        code, out, _ = _run(capsys, "relief", str(annotated), "-o", str(path), "--back", back,
                            "--quiet")
        assert code == 0, out
        vertices, faces = map(int, re.search(r"(\d+) vertices, (\d+) faces", out).groups())
        mesh = trimesh.load(path, process=False)
        assert (vertices, faces) == (len(mesh.vertices), len(mesh.faces)), back


def test_relief_max_area_too_fine_is_one_line_naming_the_flag(tmp_path, capsys):
    # 0.001 px^2 (the smallest the flag takes) over a 1200x900 drawing: 1e9 triangles
    drawing = np.full((900, 1200), 255, np.uint8)
    drawing[100:800, 600] = 0
    Image.fromarray(drawing).save(tmp_path / "d.png")
    doc = {"format": "inkray-annotations", "version": 1, "drawing": "d.png", "size": [1200, 900],
           "regions": [{"name": "a", "scribbles": [[[300, 400]]]},
                       {"name": "b", "scribbles": [[[900, 400]]]}]}
    path = tmp_path / "a.inkray.json"
    path.write_text(json.dumps(doc))
    out = tmp_path / "r.glb"
    code, _, err = _run(capsys, "relief", str(path), "-o", str(out), "--max-area", "0.001", "--quiet")
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("inkray: error: --max-area: 0.001 px^2 asks for up to 1.08e+09"), err
    assert not out.exists()
