"""Properties of the Indoor add-on (``scene.indoor``)."""
from __future__ import annotations

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty

METHOD_ITEMS = (
    ("auto", "Auto", "Manhattan grammar when the walls are mostly orthogonal, else generic"),
    ("manhattan", "Manhattan", "Shape grammar for orthogonal walls (SPEC.md §2)"),
    ("generic", "Generic", "Cell decomposition and rjMCMC for any wall directions (SPEC.md §3)"),
)
"""Reconstruction methods (ids of ``engine.reconstruct.METHODS``)."""

__all__ = ["INDOOR_PG_settings", "CLASSES", "METHOD_ITEMS"]


class INDOOR_PG_settings(bpy.types.PropertyGroup):
    """Scene-wide settings of the Indoor add-on (defaults for new imports)."""

    display_ratio: FloatProperty(
        name="Display ratio",
        description="Share of the points drawn for new scans (the data keeps every point)",
        default=1.0, min=0.0, max=1.0, subtype="FACTOR",
    )
    point_radius: FloatProperty(
        name="Point radius",
        description="Radius of each drawn point of new scans",
        default=0.01, min=0.0, soft_max=0.1, subtype="DISTANCE", unit="LENGTH", precision=4,
    )
    seed: IntProperty(
        name="Seed",
        description="Seed of the random display subset",
        default=0, min=0,
    )
    method: EnumProperty(name="Method", items=METHOD_ITEMS, default="auto",
                         description="Reconstruction method")
    reconstruct_seed: IntProperty(name="Seed", default=0, min=0,
                                  description="Seed of the reconstruction (same seed, same model)")


CLASSES = (INDOOR_PG_settings,)
