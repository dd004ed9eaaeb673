"""Scenes of several annotated drawings: each one's chain, optionally posed, placed in one picture.

The front ends' view of a scene file (:mod:`inkray.input.scene`): every
drawing gets its own :class:`~inkray.chain.ReliefChain` (Sýkora et al.,
"Ink-and-Ray", TOG 2014), is posed when its entry names a pose
(:mod:`inkray.view.posed`), and the placed reliefs are drawn together by
:mod:`inkray.view.posed_scene`.
"""

from dataclasses import dataclass

from inkray.chain import ReliefChain
from inkray.errors import InputError
from inkray.input.loading import load_input
from inkray.input.pose import load_pose
from inkray.relief.cutout import cut_out
from inkray.view.posed import PosedDrawing
from inkray.view.posed_scene import Placed, scene_image, scene_layers, scene_relief

__all__ = ["Composition", "compose"]


@dataclass
class Composition:
    """A scene's drawings, ready: ``placed`` (list of Placed) on a canvas of ``size``."""

    placed: list
    size: tuple

    def image(self):
        """The scene as (H, W, 4) uint8 RGBA."""
        return scene_image(self.placed, self.size)

    def layers(self):
        """The scene's layers (:class:`~inkray.relief.cutout.Cutout`), back drawings first."""
        return scene_layers(self.placed, self.size)

    def relief(self):
        """The scene's relief, textured from an atlas (see :func:`scene_relief`)."""
        return scene_relief(self.placed, self.size)


def compose(scene, *, progress=None):
    """Build every drawing of ``scene`` and place it.

    Parameters
    ----------
    scene : inkray.input.scene.Scene
    progress : inkray.progress.Progress, optional

    Returns
    -------
    Composition

    Raises
    ------
    InputError
        A drawing's files are bad or it has no regions; the message starts
        with the entry's key path.
    """
    placed = []
    for p in scene.drawings:
        where = f"drawings[{p.index}]"
        try:
            ann, drawing = load_input(p.annotation)
            if not ann.regions:
                raise InputError("regions: a scene drawing needs at least one region")
            chain = ReliefChain(ann, drawing, progress=progress)
            relief = chain.relief
            if p.pose is None:
                posed, cutout = relief, cut_out(chain.completion, chain.relations, drawing)
            else:
                pose = load_pose(p.pose, size=ann.size)
                drawn = PosedDrawing(relief, chain.completion, chain.relations, drawing,
                                     pose.handles, boundaries=ann.boundaries)
                posed, cutout = drawn.relief(drawn.at(pose, p.frame)), drawn.cutout
        except InputError as e:
            raise InputError(f"{where}: {e}") from None
        placed.append(Placed(posed=posed, rest=relief, cutout=cutout, rgb=drawing.rgb,
                             at=p.at, rotate=p.rotate, scale=p.scale, depth=p.depth,
                             name=f"d{p.index}"))
    return Composition(placed=placed, size=scene.size)
