"""BuildingModel → IFC4 (or IFC4X3), written with ifcopenshell and in bulk.

The file follows the "simple model from scratch" recipe of IfcOpenShell: project, SI units,
representation contexts (Model/Body, Model/Axis, Model/FootPrint), then the spatial tree
site → building → storeys → spaces, then the elements an architect's tool (Bonsai, Revit)
edits:

* ``IfcSpace`` per interior space (with ``IfcWriteParams.parts``, a merged space also
  aggregates its parts as ``PARTIAL`` sub-spaces); one ``IfcExternalSpatialElement`` per
  storey holding all of its exterior shapes (one body item each);
* ``IfcWall`` (``SOLIDWALL``) placed on its axis (local x along the attribute ``axis_line``
  or the scope's long side), with an Axis and a Body, ``Pset_WallCommon.IsExternal`` and one
  material layer (``IfcMaterialLayerSetUsage`` AXIS2, POSITIVE, offset −thickness/2: the
  layer is centred on the axis) from an ``IfcWallType`` per material and thickness;
  ``IfcRelConnectsPathElements`` for the wall joins (attribute ``joins``, each pair once);
* ``IfcSlab`` (FLOOR / ROOF / BASESLAB from the attribute ``kind``), ``Pset_SlabCommon``,
  one layer (AXIS3 from its bottom) from an ``IfcSlabType``;
* ``IfcDoor`` / ``IfcWindow`` filling an ``IfcOpeningElement`` that voids its wall, with an
  ``IfcDoorType`` / ``IfcWindowType`` per width × height; a doorless opening (a door of
  ``kind`` "opening") is the ``IfcOpeningElement`` alone: the hole without a filling;
* ``IfcRelSpaceBoundary2ndLevel`` pairs (``CorrespondingBoundary``) for the adjacency and
  connectivity relations and the windows between two spaces, with the wall's boundary as the
  ``ParentBoundary`` of a door's or window's (PHYSICAL) or a doorless opening's (VIRTUAL, on
  the ``IfcOpeningElement``); ``IfcVirtualElement`` for open plans between interior spaces;
  one-sided boundaries for walls and slabs touching a space (see
  :class:`engine.ifc.writer_geometry.BoundaryWriter`);
* base quantities (``Qto_*BaseQuantities``), the property sets ``Indoor_Provenance``
  (project), ``Indoor_Shape`` (``Confidence`` 0–1 where the shape has one: rooms seen only
  partly, detected openings) and ``Indoor_Support`` (products), ``Indoor_Storey``;
* colours by type (surface styles).

Geometry is written in the model's original frame: the site placement carries
``model.offset`` and the rigid ``model.transform`` (a non-rigid transform is applied to the
vertices instead), so world coordinates in the file are ``p_file = T p_model + offset``.
Placements below the site are translations, turned about z for walls and what sits in them
(openings, doors, windows: local x along the wall).

The output is reproducible: every GlobalId is derived from the model's seed, its name and
the entity's identity (:func:`engine.ifc.common.global_id`: a shape id, a role such as
``"opening"`` or ``"pset"``, the ids a relationship joins, a type's size), the relationships
are created here in a fixed order and in bulk (``ifcopenshell.api`` orders products through
Python sets of entity instances, whose hashes depend on everything the process made before),
and the ``SOURCE_DATE_EPOCH`` environment variable fixes the time stamps. The same model
therefore gives the same file byte for byte, apart from the header time stamp when that
variable is not set. Text from the model (names, file names) with undecodable bytes is
written with backslash escapes.

Units, contexts, styles and element types go through ``ifcopenshell.api``; products,
relationships, property and quantity sets (:mod:`engine.ifc.properties`) and space boundaries
are created directly, the same entities without the api's generic machinery (its property
sets load buildingSMART's templates, 50 ms a file): 0.46 → 0.25 s for a 100k-point office.
"""
from __future__ import annotations

import errno
import logging
import os
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..errors import InputError, OutputError
from ..fileutil import atomic_path
from ..geometry.transforms import apply_transform, is_rigid
from ..model import BuildingModel, Polyhedron, Shape, ShapeType
from ..progress import Progress
from .common import (PSET_PROVENANCE, PSET_SHAPE, PSET_STOREY, PSET_SUPPORT, SLAB_MATERIALS, WRITABLE_SCHEMAS,
                     WRITER_MODULES, connection_type, dumps, global_id, iso_timestamp, millimetres,
                     require_ifcopenshell, safe_text, source_date_epoch)
from .properties import PropertyWriter
from .writer_geometry import (BoundaryWriter, axis2, axis_line, clean_ring, default_storeys, door_size,
                              opening_geometry, polyline, slab_opening_geometry, slab_type, solid,
                              union_rings, wall_frame)

__all__ = ["IfcWriteParams", "write_ifc", "build_ifc", "TYPE_COLOURS"]

log = logging.getLogger(__name__)

TYPE_COLOURS = {
    ShapeType.INTERIOR: ((0.55, 0.75, 0.95), 0.7),
    ShapeType.EXTERIOR: ((0.60, 0.85, 0.55), 0.85),
    ShapeType.WALL: ((0.85, 0.83, 0.78), 0.0),
    ShapeType.SLAB: ((0.62, 0.62, 0.65), 0.0),
    ShapeType.DOOR: ((0.65, 0.42, 0.22), 0.0),
    ShapeType.WINDOW: ((0.62, 0.82, 0.95), 0.6),
}
"""Surface colour (red, green, blue in 0..1) and transparency (0 opaque .. 1 clear) per type."""

_I3 = np.eye(3)

@dataclass(frozen=True)
class IfcWriteParams:
    """Parameters of :func:`write_ifc` (SI units)."""

    opening_margin: float = 0.01
    """How far (m) a door's or window's opening reaches beyond each face of its wall, so the
    void cuts cleanly through coplanar faces."""
    boundary_gap: float = 0.05
    """Largest distance (m) between a space face and an element face that still bound each
    other (the faces must also be anti-parallel)."""
    boundary_cos: float = 0.996
    """Anti-parallel test for bounding faces: ``-n_space · n_element`` must reach this
    (cos 5°)."""
    min_boundary_area: float = 1e-3
    """Smallest common face area (m²) written as a space boundary."""
    rigid_tol: float = 1e-6
    """Tolerance on ``RᵀR = I`` for the model transform to go into the site placement."""
    parts: bool = False
    """Also write the parts of merged spaces (the grammar's cuboids and cells) as ``PARTIAL``
    IfcSpace under their space; by default one IfcSpace per room, as area schedules expect."""
    geometric_boundaries: bool = True
    """Also write one-sided boundaries for walls and slabs touching a space without a relation."""
    georeference: str = "placement"
    """Where ``model.offset`` goes: ``"placement"`` (the site's placement: world coordinates
    in the file are the original ones) or ``"map_conversion"`` (an ``IfcMapConversion``
    with Eastings, Northings, OrthogonalHeight = offset; placements stay near the origin)."""
    crs_name: str = "LOCAL"
    """Name of the ``IfcProjectedCRS`` target of the map conversion (e.g. "EPSG:25832");
    the offset's coordinate system is not known to the engine."""
    type_step: float = 0.001
    """Sizes (m) of element types are rounded to this: walls and slabs of one rounded
    thickness share a type and its layer set, doors and windows of one width × height a type."""


def _untimed(value):
    """``value`` (JSON-like) without the keys that hold run times ("seconds", "timings"): they
    differ run to run, and the IFC depends on the scan and the seed alone."""
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if k not in ("seconds", "timings")}
    if isinstance(value, (list, tuple)):
        return [_untimed(v) for v in value]
    return value


# --------------------------------------------------------------------------- public API
def _confidence(v) -> Optional[float]:
    """A shape's confidence attribute clipped to 0–1; None when it has none."""
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))
    return min(max(float(v), 0.0), 1.0) if ok else None


def write_ifc(model: BuildingModel, path: str | os.PathLike, *, schema: str = "IFC4",
              params: Optional[IfcWriteParams] = None, progress=None, should_stop=None) -> str:
    """Write ``model`` as an IFC file at ``path`` (temporary name, then moved into place).

    Parameters
    ----------
    model : BuildingModel
        Geometry in metres in the model (aligned) frame; ``model.transform`` and
        ``model.offset`` give the original frame the file is written in.
    path : str or path-like
        Output file (``.ifc``); its folder is created when missing.
    schema : {"IFC4", "IFC4X3"}
    params : IfcWriteParams, optional
    progress, should_stop : callbacks, see :class:`engine.progress.Progress`.

    Returns
    -------
    str — the path written.

    Raises
    ------
    InputError — unsupported schema, or a model with nothing to write.
    OutputError — the file cannot be written (full disk, read-only folder, ...); nothing is
    left in the folder and an existing file at ``path`` is unchanged.
    """
    path = os.fsdecode(os.fspath(path))
    f = build_ifc(model, schema=schema, params=params, progress=progress, should_stop=should_stop,
                  path=path)
    # serialised here and written by Python (not ``f.write``): an OS error keeps its cause
    # (ifcopenshell reports "An unknown error occurred") and names with undecodable bytes work
    data = f.to_string().encode("utf-8")
    try:
        with atomic_path(path, suffix=".ifc") as tmp:
            with open(tmp, "wb") as fh:
                fh.write(data)
    except OSError as e:
        if isinstance(e, OutputError):
            raise
        why = e.strerror or str(e)
        if e.errno in (errno.EEXIST, errno.ENOTDIR):
            why = f"a part of the folder path is a file ({why})"
        elif e.errno == errno.EISDIR:
            why = "it is a folder"
        raise OutputError(f"cannot write the IFC file: {why}", path) from e
    if log.isEnabledFor(logging.INFO):
        log.info("wrote %s (%d entities, %d bytes)", path, len(list(f)), len(data))
    return path


def build_ifc(model: BuildingModel, *, schema: str = "IFC4", params: Optional[IfcWriteParams] = None,
              progress=None, should_stop=None, path: Optional[str] = None):
    """Build the ``ifcopenshell.file`` that :func:`write_ifc` writes (nothing is written).

    ``path`` is the file it is meant for: errors name it and the header's FILE_NAME gives its
    base name.
    """
    require_ifcopenshell("writing IFC")
    schema = str(schema).upper()
    if schema not in WRITABLE_SCHEMAS:
        raise InputError(f"cannot write IFC schema {schema!r}; choose one of {list(WRITABLE_SCHEMAS)}", path)
    if not any(s.type != ShapeType.NONE for s in model.shapes):
        raise InputError("the model has no shapes to write", path)
    p = Progress.wrap(progress, should_stop)
    params = params or IfcWriteParams()
    if params.georeference not in ("placement", "map_conversion"):
        raise InputError(f"georeference must be 'placement' or 'map_conversion', not {params.georeference!r}",
                         path)
    f = _Writer(model, schema, params, p).run()
    f.header.file_name.name = safe_text(os.path.basename(os.fsdecode(path))) if path else ""
    return f


# --------------------------------------------------------------------------- writer
class _Writer(BoundaryWriter, PropertyWriter):
    def __init__(self, model: BuildingModel, schema: str, params: IfcWriteParams, p):
        import importlib

        for name in WRITER_MODULES:  # sub-modules load on import
            importlib.import_module(name)
        import ifcopenshell

        self.api = ifcopenshell.api
        self.model = model
        self.schema = schema
        self.params = params
        self.p = p
        self.f = ifcopenshell.api.project.create_file(version=schema)
        self.origin = {}  # ifc entity id -> (3,) absolute placement origin in the model frame
        self.ent = {}  # shape id -> ifc product
        self.geom = {}  # shape id -> Polyhedron in the written frame
        self.styles = {}
        self.contained = {}  # storey entity id -> list of products
        self.tables = {}  # id(Polyhedron) -> face normals and vertices (see face_table)
        self.storey_list = list(model.storeys) or default_storeys(model)
        self.keys = {}  # ifc entity id -> GlobalId key (see _own)
        self.owners = {}  # GlobalId key -> ifc entity id
        self.seed = model.provenance.seed
        self.epoch = source_date_epoch()
        self.bake = None  # non-rigid model transform applied to the vertices, else None
        self.rot = {}  # ifc entity id -> (3, 3) absolute rotation of its placement (identity if absent)
        self.canon = {}  # exterior shape id -> shape id of the IfcExternalSpatialElement holding it
        self.types = {}  # type key -> {"type", "objects", "set", "usages"} (see _typed)
        self.materials = {}  # material name -> IfcMaterial
        self.faces = {}  # boundary entity id -> (boundary, common face, space entity)
        self.holes = {}  # boundary entity id -> [(k, 3) faces of the doors and windows in it]
        self.wall_b = {}  # (space id, wall id[, partner id]) -> that wall's boundary of the space

    # ------------------------------------------------------------------ identity
    def _own(self, entity, key: tuple):
        """Give ``entity`` (an IfcRoot) the GlobalId of ``key`` (see :func:`global_id`).

        Keys are unique in the file: two entities with one key is a bug of the writer.
        """
        eid = entity.id()
        old = self.keys.get(eid)
        if old is not None:
            if old != key:
                raise RuntimeError(f"IFC entity #{eid} got two GlobalId keys: {old!r} and {key!r}")
            return entity
        other = self.owners.get(key)
        if other is not None and other != eid:
            raise RuntimeError(f"IFC entities #{other} and #{eid} share the GlobalId key {key!r}")
        self.keys[eid] = key
        self.owners[key] = eid
        entity.GlobalId = self._gid(key)
        return entity

    def _gid(self, key: tuple) -> str:
        return global_id(self.seed, self.model.name, key)

    def _key(self, entity) -> tuple:
        return self.keys[entity.id()]

    def _root(self, ifc_class: str, key: tuple, name=None, predefined_type=None):
        """An IfcRoot with the GlobalId of ``key``, the owner history, a safe ``name`` and
        ``predefined_type``; element types through ``api.root.create_entity`` (it gives them
        their defaults), the rest directly (the same entity, 5x faster)."""
        name = None if name is None else safe_text(name) or None
        if ifc_class.endswith("Type"):
            e = self.api.root.create_entity(self.f, ifc_class=ifc_class, name=name,
                                            predefined_type=predefined_type)
        else:
            e = self.f.create_entity(ifc_class, GlobalId=self._gid(key), OwnerHistory=self._history(),
                                     Name=name)
            if predefined_type:
                e.PredefinedType = predefined_type
        return self._own(e, key)

    def _history(self):
        """The owner history ifcopenshell.api gives new entities (None unless an application,
        e.g. Bonsai, has configured a user and an application): one for the whole file."""
        if not hasattr(self, "_owner_history"):
            self._owner_history = self.api.owner.create_owner_history(self.f)
        return self._owner_history

    def _aggregate(self, relating, products):
        """IfcRelAggregates of ``products`` (in this order) under ``relating``."""
        return self._rel("IfcRelAggregates", (self._key(relating), "aggregates"), RelatingObject=relating,
                         RelatedObjects=list(products))

    def _contain(self, structure, products):
        """IfcRelContainedInSpatialStructure of ``products`` (in this order) in ``structure``."""
        return self._rel("IfcRelContainedInSpatialStructure", (self._key(structure), "contains"),
                         RelatedElements=list(products), RelatingStructure=structure)

    def _finish(self):
        """Check that every IfcRoot has its GlobalId; fix the time stamps."""
        f = self.f
        gids = set()
        for e in sorted(f.by_type("IfcRoot"), key=lambda e: e.id()):
            if e.id() not in self.keys:
                raise RuntimeError(f"IFC entity {e.is_a()} #{e.id()} has no GlobalId key "
                                   "(a bug of the writer)")
            gids.add(e.GlobalId)
        if len(gids) != len(self.keys):
            raise RuntimeError("two IFC entities share a GlobalId (a bug of the writer)")
        f.header.file_name.time_stamp = iso_timestamp(self.epoch)
        if self.epoch is not None:
            for oh in f.by_type("IfcOwnerHistory"):
                oh.CreationDate = self.epoch
                if oh.LastModifiedDate is not None:
                    oh.LastModifiedDate = self.epoch

    # ------------------------------------------------------------------ frame
    def _frame(self):
        m = self.model
        t = np.asarray(m.transform, dtype=np.float64)
        in_site = self.params.georeference == "placement"
        if is_rigid(t, self.params.rigid_tol):
            site = t.copy()
            bake = None
        else:
            log.warning("model transform is not rigid: applying it to the vertices")
            site = np.eye(4)
            bake = t
        self.bake = bake
        if in_site:
            site[:3, 3] += m.offset
        self.site_matrix = site
        for s in m.shapes:
            g = s.geometry
            if bake is not None:
                g = Polyhedron(apply_transform(bake, g.vertices), g.faces)
            self.geom[s.id] = g
        self.storey_z = []
        for st in self.storey_list:
            z = st.floor_z if bake is None else float((bake @ [0.0, 0.0, st.floor_z, 1.0])[2])
            self.storey_z.append(z)

    # ------------------------------------------------------------------ helpers
    def _placement(self, entity, parent, origin, rot=None):
        """Local placement of ``entity`` at absolute model-frame ``origin`` turned by ``rot``
        (3, 3) (None: not turned), relative to ``parent``."""
        origin = np.asarray(origin, dtype=np.float64)
        rot = _I3 if rot is None else np.asarray(rot, dtype=np.float64)
        rel_to, rel, rrel = None, origin, rot
        if parent is not None:
            rel_to = parent.ObjectPlacement
            rel = origin - self.origin[parent.id()]
            prot = self.rot.get(parent.id())
            if prot is not None:
                rel, rrel = prot.T @ rel, prot.T @ rot
        turned = not np.allclose(rrel, _I3, rtol=0.0, atol=1e-12)
        entity.ObjectPlacement = self.f.createIfcLocalPlacement(
            rel_to, axis2(self.f, rel, rrel[:, 2] if turned else None, rrel[:, 0] if turned else None))
        self.origin[entity.id()] = origin
        if not np.allclose(rot, _I3, rtol=0.0, atol=1e-12):
            self.rot[entity.id()] = rot

    def _style(self, shape_type):
        if shape_type not in self.styles:
            rgb, transparency = TYPE_COLOURS[shape_type]
            st = self.api.style.add_style(self.f, name=f"Indoor {shape_type.value}")
            self.api.style.add_surface_style(
                self.f, style=st, ifc_class="IfcSurfaceStyleShading",
                attributes={"SurfaceColour": {"Name": None, "Red": rgb[0], "Green": rgb[1], "Blue": rgb[2]},
                            "Transparency": transparency})
            self.styles[shape_type] = st
        return self.styles[shape_type]

    def _body(self, product, g: Polyhedron, shape_type, origin, extra=(), rot=None, geoms=None):
        """Body (and ``extra`` representations) of ``product``: ``g``, or one item per
        polyhedron of ``geoms``, in the frame at ``origin`` turned by ``rot``."""
        items = [solid(self.f, x, origin, rot) for x in (geoms or [g])]
        kinds = {t for _, t in items}
        rtype = kinds.pop() if len(kinds) == 1 else "SolidModel"
        rep = self.f.createIfcShapeRepresentation(self.body, "Body", rtype, [i for i, _ in items])
        self.api.style.assign_representation_styles(self.f, shape_representation=rep,
                                                    styles=[self._style(shape_type)])
        product.Representation = self.f.createIfcProductDefinitionShape(None, None, [rep] + list(extra))
        return rtype

    def _rel(self, ifc_class, key, **attributes):
        """A relationship entity with the GlobalId of ``key`` (created directly, in bulk)."""
        e = self.f.create_entity(ifc_class, GlobalId=self._gid(key), OwnerHistory=self._history(), **attributes)
        return self._own(e, key)

    # ------------------------------------------------------------------ run
    def run(self):
        api, f, m, p = self.api, self.f, self.model, self.p
        self._frame()
        p(0.02, "project")
        project = self._root("IfcProject", ("project",), name=m.name or "Indoor model")
        length = api.unit.add_si_unit(f, unit_type="LENGTHUNIT")
        area = api.unit.add_si_unit(f, unit_type="AREAUNIT")
        volume = api.unit.add_si_unit(f, unit_type="VOLUMEUNIT")
        angle = api.unit.add_si_unit(f, unit_type="PLANEANGLEUNIT")
        # not api.unit.assign_unit: it orders the units through a set
        project.UnitsInContext = f.createIfcUnitAssignment([length, area, volume, angle])
        model_ctx = api.context.add_context(f, context_type="Model")
        self.body = api.context.add_context(f, context_type="Model", context_identifier="Body",
                                            target_view="MODEL_VIEW", parent=model_ctx)
        self.axis = api.context.add_context(f, context_type="Model", context_identifier="Axis",
                                            target_view="GRAPH_VIEW", parent=model_ctx)
        self.footprint = api.context.add_context(f, context_type="Model", context_identifier="FootPrint",
                                                 target_view="SKETCH_VIEW", parent=model_ctx)
        if self.params.georeference == "map_conversion":
            import ifcopenshell.api.georeference  # noqa: F401

            api.georeference.add_georeferencing(f, ifc_class="IfcMapConversion",
                                                name=safe_text(self.params.crs_name))
            e, n, h = (float(c) for c in m.offset)
            api.georeference.edit_georeferencing(
                f, coordinate_operation={"Eastings": e, "Northings": n, "OrthogonalHeight": h})
        self._provenance(project)

        site = self._root("IfcSite", ("site",), name="Site")
        sm = self.site_matrix
        site.ObjectPlacement = f.createIfcLocalPlacement(None, axis2(f, sm[:3, 3], sm[:3, 2], sm[:3, 0]))
        self.origin[site.id()] = np.zeros(3)
        self._aggregate(project, [site])
        building = self._root("IfcBuilding", ("building",), name=m.name or "Building")
        self._placement(building, site, np.zeros(3))
        self._aggregate(site, [building])
        self.site, self.building = site, building

        self.storeys = []
        for i, st in enumerate(self.storey_list):
            e = self._root("IfcBuildingStorey", ("storey", i), name=st.name or f"Storey {i}")
            e.Elevation = float(st.elevation if st.elevation is not None else self.storey_z[i])
            e.CompositionType = "ELEMENT"
            self._placement(e, building, (0.0, 0.0, self.storey_z[i]))
            self._pset(e, PSET_STOREY, {"Index": int(st.index), "FloorZ": float(st.floor_z),
                                        "CeilingZ": float(st.ceiling_z)})
            self.storeys.append(e)
        if self.storeys:
            self._aggregate(building, self.storeys)
        p(0.1, "spaces")
        self._spaces()
        p.check()
        p(0.35, "walls and slabs")
        self._elements()
        self._joins()
        p.check()
        p(0.6, "doors and windows")
        self._openings()
        p.check()
        p(0.7, "space boundaries")
        self._boundaries()
        for sid, products in self.contained.items():
            self._contain(f.by_id(sid), products)
        self._write_types()
        self._finish()
        p(1.0, "IFC built")
        return f

    def _provenance(self, project):
        """How the model was made. Only what the input and the seed determine: the timings
        stay in the JSON report, so the same scan and seed give the same IFC."""
        pv = self.model.provenance
        self._pset(project, PSET_PROVENANCE, {
            "Method": pv.method or None,
            "Seed": None if pv.seed is None else int(pv.seed),
            "Parameters": dumps(pv.parameters),
            "Trace": dumps(_untimed(pv.trace)) if pv.trace else None,
            "Source": pv.source or None,
            "Software": pv.software or None,
            "ModelName": self.model.name or None,
            "Transform": dumps(np.asarray(self.model.transform)),
            "Offset": dumps(np.asarray(self.model.offset)),
            "OffsetIn": self.params.georeference,
            "StoreyCount": len(self.storey_list),
        })

    def _writable(self, s: Shape) -> bool:
        """Spaces (active or parts) and active walls, slabs, doors, windows with a closed geometry."""
        g = s.geometry
        if len(g.faces) < 4 or len(g.vertices) < 4 or g.volume() <= 0:
            log.warning("shape %s has no closed geometry: not written", s.id)
            return False
        if not s.active and (not s.is_space or not self.params.parts):
            log.debug("inactive %s %s not written", s.type.value, s.id)
            return False
        return True

    def _container_of(self, s: Shape):
        if 0 <= s.storey < len(self.storeys):
            return self.storeys[s.storey]
        return self.building

    def _shape_psets(self, e, s: Shape, merged=None):
        """``Indoor_Shape`` (``merged``: the ids of all the shapes ``e`` holds) and ``Indoor_Support``."""
        self._pset(e, PSET_SHAPE, {
            "MergedShapeIds": dumps(merged) if merged else None,
            "ShapeId": s.id, "ShapeType": s.type.value, "Active": bool(s.active),
            "Terminal": bool(s.terminal), "StoreyIndex": int(s.storey),
            "Grid": None if s.grid is None else dumps(s.grid),
            "Attributes": dumps(s.attributes) if s.attributes else None,
            "Log": "\n".join(s.log) if s.log else None,
            "Confidence": _confidence(s.attributes.get("confidence")),  # 0-1, for schedules and filters
        })
        if s.support:
            self._pset(e, PSET_SUPPORT, {k: float(v) for k, v in s.support.items()})

    @staticmethod
    def _origin_of(g):
        """Bottom centre of the bounds of ``g`` (a Polyhedron, or its (2, 3) bounds)."""
        b = g.bounds if isinstance(g, Polyhedron) else g
        return np.array([(b[0, 0] + b[1, 0]) / 2, (b[0, 1] + b[1, 1]) / 2, b[0, 2]])

    # ------------------------------------------------------------------ spaces
    def _spaces(self):
        f, m = self.f, self.model
        spaces = [s for s in m.shapes
                  if s.type in (ShapeType.INTERIOR, ShapeType.EXTERIOR) and self._writable(s)]
        # parents before their parts
        order = {s.id: 0 for s in spaces}
        for s in spaces:
            d, q = 0, s
            while q.parent is not None and q.parent in m and m[q.parent].is_space and d < len(spaces):
                d, q = d + 1, m[q.parent]
            order[s.id] = d
        spaces.sort(key=lambda s: order[s.id])
        # one IfcExternalSpatialElement per storey: "exterior_s<k>" (else the first) holds the others
        groups = {}
        for s in spaces:
            if s.type == ShapeType.EXTERIOR and s.active:
                groups.setdefault(s.storey, []).append(s)
        members = {}
        for k, group in groups.items():
            rep = next((x for x in group if x.id == f"exterior_s{k}"), group[0])
            members[rep.id] = group
            self.canon.update({x.id: rep.id for x in group})
        agg = {}
        for s in spaces:
            if self.canon.get(s.id, s.id) != s.id:
                continue
            group = members.get(s.id, [s])
            geoms = [self.geom[x.id] for x in group]
            g = self.geom[s.id]
            if s.type == ShapeType.INTERIOR:
                e = self._root("IfcSpace", ("shape", s.id), predefined_type="SPACE", name=s.name or s.id)
                e.LongName = safe_text(s.name) if s.name else None
                e.CompositionType = "ELEMENT" if s.active else "PARTIAL"
            else:
                e = self._root("IfcExternalSpatialElement", ("shape", s.id), predefined_type="EXTERNAL",
                               name=s.name or s.id)
            parent = self.ent.get(s.parent) if s.parent is not None else None
            if parent is None or not parent.is_a("IfcSpace"):
                parent = self._container_of(s)
            b = np.array([x.bounds for x in geoms])
            origin = self._origin_of(np.array([b[:, 0].min(axis=0), b[:, 1].max(axis=0)]))
            self._placement(e, parent, origin)
            fps = [x.footprint() for x in geoms]
            rings = [fps[0]] if len(fps) == 1 and fps[0] is not None else union_rings(fps)
            rings = [r for r in (clean_ring(r - origin[:2]) for r in rings) if r is not None]
            extra = []
            if rings:
                curves = f.createIfcGeometricCurveSet([polyline(f, r) for r in rings])
                extra.append(f.createIfcShapeRepresentation(self.footprint, "FootPrint", "GeometricCurveSet",
                                                            [curves]))
            self._body(e, g, s.type, origin, extra, geoms=geoms)
            agg.setdefault(parent.id(), []).append(e)
            self.ent.update({x.id: e for x in group})
            self._shape_psets(e, s, merged=[x.id for x in group] if len(group) > 1 else None)
            if s.type == ShapeType.INTERIOR:
                zmin, zmax = g.bounds[:, 2]
                fa, per = g.plan_area_perimeter()
                vol = g.volume()
                self._qto(e, "Qto_SpaceBaseQuantities", {
                    "Height": zmax - zmin, "GrossFloorArea": fa, "NetFloorArea": fa, "GrossPerimeter": per,
                    "GrossVolume": vol, "NetVolume": vol})
        for pid, products in agg.items():
            self._aggregate(f.by_id(pid), products)

    # ------------------------------------------------------------------ walls, slabs
    def _elements(self):
        f, m = self.f, self.model
        holes_of = {}
        for d in m.shapes:
            if d.type in (ShapeType.DOOR, ShapeType.WINDOW) and d.parent is not None and d.active:
                holes_of.setdefault(d.parent, []).append(d)
        for s in m.shapes:
            if s.type not in (ShapeType.WALL, ShapeType.SLAB) or not self._writable(s):
                continue
            g = self.geom[s.id]
            zmin, zmax = g.bounds[:, 2]
            vol = g.volume()
            container = self._container_of(s)
            size = np.sort(s.scope.size[:2])
            if s.type == ShapeType.WALL:
                external = bool(s.attributes.get("external", s.attributes.get("exterior", False)))
                thick = float(s.attributes.get("thickness", size[0]))
                axis = axis_line(s, self.bake)
                frame = None if axis is None else wall_frame(axis, float(zmin))
                e = self._root("IfcWall", ("shape", s.id), predefined_type="SOLIDWALL", name=s.name or s.id)
                extra = []
                if frame is not None:
                    origin, rot, length = frame
                    extra.append(f.createIfcShapeRepresentation(
                        self.axis, "Axis", "Curve2D", [polyline(f, [(0.0, 0.0), (length, 0.0)], closed=False)]))
                else:
                    origin, rot, length = self._origin_of(g), None, float(size[1])
                self._placement(e, container, origin, rot)
                self._body(e, g, s.type, origin, extra, rot)
                self._pset(e, "Pset_WallCommon", {"IsExternal": external})
                self._layered(e, "IfcWallType", "SOLIDWALL", "Exterior wall" if external else "Wall", thick,
                              "AXIS2" if frame is not None else None)
                height = float(zmax - zmin)
                hole_area = sum(door_size(d)[0] * door_size(d)[1] for d in holes_of.get(s.id, []))
                qto = ("Qto_WallBaseQuantities", {
                    "Length": length, "Width": thick, "Height": height, "GrossSideArea": length * height,
                    "NetSideArea": max(length * height - hole_area, 0.0), "GrossVolume": vol,
                    "NetVolume": max(vol - hole_area * thick, 0.0)})
            else:
                kind = s.attributes.get("kind", s.attributes.get("role", ""))
                ptype = slab_type(kind, zmin, zmax, self.model.storeys, self.params.boundary_gap)
                e = self._root("IfcSlab", ("shape", s.id), predefined_type=ptype, name=s.name or s.id)
                origin = self._origin_of(g)
                self._placement(e, container, origin)
                self._body(e, g, s.type, origin)
                self._pset(e, "Pset_SlabCommon", {"IsExternal": ptype in ("ROOF", "BASESLAB")})
                thick = float(s.attributes.get("thickness", zmax - zmin))
                self._layered(e, "IfcSlabType", ptype, SLAB_MATERIALS[ptype], thick, "AXIS3")
                fa, per = g.plan_area_perimeter()
                qto = ("Qto_SlabBaseQuantities", {
                    "Width": zmax - zmin, "GrossArea": fa, "NetArea": fa, "Perimeter": per,
                    "GrossVolume": vol, "NetVolume": vol})
            self.contained.setdefault(container.id(), []).append(e)
            self.ent[s.id] = e
            self._shape_psets(e, s)
            self._qto(e, *qto)

    # ------------------------------------------------------------------ types, materials
    def _typed(self, product, type_class: str, ptype: str, name: str, **attributes):
        """Give ``product`` the element type ``name`` (made on first use); its entry in
        :attr:`types`. Relationships are written in bulk by :meth:`_write_types`."""
        key = ("type", type_class, ptype, name)
        entry = self.types.get(key)
        if entry is None:
            te = self._root(type_class, key, predefined_type=ptype, name=name)
            for k, v in attributes.items():
                setattr(te, k, v)
            entry = self.types[key] = {"type": te, "objects": [], "set": None, "usages": {}}
        entry["objects"].append(product)
        return entry

    def _layered(self, product, type_class, ptype, material_name, thickness, direction):
        """Type of one material layer of ``thickness`` (m, rounded to ``type_step``) for a
        wall or slab, and the layer-set usage in ``direction`` (AXIS2: centred on the wall
        axis; AXIS3: up from the slab's bottom; None: no usage, the type's set applies)."""
        mm = millimetres(thickness, self.params.type_step)
        if mm <= 0:
            return
        entry = self._typed(product, type_class, ptype, f"{material_name} {mm} mm")
        t = mm / 1000.0
        if entry["set"] is None:
            mat = self.materials.get(material_name)
            if mat is None:
                mat = self.materials[material_name] = self.f.create_entity("IfcMaterial", Name=material_name)
            layer = self.f.create_entity("IfcMaterialLayer", Material=mat, LayerThickness=t, Name=material_name)
            entry["set"] = self.f.create_entity("IfcMaterialLayerSet", MaterialLayers=[layer],
                                                LayerSetName=entry["type"].Name)
        if direction is None:
            return
        usage = entry["usages"].get(direction)
        if usage is None:
            u = self.f.create_entity("IfcMaterialLayerSetUsage", ForLayerSet=entry["set"], LayerSetDirection=direction,
                                     DirectionSense="POSITIVE",
                                     OffsetFromReferenceLine=-t / 2 if direction == "AXIS2" else 0.0)
            usage = entry["usages"][direction] = (u, [])
        usage[1].append(product)

    def _write_types(self):
        """IfcRelDefinesByType per type; IfcRelAssociatesMaterial per layer set and usage."""
        for entry in self.types.values():
            te = entry["type"]
            tk = self._key(te)
            self._rel("IfcRelDefinesByType", (tk, "types"), RelatedObjects=entry["objects"], RelatingType=te)
            if entry["set"] is not None:
                self._rel("IfcRelAssociatesMaterial", (tk, "material"), RelatedObjects=[te],
                          RelatingMaterial=entry["set"])
            for direction, (usage, objects) in entry["usages"].items():
                self._rel("IfcRelAssociatesMaterial", (tk, "usage", direction), RelatedObjects=objects,
                          RelatingMaterial=usage)

    def _joins(self):
        """IfcRelConnectsPathElements per wall join (attribute ``joins``), each pair once."""
        seen = set()
        for s in self.model.shapes:
            if s.type != ShapeType.WALL or s.id not in self.ent:
                continue
            for j in s.attributes.get("joins", ()) or ():
                other = j.get("wall") if isinstance(j, dict) else None
                if other == s.id or other not in self.ent or not self.ent[other].is_a("IfcWall"):
                    continue
                pair = frozenset((s.id, other))
                if pair in seen:
                    continue
                seen.add(pair)
                self._rel("IfcRelConnectsPathElements", ("joins", s.id, other), RelatingElement=self.ent[s.id],
                          RelatedElement=self.ent[other], RelatingPriorities=[], RelatedPriorities=[],
                          RelatingConnectionType=connection_type(j.get("at")),
                          RelatedConnectionType=connection_type(j.get("other_at")))

    # ------------------------------------------------------------------ doors, windows, openings
    def _openings(self):
        m = self.model
        ends = {}
        for r in m.relations:
            if r.via is not None:
                ends.setdefault(r.via, set()).update((r.a, r.b))
        for d in m.shapes:
            if d.type not in (ShapeType.DOOR, ShapeType.WINDOW) or not self._writable(d):
                continue
            window = d.type == ShapeType.WINDOW
            kind = str(d.attributes.get("kind", "window" if window else "door")).lower()
            host = self.ent.get(d.parent) if d.parent is not None else None
            wall = host if host is not None and host.is_a("IfcWall") else None
            roof = host if host is not None and host.is_a("IfcSlab") and window else None  # a skylight's
            rot = self.rot.get(wall.id()) if wall is not None else None
            g = self.geom[d.id]
            origin = self._origin_of(g)
            w, h = door_size(d)
            if kind == "opening" and not window:
                if wall is None:
                    log.warning("doorless opening %s has no wall to void: not written", d.id)
                    continue
                op = self._void(d, wall, origin, rot, ("shape", d.id), d.name or d.id)
                self.ent[d.id] = op
                self._shape_psets(op, d)
                depth = float(m[d.parent].attributes.get("thickness", np.min(m[d.parent].scope.size[:2])))
                self._qto(op, "Qto_OpeningElementBaseQuantities", {"Width": w, "Height": h, "Depth": depth,
                                                                   "Area": w * h})
                continue
            spaces = set(ends.get(d.id, ()))
            sp = d.attributes.get("spaces")
            if isinstance(sp, (list, tuple)):
                spaces.update(x for x in sp if isinstance(x, str))
            external = any(x in m and m[x].type == ShapeType.EXTERIOR for x in spaces)
            cls, name = ("IfcWindow", "Window") if window else ("IfcDoor", "Door")
            ptype = "SKYLIGHT" if roof is not None else name.upper()
            e = self._root(cls, ("shape", d.id), predefined_type=ptype, name=d.name or d.id)
            e.OverallWidth, e.OverallHeight = float(w), float(h)
            container = self._container_of(d)
            self._placement(e, container, origin, rot)
            self._body(e, g, d.type, origin, rot=rot)
            self.contained.setdefault(container.id(), []).append(e)
            self.ent[d.id] = e
            self._shape_psets(e, d)
            self._pset(e, f"Pset_{name}Common", {"IsExternal": external})
            self._qto(e, f"Qto_{name}BaseQuantities", {"Width": w, "Height": h, "Perimeter": 2 * (w + h),
                                                       "Area": w * h})
            step = self.params.type_step
            label = "Roof window" if roof is not None else name
            size = f"{label} {millimetres(w, step)} x {millimetres(h, step)} mm"
            if window:
                self._typed(e, "IfcWindowType", "SKYLIGHT" if roof is not None else "WINDOW", size,
                            PartitioningType="NOTDEFINED")
            else:
                self._typed(e, "IfcDoorType", "DOOR", size, OperationType="NOTDEFINED")
            if wall is None and roof is None:
                log.warning("%s %s has no wall to void; written without an opening", name.lower(), d.id)
                continue
            op = self._void(d, wall or roof, origin, rot, ("opening", d.id), f"Opening {d.name or d.id}")
            # not api.feature.add_filling: it rebuilds the placements through the api
            self._rel("IfcRelFillsElement", (self._key(op), "fills"), RelatingOpeningElement=op,
                      RelatedBuildingElement=e)

    def _void(self, d: Shape, wall, origin, rot, key, name):
        """IfcOpeningElement of door or window ``d`` (its box through the wall) voiding ``wall``."""
        f = self.f
        op = self._root("IfcOpeningElement", key, predefined_type="OPENING", name=name)
        if wall.is_a("IfcSlab"):  # a roof window: its plan through the slab's thickness
            og = slab_opening_geometry(self.geom[d.id], self.geom[d.parent], self.params.opening_margin)
        else:
            og = opening_geometry(d, self.geom[d.id], self.geom[d.parent], self.params.opening_margin)
        self._placement(op, wall, origin, rot)
        item, rtype = solid(f, og, origin, rot)
        op.Representation = f.createIfcProductDefinitionShape(
            None, None, [f.createIfcShapeRepresentation(self.body, "Body", rtype, [item])])
        # not api.feature.add_feature: it rebuilds the opening's placement through the api
        self._rel("IfcRelVoidsElement", (self._key(op), "voids"), RelatingBuildingElement=wall,
                  RelatedOpeningElement=op)
        return op
