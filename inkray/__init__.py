"""inkray: depth maps and bas-relief meshes from hand-drawn line drawings.

Implements Sýkora et al., "Adding Depth to Cartoons Using Sparse Depth
(In)equalities" (CGF 2010) and "Ink-and-Ray: Bas-Relief Meshes for Adding
Global Illumination Effects to Hand-Drawn Characters" (TOG 2014), with
LazyBrush segmentation (Sýkora, Dingliana, Collins, CGF 2009).

The pipeline is one module per stage; this namespace re-exports the public
functions so that ``import inkray`` mirrors the command line.
"""

__version__ = "0.1.0"

from inkray.input.annotations import (Annotations, Boundary, Equal, Order, Region,  # noqa: E402
                          load_annotations, parse_annotations, rescale_annotations)
from inkray.input.drawing import Drawing, drawing_from_array, load_drawing  # noqa: E402
from inkray.depthmap.estimation import (DepthResult, DepthSession, depth, depth_constraints,  # noqa: E402
                    depth_png, normal_map, shaded_preview, write_depth_outputs)
from inkray.depthmap.quadratic_program import QPResult, constraint_cycle, edge_weights, grid_laplacian, solve_depth_qp  # noqa: E402
from inkray.formats.mesh_report import check_file, failed_requirements, mesh_quality, quality_report  # noqa: E402
from inkray.errors import InkrayError, InputError, StageError, StageMissing  # noqa: E402
from inkray.formats.meshes import (NamedMesh, export_relief, pixel_coordinates, read_meshes,  # noqa: E402
                     scene_coordinates)
from inkray.input.loading import load_input  # noqa: E402
from inkray.relief.inflation import (InflatedRegion, InflationSolver, apply_profile,  # noqa: E402
                      dirichlet_vertices, inflate_mesh, inflate_region)
from inkray.relief.outline import RegionOutline, check_boundaries, region_outline  # noqa: E402
from inkray.view.rasterization import Raster, fit_view, rasterize, vertex_normals  # noqa: E402
from inkray.view.rendering import (Rendering, has_mitsuba, output_size, read_relief, render,  # noqa: E402
                     render_turntable, write_renderings)
from inkray.input.scribbles import load_scribble_layer, seed_image  # noqa: E402
from inkray.relief.triangulation import RegionMesh, mesh_region, triangulate_outline  # noqa: E402
from inkray.segmentation import Segmentation, lazybrush, segment  # noqa: E402
from inkray.relief.completion import Completion, Place, complete_regions, continue_outline  # noqa: E402
from inkray.relief.ordering import Relation, depth_order, predict_place  # noqa: E402
from inkray.relief.stitching import Layers, stitch  # noqa: E402
from inkray.relief.assembly import assemble, close_part, union_parts  # noqa: E402
from inkray.relief.model import Part, Relief  # noqa: E402
from inkray.chain import ReliefResult, build_relief  # noqa: E402

__all__ = [
    "__version__",
    "Annotations", "Boundary", "Equal", "Order", "Region",
    "load_annotations", "parse_annotations", "rescale_annotations",
    "Drawing", "drawing_from_array", "load_drawing",
    "DepthResult", "DepthSession", "depth", "depth_constraints", "depth_png", "normal_map",
    "shaded_preview", "write_depth_outputs",
    "QPResult", "constraint_cycle", "edge_weights", "grid_laplacian", "solve_depth_qp",
    "InkrayError", "InputError", "StageError", "StageMissing",
    "NamedMesh", "export_relief", "pixel_coordinates", "read_meshes", "scene_coordinates",
    "check_file", "failed_requirements", "mesh_quality", "quality_report",
    "load_input", "load_scribble_layer", "seed_image",
    "RegionOutline", "region_outline", "check_boundaries",
    "RegionMesh", "triangulate_outline", "mesh_region",
    "InflatedRegion", "InflationSolver", "dirichlet_vertices", "apply_profile", "inflate_mesh",
    "inflate_region",
    "Segmentation", "lazybrush", "segment",
    "Completion", "Place", "complete_regions", "continue_outline",
    "Relation", "depth_order", "predict_place",
    "Raster", "fit_view", "rasterize", "vertex_normals",
    "Rendering", "has_mitsuba", "output_size", "read_relief", "render", "render_turntable",
    "write_renderings",
    "Layers", "stitch", "assemble", "close_part", "union_parts", "Part", "Relief",
    "ReliefResult", "build_relief",
]
