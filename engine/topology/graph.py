"""Topology graphs and shortest paths at two granularities (docs/method.md §2, "Topology").

Nodes carry ``name``, ``type``, ``centroid`` (metres) and ``storey``; edges carry ``via``
(the wall or door between two spaces, None for an open face) and ``weight`` (distance
between the centroids, metres — the cost of Dijkstra).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import networkx as nx
import numpy as np

from ..model import BuildingModel, ShapeType

__all__ = ["space_graph", "containment_graph", "shortest_path", "PathResult", "describe_path"]

_LEVELS = ("space", "subspace")
_SPACES = (ShapeType.INTERIOR, ShapeType.EXTERIOR)


def _has_parts(model: BuildingModel, s) -> bool:
    return any(c in model and model[c].type == s.type for c in s.children)


def _nodes(model: BuildingModel, level: str, include_exterior: bool):
    types = _SPACES if include_exterior else (ShapeType.INTERIOR,)
    if level == "space":
        return [s for s in model.shapes if s.type in types and s.active]
    if level == "subspace":
        return [s for s in model.shapes if s.type in types and not _has_parts(model, s)]
    raise ValueError(f"level must be one of {_LEVELS}, not {level!r}")


def space_graph(model: BuildingModel, kind: str = "connectivity", level: str = "space",
                include_exterior: bool = False):
    """A networkx Graph of ``kind`` ("adjacency" or "connectivity") relations.

    ``level="space"``: nodes are the active spaces (rooms, corridors); relations between
    their parts are lifted to them. ``level="subspace"``: nodes are the innermost parts
    (cuboids, cells); only relations recorded between parts are used (the grammar records
    a door's connectivity between the two parts on either side of it), so a path goes
    through the part that holds the door. A model without parts (e.g. ground truth) has
    the same nodes at both levels. Exterior spaces are left out unless
    ``include_exterior``.
    """
    if kind not in ("adjacency", "connectivity"):
        raise ValueError(f"kind must be 'adjacency' or 'connectivity', not {kind!r}")
    nodes = _nodes(model, level, include_exterior)
    ids = {s.id for s in nodes}
    g = nx.Graph()
    for s in nodes:
        g.add_node(s.id, name=s.name, type=s.type.value, centroid=tuple(float(v) for v in s.centroid),
                   storey=s.storey)

    def lift(i):
        if level == "space":
            return model.top_level(i).id if i in model else i
        return i

    for r in model.relations:
        if r.kind != kind or r.a not in model or r.b not in model:
            continue
        a, b = lift(r.a), lift(r.b)
        if a == b or a not in ids or b not in ids:
            continue
        w = float(np.linalg.norm(model[a].centroid - model[b].centroid))
        if g.has_edge(a, b):
            if r.via is not None and g.edges[a, b]["via"] is None:
                g.edges[a, b]["via"] = r.via
            continue
        g.add_edge(a, b, via=r.via, weight=w)
    return g


def containment_graph(model: BuildingModel):
    """A networkx DiGraph of containment: an edge parent → child for every merged shape
    and its parts and every wall and its doors."""
    g = nx.DiGraph()
    for s in model.shapes:
        g.add_node(s.id, name=s.name, type=s.type.value, active=s.active)
    for s in model.shapes:
        for c in s.children:
            if c in model:
                g.add_edge(s.id, c)
    return g


@dataclass(frozen=True)
class PathResult:
    """A shortest path.

    ``spaces`` : ids of the spaces passed, in order; ``vias`` : the door/wall (or None) of
    each step (len = len(spaces) − 1); ``length`` : sum of centroid distances, metres;
    ``names`` : the spaces' names.
    """

    spaces: tuple
    vias: tuple
    length: float
    names: tuple

    def __str__(self) -> str:
        return " → ".join(self.names)


def _resolve(model: BuildingModel, ref: str, level: str, g) -> list[str]:
    """Node ids standing for ``ref`` (an id or a name) at ``level``."""
    if ref in model:
        s = model[ref]
    else:
        named = [s for s in model.shapes if s.name == ref and s.active]
        if not named:
            raise KeyError(f"no shape with id or name {ref!r}")
        s = named[0]
    if level == "space":
        top = model.top_level(s.id).id
        return [top] if top in g else []
    if s.id in g:
        return [s.id]
    return [p.id for p in model.leaves(s.id) if p.id in g]


def shortest_path(model: BuildingModel, a: str, b: str, level: str = "space",
                  include_exterior: bool = False) -> Optional[PathResult]:
    """Shortest walk from ``a`` to ``b`` on the connectivity graph (Dijkstra).

    Parameters
    ----------
    a, b : shape ids or names ("Room 1"); at ``level="subspace"`` a room stands for all
        its parts (the path starts and ends at the nearest ones).
    level : "space" (rooms and corridors) or "subspace" (cuboids/cells).

    Returns the :class:`PathResult`, or None when ``b`` cannot be reached from ``a``.
    """
    g = space_graph(model, "connectivity", level, include_exterior)
    src, dst = _resolve(model, a, level, g), _resolve(model, b, level, g)
    if not src or not dst:
        return None
    try:
        length, path = nx.multi_source_dijkstra(g, set(src), target=None, weight="weight")
    except nx.NetworkXNoPath:  # pragma: no cover - multi-source without target never raises
        return None
    reach = [(length[d], d) for d in dst if d in length]
    if not reach:
        return None
    best, end = min(reach)
    nodes = path[end]
    vias = tuple(g.edges[u, v]["via"] for u, v in zip(nodes[:-1], nodes[1:]))
    return PathResult(tuple(nodes), vias, float(best), tuple(model[n].name or n for n in nodes))


def describe_path(model: BuildingModel, path: PathResult, collapse: bool = True) -> str:
    """"Room 1 → Corridor → Room 5": names along a path; at the sub-space level, with
    ``collapse``, consecutive parts of one space are named once."""
    names = []
    for sid in path.spaces:
        top = model.top_level(sid)
        nm = top.name or top.id
        if collapse and names and names[-1] == nm:
            continue
        names.append(nm)
    return " → ".join(names)
