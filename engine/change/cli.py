"""``indoor changes MODEL SCAN -o DIR``: change detection between a model and a newer scan.

Wire into ``engine/cli.py`` with ``add_changes(sub)``; ``cmd_changes(args)`` returns the exit
code. Bad input raises :class:`~engine.errors.IndoorError`.
"""
from __future__ import annotations

import json
import logging
import os

import numpy as np

from ..errors import FormatError, InputError

__all__ = ["add_changes", "cmd_changes", "read_matrix"]

log = logging.getLogger(__name__)


def read_matrix(path) -> np.ndarray:
    """A 4×4 float64 transform from ``.npy``, ``.json`` (nested or flat list) or text (16 numbers)."""
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
    return m


def add_changes(sub) -> None:
    """Add the ``changes`` subcommand to an argparse subparsers object."""
    p = sub.add_parser("changes", help="compare a model with a newer scan: new points, redundant surfaces",
                       description="Register SCAN to MODEL (given transform, then ICP), classify the scan "
                                   "points existing/new, measure the coverage of every room face and flag "
                                   "redundant ones; writes classified_points.ply, coverage.json, summary.json.")
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
    p.set_defaults(func=cmd_changes)


def cmd_changes(args) -> int:
    """Run ``indoor changes``; returns 0 on success."""
    from dataclasses import replace

    from ..evaluation.loading import load_model
    from ..io import read_point_cloud
    from .detect import ChangeParams, detect_changes
    from .report import write_change_outputs

    quiet = getattr(args, "quiet", False) or getattr(args, "json", False)
    params = ChangeParams()
    kw = {}
    if args.distance is not None:
        if not args.distance > 0:
            raise InputError(f"--distance must be positive, not {args.distance}")
        kw["distance_threshold"] = float(args.distance)
    if args.alpha is not None:
        if not args.alpha > 0:
            raise InputError(f"--alpha must be positive, not {args.alpha}")
        kw["alpha_radius"] = float(args.alpha)
    if args.redundant_threshold is not None:
        kw["redundant_threshold"] = float(args.redundant_threshold)
    if args.no_normals:
        kw["use_normals"] = False
    if args.no_icp:
        kw["registration"] = replace(params.registration, enabled=False)
    params = replace(params, **kw)
    initial = read_matrix(args.initial) if args.initial else None
    model = load_model(args.model)
    try:
        from ..cli import ConsoleProgress

        bar = ConsoleProgress("changes", quiet=quiet)
    except ImportError:  # pragma: no cover
        bar = None
    cloud = read_point_cloud(args.scan, progress=bar.__call__ if bar is not None else None)
    if initial is not None:
        # the given transform maps file coordinates; the cloud's offset was removed on reading
        shift = np.eye(4)
        shift[:3, 3] = cloud.offset
        initial = initial @ shift
    res = detect_changes(model, cloud, params, initial=initial, progress=bar)
    if bar is not None:
        bar.close()
    paths = write_change_outputs(res, cloud, args.out,
                                 extra={"model": os.fspath(args.model), "scan": os.fspath(args.scan)})
    s = res.summary()
    lines = [f"points: {s['points']:,} ({s['new']:,} new, {100 * s['new_share']:.1f} %)",
             f"registration residual: {s['registration']['residual_m'] * 100:.2f} cm"
             if s["registration"]["residual_m"] is not None else "registration: none",
             f"room faces: {s['surfaces']}, redundant: {len(s['redundant'])} {', '.join(s['redundant'])}",
             f"candidate new elements: {s['new_elements']} ({s['new_walls']} walls)",
             f"written to {args.out}"]
    if getattr(args, "json", False):
        print(json.dumps(dict(s, outputs=paths), indent=2))
    elif not getattr(args, "quiet", False):
        print("\n".join(lines))
    return 0
