"""``indoor info SCAN...``: point count, bounds, fields, spacing and scans of scan files."""
from __future__ import annotations

from .. import io as scan_io
from .console import batch_exit, emit, run_batch

__all__ = ["add_info", "cmd_info"]


def add_info(sub) -> None:
    """Add the ``info`` subcommand to an argparse subparsers object."""
    p = sub.add_parser("info", help="point count, bounds, fields, spacing and scans of scan files")
    p.add_argument("scans", nargs="+", metavar="SCAN")
    p.set_defaults(func=cmd_info)


def cmd_info(args) -> int:
    """Run ``indoor info``; returns 0, 1 when some file failed, 130 interrupted."""

    def work(path, bar):
        cloud = scan_io.read_point_cloud(path, progress=bar)
        return cloud.summary()

    results, failures, interrupted = run_batch(args, args.scans, "reading", work)
    lines = []
    for r in results:
        lo, hi = r["bounds_min"], r["bounds_max"]
        lines += [
            f"{r['source']}:",
            f"  points        {r['points']:,}",
            f"  bounds min    {lo[0]:.3f} {lo[1]:.3f} {lo[2]:.3f}",
            f"  bounds max    {hi[0]:.3f} {hi[1]:.3f} {hi[2]:.3f}",
            f"  fields        {', '.join(r['fields'])}",
            f"  mean spacing  {r['mean_spacing_m'] * 1000:.1f} mm",
            f"  scans         {r['scans']}",
        ]
        if r.get("strays"):
            clo, chi = r["core_bounds_min"], r["core_bounds_max"]
            lines += [
                f"  core min      {clo[0]:.3f} {clo[1]:.3f} {clo[2]:.3f}",
                f"  core max      {chi[0]:.3f} {chi[1]:.3f} {chi[2]:.3f}",
                f"  strays        {r['strays']:,} points outside the core, up to "
                f"{r['stray_max_distance_m']:,.1f} m from it",
            ]
        if r["dropped_nonfinite"]:
            lines.append(f"  dropped       {r['dropped_nonfinite']:,} non-finite rows")
        lines += [f"  warning       {w}" for w in r["warnings"]]
    emit(args, {"files": results, "failed": [f.to_dict() for f in failures]}, lines)
    return batch_exit(failures, interrupted)
