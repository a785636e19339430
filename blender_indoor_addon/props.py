"""Properties of the Indoor add-on (``scene.indoor``)."""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from ..engine.params import Params, params_table
from . import bridge

METHOD_ITEMS = (
    ("auto", "Auto", "Manhattan grammar when the walls are mostly orthogonal, else generic"),
    ("manhattan", "Manhattan", "Shape grammar for orthogonal walls (docs/method.md §2)"),
    ("generic", "Generic", "Cell decomposition and rjMCMC for any wall directions (docs/method.md §3)"),
)
"""Reconstruction methods (ids of ``engine.reconstruct.METHODS``)."""

UNITS_ITEMS = (
    ("auto", "Auto", "Detect mm, cm, inch or feet from the extent and the storey heights"),
    ("m", "Metres", ""), ("mm", "Millimetres", ""), ("cm", "Centimetres", ""),
    ("in", "Inches", ""), ("ft", "Feet", ""),
)
"""Units of a scan file (``--units`` of ``indoor convert``); the scan is rescaled to metres."""

UP_ITEMS = (
    ("auto", "Auto", "Detect y-up and upside-down scans from the floor and ceiling planes"),
    ("z", "Z", ""), ("-z", "-Z", ""), ("y", "Y", ""), ("-y", "-Y", ""), ("x", "X", ""), ("-x", "-X", ""),
)
"""Which axis of a scan file points up (``--up``); the scan is turned z up."""

EDIT_TYPE_ITEMS = (
    ("interior", "Space", "An interior space (room, corridor)"),
    ("wall", "Wall", "A wall (between spaces)"),
    ("exterior", "Exterior", "Outside the building"),
    ("none", "None", "Not part of the building"),
)
"""Types a shape can be reclassified to (engine.topology.reclassify)."""

POSITION_ITEMS = (
    ("CURSOR", "3D cursor", "The 3D cursor projected onto the wall's axis"),
    ("VALUE", "Value", "A distance along the wall from its start, metres"),
)
"""Where Insert door puts the door's centre."""

CHANGE_COLOR_ITEMS = (
    ("TYPE", "Existing / new", "Existing points grey, new points red"),
    ("DISTANCE", "Distance", "Distance to the model: blue 0 → yellow r → red ≥ 2 r"),
)
"""How a scan shows its change-detection result."""

ENGINE_PARAMS = (
    ("min_wall_area_manhattan", "manhattan.min_wall_area", "Min wall area (Manhattan)", "AREA"),
    ("min_wall_area_generic", "generic.cells.min_wall_area", "Min wall area (generic)", "AREA"),
    ("max_wall_thickness_manhattan", "manhattan.max_wall_thickness", "Max wall thickness (Manhattan)",
     "LENGTH"),
    ("max_wall_thickness_generic", "generic.search.max_wall_thickness", "Max wall thickness (generic)",
     "LENGTH"),
    ("working_voxel", "preprocess.clean.voxel_size", "Working voxel", "LENGTH"),
)
"""``(property, engine key, label, unit)`` of the parameters the add-on shows: each is the
engine's :class:`~engine.params.Params` key of that name (its default, its doc); the
``_manhattan`` / ``_generic`` ones apply to that method only."""
PARAM_METHOD = {"min_wall_area_manhattan": "manhattan", "min_wall_area_generic": "generic",
                "max_wall_thickness_manhattan": "manhattan", "max_wall_thickness_generic": "generic"}
"""The method a shown parameter belongs to (the others apply to both)."""

__all__ = ["INDOOR_PG_settings", "CLASSES", "METHOD_ITEMS", "UNITS_ITEMS", "UP_ITEMS", "EDIT_TYPE_ITEMS",
           "POSITION_ITEMS", "CHANGE_COLOR_ITEMS", "ENGINE_PARAMS", "PARAM_METHOD", "engine_param_property",
           "engine_param_properties"]


def engine_param_property(key: str, name: str, unit: str):
    """A FloatProperty whose default and description are the engine parameter ``key``'s.

    ``unit`` is Blender's ("LENGTH", metres, or "AREA", square metres), the engine's SI unit.
    """
    row = next((r for r in params_table(Params()) if r.key == key), None)
    if row is None or not isinstance(row.value, float):
        raise KeyError(f"the engine has no number parameter {key!r}")
    kw = {"subtype": "DISTANCE"} if unit == "LENGTH" else {}
    return FloatProperty(name=name, default=row.value, min=0.0, unit=unit, precision=3,
                         description=f"{row.doc} (engine parameter {key})", **kw)


def engine_param_properties() -> dict:
    """``{property name: FloatProperty}`` for every entry of :data:`ENGINE_PARAMS`."""
    return {prop: engine_param_property(key, label, unit) for prop, key, label, unit in ENGINE_PARAMS}


def _update_change_colors(self, context):
    """Switch every scan that has change colours to the chosen colouring."""
    for obj in bridge.changed_scans():
        bridge.set_change_colors(obj, self.change_color_mode)


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
    use_custom_params: BoolProperty(name="Set parameters", default=False,
                                    description="Override key parameters (else the loaded parameter file's "
                                                "or the engine's defaults, data-dependent ones chosen from "
                                                "the scan)")
    __annotations__.update(engine_param_properties())
    params_toml: StringProperty(name="Parameters", default="", options={"HIDDEN"},
                                description="TOML of the parameters loaded by Load parameters (empty: the "
                                            "engine's defaults)")
    params_file: StringProperty(name="Parameter file", default="", subtype="FILE_PATH",
                                description="The file Load parameters read (shown only)")

    # Review and fix
    edit_type: EnumProperty(name="New type", items=EDIT_TYPE_ITEMS, default="interior",
                            description="Type given to the selected shapes by Reclassify")
    door_width: FloatProperty(name="Width", default=0.9, min=0.1, soft_max=3.0, subtype="DISTANCE",
                              unit="LENGTH", description="Door width, metres")
    door_height: FloatProperty(name="Height", default=2.1, min=0.1, soft_max=3.0, subtype="DISTANCE",
                               unit="LENGTH", description="Door height, metres")
    door_position_mode: EnumProperty(name="Position", items=POSITION_ITEMS, default="CURSOR",
                                     description="Where the door's centre goes")
    door_position: FloatProperty(name="Along wall", default=1.0, min=0.0, subtype="DISTANCE",
                                 unit="LENGTH", description="Door centre from the wall's start, metres")
    door_snap: FloatProperty(name="Snap to opening", default=0.5, min=0.0, soft_max=2.0, subtype="DISTANCE",
                             unit="LENGTH",
                             description="Insert door takes the place and size of a detected doorless "
                                         "opening of the wall within this distance along the wall, metres "
                                         "(0: never)")
    # Topology (cached results: the panel only reads them)
    path_text: StringProperty(name="Path", default="",
                              description="Room sequence of the last shortest path")
    path_length: FloatProperty(name="Length", default=0.0, subtype="DISTANCE", unit="LENGTH",
                               description="Length of the last shortest path (centre to centre), metres")
    # Changes / Evaluate (JSON summaries written by the operators)
    change_color_mode: EnumProperty(name="Colour", items=CHANGE_COLOR_ITEMS, default="TYPE",
                                    description="How the scan shows the change detection",
                                    update=_update_change_colors)
    change_summary: StringProperty(name="Change summary", default="",
                                   description="JSON summary of the last change detection")
    eval_summary: StringProperty(name="Evaluation summary", default="",
                                 description="JSON summary of the last evaluation")
    # Reconstruct: progress of a modal run
    running: BoolProperty(name="Running", default=False, description="A reconstruction is running")
    progress: FloatProperty(name="Progress", default=0.0, min=0.0, max=1.0, subtype="FACTOR",
                            description="Progress of the running reconstruction")
    progress_text: StringProperty(name="Stage", default="", description="Stage of the running reconstruction")


CLASSES = (INDOOR_PG_settings,)
