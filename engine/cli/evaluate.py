"""``indoor evaluate SOURCE REFERENCE -o DIR``: quality of a model against a reference.

``cmd_evaluate(args)`` returns the exit code. Bad input raises
:class:`~engine.errors.IndoorError` (the CLI prints it on one line).
"""
from __future__ import annotations

import json
import os

import numpy as np

from .. import io as scan_io
from ..errors import InputError
from ..evaluation.loading import load_model
from ..evaluation.metrics import DEFAULT_BUFFERS, EvaluationParams, evaluate
from ..evaluation.elements import evaluate_elements
from ..evaluation.report import write_evaluation_outputs
from ..evaluation.visibility import VisibilityParams, annotate_visibility
from .console import ConsoleProgress

__all__ = ["add_evaluate", "cmd_evaluate"]


def _floats(text: str) -> tuple:
    try:
        return tuple(float(x) for x in text.replace(";", ",").split(",") if x.strip())
    except ValueError:
        raise InputError(f"expected comma-separated numbers, not {text!r}") from None


def add_evaluate(sub) -> None:
    """Add the ``evaluate`` subcommand to an argparse subparsers object."""
    p = sub.add_parser("evaluate", help="completeness, correctness and accuracy of a model against a reference",
                       description="Compare a SOURCE model with a REFERENCE model (BuildingModel .json, .ifc, "
                                   ".obj/.ply meshes): curves over buffer sizes as JSON, CSV and PNG, and "
                                   "coloured PLY files of missing/redundant surfaces.")
    p.add_argument("source", metavar="SOURCE", help="the model under test")
    p.add_argument("reference", metavar="REFERENCE", help="the ground truth")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--surfaces", default="interior",
                   help="shape types compared, comma-separated: interior (room faces, default), wall, slab")
    p.add_argument("--groups", default="wall,floor,ceiling", help="surface kinds evaluated (default all three)")
    p.add_argument("--buffers", default=None,
                   help="buffer sizes b = cut-offs r in metres, comma-separated (default 0.01..0.10)")
    p.add_argument("--max-angle", type=float, default=10.0, help="θ in degrees (default 10)")
    p.add_argument("--unoriented", action="store_true", help="ignore face orientation (meshes with mixed normals)")
    p.add_argument("--scan", default=None, metavar="SCAN",
                   help="a scan of the reference: only surfaces it covers (point-on-face index) are compared")
    p.set_defaults(func=cmd_evaluate)


def cmd_evaluate(args) -> int:
    """Run ``indoor evaluate``; returns 0 on success."""
    quiet = getattr(args, "quiet", False) or getattr(args, "json", False)
    bar = ConsoleProgress("evaluate", quiet=quiet)
    types = tuple(t.strip().lower() for t in args.surfaces.split(",") if t.strip())
    groups = tuple(g.strip().lower() for g in args.groups.split(",") if g.strip())
    bad = [g for g in groups if g not in ("wall", "floor", "ceiling")]
    if bad:
        raise InputError(f"unknown surface group(s) {bad}; use wall, floor, ceiling")
    try:
        params = EvaluationParams(buffers=_floats(args.buffers) if args.buffers else DEFAULT_BUFFERS,
                                  max_angle=float(np.radians(args.max_angle)), oriented=not args.unoriented,
                                  surface_types=types, groups=groups)
    except ValueError as e:
        raise InputError(str(e)) from None
    source = load_model(args.source)
    reference = load_model(args.reference)
    visible = None
    if args.scan:
        cloud = scan_io.read_point_cloud(args.scan)
        ann = annotate_visibility(reference, cloud, VisibilityParams(surface_types=types))
        visible = {k: v["visible"] for k, v in ann.items()}
    res = evaluate(source, reference, params, visible=visible, progress=bar)
    bar.close()
    title = f"{os.path.basename(args.source)} vs {os.path.basename(args.reference)}"
    elements = evaluate_elements(source, reference)
    paths = write_evaluation_outputs(res, args.out, title=title, elements=elements,
                                     extra={"source": os.fspath(args.source), "reference": os.fspath(args.reference)})
    c = res.curves["all"]
    payload = {"outputs": paths, "buffers_m": res.buffers.tolist(),
               "completeness": [None if not np.isfinite(x) else float(x) for x in c["completeness"]],
               "correctness": [None if not np.isfinite(x) else float(x) for x in c["correctness"]],
               "accuracy_m": [None if not np.isfinite(x) else float(x) for x in c["accuracy"]],
               "missing": res.missing, "redundant": res.redundant, "elements": elements}
    lines = [f"{'b (cm)':>7} {'compl.':>7} {'corr.':>7} {'acc. (cm)':>9}"]
    for i, b in enumerate(res.buffers):
        acc = c["accuracy"][i]
        lines.append(f"{b * 100:7.1f} {c['completeness'][i]:7.3f} {c['correctness'][i]:7.3f} "
                     f"{(acc * 100 if np.isfinite(acc) else float('nan')):9.2f}")
    lines.append(f"missing reference surfaces: {len(res.missing)}; redundant source surfaces: {len(res.redundant)}")
    lines.extend(_element_lines(elements))
    lines.append(f"written to {args.out}")
    if getattr(args, "json", False):
        print(json.dumps(payload, indent=2))
    elif not getattr(args, "quiet", False):
        print("\n".join(lines))
    return 0


def _element_lines(e: dict) -> list:
    """Doors, windows, rooms, walls and the connectivity graph in a few lines."""
    def pr(d):
        f = (lambda x: "–" if x is None else f"{x:.2f}")
        return f"{d['matched']}/{d['true']} found ({d['found']} in the model), precision {f(d['precision'])}, " \
               f"recall {f(d['recall'])}"
    c = e["connectivity"]
    return [f"doors: {pr(e['doors'])}", f"windows: {pr(e['windows'])}",
            f"rooms: {e['spaces']['model']} (reference {e['spaces']['truth']}); walls: {e['walls']['model']} "
            f"(reference runs {e['walls']['truth_runs']}); door graph {'equal' if c['equal'] else 'differs'}"]
