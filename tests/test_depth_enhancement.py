import numpy as np
import pytest

from inkray.errors import InputError
from inkray.relief.model import Part, Relief
from inkray.view.depth_enhancement import check_enhancement, depth_highpass, enhance
from inkray.view.rendering import render


def _step(width=80, height=12.0, at=40):
    depth = np.zeros((20, width))
    depth[:, at:] = height           # the right half is nearer: its edge occludes the left
    return depth


def test_highpass_is_negative_behind_the_edge_only_and_fades():
    h = depth_highpass(_step(), radius=4.0)
    row = h[10]
    assert np.all(row[30:40] < 0) and np.all(row[40:50] > 0)
    # Antisymmetric about the edge, as the Gaussian is symmetric.
    np.testing.assert_allclose(row[30:40], -row[40:50][::-1], atol=1e-9)
    # Fades over the radius: below 1e-3 of the step 4 sigmas away.
    assert np.all(np.abs(row[:40 - 16]) < 1e-3 * 12) and np.all(np.diff(row[20:40]) <= 0)


def test_highpass_ignores_a_constant_offset_and_scales_with_the_step():
    d = _step()
    np.testing.assert_allclose(depth_highpass(d + 7.0, radius=3.0), depth_highpass(d, radius=3.0),
                               atol=1e-9)
    np.testing.assert_allclose(depth_highpass(2 * d, radius=3.0),
                               2 * depth_highpass(d, radius=3.0), atol=1e-9)


def test_enhance_darkens_only_behind_the_edge_by_the_documented_factor():
    rgb = np.full((20, 80, 3), 0.8)
    out = enhance(rgb, _step(height=8.0), strength=1.0, radius=4.0)
    assert np.all(out <= rgb + 1e-12)
    np.testing.assert_allclose(out[:, 40:], rgb[:, 40:], atol=1e-12)   # the near side: untouched
    # At the edge the high-pass is half the step: exp(-strength * (8 / 2) / 4) = exp(-1).
    edge = depth_highpass(_step(height=8.0), radius=4.0)[10, 39]
    assert edge == pytest.approx(-4.0, abs=0.6)
    assert out[10, 39, 0] / 0.8 == pytest.approx(np.exp(edge / 4.0))
    assert np.array_equal(enhance(rgb, _step(), strength=0.0, radius=4.0), rgb)
    darker = enhance(rgb, _step(), strength=3.0, radius=4.0)
    assert np.all(darker[:, :40] < out[:, :40] + 1e-12)


def test_radius_is_in_drawing_pixels_whatever_the_picture_size():
    small = enhance(np.ones((20, 80, 3)), _step(), radius=4.0)[10, :, 0]
    big_depth = np.repeat(np.repeat(_step(), 2, axis=0), 2, axis=1)
    big = enhance(np.ones((40, 160, 3)), big_depth, radius=4.0, scale=2.0)[20, :, 0]
    np.testing.assert_allclose((big[0::2] + big[1::2]) / 2, small, atol=0.02)


@pytest.mark.parametrize("strength, radius", [(-0.1, 8.0), (10.5, 8.0), (np.nan, 8.0),
                                              (1.0, 0.1), (1.0, 101.0), (1.0, np.inf),
                                              ("1", 8.0), (True, 8.0)])
def test_out_of_range_parameters_are_one_line_input_errors(strength, radius):
    with pytest.raises(InputError) as e:
        check_enhancement(strength, radius)
    assert "\n" not in str(e.value)
    check_enhancement(0.0, 0.5)         # the documented extremes are accepted
    check_enhancement(10.0, 100.0)


def _two_plates():
    """A low plate with a higher one over its right half."""
    back = Part("back", np.array([[5, 5, 2], [75, 5, 2], [75, 35, 2], [5, 35, 2]], float),
                np.array([[0, 3, 2], [0, 2, 1]]))
    front = Part("front", np.array([[40, 5, 10], [75, 5, 10], [75, 35, 10], [40, 35, 10]], float),
                 np.array([[0, 3, 2], [0, 2, 1]]))
    return Relief([back, front], size=(80, 40))


def test_render_enhance_darkens_the_back_plate_beside_the_front_one():
    relief = _two_plates()
    plain = render(relief, mode="enhance", enhance_strength=0.0).image.astype(int)
    lit = render(relief, mode="enhance", enhance_strength=2.0, enhance_radius=4.0)
    image = lit.image.astype(int)
    assert lit.mode == "enhance" and np.array_equal(image[..., 3], plain[..., 3])
    assert np.all(image[..., :3] <= plain[..., :3])
    row = 20
    assert image[row, 37, 0] < plain[row, 37, 0] - 40          # just behind the front plate
    assert image[row, 15, 0] == plain[row, 15, 0]              # far from it
    assert image[row, 60, 0] == plain[row, 60, 0]              # on the front plate


def test_render_refuses_bad_enhancement_values_up_front():
    with pytest.raises(InputError, match="^enhance_radius: expected a number in 0.5..100"):
        render(_two_plates(), mode="enhance", enhance_radius=0.0)


def test_cli_render_enhance(tmp_path, capsys):
    from inkray import cli
    from inkray.formats.meshes import export_relief

    mesh = tmp_path / "plates.ply"
    export_relief(_two_plates(), mesh)
    out = tmp_path / "enhanced.png"
    assert cli.main(["--quiet", "render", str(mesh), "-o", str(out), "--mode", "enhance",
                     "--enhance-radius", "0"]) == 2
    assert "--enhance-radius: expected a number in 0.5..100" in capsys.readouterr().err
    assert not out.exists()
    assert cli.main(["--quiet", "render", str(mesh), "-o", str(out), "--mode", "enhance",
                     "--enhance-strength", "10", "--enhance-radius", "100"]) == 0
    assert out.is_file()
