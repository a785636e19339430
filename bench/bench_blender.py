"""Import speed of scans into Blender: the engine read, the bridge, and the whole operator.

A synthetic cloud (uniform points in a 20 x 15 x 3 m box) is written as binary PLY twice:
with coordinates only, and with colour, intensity and normals. A fresh process with the
bpy module (Blender 4.5) registers the add-on from the source tree and measures, best of a
few repeats on a fresh scene each:

* ``read_s``      — ``engine.io.read_point_cloud`` alone (engine, no Blender);
* ``bridge_s``    — ``bridge.point_cloud_to_object``: mesh, attributes, modifier, material
  (engine read excluded);
* ``evaluate_s``  — the first depsgraph evaluation (Geometry Nodes "Mesh to Points");
* ``operator_s``  — ``bpy.ops.indoor.import_scan`` end to end (engine read included).

Target ("millions of points load in seconds"): 1M points into Blender in ≤ 3 s.

The same process also times ``bridge.model_to_objects`` on the true model of a 20-room grid
plan (engine.synthetic: rooms, walls, doors, slabs; target ≤ 1 s), a second build that
replaces the first, and drawing both topology graphs.
"""
from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import tempfile

import numpy as np

from engine.io import write_ply
from engine.pointcloud import PointCloud

log = logging.getLogger(__name__)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
POINTS = 1_000_000
QUICK_POINTS = 100_000
REPEATS = 3
QUICK_REPEATS = 1
TARGET_S = 3.0
"""Goal for 1M points into Blender (operator, read included)."""
BOX_M = (20.0, 15.0, 3.0)
SEED = 0

_MEASURE = r"""
import importlib, importlib.util, json, os, sys, time
root, out_path, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3])
files = sys.argv[4:]
import bpy
spec = importlib.util.spec_from_file_location("indoor_reconstruction", os.path.join(root, "__init__.py"),
                                              submodule_search_locations=[root])
pkg = importlib.util.module_from_spec(spec)
sys.modules["indoor_reconstruction"] = pkg
spec.loader.exec_module(pkg)
addon = importlib.import_module("indoor_reconstruction.blender_indoor_addon")
io = importlib.import_module("indoor_reconstruction.engine.io")
addon.register()
results = {}
try:
    for path in files:
        r = {"read_s": [], "bridge_s": [], "evaluate_s": [], "operator_s": []}
        for _ in range(repeats):
            bpy.ops.wm.read_homefile(app_template="", use_factory_startup=True)
            t = time.perf_counter(); cloud = io.read_point_cloud(path)
            r["read_s"].append(time.perf_counter() - t)
            t = time.perf_counter(); obj = addon.bridge.point_cloud_to_object(cloud)
            r["bridge_s"].append(time.perf_counter() - t)
            t = time.perf_counter(); dg = bpy.context.evaluated_depsgraph_get(); obj.evaluated_get(dg)
            r["evaluate_s"].append(time.perf_counter() - t)
            del cloud
            bpy.ops.wm.read_homefile(app_template="", use_factory_startup=True)
            t = time.perf_counter(); res = bpy.ops.indoor.import_scan(filepath=path)
            r["operator_s"].append(time.perf_counter() - t)
            assert res == {"FINISHED"}, res
            r["vertices"] = len(bpy.context.view_layer.objects.active.data.vertices)
        results[os.path.basename(path)] = r
    model_path = os.environ.get("INDOOR_BENCH_MODEL")
    if model_path:
        model_mod = importlib.import_module("indoor_reconstruction.engine.model")
        with open(model_path) as f:
            model = model_mod.BuildingModel.from_json(f.read())
        r = {"build_s": [], "rebuild_s": [], "graphs_s": []}
        for _ in range(repeats):
            bpy.ops.wm.read_homefile(app_template="", use_factory_startup=True)
            t = time.perf_counter(); by = addon.bridge.model_to_objects(model)
            r["build_s"].append(time.perf_counter() - t)
            t = time.perf_counter(); addon.bridge.model_to_objects(model)
            r["rebuild_s"].append(time.perf_counter() - t)
            t = time.perf_counter()
            addon.bridge.graph_to_curve(model, "adjacency")
            addon.bridge.graph_to_curve(model, "connectivity")
            r["graphs_s"].append(time.perf_counter() - t)
        r["objects"] = sum(len(v) for v in by.values())
        r["spaces"] = len(by.get("Spaces", []))
        results["model"] = r
    with open("/proc/self/status") as f:
        results["peak_rss_mb"] = [int(l.split()[1]) / 1024 for l in f if l.startswith("VmHWM")][0]
finally:
    addon.unregister()
    with open(out_path, "w") as f:
        json.dump(results, f)
    sys.stdout.flush()
    os._exit(0)
"""


def _clouds(n, rng):
    lo, hi = np.zeros(3), np.array(BOX_M)
    xyz = rng.uniform(lo, hi, (n, 3))
    normals = rng.normal(size=(n, 3)).astype(np.float32)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    plain = PointCloud(xyz=xyz)
    full = PointCloud(xyz=xyz, colors=rng.integers(0, 256, (n, 3), dtype=np.uint8),
                      intensity=rng.uniform(0, 1, n).astype(np.float32), normals=normals)
    return {"xyz": plain, "xyz_rgb_i_n": full}


ROOMS_GRID = (5, 4)
"""Rooms of the model-building benchmark: a 5 x 4 grid of 4 m x 3.5 m rooms (20 rooms)."""
MODEL_TARGET_S = 1.0
"""Goal for building the objects of a 20-room model."""


def grid_model():
    """The true model of a 20-room plan (engine.synthetic): rooms, walls, doors, slabs."""
    from engine.synthetic.plan import Door, FloorPlan, PlanStorey, build_truth, rooms_from_partition

    nx_, ny_ = ROOMS_GRID
    w, d = 4.0, 3.5
    cells = [(f"Room {j * nx_ + i + 1}", [(w * i, d * j), (w * (i + 1), d * j), (w * (i + 1), d * (j + 1)),
                                          (w * i, d * (j + 1))]) for j in range(ny_) for i in range(nx_)]
    rooms = rooms_from_partition(cells, 0.15)
    doors = [Door((f"Room {j * nx_ + i + 1}", f"Room {j * nx_ + i + 2}"), 0.5)
             for j in range(ny_) for i in range(nx_ - 1)]
    plan = FloorPlan("grid20", (PlanStorey(0.0, 2.8, "Ground floor"),), tuple(rooms), tuple(doors),
                     interior_thickness=0.15, exterior_thickness=0.3)
    return build_truth(plan)


def run(out_dir: str, quick: bool) -> dict:
    """Measure; return ``{points, repeats, target_s, cases: {name: figures}, ...}``."""
    n = QUICK_POINTS if quick else POINTS
    repeats = QUICK_REPEATS if quick else REPEATS
    rng = np.random.default_rng(SEED)
    with tempfile.TemporaryDirectory(prefix="bench_blender_") as tmp:
        paths = {}
        for name, cloud in _clouds(n, rng).items():
            paths[name] = os.path.join(tmp, f"{name}.ply")
            write_ply(paths[name], cloud)
        script = os.path.join(tmp, "measure.py")
        with open(script, "w") as f:
            f.write(_MEASURE)
        out_json = os.path.join(tmp, "result.json")
        model = grid_model()
        model_path = os.path.join(tmp, "grid20.json")
        with open(model_path, "w") as f:
            f.write(model.to_json())
        env = dict(os.environ, INDOOR_BENCH_MODEL=model_path)
        proc = subprocess.run([sys.executable, script, ROOT, out_json, str(repeats), *paths.values()],
                              stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=1800, env=env)
        if not os.path.exists(out_json):
            raise RuntimeError("the Blender measurement failed:\n" + proc.stderr[-3000:])
        with open(out_json) as f:
            raw = json.load(f)
    cases = {}
    for name, path in paths.items():
        r = raw.get(os.path.basename(path))
        if r is None:
            raise RuntimeError(f"no figures for {name}: " + proc.stderr[-2000:])
        best = {k: round(min(v), 3) for k, v in r.items() if isinstance(v, list)}
        best["vertices"] = r["vertices"]
        best["into_blender_excluding_read_s"] = round(best["bridge_s"] + best["evaluate_s"], 3)
        best["into_blender_including_read_s"] = best["operator_s"]
        best["points_per_s_operator"] = round(n / best["operator_s"])
        cases[name] = best
        log.info("%s: %d points, read %.2f s, bridge %.2f s, evaluate %.2f s, operator %.2f s",
                 name, n, best["read_s"], best["bridge_s"], best["evaluate_s"], best["operator_s"])
    worst = max(c["operator_s"] for c in cases.values())
    m = raw.get("model", {})
    model_fig = {k: round(min(v), 3) for k, v in m.items() if isinstance(v, list)}
    model_fig.update(objects=m.get("objects"), spaces=m.get("spaces"), shapes=len(model.shapes),
                     target_s=MODEL_TARGET_S,
                     meets_target=bool(model_fig and model_fig["build_s"] <= MODEL_TARGET_S))
    log.info("20-room model: %s objects built in %.3f s (rebuild %.3f s, graphs %.3f s)",
             model_fig.get("objects"), model_fig.get("build_s", float("nan")),
             model_fig.get("rebuild_s", float("nan")), model_fig.get("graphs_s", float("nan")))
    return {
        "points": n,
        "repeats": repeats,
        "target_s": TARGET_S,
        "target_points": POINTS,
        "meets_target": bool(not quick and worst <= TARGET_S),
        "cases": cases,
        "model_objects": model_fig,
        "peak_rss_mb": round(raw.get("peak_rss_mb", float("nan")), 1),
    }
