"""``indoor changes MODEL SCAN -o DIR``: change detection between a model and a newer scan.

``cmd_changes(args)`` returns the exit code: 0, or 1 when the scan could not be registered to
the model (the outputs are written all the same, marked "unregistered" and claiming no change
unless ``--force``). Bad input raises :class:`~engine.errors.IndoorError`.
"""
from __future__ import annotations

import json
import math
import os
import sys
from dataclasses import replace

import numpy as np

from .. import io as scan_io
from ..change.detect import ChangeParams, detect_changes
from ..change.report import write_change_outputs
from ..errors import FormatError, InputError
from ..evaluation.loading import load_model
from .console import ConsoleProgress

__all__ = ["add_changes", "cmd_changes", "read_matrix"]


RIGID_TOLERANCE = 1e-3
"""Largest |RᵀR − I| entry of the rotation part of a transform read by :func:`read_matrix`."""


def read_matrix(path) -> np.ndarray:
    """A rigid 4×4 float64 transform (rotation and translation) from ``.npy``, ``.json``
    (nested or flat list, or ``{"transform": ...}``) or text (16 numbers).

    Raises
    ------
    InputError
        The file does not exist.
    FormatError
        Not 16 finite numbers, or not a rigid transform (scale, shear, mirror, a bottom row
        other than 0 0 0 1): ICP and the point normals need a rigid one.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError("file not found", path)
    try:
        if path.lower().endswith(".npy"):
            m = np.load(path)
        elif path.lower().endswith(".json"):
            with open(path, encoding="utf-8") as f:
                d = json.load(f)
            m = np.asarray(d.get("transform", d) if isinstance(d, dict) else d, dtype=np.float64)
        else:
            m = np.loadtxt(path, dtype=np.float64)
        m = np.asarray(m, dtype=np.float64).reshape(4, 4)
    except (ValueError, OSError, json.JSONDecodeError) as e:
        raise FormatError(f"not a 4x4 transform: {e}", path) from None
    if not np.isfinite(m).all():
        raise FormatError("the transform has non-finite entries", path)
    if np.abs(m[3] - [0.0, 0.0, 0.0, 1.0]).max() > 1e-9:
        raise FormatError(f"the transform's last row must be 0 0 0 1, not {' '.join(f'{v:g}' for v in m[3])}",
                          path)
    r = m[:3, :3]
    if np.abs(r.T @ r - np.eye(3)).max() > RIGID_TOLERANCE or np.linalg.det(r) < 0:
        raise FormatError("the transform is not rigid (its 3x3 part has scale, shear or a mirror); give a "
                          "rotation and a translation", path)
    return m


def add_changes(sub) -> None:
    """Add the ``changes`` subcommand to an argparse subparsers object."""
    p = sub.add_parser("changes", help="compare a model with a newer scan: new points, redundant surfaces",
                       description="Register SCAN to MODEL (given transform, then ICP), classify the scan "
                                   "points existing/new, measure the coverage of every room face and flag "
                                   "redundant ones, give each wall, slab, door and window a status "
                                   "(installed, incomplete, not installed, no data) and fit new walls; "
                                   "writes classified_points.ply, coverage.json, elements.json, "
                                   "summary.json, changes.ifc (and changes.bcf) when something changed, "
                                   "as_built.ifc with --update. Exit code 1 when the scan does not fit the model "
                                   "(registration failed).")
    p.add_argument("model", metavar="MODEL", help="the (old) model: .json, .ifc, .obj/.ply mesh")
    p.add_argument("scan", metavar="SCAN", help="the (new) scan")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--distance", type=float, default=None,
                   help="r in metres: points this close to a model surface exist "
                        "(default: automatic from the registration residual, at least 0.05)")
    p.add_argument("--alpha", type=float, default=None, help="alpha-shape radius in metres (default 0.2)")
    p.add_argument("--redundant-threshold", type=float, default=None,
                   help="faces with coverage at most this are redundant (default 0.25)")
    p.add_argument("--initial", default=None, metavar="FILE",
                   help="coarse scan→model 4x4 transform (.npy, .json or text)")
    p.add_argument("--no-icp", action="store_true", help="use the initial transform as is")
    p.add_argument("--no-normals", action="store_true", help="classify by distance and boundary only")
    p.add_argument("--update", action="store_true",
                   help="also write as_built.ifc: the model as built (removed walls dropped, new walls added, "
                        "spaces re-derived)")
    p.add_argument("--force", action="store_true",
                   help="report new points and redundant faces even when the registration failed "
                        "(the summary still says unregistered)")
    p.set_defaults(func=cmd_changes)


def _number(value, flag: str, *, low: float, high: float = math.inf, low_open: bool = True,
            high_open: bool = False) -> float:
    """``value`` as a float inside the given range, else an InputError naming ``flag``."""
    v = float(value)
    ok = math.isfinite(v) and (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    if not ok:
        lo = f"{'>' if low_open else '>='} {low:g}"
        hi = "" if math.isinf(high) else f" and {'<' if high_open else '<='} {high:g}"
        raise InputError(f"{flag} must be a number {lo}{hi}, not {value:g}")
    return v


def _failure(reg: dict) -> str:
    """What failed in an unregistered result: "fitness 0.02 < 0.50 (...)", and the walls'."""
    fit, wall, d = reg["fitness"] or 0.0, reg["wall_fitness"], reg["fitness_distance_m"]
    within = f"within {d * 100:.0f} cm of the model" if d is not None else "on the model"
    low_fit = reg["min_fitness"] is not None and fit < reg["min_fitness"]
    low_wall = wall is not None and reg["min_wall_fitness"] is not None and wall < reg["min_wall_fitness"]
    parts = [f"fitness {fit:.2f} < {reg['min_fitness']:.2f} (share of scan points {within})" if low_fit
             else f"fitness {fit:.2f} (share of scan points {within})"]
    if low_wall:
        parts.append(f"wall fitness {wall:.2f} < {reg['min_wall_fitness']:.2f} (the same on walls)")
    return ", ".join(parts)


def _registration_line(reg: dict) -> str:
    fit, d, rmse = reg["fitness"], reg["fitness_distance_m"], reg["rmse_m"]
    within = f"within {d * 100:.0f} cm of the model" if d is not None else "on the model"
    if reg["status"] != "registered":
        return f"registration FAILED: {_failure(reg)}"
    parts = [f"registration: fitness {fit:.2f} ({within})"]
    if reg["residual_m"] is not None:
        parts.append(f"residual {reg['residual_m'] * 100:.2f} cm")
    if rmse is not None:
        parts.append(f"rmse {rmse * 100:.2f} cm")
    if reg["start"] != "initial":
        parts.append(f"coarse start from the {reg['start']}")
    return ", ".join(parts)


def cmd_changes(args) -> int:
    """Run ``indoor changes``; returns 0 on success, 1 when the scan is unregistered."""
    quiet = getattr(args, "quiet", False) or getattr(args, "json", False)
    force = bool(getattr(args, "force", False))
    params = ChangeParams()
    kw = {"force": force}
    if args.distance is not None:
        kw["distance_threshold"] = _number(args.distance, "--distance", low=0.0)
    if args.alpha is not None:
        kw["alpha_radius"] = _number(args.alpha, "--alpha", low=0.0)
    if args.redundant_threshold is not None:
        kw["redundant_threshold"] = _number(args.redundant_threshold, "--redundant-threshold", low=0.0,
                                            low_open=False, high=1.0, high_open=True)
    if args.no_normals:
        kw["use_normals"] = False
    if args.no_icp:
        kw["registration"] = replace(params.registration, enabled=False)
    params = replace(params, **kw)
    initial = read_matrix(args.initial) if args.initial else None
    model = load_model(args.model)
    bar = ConsoleProgress("changes", quiet=quiet)
    cloud = scan_io.read_point_cloud(args.scan, progress=bar)
    if initial is not None:
        # the given transform maps file coordinates; the cloud's offset was removed on reading
        shift = np.eye(4)
        shift[:3, 3] = cloud.offset
        initial = initial @ shift
    try:
        res = detect_changes(model, cloud, params, initial=initial, progress=bar)
    finally:
        bar.close()
    paths = write_change_outputs(res, cloud, args.out, model=model, update=bool(getattr(args, "update", False)),
                                 extra={"model": os.fspath(args.model), "scan": os.fspath(args.scan)})
    s = res.summary()
    reg = s["registration"]
    if res.classified:
        lines = [f"points: {s['points']:,} ({s['new']:,} new, {100 * s['new_share']:.1f} %)",
                 _registration_line(reg),
                 f"room faces: {s['surfaces']}, redundant: {len(s['redundant'])} {', '.join(s['redundant'])}",
                 f"candidate new elements: {s['new_elements']} ({s['new_walls']} walls)",
                 "elements: " + ", ".join(f"{v} {k}" for k, v in s["element_status"].items()),
                 f"new walls fitted: {len(res.new_walls)}, doors in them: {len(res.new_openings)}"]
        gone = [e for e in res.element_status if e["status"] == "not installed" and e["type"] == "wall"]
        if gone:
            lines.append("not installed: " + ", ".join(f"{e['ifc_class']} {e['name'] or e['id']} ({e['global_id']})"
                                                       for e in gone))
        if not res.registered:
            lines.append("--force: changes reported although the registration failed; they may be artefacts "
                         "of the misregistration")
    else:
        lines = [f"points: {s['points']:,} (not classified: the scan is not registered to the model)",
                 _registration_line(reg),
                 f"room faces: {s['surfaces']}, redundant: none claimed",
                 "candidate new elements: none claimed"]
    lines.append(f"written to {args.out}")
    if getattr(args, "json", False):
        print(json.dumps(dict(s, outputs=paths), indent=2))
    elif not getattr(args, "quiet", False):
        print("\n".join(lines))
    if res.registered or force:
        return 0
    print(f"error: {os.fspath(args.scan)}: the scan could not be registered to {os.fspath(args.model)}: "
          f"{_failure(reg)}; no change is claimed in {args.out}. Give a coarse scan-to-model transform "
          "with --initial FILE (4x4), or use --force to report changes anyway", file=sys.stderr)
    return 1
