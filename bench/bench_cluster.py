"""Batch conversion on a Dask LocalCluster (engine/cluster.py) against the in-process loop.

* 8 small synthetic scans (``office_mw``, seeds 1..8) converted in process, then with 1 and
  2 worker processes: wall time, throughput, overhead per file against in process (the
  cluster's start-up is reported apart).
* 1,000 trivial tasks through the same submission path (:func:`engine.cluster.run_jobs`):
  the scheduler's cost per task, to show it is not the bottleneck next to a conversion.
"""
from __future__ import annotations

import os
import sys
import tempfile
import time

N_SCANS, POINTS = 8, 15_000
N_TRIVIAL = 1000


def trivial_task(job, data=None):
    """The task of the 1,000-job run: no conversion, the same result shape."""
    return {"input": job.path, "name": job.name, "status": "done", "seconds": 0.0}


def _scans(folder, n, points):
    from engine.io import write_ply
    from engine.synthetic import preset

    paths = []
    for seed in range(1, n + 1):
        p = os.path.join(folder, f"scan{seed}.ply")
        write_ply(p, preset("office_mw", seed=seed, noise="tls", target_points=points).cloud)
        paths.append(p)
    return paths


def run(out_dir, quick: bool = False) -> dict:
    import cloudpickle

    from engine import cluster, reconstruct

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers need not import bench/
    n, points, n_trivial = (4, 8_000, 200) if quick else (N_SCANS, POINTS, N_TRIVIAL)
    opts = {"method": "manhattan", "seed": 0}
    res: dict = {"scans": n, "points": points, "preset": "office_mw", "cpu_count": os.cpu_count()}
    with tempfile.TemporaryDirectory(prefix="bench-cluster-") as tmp:
        paths = _scans(tmp, n, points)
        out = os.path.join(tmp, "inproc")
        t0 = time.perf_counter()
        for p in paths:
            reconstruct.convert_file(p, out, **opts)
        inproc = time.perf_counter() - t0
        res["in_process"] = {"wall_s": round(inproc, 2), "per_file_s": round(inproc / n, 3),
                             "load_average_1min": round(os.getloadavg()[0], 2)}
        for workers in (1, 2):
            t0 = time.perf_counter()
            with cluster.connect(workers=workers) as client:
                start = time.perf_counter() - t0
                out = os.path.join(tmp, f"w{workers}")
                jobs = [cluster.Job(p, os.path.splitext(os.path.basename(p))[0], out, opts) for p in paths]
                t1 = time.perf_counter()
                results = cluster.run_jobs(client, jobs)
                wall = time.perf_counter() - t1
                entry = {"startup_s": round(start, 2), "wall_s": round(wall, 2),
                         "files_per_min": round(60 * n / wall, 2),
                         "ok": sum(r["status"] == "done" for r in results),
                         "task_s_mean": round(sum(r["seconds"] for r in results) / n, 3),
                         "peak_mb_max": max(r.get("peak_mb", 0) for r in results),
                         "overhead_per_file_s": round((wall * workers - inproc) / n, 3),
                         "speedup_vs_in_process": round(inproc / wall, 2),
                         "load_average_1min": round(os.getloadavg()[0], 2)}
                if workers == 2:
                    jobs = [cluster.Job(f"job{i}", f"job{i}", out, {}) for i in range(n_trivial)]
                    t1 = time.perf_counter()
                    done = cluster.run_jobs(client, jobs, task=trivial_task)
                    tw = time.perf_counter() - t1
                    res["trivial_tasks"] = {"tasks": n_trivial, "workers": 2, "wall_s": round(tw, 2),
                                            "per_task_ms": round(1000 * tw / n_trivial, 2),
                                            "ok": sum(r["status"] == "done" for r in done)}
            res[f"workers_{workers}"] = entry
    return res
