"""IFC (IFC2X3 / IFC4 / IFC4X3) → BuildingModel (surface meshes: :mod:`.mesh`).

:func:`read_ifc` tessellates the walls, slabs, spaces and doors of a file with
``ifcopenshell.geom`` (world coordinates, metres whatever the file's length unit), assigns
each to its storey (spatial containment, aggregation, or the wall a door fills), and
derives the topology from the space boundaries:

* adjacency ``(space, space, via=wall)`` and connectivity ``(space, space, via=door)`` from
  pairs of boundaries pointing at each other (``CorrespondingBoundary``); in files without
  such pairs, two spaces bounded by the same wall on opposite sides of it are adjacent and
  two spaces bounded by the same door are connected (the two on its sides, ``spaces``
  below, where more than two boundaries name the door);
* virtual boundaries (``IfcVirtualElement``) give relations without a wall or door.

Shapes are vertical prisms (:meth:`Polyhedron.prism`) when the tessellation is one,
otherwise triangle meshes. Doors and windows (ShapeType.DOOR / WINDOW) become the box of
their opening in the wall they fill (``IfcRelFillsElement`` → ``IfcRelVoidsElement``; that
wall is their ``parent``): ``OverallWidth`` along the wall axis × the wall thickness, from
their lowest point up ``OverallHeight``; attributes ``width``, ``height``, ``sill`` (above
the storey floor), ``kind`` ("door" / "window") and ``spaces`` (the two spaces on either
side from the space boundaries, or by geometry where a boundary is missing; the outside is
``"exterior_s<k>"`` or the storey's EXTERIOR shape). Walls get ``thickness`` (base
quantities, material layers or geometry), ``height``, ``axis_line``, ``external``
(``Pset_WallCommon.IsExternal``, else whether a space boundary of the wall is EXTERNAL) and
``joins`` (``IfcRelConnectsPathElements``); slabs ``kind`` (floor / base / roof) and
``thickness``. Files written by :func:`engine.ifc.write_ifc` come back in the
model's own frame with their shape ids, supports and attributes; other files keep their
world coordinates (minus a whole-metre offset when they are far from the origin).
"""
from __future__ import annotations

import json
import logging
import os
import re
from dataclasses import dataclass
from typing import Optional

import numpy as np
from shapely.geometry import Point, Polygon
from shapely.ops import unary_union

from ..errors import FormatError, InputError, is_valid_text
from ..geometry.mesh import orient_outward
from ..geometry.transforms import apply_transform
from ..model import BuildingModel, Polyhedron, Provenance, Relation, Shape, ShapeType, Storey
from ..progress import Progress
from .common import (PSET_PROVENANCE, PSET_SHAPE, PSET_STOREY, PSET_SUPPORT, READABLE_SCHEMAS, check_path,
                     loads, require_ifcopenshell)
from .mesh import _MIN_DOUBLE_AREA, MESH_EXTENSIONS, read_mesh

__all__ = ["IfcReadParams", "read_ifc", "read_reference"]

log = logging.getLogger(__name__)

@dataclass(frozen=True)
class IfcReadParams:
    """Parameters of :func:`read_ifc` (SI units)."""

    element_classes: tuple = ("IfcWall", "IfcSlab", "IfcSpace", "IfcDoor", "IfcWindow",
                              "IfcExternalSpatialElement")
    """IFC classes read (with their subclasses, e.g. IfcWallStandardCase)."""
    prism_tol: float = 1e-4
    """Height tolerance (m) and normal tolerance (|n_z| of vertical / 1 - |n_z| of horizontal
    faces) for recognising a tessellated vertical prism."""
    prism_area_rtol: float = 1e-3
    """Relative tolerance on the side-face and top/bottom areas of a recognised prism."""
    recentre_beyond: float = 1e4
    """Coordinates (m) beyond which a foreign file is moved near the origin (``model.offset``)."""
    storey_tol: float = 0.05
    """Tolerance (m) when a shape is put in a storey by its height (no containment found)."""
    threads: int = 2
    """Tessellation threads (booleans of walls with many openings dominate the reading time)."""
    opening_side_reach: float = 0.5
    """A door or window without a space boundary on one side of its wall gets the space
    found within this distance (m) of the wall face there."""


# --------------------------------------------------------------------------- entry points
def read_reference(path: str | os.PathLike, **kwargs) -> BuildingModel:
    """Read a reference model: ``.ifc`` through :func:`read_ifc`, meshes through :func:`read_mesh`."""
    p = check_path(path)
    ext = os.path.splitext(p)[1].lower()
    if ext == ".ifc":
        return read_ifc(p, **kwargs)
    if ext in MESH_EXTENSIONS:
        return read_mesh(p, **kwargs)
    raise InputError(f"unknown reference format {ext!r}; expected .ifc or one of {list(MESH_EXTENSIONS)}", p)


def read_ifc(path: str | os.PathLike, *, params: Optional[IfcReadParams] = None, progress=None,
             should_stop=None) -> BuildingModel:
    """Read an IFC file into a :class:`BuildingModel`.

    Parameters
    ----------
    path : str or path-like
        An IFC-SPF (``.ifc``) file, schema IFC2X3, IFC4 or IFC4X3.
    params : IfcReadParams, optional
    progress, should_stop : callbacks, see :class:`engine.progress.Progress`.

    Returns
    -------
    BuildingModel
        Shapes: WALL, SLAB, INTERIOR / EXTERIOR spaces, DOOR, WINDOW — geometry in metres, z up,
        ``storey`` = index into ``model.storeys`` (sorted by height). Relations from the
        space boundaries. ``transform``/``offset`` map back to the file's coordinates.

    Raises
    ------
    InputError — missing file; the file has no IfcBuildingStorey.
    FormatError — empty, not an IFC-SPF file, an unsupported schema, truncated (no
    ``END-ISO-10303-21;`` at its end), or content the parser rejects (syntax errors).
    """
    params = params or IfcReadParams()
    p = Progress.wrap(progress, should_stop)
    path = check_path(path)
    require_ifcopenshell("reading IFC")
    f = _open(path)
    p(0.05, "opened")
    return _Reader(f, path, params, p).run()


_HEAD_BYTES = 8192
"""Bytes read from the start of an IFC file for its header (magic and FILE_SCHEMA)."""
_TAIL_BYTES = 4096
"""Bytes read from the end of an IFC file for its ``END-ISO-10303-21;`` terminator."""
_END_RE = re.compile(rb"END-ISO-10303-21\s*;")


def _open(path: str):
    """Check the header and the end of the file, then parse it; FormatError on bad content."""
    import ifcopenshell

    try:
        with open(path, "rb") as fh:
            head = fh.read(_HEAD_BYTES)
            size = fh.seek(0, os.SEEK_END)
            fh.seek(max(size - _TAIL_BYTES, 0))
            tail = fh.read()
    except OSError as e:
        raise InputError(f"cannot read the file: {e.strerror or e}", path) from None
    if not head.strip():
        raise FormatError("the file is empty", path)
    text = head.decode("latin-1", errors="replace")
    if "ISO-10303-21" not in text:
        if head[:2] == b"PK":
            raise FormatError("is a ZIP archive (ifcZIP?): unzip it and read the .ifc inside", path)
        raise FormatError("not an IFC file (no ISO-10303-21 header)", path)
    m = re.search(r"FILE_SCHEMA\s*\(\s*\(\s*'([^']*)'", text, flags=re.I)
    if m is None:
        raise FormatError("IFC header has no FILE_SCHEMA", path)
    schema = m.group(1).strip().upper()
    if not any(schema == s or schema.startswith(s + "_") for s in READABLE_SCHEMAS):
        raise FormatError(f"unsupported IFC schema {schema!r}; readable: {list(READABLE_SCHEMAS)}", path)
    if not _END_RE.search(tail):
        raise FormatError(f"truncated: no END-ISO-10303-21 at the end of the file ({size} bytes)", path)
    wrapper = ifcopenshell.ifcopenshell_wrapper
    wrapper.get_log()  # drop messages of earlier work: what follows is about this file
    try:
        if is_valid_text(path):
            f = ifcopenshell.open(path)
        else:  # a name with undecodable bytes: ifcopenshell takes UTF-8 names only
            with open(path, "rb") as fh:
                f = ifcopenshell.file.from_string(fh.read().decode("utf-8", errors="replace"))
    except Exception as e:  # ifcopenshell raises plain errors on bad content
        raise FormatError(f"cannot parse the IFC file: {e}", path) from None
    errors = _parse_errors(wrapper.get_log())
    if errors:
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        raise FormatError(f"syntax error in the IFC file: {errors[0]}{more}", path)
    return f


def _parse_errors(log_text: str) -> list:
    """Messages of the error-level entries of ifcopenshell's log (text or JSON format): the
    parser logs bad entities and dangling references there and goes on without them."""
    out = []
    for line in (log_text or "").splitlines():
        line = line.strip()
        if line.startswith("{"):
            try:
                rec = json.loads(line)
            except ValueError:
                continue
            if str(rec.get("level", "")).lower() == "error":
                out.append(str(rec.get("message", "")))
        else:
            m = re.match(r"\[error\]\s*(?:\[[^\]]*\]\s*)?(.*)", line, flags=re.I)
            if m:
                out.append(m.group(1))
    return out


# --------------------------------------------------------------------------- reader
class _Reader:
    def __init__(self, f, path, params: IfcReadParams, p):
        import ifcopenshell.util.element
        import ifcopenshell.util.placement
        import ifcopenshell.util.unit

        self.ue = ifcopenshell.util.element
        self.up = ifcopenshell.util.placement
        self.f, self.path, self.params, self.p = f, path, params, p
        self.scale = float(ifcopenshell.util.unit.calculate_unit_scale(f))

    def _pset(self, e, name) -> dict:
        return self.ue.get_psets(e).get(name, {})

    def run(self) -> BuildingModel:
        f, prm = self.f, self.params
        storeys = list(f.by_type("IfcBuildingStorey"))
        if not storeys:
            raise InputError("the IFC file has no storeys (IfcBuildingStorey)", self.path)
        projects = f.by_type("IfcProject")
        prov = self._pset(projects[0], PSET_PROVENANCE) if projects else {}
        self.ours = bool(prov) and "Transform" in prov
        if self.ours:
            t = np.asarray(loads(prov.get("Transform"), np.eye(4).tolist()), dtype=np.float64).reshape(4, 4)
            offset = np.asarray(loads(prov.get("Offset"), [0, 0, 0]), dtype=np.float64).reshape(3)
        else:
            t, offset = np.eye(4), np.zeros(3)
        elements = []
        for cls in prm.element_classes:
            try:
                elements.extend(f.by_type(cls))
            except RuntimeError:  # class not in this schema (IfcExternalSpatialElement in IFC2X3)
                continue
        elements += _doorless_openings(f)
        elements = list({e.id(): e for e in elements}.values())
        meshes = self._tessellate(elements)
        self.p(0.8, "topology")
        # frame: file coordinates (metres) -> model frame
        if not self.ours and meshes:
            allv = np.vstack([v for v, _ in meshes.values()])
            if np.abs(allv).max() > prm.recentre_beyond:
                offset = np.floor(allv.min(axis=0))
                offset[2] = 0.0
        tinv = np.linalg.inv(t)
        # our files with the offset in an IfcMapConversion have it out of the placements
        placed_offset = np.zeros(3) if self.ours and prov.get("OffsetIn") == "map_conversion" else offset

        def to_model(v):
            q = np.asarray(v, dtype=np.float64).reshape(-1, 3) - placed_offset
            return apply_transform(tinv, q)

        # storeys
        info = []
        for s in storeys:
            sp = self._pset(s, PSET_STOREY)
            z = None
            if s.ObjectPlacement is not None:
                mat = self.up.get_local_placement(s.ObjectPlacement)
                z = float(to_model(mat[:3, 3] * self.scale)[0, 2])
            elev = None if s.Elevation is None else float(s.Elevation) * self.scale
            if sp.get("FloorZ") is not None:
                z = float(sp["FloorZ"])
            if z is None:
                z = elev if elev is not None else 0.0
            info.append((z, s, elev, sp))
        info.sort(key=lambda x: (x[0], x[1].id()))
        storey_index = {s.id(): i for i, (_, s, _, _) in enumerate(info)}

        shapes = {}
        ids = {}
        for e in elements:
            if e.id() not in meshes:
                continue
            v, tri = meshes[e.id()]
            v = to_model(v)
            shape = self._shape(e, v, tri, storey_index, info)
            if shape is None:
                continue
            if shape.id in shapes:  # duplicate ids (copied GlobalIds): keep both
                shape = shape.with_(id=f"{shape.id}#{e.id()}")
            shapes[shape.id] = shape
            ids[e.id()] = shape.id

        shapes = self._hierarchy(shapes, ids, elements)
        if not self.ours:
            shapes = self._element_facts(shapes, ids, elements, info)
        st_objs = []
        for i, (z, s, elev, sp) in enumerate(info):
            ceiling = sp.get("CeilingZ")
            if ceiling is None:
                rooms = [sh for sh in shapes.values() if sh.storey == i and sh.type == ShapeType.INTERIOR]
                if rooms:  # the top of most of the floor area (a stair well may reach the storey above)
                    areas = [max(sh.geometry.plan_area_perimeter()[0], 1e-6) for sh in rooms]
                    ceiling = _weighted_median([sh.bounds[1, 2] for sh in rooms], areas)
                elif i + 1 < len(info):
                    ceiling = info[i + 1][0]
                else:
                    tops = [sh.bounds[1, 2] for sh in shapes.values() if sh.storey == i]
                    ceiling = max(tops) if tops else z
            st_objs.append(Storey(i, float(z), float(ceiling), s.Name or s.LongName or f"Storey {i}",
                                  elev))
        relations = self._relations(ids, shapes)
        if self.ours:
            provenance = Provenance(prov.get("Method", "") or "", loads(prov.get("Parameters"), {}) or {},
                                    prov.get("Seed"), loads(prov.get("Timings"), {}) or {},
                                    loads(prov.get("Trace"), {}) or {}, self.path,
                                    prov.get("Software", "") or "")
            name = prov.get("ModelName") or (projects[0].Name or "")
        else:
            app = ""
            for oh in f.by_type("IfcApplication")[:1]:
                app = f"{oh.ApplicationFullName or ''} {oh.Version or ''}".strip()
            provenance = Provenance("ifc", {}, None, {}, {}, self.path, app)
            name = (projects[0].Name or "") if projects else ""
        model = BuildingModel(shapes=tuple(shapes.values()), storeys=tuple(st_objs),
                              relations=tuple(relations),
                              transform=t, offset=offset, provenance=provenance,
                              name=name or os.path.splitext(os.path.basename(self.path))[0])
        self.p(1.0, "IFC read")
        log.info("read %s: %s", self.path, model.summary())
        return model

    # ------------------------------------------------------------------ geometry
    def _tessellate(self, elements) -> dict:
        """{entity id: (vertices (n, 3) float64 metres in file coordinates, triangles (m, 3) int64)}."""
        import ifcopenshell.geom

        out = {}
        if not elements:
            return out
        settings = ifcopenshell.geom.settings()
        settings.set("use-world-coords", True)
        settings.set("weld-vertices", True)
        it = ifcopenshell.geom.iterator(settings, self.f, max(1, int(self.params.threads)), include=elements)
        n = len(elements)
        try:
            ok = it.initialize()
        except Exception as e:
            raise FormatError(f"cannot tessellate the IFC geometry: {e}", self.path) from None
        if not ok:
            log.warning("%s: no geometry could be tessellated", self.path)
            return out
        k = 0
        while True:
            sh = it.get()
            v = np.asarray(sh.geometry.verts, dtype=np.float64).reshape(-1, 3)
            t = np.asarray(sh.geometry.faces, dtype=np.int64).reshape(-1, 3)
            if len(t):
                out[int(sh.id)] = (v, t)
            k += 1
            if k % 16 == 0:
                self.p(0.05 + 0.75 * k / n, "tessellating")
            if not it.next():
                break
        return out

    def _storey_of(self, e, storey_index) -> Optional[int]:
        seen = set()
        q = e
        while q is not None and q.id() not in seen:
            seen.add(q.id())
            if q.id() in storey_index:
                return storey_index[q.id()]
            nxt = self.ue.get_container(q)
            if nxt is None:
                nxt = self.ue.get_aggregate(q)
            if nxt is None and (q.is_a("IfcDoor") or q.is_a("IfcWindow") or q.is_a("IfcOpeningElement")):
                ops = [q] if q.is_a("IfcOpeningElement") else [r.RelatingOpeningElement for r in q.FillsVoids or ()]
                for vrel in (v for op in ops for v in getattr(op, "VoidsElements", ()) or ()):
                    nxt = vrel.RelatingBuildingElement
            q = nxt
        return None

    def _shape(self, e, v, tri, storey_index, info) -> Optional[Shape]:
        prm = self.params
        if e.is_a("IfcWall"):
            kind = ShapeType.WALL
        elif e.is_a("IfcSlab"):
            kind = ShapeType.SLAB
        elif e.is_a("IfcDoor"):
            kind = ShapeType.DOOR
        elif e.is_a("IfcWindow"):
            kind = ShapeType.WINDOW
        elif e.is_a("IfcOpeningElement"):  # a doorless opening (_doorless_openings)
            kind = ShapeType.DOOR
        elif e.is_a("IfcSpace"):
            kind = ShapeType.INTERIOR
            ext = getattr(e, "InteriorOrExteriorSpace", None) == "EXTERNAL" or \
                getattr(e, "PredefinedType", None) == "EXTERNAL"
            if ext:
                kind = ShapeType.EXTERIOR
        elif e.is_a("IfcExternalSpatialElement"):
            kind = ShapeType.EXTERIOR
        else:
            return None
        geom = _polyhedron(v, tri, prm)
        if geom is None:
            return None
        ps = self._pset(e, PSET_SHAPE) if self.ours else {}
        sup = self._pset(e, PSET_SUPPORT) if self.ours else {}
        storey = self._storey_of(e, storey_index)
        if storey is None:
            zmin = geom.bounds[0, 2]
            below = [i for i, (z, *_rest) in enumerate(info) if z <= zmin + prm.storey_tol]
            storey = below[-1] if below else (0 if info else -1)
        if ps.get("StoreyIndex") is not None and int(ps["StoreyIndex"]) < 0:
            storey = -1
        attributes = dict(loads(ps.get("Attributes"), {}) or {})
        if e.is_a("IfcOpeningElement"):
            attributes.setdefault("kind", "opening")
        elif kind in (ShapeType.DOOR, ShapeType.WINDOW):
            if getattr(e, "OverallWidth", None):
                attributes.setdefault("width", float(e.OverallWidth) * self.scale)
            if getattr(e, "OverallHeight", None):
                attributes.setdefault("height", float(e.OverallHeight) * self.scale)
        if kind == ShapeType.WALL and "thickness" not in attributes:
            qto = self.ue.get_psets(e, qtos_only=True).get("Qto_WallBaseQuantities", {})
            if qto.get("Width"):
                attributes["thickness"] = float(qto["Width"]) * self.scale
        if kind in (ShapeType.INTERIOR, ShapeType.EXTERIOR):
            name = getattr(e, "LongName", None) or ("" if ps else (e.Name or ""))
        else:
            name = e.Name or ""
        grid = loads(ps.get("Grid"))
        return Shape(
            id=str(ps.get("ShapeId") or e.GlobalId), type=kind, geometry=geom, storey=int(storey), name=name,
            terminal=bool(ps.get("Terminal", kind != ShapeType.INTERIOR)),
            active=bool(ps.get("Active", True)),
            grid=None if grid is None else tuple(grid),
            support={k: float(x) for k, x in sup.items() if k != "id" and isinstance(x, (int, float))},
            attributes=attributes, log=tuple((ps.get("Log") or "").split("\n")) if ps.get("Log") else (),
        )

    def _hierarchy(self, shapes: dict, ids: dict, elements) -> dict:
        """Parents and children: space parts in their space, doors in their wall."""
        parent = {}
        for e in elements:
            if e.id() not in ids:
                continue
            sid = ids[e.id()]
            if e.is_a("IfcSpace"):
                agg = self.ue.get_aggregate(e)
                if agg is not None and agg.id() in ids:
                    parent[sid] = ids[agg.id()]
            elif e.is_a("IfcDoor") or e.is_a("IfcWindow") or e.is_a("IfcOpeningElement"):
                voided = [e] if e.is_a("IfcOpeningElement") else \
                    [rel.RelatingOpeningElement for rel in getattr(e, "FillsVoids", ()) or ()]
                for op in voided:
                    for vrel in getattr(op, "VoidsElements", ()) or ():
                        w = vrel.RelatingBuildingElement
                        parts = [w] + [x for r in getattr(w, "IsDecomposedBy", ()) or ()
                                       for x in r.RelatedObjects]
                        hit = [x for x in parts if x.id() in ids]  # an IfcRoof: the slab that is its part
                        if hit:
                            parent[sid] = ids[hit[0].id()]
        children = {}
        for c, pid in parent.items():
            children.setdefault(pid, []).append(c)
        out = {}
        for sid, s in shapes.items():
            changes = {}
            if sid in parent:
                changes["parent"] = parent[sid]
                if s.is_space and not self.ours:
                    changes["active"] = False
            if sid in children:
                changes["children"] = tuple(children[sid])
            out[sid] = s.with_(**changes) if changes else s
        return out

    # ------------------------------------------------------------------ element facts
    def _layer_thickness(self, e) -> Optional[float]:
        """Total thickness (m) of the element's material layer set, None without one."""
        try:
            m = self.ue.get_material(e, should_skip_usage=True)
        except Exception:  # odd material assignments: no layer thickness
            return None
        if m is None or not m.is_a("IfcMaterialLayerSet"):
            return None
        t = sum(float(x.LayerThickness or 0.0) for x in m.MaterialLayers or ()) * self.scale
        return t if t > 0 else None

    def _element_facts(self, shapes: dict, ids: dict, elements, info) -> dict:
        """Attributes of the walls, slabs, doors and windows of a foreign file (module doc)."""
        by_eid = {e.id(): e for e in elements}
        bounds = {}
        for b in self.f.by_type("IfcRelSpaceBoundary"):
            sp, el = b.RelatingSpace, b.RelatedBuildingElement
            if sp is not None and el is not None and sp.id() in ids and ids[sp.id()] in shapes:
                io = str(getattr(b, "InternalOrExternalBoundary", "") or "").upper()
                bounds.setdefault(el.id(), []).append((ids[sp.id()], io.startswith("EXTERNAL")))
        joins = {}
        for r in self.f.by_type("IfcRelConnectsPathElements"):
            a, b = r.RelatingElement, r.RelatedElement
            if a is None or b is None or a.id() not in ids or b.id() not in ids:
                continue
            ta = str(r.RelatingConnectionType or "NOTDEFINED")
            tb = str(r.RelatedConnectionType or "NOTDEFINED")
            joins.setdefault(ids[a.id()], []).append({"wall": ids[b.id()], "at": ta, "other_at": tb})
            joins.setdefault(ids[b.id()], []).append({"wall": ids[a.id()], "at": tb, "other_at": ta})
        out = dict(shapes)
        for eid, sid in ids.items():
            e, s = by_eid[eid], shapes[sid]
            att = dict(s.attributes)
            lo, hi = s.bounds
            if s.type == ShapeType.WALL:
                sc = s.scope
                att.setdefault("thickness", self._layer_thickness(e) or float(min(sc.size[0], sc.size[1])))
                att["height"] = float(hi[2] - lo[2])
                p0 = sc.origin + sc.axes[1] * sc.size[1] / 2
                p1 = p0 + sc.axes[0] * sc.size[0]
                if e.ObjectPlacement is not None:  # start -> end along the wall's own x axis
                    xdir = self.up.get_local_placement(e.ObjectPlacement)[:2, 0]
                    if float(xdir @ sc.axes[0, :2]) < 0:
                        p0, p1 = p1, p0
                att["axis_line"] = [[float(p0[0]), float(p0[1])], [float(p1[0]), float(p1[1])]]
                ext = self._pset(e, "Pset_WallCommon").get("IsExternal")
                if ext is None and eid in bounds:
                    ext = any(x for _, x in bounds[eid])
                if ext is not None:
                    att["external"] = bool(ext)
                att["joins"] = joins.get(sid, [])
            elif s.type == ShapeType.SLAB:
                agg = self.ue.get_aggregate(e)
                pt = str(getattr(e, "PredefinedType", "") or "").upper()
                roof = pt == "ROOF" or (agg is not None and agg.is_a("IfcRoof"))
                att.setdefault("kind", "roof" if roof else "base" if pt == "BASESLAB" else "floor")
                att.setdefault("thickness", self._layer_thickness(e) or float(hi[2] - lo[2]))
            out[sid] = s.with_(attributes=att)
        plans = {sid: _plan_polygon(s) for sid, s in shapes.items() if s.is_space}
        for eid, sid in ids.items():
            s = out[sid]
            if s.type in (ShapeType.DOOR, ShapeType.WINDOW):
                out[sid] = self._opening(by_eid[eid], s, out, plans, bounds.get(eid, []), info)
        return out

    def _opening(self, e, s: Shape, shapes: dict, plans: dict, bounds: list, info) -> Shape:
        """A door or window as its opening box in the host wall, with width, height, sill,
        kind and the spaces on either side."""
        att = dict(s.attributes)
        v = s.geometry.vertices
        z0, z1 = float(v[:, 2].min()), float(v[:, 2].max())
        host = shapes.get(s.parent)
        in_wall = host is not None and host.type == ShapeType.WALL
        sc = host.scope if in_wall else s.scope
        u, n = sc.axes[0, :2], sc.axes[1, :2]
        pu = v[:, :2] @ u
        width = float(att.get("width") or (pu.max() - pu.min()))
        height = float(att.get("height") or (z1 - z0))
        vn0 = float(sc.origin[:2] @ n)
        vn1 = vn0 + float(sc.size[1])
        cu = float(pu.max() + pu.min()) / 2
        if in_wall:
            ring = [u * a + n * b for a, b in ((cu - width / 2, vn0), (cu + width / 2, vn0),
                                               (cu + width / 2, vn1), (cu - width / 2, vn1))]
            geom = Polyhedron.prism(ring, z0, z0 + height)
        else:  # a roof light (in a slab) or an opening in nothing: its own box
            corners = ((0, 0), (sc.size[0], 0), (sc.size[0], sc.size[1]), (0, sc.size[1]))
            ring = [sc.origin[:2] + u * a + n * b for a, b in corners]
            geom = Polyhedron.prism(ring, z0, z1)
        floor = info[s.storey][0] if 0 <= s.storey < len(info) else 0.0
        att.update(width=width, height=height, sill=z0 - floor,
                   kind="window" if s.type == ShapeType.WINDOW else "opening" if e.is_a("IfcOpeningElement")
                   else "door")
        outside = next((x.id for x in shapes.values()
                        if x.type == ShapeType.EXTERIOR and x.storey == s.storey), f"exterior_s{s.storey}")
        external = any(x for _, x in bounds) or (in_wall and bool(host.attributes.get("external")))
        centre = u * cu + n * (vn0 + vn1) / 2
        zmid = z0 + min(height, z1 - z0) / 2

        def near(sid, probe):
            sh, pl = shapes[sid], plans.get(sid)
            if pl is None or not sh.bounds[0, 2] - 0.5 < zmid < sh.bounds[1, 2] + 0.5:
                return np.inf
            return float(pl.distance(Point(probe)))

        if in_wall:
            reach = (vn1 - vn0) / 2 + self.params.opening_side_reach
            probes = [centre + n * (vn1 - vn0) / 2, centre - n * (vn1 - vn0) / 2]

            def pick(cands, k):
                d = {sid: near(sid, probes[k]) for sid in cands}
                d = {sid: x for sid, x in d.items() if x <= reach and x <= near(sid, probes[1 - k])}
                return min(d, key=d.get) if d else None

            named = list(dict.fromkeys(sid for sid, _ in bounds))
            found = [pick(named, 0), pick(named, 1)]
            if found == [None, None] or not external:  # a missing boundary: the space by geometry
                rooms = [sid for sid, sh in shapes.items() if sh.type == ShapeType.INTERIOR]
                found = [f if f is not None else pick(rooms, k) for k, f in enumerate(found)]
            if found[0] is not None and found[0] == found[1]:
                found[1] = None
            sides = [x for x in found if x is not None]
            if len(sides) < 2 and external:
                sides.append(outside)
        else:
            below = [sid for sid, pl in plans.items() if shapes[sid].type == ShapeType.INTERIOR
                     and pl.contains(Point(centre))
                     and shapes[sid].bounds[0, 2] < z0 <= shapes[sid].bounds[1, 2] + 0.5]
            sides = below[:1] + [outside]
        att["spaces"] = sides
        return s.with_(geometry=geom, scope=None, attributes=att)

    # ------------------------------------------------------------------ topology
    def _relations(self, ids: dict, shapes: dict) -> list:
        f = self.f
        bounds = list(f.by_type("IfcRelSpaceBoundary"))
        by_elem = {}
        paired = any(getattr(b, "CorrespondingBoundary", None) is not None for b in bounds)
        rel = []
        for b in bounds:
            sp, el = b.RelatingSpace, b.RelatedBuildingElement
            if sp is None or el is None or sp.id() not in ids:
                continue
            by_elem.setdefault(el.id(), {})[ids[sp.id()]] = b
        for eid, spaces in by_elem.items():
            el = f.by_id(eid)
            if el.is_a("IfcVirtualElement"):
                kinds = self._pset(el, PSET_SHAPE).get("RelationKinds") or "adjacency,connectivity"
                kinds = kinds.split(",")
                via = None
            elif el.is_a("IfcDoor") or el.is_a("IfcOpeningElement"):
                kinds, via = ("connectivity",), ids.get(eid)
            elif el.is_a("IfcWindow"):  # a window joins no spaces
                continue
            else:
                kinds, via = ("adjacency",), ids.get(eid)
                if via is None:  # an element we did not read (a column, a window, ...)
                    continue
            pairs = set()
            if paired:
                for a, b in spaces.items():
                    cb = getattr(b, "CorrespondingBoundary", None)
                    if cb is not None and cb.RelatingSpace is not None and cb.RelatingSpace.id() in ids:
                        other = ids[cb.RelatingSpace.id()]
                        if other != a:
                            pairs.add(tuple(sorted((a, other))))
            else:
                names = sorted(spaces)
                sides = [x for x in (shapes[via].attributes.get("spaces") or ()) if x in spaces] \
                    if kinds == ("connectivity",) and via in shapes else []
                if len(names) > 2 and len(sides) == 2:
                    # a door joins the two spaces on its two sides: a third space whose
                    # boundary also names it (the Duplex's utility door lists the hallway
                    # 13 cm past its end) is not reached through it
                    names = sorted(sides)
                for i in range(len(names)):
                    for j in range(i + 1, len(names)):
                        if kinds == ("adjacency",) and via in shapes and \
                                not _opposite_sides(shapes[via], shapes[names[i]], shapes[names[j]]):
                            continue
                        pairs.add((names[i], names[j]))
            for a, b in sorted(pairs):
                for k in kinds:
                    if k:
                        rel.append(Relation(k.strip(), a, b, via))
        return rel


def _doorless_openings(f) -> list:
    """Openings that void a wall and hold no door or window: doorless passages."""
    out = []
    for op in f.by_type("IfcOpeningElement"):
        if getattr(op, "HasFillings", None) or str(getattr(op, "PredefinedType", "") or "").upper() == "RECESS":
            continue
        if any(v.RelatingBuildingElement is not None and v.RelatingBuildingElement.is_a("IfcWall")
               for v in getattr(op, "VoidsElements", ()) or ()):
            out.append(op)
    return out


def _opposite_sides(wall: Shape, a: Shape, b: Shape) -> bool:
    """True when the centroids of ``a`` and ``b`` lie on opposite sides of ``wall``'s thin axis."""
    sc = wall.scope
    n = sc.axes[int(np.argmin(sc.size[:2]))]
    c = sc.center
    sa = float((a.centroid - c) @ n)
    sb = float((b.centroid - c) @ n)
    return sa * sb < 0


def _weighted_median(values, weights) -> float:
    """The value at half of the total weight (values sorted; the upper one at a tie)."""
    order = np.argsort(values, kind="stable")
    w = np.cumsum(np.asarray(weights, dtype=np.float64)[order])
    return float(np.asarray(values, dtype=np.float64)[order][int(np.searchsorted(w, w[-1] / 2))])


def _plan_polygon(s: Shape):
    """The shape's plan outline: its prism footprint, else the union of its projected triangles."""
    fp = s.footprint()
    if fp is not None:
        return Polygon(fp)
    v, tri = s.geometry.triangles()
    parts = [Polygon(v[t, :2]) for t in tri]
    return unary_union([p for p in parts if p.area > 1e-9]).buffer(0)


# --------------------------------------------------------------------------- meshes
def _polyhedron(v: np.ndarray, tri: np.ndarray, prm: IfcReadParams) -> Optional[Polyhedron]:
    """A vertical prism when the triangle mesh is one, else the triangles themselves."""
    if len(tri) == 0:
        return None
    cross = lambda t: np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])  # noqa: E731
    tri = tri[np.linalg.norm(cross(tri), axis=1) > _MIN_DOUBLE_AREA]
    if len(tri) == 0:
        return None
    tri = orient_outward(v, tri)  # some IFC solids wind faces inwards
    cr = cross(tri)
    area2 = np.linalg.norm(cr, axis=1)
    prism = _as_prism(v, tri, cr / area2[:, None], area2 / 2, prm)
    if prism is not None:
        return prism
    used = np.unique(tri)
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return Polyhedron(v[used], [tuple(t) for t in remap[tri]])


def _as_prism(v, tri, normals, areas, prm: IfcReadParams) -> Optional[Polyhedron]:
    tol = prm.prism_tol
    z = v[np.unique(tri), 2]
    zmin, zmax = z.min(), z.max()
    h = zmax - zmin
    if h <= tol or not np.all((z - zmin < tol) | (zmax - z < tol)):
        return None
    nz = normals[:, 2]
    top, bottom, side = nz > 1 - tol, nz < -(1 - tol), np.abs(nz) < tol
    if not np.all(top | bottom | side):
        return None
    up = unary_union([Polygon(v[t, :2]) for t in tri[top]]).buffer(0)
    down = unary_union([Polygon(v[t, :2]) for t in tri[bottom]]).buffer(0)
    if up.geom_type != "Polygon" or len(up.interiors) or up.area <= 0:
        return None
    rt = prm.prism_area_rtol
    if abs(down.area - up.area) > rt * up.area or up.symmetric_difference(down).area > rt * up.area:
        return None
    if abs(areas[side].sum() - up.length * h) > rt * up.length * h:
        return None
    ring = np.asarray(up.simplify(tol).exterior.coords)[:-1]
    if len(ring) < 3:
        return None
    return Polyhedron.prism(ring, zmin, zmax)
