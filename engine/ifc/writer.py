"""BuildingModel → IFC4 (or IFC4X3), written with ``ifcopenshell.api``.

The file follows the "simple model from scratch" recipe of IfcOpenShell: project, SI units,
representation contexts (Model/Body, Model/Axis, Model/FootPrint), then the spatial tree
site → building → storeys → spaces, then the elements:

* ``IfcSpace`` per interior space (with ``IfcWriteParams.parts``, a merged space also
  aggregates its parts as ``PARTIAL`` sub-spaces); ``IfcExternalSpatialElement`` per exterior
  space;
* ``IfcWall`` / ``IfcSlab`` (an ``IfcExtrudedAreaSolid`` when the shape is a vertical
  prism, an ``IfcFacetedBrep`` otherwise), ``IfcDoor`` filling an ``IfcOpeningElement``
  that voids its wall;
* ``IfcRelSpaceBoundary2ndLevel`` for every adjacency (space–wall–space) and connectivity
  (space–door–space) relation of the model, the two sides pointing at each other through
  ``CorrespondingBoundary``; relations without a wall or door go through an
  ``IfcVirtualElement`` (``VIRTUAL`` boundaries); walls and slabs that touch a space without
  a relation get a one-sided boundary. Connection geometry is the common face region.
* base quantities (``Qto_*BaseQuantities``), the property sets ``Indoor_Provenance``
  (project), ``Indoor_Shape`` and ``Indoor_Support`` (products), ``Indoor_Storey``;
* colours by type (surface styles).

Geometry is written in the model's original frame: the site placement carries
``model.offset`` and the rigid ``model.transform`` (a non-rigid transform is applied to the
vertices instead), so world coordinates in the file are ``p_file = T p_model + offset``.
Every placement below the site is a pure translation.

The output is reproducible: every GlobalId is derived from the model's seed, its name and
the entity's identity (:func:`engine.ifc.common.global_id`: a shape id, a role such as
``"opening"`` or ``"pset"``, the ids a relationship joins), the relationships are created
here in a fixed order (``ifcopenshell.api`` orders products through Python sets of entity
instances, whose hashes depend on everything the process made before), and the
``SOURCE_DATE_EPOCH`` environment variable fixes the time stamps. The same model therefore
gives the same file byte for byte, apart from the header time stamp when that variable is
not set. Text from the model (names, file names) with undecodable bytes is written with
backslash escapes.
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
from .common import (PSET_PROVENANCE, PSET_SHAPE, PSET_STOREY, PSET_SUPPORT, WRITABLE_SCHEMAS, dumps,
                     global_id, iso_timestamp, require_ifcopenshell, safe_text, source_date_epoch)
from .writer_geometry import (clean_ring, common_face, default_storeys, door_size, opening_geometry,
                              wall_axis)

__all__ = ["IfcWriteParams", "write_ifc", "build_ifc", "TYPE_COLOURS"]

log = logging.getLogger(__name__)

TYPE_COLOURS = {
    ShapeType.INTERIOR: ((0.55, 0.75, 0.95), 0.7),
    ShapeType.EXTERIOR: ((0.60, 0.85, 0.55), 0.85),
    ShapeType.WALL: ((0.85, 0.83, 0.78), 0.0),
    ShapeType.SLAB: ((0.62, 0.62, 0.65), 0.0),
    ShapeType.DOOR: ((0.65, 0.42, 0.22), 0.0),
}
"""Surface colour (red, green, blue in 0..1) and transparency (0 opaque .. 1 clear) per type."""




@dataclass(frozen=True)
class IfcWriteParams:
    """Parameters of :func:`write_ifc` (SI units)."""

    opening_margin: float = 0.01
    """How far (m) a door's opening reaches beyond each face of its wall, so the void cuts
    cleanly through coplanar faces."""
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


# --------------------------------------------------------------------------- public API
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
class _Writer:
    def __init__(self, model: BuildingModel, schema: str, params: IfcWriteParams, p):
        import ifcopenshell
        import ifcopenshell.api.aggregate  # noqa: F401  (sub-modules load on import)
        import ifcopenshell.api.boundary  # noqa: F401
        import ifcopenshell.api.context  # noqa: F401
        import ifcopenshell.api.feature  # noqa: F401
        import ifcopenshell.api.geometry  # noqa: F401
        import ifcopenshell.api.owner  # noqa: F401
        import ifcopenshell.api.project  # noqa: F401
        import ifcopenshell.api.pset  # noqa: F401
        import ifcopenshell.api.root  # noqa: F401
        import ifcopenshell.api.spatial  # noqa: F401
        import ifcopenshell.api.style  # noqa: F401
        import ifcopenshell.api.unit  # noqa: F401

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

    def _root(self, ifc_class: str, key: tuple, name=None, **kwargs):
        """``api.root.create_entity`` with the GlobalId of ``key`` and a safe ``name``."""
        e = self.api.root.create_entity(self.f, ifc_class=ifc_class,
                                        name=None if name is None else safe_text(name), **kwargs)
        return self._own(e, key)

    def _history(self):
        """The owner history ifcopenshell.api gives new entities (None unless an application,
        e.g. Bonsai, has configured a user and an application)."""
        return self.api.owner.create_owner_history(self.f)

    def _aggregate(self, relating, products):
        """IfcRelAggregates of ``products`` (in this order) under ``relating``."""
        key = (self._key(relating), "aggregates")
        rel = self.f.createIfcRelAggregates(self._gid(key), self._history(), None, None, relating,
                                            list(products))
        return self._own(rel, key)

    def _contain(self, structure, products):
        """IfcRelContainedInSpatialStructure of ``products`` (in this order) in ``structure``."""
        key = (self._key(structure), "contains")
        rel = self.f.createIfcRelContainedInSpatialStructure(self._gid(key), self._history(), None, None,
                                                             list(products), structure)
        return self._own(rel, key)

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
    def _point(self, xyz):
        return self.f.createIfcCartesianPoint([float(c) for c in xyz])

    def _axis2(self, location, z=None, x=None):
        f = self.f
        return f.createIfcAxis2Placement3D(
            self._point(location),
            None if z is None else f.createIfcDirection([float(c) for c in z]),
            None if x is None else f.createIfcDirection([float(c) for c in x]))

    def _placement(self, entity, parent, origin):
        """Local placement of ``entity`` at absolute model-frame ``origin`` relative to ``parent``."""
        origin = np.asarray(origin, dtype=np.float64)
        rel_to = None
        rel = origin
        if parent is not None:
            rel_to = parent.ObjectPlacement
            rel = origin - self.origin[parent.id()]
        entity.ObjectPlacement = self.f.createIfcLocalPlacement(rel_to, self._axis2(rel))
        self.origin[entity.id()] = origin

    def _pset(self, product, name, props):
        props = {k: v for k, v in props.items() if v is not None}
        if not props:
            return
        for k, v in list(props.items()):
            if isinstance(v, str):
                v = props[k] = safe_text(v)
                if len(v) > 255:
                    props[k] = self.f.createIfcText(v)
        pset = self.api.pset.add_pset(self.f, product=product, name=name)
        self._own_definition(product, pset, name)
        self.api.pset.edit_pset(self.f, pset=pset, properties=props)

    def _own_definition(self, product, definition, name):
        """GlobalIds of a property set or quantity set and of the relationship defining it."""
        owner = self._key(product)
        self._own(definition, (owner, "pset", name))
        for rel in definition.DefinesOccurrence:
            self._own(rel, (owner, "defines", name))

    def _qto(self, product, name, props):
        props = {k: float(v) for k, v in props.items() if v is not None and np.isfinite(v)}
        if props:
            q = self.api.pset.add_qto(self.f, product=product, name=name)
            self._own_definition(product, q, name)
            self.api.pset.edit_qto(self.f, qto=q, properties=props)

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

    def _polyline(self, pts2or3, closed=True):
        pts = [self.f.createIfcCartesianPoint([float(c) for c in q]) for q in pts2or3]
        if closed:
            pts.append(pts[0])
        return self.f.createIfcPolyline(pts)

    def _solid(self, g: Polyhedron, origin):
        """(item, representation type) of polyhedron ``g`` relative to ``origin`` (3,)."""
        fp = g.footprint()
        zmin, zmax = g.bounds[:, 2]
        if fp is not None and zmax - zmin > 0:
            fp = clean_ring(fp - origin[:2])
            if fp is not None:
                f = self.f
                profile = f.createIfcArbitraryClosedProfileDef("AREA", None, self._polyline(fp))
                solid = f.createIfcExtrudedAreaSolid(
                    profile, self._axis2((0.0, 0.0, zmin - origin[2])), f.createIfcDirection([0.0, 0.0, 1.0]),
                    float(zmax - zmin))
                return solid, "SweptSolid"
        return self._brep(g, origin), "Brep"

    def _brep(self, g: Polyhedron, origin):
        f = self.f
        pts = [f.createIfcCartesianPoint([float(c) for c in v]) for v in g.vertices - origin]
        faces = []
        for face in g.faces:
            idx = [i for k, i in enumerate(face) if i != face[k - 1]]  # drop repeated vertices
            if len(idx) < 3:
                continue
            loop = f.createIfcPolyLoop([pts[i] for i in idx])
            faces.append(f.createIfcFace([f.createIfcFaceOuterBound(loop, True)]))
        return f.createIfcFacetedBrep(f.createIfcClosedShell(faces))

    def _body(self, product, g: Polyhedron, shape_type, origin, extra=()):
        item, rtype = self._solid(g, origin)
        rep = self.f.createIfcShapeRepresentation(self.body, "Body", rtype, [item])
        self.api.style.assign_representation_styles(self.f, shape_representation=rep,
                                                    styles=[self._style(shape_type)])
        reps = [rep] + list(extra)
        product.Representation = self.f.createIfcProductDefinitionShape(None, None, reps)
        return rtype

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
        site.ObjectPlacement = f.createIfcLocalPlacement(None, self._axis2(sm[:3, 3], sm[:3, 2], sm[:3, 0]))
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
        p.check()
        p(0.6, "doors")
        self._doors()
        p.check()
        p(0.7, "space boundaries")
        self._boundaries()
        for sid, products in self.contained.items():
            self._contain(f.by_id(sid), products)
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
            "Trace": dumps(pv.trace) if pv.trace else None,
            "Source": pv.source or None,
            "Software": pv.software or None,
            "ModelName": self.model.name or None,
            "Transform": dumps(np.asarray(self.model.transform)),
            "Offset": dumps(np.asarray(self.model.offset)),
            "OffsetIn": self.params.georeference,
            "StoreyCount": len(self.storey_list),
        })

    def _writable(self, s: Shape) -> bool:
        """Spaces (active or parts) and active walls, slabs, doors with a closed geometry."""
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

    def _shape_psets(self, e, s: Shape):
        self._pset(e, PSET_SHAPE, {
            "ShapeId": s.id, "ShapeType": s.type.value, "Active": bool(s.active),
            "Terminal": bool(s.terminal), "StoreyIndex": int(s.storey),
            "Grid": None if s.grid is None else dumps(s.grid),
            "Attributes": dumps(s.attributes) if s.attributes else None,
            "Log": "\n".join(s.log) if s.log else None,
        })
        if s.support:
            self._pset(e, PSET_SUPPORT, {k: float(v) for k, v in s.support.items()})

    @staticmethod
    def _origin_of(g: Polyhedron):
        b = g.bounds
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
        agg = {}
        for s in spaces:
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
            origin = self._origin_of(g)
            self._placement(e, parent, origin)
            extra = []
            fp = g.footprint()
            if fp is not None:
                ring = clean_ring(fp - origin[:2])
                if ring is not None:
                    curves = f.createIfcGeometricCurveSet([self._polyline(ring)])
                    extra.append(f.createIfcShapeRepresentation(self.footprint, "FootPrint",
                                                                "GeometricCurveSet", [curves]))
            self._body(e, g, s.type, origin, extra)
            agg.setdefault(parent.id(), []).append(e)
            self.ent[s.id] = e
            self._shape_psets(e, s)
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
        doors_of = {}
        for d in m.shapes:
            if d.type == ShapeType.DOOR and d.parent is not None:
                doors_of.setdefault(d.parent, []).append(d)
        for s in m.shapes:
            if s.type not in (ShapeType.WALL, ShapeType.SLAB) or not self._writable(s):
                continue
            g = self.geom[s.id]
            if s.type == ShapeType.WALL:
                e = self._root("IfcWall", ("shape", s.id), predefined_type="SOLIDWALL", name=s.name or s.id)
            else:
                e = self._root("IfcSlab", ("shape", s.id), predefined_type=self._slab_type(s, g),
                               name=s.name or s.id)
            container = self._container_of(s)
            origin = self._origin_of(g)
            self._placement(e, container, origin)
            extra = []
            if s.type == ShapeType.WALL:
                axis = wall_axis(s, g)
                if axis is not None:
                    a = axis - origin[:2]
                    extra.append(f.createIfcShapeRepresentation(self.axis, "Axis", "Curve2D",
                                                                [self._polyline(a, closed=False)]))
            self._body(e, g, s.type, origin, extra)
            self.contained.setdefault(container.id(), []).append(e)
            self.ent[s.id] = e
            self._shape_psets(e, s)
            zmin, zmax = g.bounds[:, 2]
            vol = g.volume()
            if s.type == ShapeType.WALL:
                size = np.sort(s.scope.size[:2])
                thick = float(s.attributes.get("thickness", size[0]))
                length, height = float(size[1]), float(zmax - zmin)
                holes = [d for d in doors_of.get(s.id, [])]
                hole_area = sum(door_size(d)[0] * door_size(d)[1] for d in holes)
                self._qto(e, "Qto_WallBaseQuantities", {
                    "Length": length, "Width": thick, "Height": height, "GrossSideArea": length * height,
                    "NetSideArea": max(length * height - hole_area, 0.0), "GrossVolume": vol,
                    "NetVolume": max(vol - hole_area * thick, 0.0)})
            else:
                fa, per = g.plan_area_perimeter()
                self._qto(e, "Qto_SlabBaseQuantities", {
                    "Width": zmax - zmin, "GrossArea": fa, "NetArea": fa, "Perimeter": per,
                    "GrossVolume": vol, "NetVolume": vol})

    def _slab_type(self, s: Shape, g: Polyhedron) -> str:
        kind = str(s.attributes.get("kind", s.attributes.get("role", ""))).lower()
        if kind in ("roof",):
            return "ROOF"
        if kind in ("base", "baseslab", "ground"):
            return "BASESLAB"
        if not self.model.storeys:
            return "FLOOR"
        zmin, zmax = g.bounds[:, 2]
        lowest = min(st.floor_z for st in self.model.storeys)
        highest = max(st.ceiling_z for st in self.model.storeys)
        if kind != "ceiling" and zmax <= lowest + self.params.boundary_gap:
            return "BASESLAB"
        if kind != "floor" and zmin >= highest - self.params.boundary_gap:
            return "ROOF"
        return "FLOOR"

    # ------------------------------------------------------------------ doors
    def _doors(self):
        f, m = self.f, self.model
        for d in m.shapes:
            if d.type != ShapeType.DOOR or not self._writable(d):
                continue
            g = self.geom[d.id]
            e = self._root("IfcDoor", ("shape", d.id), predefined_type="DOOR", name=d.name or d.id)
            w, h = door_size(d)
            e.OverallWidth, e.OverallHeight = float(w), float(h)
            container = self._container_of(d)
            origin = self._origin_of(g)
            self._placement(e, container, origin)
            self._body(e, g, ShapeType.DOOR, origin)
            self.contained.setdefault(container.id(), []).append(e)
            self.ent[d.id] = e
            self._shape_psets(e, d)
            self._qto(e, "Qto_DoorBaseQuantities", {"Width": w, "Height": h, "Area": w * h})
            wall = self.ent.get(d.parent) if d.parent is not None else None
            if wall is None or not wall.is_a("IfcWall"):
                log.warning("door %s has no wall to void; written without an opening", d.id)
                continue
            op = self._root("IfcOpeningElement", ("opening", d.id), predefined_type="OPENING",
                            name=f"Opening {d.name or d.id}")
            og = opening_geometry(d, self.geom[d.id], self.geom[d.parent], self.params.opening_margin)
            self._placement(op, wall, origin)
            item, rtype = self._solid(og, origin)
            op.Representation = f.createIfcProductDefinitionShape(
                None, None, [f.createIfcShapeRepresentation(self.body, "Body", rtype, [item])])
            # not api.feature.add_feature: it rebuilds the opening's placement through the api
            voids, fills = (self._key(op), "voids"), (self._key(op), "fills")
            self._own(f.createIfcRelVoidsElement(self._gid(voids), self._history(), None, None, wall, op),
                      voids)
            self._own(f.createIfcRelFillsElement(self._gid(fills), self._history(), None, None, op, e),
                      fills)

    # ------------------------------------------------------------------ boundaries
    def _boundaries(self):
        m, prm = self.model, self.params
        done = set()
        n = 0
        for r in m.relations:
            if r.a not in self.ent or r.b not in self.ent:
                continue
            sa, sb = self.ent[r.a], self.ent[r.b]
            if not (_is_space_entity(sa) and _is_space_entity(sb)):
                continue
            ext = m[r.a].type == ShapeType.EXTERIOR or m[r.b].type == ShapeType.EXTERIOR
            io = "EXTERNAL" if ext else "INTERNAL"
            if r.via is not None and r.via in self.ent and not _is_space_entity(self.ent[r.via]):
                elem, elem_shape, phys = self.ent[r.via], r.via, "PHYSICAL"
            else:
                key = ("virtual", r.a, r.b)
                if key not in self.ent:
                    label = f"Open boundary {m[r.a].name or r.a} | {m[r.b].name or r.b}"
                    ve = self._root("IfcVirtualElement", ("virtual", r.a, r.b), name=label)
                    container = self._container_of(m[r.a])
                    self._placement(ve, container, self.origin[sa.id()])
                    self.contained.setdefault(container.id(), []).append(ve)
                    self._pset(ve, PSET_SHAPE, {"ShapeId": f"open:{r.a}|{r.b}", "ShapeType": "virtual",
                                                "RelationKinds": r.kind})
                    self.ent[key] = ve
                else:
                    ps = _find_pset(self.ent[key], PSET_SHAPE)
                    if ps is not None:
                        kinds = sorted(set(ps.get("RelationKinds", "").split(",")) | {r.kind})
                        self._pset_update(self.ent[key], PSET_SHAPE,
                                          {"RelationKinds": ",".join(k for k in kinds if k)})
                elem, elem_shape, phys = self.ent[key], None, "VIRTUAL"
            if (r.a, r.b, elem.id()) in done:
                continue
            done.add((r.a, r.b, elem.id()))
            ba = self._boundary(r.a, sa, elem, elem_shape, phys, io, "2a", partner=r.b)
            bb = self._boundary(r.b, sb, elem, elem_shape, phys, io, "2a", partner=r.a)
            ba.CorrespondingBoundary, bb.CorrespondingBoundary = bb, ba
            done.add((r.a, elem.id()))
            done.add((r.b, elem.id()))
            n += 2
        if prm.geometric_boundaries:
            spaces = [s for s in m.shapes if s.is_space and s.active and s.id in self.ent]
            elems = [s for s in m.shapes if s.type in (ShapeType.WALL, ShapeType.SLAB) and s.id in self.ent]
            for s in spaces:
                for w in elems:
                    if (s.id, self.ent[w.id].id()) in done:
                        continue
                    common = common_face(self.geom[s.id], self.geom[w.id], prm.boundary_gap, prm.boundary_cos,
                                         prm.min_boundary_area, self.tables)
                    if common is None:
                        continue
                    io = "EXTERNAL" if s.type == ShapeType.EXTERIOR else "NOTDEFINED"
                    self._boundary(s.id, self.ent[s.id], self.ent[w.id], w.id, "PHYSICAL", io, "2b", common)
                    done.add((s.id, self.ent[w.id].id()))
                    n += 1
        log.debug("%d space boundaries", n)

    def _pset_update(self, product, name, props):
        for rel in getattr(product, "IsDefinedBy", ()) or ():
            pd = rel.RelatingPropertyDefinition
            if rel.is_a("IfcRelDefinesByProperties") and pd.is_a("IfcPropertySet") and pd.Name == name:
                self.api.pset.edit_pset(self.f, pset=pd, properties=props)
                return

    def _boundary(self, space_id, space, elem, elem_shape, phys, io, level, common=None, partner=None):
        """The boundary of space ``space_id`` by ``elem``; ``partner`` is the space on the other
        side for a relation's boundary (its key tells the two boundaries of one wall apart)."""
        f = self.f
        b = self._root("IfcRelSpaceBoundary2ndLevel", ("boundary", space_id, self._key(elem), partner))
        b.Name, b.Description = "2ndLevel", level
        self.api.boundary.edit_attributes(f, entity=b, relating_space=space, related_building_element=elem,
                                          physical_or_virtual=phys, internal_or_external=io)
        if common is None and elem_shape is not None:
            prm = self.params
            common = common_face(self.geom[space_id], self.geom[elem_shape], prm.boundary_gap,
                                 prm.boundary_cos, prm.min_boundary_area, self.tables)
        if common is not None:
            poly2, origin, normal, u = common
            loc = origin - self.origin[space.id()]
            self.api.boundary.assign_connection_geometry(
                f, rel_space_boundary=b, outer_boundary=poly2, location=loc, axis=normal, ref_direction=u,
                unit_scale=1.0)
        return b


# --------------------------------------------------------------------------- entities
def _is_space_entity(e) -> bool:
    return e.is_a("IfcSpace") or e.is_a("IfcExternalSpatialElement")


def _find_pset(product, name):
    import ifcopenshell.util.element as ue

    return ue.get_psets(product).get(name)
