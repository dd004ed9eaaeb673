import numpy as np

from inkray.numerics.quantization import dequantize16, quantize16


def test_round_trip_within_half_a_step():
    rng = np.random.default_rng(3)
    v = rng.standard_normal((30, 20)) * 50
    mask = rng.random(v.shape) > 0.3
    codes, (lo, hi) = quantize16(v, mask)
    assert codes[~mask].max() == 0 and codes[mask].min() == 1 and codes[mask].max() == 65535
    back = dequantize16(codes, (lo, hi))
    assert np.isnan(back[~mask]).all()
    assert np.abs(back[mask] - v[mask]).max() <= (hi - lo) / 65534 / 2 + 1e-9


def test_constant_values_are_all_top_and_empty_mask_is_all_zero():
    codes, (lo, hi) = quantize16(np.full((3, 3), 2.5))
    assert (codes == 65535).all() and lo == hi == 2.5
    codes, r = quantize16(np.ones(4), np.zeros(4, bool))
    assert (codes == 0).all() and r == (0.0, 0.0)
