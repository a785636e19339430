"""Building elements of ``reconstruct(cloud, "auto")`` scored against the truth.

For each scene (presets office_mw, two_storey_office, three_storey_house, syn_house; TLS and
mobile; seeds 0, 1, 2; 300k points — quick: office_mw, TLS, seed 0, 100k points; plus the IFC
scenes fzk_haus and duplex of :mod:`engine.synthetic.ifcscene` when that module imports and
the run is not quick): reconstruct, then :func:`engine.evaluation.evaluate_elements` — doors
and windows (true / found / matched, P, R, F1, width errors), exterior-boundary coverage by
external and by any walls, floor and ceiling slabs per storey, rooms (model spaces / true
rooms / matched, open plans merged on both sides; the raw space count in brackets when it
differs), walls vs true wall runs, the door graph — and the
reconstruction time. The bench only reports what the model holds. Rooms,
exterior walls and slabs are scored over the true spaces the scan reaches
(:func:`engine.evaluation.rooms.scanned_spaces`: an IFC roof level no scanner enters is left
out).

A row "truth" per scene scores the truth against itself (what the truth allows: an IFC
truth can lack a slab or have outline stretches with no wall).
Writes ``elements_table.md`` (one compact markdown row per scene / noise / seed) and
``elements_runs.json`` (every figure) into the out folder; ``python -m bench`` also writes
``elements.json``. Standalone: ``python -m bench.bench_elements --out DIR [--scenes ...]
[--noise tls mobile] [--seeds 0 1 2] [--points N] [--no-ifc] [--positions yes|no|both] [--quick]``
(``hexagon_hall`` and any other preset may be named in ``--scenes``).
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import sys
import time
import traceback

from engine.fileutil import atomic_write_text

log = logging.getLogger(__name__)

SCENES = ("office_mw", "two_storey_office", "three_storey_house", "syn_house")
IFC_SCENES = ("fzk_haus", "duplex")
NOISES = ("tls", "mobile")
SEEDS = (0, 1, 2)
POINTS, QUICK_POINTS = 300_000, 100_000

COLUMNS = ("scene", "noise", "seed", "pts", "rec s", "doors T/F/M", "door P/R/F1", "dW cm mean/max",
           "win T/F/M", "win F1", "ext cov ext/any", "slabs F/C", "rooms M/T/=", "walls m/runs",
           "graph =/−/+", "wW cm mean/max")


def _scene(name: str, seed: int, noise: str, points: int):
    if name in IFC_SCENES:
        from engine.synthetic.ifcscene import ifc_scene

        return ifc_scene(name, seed=seed, noise=noise, target_points=points)
    from engine.synthetic import preset

    return preset(name, seed=seed, noise=noise, target_points=points)


def one(name: str, noise: str, seed: int, points: int, truths: dict = None, positions: bool = True) -> dict:
    """Scene → reconstruct (auto) → element scores; the error text instead when a step fails.
    ``truths`` (optional) collects the scene's truth under its name. ``positions`` False: the
    scan is reconstructed from its points alone (no scanner positions, no scan of each point,
    as a merged export), the truth scored against as before."""
    row = {"scene": name, "noise": noise, "seed": int(seed), "positions": bool(positions)}
    try:
        from engine.evaluation import evaluate_elements
        from engine.evaluation.rooms import scanned_spaces
        from engine.reconstruct import reconstruct

        t0 = time.perf_counter()
        sc = _scene(name, seed, noise, points)
        row["scene_s"] = round(time.perf_counter() - t0, 2)
        row["points"] = int(sc.cloud.n)
        if truths is not None:
            truths.setdefault(name, sc.truth)
        t0 = time.perf_counter()
        cloud = sc.cloud if positions else sc.cloud.with_(scanner_positions=None, scan_index=None)
        model = reconstruct(cloud, "auto", rng=seed)
        row["reconstruct_s"] = round(time.perf_counter() - t0, 2)
        row["method"] = model.provenance.method
        t0 = time.perf_counter()
        row["elements"] = evaluate_elements(model, sc.truth, seen=scanned_spaces(sc.truth, sc.cloud.xyz))
        row["evaluate_s"] = round(time.perf_counter() - t0, 3)
        row["elements"].pop("params", None)
    except Exception as e:  # one broken scene must not hide the others' rows
        row["error"] = f"{type(e).__name__}: {e}"
        log.error("%s %s seed %d failed:\n%s", name, noise, seed, traceback.format_exc())
    return row


def baseline(name: str, truth) -> dict:
    """The truth scored against itself: the best figures the truth allows (below 1 where the
    truth itself lacks something, e.g. an IFC roof storey without a slab above)."""
    from engine.evaluation import evaluate_elements

    e = evaluate_elements(truth, truth)
    e.pop("params", None)
    return {"scene": name, "noise": "truth", "seed": "–", "elements": e}


def _f(v, digits=2, scale=1.0) -> str:
    return "–" if v is None else f"{v * scale:.{digits}f}"


def table_row(r: dict) -> str:
    """One markdown row of :data:`COLUMNS` for a result of :func:`one`."""
    head = [r["scene"], r["noise"], str(r["seed"]) + ("" if r.get("positions", True) else " (no positions)")]
    if "error" in r:
        return "| " + " | ".join(head + [f"error: {r['error'][:80]}"] + [""] * (len(COLUMNS) - 4)) + " |"
    e = r["elements"]
    d, w, ex, sl, sp, wa, c = (e[k] for k in ("doors", "windows", "exterior", "slabs", "spaces", "walls",
                                               "connectivity"))
    cells = head + [
        f"{r['points'] // 1000}k" if "points" in r else "–",
        f"{r['reconstruct_s']:.1f}" if "reconstruct_s" in r else "–",
        f"{d['true']}/{d['found']}/{d['matched']}",
        f"{_f(d['precision'])}/{_f(d['recall'])}/{_f(d['f1'])}",
        f"{_f(d['width_error_mean'], 1, 100)}/{_f(d['width_error_max'], 1, 100)}",
        f"{w['true']}/{w['found']}/{w['matched']}", _f(w["f1"]),
        f"{_f(ex['external_share'])}/{_f(ex['any_share'])}",
        f"{sl['floor_found']}/{sl['ceiling_found']} of {sl['storeys']}",
        f"{sp['model_rooms']}/{sp['truth']}/{sp['matched']}"
        + ("" if sp["model_rooms"] == sp["model"] else f" ({sp['model']} spaces)"),
        f"{wa['model']}/{wa['truth_runs']}",
        f"{'yes' if c['equal'] else 'no'}/{len(c['missing'])}/{len(c['extra'])}",
        f"{_f(w['width_error_mean'], 1, 100)}/{_f(w['width_error_max'], 1, 100)}",
    ]
    return "| " + " | ".join(cells) + " |"


def table(rows: list) -> str:
    """The markdown table of the results of :func:`one`."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    return "\n".join(lines + [table_row(r) for r in rows]) + "\n"


def _ifc_available() -> bool:
    try:
        from engine.synthetic import ifcscene  # noqa: F401  (being written alongside)

        return hasattr(ifcscene, "ifc_scene")
    except Exception:  # any import failure (module missing, ifcopenshell missing): skip
        return False


def bench(out_dir: str, scenes, noises, seeds, points: int, positions=(True,)) -> dict:
    rows, truths = [], {}
    for name in scenes:
        for noise in noises:
            for seed in seeds:
                for pos in positions:
                    r = one(name, noise, seed, points, truths, pos)
                    rows.append(r)
                    print(table_row(r), flush=True)
        if name in truths:
            rows.append(baseline(name, truths[name]))
            print(table_row(rows[-1]), flush=True)
    os.makedirs(out_dir, exist_ok=True)
    md = table(rows)
    atomic_write_text(os.path.join(out_dir, "elements_table.md"), md)
    atomic_write_text(os.path.join(out_dir, "elements_runs.json"), json.dumps(rows, indent=1) + "\n")
    ok = [r for r in rows if "error" not in r and r["noise"] != "truth"]
    f1 = [r["elements"]["doors"]["f1"] for r in ok if r["elements"]["doors"]["f1"] is not None]
    failed = sum(1 for r in rows if "error" in r)
    return {"runs": rows, "table": md, "failed": failed,
            "door_f1_mean": round(sum(f1) / len(f1), 4) if f1 else None,
            "graph_equal": sum(1 for r in ok if r["elements"]["connectivity"]["equal"]),
            "reconstruct_s_total": round(sum(r["reconstruct_s"] for r in ok), 2)}


def run(out_dir: str, quick: bool = False) -> dict:
    """``python -m bench`` entry: the quick or the full grid (IFC scenes when importable)."""
    if quick:
        return bench(out_dir, ("office_mw",), ("tls",), (0,), QUICK_POINTS)
    scenes = SCENES + (IFC_SCENES if _ifc_available() else ())
    return bench(out_dir, scenes, NOISES, SEEDS, POINTS)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m bench.bench_elements", description=__doc__.splitlines()[0])
    p.add_argument("--out", default=os.path.join("out", "bench"))
    p.add_argument("--scenes", nargs="+", default=None, help=f"default {' '.join(SCENES)} (+ IFC scenes)")
    p.add_argument("--noise", nargs="+", default=list(NOISES), choices=NOISES)
    p.add_argument("--seeds", nargs="+", type=int, default=list(SEEDS))
    p.add_argument("--points", type=int, default=POINTS)
    p.add_argument("--no-ifc", action="store_true", help="leave out the IFC scenes")
    p.add_argument("--quick", action="store_true", help="office_mw, tls, seed 0, 100k points")
    p.add_argument("--positions", choices=("yes", "no", "both"), default="yes",
                   help="reconstruct with the scanner positions, without (a merged export), or both")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    if a.quick:
        res = run(a.out, True)
    else:
        ifc = () if a.no_ifc or not _ifc_available() else IFC_SCENES
        scenes = tuple(a.scenes) if a.scenes else SCENES + ifc
        pos = {"yes": (True,), "no": (False,), "both": (True, False)}[a.positions]
        res = bench(a.out, scenes, a.noise, a.seeds, a.points, pos)
    atomic_write_text(os.path.join(a.out, "elements.json"),
                      json.dumps({"benchmark": "elements", "results": res}, indent=1) + "\n")
    print()
    print(res["table"])
    return 1 if res["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
