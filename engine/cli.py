"""The ``indoor`` command line.

Subcommands live in this module as ``cmd_<name>`` functions with an ``add_<name>`` parser
builder; each returns an exit code. Errors the engine raises on purpose
(:class:`~engine.errors.IndoorError`) become one line on stderr naming the file and the
problem; a batch goes on with the other files and reports which failed.
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from typing import Callable, Optional, Sequence

from . import __version__
from .errors import IndoorError

__all__ = ["main", "ConsoleProgress"]

log = logging.getLogger(__name__)


class ConsoleProgress:
    """A one-line progress bar on stderr (silent when ``quiet`` or stderr is not a tty)."""

    def __init__(self, label: str, quiet: bool = False, stream=None):
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = not quiet and hasattr(self.stream, "isatty") and self.stream.isatty()
        self._last = -1.0
        self._t0 = time.perf_counter()

    def __call__(self, fraction: float, message: str = "") -> None:
        if not self.enabled:
            return
        if fraction < 1.0 and fraction - self._last < 0.01:
            return
        self._last = fraction
        width = 30
        done = int(round(width * fraction))
        bar = "#" * done + "-" * (width - done)
        el = time.perf_counter() - self._t0
        self.stream.write(f"\r{self.label[:30]:30s} [{bar}] {100 * fraction:5.1f}% {el:6.1f}s {message[:30]:30s}")
        if fraction >= 1.0:
            self.stream.write("\n")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self._last < 1.0 and self._last >= 0:
            self.stream.write("\n")
            self.stream.flush()


def _emit(args, payload, text_lines: Sequence[str]) -> None:
    if getattr(args, "json", False):
        print(json.dumps(payload, indent=2))
    elif not getattr(args, "quiet", False):
        for line in text_lines:
            print(line)


def _run_batch(args, items, label: str, work: Callable):
    """Run ``work(item, progress)`` for each item; collect results and failures."""
    results, failures = [], []
    for item in items:
        bar = ConsoleProgress(f"{label} {item}", quiet=args.quiet or args.json)
        try:
            results.append(work(item, bar))
        except IndoorError as e:
            msg = str(e) if str(item) in str(e) else f"{item}: {e}"  # always name the file
            failures.append({"file": str(item), "error": msg})
            print(f"error: {msg}", file=sys.stderr)
        finally:
            bar.close()
    return results, failures


# --------------------------------------------------------------------------- info
def add_info(sub) -> None:
    p = sub.add_parser("info", help="point count, bounds, fields, spacing and scans of scan files")
    p.add_argument("scans", nargs="+", metavar="SCAN")
    p.set_defaults(func=cmd_info)


def cmd_info(args) -> int:
    from .io import read_point_cloud

    def work(path, bar):
        cloud = read_point_cloud(path, progress=bar)
        return cloud.summary()

    results, failures = _run_batch(args, args.scans, "reading", work)
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
        if r["dropped_nonfinite"]:
            lines.append(f"  dropped       {r['dropped_nonfinite']:,} non-finite rows")
        lines += [f"  warning       {w}" for w in r["warnings"]]
    _emit(args, {"files": results, "failed": failures}, lines)
    return 1 if failures else 0


# --------------------------------------------------------------------------- convert
def add_convert(sub) -> None:
    p = sub.add_parser("convert", help="reconstruct building models from scans, write IFC and JSON")
    p.add_argument("scans", nargs="+", metavar="SCAN")
    p.add_argument("-o", "--out", required=True, metavar="OUT_DIR", help="output folder")
    p.add_argument("--method", choices=("auto", "manhattan", "generic"), default="auto",
                   help="auto: Manhattan grammar when the walls are Manhattan, else cells + rjMCMC")
    p.add_argument("--seed", type=int, default=0, help="random seed (same seed, same model)")
    p.add_argument("--no-ifc", action="store_true", help="write only the JSON model and report")
    p.set_defaults(func=cmd_convert)


def cmd_convert(args) -> int:
    from .reconstruct import convert_file

    def work(path, bar):
        r = convert_file(path, args.out, method=args.method, seed=args.seed,
                         write_ifc=not args.no_ifc, progress=bar)
        return {"source": str(path), "json": r.json_path, "ifc": r.ifc_path, **r.report["summary"],
                "method": r.model.provenance.method, "seconds": r.report["timings_s"]["total"]}

    results, failures = _run_batch(args, args.scans, "converting", work)
    lines = [f"{r['source']}: {r['spaces']} spaces, {r['walls']} walls, {r['doors']} doors "
             f"({r['method']}, {r['seconds']:.1f} s) -> {r['ifc'] or r['json']}" for r in results]
    if failures:
        lines.append(f"{len(failures)} of {len(args.scans)} files failed: "
                     + ", ".join(f["file"] for f in failures))
    _emit(args, {"converted": results, "failed": failures}, lines)
    return 1 if failures else 0


# --------------------------------------------------------------------------- main
def _commands():
    """Parser builders, one per subcommand, in the order ``--help`` lists them."""
    from .change.cli import add_changes
    from .evaluation.cli import add_evaluate
    from .segmentation.cli import add_segment
    from .synthetic.cli import add_synth

    return [add_info, add_convert, add_evaluate, add_changes, add_synth, add_segment]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="indoor",
        description="Turn indoor laser scans into building models (IFC), evaluate models "
        "against references and detect changes.",
    )
    parser.add_argument("--version", action="version", version=f"indoor {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log what the engine does")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--quiet", action="store_true", help="no progress bar, no text output")
    common.add_argument("--json", action="store_true", help="print the result as JSON")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    orig = sub.add_parser

    def add_parser(name, **kw):  # every subcommand gets --quiet and --json
        kw.setdefault("parents", []).append(common)
        return orig(name, **kw)

    sub.add_parser = add_parser
    for add in _commands():
        add(sub)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.func(args) or 0)
    except IndoorError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
