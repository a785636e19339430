"""The model as built, and the changes as IFC (docs/method.md §5, "Status per element").

* :func:`as_built_model` — the old model with the walls found "not installed" dropped (with
  their doors and windows), the new walls and their doors added, and the interior spaces
  re-derived per storey from the walls as built: the plan region of the old spaces and walls
  minus the walls, split into connected parts (two offices whose partition was removed become
  one; an office cut by a new wall becomes two). A part keeps the id and name of the old space
  it mostly holds ("A + B" when it holds several); the smaller parts of a split space are
  named "<name> (2)", ...
* :func:`changes_model` / :func:`write_changes_ifc` — ``changes.ifc``: the new walls (and
  doors) and the removed elements, each with the property set ``Indoor_Change`` (``Status``
  "new" / "not installed", ``ShapeId``); removed elements keep the GlobalId they have in
  the model, so a viewer matches them with the model's elements.
"""
from __future__ import annotations

import logging
import os
from typing import Optional

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..model import BuildingModel, Polyhedron, Scope, Shape, ShapeType
from .elements import NOT_INSTALLED, element_global_id

__all__ = ["as_built_model", "changes_model", "write_changes_ifc", "write_as_built_ifc", "PSET_CHANGE",
           "removed_ids"]

log = logging.getLogger(__name__)

PSET_CHANGE = "Indoor_Change"
"""Property set of the change status of each element in changes.ifc."""
SPACE_GAP = 0.08
"""Walls are grown by this (metres) when splitting the plan into spaces, so that a gap of up to
twice this between two walls still separates two rooms: a wall ending short of another, or the
junction square a removed wall leaves in the wall it met."""
MIN_SPACE_AREA = 0.5
"""Smaller parts (m²) are slivers, not spaces."""


def removed_ids(model: BuildingModel, result) -> list[str]:
    """Ids of the walls found "not installed" and of their doors and windows, and of the doors
    and windows whose wall is closed across them ("walled up")."""
    gone = [e["id"] for e in result.element_status if e["status"] == NOT_INSTALLED and e["type"] == "wall"]
    out = list(gone)
    for s in model.shapes:
        if s.type in (ShapeType.DOOR, ShapeType.WINDOW) and s.parent in gone:
            out.append(s.id)
    out += [e["id"] for e in result.element_status if e.get("walled_up") and e["id"] not in out]
    return out


def _new_shapes(result) -> list[Shape]:
    walls = [w["shape"] for w in result.new_walls]
    kids = {}
    for d in result.new_openings:
        kids.setdefault(d.parent, []).append(d.id)
    walls = [w.with_(children=tuple(kids.get(w.id, ()))) for w in walls]
    return walls + list(result.new_openings)


def _footprint(s: Shape) -> Optional[Polygon]:
    fp = s.footprint()
    if fp is None or len(fp) < 3:
        return None
    g = Polygon(fp)
    return g if g.is_valid else g.buffer(0)


def _spaces(model: BuildingModel, walls: list[Shape]) -> list[Shape]:
    """Interior spaces re-derived from ``walls`` (see the module docstring)."""
    old = [s for s in model.spaces if s.type == ShapeType.INTERIOR and s.active]
    out = []
    for st in sorted({s.storey for s in old}):
        spaces = [s for s in old if s.storey == st]
        ws = [w for w in walls if w.storey == st]
        fps = [g for g in (_footprint(s) for s in spaces) if g is not None]
        wfp = [g for g in (_footprint(w) for w in ws) if g is not None]
        if not fps:
            continue
        # snapped to a 10 µm grid: faces of touching footprints leave no slit between them
        region = shapely.union_all(fps + [w for w in (_footprint(w) for w in model.walls if w.storey == st)
                                          if w is not None], grid_size=1e-5)
        wall_u = shapely.union_all(wfp) if wfp else Polygon()
        free = region.difference(wall_u)
        parts = region.difference(wall_u.buffer(SPACE_GAP, join_style="mitre"))
        parts = [g for g in getattr(parts, "geoms", [parts]) if g.geom_type == "Polygon" and g.area >= MIN_SPACE_AREA]
        parts = [g.buffer(SPACE_GAP, join_style="mitre").intersection(free) for g in parts]
        parts = [max(getattr(g, "geoms", [g]), key=lambda x: x.area) for g in parts if not g.is_empty]
        parts.sort(key=lambda g: -g.area)
        z0 = min(float(s.bounds[0, 2]) for s in spaces)
        z1 = max(float(s.bounds[1, 2]) for s in spaces)
        claimed = {}
        rows = []
        for g in parts:
            held = [s for s, f in zip(spaces, fps) if g.intersection(f).area >= 0.5 * f.area]
            if held:
                base, name = held[0], " + ".join(s.name or s.id for s in held)
            else:
                base = max(zip(spaces, fps), key=lambda sf: g.intersection(sf[1]).area)[0]
                name = None
            k = claimed.get(base.id, 0)
            claimed[base.id] = k + 1
            sid = base.id if k == 0 else f"{base.id}_part{k + 1}"
            if name is None or k > 0:
                name = base.name if k == 0 else f"{base.name or base.id} ({k + 1})"
            rows.append((g, sid, name, base, held))
        for g, sid, name, base, held in rows:
            ring = np.asarray(g.simplify(1e-4).exterior.coords)[:-1]
            geom = Polyhedron.prism(ring, z0, z1)
            attrs = dict(base.attributes)
            if len(held) > 1:
                attrs["merged_from"] = [s.id for s in held]
            elif not held:
                attrs["split_from"] = base.id
            out.append(Shape(id=sid, type=ShapeType.INTERIOR, geometry=geom, scope=Scope.of_points(geom.vertices),
                             storey=base.storey, name=name, terminal=True, attributes=attrs))
    return out


def _door_spaces(d: Shape, walls: dict, spaces: list[Shape]) -> Shape:
    """A door's or window's "spaces": the spaces on both sides of its wall (exterior when none)."""
    w = walls.get(d.parent)
    if w is None:
        return d
    from .elements import _wall_frame
    _, dirn, n, _, thick = _wall_frame(w)
    b = d.geometry.bounds
    c = (b[0, :2] + b[1, :2]) / 2
    out = []
    for side in (1.0, -1.0):
        q = c + side * n * (thick / 2 + 0.15)
        hit = next((s.id for s in spaces if s.storey == d.storey and _footprint(s) is not None
                    and _footprint(s).contains(shapely.Point(q))), f"exterior_s{d.storey}")
        out.append(hit)
    return d.with_(attributes={**d.attributes, "spaces": out})


def as_built_model(model: BuildingModel, result) -> BuildingModel:
    """The model as built (see the module docstring); ``result`` is a classified ChangeResult."""
    gone = set(removed_ids(model, result))
    new = _new_shapes(result)
    kept = [s for s in model.shapes if s.id not in gone and not (s.type == ShapeType.INTERIOR and s.active)]
    kept = [s.with_(children=tuple(c for c in s.children if c not in gone)) if s.children else s for s in kept]
    walls = [s for s in kept if s.type == ShapeType.WALL and s.active] + [s for s in new if s.type == ShapeType.WALL]
    spaces = _spaces(model, walls)
    ids = {s.id for s in kept} | {s.id for s in new} | {s.id for s in spaces}
    wall_by_id = {w.id: w for w in walls}
    shapes = []
    for s in kept + new:
        if s.type in (ShapeType.DOOR, ShapeType.WINDOW):
            s = _door_spaces(s, wall_by_id, spaces)
        shapes.append(s)
    shapes += spaces
    rels = tuple(r for r in model.relations if r.a in ids and r.b in ids and (r.via is None or r.via in ids)
                 and r.kind != "adjacency")
    return model.with_(shapes=tuple(shapes), relations=rels)


def changes_model(model: BuildingModel, result) -> tuple[BuildingModel, dict]:
    """The changes as a model (new walls and doors, removed elements) and shape id → status."""
    gone = removed_ids(model, result)
    new = _new_shapes(result)
    status = {s.id: "new" for s in new}
    status.update({i: NOT_INSTALLED for i in gone})
    shapes = [model[i] for i in gone] + new
    return model.with_(shapes=tuple(shapes), relations=()), status


def _pset(f, product, name: str, props: dict, gid_key, seed, model_name):
    import ifcopenshell.api

    from ..ifc.common import global_id
    pset = ifcopenshell.api.pset.add_pset(f, product=product, name=name)
    ifcopenshell.api.pset.edit_pset(f, pset=pset, properties=props)
    pset.GlobalId = global_id(seed, model_name, (gid_key, "pset", name))
    for k, rel in enumerate(pset.DefinesOccurrence):
        rel.GlobalId = global_id(seed, model_name, (gid_key, "defines", name, k))


def write_changes_ifc(model: BuildingModel, result, path) -> tuple[str, dict]:
    """Write ``changes.ifc``; returns (path, shape id → GlobalId in the file)."""
    from ..fileutil import atomic_path
    from ..ifc.common import PSET_SHAPE
    from ..ifc.writer import build_ifc
    import ifcopenshell.util.element as ue

    path = os.fspath(path)
    cm, status = changes_model(model, result)
    name = f"{model.name or 'model'} changes"
    cm = cm.with_(name=name)
    gids = {}
    if not cm.shapes:  # nothing changed: no file
        log.info("changes.ifc: no change to write")
        return "", {}
    f = build_ifc(cm, path=path)
    for e in list(f.by_type("IfcElement")):
        sid = ue.get_psets(e).get(PSET_SHAPE, {}).get("ShapeId")
        if sid not in status:
            continue
        if status[sid] == NOT_INSTALLED:
            e.GlobalId = element_global_id(model, model[sid])
        gids[sid] = e.GlobalId
        _pset(f, e, PSET_CHANGE, {"Status": status[sid], "ShapeId": sid}, ("change", sid),
              model.provenance.seed, name)
    data = f.to_string().encode("utf-8")
    with atomic_path(path, suffix=".ifc") as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
    return path, gids


def write_as_built_ifc(model: BuildingModel, result, path) -> str:
    """Write the model as built (:func:`as_built_model`) with the regular IFC writer."""
    from ..ifc.writer import write_ifc
    return write_ifc(as_built_model(model, result), path)
