"""Plan views of the IFC-built scenes (issue 19): FZK-Haus and the Duplex, reconstructed and
drawn over the truth.

Each building is scanned with :func:`engine.synthetic.ifc_scene` (seed 1, TLS, 300k points;
quick: 100k), reconstructed with ``reconstruct(cloud, "auto", rng=0)`` and drawn with
:func:`engine.evaluation.planview.plan_view`: one PNG with the storeys side by side
(``<scene>_plan.png``) and one per storey (``<scene>_plan_<storey>.png``), the storeys that
have a scanned true room or a modelled space. :func:`~engine.evaluation.planview.plan_differences`
lists where the plan leaves the truth (extra and missing walls, spaces off the true rooms,
rooms not covered) in ``planviews.md``, with the room scores of
:func:`engine.evaluation.rooms.room_scores`; ``planviews.json`` has the same figures.

Standalone: ``python -m bench.bench_planviews --out DIR [--scenes fzk_haus duplex] [--seed 1]
[--noise tls] [--points N] [--docs docs/images]`` (``--docs``: also write the side-by-side
pictures there).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import sys
import time

from engine.fileutil import atomic_write_text

log = logging.getLogger(__name__)

SCENES = ("fzk_haus", "duplex")
SEED = 1
NOISE = "tls"
POINTS = 300_000
QUICK_POINTS = 100_000
DPI = 110


def _storeys_to_draw(model, truth, seen) -> list[int]:
    from engine.evaluation.elements import _storey_of, _truth_storey

    ks = {_truth_storey(s, truth) for s in truth.spaces if s.id in seen}
    ks |= {_storey_of(s, truth) for s in model.spaces}
    return sorted(k for k in ks if 0 <= k < len(truth.storeys)) or list(range(len(truth.storeys)))


def one(name: str, out_dir: str, *, seed: int = SEED, noise: str = NOISE, points: int = POINTS,
        dpi: int = DPI) -> dict:
    """Scan, reconstruct and draw one building; the figures of its pictures."""
    from engine.evaluation.planview import plan_differences, plan_view
    from engine.evaluation.rooms import room_scores, scanned_spaces
    from engine.reconstruct import reconstruct
    from engine.synthetic import ifc_scene

    t0 = time.perf_counter()
    sc = ifc_scene(name, seed=seed, noise=noise, target_points=points)
    t1 = time.perf_counter()
    model = reconstruct(sc.cloud, "auto", rng=0)
    t2 = time.perf_counter()
    seen = scanned_spaces(sc.truth, sc.cloud.xyz)
    scores = room_scores(model, sc.truth, seen=seen)
    ks = _storeys_to_draw(model, sc.truth, seen)
    title = f"{name}: seed {seed}, {noise.upper()}, {len(sc.cloud) // 1000}k points, reconstruct 'auto'"
    pictures = [plan_view(model, sc.truth, storey=ks, cloud=sc.cloud, title=title, dpi=dpi,
                          path=os.path.join(out_dir, f"{name}_plan.png"))]
    for k in ks:
        pictures.append(plan_view(model, sc.truth, storey=k, cloud=sc.cloud, title=title, dpi=dpi,
                                  panel_size=(9.0, 9.0), path=os.path.join(out_dir, f"{name}_plan_{k}.png")))
    for p in pictures:
        p["bytes"] = os.path.getsize(p["path"])
    diffs = plan_differences(model, sc.truth, storeys=ks)
    t3 = time.perf_counter()
    return dict(scene=name, seed=seed, noise=noise, points=int(len(sc.cloud)), storeys=ks,
                scan_s=round(t1 - t0, 1), reconstruct_s=round(t2 - t1, 1), draw_s=round(t3 - t2, 1),
                rooms={k: scores[k] for k in ("true", "model", "matched", "recall", "precision", "mean_iou",
                                              "small_spurious", "outside_m2")},
                per_storey=[{k: p[k] for k in ("storey", "true", "model", "matched", "ious", "true_groups")}
                            for p in scores["per_storey"]],
                pictures=pictures, differences=diffs)


def report(rows: list) -> str:
    """Markdown: per building, the room scores, the pictures and where the plan leaves the truth."""
    out = ["# Plan views (issue 19)", ""]
    for r in rows:
        s = r["rooms"]
        out += [f"## {r['scene']} (seed {r['seed']}, {r['noise']}, {r['points']} points)", "",
                f"rooms {s['matched']}/{s['true']} matched of {s['model']} modelled, recall {s['recall']:.2f}, "
                f"precision {s['precision']:.2f}, mean IoU {s['mean_iou']:.2f}, small/low extra "
                f"{s['small_spurious']}, outside {s['outside_m2']:.1f} m²; scan {r['scan_s']} s, "
                f"reconstruct {r['reconstruct_s']} s, draw {r['draw_s']} s", ""]
        for p in r["pictures"]:
            out.append(f"- `{os.path.basename(p['path'])}`: {p['width']}×{p['height']} px, {p['bytes'] // 1024} KB; "
                       + "; ".join(f"{q['name']}: {q['spaces']} spaces, {q['walls']} walls, {q['true_rooms']} true "
                                   f"rooms" for q in p["panels"]))
        out += ["", "| storey | kind | m² | x0 | y0 | x1 | y1 | shapes |", "|---|---|---|---|---|---|---|---|"]
        for d in r["differences"]:
            x0, y0, x1, y1 = d["bbox"]
            out.append(f"| {d['storey_name']} | {d['kind']} | {d['area']:.2f} | {x0:.2f} | {y0:.2f} | {x1:.2f} | "
                       f"{y1:.2f} | {', '.join(d['names'])[:90]} |")
        out.append("")
    return "\n".join(out)


def run(out_dir: str, quick: bool = False, *, scenes=SCENES, seed: int = SEED, noise: str = NOISE,
        points: int = POINTS, docs: str = "") -> dict:
    if quick:
        points = min(points, QUICK_POINTS)
    out = os.path.join(out_dir, "planviews")
    os.makedirs(out, exist_ok=True)
    rows = []
    for name in scenes:
        r = one(name, out, seed=seed, noise=noise, points=points)
        log.info("%s: %s", name, r["rooms"])
        rows.append(r)
        if docs:
            os.makedirs(docs, exist_ok=True)
            shutil.copyfile(r["pictures"][0]["path"], os.path.join(docs, f"{name}_plan.png"))
    md = report(rows)
    atomic_write_text(os.path.join(out, "planviews.md"), md + "\n")
    atomic_write_text(os.path.join(out, "planviews.json"), json.dumps(rows, indent=1, default=str) + "\n")
    print(md)
    return {"rows": [{k: v for k, v in r.items() if k != "differences"} | {"differences": len(r["differences"])}
                     for r in rows]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.bench_planviews", description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join("out", "bench"))
    ap.add_argument("--scenes", nargs="+", default=list(SCENES))
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--noise", default=NOISE)
    ap.add_argument("--points", type=int, default=POINTS)
    ap.add_argument("--docs", default="", help="also write <scene>_plan.png into this folder")
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    run(a.out, a.quick, scenes=a.scenes, seed=a.seed, noise=a.noise, points=a.points, docs=a.docs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
