"""Footprints and storeys of model and truth shapes, shared by the element and room scores
and the plan views: a model moved into the truth's frame (``_in_truth_frame``), a
shape's plan polygon, its storey, the external flag of a wall, and a storey's outline
(:func:`exterior_outline`: the footprint whose boundary exterior walls must cover)."""
from __future__ import annotations

import logging
from typing import Optional

import numpy as np
from shapely.geometry import Polygon
from shapely.ops import unary_union

from ..geometry.polygon import polygon_parts
from ..geometry.transforms import apply_transform, frame_transform
from ..model import BuildingModel, Shape, ShapeType
from .loading import transform_model

__all__ = ["exterior_outline"]

log = logging.getLogger(__name__)

_MITRE = dict(join_style="mitre", mitre_limit=10.0)
_STOREY_Z_SLACK = 0.3
"""A shape whose bottom is at most this below a storey's floor belongs to it, metres."""


def _in_truth_frame(model: BuildingModel, truth: BuildingModel) -> BuildingModel:
    """``model`` with geometry (and wall ``axis_line`` attributes) in the truth's frame."""
    m = frame_transform(model.transform, model.offset, truth.transform, truth.offset)
    if np.allclose(m, np.eye(4), atol=1e-9):
        return model
    log.info("moving the model into the truth's frame (their transforms/offsets differ)")
    moved = transform_model(model, m)
    upd = []
    for s in moved.shapes:
        line = _axis_attr(s)
        if line is not None:
            z = float(model[s.id].bounds[0, 2])
            p = apply_transform(m, np.column_stack([line, [z, z]]))[:, :2]
            upd.append(s.with_(attributes={**s.attributes, "axis_line": p.tolist()}))
    return moved.replace_shapes(*upd) if upd else moved


def _axis_attr(s: Shape) -> Optional[np.ndarray]:
    line = s.attributes.get("axis_line")
    try:
        a = np.asarray(line, dtype=np.float64).reshape(2, 2)
    except (TypeError, ValueError):
        return None
    return a if np.all(np.isfinite(a)) and np.linalg.norm(a[1] - a[0]) > 1e-9 else None


_polygons = polygon_parts


def _plan(s: Shape, model: BuildingModel):
    """Shapely polygon of a shape's plan (footprint of a prism; else the union of its parts'
    footprints or of its projected triangles), metres."""
    fp = s.footprint()
    if fp is not None:
        return Polygon(fp).buffer(0)
    parts = [p for p in model.leaves(s.id) if p.id != s.id]
    fps = [p.footprint() for p in parts]
    if parts and all(f is not None for f in fps):
        return unary_union([Polygon(f).buffer(0) for f in fps])
    v, tri = s.geometry.triangles()
    polys = [Polygon(v[t, :2]) for t in tri]
    return unary_union([p for p in polys if p.area > 1e-12])


def _zrange(s: Shape) -> tuple[float, float]:
    b = s.bounds
    return float(b[0, 2]), float(b[1, 2])


def _storey_of(s: Shape, truth: BuildingModel) -> int:
    """Truth storey a shape belongs to by its bottom height: the highest storey whose floor
    lies at most ``_STOREY_Z_SLACK`` above the bottom and whose ceiling is above it (a stair
    space over two storeys belongs to the lower); else the nearest one; -1 without storeys."""
    st = truth.storeys
    if not st:
        return -1
    z0 = _zrange(s)[0]
    inside = [k for k, t in enumerate(st) if t.floor_z - _STOREY_Z_SLACK <= z0 < t.ceiling_z]
    if inside:
        return max(inside, key=lambda k: st[k].floor_z)
    return int(np.argmin([max(t.floor_z - z0, z0 - t.ceiling_z, 0.0) for t in st]))


def _truth_storey(s: Shape, truth: BuildingModel) -> int:
    return s.storey if 0 <= s.storey < len(truth.storeys) else _storey_of(s, truth)


def _exterior_adjacent(model: BuildingModel) -> set:
    """Ids of the shapes named as ``via`` of an adjacency with an EXTERIOR shape."""
    ext = {s.id for s in model.of_type(ShapeType.EXTERIOR, active=None)}
    return {r.via for r in model.relations_of("adjacency")
            if r.via is not None and (r.a in ext or r.b in ext)}


def _is_external(w: Shape, model: BuildingModel, adjacent: set) -> bool:
    """``external`` (or the truth's ``exterior``) attribute; else a ``sides`` entry that is
    None or an exterior shape; else an adjacency with an exterior shape through the wall."""
    for key in ("external", "exterior"):
        v = w.attributes.get(key)
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
    sides = w.attributes.get("sides")
    if isinstance(sides, (list, tuple)) and len(sides) == 2:
        return any(x is None or (x in model and model[x].type == ShapeType.EXTERIOR) or
                   (x not in model and str(x).startswith("exterior")) for x in sides)
    return w.id in adjacent


def exterior_outline(truth: BuildingModel, storey: int, closing: float = 0.3, seen: Optional[set] = None):
    """The storey's footprint: the union of the true rooms' footprints and the interior
    walls' (not ``external``: a party wall or a shaft thicker than ``2 * closing`` lies
    inside the building, not on its boundary), the remaining gaps closed (radius
    ``closing``, metres), parts narrower than ``closing`` dropped, holes dropped. A space of
    another storey that reaches through this one's mid-height (a stairwell spanning two
    storeys) is part of its footprint: the void over a stair is inside the building.
    ``seen``: the ids of the true spaces a scan reaches; the others are left out (a room
    never scanned is no part of the scanned building's outline). Empty when the storey has no
    (seen) rooms."""
    st = truth.storeys[storey]
    mid = (st.floor_z + st.ceiling_z) / 2

    def here(s):
        if _truth_storey(s, truth) == storey:
            return True
        z0, z1 = _zrange(s)
        return z0 < mid < z1

    spaces = [s for s in truth.spaces if seen is None or s.id in seen]
    if not any(_truth_storey(s, truth) == storey for s in spaces):
        return Polygon()
    rooms = [s for s in spaces if here(s)]
    adjacent = _exterior_adjacent(truth)
    inner = [_plan(w, truth) for w in truth.walls
             if _truth_storey(w, truth) == storey and not _is_external(w, truth, adjacent)]
    u = unary_union([_plan(s, truth) for s in rooms] + inner)
    if u.is_empty:
        return Polygon()
    u = u.buffer(closing, **_MITRE).buffer(-closing, **_MITRE)
    # an opening drops the ends of interior walls that run on through an exterior wall's
    # junction (narrower than ``closing``): they are no part of the inside
    u = u.buffer(-closing / 2, **_MITRE).buffer(closing / 2, **_MITRE)
    return unary_union([Polygon(p.exterior) for p in _polygons(u)])
