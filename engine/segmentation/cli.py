"""``indoor segment SCAN... -o DIR [--seed N] [--voxel M] [--no-manhattan]``.

Runs :func:`engine.segmentation.preprocess` on each scan and writes
``DIR/<stem>_segmented.ply`` (the aligned working cloud with normals and the per-point
fields ``segment_class`` — 0 wall, 1 floor/ceiling, 2 other — and ``plane``, -1 for none)
and ``DIR/<stem>_segmentation.json`` (storeys, the aligned → input transform, the
alignment figures, every plane, and the cell complex: cells with footprint and z range,
shared faces with their wall plane and coverage, timings). Both files are written
atomically.
"""
from __future__ import annotations

import json
import logging
import math
import os


__all__ = ["add_segment", "cmd_segment", "segmentation_report"]

from ..jobs import seed_argument

log = logging.getLogger(__name__)


def add_segment(sub) -> None:
    """Add the ``segment`` subcommand to an argparse sub-parser collection."""
    p = sub.add_parser("segment", help="preprocess scans: align, storeys, planes and the cell complex")
    p.add_argument("scans", nargs="+", metavar="SCAN", help="point-cloud files")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--seed", type=seed_argument, default=0, help="random seed (default 0)")
    p.add_argument("--voxel", type=float, default=None, metavar="M",
                   help="voxel of the working cloud in metres (default 0.03, enlarged for big clouds)")
    p.add_argument("--no-manhattan", action="store_true",
                   help="only level the cloud (no rotation about z): for non-Manhattan buildings")
    p.set_defaults(func=cmd_segment)


def segmentation_report(res) -> dict:
    """A JSON-ready dict of a :class:`~engine.segmentation.Preprocessed`."""
    cells = res.cells
    out = {
        "points": int(len(res.cloud)),
        "working_points": int(len(res.working)),
        "transform_aligned_to_input": res.transform.tolist(),
        "alignment": {"yaw_deg": math.degrees(res.alignment.yaw),
                      "tilt_deg": math.degrees(res.alignment.tilt),
                      "wall_fraction": res.alignment.wall_fraction,
                      "manhattan_fraction": res.alignment.manhattan_fraction},
        "storeys": [s.to_dict() for s in res.storeys],
        "planes": [p.to_dict() for p in res.planes],
        "timings_s": {k: float(v) for k, v in res.timings.items()},
    }
    if cells is not None:
        out["cells"] = {
            "summary": cells.summary(),
            "cells": [{"id": c.id, "storey": c.storey, "face": c.face, "layer": c.layer,
                       "polygon": c.polygon.tolist(), "z0": c.z0, "z1": c.z1, "area": c.area,
                       "top_coverage": c.top_coverage, "bottom_coverage": c.bottom_coverage}
                      for c in cells.cells],
            "faces": [{"a": f.a, "b": f.b, "kind": f.kind, "segments": f.segments.tolist(),
                       "z0": f.z0, "z1": f.z1, "length": f.length, "wall_plane": f.wall_plane,
                       "coverage": f.coverage} for f in cells.faces],
        }
    return out


def _plain(o):
    """JSON fallback for numpy scalars and arrays."""
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"{type(o).__name__} is not JSON serializable")


def cmd_segment(args) -> int:
    from dataclasses import replace

    from ..cli import ConsoleProgress
    from ..fileutil import atomic_write_text
    from ..io import read_point_cloud, write_ply
    from .params import PreprocessParams
    from .pipeline import preprocess

    params = PreprocessParams(align_manhattan=not args.no_manhattan)
    if args.voxel is not None:
        params = replace(params, clean=replace(params.clean, voxel_size=float(args.voxel)))
    from ..jobs import check_output_dir, guarded, output_stems

    check_output_dir(args.out)
    done, failed = [], []

    def report(f):
        f.print(getattr(args, "debug", False))

    def work(path, stem, bar):
        cloud = read_point_cloud(path)
        res = preprocess(cloud, params, rng=args.seed, progress=bar)
        os.makedirs(args.out, exist_ok=True)
        ply = os.path.join(args.out, f"{stem}_segmented.ply")
        js = os.path.join(args.out, f"{stem}_segmentation.json")
        write_ply(ply, res.working)
        rep = segmentation_report(res)
        rep["source"] = path
        atomic_write_text(js, json.dumps(rep, indent=1, default=_plain))
        return {"file": path, "ply": ply, "json": js, "storeys": len(res.storeys),
                "planes": len(res.planes), "cells": len(res.cells.cells) if res.cells else 0}

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
