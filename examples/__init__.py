"""Bundled example drawings with their annotation files (installed as ``inkray.examples``).

The drawings are by other people; see ``SOURCES.md`` beside this file.
"""

from pathlib import Path

from inkray.errors import InputError

__all__ = ["EXAMPLES", "example_path"]

_HERE = Path(__file__).resolve().parent
EXAMPLES = ("turtle", "frog", "balls", "donkey", "dragon", "fox", "gingerbread", "man", "rings", "figure", "cat",
            "bird", "fish", "cards", "snowman")


def example_path(name="turtle"):
    """Path of a bundled example's annotation file.

    Parameters
    ----------
    name : str, default "turtle"
        One of :data:`EXAMPLES`.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> example_path("frog").name
    'drawing.inkray.json'
    """
    if name not in EXAMPLES:
        raise InputError(f"--example {name}: no such bundled example (choose from {', '.join(EXAMPLES)})")
    return _HERE / name / "drawing.inkray.json"
