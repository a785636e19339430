"""Review and fix (Reclassify, Insert door, Revert last edit) and Topology (graphs, shortest path).

On a model with building elements (wall runs, openings, slabs, storey exteriors) the edits go
through :mod:`.elements`: Reclassify rebuilds the walls, slabs and exteriors and keeps the
openings in their walls; Insert door puts a door in a wall run and snaps it to a detected
doorless opening nearby. Other models (older files, reference models) use the bare rules.
"""
from __future__ import annotations

import bpy
from bpy.props import EnumProperty, FloatProperty, StringProperty

from ...engine.topology import describe_path, insert_door, reclassify, shortest_path
from .. import bridge
from ..props import EDIT_TYPE_ITEMS, POSITION_ITEMS
from .common import has_model, show_model_change, stored_or_report
from ...engine.topology.elements import (SNAP_DISTANCE, has_elements, insert_wall_door, made_by_elements,
                       reclassify_with_elements)
from .engine_call import engine_call

__all__ = ["INDOOR_OT_reclassify", "INDOOR_OT_insert_door", "INDOOR_OT_revert_edit", "INDOOR_OT_show_graph",
           "INDOOR_OT_shortest_path"]


class INDOOR_OT_reclassify(bpy.types.Operator):
    """Give the selected shapes a new type; merges, walls, doors and topology are re-derived"""

    bl_idname = "indoor.reclassify"
    bl_label = "Reclassify"
    bl_options = {"REGISTER", "UNDO"}

    type: EnumProperty(name="New type", items=EDIT_TYPE_ITEMS, default="interior")
    shape_ids: StringProperty(name="Shape ids", default="", options={"SKIP_SAVE"},
                              description="Comma-separated shape ids (default: the selected objects)")

    @classmethod
    def poll(cls, context):
        return has_model(context) and any(bridge.SHAPE_PROP in o for o in context.selected_objects)

    def invoke(self, context, event):
        settings = getattr(context.scene, "indoor", None)
        if settings is not None and not self.properties.is_property_set("type"):
            self.type = settings.edit_type
        return self.execute(context)

    def execute(self, context):
        model = stored_or_report(self, context)
        if model is None:
            return {"CANCELLED"}
        ids = [i.strip() for i in self.shape_ids.split(",") if i.strip()] or \
            bridge.shape_ids_of(context.selected_objects)
        if not ids:
            self.report({"ERROR"}, "select shapes of the model (spaces, walls, exterior)")
            return {"CANCELLED"}
        dropped = ()
        with engine_call(self, context, progress_bar=False) as call:
            if has_elements(model):  # walls, slabs, exteriors rebuilt; openings kept in their walls
                result = reclassify_with_elements(model, ids, self.type)
                new, dropped = result.model, result.dropped
            else:
                new = reclassify(model, ids, self.type)
            bridge.apply_edit(model, new, scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        show_model_change(self, context, new)
        text = (f"Reclassified {len(ids)} shape(s) as {self.type}: {len(new.spaces)} spaces, "
                f"{len(new.walls)} walls, {len(new.doors)} doors, {len(new.windows)} windows")
        if dropped:
            self.report({"WARNING"}, f"{text}; {len(dropped)} opening(s) lie in no wall any more and were "
                                     f"removed: {', '.join(model[i].name or i for i in dropped)}")
        else:
            self.report({"INFO"}, text)
        return {"FINISHED"}


class INDOOR_OT_insert_door(bpy.types.Operator):
    """Insert a door in the active wall, at the 3D cursor or at a distance along the wall; near a
    detected doorless opening it takes that opening's place and size"""

    bl_idname = "indoor.insert_door"
    bl_label = "Insert Door"
    bl_options = {"REGISTER", "UNDO"}

    width: FloatProperty(name="Width", default=0.9, min=0.1, subtype="DISTANCE", unit="LENGTH")
    height: FloatProperty(name="Height", default=2.1, min=0.1, subtype="DISTANCE", unit="LENGTH")
    position_mode: EnumProperty(name="Position", items=POSITION_ITEMS, default="CURSOR")
    position: FloatProperty(name="Along wall", default=1.0, min=0.0, subtype="DISTANCE", unit="LENGTH",
                            description="Door centre from the wall's start, metres (Position = Value)")
    snap_distance: FloatProperty(name="Snap to opening", default=SNAP_DISTANCE, min=0.0, soft_max=2.0,
                                 subtype="DISTANCE", unit="LENGTH",
                                 description="A detected doorless opening of the wall within this "
                                             "distance (along the wall, metres) becomes the door, with its "
                                             "position and size; 0 never snaps")
    wall_id: StringProperty(name="Wall id", default="", options={"SKIP_SAVE"},
                            description="Id of the wall (default: the active object)")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return has_model(context) and obj is not None and obj.get("indoor_type") == "wall"

    def invoke(self, context, event):
        settings = getattr(context.scene, "indoor", None)
        if settings is not None:
            for mine, theirs in (("width", "door_width"), ("height", "door_height"),
                                 ("position_mode", "door_position_mode"), ("position", "door_position"),
                                 ("snap_distance", "door_snap")):
                if not self.properties.is_property_set(mine):
                    setattr(self, mine, getattr(settings, theirs))
        return self.execute(context)

    def execute(self, context):
        model = stored_or_report(self, context)
        if model is None:
            return {"CANCELLED"}
        obj = context.active_object
        wall_id = self.wall_id or (str(obj[bridge.SHAPE_PROP]) if obj is not None and bridge.SHAPE_PROP in obj
                                   else "")
        if not wall_id:
            self.report({"ERROR"}, "select a wall of the model")
            return {"CANCELLED"}
        if self.position_mode == "CURSOR":
            position = bridge.to_model_frame(model, context.scene.cursor.location)
        else:
            position = float(self.position)
        wall = model.get(wall_id)
        result = None
        with engine_call(self, context, progress_bar=False) as call:
            if wall is not None and made_by_elements(wall) and "axis_line" in wall.attributes:
                result = insert_wall_door(model, wall_id, position=position, width=self.width,
                                          height=self.height, snap=self.snap_distance)
                new = result.model
            else:
                new = insert_door(model, wall_id, position=position, width=self.width, height=self.height)
            bridge.apply_edit(model, new, scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        show_model_change(self, context, new)
        door = new[result.door_id] if result is not None else next(s for s in new.doors if s.id not in model)
        a = door.attributes
        text = (f"Inserted {door.name} ({a['width']:.2f} x {a['height']:.2f} m) in "
                f"{wall.name if wall is not None and wall.name else wall_id} at {a['position']:.2f} m")
        if result is not None and result.snapped is not None:
            text += f", snapped to {result.snapped_name} ({result.snap_distance:.2f} m away)"
        self.report({"INFO"}, text)
        return {"FINISHED"}


class INDOOR_OT_revert_edit(bpy.types.Operator):
    """Go back to the model before the last Reclassify / Insert door (kept in the .blend)"""

    bl_idname = "indoor.revert_edit"
    bl_label = "Revert Last Edit"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return bpy.data.texts.get(bridge.HISTORY_TEXT) is not None and bridge.history_length() > 0

    def execute(self, context):
        with engine_call(self, context, progress_bar=False) as call:
            model = bridge.restore_previous(scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        if model is None:
            self.report({"ERROR"}, "no earlier model to go back to")
            return {"CANCELLED"}
        show_model_change(self, context, model)
        self.report({"INFO"}, f"Restored the previous model ({len(model.spaces)} spaces, "
                              f"{len(model.doors)} doors)")
        return {"FINISHED"}


# --------------------------------------------------------------------------- Topology
class INDOOR_OT_show_graph(bpy.types.Operator):
    """Draw or hide the adjacency / connectivity graph: curves between the centres of spaces"""

    bl_idname = "indoor.show_graph"
    bl_label = "Show Graph"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(name="Graph", items=(("adjacency", "Adjacency", "Spaces sharing a wall"),
                                            ("connectivity", "Connectivity", "Spaces joined by a door")))
    show: EnumProperty(name="Show", items=(("TOGGLE", "Toggle", ""), ("ON", "On", ""), ("OFF", "Off", "")),
                       default="TOGGLE")

    @classmethod
    def poll(cls, context):
        return has_model(context)

    def execute(self, context):
        on = (not bridge.graph_shown(self.kind)) if self.show == "TOGGLE" else self.show == "ON"
        if not on:
            bridge.remove_graph(self.kind)
            return {"FINISHED"}
        model = stored_or_report(self, context)
        if model is None:
            return {"CANCELLED"}
        with engine_call(self, context, progress_bar=False) as call:
            obj = bridge.graph_to_curve(model, self.kind, scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        self.report({"INFO"}, f"{self.kind.capitalize()} graph: {len(obj['indoor_edges'])} edges")
        return {"FINISHED"}


class INDOOR_OT_shortest_path(bpy.types.Operator):
    """Shortest walk between the two selected spaces (through doors), drawn as a curve"""

    bl_idname = "indoor.shortest_path"
    bl_label = "Shortest Path"
    bl_options = {"REGISTER", "UNDO"}

    start: StringProperty(name="From", default="", options={"SKIP_SAVE"},
                          description="Space id or name (default: the selected space that is not active)")
    end: StringProperty(name="To", default="", options={"SKIP_SAVE"},
                        description="Space id or name (default: the active space)")

    @classmethod
    def poll(cls, context):
        return has_model(context)

    def _ends(self, context):
        if self.start and self.end:
            return self.start, self.end
        spaces = [o for o in context.selected_objects
                  if o.get("indoor_type") == "interior" and bridge.SHAPE_PROP in o]
        if len(spaces) != 2:
            return None
        active = context.active_object
        spaces.sort(key=lambda o: o == active)  # the active one last
        return tuple(str(o[bridge.SHAPE_PROP]) for o in spaces)

    def execute(self, context):
        model = stored_or_report(self, context)
        if model is None:
            return {"CANCELLED"}
        ends = self._ends(context)
        if ends is None:
            self.report({"ERROR"}, "select exactly two spaces")
            return {"CANCELLED"}
        settings = getattr(context.scene, "indoor", None)
        try:
            path = shortest_path(model, *ends)
        except KeyError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if path is None:
            show_model_change(self, context, model)  # drops a previous path
            text = f"{ends[1]} cannot be reached from {ends[0]}"
            if settings is not None:
                settings.path_text, settings.path_length = text, 0.0
            self.report({"WARNING"}, text)
            return {"FINISHED"}
        with engine_call(self, context, progress_bar=False) as call:
            text = describe_path(model, path)
            bridge.path_to_curve(model, path, scene=context.scene)
        if call.failed:
            return {"CANCELLED"}
        if settings is not None:
            settings.path_text, settings.path_length = text, path.length
        self.report({"INFO"}, f"{text} ({path.length:.1f} m)")
        return {"FINISHED"}
