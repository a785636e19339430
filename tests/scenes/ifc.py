"""A small hand-built model with every kind of entity the IFC writer makes (the IFC tests and
the subprocesses they start import it from here)."""
from engine import BuildingModel, Polyhedron, Provenance, Relation, Shape, Storey

H = 2.6  # storey height, m


def small_model(seed=3, name="small", with_corridor=True) -> BuildingModel:
    """Two rooms with a wall and a door between them, an open (virtual) boundary to a corridor,
    walls, a floor slab and an outside space: every kind of entity the writer makes."""
    t = 0.2
    r1 = Shape("r1", "interior", Polyhedron.box((0, 0, 0), (4, 4, H)), name="Room 1")
    r2 = Shape("r2", "interior", Polyhedron.box((4.2, 0, 0), (8, 4, H)), name="Room 2")
    w1 = Shape("w1", "wall", Polyhedron.box((4, 0, 0), (4.2, 4, H)), name="Wall 1", children=("d1",),
               attributes={"thickness": t})
    w2 = Shape("w2", "wall", Polyhedron.box((-t, -t, 0), (8 + t, 0, H)), name="Wall 2",
               attributes={"thickness": t})
    d1 = Shape("d1", "door", Polyhedron.box((4, 1, 0), (4.2, 1.9, 2)), name="Door 1", parent="w1",
               attributes={"width": 0.9, "height": 2.0})
    s0 = Shape("s0", "slab", Polyhedron.box((-t, -t, -0.3), (8 + t, 6, 0)), name="Floor")
    x = Shape("x", "exterior", Polyhedron.box((0, -3, 0), (8, -t, H)), name="Outside")
    shapes = [r1, r2, w1, w2, d1, s0, x]
    rel = [Relation("adjacency", "r1", "r2", via="w1"), Relation("connectivity", "r1", "r2", via="d1")]
    if with_corridor:
        shapes.append(Shape("c", "interior", Polyhedron.box((0, 4, 0), (8, 6, H)), name="Corridor"))
        rel += [Relation("adjacency", "r1", "c"), Relation("connectivity", "r1", "c")]
    return BuildingModel(shapes=tuple(shapes), storeys=(Storey(0, 0.0, H, "Ground", 0.0),), relations=rel,
                         provenance=Provenance("test", {"eps": 0.05}, seed), name=name)
