"""``indoor segment SCAN... -o DIR [--seed N] [--voxel M] [--params FILE] [--set KEY=VALUE]``.

Runs the preprocessing stage every reconstruction method uses
(:func:`engine.pipeline.preprocess`, then :func:`engine.pipeline.align` for the alignment
figures) and the cells of the generic method
(:func:`engine.grammar.generic.storey_cells`) on each scan, and writes
``DIR/<stem>_segmented.ply`` (the working cloud, in the input frame, with normals and the
per-point fields ``segment_class`` — 0 wall, 1 floor/ceiling, 2 other — and ``plane``, -1 for
none) and ``DIR/<stem>_segmentation.json`` (storeys, the aligned → input transform, the
alignment figures, every plane, the cells of each storey with footprint and z range in metres,
timings in seconds). Both files are written atomically.
"""
from __future__ import annotations

import json
import math
import os

import numpy as np

from .. import io as scan_io, pipeline
from ..fileutil import atomic_write_text
from ..grammar import generic
from ..jobs import check_output_dir, guarded, output_stems, seed_argument
from .console import ConsoleProgress, plain
from .params import add_params_options, params_from_args

__all__ = ["add_segment", "cmd_segment", "segmentation_report", "VOXEL_KEY"]

VOXEL_KEY = "preprocess.clean.voxel_size"
"""The parameter ``--voxel`` sets: the edge of the working cloud's voxel, metres."""


def add_segment(sub) -> None:
    """Add the ``segment`` subcommand to an argparse sub-parser collection."""
    p = sub.add_parser("segment", help="preprocess scans: align, storeys, planes and the cells")
    p.add_argument("scans", nargs="+", metavar="SCAN", help="point-cloud files")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--seed", type=seed_argument, default=0, help="random seed (default 0)")
    p.add_argument("--voxel", type=float, default=None, metavar="M",
                   help=f"voxel of the working cloud in metres (sets {VOXEL_KEY}, after --set)")
    add_params_options(p)
    p.set_defaults(func=cmd_segment)


def _cell_dicts(cells) -> list:
    """One dict per cell of a CellSet: open footprint ring (x, y) in metres, z range, area m²."""
    out = []
    for poly, (z0, z1) in zip(cells.polygons, np.asarray(cells.z_range, dtype=np.float64).reshape(-1, 2)):
        ring = np.asarray(poly.exterior.coords, dtype=np.float64)[:-1, :2]
        out.append({"polygon": ring.tolist(), "z0": float(z0), "z1": float(z1), "area": float(poly.area)})
    return out


def segmentation_report(prep, storey_cells=None) -> dict:
    """A JSON-ready dict of a :class:`~engine.pipeline.Prepared` and, when given, the cells of
    each storey (the list :func:`engine.grammar.generic.storey_cells` returns)."""
    out = {
        "points": int(len(prep.cloud)),
        "working_points": int(len(prep.working)),
        "transform_aligned_to_input": np.asarray(prep.transform).tolist(),
        "alignment": {"yaw_deg": math.degrees(prep.alignment.yaw),
                      "tilt_deg": math.degrees(prep.alignment.tilt),
                      "wall_fraction": prep.alignment.wall_fraction,
                      "manhattan_fraction": prep.alignment.manhattan_fraction},
        "storeys": [s.to_dict() for s in prep.storeys],
        "planes": [p.to_dict() for p in prep.planes],
        "timings_s": {k: float(v) for k, v in prep.timings.items()},
    }
    if storey_cells is not None:
        out["cells"] = [{"storey": sc.storey.index, "cells": _cell_dicts(sc.cells)} for sc in storey_cells]
    return out


def cmd_segment(args) -> int:
    """Run ``indoor segment``; returns 0, or 1 when some file failed."""
    params = params_from_args(args, [f"{VOXEL_KEY}={args.voxel!r}"] if args.voxel is not None else ())
    check_output_dir(args.out)
    done, failed = [], []

    def report(f):
        f.print(getattr(args, "debug", False))

    def work(path, stem, bar):
        cloud = scan_io.read_point_cloud(path)
        prep = pipeline.preprocess(cloud, params.preprocess, rng=args.seed, progress=bar)
        prep = pipeline.align(prep, rng=args.seed)
        cells = generic.storey_cells(prep, params.generic)
        os.makedirs(args.out, exist_ok=True)
        ply = os.path.join(args.out, f"{stem}_segmented.ply")
        js = os.path.join(args.out, f"{stem}_segmentation.json")
        scan_io.write_ply(ply, prep.working)
        rep = segmentation_report(prep, cells)
        rep["source"] = path
        atomic_write_text(js, json.dumps(rep, indent=1, default=plain))
        return {"file": path, "ply": ply, "json": js, "storeys": len(prep.storeys),
                "planes": len(prep.planes), "cells": sum(len(sc.cells.polygons) for sc in cells)}

    for path, stem in zip(args.scans, output_stems(args.scans)):
        bar = ConsoleProgress(f"segment {os.path.basename(path)}", quiet=args.quiet or args.json)
        try:
            result, failure = guarded(path, lambda: work(path, stem, bar),
                                      debug=getattr(args, "debug", False), on_failure=report)
        finally:
            bar.close()
        if failure is None:
            done.append(result)
        else:
            failed.append(failure.to_dict())
    if args.json:
        print(json.dumps({"segmented": done, "failed": failed}, indent=2))
    elif not args.quiet:
        for d in done:
            print(f"{d['file']}: {d['storeys']} storey(s), {d['planes']} planes, {d['cells']} cells -> {d['json']}")
    return 1 if failed else 0
