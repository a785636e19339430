"""Rooms and side faces of real architects' plans (issue 19): the IFC-built scenes.

For FZK-Haus (both storeys in one scan) and the Duplex (level 1, level 2 — the scan cut to
that storey's heights — and both levels in one scan), TLS and mobile, a few seeds, 300k
points (quick: FZK and Duplex both, TLS, seed 0): ``reconstruct`` with each method, then
:func:`engine.evaluation.rooms.room_scores` (one-to-one footprint IoU with open plans merged,
recall, mean IoU, small or low spaces the truth lacks, area outside the true envelope; only
the true spaces the scan reaches, :func:`~engine.evaluation.rooms.scanned_spaces`) and the
side-face (wall group) completeness and correctness at 10 cm of :func:`engine.evaluation.evaluate`
over the true surfaces the scan sees (:func:`engine.evaluation.annotate_visibility`, as the
thesis's evaluation; "all": over every true surface, e.g. a stairwell's faces on the storey a
cut leaves out). Open plans' virtual boundaries are no surfaces (``shared_face_gap``).
A failed reconstruction is a row with its error (an empty model is an error naming its stage).

Writes ``buildings_table.md`` (one markdown table per scene) and ``buildings_runs.json``.
Standalone: ``python -m bench.bench_buildings --out DIR [--scenes fzk_haus duplex]
[--noise tls mobile] [--seeds 0 1] [--methods auto generic] [--points N] [--label before]
[--positions-per-storey 1]`` (``--points 200000 --positions-per-storey 1``: the issue's sparse,
single-position scans, terrestrial only).
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import sys
import time
import traceback

import numpy as np

from engine.fileutil import atomic_write_text

log = logging.getLogger(__name__)

SCENES = ("fzk_haus", "duplex")
NOISES = ("tls", "mobile")
SEEDS = (0, 1)
METHODS = ("auto", "generic")
POINTS = 300_000
CUTS = {"fzk_haus": ("both",), "duplex": ("L1", "L2", "both")}
"""Which scans of each building: one storey of the truth (L1 = the first storey with rooms)
cut out of the whole scan, or the whole scan."""
COLUMNS = ("scan", "noise", "seed", "method", "storeys m/t", "rooms m/t", "matched", "recall", "mean IoU",
           "small/low", "outside m²", "wall compl", "wall corr", "compl all", "corr all", "rec s")


def _storeys_with_rooms(truth) -> list:
    used = sorted({s.storey for s in truth.spaces})
    return [k for k in used if 0 <= k < len(truth.storeys)]


def storey_cut(scene, k: int):
    """(cloud, truth) of truth storey ``k`` alone: points from just under its floor to just
    under the next storey's floor (its ceiling + 0.4 m for the top one); the truth's shapes
    of that storey and the spaces and walls of others reaching through its mid-height."""
    from engine.model import Storey

    st = scene.truth.storeys
    lo = st[k].floor_z - 0.2
    hi = st[k + 1].floor_z - 0.05 if k + 1 < len(st) else st[k].ceiling_z + 0.4
    z = scene.cloud.xyz[:, 2]
    cloud = scene.cloud.subset(np.flatnonzero((z >= lo) & (z <= hi)))
    mid = 0.5 * (st[k].floor_z + st[k].ceiling_z)
    keep = [s for s in scene.truth.shapes  # with the stairwells and walls reaching through it
            if s.storey == k or (s.type.value in ("interior", "wall") and s.bounds[0, 2] < mid < s.bounds[1, 2])]
    one = Storey(0, st[k].floor_z, st[k].ceiling_z, st[k].name, st[k].elevation)
    truth = scene.truth.with_(shapes=tuple(s.with_(storey=0) for s in keep), storeys=(one,), relations=())
    return cloud, truth


def one(scene, cut: str, method: str) -> dict:
    """Reconstruct one scan of a scene with one method and score it."""
    from engine.evaluation import evaluate
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct

    row = {"scan": f"{scene.name} {cut}", "noise": "tls" if scene.noise_sigma < 0.01 else "mobile",
           "seed": scene.seed, "method": method}
    if cut == "both":
        cloud, truth = scene.cloud, scene.truth
    else:
        ks = _storeys_with_rooms(scene.truth)
        cloud, truth = storey_cut(scene, ks[int(cut[1:]) - 1])
    row["points"] = int(len(cloud))
    t0 = time.perf_counter()
    try:
        model = reconstruct(cloud, method, rng=0)
    except Exception as e:  # a failed scan is a row of the table, not the end of the bench
        row["error"] = f"{type(e).__name__}: {e}"
        row["traceback"] = traceback.format_exc()
        return row
    row["rec_s"] = round(time.perf_counter() - t0, 2)
    seen = scanned_spaces(truth, cloud.xyz)
    row["rooms"] = room_scores(model, truth, seen=seen)
    try:
        from engine.evaluation import annotate_visibility

        ev = evaluate(model, truth)
        i = int(np.argmin(np.abs(ev.buffers - 0.10)))
        row["wall_completeness_all"] = float(ev.curve("completeness", "wall")[i])
        row["wall_correctness_all"] = float(ev.curve("correctness", "wall")[i])
        vis = annotate_visibility(truth, cloud)
        ev = evaluate(model, truth, visible={k: v["visible"] for k, v in vis.items()})
        row["wall_completeness"] = float(ev.curve("completeness", "wall")[i])
        row["wall_correctness"] = float(ev.curve("correctness", "wall")[i])
    except Exception as e:
        row["surface_error"] = f"{type(e).__name__}: {e}"
    return row


def _f(v, nd=2) -> str:
    return "—" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{nd}f}"


def table(rows: list) -> str:
    """Markdown: one table per building, one row per scan / noise / seed / method."""
    out = []
    for name in dict.fromkeys(r["scan"].split()[0] for r in rows):
        out += [f"### {name}", "", "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
        for r in rows:
            if r["scan"].split()[0] != name:
                continue
            head = [r["scan"], r["noise"], str(r["seed"]), r["method"]]
            if "error" in r:
                out.append("| " + " | ".join(head + [r["error"][:80]] + [""] * (len(COLUMNS) - 5)) + " |")
                continue
            s = r["rooms"]
            out.append("| " + " | ".join(head + [
                f"{s['storeys']['model']}/{s['storeys']['truth']}", f"{s['model']}/{s['true']}", str(s["matched"]),
                _f(s["recall"]), _f(s["mean_iou"]), str(s["small_spurious"]), _f(s["outside_m2"], 1),
                _f(r.get("wall_completeness")), _f(r.get("wall_correctness")), _f(r.get("wall_completeness_all")),
                _f(r.get("wall_correctness_all")), _f(r.get("rec_s"), 1)]) + " |")
        out.append("")
    return "\n".join(out)


def run(out_dir: str, quick: bool = False, *, scenes=SCENES, noises=NOISES, seeds=SEEDS, methods=METHODS,
        points: int = POINTS, label: str = "", positions_per_storey=None) -> dict:
    from engine.synthetic.ifcscene import ifc_scene, ifc_truth, ifc_geometry, ifc_scene_path

    if quick:
        noises, seeds, methods = ("tls",), (0,), ("auto",)
    rows = []
    for name in scenes:
        truth = ifc_truth(ifc_scene_path(name))
        geo = ifc_geometry(ifc_scene_path(name), offset=truth.offset)
        for noise in noises:
            for seed in seeds:
                if positions_per_storey is not None and noise == "mobile":
                    continue  # one static position per storey is a terrestrial scan
                sc = ifc_scene(name, seed=seed, noise=noise, target_points=points, truth=truth, geometry=geo,
                               positions_per_storey=positions_per_storey)
                for cut in (("both",) if quick else CUTS[name]):
                    for method in methods:
                        r = one(sc, cut, method)
                        log.info("%s", {k: v for k, v in r.items() if k not in ("traceback",)})
                        rows.append(r)
    md = table(rows)
    if label:
        md = f"## {label}\n\n" + md
    os.makedirs(out_dir, exist_ok=True)
    stem = "buildings" + (f"_{label}" if label else "")
    atomic_write_text(os.path.join(out_dir, stem + "_table.md"), md + "\n")
    atomic_write_text(os.path.join(out_dir, stem + "_runs.json"), json.dumps(rows, indent=1, default=str) + "\n")
    print(md)
    return {"rows": [{k: v for k, v in r.items() if k != "traceback"} for r in rows]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_buildings", description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join("out", "bench"))
    ap.add_argument("--scenes", nargs="+", default=list(SCENES))
    ap.add_argument("--noise", nargs="+", default=list(NOISES))
    ap.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS))
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    ap.add_argument("--points", type=int, default=POINTS)
    ap.add_argument("--label", default="")
    ap.add_argument("--positions-per-storey", type=int, default=None)
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    run(a.out, a.quick, scenes=a.scenes, noises=a.noise, seeds=a.seeds, methods=a.methods, points=a.points,
        label=a.label, positions_per_storey=a.positions_per_storey)
    return 0


if __name__ == "__main__":
    sys.exit(main())
