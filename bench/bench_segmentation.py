"""Time and peak memory of the shared preprocessing (:func:`engine.pipeline.preprocess`:
working cloud, normals, point clusters, storeys, planes), the Manhattan alignment and the
generic method's cells (:func:`engine.grammar.generic.storey_cells`) on the ``office_mw``
synthetic scan at 1M and 5M points (targets: ≤ 15 s and ≤ 60 s on the 2-core machine).

Each size runs in a fresh subprocess that loads the cloud from a temporary ``.npy`` file,
so the peak resident set (``VmHWM``) is that of the preprocessing alone (plus the imports
and the input array, reported separately as the baseline after loading). Wall-clock and
CPU seconds are both reported: the machine is shared, so the wall clock depends on the load
(recorded too).
"""
from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

log = logging.getLogger(__name__)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZES = (1_000_000, 5_000_000)
QUICK_SIZES = (200_000,)
TARGET_S = {1_000_000: 15.0, 5_000_000: 60.0}
PRESET = "office_mw"

_MEASURE = r"""
import json, sys, time, os
def hwm_mb():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
def rss_mb():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")
import numpy as np
import open3d, scipy.spatial, shapely  # imports are not part of the timing
from engine.pointcloud import PointCloud
from engine.grammar.generic import storey_cells
from engine.pipeline import align, preprocess
xyz = np.load(sys.argv[1])
cloud = PointCloud(xyz=xyz)
base = rss_mb()
t, c = time.perf_counter(), time.process_time()
res = align(preprocess(cloud, rng=0), rng=0)
t1 = time.perf_counter()
cells = storey_cells(res)
steps = dict(res.timings, cells=time.perf_counter() - t1)
dt, dc = time.perf_counter() - t, time.process_time() - c
print(json.dumps({"points": len(cloud), "working_points": len(res.working), "seconds": dt,
                  "cpu_seconds": dc, "steps": steps, "peak_rss_mb": hwm_mb(),
                  "rss_after_load_mb": base, "storeys": len(res.storeys),
                  "planes": len(res.planes), "cells": sum(len(sc.cells) for sc in cells),
                  "load_average": list(os.getloadavg())}))
"""


def run(out_dir: str, quick: bool = False) -> dict:
    from engine.synthetic import preset

    sizes = QUICK_SIZES if quick else SIZES
    results = []
    with tempfile.TemporaryDirectory(prefix="bench_seg_") as tmp:
        for n in sizes:
            t0 = time.perf_counter()
            scene = preset(PRESET, seed=0, target_points=n)
            gen = time.perf_counter() - t0
            path = os.path.join(tmp, f"cloud_{n}.npy")
            np.save(path, scene.cloud.xyz)
            del scene
            env = dict(os.environ)
            env["PYTHONPATH"] = ROOT + os.pathsep + env.get("PYTHONPATH", "")
            proc = subprocess.run([sys.executable, "-c", _MEASURE, path], capture_output=True, text=True,
                                  cwd=ROOT, env=env)
            if proc.returncode != 0:
                raise RuntimeError(f"preprocess of {n} points failed: {proc.stderr[-2000:]}")
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            r["generate_seconds"] = gen
            r["target_seconds"] = TARGET_S.get(n)
            r["meets_target"] = None if n not in TARGET_S else bool(r["seconds"] <= TARGET_S[n])
            log.info("segmentation %d points: %.1f s wall, %.1f s CPU, peak %.0f MB", n, r["seconds"],
                     r["cpu_seconds"], r["peak_rss_mb"])
            results.append(r)
    return {"preset": PRESET, "runs": results}
