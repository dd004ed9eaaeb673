"""Stroke width and stroke ends of a drawing (inkray.relief.ink_style)."""

import numpy as np
import pytest

from inkray.relief.ink_style import InkStyle, ink_style


def _frame(width, *, gaps=0):
    """A rectangle outline of ``width`` px strokes; ``gaps`` breaks cut into its top side."""
    gray = np.ones((120, 160))
    gray[20:100, 30:130] = 0.0
    gray[20 + width:100 - width, 30 + width:130 - width] = 1.0
    for i in range(gaps):
        x = 45 + 12 * i
        gray[20:20 + width, x:x + 4] = 1.0
    return gray


@pytest.mark.parametrize("width", [3, 6, 12])
def test_a_clean_closed_outline_has_no_stroke_ends_and_its_width(width):
    style = ink_style(_frame(width))
    assert style.stroke_ends == 0.0
    assert abs(style.width - width) <= 1.5          # the distance counts to the paper pixel
    assert style.clarity(1.0) == 1.0


def test_gaps_in_an_outline_are_stroke_ends_and_lower_the_clarity():
    clean, gappy = ink_style(_frame(3)), ink_style(_frame(3, gaps=5))
    assert gappy.stroke_ends > 10 * max(clean.stroke_ends, 0.1)
    assert gappy.clarity(1.0) < 0.01 < gappy.clarity(100.0) < clean.clarity(100.0)


def test_a_blank_drawing_has_no_style():
    assert ink_style(np.ones((20, 30))) == InkStyle(width=0.0, stroke_ends=0.0)


def test_stroke_ends_read_the_same_at_twice_the_resolution():
    # counted per stroke width of ink, not per pixel: a larger scan of the same
    # sketchy drawing must not look cleaner
    gray = _frame(3, gaps=5)
    once, twice = ink_style(gray), ink_style(np.kron(gray, np.ones((2, 2))))
    assert twice.width >= 1.4 * once.width
    # per pixel the ratio would be 0.5 (same ends, twice the length); the width's
    # pixel rounding (4 and 6 px for 3 and 6 px strokes) keeps it off 1
    assert 0.7 <= twice.stroke_ends / once.stroke_ends <= 1.3
