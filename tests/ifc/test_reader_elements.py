"""read_ifc on the two real reference models: windows, opening boxes and the attributes of
walls, slabs, doors and windows (tests/data/*.ifc, see tests/data/README.md)."""
import functools
import os

import numpy as np
import pytest

from engine.ifc import read_ifc
from engine.model import ShapeType
from scenes import DATA

FZK = os.path.join(DATA, "AC20-FZK-Haus.ifc")
DUPLEX = os.path.join(DATA, "Duplex_A_20110907_architecture.ifc")


@functools.lru_cache(maxsize=None)
def _read(path):
    return read_ifc(path)


def _per_storey(shapes, n):
    return [sum(1 for s in shapes if s.storey == k) for k in range(n)]


def _box_axes(s):
    """Width along the wall (longer horizontal side) and depth (shorter) of an opening box, m."""
    size = s.scope.size
    return float(max(size[0], size[1])), float(min(size[0], size[1]))


def test_fzk_haus_windows_doors_and_their_walls():
    m = _read(FZK)
    assert len(m.windows) == 11 and len(m.doors) == 5
    assert _per_storey(m.windows, 2) == [9, 2] and _per_storey(m.doors, 2) == [5, 0]
    walls = {w.id: w for w in m.walls}
    names = {s.id: s.name for s in m.spaces}
    for o in m.doors + m.windows:
        a = o.attributes
        assert o.parent in walls and o.id in walls[o.parent].children
        assert a["kind"] == ("window" if o.type == ShapeType.WINDOW else "door")
        # the box: OverallWidth along the wall x the wall's thickness, OverallHeight high
        width, depth = _box_axes(o)
        assert width == pytest.approx(a["width"], abs=1e-6)
        assert depth == pytest.approx(walls[o.parent].attributes["thickness"], abs=0.02)
        assert o.bounds[1, 2] - o.bounds[0, 2] == pytest.approx(a["height"], abs=1e-6)
        assert o.bounds[0, 2] == pytest.approx(m.storeys[o.storey].floor_z + a["sill"], abs=1e-6)
    # window sizes and sills as the file has them (ground floor 2.0 x 1.2 at 0.8 / 0.95 m,
    # roof storey 1.0 x 1.0 at 0.8 m)
    ground = [w for w in m.windows if w.storey == 0]
    assert sorted({(w.attributes["width"], w.attributes["height"]) for w in ground}) == [(2.0, 1.2)]
    assert sorted(round(w.attributes["sill"], 3) for w in ground) == [0.8] * 7 + [0.95] * 2
    assert all(w.attributes["width"] == pytest.approx(1.0) and w.attributes["sill"] == pytest.approx(0.8)
               for w in m.windows if w.storey == 1)
    # every window looks from one room to the outside; inner doors join the hall to a room
    for w in m.windows:
        sp = w.attributes["spaces"]
        assert len(sp) == 2 and sp[0] in names and sp[1] == f"exterior_s{w.storey}"
    inner = sorted(tuple(sorted(names[x] for x in d.attributes["spaces"])) for d in m.doors
                   if all(x in names for x in d.attributes["spaces"]))
    assert inner == [("Bad", "Flur"), ("Buero", "Flur"), ("Flur", "Schlafzimmer")]
    outer = sorted(names[d.attributes["spaces"][0]] for d in m.doors
                   if "exterior_s0" in d.attributes["spaces"])
    assert outer == ["Flur", "Wohnen"]
    assert sorted(round(d.attributes["width"], 3) for d in m.doors) == [0.885, 0.885, 0.885, 1.01, 2.01]


def test_fzk_haus_wall_and_slab_attributes():
    m = _read(FZK)
    # no Pset_WallCommon.IsExternal in this file: external from the EXTERNAL space boundaries
    ext = sorted(w.name for w in m.walls if w.attributes["external"])
    assert len(ext) == 8 and all("-Ext-" in n for n in ext)
    assert all(not w.attributes["external"] for w in m.walls if "-Int-" in w.name)
    assert {round(w.attributes["thickness"], 3) for w in m.walls if "-Int-" in w.name} == {0.24}
    for w in m.walls:
        (x0, y0), (x1, y1) = w.attributes["axis_line"]
        length = float(np.hypot(x1 - x0, y1 - y0))
        assert length == pytest.approx(max(w.scope.size[:2]), abs=1e-6)
        assert w.attributes["height"] == pytest.approx(w.bounds[1, 2] - w.bounds[0, 2])
        assert all(j["at"] in ("ATSTART", "ATEND", "ATPATH", "NOTDEFINED") for j in w.attributes["joins"])
    joins = sum(len(w.attributes["joins"]) for w in m.walls)
    assert joins == 2 * 16  # 16 IfcRelConnectsPathElements, seen from both walls
    kinds = sorted((s.name, s.attributes["kind"], round(s.attributes["thickness"], 3)) for s in m.slabs)
    assert kinds == [("Bodenplatte", "base", 0.2), ("Dach-1", "roof", 0.2), ("Dach-2", "roof", 0.2),
                     ("Slab-033", "floor", 0.2)]


def test_duplex_windows_doors_and_attributes():
    m = _read(DUPLEX)
    n = len(m.storeys)
    assert [s.name for s in m.storeys] == ["T/FDN", "Level 1", "Level 2", "Roof"]
    assert len(m.windows) == 24 and len(m.doors) == 14
    assert _per_storey(m.windows, n) == [0, 4, 18, 2] and _per_storey(m.doors, n) == [0, 6, 8, 0]
    assert _per_storey(m.spaces, n) == [0, 10, 10, 1] and _per_storey(m.walls, n) == [7, 21, 25, 4]
    # the level 1 ceiling is the rooms' 2.6 m, not the stair well's 5.7 m
    assert [round(s.ceiling_z, 2) for s in m.storeys[1:3]] == [2.6, 5.7]
    walls = {w.id for w in m.walls}
    roof = [s for s in m.slabs if s.attributes["kind"] == "roof"]
    assert len(roof) == 1
    skylights = [w for w in m.windows if w.parent == roof[0].id]
    assert len(skylights) == 2 and all(w.parent in walls for w in m.windows if w not in skylights)
    assert all(d.parent in walls for d in m.doors)
    # Pset_WallCommon.IsExternal (the party wall between the two flats counts as external)
    assert sum(1 for w in m.walls if w.attributes.get("external")) == 23
    names = {s.id: s.name for s in m.spaces}
    pairs = sorted(tuple(sorted(names.get(x, "outside") for x in d.attributes["spaces"])) for d in m.doors)
    assert pairs == sorted([("Foyer", "outside")] * 2 + [("Living Room", "outside")] * 2 +
                           [("Bathroom 1", "Foyer")] * 2 + [("Bedroom 2", "Hallway")] * 2 +
                           [("Bedroom 1", "Hallway")] * 2 + [("Bathroom 2", "Hallway")] * 2 +
                           [("Bathroom 2", "Utility")] * 2)
    # a door joins the two spaces on its sides: the utility doors' boundaries also name the
    # hallway, 13 cm past their ends, which they do not reach (10 edges, one per inner door)
    joined = sorted(tuple(sorted(names[x] for x in (r.a, r.b))) for r in m.relations_of("connectivity"))
    assert joined == sorted(p for p in pairs if "outside" not in p)
    # windows without a space boundary get their room by geometry
    assert all(len(w.attributes["spaces"]) == 2 and w.attributes["spaces"][0] in names for w in m.windows)
    assert sorted({round(w.attributes["sill"], 3) for w in m.windows if w.storey == 2}) == [0.1, 0.925, 1.751]


@pytest.mark.parametrize("path", [FZK, DUPLEX])
def test_space_faces_point_outwards(path):
    # the Duplex's IfcSpace breps wind some faces inwards; the reader turns them out, so that
    # the evaluation (which compares like-facing surfaces) sees every room face: a point 2 cm
    # along each face's normal lies outside the room, 2 cm against it inside
    from engine.geometry.mesh import inside

    m = _read(path)
    checked = 0
    for s in m.spaces:
        g = s.geometry
        v, tri = g.triangles()
        cen = np.array([g.face_vertices(i).mean(axis=0) for i in range(len(g.faces))])
        n = np.array([g.face_normal(i) for i in range(len(g.faces))])
        big = np.array([g.face_area(i) > 0.05 for i in range(len(g.faces))])
        out, into = inside(v, tri, cen[big] + 0.02 * n[big]), inside(v, tri, cen[big] - 0.02 * n[big])
        assert not out.any() and into.all(), (s.name, np.flatnonzero(big)[out | ~into])
        checked += int(big.sum())
    assert checked >= 6 * len(m.spaces)


def test_orient_outward_mixed_windings():
    from engine.geometry.mesh import orient_outward
    from engine.model import Polyhedron

    rng = np.random.default_rng(0)
    parts = [Polyhedron.prism([(0, 0), (3, 0), (3, 1), (1, 1), (1, 3), (0, 3)], 0, 2.5),  # an L
             Polyhedron.box((4, 0, 0), (5, 2, 1))]
    v, t = [], []
    for g in parts:
        gv, gt = g.triangles()
        t.append(gt + sum(len(x) for x in v))
        v.append(gv)
    v, t = np.vstack(v), np.vstack(t)
    for _ in range(3):
        bad = t.copy()
        f = rng.random(len(t)) < 0.5
        bad[f] = bad[f][:, ::-1]
        assert np.array_equal(orient_outward(v, bad), t)
    assert np.array_equal(orient_outward(v, t[:, ::-1]), t)  # all inside out
