"""inkray: depth maps and bas-relief meshes from hand-drawn line drawings.

Implements Sýkora et al., "Adding Depth to Cartoons Using Sparse Depth
(In)equalities" (CGF 2010) and "Ink-and-Ray: Bas-Relief Meshes for Adding
Global Illumination Effects to Hand-Drawn Characters" (TOG 2014), with
LazyBrush segmentation (Sýkora, Dingliana, Collins, CGF 2009).

The namespace is small: the input, the resumable chain, the depth map, the
relief's files and renders, and the records between them. Everything else
lives in its module (``inkray.segmentation``, ``inkray.relief.stitching``,
...). Names load on first use, so ``import inkray`` stays quick.

Examples
--------
>>> import inkray
>>> from inkray.examples import example_path
>>> ann, drawing = inkray.load_input(example_path("turtle"))
>>> chain = inkray.ReliefChain(ann, drawing)
>>> [r.name for r in ann.regions][:2]
['head', 'leg_front']
"""

from importlib import import_module

from inkray._version import __version__

_NAMES = {
    "load_input": "inkray.input.loading",
    "Annotations": "inkray.input.annotations",
    "parse_annotations": "inkray.input.annotations",
    "Drawing": "inkray.input.drawing",
    "ReliefChain": "inkray.chain",
    "ChainOptions": "inkray.chain",
    "build_relief": "inkray.chain",
    "ReliefResult": "inkray.chain",
    "Segmentation": "inkray.segmentation",
    "segment": "inkray.segmentation",
    "depth": "inkray.depthmap.estimation",
    "DepthSession": "inkray.depthmap.estimation",
    "DepthResult": "inkray.depthmap.estimation",
    "Relation": "inkray.relief.ordering",
    "Relief": "inkray.relief.model",
    "Part": "inkray.relief.model",
    "render": "inkray.view.rendering",
    "Rendering": "inkray.view.rendering",
    "export_relief": "inkray.formats.meshes",
    "read_relief": "inkray.formats.meshes",
    "Progress": "inkray.progress",
    "InkrayError": "inkray.errors",
    "InputError": "inkray.errors",
    "StageError": "inkray.errors",
}

__all__ = ["__version__", *_NAMES]


def __getattr__(name):
    module = _NAMES.get(name)
    if module is None:
        raise AttributeError(f"module 'inkray' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_NAMES))
