"""``indoor synth PRESET -o DIR [--seed N] [--noise tls|mobile|SIGMA] [--points N]``.

PRESET is a preset name or a floor-plan JSON file. Writes ``DIR/<preset>.ply`` (the simulated
scan with per-point ``label``, ``scan_index`` and, for change_demo, ``new``),
``DIR/<preset>_truth.json`` and ``.ifc`` (the true model), ``DIR/<preset>_<variant>.json`` and
``.ifc`` for each variant, ``DIR/<preset>_plan.json`` (the furnished floor plan, readable back
as PRESET) and ``DIR/<preset>_top.png`` (a top view).
"""
from __future__ import annotations

import logging
import os
import time

from .. import io as scan_io
from ..errors import MissingDependencyError
from ..ifc import write_ifc
from ..jobs import seed_argument
from ..synthetic.plan import FloorPlan
from ..synthetic.presets import DEFAULT_POINTS, PRESETS, preset, scene_from_plans
from ..synthetic.render import top_view_png
from .console import ConsoleProgress, emit

__all__ = ["add_synth", "cmd_synth", "write_scene"]

log = logging.getLogger(__name__)


def add_synth(sub) -> None:
    """Add the ``synth`` subcommand to an argparse sub-parser collection."""
    p = sub.add_parser("synth", help="write a synthetic scan and its ground-truth model")
    p.add_argument("preset", metavar="PRESET",
                   help=f"one of: {', '.join(PRESETS)}; or a floor-plan JSON file (as written to "
                        "DIR/<preset>_plan.json)")
    p.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--seed", type=seed_argument, default=0, help="random seed (default 0)")
    p.add_argument("--noise", default="tls",
                   help="tls (σ = 5 mm), mobile (walk through the doors, σ = 2 cm) or a σ in metres")
    p.add_argument("--points", type=int, default=DEFAULT_POINTS,
                   help=f"about how many points to simulate (default {DEFAULT_POINTS:,})")
    p.add_argument("--no-clutter", action="store_true", help="leave the rooms empty")
    p.add_argument("--no-surroundings", action="store_true",
                   help="nothing outside the building (no ground, trees or facade seen through the windows)")
    p.add_argument("--no-png", action="store_true", help="skip the top-view picture")
    p.add_argument("--no-ifc", action="store_true", help="skip the IFC files of the true model and variants")
    p.set_defaults(func=cmd_synth)


def write_scene(scene, out_dir, *, png: bool = True, ifc: bool = True) -> dict:
    """Write a :class:`SyntheticScene`'s files into ``out_dir``; return their paths and timings.

    Files: ``<name>.ply`` (scan), ``<name>_truth.json`` (+ ``.ifc``), ``<name>_<variant>.json``
    (+ ``.ifc``) and ``<name>_top.png``. The IFC files are skipped, with a warning, when
    ifcopenshell is missing.
    """
    os.makedirs(out_dir, exist_ok=True)
    name = scene.name
    files = {}
    t0 = time.perf_counter()
    files["scan"] = os.path.join(out_dir, f"{name}.ply")
    scan_io.write_ply(files["scan"], scene.cloud)
    t_ply = time.perf_counter() - t0
    files["truth"] = os.path.join(out_dir, f"{name}_truth.json")
    scene.truth.to_json(files["truth"])
    files["plan"] = os.path.join(out_dir, f"{name}_plan.json")
    scene.plan.to_json(files["plan"])
    for k, m in scene.variants.items():
        files[k] = os.path.join(out_dir, f"{name}_{k}.json")
        m.to_json(files[k])
    t_ifc = 0.0
    if ifc:
        t0 = time.perf_counter()
        try:
            files["truth_ifc"] = write_ifc(scene.truth, os.path.join(out_dir, f"{name}_truth.ifc"))
            for k, m in scene.variants.items():
                files[f"{k}_ifc"] = write_ifc(m, os.path.join(out_dir, f"{name}_{k}.ifc"))
        except (ImportError, MissingDependencyError) as e:
            log.warning("IFC files skipped: %s", e)
        t_ifc = time.perf_counter() - t0
    t_png = 0.0
    if png:
        t0 = time.perf_counter()
        files["top"] = os.path.join(out_dir, f"{name}_top.png")
        top_view_png(files["top"], scene.cloud, scene.truth,
                     title=f"{name} (seed {scene.seed}, σ = {scene.noise_sigma * 1000:.0f} mm, "
                           f"{len(scene.cloud):,} points)")
        t_png = time.perf_counter() - t0
    return {"files": files, "write_ply_s": t_ply, "ifc_s": t_ifc, "png_s": t_png}


def cmd_synth(args) -> int:
    """Run ``indoor synth``; returns the exit code."""
    bar = ConsoleProgress(f"synth {args.preset}", quiet=getattr(args, "quiet", False) or getattr(args, "json", False))
    t0 = time.perf_counter()
    try:
        kw = dict(seed=args.seed, noise=args.noise, target_points=args.points, clutter=not args.no_clutter,
                  surroundings=not args.no_surroundings, progress=bar)
        if args.preset.lower().endswith(".json"):
            plan = FloorPlan.from_json(args.preset)
            name = os.path.splitext(os.path.basename(args.preset))[0]  # file names follow the file
            if name.endswith("_plan"):
                name = name[: -len("_plan")]
            scene = scene_from_plans({"truth": plan}, name=name, **kw)
        else:
            scene = preset(args.preset, **kw)
    finally:
        bar.close()
    t_sim = time.perf_counter() - t0
    written = write_scene(scene, args.out, png=not args.no_png, ifc=not args.no_ifc)
    total = time.perf_counter() - t0
    payload = {
        "preset": scene.name,
        "seed": scene.seed,
        "noise_sigma_m": scene.noise_sigma,
        "points": len(scene.cloud),
        "scans": int(scene.cloud.scan_count),
        "truth": scene.truth.summary(),
        "variants": sorted(scene.variants),
        "files": written["files"],
        "seconds": {"simulate": round(t_sim, 3), "write_ply": round(written["write_ply_s"], 3),
                    "ifc": round(written["ifc_s"], 3), "png": round(written["png_s"], 3),
                    "total": round(total, 3)},
    }
    lines = [f"{scene.name}: {len(scene.cloud):,} points from {scene.cloud.scan_count} scanner positions "
             f"(σ = {scene.noise_sigma * 1000:.0f} mm) in {total:.1f} s"]
    lines += [f"  {k:8s} {v}" for k, v in written["files"].items()]
    emit(args, payload, lines)
    return 0
