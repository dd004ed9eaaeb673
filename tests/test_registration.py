import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.registration import (arap_register, arap_segments, rigid_poses,
                                          rigid_segments, warp_points)

from conftest import EXAMPLES


def _ink(name):
    gray = np.asarray(Image.open(EXAMPLES / name / "drawing.png").convert("L"), float) / 255
    return 1 - gray


def _backward(x, y, h, w):
    """A smooth warp (about 6 px): the target at q shows the source at q + b(q)."""
    return 6 * np.sin(1.6 * np.pi * y / h) + 3, 5 * np.cos(1.4 * np.pi * x / w) - 2


def _warped(ink):
    h, w = ink.shape
    ys, xs = np.mgrid[:h, :w].astype(float)
    bx, by = _backward(xs, ys, h, w)
    target = ndimage.map_coordinates(ink, [ys + by, xs + bx], order=1)
    # The forward displacement u solves p + u + b(p + u) = p (a contraction).
    u = np.zeros((h, w, 2))
    for _ in range(40):
        bx, by = _backward(xs + u[..., 0], ys + u[..., 1], h, w)
        u = -np.stack([bx, by], axis=-1)
    return target, u


def test_a_drawing_registered_to_itself_is_the_identity():
    ink = _ink("cat")
    reg = arap_register(ink, ink)
    assert np.abs(reg.displacement).max() < 1e-6
    assert reg.confidence[ink > 0.5].min() > 0.999


def test_a_known_smooth_warp_is_recovered_within_a_pixel_on_the_ink():
    ink = _ink("figure")
    target, truth = _warped(ink)
    reg = arap_register(ink, target)
    err = np.linalg.norm(reg.displacement - truth, axis=-1)[ink > 0.5]
    # Along a straight stroke the shift along it is seen only at its ends
    # (the aperture problem): the few pixels above a pixel are such.
    assert np.median(err) < 0.3
    assert np.percentile(err, 99) < 1.0
    assert np.abs(truth).max() > 5  # the warp is larger than the tolerance


def test_a_translation_is_found_and_points_move_with_it():
    ink = _ink("turtle")
    moved = np.roll(ink, (7, -12), axis=(0, 1))
    reg = arap_register(ink, moved)
    on_ink = ink > 0.5
    on_ink[:20] = on_ink[-20:] = False  # rolled over the border
    on_ink[:, :20] = on_ink[:, -20:] = False
    assert np.allclose(reg.displacement[on_ink], [-12, 7], atol=0.5)
    p = np.argwhere(on_ink)[::500][:, ::-1].astype(float)
    assert np.allclose(warp_points(reg, p), p + [-12, 7], atol=0.5)


def test_a_stroke_that_appears_lowers_the_confidence_there_only():
    ink = _ink("figure")
    target = ink.copy()
    target[100:104, 40:140] = 1.0  # a new stroke across empty paper near the head
    reg = arap_register(ink, target)
    far = ink > 0.5
    far[60:150, :180] = False
    assert np.abs(reg.displacement[far]).max() < 0.5
    assert reg.confidence[102, 90] < 0.7 < np.median(reg.confidence[far])


@pytest.mark.parametrize("kwargs, match", [
    ({"target": np.zeros((5, 6))}, "source is 8x8 but target is 6x5"),
    ({"spacing": 1}, "spacing must be an integer >= 2"),
    ({"trim": 1.5}, "trim must lie in"),
    ({"target": np.full((8, 8), np.nan)}, "NaN"),
])
def test_bad_input_is_one_line(kwargs, match):
    args = {"source": np.zeros((8, 8)), "target": np.zeros((8, 8))} | kwargs
    with pytest.raises(InputError, match=match):
        arap_register(**args)


def _outline(mask):
    return (mask & ~ndimage.binary_erosion(mask)).astype(float)


def _limb_scene(angle_deg):
    """A box (the body) with a bar (the limb) hinged at (60, 70), the bar turned by ``angle_deg``."""
    h, w = 140, 160
    ys, xs = np.mgrid[:h, :w].astype(float)
    body = (xs >= 30) & (xs <= 90) & (ys >= 30) & (ys <= 70)
    pivot = np.array([60.0, 70.0])
    t = np.deg2rad(angle_deg)
    # A frame pixel is on the turned bar when turning it back lands on the bar at rest.
    dx, dy = xs - pivot[0], ys - pivot[1]
    bx = np.cos(t) * dx + np.sin(t) * dy + pivot[0]
    by = -np.sin(t) * dx + np.cos(t) * dy + pivot[1]
    bar = (np.abs(bx - 60) <= 5) & (by >= 70) & (by <= 125)
    labels = np.full((h, w), -1)
    labels[body] = 0
    labels[bar & ~body] = 1
    return np.clip(_outline(body) + _outline(bar & ~body), 0, 1), labels, pivot


def test_a_limb_turned_far_is_found_by_its_own_rigid_motion():
    source, labels, pivot = _limb_scene(0)
    target, _, _ = _limb_scene(35)
    reg = arap_register(source, target)
    motions = rigid_segments(source, target, labels, reg)
    limb = motions[1]
    tip = np.array([[60.0, 120.0]])
    t = np.deg2rad(35)
    truth = pivot + [[-np.sin(t) * 50, np.cos(t) * 50]]
    # The smooth registration does not follow the bar; the rigid search does.
    assert np.linalg.norm(warp_points(reg, tip) - truth) > 5
    assert np.linalg.norm(limb.apply(tip) - truth) < 2.0
    assert abs(np.rad2deg(limb.angle) - 35) < 2
    assert limb.cost < 0.5 < 1.5 < limb.base_cost
    assert np.allclose(limb.invert(limb.apply(tip)), tip)
    # The body, which the registration already fits, keeps that fit.
    assert motions[0].cost == motions[0].base_cost
    local = arap_segments(source, target, labels, {1: limb})[1]
    assert np.linalg.norm(local.apply(tip) - truth) < 2.0
    assert local.cost <= limb.cost + 0.1


def test_segments_need_labels_of_the_images_shape():
    ink = np.zeros((20, 20))
    with pytest.raises(InputError, match="one shape"):
        rigid_segments(ink, ink, np.zeros((10, 10), int), arap_register(ink, ink))


def test_a_limb_folded_120_degrees_about_its_attachment_is_among_the_poses():
    source, labels, pivot = _limb_scene(0)
    target, _, _ = _limb_scene(120)
    reg = arap_register(source, target)
    tip = np.array([[60.0, 120.0]])
    t = np.deg2rad(120)
    truth = pivot + [[-np.sin(t) * 50, np.cos(t) * 50]]
    # Beyond the search of rigid_segments: its best motion leaves the tip far away.
    assert np.linalg.norm(rigid_segments(source, target, labels, reg)[1].apply(tip) - truth) > 10
    poses = rigid_poses(source, target, labels, 1, reg, count=4)
    assert 1 <= len(poses) <= 4
    assert [m.cost for m in poses] == sorted(m.cost for m in poses)
    # The hinge search turns it about its attachment: one pose puts the tip there.
    best = min(poses, key=lambda m: np.linalg.norm(m.apply(tip) - truth))
    assert np.linalg.norm(best.apply(tip) - truth) < 2.0
    # The body hides part of the folded bar: its fit is not perfect, but the best.
    assert best is poses[0] and best.cost < best.base_cost / 2
    # Poses are distinct: each pair puts some of the limb at least 6 px apart.
    ink = np.argwhere((labels == 1) & (source > 0.5))[:, ::-1].astype(float)
    for i in range(len(poses)):
        for j in range(i):
            assert np.abs(poses[i].apply(ink) - poses[j].apply(ink)).max() >= 6 - 1e-9
    assert rigid_poses(source, target, labels, 7, reg) == []
