import numpy as np
import pytest

from inkray.view.denoising import atrous_denoise


def _noisy(value, shape, sigma=0.1, seed=0):
    return value + np.random.default_rng(seed).normal(0.0, sigma, shape)


def test_a_noisy_constant_field_becomes_constant_with_its_mean():
    img = _noisy(0.5, (64, 64, 3))
    out = atrous_denoise(img, levels=5)
    assert out.shape == img.shape and out.dtype == np.float64
    assert out.std() < 0.1 * img.std()
    assert abs(out.mean() - img.mean()) < 2e-3


def test_a_constant_field_is_left_as_it_is():
    img = np.full((20, 30), 0.7)
    n = np.zeros((20, 30, 3))
    n[..., 2] = 1
    out = atrous_denoise(img, normals=n, labels=np.zeros((20, 30), int),
                         variance=np.full((20, 30), 0.01))
    np.testing.assert_allclose(out, 0.7, rtol=1e-6)


def test_a_label_edge_is_kept_exactly():
    labels = np.zeros((48, 48), int)
    labels[:, 20:] = 3
    clean = np.where(labels == 3, 1.0, 0.0)
    out = atrous_denoise(_noisy(clean, clean.shape, 0.05), labels=labels)
    # nothing crosses the edge: each side keeps its own level
    assert abs(out[:, :20].mean() - 0.0) < 0.01 and abs(out[:, 20:].mean() - 1.0) < 0.01
    assert np.abs(out[:, 19]).max() < 0.05 and np.abs(out[:, 20] - 1).max() < 0.05
    # without the labels the edge is smeared
    blurred = atrous_denoise(_noisy(clean, clean.shape, 0.05))
    assert blurred[:, 19].mean() > 0.2


def test_a_crease_in_the_normals_stops_the_filter():
    n = np.zeros((32, 32, 3))
    n[:, :16] = [-0.6, 0, 0.8]
    n[:, 16:] = [0.6, 0, 0.8]
    clean = np.where(np.arange(32) < 16, 0.2, 0.9)[None, :].repeat(32, 0)
    out = atrous_denoise(_noisy(clean, clean.shape, 0.02), normals=n, sigma_normal=64)
    assert np.abs(out[:, 15] - 0.2).max() < 0.03 and np.abs(out[:, 16] - 0.9).max() < 0.03


def test_the_variance_keeps_a_shadow_edge_larger_than_the_noise():
    # a shadow: same surface, same label, a step in brightness far above the noise
    cols = np.arange(64)
    clean = np.where(cols >= 32, 0.8, 0.2)[None, :].repeat(64, 0)
    sigma = 0.02
    noisy = _noisy(clean, clean.shape, sigma)
    var = np.full(clean.shape, sigma ** 2)
    kept = atrous_denoise(noisy, variance=var)
    assert abs(kept[:, 31].mean() - 0.2) < 0.02 and abs(kept[:, 32].mean() - 0.8) < 0.02
    assert kept[:, :28].std() < sigma / 2  # and the noise is still filtered


def test_weights_are_normalised_at_the_borders_and_for_single_pixels():
    out = atrous_denoise(np.full((1, 1, 3), 0.3))
    np.testing.assert_allclose(out, 0.3)
    out = atrous_denoise(np.full((3, 50), 2.0), levels=8, variance=np.ones((3, 50)))
    np.testing.assert_allclose(out, 2.0)


def test_no_levels_is_the_identity():
    img = _noisy(0.0, (8, 8, 3))
    np.testing.assert_allclose(atrous_denoise(img, levels=0), img, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("kwargs, match", [
    (dict(normals=np.zeros((4, 4))), "normals"),
    (dict(normals=np.zeros((5, 4, 3))), "normals"),
    (dict(labels=np.zeros((4, 5), int)), "labels"),
    (dict(variance=np.zeros((4,))), "variance"),
    (dict(levels=-1), "levels"),
    (dict(sigma_luminance=0.0), "sigma_luminance"),
    (dict(sigma_normal=np.nan), "sigma_normal"),
])
def test_bad_arguments_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        atrous_denoise(np.zeros((4, 4, 3)), **kwargs)


def test_the_same_input_gives_the_same_output():
    img = _noisy(0.5, (32, 32, 3))
    var = np.full((32, 32), 0.01)
    assert np.array_equal(atrous_denoise(img, variance=var), atrous_denoise(img, variance=var))
