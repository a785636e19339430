"""Manual rules: reclassification and door insertion (docs/method.md §2, rules 2 and 6).

Both return a new :class:`BuildingModel` and re-derive everything downstream
(connectivity → merge, containment, adjacency → doors → connectivity), so an edit never
leaves a stale relation. The input model is not changed: undo is keeping it.
"""
from __future__ import annotations

import logging
from typing import Iterable, Union

import numpy as np

from ..errors import InputError
from ..grammar.geometry import box_of
from ..grammar.rules import derive_topology, is_part
from ..model import BuildingModel, Shape, ShapeType

__all__ = ["reclassify", "insert_door"]

log = logging.getLogger(__name__)

_EDITABLE = (ShapeType.INTERIOR, ShapeType.EXTERIOR, ShapeType.WALL, ShapeType.NONE)


def reclassify(model: BuildingModel, shape_ids: Union[str, Iterable[str]], type) -> BuildingModel:
    """Rule 2 invoked manually: give shapes a new type, then re-derive the topology.

    Parameters
    ----------
    model : the model (unchanged).
    shape_ids : one id or several; a merged shape (a room, a wall, an exterior) stands
        for all its parts.
    type : ShapeType or its name ("interior", "exterior", "wall", "none").

    Returns the new model. Raises ``InputError`` for an unknown id, a door/slab, or a
    type that is not a space or wall type.
    """
    new_type = ShapeType.parse(type)
    if new_type not in _EDITABLE:
        raise InputError(f"cannot reclassify to {new_type.value!r}; use one of {[t.value for t in _EDITABLE]}")
    if isinstance(shape_ids, str):
        shape_ids = [shape_ids]
    targets: dict[str, Shape] = {}
    for sid in shape_ids:
        if sid not in model:
            raise InputError(f"no shape with id {sid!r} in the model")
        s = model[sid]
        if s.type not in _EDITABLE:
            raise InputError(f"shape {sid!r} is a {s.type.value}; only spaces and walls can be reclassified")
        parts = [c for c in model.leaves(sid) if is_part(c)] if not is_part(s) else [s]
        if not parts:  # a model without parts: the shape itself
            parts = [s]
        for p in parts:
            targets[p.id] = p
    changed = [p.logged(f"reclassify (manual): {p.type.value} -> {new_type.value}", type=new_type,
                        terminal=new_type != ShapeType.INTERIOR)
               for p in targets.values()]
    out = model.replace_shapes(*changed)
    if not any(is_part(p) for p in changed):
        # no parts to merge: the shapes themselves are the spaces
        out = out.replace_shapes(*[out[p.id].with_(active=True) for p in changed])
    return derive_topology(out)


def insert_door(model: BuildingModel, wall_id: str, *, position, width: float = 0.9,
                height: float = 2.1, sill: float = 0.0, name: str = "") -> BuildingModel:
    """Rule 6 invoked manually: put a door in a wall, then re-derive the topology.

    Parameters
    ----------
    model : the model (unchanged).
    wall_id : id of an active wall (a wall part stands for its wall).
    position : where along the wall the door's centre is: a float (metres from the
        wall's start along its length) or a point (2 or 3 coordinates, metres, model
        frame) projected onto the wall's axis.
    width, height : door size, metres. sill : height of its bottom above the wall's
        bottom, metres (0 for a door).

    Returns the new model with a DOOR shape (parent = the wall; attributes ``width``,
    ``height``, ``sill``, ``position``, ``center``) whose box cuts the wall through its
    thickness; the wall's geometry gets the opening; spaces on both sides become
    connected through the door.
    """
    if wall_id not in model:
        raise InputError(f"no shape with id {wall_id!r} in the model")
    wall = model.top_level(wall_id)
    if wall.type != ShapeType.WALL:
        raise InputError(f"shape {wall_id!r} is a {wall.type.value}, not a wall")
    width, height, sill = float(width), float(height), float(sill)
    if width <= 0 or height <= 0 or sill < 0:
        raise InputError(f"door size must be positive (width={width}, height={height}, sill={sill})")
    lo, hi = wall.bounds
    size = hi - lo
    axis = int(wall.attributes.get("axis", int(np.argmax(size[:2]))))
    across = 1 - axis
    if np.ndim(position) == 0:
        t = float(position)
    else:
        pt = np.asarray(position, dtype=np.float64).ravel()
        t = float(pt[axis] - lo[axis])
    if t - width / 2 < -1e-9 or t + width / 2 > size[axis] + 1e-9:
        raise InputError(f"a {width:.2f} m door centred {t:.2f} m along wall {wall.id} "
                         f"(length {size[axis]:.2f} m) does not fit")
    if sill + height > size[2] + 1e-9:
        raise InputError(f"a door of height {height:.2f} m (sill {sill:.2f} m) does not fit in "
                         f"wall {wall.id} of height {size[2]:.2f} m")
    dlo, dhi = lo.copy(), hi.copy()
    dlo[axis], dhi[axis] = lo[axis] + t - width / 2, lo[axis] + t + width / 2
    dlo[across], dhi[across] = lo[across], hi[across]
    dlo[2], dhi[2] = lo[2] + sill, lo[2] + sill + height
    k = 1
    while f"door_{wall.id}_{k}" in model:
        k += 1
    did = f"door_{wall.id}_{k}"
    center = (dlo + dhi) / 2
    door = Shape(id=did, type=ShapeType.DOOR, geometry=box_of(dlo, dhi), storey=wall.storey,
                 name=name or f"Door {len(model.doors) + 1}", terminal=True, parent=wall.id,
                 attributes={"width": width, "height": height, "sill": sill, "position": t,
                             "center": center.tolist(), "axis": axis, "thickness": float(size[across])},
                 log=(f"containment (manual): door {width:.2f} x {height:.2f} m at {t:.2f} m along {wall.id}",))
    return derive_topology(model.replace_shapes(door))
