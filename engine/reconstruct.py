"""Scan file → building model → IFC and a JSON report: the one entry point the CLI, the
Blender operators and the batch script share.

``reconstruct`` picks the method (``auto``: the Manhattan grammar when the wall normals
are Manhattan enough, else cells + rjMCMC), ``model_report`` gives the JSON-ready facts
(spaces, walls, doors, topology, parameters, timings) and ``convert_file`` does the whole
job for one scan with atomic outputs.
"""
from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .model import BuildingModel
from .pointcloud import PointCloud
from .progress import Progress

__all__ = ["METHODS", "choose_method", "reconstruct", "model_report", "convert_file", "ConvertResult"]

log = logging.getLogger(__name__)

METHODS = ("auto", "manhattan", "generic")


def choose_method(cloud: PointCloud, *, rng=0) -> tuple[str, float]:
    """Pick ``"manhattan"`` or ``"generic"`` for ``--method auto``.

    The score is :func:`engine.grammar.generic.manhattan_score`: the share of the RANSAC
    wall-plane area within 3° of two perpendicular horizontal directions (planes, not
    per-point normals, which scatter by several degrees on a 2 cm mobile scan). Manhattan
    when it reaches ``GenericParams.manhattan_threshold`` (0.85).

    Returns
    -------
    (method, score) : (str, float in [0, 1])
    """
    from .grammar.generic import choose_method as _choose

    return _choose(cloud, rng=rng)


def reconstruct(cloud: PointCloud, method: str = "auto", *, params=None, rng=0, progress=None,
                should_stop=None) -> BuildingModel:
    """Reconstruct a building model from a scan.

    Parameters
    ----------
    cloud : PointCloud — metres, z roughly up.
    method : "auto", "manhattan" (shape grammar, SPEC.md §2) or "generic" (cells +
        rjMCMC, SPEC.md §3).
    params : ManhattanParams / GenericParams for the chosen method, or None (defaults
        chosen from the data).
    rng : seed or Generator; same seed, same model.
    progress, should_stop : see :class:`engine.progress.Progress`.

    Returns
    -------
    BuildingModel; ``provenance.parameters["method_choice"]`` records how auto chose.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, not {method!r}")
    p = Progress.wrap(progress, should_stop)
    choice = {}
    if method == "auto":
        p(0.0, "choosing method")
        method, score = choose_method(cloud, rng=rng)
        p(0.1, f"method: {method}")
        choice = {"method_choice": "auto", "manhattan_score": round(score, 4)}
    if method == "manhattan":
        from .grammar import reconstruct_manhattan as run
    else:
        from .grammar.generic import reconstruct_generic as run
    model = run(cloud, params, rng=rng, progress=p.sub(0.1 if choice else 0.0, 1.0))
    if choice:
        prov = model.provenance
        model = model.with_(provenance=prov.__class__(
            prov.method, {**prov.parameters, **choice}, prov.seed, prov.timings, prov.trace,
            prov.source, prov.software))
    return model


def _space_facts(model: BuildingModel, s) -> dict:
    fp = s.footprint()
    area = None
    if fp is not None:
        x, y = fp[:, 0], fp[:, 1]
        area = float(abs(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)) / 2)
    lo, hi = s.bounds
    return {
        "id": s.id, "name": s.name, "storey": s.storey,
        "floor_area_m2": None if area is None else round(area, 3),
        "height_m": round(float(hi[2] - lo[2]), 3),
        "volume_m3": round(s.geometry.volume(), 3),
        "bounds_min": [round(float(v), 3) for v in lo], "bounds_max": [round(float(v), 3) for v in hi],
        "parts": [c for c in s.children if c in model and model[c].type == s.type],
        "support": dict(s.support),
    }


def model_report(model: BuildingModel) -> dict:
    """JSON-ready facts about a model: counts, spaces, walls, doors, topology, provenance."""
    spaces = [_space_facts(model, s) for s in model.spaces]
    walls = [{"id": w.id, "name": w.name, "storey": w.storey,
              "thickness_m": w.attributes.get("thickness"), "support": dict(w.support)} for w in model.walls]
    doors = [{"id": d.id, "wall": d.parent, **{k: d.attributes.get(k) for k in ("width", "height")}}
             for d in model.doors]
    edges = {kind: [[r.a, r.b, r.via] for r in model.relations_of(kind)]
             for kind in ("adjacency", "connectivity")}
    return {
        "summary": model.summary(),
        "storeys": [s.to_dict() for s in model.storeys],
        "spaces": spaces,
        "walls": walls,
        "doors": doors,
        "topology": edges,
        "provenance": model.provenance.to_dict(),
    }


@dataclass(frozen=True)
class ConvertResult:
    """What ``convert_file`` wrote: paths and the report."""

    source: str
    model: BuildingModel
    report: dict
    json_path: str
    ifc_path: Optional[str]


def convert_file(path: str | os.PathLike, out_dir: str | os.PathLike, *, method: str = "auto",
                 seed: int = 0, write_ifc: bool = True, params=None, progress=None,
                 should_stop=None) -> ConvertResult:
    """Read one scan, reconstruct, write ``<name>.json`` (model + report) and ``<name>.ifc``.

    Both outputs are written to temporary names and moved into place, so a failure leaves
    no half-written file. ``<name>.json`` is the model's JSON (readable with
    :meth:`BuildingModel.from_json`) with an extra ``report`` key.
    """
    from .io import read_point_cloud

    p = Progress.wrap(progress, should_stop)
    t0 = time.perf_counter()
    cloud = read_point_cloud(path, progress=p.sub(0.0, 0.1))
    t_read = time.perf_counter() - t0
    model = reconstruct(cloud, method, params=params, rng=seed, progress=p.sub(0.1, 0.9))
    name = os.path.splitext(os.path.basename(os.fspath(path)))[0]
    model = model.with_(name=model.name or name)
    report = model_report(model)
    report["source"] = {"path": os.fspath(path), "points": len(cloud), "read_s": round(t_read, 3)}
    os.makedirs(out_dir, exist_ok=True)
    ifc_path = None
    if write_ifc:
        from .ifc import write_ifc as _write_ifc

        p(0.92, "writing IFC")
        ifc_path = os.path.join(out_dir, name + ".ifc")
        _write_ifc(model, ifc_path)
    report["timings_s"] = {"read": round(t_read, 3), "total": round(time.perf_counter() - t0, 3)}
    import json

    from .fileutil import atomic_write_text

    data = model.to_dict()
    data["report"] = report
    json_path = os.path.join(out_dir, name + ".json")
    atomic_write_text(json_path, json.dumps(data))
    p(1.0, "done")
    return ConvertResult(os.fspath(path), model, report, json_path, ifc_path)
