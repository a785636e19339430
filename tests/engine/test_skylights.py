"""Roof windows: holes in a roof slab seen from the room under it (engine.elements.skylights)."""
import numpy as np
import pytest
from shapely.geometry import Polygon

from engine.elements.build import building_elements
from engine.elements.params import ElementsParams
from engine.elements.skylights import roof_windows
from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey
from engine.pointcloud import PointCloud

CEIL = 2.6
HOLE = (1.5, 1.0, 2.7, 2.0)  # x0, y0, x1, y1: 1.2 m x 1.0 m


def _ceiling(rng, hole=HOLE, spacing=0.03, sigma=0.005, skip=None):
    """Ceiling points of a 5 m x 4 m room at CEIL, none over ``hole`` (nor over ``skip``)."""
    x, y = np.meshgrid(np.arange(0.0, 5.0, spacing), np.arange(0.0, 4.0, spacing))
    x, y = x.ravel() + rng.uniform(0, spacing, x.size), y.ravel() + rng.uniform(0, spacing, y.size)
    keep = np.ones(x.size, bool)
    for box in (hole, skip):
        if box is not None:
            keep &= ~((x > box[0]) & (x < box[2]) & (y > box[1]) & (y < box[3]))
    return np.column_stack([x[keep], y[keep], CEIL + rng.normal(0, sigma, keep.sum())])


def _shaft(rng, hole=HOLE, top=3.1, glass=True, n=600, sigma=0.005):
    """The hole's four reveals from the ceiling up to ``top``, and its glazing at the top."""
    x0, y0, x1, y1 = hole
    z = rng.uniform(CEIL, top, 4 * n)
    t = rng.uniform(0, 1, 4 * n)
    sides = [np.column_stack([np.full(n, x0), y0 + (y1 - y0) * t[:n], z[:n]]),
             np.column_stack([np.full(n, x1), y0 + (y1 - y0) * t[n:2 * n], z[n:2 * n]]),
             np.column_stack([x0 + (x1 - x0) * t[2 * n:3 * n], np.full(n, y0), z[2 * n:3 * n]]),
             np.column_stack([x0 + (x1 - x0) * t[3 * n:], np.full(n, y1), z[3 * n:]])]
    if glass:
        sides.append(np.column_stack([rng.uniform(x0, x1, 2 * n), rng.uniform(y0, y1, 2 * n),
                                      np.full(2 * n, top)]))
    p = np.vstack(sides)
    return p + rng.normal(0, sigma, p.shape)


def _roof():
    plan = [(-0.2, -0.2), (5.2, -0.2), (5.2, 4.2), (-0.2, 4.2)]
    return Shape("slab_roof", ShapeType.SLAB, Polyhedron.prism(plan, CEIL, CEIL + 0.25),
                 storey=0, terminal=True, attributes={"kind": "roof", "thickness": 0.25})


def _find(xyz):
    room = ("room0", 0, Polygon([(0, 0), (5, 0), (5, 4), (0, 4)]))
    return roof_windows([_roof()], [room], xyz, {0: "exterior_s0"})


@pytest.mark.parametrize("glass", [True, False])
@pytest.mark.parametrize("seed", [0, 1])
def test_a_hole_in_the_ceiling_with_its_reveals_is_a_roof_window(glass, seed):
    """A 1.2 m x 1.0 m hole in the ceiling, 0.5 m deep: its reveals and, when the glazing
    returns points, its top. Found where it is (centre within 3 cm), its sides within 3 cm
    (the raster's 10 cm cells are refined by the reveals), its top at the glazing, in the
    roof slab, between the room and the exterior. Clear glass (nothing at the top, the
    reveals alone) is a hole too."""
    rng = np.random.default_rng(seed)
    found = _find(np.vstack([_ceiling(rng), _shaft(rng, glass=glass)]))
    assert len(found) == 1
    w = found[0]
    assert w.type == ShapeType.WINDOW and w.parent == "slab_roof" and w.attributes["skylight"]
    assert w.attributes["kind"] == "window" and w.attributes["spaces"] == ["room0", "exterior_s0"]
    c = w.centroid
    assert abs(c[0] - 2.1) <= 0.03 and abs(c[1] - 1.5) <= 0.03
    assert abs(w.attributes["width"] - 1.2) <= 0.03 and abs(w.attributes["height"] - 1.0) <= 0.03
    assert abs(w.bounds[1, 2] - 3.1) <= 0.03


def test_what_is_not_a_hole_in_the_roof():
    """No roof window: a patch of ceiling nobody saw (no points above it); a recessed light
    10 cm deep (less than min_depth); a hole at the room's edge with the ceiling of a higher
    part beyond (a skylight against a wall is one: its shaft hides all beyond); a 3 m x 2.5 m
    opening (larger than a skylight: a void); a missing ceiling tile with the plenum over it."""
    rng = np.random.default_rng(3)
    assert _find(_ceiling(rng)) == []  # the hole seen as nothing at all
    light = (3.5, 2.5, 4.1, 3.1)
    lamp = np.column_stack([rng.uniform(3.5, 4.1, 500), rng.uniform(2.5, 3.1, 500), np.full(500, CEIL + 0.1)])
    assert _find(np.vstack([_ceiling(rng, hole=light), lamp])) == []
    edge = (0.0, 1.0, 1.0, 2.0)  # at the room's edge, a higher ceiling (0.4 m up) beyond it
    higher = np.column_stack([rng.uniform(-0.5, 0.0, 800), rng.uniform(0.0, 4.0, 800),
                              np.full(800, CEIL + 0.4)])
    assert _find(np.vstack([_ceiling(rng, hole=edge), _shaft(rng, hole=edge), higher])) == []
    # ... while a shaft against the wall (three sides of ceiling, nothing beyond) is one
    assert len(_find(np.vstack([_ceiling(rng, hole=edge), _shaft(rng, hole=edge)]))) == 1
    void = (1.0, 0.8, 4.0, 3.3)
    assert _find(np.vstack([_ceiling(rng, hole=void), _shaft(rng, hole=void, n=2000)])) == []
    # a missing ceiling tile: through it the plenum is seen well past its edges (ducts and the
    # slab 0.3-0.8 m up), where a skylight's shaft hides all beyond its reveals
    tile = (2.0, 1.5, 2.6, 2.1)
    plenum = np.column_stack([rng.uniform(1.4, 3.2, 3000), rng.uniform(0.9, 2.7, 3000),
                              CEIL + rng.uniform(0.3, 0.8, 3000)])
    assert _find(np.vstack([_ceiling(rng, hole=tile), plenum])) == []
    assert len(_find(np.vstack([_ceiling(rng, hole=tile), _shaft(rng, hole=tile)]))) == 1  # a shaft: one


def test_building_elements_puts_a_roof_window_in_the_roof_and_keeps_it():
    """Through building_elements: the window's parent is the roof slab it made, and a run
    without a scan (after an edit) keeps it in the new roof slab."""
    rng = np.random.default_rng(4)
    room = Shape("room0", ShapeType.INTERIOR, Polyhedron.prism([(0, 0), (5, 0), (5, 4), (0, 4)], 0.0, CEIL),
                 name="Room", terminal=True)
    model = BuildingModel(shapes=(room,), storeys=(Storey(0, 0.0, CEIL, "Ground"),))
    xyz = np.vstack([_ceiling(rng), _shaft(rng)])
    out = building_elements(model, PointCloud(xyz=xyz), params=ElementsParams())
    sky = [w for w in out.windows if w.attributes.get("skylight")]
    assert len(sky) == 1
    roof = out[sky[0].parent]
    assert roof.type == ShapeType.SLAB and roof.attributes["kind"] == "roof"
    again = building_elements(out, params=ElementsParams(detect_openings=False))
    kept = [w for w in again.windows if w.attributes.get("skylight")]
    assert [w.id for w in kept] == [sky[0].id] and again[kept[0].parent].attributes["kind"] == "roof"
