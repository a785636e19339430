"""A hand-built scene with known changes for the change-detection tests (engine.change).

Old model: rooms A | B side by side (wall W1 between them), a corridor C behind wall W2,
outer walls, floor and ceiling slabs. The changed building: W1 removed (A and B are one
room), two new walls (N1 in the merged room, N2 across the corridor). The scan samples the
changed building's visible surfaces with 5 mm noise; points on the new walls carry
``fields["new"] = 1``.
"""
import numpy as np

from engine.evaluation.patches import patches_from_model, points_inside, project_to
from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey
from engine.pointcloud import PointCloud

H = 2.5
T = 0.2
ROOMS_OLD = {"A": (0, 0, 4, 6), "B": (4.2, 0, 8, 6), "C": (0, 6.2, 8, 8)}
ROOMS_NEW = {"AB": (0, 0, 8, 6), "C": (0, 6.2, 8, 8)}
NEW_WALLS = {"N1": (0, 3.0, 3.0, 3.1), "N2": (5.0, 6.2, 5.1, 8.0)}


def box(x0, y0, x1, y1, z0=0.0, z1=H):
    """Axis-aligned box polyhedron (metres)."""
    return Polyhedron.box((x0, y0, z0), (x1, y1, z1))


def old_model() -> BuildingModel:
    """The model before the changes: rooms A, B, corridor C, their walls and slabs; wall W1
    carries ``attributes["removed_in_scan"]``."""
    shapes = [Shape(id=f"room_{k}", type=ShapeType.INTERIOR, geometry=box(*r), name=f"Room {k}")
              for k, r in ROOMS_OLD.items()]
    walls = {"W1": (4, 0, 4.2, 6), "W2": (0, 6, 8, 6.2), "Wwest": (-T, -T, 0, 8 + T),
             "Weast": (8, -T, 8 + T, 8 + T), "Wsouth": (0, -T, 8, 0), "Wnorth": (0, 8, 8, 8 + T)}
    for k, w in walls.items():
        shapes.append(Shape(id=k, type=ShapeType.WALL, geometry=box(*w), name=k,
                            attributes={"thickness": T, "removed_in_scan": k == "W1"}))
    shapes.append(Shape(id="floor", type=ShapeType.SLAB, geometry=box(-T, -T, 8 + T, 8 + T, -T, 0)))
    shapes.append(Shape(id="ceiling", type=ShapeType.SLAB, geometry=box(-T, -T, 8 + T, 8 + T, H, H + T)))
    return BuildingModel(shapes=tuple(shapes), storeys=(Storey(0, 0.0, H),))


def sample_patch(patch, density, rng):
    """Uniform points on a model patch, ``density`` points per m² (Poisson count)."""
    minx, miny, maxx, maxy = patch.geom.bounds
    n = rng.poisson(density * (maxx - minx) * (maxy - miny))
    xy = np.column_stack([rng.uniform(minx, maxx, n), rng.uniform(miny, maxy, n)])
    xy = xy[points_inside(patch, xy)]
    return patch.to3d(xy)


def in_boxes(xyz, boxes, margin=0.0):
    m = np.zeros(len(xyz), dtype=bool)
    for x0, y0, x1, y1 in boxes:
        m |= (xyz[:, 0] > x0 - margin) & (xyz[:, 0] < x1 + margin) & (xyz[:, 1] > y0 - margin) & \
             (xyz[:, 1] < y1 + margin)
    return m


def changed_scan(density=800.0, sigma=0.005, seed=0) -> PointCloud:
    """Scan of the changed building: room faces minus what the new walls hide, plus the new
    walls' exposed faces; Gaussian noise of ``sigma`` metres."""
    rng = np.random.default_rng(seed)
    changed = BuildingModel(shapes=tuple(
        Shape(id=k, type=ShapeType.INTERIOR, geometry=box(*r)) for k, r in ROOMS_NEW.items()))
    pts, new = [], []
    for p in patches_from_model(changed):
        q = sample_patch(p, density, rng)
        q = q[~in_boxes(q, NEW_WALLS.values())]
        pts.append(q)
        new.append(np.zeros(len(q), dtype=np.int32))
    wall_model = BuildingModel(shapes=tuple(
        Shape(id=k, type=ShapeType.WALL, geometry=box(*r)) for k, r in NEW_WALLS.items()))
    inside_rooms = list(ROOMS_NEW.values())
    for p in patches_from_model(wall_model, (ShapeType.WALL,), kinds=("wall",)):
        q = sample_patch(p, density, rng)
        # keep the exposed parts (faces against an existing wall are hidden)
        inner = np.zeros(len(q), dtype=bool)
        for x0, y0, x1, y1 in inside_rooms:
            inner |= (q[:, 0] > x0 + 1e-3) & (q[:, 0] < x1 - 1e-3) & (q[:, 1] > y0 + 1e-3) & (q[:, 1] < y1 - 1e-3)
        q = q[inner]
        pts.append(q)
        new.append(np.ones(len(q), dtype=np.int32))
    xyz = np.vstack(pts)
    xyz = xyz + rng.normal(0.0, sigma, xyz.shape)
    return PointCloud(xyz, fields={"new": np.concatenate(new)})


def removed_faces(model):
    """Keys of the room faces coplanar with a side of the wall marked ``removed_in_scan``
    (derived from the geometry)."""
    rooms = patches_from_model(model)
    walls = [p for p in patches_from_model(model, (ShapeType.WALL,)) if model[p.shape_id].attributes.get(
        "removed_in_scan")]
    out = set()
    for r in rooms:
        for w in walls:
            if r.normal @ w.normal < -0.99 and abs(r.rho + w.rho) < 1e-6:
                if project_to(w.geom, w, r).intersection(r.geom).area > 0.5 * r.area:
                    out.add(r.key)
    return out


def rot_z(deg, shift):
    """4x4 rotation by ``deg`` degrees about z, then translation by ``shift`` (metres)."""
    a = np.radians(deg)
    m = np.eye(4)
    m[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    m[:3, 3] = shift
    return m


def precision_recall(pred, truth):
    """(precision, recall) of a boolean prediction against boolean truth."""
    tp = np.sum(pred & truth)
    return tp / max(pred.sum(), 1), tp / max(truth.sum(), 1)
