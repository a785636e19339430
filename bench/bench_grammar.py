"""Manhattan grammar and topology on ``office_mw`` (1M points; quick: 200k).

Target: grammar and topology ≤ 10 s after preprocessing on the 2-core
machine. Reports the preprocessing time (normals, Manhattan alignment, storeys) apart
from the grammar's own steps (levels, place + point-on-face index + classify, merge and
topology), the time of a manual reclassification and a door insertion (each re-derives
the topology), the peak resident memory, and the quality figures: share of
cuboids typed right, room count, side-face completeness/correctness at b = 10 cm (when
``engine.evaluation`` is present) and the median |distance| of wall points to the model.
"""
from __future__ import annotations

import os
import time

import numpy as np

from bench import peak_rss_mb

SIZES = (1_000_000,)
QUICK_SIZES = (200_000,)
TARGET_S = 10.0


def _truth_type(truth, c):
    from shapely.geometry import Point, Polygon

    from engine.model import ShapeType

    for s in truth.shapes:
        if s.type in (ShapeType.INTERIOR, ShapeType.WALL) and s.active:
            fp = s.footprint()
            lo, hi = s.bounds
            if fp is not None and lo[2] <= c[2] <= hi[2] and Polygon(fp).contains(Point(c[0], c[1])):
                return s.type
    return ShapeType.EXTERIOR


def _one(n: int, noise: str) -> dict:
    from engine.grammar import reconstruct_manhattan
    from engine.synthetic import LABEL_WALL, preset
    from engine.topology import insert_door, reclassify

    sc = preset("office_mw", seed=0, noise=noise, target_points=n)
    t0 = time.perf_counter()
    model = reconstruct_manhattan(sc.cloud, rng=0)
    total = time.perf_counter() - t0
    tm = dict(model.provenance.timings)
    grammar_s = sum(v for k, v in tm.items() if k != "preprocess")
    parts = [s for s in model.shapes if s.grid is not None]
    typed = float(np.mean([_truth_type(sc.truth, s.bounds.mean(axis=0)) == s.type for s in parts]))
    out = {"points": sc.cloud.n, "noise": noise, "seconds_total": total, "timings": tm,
           "grammar_and_topology_s": grammar_s, "target_s": TARGET_S, "within_target": grammar_s <= TARGET_S,
           "cuboids": len(parts), "typed_right": typed, "rooms": len(model.spaces),
           "rooms_truth": len(sc.truth.spaces), "walls": len(model.walls)}
    # editing: one reclassification and one door, each re-deriving the topology
    room = model.spaces[0]
    t1 = time.perf_counter()
    m2 = reclassify(model, [room.id], "exterior")
    out["reclassify_s"] = time.perf_counter() - t1
    adj = [r for r in model.relations_of("adjacency") if r.via and r.a in {s.id for s in model.spaces}
           and r.b in {s.id for s in model.spaces}]
    if adj:
        w = model[adj[0].via]
        lo, hi = w.bounds
        ax = int(w.attributes.get("axis", 0))
        la, lb = model[adj[0].a].bounds, model[adj[0].b].bounds
        mid = (max(la[0, ax], lb[0, ax]) + min(la[1, ax], lb[1, ax])) / 2 - lo[ax]
        t2 = time.perf_counter()
        m3 = insert_door(model, w.id, position=mid, width=0.9, height=2.0)
        out["insert_door_s"] = time.perf_counter() - t2
        out["door_connects"] = any(r.via == m3.doors[0].id for r in m3.relations_of("connectivity"))
    del m2
    try:
        from engine.evaluation import EvaluationParams, evaluate

        res = evaluate(model, sc.truth, EvaluationParams(buffers=(0.1,), groups=("wall",)))
        out["side_faces_completeness_b10cm"] = float(res.curves["wall"]["completeness"][0])
        out["side_faces_correctness_b10cm"] = float(res.curves["wall"]["correctness"][0])
    except ImportError:
        pass
    pts = sc.cloud.xyz[sc.cloud.fields["label"] == LABEL_WALL]
    best = np.full(len(pts), np.inf)
    for srf in model.surfaces():
        if srf.kind != "wall":
            continue
        a = int(np.argmax(np.abs(srf.normal)))
        lo, hi = srf.polygon.min(axis=0), srf.polygon.max(axis=0)
        o = [k for k in range(3) if k != a]
        inside = np.all((pts[:, o] >= lo[o] - 1e-3) & (pts[:, o] <= hi[o] + 1e-3), axis=1)
        best = np.where(inside, np.minimum(best, np.abs(pts[:, a] - lo[a])), best)
    fin = best[np.isfinite(best)]
    out["wall_points_median_distance_m"] = float(np.median(fin)) if len(fin) else None
    out["peak_rss_mb"] = peak_rss_mb()
    out["load_average"] = list(os.getloadavg())
    return out


def run(out_dir: str, quick: bool = False) -> dict:
    sizes = QUICK_SIZES if quick else SIZES
    runs = [_one(n, noise) for n in sizes for noise in ("tls", "mobile")]
    return {"preset": "office_mw", "runs": runs,
            "all_within_target": all(r["within_target"] for r in runs)}
