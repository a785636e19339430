"""Non-Manhattan scenes with known rooms for the generic-method tests (cells, rjMCMC).

Written out here (independent of ``engine.synthetic``) so the rjMCMC tests check the search on
scenes whose truth is explicit: rooms are the pieces of a partition shrunk by half the wall
thickness; points are sampled on every room's floor, ceiling and side faces, with exact
inward normals and Gaussian noise along the normal.
"""

import numpy as np
import shapely
import shapely.affinity as aff

from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey
from engine.pointcloud import PointCloud

Z0, Z1 = 0.0, 2.7


def hexagon_rooms(R=7.0, r=3.5, thickness=0.2):
    """A hexagonal hall (inner hexagon) ringed by six trapezoid rooms; 7 rooms, walls 60° apart."""
    ang = np.radians(np.arange(6) * 60.0 + 15.0)
    outer = np.column_stack([R * np.cos(ang), R * np.sin(ang)])
    inner = np.column_stack([r * np.cos(ang), r * np.sin(ang)])
    pieces = [shapely.Polygon(inner)]
    for i in range(6):
        j = (i + 1) % 6
        pieces.append(shapely.Polygon([inner[i], outer[i], outer[j], inner[j]]))
    return [p.buffer(-thickness / 2, join_style="mitre") for p in pieces]


def skew_rooms(thickness=0.2, angle=23.0):
    """A 12 m x 8 m house rotated by ``angle`` degrees, four rooms and a slanted wall."""
    pieces = [shapely.box(0, 0, 5, 8), shapely.Polygon([(5, 0), (12, 0), (12, 3), (5, 4.5)]),
              shapely.Polygon([(5, 4.5), (12, 3), (12, 8), (8.5, 8), (8.5, 4.5 - 3.5 * 1.5 / 7)]),
              shapely.Polygon([(5, 4.5), (8.5, 4.5 - 3.5 * 1.5 / 7), (8.5, 8), (5, 8)])]
    return [aff.rotate(p.buffer(-thickness / 2, join_style="mitre"), angle, origin=(0, 0)) for p in pieces]


def _rect_points(rng, origin, u, v, density, sigma, normal):
    area = np.linalg.norm(u) * np.linalg.norm(v)
    n = max(int(area * density), 3)
    s, t = rng.random(n), rng.random(n)
    p = origin + s[:, None] * u + t[:, None] * v
    return p + rng.normal(0, sigma, n)[:, None] * normal, np.tile(normal, (n, 1))


def sample_rooms(rooms, density=150.0, sigma=0.005, seed=0, z0=Z0, z1=Z1):
    """PointCloud on the rooms' floors, ceilings and side faces; fields["label"] 0 wall,
    1 floor, 2 ceiling."""
    rng = np.random.default_rng(seed)
    xyz, nrm, lab = [], [], []
    for room in rooms:
        room = shapely.geometry.polygon.orient(room, 1.0)
        lo = np.array(room.bounds[:2])
        hi = np.array(room.bounds[2:])
        for z, nz, label in ((z0, 1.0, 1), (z1, -1.0, 2)):
            k = int(room.area * density * (hi - lo).prod() / room.area)
            q = lo + rng.random((k, 2)) * (hi - lo)
            q = q[shapely.contains_xy(room, q[:, 0], q[:, 1])]
            zz = z + rng.normal(0, sigma, len(q))
            xyz.append(np.column_stack([q, zz]))
            nrm.append(np.tile([0.0, 0.0, nz], (len(q), 1)))
            lab.append(np.full(len(q), label))
        c = np.asarray(room.exterior.coords)
        for a, b in zip(c[:-1], c[1:]):
            d = b - a
            inward = np.array([-d[1], d[0], 0.0]) / np.linalg.norm(d)  # CCW: left is inside
            p, n = _rect_points(rng, np.array([a[0], a[1], z0]), np.array([d[0], d[1], 0.0]),
                                np.array([0.0, 0.0, z1 - z0]), density, sigma, inward)
            xyz.append(p)
            nrm.append(n)
            lab.append(np.zeros(len(p)))
    xyz = np.vstack(xyz)
    return PointCloud(xyz=xyz, normals=np.vstack(nrm).astype(np.float32),
                      fields={"label": np.concatenate(lab).astype(np.int32)})


def truth_model(rooms, z0=Z0, z1=Z1):
    """A truth BuildingModel: one interior prism per room."""
    shapes = [Shape(id=f"room{i}", type=ShapeType.INTERIOR,
                    geometry=Polyhedron.prism(np.asarray(r.exterior.coords)[:-1], z0, z1), name=f"Room {i + 1}")
              for i, r in enumerate(rooms)]
    return BuildingModel(shapes=tuple(shapes), storeys=(Storey(0, z0, z1),))


def room_lines(rooms):
    """(k, 3) lines (nx, ny, rho) of every room edge (the true wall planes)."""
    out = []
    for r in rooms:
        c = np.asarray(r.exterior.coords)
        for a, b in zip(c[:-1], c[1:]):
            d = (b - a) / np.linalg.norm(b - a)
            n = np.array([-d[1], d[0]])
            out.append((n[0], n[1], float(n @ a)))
    return np.array(out)


def match_rooms(polys, rooms):
    """Best IoU of every true room with a found footprint (list, one per room)."""
    out = []
    for r in rooms:
        best = 0.0
        for p in polys:
            i = r.intersection(p).area
            if i > 0:
                best = max(best, i / r.union(p).area)
        out.append(best)
    return out
