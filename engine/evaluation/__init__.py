"""Quality evaluation of indoor models against a reference (docs/method.md §4).

:func:`evaluate` gives completeness, correctness and accuracy curves over buffer sizes
b = r (1–10 cm by default), per semantic group (wall / floor / ceiling) and overall, and
localises missing reference surfaces and redundant source surfaces.
:func:`annotate_visibility` marks reference surfaces visible/interpreted from a scan
(point-on-face index). :func:`evaluate_elements` scores building elements (doors, windows,
exterior walls, slabs, rooms, wall runs, the door graph) against a true model.
:func:`load_model` reads JSON, IFC and OBJ/PLY models;
:func:`write_evaluation_outputs` writes JSON, CSV, a PNG plot and coloured PLY files.
"""
from .coverage import PatchSupport, alpha_area, patch_support
from .elements import ElementMatchParams, evaluate_elements, exterior_outline, true_wall_runs
from .loading import MODEL_EXTENSIONS, load_model, mesh_to_model
from .metrics import DEFAULT_BUFFERS, GROUPS, EvaluationParams, EvaluationResult, evaluate
from .patches import PlanarPatch, patches_from_model
from .report import write_evaluation_outputs, write_ply_arrays
from .visibility import VisibilityParams, annotate_visibility

__all__ = [
    "evaluate", "EvaluationParams", "EvaluationResult", "DEFAULT_BUFFERS", "GROUPS",
    "annotate_visibility", "VisibilityParams", "load_model", "mesh_to_model", "MODEL_EXTENSIONS",
    "PlanarPatch", "patches_from_model", "alpha_area", "patch_support", "PatchSupport",
    "write_evaluation_outputs", "write_ply_arrays",
    "evaluate_elements", "ElementMatchParams", "true_wall_runs", "exterior_outline",
]
