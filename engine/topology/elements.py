"""Edits of a model with building elements (wall runs, openings, slabs, one exterior per storey).

The Blender add-on's Review operators call these instead of the bare topology rules when the model was
built by the elements stage (:func:`engine.elements.build.building_elements`): after the
edit the walls, slabs and exteriors are rebuilt from the spaces and the openings move to
the new wall that holds them, so walls stay joined and openings stay in their walls.
No bpy here: pure model in, model out (metres, the model frame).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..elements.build import ELEMENT_LOG, building_elements
from ..errors import InputError, ReconstructionError
from ..model import BuildingModel, Polyhedron, Shape, ShapeType
from .edit import reclassify

__all__ = ["SNAP_DISTANCE", "made_by_elements", "has_elements", "rebuild_elements", "grammar_ids",
           "ReclassifyResult", "reclassify_with_elements", "DoorResult", "insert_wall_door", "wall_frame"]

log = logging.getLogger(__name__)

SNAP_DISTANCE = 0.5
"""Default reach of Insert door's snap to a detected opening, metres along the wall."""

_OPENINGS = (ShapeType.DOOR, ShapeType.WINDOW)
_REACH = 0.1  # a grammar wall belongs to a wall run when its centre lies within the run's box + this, m


def made_by_elements(s: Shape) -> bool:
    """The shape was made by the elements stage (its first log entry names it)."""
    return bool(s.log) and str(s.log[0]).startswith(ELEMENT_LOG)


def has_elements(model: BuildingModel) -> bool:
    """The model holds wall runs of the elements stage (so edits rebuild them)."""
    return any(s.type == ShapeType.WALL and s.active and made_by_elements(s) and "axis_line" in s.attributes
               for s in model.shapes)


def rebuild_elements(model: BuildingModel) -> BuildingModel:
    """:func:`building_elements` without a scan: walls, slabs, exteriors rebuilt from the spaces,
    every opening kept and re-parented to the wall run that holds it."""
    return building_elements(model)


@dataclass(frozen=True)
class WallFrame:
    """A wall run's frame in plan: start ``a`` (2,), unit direction ``d``, left normal ``n``
    (metres), ``length``, ``thickness``, storey floor ``z0`` and wall top ``z1`` (metres)."""

    a: np.ndarray
    d: np.ndarray
    n: np.ndarray
    length: float
    thickness: float
    z0: float
    z1: float

    def along(self, xy) -> float:
        """Distance of a plan point along the axis from the start, metres."""
        return float(self.d @ (np.asarray(xy, dtype=np.float64)[:2] - self.a))

    def across(self, xy) -> float:
        """Signed distance of a plan point from the axis (+ on the left), metres."""
        return float(self.n @ (np.asarray(xy, dtype=np.float64)[:2] - self.a))


def wall_frame(model: BuildingModel, wall: Shape) -> WallFrame:
    """The :class:`WallFrame` of a wall run (``axis_line`` and ``thickness`` attributes)."""
    ax = np.asarray(wall.attributes["axis_line"], dtype=np.float64).reshape(2, 2)
    vec = ax[1] - ax[0]
    length = float(np.hypot(*vec))
    thick = float(wall.attributes.get("thickness", 0.0))
    if not (np.all(np.isfinite(ax)) and length > 0 and np.isfinite(thick) and thick > 0):
        raise InputError(f"wall {wall.id!r}: its axis_line / thickness cannot frame a door")
    d = vec / length
    st = next((s for s in model.storeys if s.index == wall.storey), None)
    z0 = float(st.floor_z) if st is not None else float(wall.attributes.get("floor_z", wall.bounds[0, 2]))
    return WallFrame(ax[0], d, np.array([-d[1], d[0]]), length, thick, z0, float(wall.bounds[1, 2]))


def grammar_ids(model: BuildingModel, shape_ids) -> list[str]:
    """The shapes a reclassification acts on: a wall run stands for the reconstruction's walls
    under it, a storey's exterior for the exteriors it gathers; other ids stay.

    Raises ``InputError`` when a wall run or exterior covers none.
    """
    out: list[str] = []
    for sid in shape_ids:
        s = model.get(sid)
        if s is None or not made_by_elements(s) or s.type not in (ShapeType.WALL, ShapeType.EXTERIOR):
            out.append(sid)
            continue
        if s.type == ShapeType.EXTERIOR:
            found = [c for c in s.children if c in model and model[c].type == ShapeType.EXTERIOR]
        else:
            f = wall_frame(model, s)
            found = []
            for w in model.shapes:
                if w.type != ShapeType.WALL or made_by_elements(w) or w.storey != s.storey or \
                        model.top_level(w.id).id != w.id:
                    continue
                c = w.centroid
                if -_REACH <= f.along(c) <= f.length + _REACH and \
                        abs(f.across(c)) <= f.thickness / 2 + _REACH:
                    found.append(w.id)
        if not found:
            raise InputError(f"{s.name or s.id} is derived from the spaces and covers no shape of the "
                             f"reconstruction to reclassify; reclassify the spaces beside it")
        out.extend(found)
    return list(dict.fromkeys(out))


@dataclass(frozen=True)
class ReclassifyResult:
    """The model after a reclassification, and the openings it lost (ids) because no wall
    holds them any more."""

    model: BuildingModel
    dropped: tuple = ()


def reclassify_with_elements(model: BuildingModel, shape_ids, type) -> ReclassifyResult:
    """Reclassify (:func:`engine.topology.reclassify`) then rebuild the elements.

    The topology rules re-derive the reconstruction's walls and may drop openings that no
    such wall holds; those come back before :func:`rebuild_elements` puts every opening in
    the wall run holding it. Only openings that lie in no wall run afterwards are dropped.
    """
    before = {s.id: s for s in model.shapes if s.type in _OPENINGS}
    new = reclassify(model, grammar_ids(model, shape_ids), type)
    lost = [s for sid, s in before.items() if sid not in new]
    if lost:
        new = new.replace_shapes(*lost)
    out = rebuild_elements(new)
    return ReclassifyResult(out, tuple(sid for sid in before if sid not in out))


@dataclass(frozen=True)
class DoorResult:
    """An inserted door: the new model, the door's id, and the opening it snapped to (its id,
    its name, the distance along the wall from the asked position to its centre, metres)."""

    model: BuildingModel
    door_id: str
    snapped: Optional[str] = None
    snapped_name: str = ""
    snap_distance: float = 0.0


def _free_name(model: BuildingModel, stem: str) -> str:
    names = {s.name for s in model.shapes}
    k = 1
    while f"{stem} {k}" in names:
        k += 1
    return f"{stem} {k}"


def insert_wall_door(model: BuildingModel, wall_id: str, *, position, width: float = 0.9, height: float = 2.1,
                     sill: float = 0.0, snap: float = SNAP_DISTANCE) -> DoorResult:
    """Put a door in a wall run (shared conventions), snapping to a doorless opening nearby.

    Parameters
    ----------
    model : a model with elements (unchanged).
    wall_id : id of an active wall run (``axis_line``, ``thickness``).
    position : float (metres from the run's start along its axis) or a point (2 or 3
        coordinates, metres, model frame) projected onto the axis.
    width, height, sill : door size and its bottom above the storey floor, metres.
    snap : metres; a DOOR of kind "opening" in this wall whose centre is within ``snap``
        (along the wall) of ``position`` becomes the door: the door takes its centre,
        width, height and sill (and its evidence), the opening is removed. 0 turns it off.

    Returns a :class:`DoorResult`; the model's elements are rebuilt (:func:`rebuild_elements`)
    so the door has its wall as parent, ``spaces`` from the wall's sides and a connectivity
    relation. Raises ``InputError`` when the door does not fit or overlaps another opening.
    """
    wall = model.get(wall_id)
    if wall is None:
        raise InputError(f"no shape with id {wall_id!r} in the model")
    if wall.type != ShapeType.WALL or "axis_line" not in wall.attributes:
        raise InputError(f"shape {wall_id!r} is a {wall.type.value}, not a wall run")
    width, height, sill, snap = float(width), float(height), float(sill), float(snap)
    if not (width > 0 and height > 0 and sill >= 0):
        raise InputError(f"door size must be positive (width={width}, height={height}, sill={sill})")
    f = wall_frame(model, wall)
    u = float(position) if np.ndim(position) == 0 else f.along(np.asarray(position, dtype=np.float64).ravel())
    if not np.isfinite(u):
        raise InputError(f"door position {position!r} along wall {wall.id} is not a number")
    inside = [o for o in model.shapes if o.type in _OPENINGS and o.active and o.parent == wall.id]
    snapped, gap = None, 0.0
    if snap > 0:
        cand = [(abs(f.along(o.centroid) - u), o) for o in inside
                if o.type == ShapeType.DOOR and o.attributes.get("kind") == "opening"]
        cand = [c for c in cand if c[0] <= snap]
        if cand:
            gap, snapped = min(cand, key=lambda c: c[0])
            a = snapped.attributes
            u = f.along(snapped.centroid)
            width = float(a.get("width", width))
            height = float(a.get("height", height))
            sill = float(a.get("sill", sill))
    where = f"{wall.name or wall.id} (length {f.length:.2f} m)"
    if u - width / 2 < -1e-9 or u + width / 2 > f.length + 1e-9:
        raise InputError(f"a {width:.2f} m door centred {u:.2f} m along {where} does not fit")
    if f.z0 + sill + height > f.z1 + 1e-9:
        raise InputError(f"a door of height {height:.2f} m (sill {sill:.2f} m) does not fit in "
                         f"{wall.name or wall.id} of height {f.z1 - f.z0:.2f} m")
    for o in inside:
        if o is snapped:
            continue
        ou, ow = f.along(o.centroid), float(o.attributes.get("width", 0.0))
        z_lo, z_hi = float(o.bounds[0, 2]), float(o.bounds[1, 2])
        if min(u + width / 2, ou + ow / 2) - max(u - width / 2, ou - ow / 2) > 1e-6 and \
                min(f.z0 + sill + height, z_hi) - max(f.z0 + sill, z_lo) > 1e-6:
            raise InputError(f"a {width:.2f} m door at {u:.2f} m along {wall.name or wall.id} overlaps "
                             f"{o.name or o.id}")
    k = 1
    while f"door_{wall.id}_m{k}" in model:
        k += 1
    did = f"door_{wall.id}_m{k}"
    half = f.thickness / 2
    p0, p1 = f.a + f.d * (u - width / 2), f.a + f.d * (u + width / 2)
    fp = [p0 - f.n * half, p1 - f.n * half, p1 + f.n * half, p0 + f.n * half]
    z = f.z0 + sill
    centre = np.array([*(f.a + f.d * u), z + height / 2])
    sides = list(wall.attributes.get("sides", [None, None]))[:2]
    note = f"; snapped to {snapped.id} ({gap:.2f} m away)" if snapped is not None else ""
    door = Shape(did, ShapeType.DOOR, Polyhedron.prism(fp, z, z + height), storey=wall.storey,
                 name=_free_name(model, "Door"), terminal=True, parent=wall.id,
                 support=dict(snapped.support) if snapped is not None else {},
                 attributes={"width": width, "height": height, "sill": sill, "kind": "door", "open": True,
                             "spaces": sides, "confidence": 1.0, "manual": True, "position": u,
                             "center": centre.tolist()},
                 log=(f"insert door (manual): {width:.2f} x {height:.2f} m, sill {sill:.2f} m, at {u:.2f} m "
                      f"along {wall.id}{note}",))
    kids = tuple(c for c in wall.children if snapped is None or c != snapped.id) + (did,)
    new = model.replace_shapes(wall.with_(children=kids), door,
                               remove=() if snapped is None else (snapped.id,))
    out = rebuild_elements(new)
    if did not in out:  # a door inside its run always finds it again; never hand back a model without it
        raise ReconstructionError(f"door {did} lies in no wall after rebuilding the walls")
    if snapped is None:
        return DoorResult(out, did)
    return DoorResult(out, did, snapped.id, snapped.name or snapped.id, float(gap))
