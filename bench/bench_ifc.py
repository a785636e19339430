"""IFC writing and reading speed, file size and validity.

* write: the true model of each synthetic preset (plan only, no scan) → IFC4, timed; then
  ``ifcopenshell.validate`` (schema level; with EXPRESS rules on one preset) and a read back
  (:func:`engine.ifc.read_ifc`) with the footprint IoU of every space and whether the
  topology came back unchanged;
* read: the two real reference models shipped in ``tests/data`` (IFC4 FZK-Haus, IFC2X3
  Duplex), timed, with what was found (storeys, spaces, walls, doors, relations).

Times are wall-clock seconds of one run (the files are small; the first call also pays the
import of ifcopenshell, so one warm-up write is done first).
"""
from __future__ import annotations

import logging
import os
import shutil
import tempfile
import time

import numpy as np

log = logging.getLogger(__name__)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REAL_FILES = ("AC20-FZK-Haus.ifc", "Duplex_A_20110907_architecture.ifc")
QUICK_PRESETS = ("office_mw", "two_storey_office")
EXPRESS_PRESET = "office_mw"


def _iou(a, b) -> float:
    from shapely.geometry import Polygon

    pa, pb = Polygon(a), Polygon(b)
    return float(pa.intersection(pb).area / pa.union(pb).area)


def _errors(path, express_rules=False) -> int:
    import ifcopenshell.validate

    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(path, logger, express_rules=express_rules)
    return sum(1 for s in logger.statements if s.get("level") == "error")


def run(out_dir: str, quick: bool) -> dict:
    """Figures per preset (write/validate/read seconds, size, IoU, topology) and per real file."""
    from engine.ifc import read_ifc, write_ifc
    from engine.synthetic import PRESETS, build_truth, preset_plans

    tmp = tempfile.mkdtemp(prefix="bench_ifc_")
    out = {"presets": {}, "real": {}}
    try:
        presets = QUICK_PRESETS if quick else PRESETS
        warm = build_truth(preset_plans(presets[0])["truth"])
        write_ifc(warm, os.path.join(tmp, "warmup.ifc"))
        for name in presets:
            truth = build_truth(preset_plans(name)["truth"])
            path = os.path.join(tmp, f"{name}.ifc")
            t = time.perf_counter()
            write_ifc(truth, path)
            t_write = time.perf_counter() - t
            t = time.perf_counter()
            n_err = _errors(path)
            t_val = time.perf_counter() - t
            row = {"shapes": len(truth.shapes), "write_s": round(t_write, 3), "validate_s": round(t_val, 3),
                   "size_kb": round(os.path.getsize(path) / 1024, 1), "validate_errors": n_err}
            if name == EXPRESS_PRESET:
                t = time.perf_counter()
                row["express_errors"] = _errors(path, express_rules=True)
                row["validate_express_s"] = round(time.perf_counter() - t, 3)
            t = time.perf_counter()
            back = read_ifc(path)
            row["read_s"] = round(time.perf_counter() - t, 3)
            ious = [_iou(s.footprint(), back[s.id].footprint()) for s in truth.shapes
                    if s.is_space and s.footprint() is not None and back[s.id].footprint() is not None]
            row["min_space_iou"] = round(min(ious), 6) if ious else None
            row["topology_equal"] = sorted((r.kind, r.a, r.b, r.via) for r in back.relations) == \
                sorted((r.kind, r.a, r.b, r.via) for r in truth.relations)
            out["presets"][name] = row
            log.info("%s: %s", name, row)
        for fname in REAL_FILES:
            path = os.path.join(ROOT, "tests", "data", fname)
            if not os.path.exists(path):
                continue
            t = time.perf_counter()
            m = read_ifc(path)
            row = {"read_s": round(time.perf_counter() - t, 3), **m.summary(),
                   "storey_floor_z": [round(s.floor_z, 3) for s in m.storeys],
                   "prism_shapes": int(sum(s.footprint() is not None for s in m.shapes)),
                   "shapes": len(m.shapes)}
            out["real"][fname] = row
            log.info("%s: %s", fname, row)
        out["write_s_total"] = round(float(np.sum([r["write_s"] for r in out["presets"].values()])), 3)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out
