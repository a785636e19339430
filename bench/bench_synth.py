"""Speed and fidelity of ``indoor synth``.

1. The office_mw preset (about 1M points, terrestrial σ = 5 mm) written end to end (scan
   PLY, truth JSON and IFC, plan JSON, top-view PNG) in a fresh process, as a user runs
   it — target ≤ 20 s.
2. Every preset in both noise modes in this process (simulation only): point counts,
   scanner positions, seconds, the truth's size.
3. Fidelity on office_mw (TLS and mobile): the range residual of wall/floor/ceiling points
   along their ray against the true model's space prisms (median |r| / σ, 0.674 for
   Gaussian noise), the perpendicular distance to the nearest true surface (median / σ),
   label shares, and the share of the true wall area seen (a 5 cm grid on the spaces'
   wall faces, a cell seen when a wall point lies within 5 cm) with and without clutter
   from the same scanner positions.
"""
from __future__ import annotations

import json
import logging

import numpy as np
import os
import subprocess
import sys
import tempfile
import time

log = logging.getLogger(__name__)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FULL_POINTS = 1_000_000
QUICK_POINTS = 200_000
PER_PRESET_POINTS = 300_000
QUICK_PER_PRESET_POINTS = 50_000
TARGET_SECONDS = 20.0

_CLI = r"""
import argparse, json, sys, time
t0 = time.perf_counter()
from engine.cli.synth import add_synth
p = argparse.ArgumentParser(); sub = p.add_subparsers(); add_synth(sub)
a = p.parse_args(sys.argv[1:]); a.quiet = True; a.json = True
import io, contextlib
buf = io.StringIO()
with contextlib.redirect_stdout(buf):
    a.func(a)
out = json.loads(buf.getvalue())
with open("/proc/self/status") as f:
    hwm = [int(l.split()[1]) / 1024 for l in f if l.startswith("VmHWM")][0]
out["process_seconds"] = time.perf_counter() - t0
out["peak_rss_mb"] = hwm
print(json.dumps(out))
"""


def run(out_dir: str, quick: bool) -> dict:
    """Run the benchmark; returns figures (seconds, points, MB)."""
    from engine.synthetic import PRESETS, preset

    points = QUICK_POINTS if quick else FULL_POINTS
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", _CLI, "synth", "office_mw", "-o", tmp, "--seed", "0",
                               "--points", str(points)], cwd=ROOT, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t0
        cli = json.loads(proc.stdout.strip().splitlines()[-1])
        sizes = {os.path.basename(v): os.path.getsize(v) for v in cli["files"].values()}
    result = {
        "office_mw_cli": {
            "points": cli["points"], "scanner_positions": cli["scans"], "seconds_wall": round(wall, 2),
            "seconds_in_process": {k: v for k, v in cli["seconds"].items()},
            "peak_rss_mb": round(cli["peak_rss_mb"], 1), "file_bytes": sizes,
            "target_seconds": TARGET_SECONDS, "meets_target": wall <= TARGET_SECONDS,
        },
        "presets": {},
    }
    n = QUICK_PER_PRESET_POINTS if quick else PER_PRESET_POINTS
    for name in PRESETS:
        for noise in ("tls", "mobile"):
            t0 = time.perf_counter()
            sc = preset(name, seed=0, noise=noise, target_points=n)
            dt = time.perf_counter() - t0
            result["presets"][f"{name}/{noise}"] = {
                "points": len(sc.cloud), "target": n, "scanner_positions": int(sc.cloud.scan_count),
                "seconds": round(dt, 2), "truth": sc.truth.summary(), "variants": sorted(sc.variants),
            }
            log.info("%s/%s: %d points in %.2f s", name, noise, len(sc.cloud), dt)
    result["fidelity"] = {}
    for noise in ("tls", "mobile"):
        result["fidelity"][f"office_mw/{noise}"] = fidelity("office_mw", noise, points // (2 if quick else 1))
    return result


def _wall_grid(model, cell):
    """Points on a ``cell`` grid over the spaces' vertical faces: (n, 3) float64 metres."""
    pts = []
    for s in model.surfaces():
        if s.kind != "wall":
            continue
        v = s.polygon
        d = np.array([-s.normal[1], s.normal[0]])
        d /= np.linalg.norm(d)
        u = v[:, :2] @ d
        base = v[np.argmin(u), :2]
        us = np.arange(cell / 2, u.max() - u.min(), cell)
        zs = np.arange(v[:, 2].min() + cell / 2, v[:, 2].max(), cell)
        gu, gz = np.meshgrid(us, zs)
        p = base[None] + gu.reshape(-1, 1) * d[None]
        pts.append(np.column_stack([p, gz.ravel()]))
    return np.vstack(pts)


def fidelity(name: str, noise: str, points: int) -> dict:
    """Noise, label and occlusion figures of one preset scan (see module doc)."""
    import numpy as np
    import open3d as o3d
    import shapely
    from scipy.spatial import cKDTree
    from shapely.geometry import Polygon

    from engine.synthetic import LABEL_CLUTTER, LABEL_NAMES, LABEL_WALL, preset, simulate_scan

    sc = preset(name, seed=0, noise=noise, target_points=points)
    c, m, sigma = sc.cloud, sc.truth, sc.noise_sigma
    lab = c.fields["label"]
    vs, ts, off = [], [], 0
    for s in m.spaces:
        v, t = s.geometry.triangles()
        vs.append(v)
        ts.append(t + off)
        off += len(v)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.vstack(vs).astype(np.float32)),
                        o3d.core.Tensor(np.vstack(ts).astype(np.uint32)))
    pos = c.scanner_positions
    own = np.zeros(len(c), bool)
    for s in m.spaces:
        fp = Polygon(s.footprint())
        in_room = shapely.contains_xy(fp.buffer(-0.05), c.xyz[:, 0], c.xyz[:, 1])
        scan_in = shapely.contains_xy(fp, pos[:, 0], pos[:, 1])
        own |= in_room & scan_in[c.scan_index]
    sel = np.flatnonzero(own & (lab != LABEL_CLUTTER))
    o = pos[c.scan_index[sel]]
    v = c.xyz[sel] - o
    r = np.linalg.norm(v, axis=1)
    t = scene.cast_rays(o3d.core.Tensor(np.hstack([o, v / r[:, None]]).astype(np.float32)))["t_hit"].numpy()
    resid = r - t
    perp = scene.compute_distance(o3d.core.Tensor(c.xyz[sel].astype(np.float32))).numpy()
    params = sc.scan_params
    empty = simulate_scan(sc.plan, params, positions=pos, rng=0, clutter=False).cloud
    grid = _wall_grid(m, 0.05)

    def seen(cloud):
        w = cloud.xyz[cloud.fields["label"] == LABEL_WALL]
        d, _ = cKDTree(w).query(grid, distance_upper_bound=0.05)
        return float(np.mean(np.isfinite(d)))

    return {
        "points": len(c), "sigma_m": sigma, "checked_points": len(sel),
        "median_abs_range_residual_over_sigma": round(float(np.median(np.abs(resid))) / sigma, 4),
        "mean_range_residual_mm": round(float(np.mean(resid)) * 1000, 3),
        "median_perpendicular_distance_over_sigma": round(float(np.median(perp)) / sigma, 4),
        "p999_perpendicular_distance_over_sigma": round(float(np.quantile(perp, 0.999)) / sigma, 3),
        "label_share": {LABEL_NAMES[k]: round(float(np.mean(lab == k)), 4) for k in range(4)},
        "wall_area_seen_with_clutter": round(seen(c), 4),
        "wall_area_seen_without_clutter": round(seen(empty), 4),
    }
