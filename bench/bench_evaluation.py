"""Speed of the quality evaluation and of the change detection.

* ``evaluation``: a 54-surface model (a 3 × 3 grid of rooms, 6 faces each) evaluated against
  its reference at 10 buffer sizes; the source has jittered walls (±1 cm), one room missing
  and one extra room. Goal: ≤ 10 s.
* ``changes``: :func:`engine.change.detect_changes` on the ``change_demo`` preset scanned with
  1 M points (5 mm noise, furniture), from a model misregistered by 5° yaw and 0.3 m —
  registration, classification, coverage and clusters. Goal: ≤ 15 s. Scene generation is not
  timed (wall and CPU time are both reported: the goal is on wall time on an unloaded
  machine). Quality figures (precision/recall of new walls, residual, redundant faces) and the
  peak resident memory (``VmHWM`` of this process so far) are reported alongside.
"""
from __future__ import annotations

import logging
import os
import time

import numpy as np

from bench import peak_rss_mb

from engine.change import NEW, detect_changes, transform_model
from engine.evaluation import evaluate
from engine.model import BuildingModel, Polyhedron, Shape, ShapeType, Storey

log = logging.getLogger(__name__)

GOAL_EVALUATION_S = 10.0
GOAL_CHANGES_S = 15.0
POINTS = 1_000_000
QUICK_POINTS = 150_000
ROOM_M = 5.0
WALL_M = 0.2
HEIGHT_M = 2.8


def _grid_model(n=3, jitter=0.0, skip=(), extra=False, seed=0) -> BuildingModel:
    rng = np.random.default_rng(seed)
    shapes = []
    cells = [(i, j) for i in range(n) for j in range(n)] + ([(n, 0)] if extra else [])
    for i, j in cells:
        if (i, j) in skip:
            continue
        x0, y0 = i * (ROOM_M + WALL_M), j * (ROOM_M + WALL_M)
        box = np.array([x0, y0, x0 + ROOM_M, y0 + ROOM_M]) + rng.uniform(-jitter, jitter, 4)
        shapes.append(Shape(id=f"room_{i}_{j}", type=ShapeType.INTERIOR, name=f"Room {i},{j}",
                            geometry=Polyhedron.box((box[0], box[1], 0.0), (box[2], box[3], HEIGHT_M))))
    return BuildingModel(shapes=tuple(shapes), storeys=(Storey(0, 0.0, HEIGHT_M),))


def _bench_evaluation() -> dict:
    ref = _grid_model()
    src = _grid_model(jitter=0.01, skip={(1, 1)}, extra=True, seed=1)
    evaluate(src, ref)  # warm-up (imports)
    t, c = time.perf_counter(), time.process_time()
    res = evaluate(src, ref)
    dt, cpu = time.perf_counter() - t, time.process_time() - c
    c = res.curves["all"]
    return {"reference_surfaces": len(res.reference), "source_surfaces": len(res.source),
            "buffers": len(res.buffers), "seconds": round(dt, 3), "cpu_seconds": round(cpu, 3), "goal_s": GOAL_EVALUATION_S,
            "met": dt <= GOAL_EVALUATION_S,
            "completeness": [round(float(x), 4) for x in c["completeness"]],
            "correctness": [round(float(x), 4) for x in c["correctness"]],
            "accuracy_m": [None if not np.isfinite(x) else round(float(x), 5) for x in c["accuracy"]]}


def _rot_z(deg, shift) -> np.ndarray:
    a = np.radians(deg)
    m = np.eye(4)
    m[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    m[:3, 3] = shift
    return m


def _bench_changes(points: int) -> dict:
    from engine.synthetic import preset

    t = time.perf_counter()
    scene = preset("change_demo", seed=0, target_points=points)
    gen = time.perf_counter() - t
    wrong = _rot_z(5.0, (0.3, 0.0, 0.0))
    model = transform_model(scene.truth, wrong)
    t, c = time.perf_counter(), time.process_time()
    res = detect_changes(model, scene.cloud)
    dt, cpu = time.perf_counter() - t, time.process_time() - c
    truth = scene.cloud.fields["new"] == 1
    pred = res.new_structure()
    tp = float(np.sum(pred & truth))
    pts = scene.cloud.xyz[::100]
    err = np.linalg.norm(pts @ (res.registration.transform - wrong)[:3, :3].T
                         + (res.registration.transform - wrong)[:3, 3], axis=1).max()
    return {"points": len(scene.cloud), "generation_s": round(gen, 2), "seconds": round(dt, 3),
            "cpu_seconds": round(cpu, 3), "load_average": list(os.getloadavg()),
            "goal_s": GOAL_CHANGES_S, "met": dt <= GOAL_CHANGES_S,
            "residual_m": res.registration.residual, "registration_error_max_m": float(err),
            "new_wall_precision": tp / max(pred.sum(), 1), "new_wall_recall": tp / max(truth.sum(), 1),
            "new_points_share": float(np.mean(res.point_type == NEW)),
            "redundant": res.redundant, "peak_rss_mb": round(peak_rss_mb(), 1)}


def run(out_dir: str, quick: bool) -> dict:
    """Timings of evaluate() (54 surfaces, 10 buffers) and detect_changes() (1 M points)."""
    out = {"evaluation": _bench_evaluation()}
    log.info("evaluation: %.2f s", out["evaluation"]["seconds"])
    out["changes"] = _bench_changes(QUICK_POINTS if quick else POINTS)
    log.info("changes: %d points in %.2f s", out["changes"]["points"], out["changes"]["seconds"])
    return out
