"""IFC export and import of :class:`~engine.model.BuildingModel` (ifcopenshell).

* :func:`write_ifc` — BuildingModel → IFC4 file (spatial tree, spaces, walls, slabs, doors
  in openings, space boundaries, quantities, provenance), written atomically.
* :func:`read_ifc` — IFC2X3 / IFC4 / IFC4X3 file → BuildingModel of its walls, slabs,
  spaces and doors with their storeys and topology.
* :func:`read_mesh` — OBJ / PLY surface mesh → BuildingModel (reference surfaces).
"""
from .mesh import read_mesh
from .reader import IfcReadParams, read_ifc, read_reference
from .writer import IfcWriteParams, build_ifc, write_ifc

__all__ = ["IfcWriteParams", "IfcReadParams", "write_ifc", "build_ifc", "read_ifc", "read_mesh",
           "read_reference"]
