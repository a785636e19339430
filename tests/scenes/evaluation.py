"""Hand-built models for the evaluation tests: a 6 m × 9 m × 2.5 m room and a corridor (like
the thesis's Fig. 5.9), an extra room, and the reference model made of the first two."""
import numpy as np

from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey

H = 2.5
ROOM = (0.0, 0.0, 6.0, 9.0)
CORRIDOR = (6.2, -1.5, 8.2, 10.5)
EXTRA = (-5.2, 1.5, -0.2, 7.5)


def room_model(rooms, jitter=0.0, rng=None):
    """Rooms ``{name: (x0, y0, x1, y1)}`` as interior prisms of height ``H``; ``jitter``: uniform
    noise (metres) on every wall position."""
    rng = np.random.default_rng(rng)
    shapes = []
    for name, (x0, y0, x1, y1) in rooms.items():
        if jitter:
            x0, y0, x1, y1 = np.array([x0, y0, x1, y1]) + rng.uniform(-jitter, jitter, 4)
        shapes.append(Shape(id=name, type=ShapeType.INTERIOR, geometry=Polyhedron.box((x0, y0, 0), (x1, y1, H)),
                            name=name))
    return BuildingModel(shapes=tuple(shapes), storeys=(Storey(0, 0.0, H),))


REF = room_model({"Room 1": ROOM, "Corridor": CORRIDOR})
"""The reference model: Room 1 and the corridor."""


def grow(rect, d, sides):
    """``rect`` (x0, y0, x1, y1) moved out by ``d`` metres on the named sides ("w", "s", "e", "n")."""
    x0, y0, x1, y1 = rect
    return (x0 - d * ("w" in sides), y0 - d * ("s" in sides), x1 + d * ("e" in sides), y1 + d * ("n" in sides))
