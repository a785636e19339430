"""A whole office floor from one scanner position: 70 m × 66 m, 60 offices on three
corridors, rotated 30° about z, with stray points up to 1 km away (issue 15's real-scan case:
cost must follow the points and the occupied area, not the file's extent).

One terrestrial position in the middle corridor (range 60 m) sees the corridors and the
offices only through their open doors. Figures: points, strays removed, seconds per stage
(read-free: reconstruct, IFC), peak RSS, spaces found (and how many under 5 m²), and the IFC's
size; ``--quick`` uses 200k points instead of 1M.
"""
from __future__ import annotations

import logging
import math
import os
import tempfile
import time

import numpy as np

from bench import peak_rss_mb

log = logging.getLogger(__name__)

POINTS, QUICK_POINTS = 1_000_000, 200_000
ROOM_W, ROOM_D, CORRIDOR = 7.0, 10.0, 2.0
COLUMNS = 10
ANGLE = math.radians(30.0)
STRAYS = 2_000
STRAY_RANGE = 1_000.0


def _rect(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def floor_plan():
    """60 offices (7 m × 10 m) in six rows along three 2 m corridors, 70 m × 66 m."""
    from engine.synthetic.plan import Door, FloorPlan, PlanStorey, rooms_from_partition

    cells, doors = [], []
    y = 0.0
    for band in range(3):
        rows = []
        for side in range(2):  # rooms below the corridor, the corridor, rooms above it
            if side == 1:
                corridor = f"Corridor {band + 1}"
                cells.append((corridor, _rect(0, y, COLUMNS * ROOM_W, y + CORRIDOR), {"furnished": False}))
                y += CORRIDOR
            row = []
            for k in range(COLUMNS):
                name = f"Office {band + 1}.{side + 1}.{k + 1}"
                cells.append((name, _rect(k * ROOM_W, y, (k + 1) * ROOM_W, y + ROOM_D)))
                row.append(name)
            rows.append(row)
            y += ROOM_D
        for row in rows:
            doors += [Door((name, f"Corridor {band + 1}"), 0.5) for name in row]
    rooms = rooms_from_partition(cells, 0.15)
    return FloorPlan("large_floor", (PlanStorey(0.0, 3.0, "Floor"),), tuple(rooms), tuple(doors),
                     interior_thickness=0.15, exterior_thickness=0.3)


def run(out_dir: str, quick: bool = False) -> dict:
    from engine.ifc import write_ifc
    from engine.pointcloud import PointCloud
    from engine.reconstruct import reconstruct
    from engine.synthetic.scan import ScanParams, simulate_scan

    plan = floor_plan()
    t0 = time.perf_counter()
    # in the middle corridor (y from 32 to 34 m), half-way along it
    origin = np.array([[COLUMNS * ROOM_W / 2, (2 * ROOM_D + CORRIDOR) + ROOM_D + CORRIDOR / 2, 1.5]])
    scan = simulate_scan(plan, ScanParams(mode="tls", max_range=60.0, target_points=QUICK_POINTS if quick else POINTS),
                         positions=origin, rng=0)
    t_scan = time.perf_counter() - t0
    rng = np.random.default_rng(0)
    c, s = math.cos(ANGLE), math.sin(ANGLE)
    turn = np.eye(4)
    turn[:2, :2] = [[c, -s], [s, c]]
    floor = scan.cloud.transformed(turn)
    strays = rng.uniform(-STRAY_RANGE, STRAY_RANGE, (STRAYS, 3)) * [1, 1, 0.05]
    cloud = PointCloud(xyz=np.r_[floor.xyz, strays], scanner_positions=floor.scanner_positions,
                       scan_index=np.zeros(len(floor) + STRAYS, np.int32), source="large_floor")
    t = time.perf_counter()
    model = reconstruct(cloud, "auto", rng=0)
    t_rec = time.perf_counter() - t
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "large_floor.ifc")
        t = time.perf_counter()
        write_ifc(model, path)
        t_ifc = time.perf_counter() - t
        size = os.path.getsize(path)
    areas = [s.geometry.plan_area_perimeter()[0] for s in model.spaces]
    out = {"points": int(len(cloud)), "scan_seconds": round(t_scan, 2), "method": model.provenance.method,
           "cleaning": model.provenance.trace.get("cleaning"),
           "reconstruct_seconds": round(t_rec, 2), "ifc_seconds": round(t_ifc, 2),
           "ifc_share_of_total": round(t_ifc / (t_rec + t_ifc), 3), "ifc_mb": round(size / 1e6, 2),
           "timings": {k: round(float(v), 2) for k, v in model.provenance.timings.items()
                       if isinstance(v, (int, float))},
           "spaces": len(model.spaces), "spaces_under_5m2": int(sum(a < 5.0 for a in areas)),
           "rooms_truth": len(plan.rooms), "walls": len(model.walls), "peak_rss_mb": round(peak_rss_mb()),
           "load_average": list(os.getloadavg()), "target_seconds": 15.0}
    log.info("large floor: %s", out)
    return out
