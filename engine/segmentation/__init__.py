"""Preprocessing steps (docs/method.md §1).

Steps (each takes a frozen parameters dataclass from :mod:`.params` and, where the work is
long, ``progress``/``should_stop``):

* :func:`normalize_frame` — before everything: degenerate clouds refused
  (:func:`check_degenerate`), the up axis (:func:`detect_up`) and the units
  (:func:`detect_units`) detected or given, the cloud brought to metres with z up;
* :func:`clean` — non-finite rows, voxel downsampling to a *working cloud* (representative
  input points, so attributes and truth fields survive; the voxel grows so the working
  cloud stays ≤ ``max_working_points``), statistical outliers;
* :func:`estimate_normals` — PCA normals (open3d), facing the scanner when known;
* :func:`align_manhattan` — axial k-means of the normals + refinement → rotation and the
  4×4 aligned → input transform;
* :func:`detect_storeys` — floors and ceilings from horizontal layers (area and
  above/below contrast rule out furniture);
* :func:`classify_points` — wall / floor-ceiling / other by the normal (θ = 10°);
* :func:`extract_planes` — local RANSAC in 4 m tiles with orientation, normal and fill
  constraints, then global merging until nothing merges;
The one preprocessing stage that runs these in order, for both methods, is
:func:`engine.pipeline.preprocess`; the cells of the generic method are
:func:`engine.grammar.generic.storey_cells`.

Departures from the thesis (docs/method.md §1, §3.1; details in each module's docstring):
alignment refines the k-means directions (vertical from floors *and* walls; yaw from the 4φ
circular mean); storeys use layer area and wall contrast, not the raw histogram peaks;
planes are exactly vertical/horizontal in the aligned frame, merge below 4° (not θ = 10°:
walls meeting at a few degrees exist), use the median support distance and reject merges
that do not fit; the inlier band follows the floor's measured noise; a plane's area is
counted on a 10 cm grid instead of an alpha shape.
"""
from .alignment import AlignmentResult, align_manhattan, axial_kmeans, manhattan_residual
from .classify import CLASS_HORIZONTAL, CLASS_OTHER, CLASS_WALL, classify_points
from .cleaning import clean, drop_nonfinite, estimate_normals, remove_statistical_outliers, voxel_downsample
from .params import (AlignParams, ClassifyParams, CleanParams, NormalParams, PlaneParams, PreprocessParams,
                     StoreyParams)
from .storeys import Layer, detect_layers, detect_storeys
from .frame import (UNITS, UP_AXES, FrameParams, UnitGuess, UpGuess, check_degenerate, detect_units,
                    detect_up, normalize_frame, up_rotation)
from .planes import Plane, extract_planes

__all__ = [
    "AlignmentResult", "align_manhattan", "axial_kmeans", "manhattan_residual",
    "CLASS_HORIZONTAL", "CLASS_OTHER", "CLASS_WALL", "classify_points",
    "clean", "drop_nonfinite", "estimate_normals", "remove_statistical_outliers", "voxel_downsample",
    "AlignParams", "ClassifyParams", "CleanParams", "NormalParams", "PlaneParams",
    "PreprocessParams", "StoreyParams",
    "Layer", "detect_layers", "detect_storeys",
    "UNITS", "UP_AXES", "FrameParams", "UnitGuess", "UpGuess", "check_degenerate", "detect_units",
    "detect_up", "normalize_frame", "up_rotation",
    "Plane", "extract_planes",
]
