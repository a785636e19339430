"""Synthetic buildings with known truth and a scan simulator.

``preset(name, seed=..., noise="tls"|"mobile"|σ, target_points=...)`` gives a
:class:`SyntheticScene`: a simulated scan (PointCloud with a per-point truth ``label``),
the true :class:`~engine.model.BuildingModel`, the floor plan and model variants. Plans can
also be written by hand (:class:`FloorPlan`, :class:`Room`, :class:`Door`,
:class:`Window`, :class:`PlanStorey`) and turned into a true model (:func:`build_truth`) and a scan
(:func:`simulate_scan`). Scenes from IFC models: :func:`ifc_scene` (:mod:`.ifcscene`).
"""
from .furnish import FurnishParams, furnish
from .plan import (
    Clutter,
    Door,
    FloorPlan,
    PlanGeometry,
    PlanStorey,
    Room,
    WallPiece,
    Window,
    build_truth,
    door_footprint,
    exterior_stretches,
    plan_geometry,
    rooms_from_partition,
    window_footprint,
)
from .presets import (
    DEFAULT_POINTS,
    NOISE_SIGMA,
    PRESETS,
    SyntheticScene,
    preset,
    preset_plans,
    scan_params_for,
    scene_from_plans,
)
from .scan import (
    LABEL_CEILING,
    LABEL_CLUTTER,
    LABEL_DOOR,
    LABEL_FLOOR,
    LABEL_GLASS,
    LABEL_NAMES,
    LABEL_OUTSIDE,
    LABEL_WALL,
    ScanParams,
    ScanResult,
    SceneMesh,
    build_scene_mesh,
    scanner_positions,
    scan_mesh,
    simulate_scan,
)

__all__ = [
    "preset", "preset_plans", "scene_from_plans", "scan_params_for", "PRESETS", "NOISE_SIGMA", "DEFAULT_POINTS", "SyntheticScene",
    "Room", "Door", "Window", "PlanStorey", "Clutter", "FloorPlan", "WallPiece", "PlanGeometry",
    "rooms_from_partition", "plan_geometry", "build_truth", "door_footprint", "window_footprint",
    "exterior_stretches",
    "FurnishParams", "furnish",
    "LABEL_WALL", "LABEL_FLOOR", "LABEL_CEILING", "LABEL_CLUTTER", "LABEL_OUTSIDE", "LABEL_GLASS", "LABEL_DOOR",
    "LABEL_NAMES",
    "ScanParams", "ScanResult", "SceneMesh", "build_scene_mesh", "scanner_positions", "simulate_scan", "scan_mesh",
]

_IFC_SCENE_NAMES = ("IFC_SCENES", "IfcSceneParams", "IfcScene", "IfcGeometry", "IfcElementMesh", "IfcSpaceArea",
                    "ifc_scene", "ifc_scene_path", "ifc_geometry", "ifc_scene_mesh", "ifc_scanner_positions",
                    "ifc_truth", "ifc_door_states")
__all__ += list(_IFC_SCENE_NAMES)


def __getattr__(name):  # the scenes from IFC files load the IFC reader only when asked for
    if name in _IFC_SCENE_NAMES:
        from . import ifcscene
        return getattr(ifcscene, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
