"""The whole Ink-and-Ray chain, stage after stage (Sýkora et al., TOG 2014):
segmentation -> completion and depth order -> meshes and inflation ->
stitching -> assembly. Each stage is its own module; this one only passes
their dataclasses along and times them.
"""

from dataclasses import dataclass, field

from inkray.relief.assembly import assemble
from inkray.relief.completion import complete_regions
from inkray.errors import InputError
from inkray.relief.inflation import inflate_region
from inkray.relief.ordering import depth_order
from inkray.relief.outline import DEFAULT_MAX_AREA, check_boundaries
from inkray.progress import Progress
from inkray.segmentation import segment
from inkray.relief.stitching import stitch

__all__ = ["ReliefResult", "build_relief"]


@dataclass
class ReliefResult:
    """What :func:`build_relief` produced, with everything needed to inspect it.

    Attributes
    ----------
    relief : inkray.relief.model.Relief
    segmentation : inkray.segmentation.Segmentation
    completion : inkray.relief.completion.Completion
        After the depth order (only hidden parts under a region in front).
    relations : list of inkray.relief.ordering.Relation
    layers : inkray.relief.stitching.Layers
    warnings : list of str
    timings : list of (str, float)
        Seconds per stage.
    """

    relief: object
    segmentation: object
    completion: object
    relations: list
    layers: object
    warnings: list = field(default_factory=list)
    timings: list = field(default_factory=list)


def build_relief(annotations, drawing, *, predict=True, max_area=DEFAULT_MAX_AREA, epsilon=None,
                 closed=False, union=False, progress=None):
    """Build the bas-relief of an annotated drawing.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations
    drawing : inkray.input.drawing.Drawing
    predict : bool, default True
        Predict the depth order where the user's entries are silent.
    max_area : float, default 50
        Largest triangle area in px^2 (the mesh resolution).
    epsilon : float, optional
        Depth step between a part and the part behind it (px); default 0.4 %
        of the drawing's longer side.
    closed : bool, default False
        Closed solids (mirrored backs) instead of front surfaces.
    union : bool, default False
        With ``closed``: one watertight solid.
    progress : inkray.progress.Progress, optional

    Returns
    -------
    ReliefResult

    Raises
    ------
    InputError
        Bad annotations (no regions, boundaries far from any outline,
        contradictory order).
    StageError
        A stage failed on valid input.
    """
    if not annotations.regions:
        raise InputError("regions: a relief needs at least one region")
    if union and not closed:
        raise InputError("--union needs --closed (the union of open surfaces is not a solid)")
    progress = progress if progress is not None else Progress(quiet=True)
    warnings = []
    with progress.stage("segment"):
        seg = segment(annotations, drawing, progress=progress)
        warnings += seg.warnings
    with progress.stage("complete"):
        completion = complete_regions(seg.labels, names=seg.names, progress=progress)
    with progress.stage("order"):
        relations, more = depth_order(annotations, seg.labels, completion, predict=predict)
        warnings += more
        completion = completion.ordered(relations)
    with progress.stage("inflate"):
        inflated = []
        for i, region in enumerate(annotations.regions):
            progress.update(i, len(annotations.regions))
            mask = completion.completed(i)
            if not mask.any():
                warnings.append(f"region {region.name!r}: no pixels after segmentation; left out")
                inflated.append(None)
                continue
            inflated.append(inflate_region(
                mask, visible=completion.visible(i), labels=seg.labels, region=i, name=region.name,
                boundaries=annotations.boundaries, inflation=region.inflation,
                profile=region.profile, max_area=max_area))
        check_boundaries([r.mesh for r in inflated if r is not None], annotations.boundaries)
    with progress.stage("stitch"):
        layers = stitch(inflated, relations, completion, annotations=annotations, epsilon=epsilon,
                        progress=progress)
    with progress.stage("assemble"):
        relief = assemble(layers, size=annotations.size, texture=drawing.rgb, closed=closed,
                          union=union)
    return ReliefResult(relief=relief, segmentation=seg, completion=completion,
                        relations=relations, layers=layers, warnings=warnings,
                        timings=list(progress.timings))

