"""Preprocessing and space partitioning (SPEC.md §1 and §3.1).

Cleaning and normals (:mod:`.cleaning`), Manhattan alignment (:mod:`.alignment`), storeys
(:mod:`.storeys`), point clusters (:mod:`.classify`), multi-scale RANSAC planes
(:mod:`.planes`) and the cell decomposition (:mod:`.cells`).
"""
from .alignment import AlignmentResult, align_manhattan, axial_kmeans, manhattan_residual
from .classify import CLASS_HORIZONTAL, CLASS_OTHER, CLASS_WALL, classify_points
from .cleaning import clean, drop_nonfinite, estimate_normals, remove_statistical_outliers, voxel_downsample
from .params import (AlignParams, CellParams, ClassifyParams, CleanParams, NormalParams, PlaneParams,
                     PreprocessParams, StoreyParams)
from .storeys import Layer, detect_layers, detect_storeys
from .planes import Plane, extract_planes
from .cells import (Cell, CellComplex, CellFace, ceiling_levels, decompose_cells, is_structural_wall,
                    wall_segments)
from .pipeline import Preprocessed, preprocess

__all__ = [
    "AlignmentResult", "align_manhattan", "axial_kmeans", "manhattan_residual",
    "CLASS_HORIZONTAL", "CLASS_OTHER", "CLASS_WALL", "classify_points",
    "clean", "drop_nonfinite", "estimate_normals", "remove_statistical_outliers", "voxel_downsample",
    "AlignParams", "CellParams", "ClassifyParams", "CleanParams", "NormalParams", "PlaneParams",
    "PreprocessParams", "StoreyParams",
    "Layer", "detect_layers", "detect_storeys",
    "Plane", "extract_planes",
    "Cell", "CellComplex", "CellFace", "ceiling_levels", "decompose_cells", "is_structural_wall", "wall_segments",
    "Preprocessed", "preprocess",
]
