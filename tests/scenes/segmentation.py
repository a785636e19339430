"""Tiny scenes for the segmentation tests: points sampled on box rooms with noise, and the
checks of found planes and cells against a true model.

Independent of ``engine.synthetic`` so the segmentation tests check the algorithms on
scenes whose truth is written out here.
"""
import numpy as np
import shapely
from shapely.geometry import Polygon

from engine.model import ShapeType
from engine.pointcloud import PointCloud


def _rect(rng, origin, u, v, density, sigma, normal):
    """Points on the rectangle origin + s u + t v (s, t in [0, 1])."""
    area = np.linalg.norm(u) * np.linalg.norm(v)
    n = max(int(area * density), 3)
    s, t = rng.random(n), rng.random(n)
    p = origin + s[:, None] * u + t[:, None] * v
    return p + rng.normal(0, sigma, n)[:, None] * normal


def room_points(rng, x0, y0, x1, y1, z0, z1, density=400.0, sigma=0.005, walls=(True,) * 4,
                floor=True, ceiling=True):
    """Points on the inner faces of an axis-aligned room; returns (xyz, label) with labels
    0 wall, 1 floor, 2 ceiling."""
    parts, labels = [], []
    o = np.array
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    if floor:
        parts.append(_rect(rng, o([x0, y0, z0]), o([dx, 0, 0]), o([0, dy, 0]), density, sigma, o([0, 0, 1.0])))
        labels.append(1)
    if ceiling:
        parts.append(_rect(rng, o([x0, y0, z1]), o([dx, 0, 0]), o([0, dy, 0]), density, sigma, o([0, 0, 1.0])))
        labels.append(2)
    specs = [
        (o([x0, y0, z0]), o([dx, 0, 0]), o([0, 1.0, 0])),
        (o([x0, y1, z0]), o([dx, 0, 0]), o([0, 1.0, 0])),
        (o([x0, y0, z0]), o([0, dy, 0]), o([1.0, 0, 0])),
        (o([x1, y0, z0]), o([0, dy, 0]), o([1.0, 0, 0])),
    ]
    for on, (org, u, nrm) in zip(walls, specs):
        if on:
            parts.append(_rect(rng, org, u, o([0, 0, dz]), density, sigma, nrm))
            labels.append(0)
    lab = np.concatenate([np.full(len(p), l, np.int32) for p, l in zip(parts, labels)])
    return np.vstack(parts), lab


def box_points(rng, lo, hi, density, sigma):
    """Points on all six faces of a box (furniture)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    xyz, _ = room_points(rng, lo[0], lo[1], hi[0], hi[1], lo[2], hi[2], density, sigma)
    return xyz


def make_cloud(xyz, labels=None, scanners=None, scan_index=None):
    fields = {} if labels is None else {"label": labels}
    return PointCloud(xyz=xyz, fields=fields, scanner_positions=scanners, scan_index=scan_index)


def two_room_office(seed=0, sigma=0.005, density=400.0):
    """Two rooms 4 x 5 m and 3 x 5 m side by side sharing a 0.2 m thick wall at x = 4..4.2,
    floor 0, ceiling 2.7, with a desk in room 1. Returns (cloud, truth dict)."""
    rng = np.random.default_rng(seed)
    a, la = room_points(rng, 0, 0, 4, 5, 0, 2.7, density, sigma)
    b, lb = room_points(rng, 4.2, 0, 7.2, 5, 0, 2.7, density, sigma)
    desk = box_points(rng, (1.0, 1.0, 0.0), (2.6, 1.8, 0.75), density * 2, sigma)
    xyz = np.vstack([a, b, desk])
    lab = np.concatenate([la, lb, np.full(len(desk), 3, np.int32)])
    sc = np.array([[2.0, 3.5, 1.5], [5.7, 2.5, 1.5]])
    si = np.concatenate([np.zeros(len(a), np.int32), np.ones(len(b), np.int32), np.zeros(len(desk), np.int32)])
    truth = {
        "rooms": [(0, 0, 4, 5), (4.2, 0, 7.2, 5)],
        "walls_x": [0.0, 4.0, 4.2, 7.2],
        "walls_y": [0.0, 5.0],
        "floor": 0.0,
        "ceiling": 2.7,
    }
    return make_cloud(xyz, lab, sc, si), truth


def two_storey(seed=0, sigma=0.005, density=300.0):
    """Two storeys of one 6 x 4 m room: floors 0 and 3.0, ceilings 2.6 and 5.75 (0.4 m
    slab). Returns (cloud, [(floor, ceiling), ...])."""
    rng = np.random.default_rng(seed)
    a, la = room_points(rng, 0, 0, 6, 4, 0.0, 2.6, density, sigma)
    b, lb = room_points(rng, 0, 0, 6, 4, 3.0, 5.75, density, sigma)
    return make_cloud(np.vstack([a, b]), np.concatenate([la, lb])), [(0.0, 2.6), (3.0, 5.75)]


def rotation(yaw, tilt_x=0.0, tilt_y=0.0):
    """(4, 4) rotation: tilt about x, then about y, then yaw about z (radians)."""
    cz, sz = np.cos(yaw), np.sin(yaw)
    cx, sx = np.cos(tilt_x), np.sin(tilt_x)
    cy, sy = np.cos(tilt_y), np.sin(tilt_y)
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    m = np.eye(4)
    m[:3, :3] = rz @ ry @ rx
    return m


# ----------------------------------------------------------------------------- evaluation
def truth_walls(truth, transform, cloud_aligned, label_wall=0, band=0.03, grid=0.1):
    """Inner wall faces of the true rooms in the aligned frame with their visible share.

    Returns a list of (normal (3,), offset, polygon (k, 3), visible share 0..1); the visible
    share is the fraction of the face's 10 cm (length × height) bins holding wall-labelled
    points within ``band`` of it.
    """
    inv = np.linalg.inv(transform)
    r, t = inv[:3, :3], inv[:3, 3]
    lab = cloud_aligned.fields.get("label")
    pts = cloud_aligned.xyz if lab is None else cloud_aligned.xyz[lab == label_wall]
    out = []
    for s in truth.surfaces(types=(ShapeType.INTERIOR,)):
        if s.kind != "wall":
            continue
        poly = s.polygon @ r.T + t
        n = s.normal @ r.T
        off = float(n @ poly[0])
        u = np.cross([0, 0, 1.0], n)
        u /= np.linalg.norm(u)
        tu = poly @ u
        z = poly[:, 2]
        near = np.abs(pts @ n - off) <= band
        q = pts[near]
        a = q @ u
        ok = (a >= tu.min()) & (a <= tu.max()) & (q[:, 2] >= z.min()) & (q[:, 2] <= z.max())
        nt = max(int(np.ceil((tu.max() - tu.min()) / grid)), 1)
        nz = max(int(np.ceil((z.max() - z.min()) / grid)), 1)
        ti = np.minimum(((a[ok] - tu.min()) / grid).astype(int), nt - 1)
        zi = np.minimum(((q[ok, 2] - z.min()) / grid).astype(int), nz - 1)
        vis = len(np.unique(ti * nz + zi)) / (nt * nz)
        out.append((n, off, poly, vis))
    return out


def match_planes(planes, walls, max_angle_deg, max_dist):
    """Which visible (≥ 50 %) true walls have a plane within the angle and the distance,
    and which planes match no true wall.

    A plane matches a true wall when their normals are within ``max_angle_deg`` and, over
    the stretch where the plane's segment and the wall overlap along the wall, the plane
    lies within ``max_dist`` of the wall (checked at both ends of the overlap). Returns
    (matched flags of the visible walls, ids of unmatched planes)."""
    used = set()
    flags = []
    for n, off, poly, vis in walls:
        u = np.cross([0, 0, 1.0], n)
        u /= np.linalg.norm(u)
        tu = poly @ u
        ok = False
        for p in planes:
            ang = np.degrees(np.arccos(min(1.0, abs(float(p.normal @ n)))))
            if ang > max_angle_deg:
                continue
            e0, e1 = p.segment
            a0, a1 = float(e0 @ u[:2]), float(e1 @ u[:2])
            lo, hi = max(min(a0, a1), tu.min()), min(max(a0, a1), tu.max())
            if hi - lo <= 0:
                continue
            dist = 0.0
            for t in (lo, hi):
                x = e0 + (e1 - e0) * ((t - a0) / (a1 - a0) if a1 != a0 else 0.0)
                dist = max(dist, abs(float(n[:2] @ x) - off))
            if dist > max_dist:
                continue
            used.add(p.id)
            ok = True
        if vis >= 0.5:
            flags.append(ok)
    unmatched = [p.id for p in planes if p.id not in used]
    return flags, unmatched


def room_coverage(cells, truth, transform, storey=0):
    """For every true room of ``storey``: (name, covered share of its floor area by the union of
    the cells (shapely polygons) lying mostly inside it, area of that union outside the room
    as a share of the room's area)."""
    inv = np.linalg.inv(transform)
    out = []
    for s in truth.spaces:
        if s.storey != storey:
            continue
        fp = s.footprint()
        p3 = np.c_[fp, np.zeros(len(fp))] @ inv[:3, :3].T + inv[:3, 3]
        room = Polygon(p3[:, :2])
        parts = [c for c in cells if c.intersection(room).area > 0.5 * c.area]
        if not parts:
            out.append((s.name, 0.0, 0.0))
            continue
        u = shapely.union_all(parts)
        out.append((s.name, u.intersection(room).area / room.area, u.difference(room).area / room.area))
    return out
