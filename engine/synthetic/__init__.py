"""Synthetic buildings with known truth and a scan simulator.

``preset(name, seed=..., noise="tls"|"mobile"|σ, target_points=...)`` gives a
:class:`SyntheticScene`: a simulated scan (PointCloud with a per-point truth ``label``),
the true :class:`~engine.model.BuildingModel`, the floor plan and model variants. Plans can
also be written by hand (:class:`FloorPlan`, :class:`Room`, :class:`Door`,
:class:`PlanStorey`) and turned into a true model (:func:`build_truth`) and a scan
(:func:`simulate_scan`).
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
    build_truth,
    door_footprint,
    plan_geometry,
    rooms_from_partition,
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
    LABEL_FLOOR,
    LABEL_NAMES,
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
    "Room", "Door", "PlanStorey", "Clutter", "FloorPlan", "WallPiece", "PlanGeometry",
    "rooms_from_partition", "plan_geometry", "build_truth", "door_footprint",
    "FurnishParams", "furnish",
    "LABEL_WALL", "LABEL_FLOOR", "LABEL_CEILING", "LABEL_CLUTTER", "LABEL_NAMES",
    "ScanParams", "ScanResult", "SceneMesh", "build_scene_mesh", "scanner_positions", "simulate_scan", "scan_mesh",
]
