"""Properties of the Indoor add-on (``scene.indoor``)."""
from __future__ import annotations

import bpy
from bpy.props import FloatProperty, IntProperty

__all__ = ["INDOOR_PG_settings", "CLASSES"]


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


CLASSES = (INDOOR_PG_settings,)
