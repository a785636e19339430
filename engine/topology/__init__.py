"""Topology of a building model: graphs, shortest paths, and the editing rules.

* :func:`derive_topology` — re-derive merge, containment, adjacency and connectivity of a
  model from its parts (the grammar's production order after classification);
* :func:`space_graph` — networkx graphs at two granularities: ``"space"`` (rooms,
  corridors) and ``"subspace"`` (the cuboids/cells they are merged from), of adjacency,
  connectivity or containment;
* :func:`shortest_path` — Dijkstra on the connectivity graph at either granularity
  ("Room 1 → Corridor → Room 5" and the sub-space sequence behind it);
* :func:`reclassify` and :func:`insert_door` — the manual rules used by the Blender
  operators; each returns a **new** model with everything downstream re-derived (the
  input is never changed, so undo is keeping the old model).
"""
from ..grammar.rules import derive_topology
from .edit import insert_door, reclassify
from .graph import PathResult, containment_graph, describe_path, shortest_path, space_graph

__all__ = ["derive_topology", "space_graph", "containment_graph", "shortest_path", "PathResult",
           "describe_path", "reclassify", "insert_door"]
