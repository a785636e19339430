"""Quality and time of ``reconstruct`` on every reconstruction preset, TLS and mobile.

For each preset and noise model (one seed, 300k points; quick: three presets, 100k):
``reconstruct(cloud, "auto")`` and ``reconstruct(cloud, <the method auto chose>)`` on the
same scan. Figures: method and Manhattan score, rooms found and true, mean footprint IoU of
the true rooms (each matched one-to-one with its best model room), side-face completeness
and correctness at b = 10 cm, the per-stage timings the model records, the seconds
``auto`` costs beyond running the chosen method directly (the method choice), and the
seconds of writing the IFC and the model JSON with their share of the whole convert.
"""
from __future__ import annotations

import logging
import os
import tempfile
import time

import numpy as np

log = logging.getLogger(__name__)

PRESETS = ("office_mw", "two_storey_office", "house_multi_height", "unscanned_room", "syn_house",
           "hexagon_hall")
QUICK_PRESETS = ("office_mw", "syn_house", "hexagon_hall")
POINTS, QUICK_POINTS = 300_000, 100_000


def room_scores(model, truth) -> tuple[int, float]:
    """(true rooms matched, mean IoU over the true rooms; unmatched count 0), matching each
    true room one-to-one with the model room of the same storey that overlaps it most."""
    from shapely.geometry import Polygon

    def poly(s):
        return Polygon(s.footprint()).buffer(0)

    pairs = []
    for i, t in enumerate(truth.spaces):
        pt = poly(t)
        for j, s in enumerate(model.spaces):
            if s.storey != t.storey:
                continue
            ps = poly(s)
            inter = pt.intersection(ps).area
            if inter > 0:
                pairs.append((inter / pt.union(ps).area, i, j))
    pairs.sort(reverse=True)
    used_t, used_m, ious = set(), set(), {}
    for iou, i, j in pairs:
        if i in used_t or j in used_m:
            continue
        used_t.add(i)
        used_m.add(j)
        ious[i] = iou
    n = len(truth.spaces)
    matched = sum(1 for v in ious.values() if v >= 0.5)
    return matched, float(sum(ious.values()) / max(n, 1))


def _one(name: str, noise: str, points: int) -> dict:
    from engine.evaluation import EvaluationParams, evaluate
    from engine.ifc import write_ifc
    from engine.reconstruct import reconstruct
    from engine.synthetic import preset

    sc = preset(name, seed=0, noise=noise, target_points=points)
    t0 = time.perf_counter()
    model = reconstruct(sc.cloud, "auto", rng=0)
    t_auto = time.perf_counter() - t0
    method = model.provenance.method
    t0 = time.perf_counter()
    direct = reconstruct(sc.cloud, method, rng=0)
    t_direct = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        write_ifc(model, os.path.join(tmp, "m.ifc"))
        t_ifc = time.perf_counter() - t0
        t0 = time.perf_counter()
        model.to_json(os.path.join(tmp, "m.json"))
        t_json = time.perf_counter() - t0
    matched, iou = room_scores(model, sc.truth)
    res = evaluate(model, sc.truth, EvaluationParams(buffers=(0.1,), groups=("wall",)))
    out = {
        "preset": name, "noise": noise, "points": int(sc.cloud.n), "method": method,
        "manhattan_score": model.provenance.parameters.get("manhattan_score"),
        "rooms": len(model.spaces), "rooms_truth": len(sc.truth.spaces), "rooms_matched": matched,
        "mean_iou": round(iou, 4),
        "completeness_b10cm": round(float(res.curves["wall"]["completeness"][0]), 4),
        "correctness_b10cm": round(float(res.curves["wall"]["correctness"][0]), 4),
        "direct_same_rooms": len(direct.spaces) == len(model.spaces),
        "auto_s": round(t_auto, 2), "direct_s": round(t_direct, 2),
        "choice_overhead_s": round(t_auto - t_direct, 2),
        "ifc_s": round(t_ifc, 3), "json_s": round(t_json, 3),
        "writing_share": round((t_ifc + t_json) / (t_auto + t_ifc + t_json), 3),
        "timings": {k: round(float(v), 3) for k, v in model.provenance.timings.items()
                    if isinstance(v, (int, float))},
    }
    log.info("%s %s: %s rooms %d/%d IoU %.3f, auto %.1f s, direct %.1f s", name, noise, method,
             matched, out["rooms_truth"], iou, t_auto, t_direct)
    return out


def run(out_dir: str, quick: bool = False) -> dict:
    presets = QUICK_PRESETS if quick else PRESETS
    points = QUICK_POINTS if quick else POINTS
    runs = [_one(name, noise, points) for name in presets for noise in ("tls", "mobile")]
    return {"runs": runs, "load_average": list(os.getloadavg()),
            "mean_iou": round(float(np.mean([r["mean_iou"] for r in runs])), 4),
            "auto_s_total": round(sum(r["auto_s"] for r in runs), 2),
            "choice_overhead_s_total": round(sum(r["choice_overhead_s"] for r in runs), 2),
            "writing_share_max": max(r["writing_share"] for r in runs)}
