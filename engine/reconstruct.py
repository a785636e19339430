"""Scan file → building model → IFC and a JSON report: the one entry point the CLI, the
Blender operators and the batch script share.

``reconstruct`` preprocesses once (:mod:`engine.pipeline`), picks the method (``auto``: the
Manhattan grammar when the wall planes are Manhattan enough, else cells + rjMCMC) and runs
it; ``model_report`` gives the JSON-ready facts
(spaces, walls, doors, topology, parameters, timings) and ``convert_file`` does the whole
job for one scan with atomic outputs.
"""
from __future__ import annotations

import contextlib
import copy
import json
import logging
import os
import time
from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from .elements.build import building_elements
from .errors import InputError, ReconstructionError, printable
from .fileutil import atomic_write_text
from .grammar.generic import generic_model
from .grammar.manhattan import manhattan_model
from .ifc import IfcWriteParams
from .ifc import write_ifc as _write_ifc
from .ifc.common import preload_writer_modules
from .io import read_point_cloud
from .jobs import check_output_dir
from .model import BuildingModel
from .params import Params
from .pipeline import cap_points, choose_method, cleaned_clouds, plausible_scanners, preprocess
from .segmentation.cleaning import drop_nonfinite
from .pointcloud import PointCloud
from .progress import Progress
from .segmentation.frame import check_degenerate, normalize_frame
from .geometry.boxes import column_max, column_min

__all__ = ["METHODS", "reconstruct", "model_report", "convert_file", "ConvertResult"]

log = logging.getLogger(__name__)

METHODS = ("auto", "manhattan", "generic")


def reconstruct(cloud: PointCloud, method: str = "auto", *, params=None, rng=0, progress=None,
                should_stop=None, check: bool = True) -> BuildingModel:
    """Reconstruct a building model from a scan: preprocess once, choose, run the method.

    Parameters
    ----------
    cloud : PointCloud — metres, z roughly up.
    method : "auto", "manhattan" (shape grammar, docs/method.md §2) or "generic" (cells +
        rjMCMC, §3). ``auto`` picks Manhattan when the wall planes found by preprocessing
        are Manhattan enough (:func:`engine.pipeline.choose_method`).
    params : Params, or one stage's parameters (ManhattanParams, GenericParams,
        PreprocessParams), or None for the defaults.
    rng : seed or Generator; same seed, same model.
    progress, should_stop : see :class:`engine.progress.Progress`.
    check : bool
        Run :func:`~engine.segmentation.frame.check_degenerate` first; False when the caller
        already did (``normalize_frame`` runs the same checks).

    Returns
    -------
    BuildingModel; with ``auto``, ``provenance.parameters`` records ``method_choice`` and
    ``manhattan_score``.

    Raises
    ------
    ReconstructionError
        A degenerate cloud, data that give no storey or wall, or a result without any space.
    """
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, not {method!r}")
    params = Params.coerce(params)
    if check:
        check_degenerate(cloud)  # flat, a line, identical points, noise: fail in a second
    p = Progress.wrap(progress, should_stop)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    p(0.0, "preprocessing")
    t0 = time.perf_counter()
    cloud, capped = cap_points(cloud, params.preprocess.clean)  # a 10M-point scan costs what 2M cost
    t_cap = time.perf_counter() - t0
    pp = params.preprocess
    cleaned = cleaned_clouds(cloud, pp)
    # auto chooses from the wall planes on the Manhattan grammar's normals (the full cloud's,
    # which the working cloud shares) drawn from a copy of the Generator: choosing Manhattan
    # then costs no normals of its own and gives what --method manhattan gives; the generic
    # method finds its normals and planes anew, as --method generic does
    prep = preprocess(cloud, pp, rng=copy.deepcopy(gen) if method == "auto" else gen,
                      planes=method != "manhattan", full_normals=method != "generic",
                      progress=p.sub(0.0, 0.3 if method == "auto" else 0.4), cleaned=cleaned,
                      plane_kinds=("wall",) if method == "auto" else ("wall", "horizontal"))
    choice = {}
    if method == "auto":
        method, score = choose_method(prep, params.choice)
        p(0.3, f"method: {method}")
        choice = {"method_choice": "auto", "manhattan_score": round(score, 4)}
        if method == "generic":
            spent = sum(v for k, v in prep.timings.items() if k not in cleaned.timings)
            prep = preprocess(cloud, pp, rng=gen, progress=p.sub(0.3, 0.4), cleaned=cleaned)
            prep = replace(prep, timings={**prep.timings, "method_choice": spent})
    if prep.cleaning.get("scanner_positions_dropped"):  # the elements read the input cloud's too
        cloud, _ = plausible_scanners(cloud, pp.clean.scanner_margin,
                                      (column_min(prep.cloud.xyz), column_max(prep.cloud.xyz)))
    if method == "manhattan":
        model = manhattan_model(prep, params.manhattan, rng=gen, progress=p.sub(0.4, 1.0))
    else:
        model = generic_model(prep, params.generic, rng=gen, progress=p.sub(0.4, 1.0))
    if not model.spaces:
        ev = model.provenance.trace.get("evidence") or {}
        stage = (f"the evidence rule rejected all {ev['spaces_before']} spaces as too narrow, small or low"
                 if ev.get("spaces_before") else "the scan shows no closed room (floor, ceiling and walls around it)")
        raise ReconstructionError(f"no space found ({model.provenance.method} method): {stage}",
                                  cloud.source or None)
    p(0.97, "walls, slabs and openings")
    model = building_elements(model, drop_nonfinite(cloud), params.elements)  # points beyond windows too
    prov = model.provenance
    seed = int(rng) if isinstance(rng, (int, np.integer)) else prov.seed
    timings, trace = dict(prov.timings), dict(prov.trace)
    if capped:
        timings = {"thin": t_cap, **timings}
        trace["cleaning"] = {**trace.get("cleaning", {}), "thinned": capped}
    return model.with_(provenance=prov.__class__(
        prov.method, {**prov.parameters, **choice}, seed, timings, trace,
        prov.source, prov.software))


def _space_facts(model: BuildingModel, s) -> dict:
    area, _ = s.geometry.plan_area_perimeter()
    lo, hi = s.bounds
    return {
        "id": s.id, "name": s.name, "storey": s.storey,
        "floor_area_m2": round(area, 3),
        "height_m": round(float(hi[2] - lo[2]), 3),
        "volume_m3": round(s.geometry.volume(), 3),
        "bounds_min": [round(float(v), 3) for v in lo], "bounds_max": [round(float(v), 3) for v in hi],
        "parts": [c for c in s.children if c in model and model[c].type == s.type],
        "support": dict(s.support),
    }


def _r(v, nd=3):
    return None if v is None else round(float(v), nd)


def _opening_facts(o) -> dict:
    a = o.attributes
    c = o.centroid
    return {"id": o.id, "name": o.name, "kind": a.get("kind", o.type.value), "storey": o.storey,
            "wall": o.parent, "spaces": list(a.get("spaces", [])),
            "width_m": _r(a.get("width")), "height_m": _r(a.get("height")), "sill_m": _r(a.get("sill")),
            "open": a.get("open"), "confidence": _r(a.get("confidence")),
            "centre": [round(float(v), 3) for v in c], "support": dict(o.support)}


def model_report(model: BuildingModel) -> dict:
    """JSON-ready facts about a model: counts, spaces, walls, openings, slabs, topology,
    provenance."""
    spaces = [_space_facts(model, s) for s in model.spaces]
    walls = [{"id": w.id, "name": w.name, "storey": w.storey, "external": w.attributes.get("external"),
              "thickness_m": _r(w.attributes.get("thickness")), "length_m": _r(_axis_length(w)),
              "thickness_measured": w.attributes.get("thickness_measured"),
              "sides": w.attributes.get("sides"), "openings": list(w.children), "support": dict(w.support)}
             for w in model.walls]
    slabs = [{"id": s.id, "name": s.name, "storey": s.storey, "kind": s.attributes.get("kind"),
              "thickness_m": _r(s.attributes.get("thickness")),
              "area_m2": _r(s.geometry.plan_area_perimeter()[0])} for s in model.slabs]
    edges = {kind: [[r.a, r.b, r.via] for r in model.relations_of(kind)]
             for kind in ("adjacency", "connectivity")}
    return {
        "summary": model.summary(),
        "storeys": [s.to_dict() for s in model.storeys],
        "spaces": spaces,
        "walls": walls,
        "doors": [_opening_facts(d) for d in model.doors],
        "windows": [_opening_facts(w) for w in model.windows],
        "slabs": slabs,
        "topology": edges,
        "provenance": model.provenance.to_dict(),
    }


def _axis_length(w) -> Optional[float]:
    ax = w.attributes.get("axis_line")
    if ax is None:
        return float(np.sort(w.scope.size[:2])[1])
    return float(np.linalg.norm(np.subtract(ax[1], ax[0])))


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
                 should_stop=None, name: Optional[str] = None, units: str = "auto",
                 up: str = "auto", ifc_parts: bool = False) -> ConvertResult:
    """Read one scan, reconstruct, write ``<name>.json`` (model + report) and ``<name>.ifc``.

    The output folder is checked first (:func:`engine.jobs.check_output_dir`), so a folder
    that cannot be written fails before any work. The scan is then checked for degenerate
    geometry and brought to metres with z up (``units``, ``up``: ``"auto"`` detects them,
    see :func:`engine.segmentation.frame.normalize_frame`); what was done is recorded in
    ``provenance.parameters["frame"]``. Both outputs are written to temporary names and
    moved into place, and the IFC is removed again when the JSON cannot be written, so a
    failure leaves no half-written result. ``<name>.json`` is the model's JSON (readable
    with :meth:`BuildingModel.from_json`) with an extra ``report`` key.

    Parameters
    ----------
    ifc_parts : bool
        Also write the parts of merged spaces as ``PARTIAL`` IfcSpace (default: one IfcSpace
        per room; the JSON always has every part).
    name : str, optional
        Output file stem; default the scan's stem (a batch passes distinct names, see
        :func:`engine.jobs.output_stems`).

    Raises
    ------
    InputError, ReconstructionError, OutputError
        See :mod:`engine.errors`; a model without any space is a ReconstructionError.
    """
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise InputError(f"the seed must be a whole number >= 0, not {seed!r}")
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, not {method!r}")
    check_output_dir(out_dir)
    p = Progress.wrap(progress, should_stop)
    if write_ifc:
        preload_writer_modules()  # ifcopenshell loads while the scan is reconstructed
    t0 = time.perf_counter()
    cloud = read_point_cloud(path, progress=p.sub(0.0, 0.1))
    t_read = time.perf_counter() - t0
    t1 = time.perf_counter()
    cloud, frame = normalize_frame(cloud, units=units, up=up)  # checks the cloud as well
    t_frame = time.perf_counter() - t1
    t1 = time.perf_counter()
    model = reconstruct(cloud, method, params=params, rng=seed, progress=p.sub(0.1, 0.9), check=False)
    t_rec = time.perf_counter() - t1
    t1 = time.perf_counter()
    name = name or os.path.splitext(os.path.basename(os.fspath(path)))[0]
    prov = model.provenance
    model = model.with_(name=model.name or name, provenance=prov.__class__(
        prov.method, {**prov.parameters, "frame": frame}, prov.seed, prov.timings, prov.trace,
        prov.source, prov.software))
    report = model_report(model)
    report["source"] = {"path": printable(path), "points": len(cloud), "read_s": round(t_read, 3),
                        "frame": frame, "warnings": list(cloud.warnings)}
    os.makedirs(out_dir, exist_ok=True)
    t_report = time.perf_counter() - t1
    ifc_path = written = None
    t_ifc = 0.0
    json_path = os.path.join(out_dir, name + ".json")
    try:  # the pair is written whole or not at all (an interrupt between the two included)
        if write_ifc:
            p(0.92, "writing IFC")
            ifc_path = os.path.join(out_dir, name + ".ifc")
            t1 = time.perf_counter()
            _write_ifc(model, ifc_path, params=IfcWriteParams(parts=ifc_parts))
            t_ifc = time.perf_counter() - t1
            written = ifc_path
        report["timings_s"] = {"read": round(t_read, 3), "frame": round(t_frame, 3),
                               "reconstruct": round(t_rec, 3), "report": round(t_report, 3),
                               "ifc": round(t_ifc, 3), "total": round(time.perf_counter() - t0, 3)}
        data = model.to_dict()
        data["report"] = report
        atomic_write_text(json_path, json.dumps(data))
    except BaseException:
        if written is not None:
            with contextlib.suppress(OSError):
                os.remove(written)
        raise
    p(1.0, "done")
    return ConvertResult(os.fspath(path), model, report, json_path, ifc_path)
