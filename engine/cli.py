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
from .jobs import seed_argument

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


def _run_batch(args, items, label: str, work: Callable, names: Optional[Sequence[str]] = None):
    """Run ``work(item, progress)`` (or ``work(item, progress, name)`` with ``names``) for each
    item inside one error boundary each (:func:`engine.jobs.guarded`): any exception becomes a
    one-line error naming the file and its kind, printed at once, and the batch goes on.
    Ctrl-C or SIGTERM stops it; what finished is returned with ``interrupted`` set.

    Returns
    -------
    (results, failures, interrupted) : (list, list[Failure], bool)
    """
    from .jobs import guarded, stop_requested

    results, failures = [], []
    debug = getattr(args, "debug", False)

    def report(f):
        if not (f.kind == "cancelled" and stop_requested()):  # SIGTERM: said once, below
            f.print(debug)

    interrupted = False
    for i, item in enumerate(items):
        bar = ConsoleProgress(f"{label} {item}", quiet=args.quiet or args.json)
        try:
            call = (lambda: work(item, bar, names[i])) if names is not None else (lambda: work(item, bar))
            result, failure = guarded(item, call, debug=debug, on_failure=report)
        except KeyboardInterrupt:
            interrupted = True
            break
        finally:
            bar.close()
        if failure is None:
            results.append(result)
        elif not (failure.kind == "cancelled" and stop_requested()):
            failures.append(failure)
        if stop_requested():  # SIGTERM during this file: it was cancelled or finished
            interrupted = True
            break
    return results, failures, interrupted


def _batch_exit(failures, interrupted: bool) -> int:
    from .jobs import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK

    if interrupted:
        print("interrupted: the files finished before it are intact", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_FAILED if failures else EXIT_OK


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

    results, failures, interrupted = _run_batch(args, args.scans, "reading", work)
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
    _emit(args, {"files": results, "failed": [f.to_dict() for f in failures]}, lines)
    return _batch_exit(failures, interrupted)


# --------------------------------------------------------------------------- convert
def add_convert(sub) -> None:
    from .segmentation.frame import UNITS, UP_AXES

    p = sub.add_parser("convert", help="reconstruct building models from scans, write IFC and JSON",
                       description="Reconstruct each SCAN and write OUT_DIR/<name>.ifc and <name>.json; "
                                   "OUT_DIR/batch.json maps every input to its outputs and lists the "
                                   "failures. Inputs that share a name get <name>_2, <name>_3, ... "
                                   "Exit code: 0 all done, 1 some files failed, 2 usage, 130 interrupted.")
    p.add_argument("scans", nargs="+", metavar="SCAN")
    p.add_argument("-o", "--out", required=True, metavar="OUT_DIR", help="output folder")
    p.add_argument("--method", choices=("auto", "manhattan", "generic"), default="auto",
                   help="auto: Manhattan grammar when the walls are Manhattan, else cells + rjMCMC")
    p.add_argument("--seed", type=seed_argument, default=0, help="random seed >= 0 (same seed, same model)")
    p.add_argument("--units", choices=("auto", *UNITS), default="auto",
                   help="units of the scan's coordinates; auto detects mm, cm, in, ft from the extent and "
                        "the storey heights and rescales to metres (default auto)")
    p.add_argument("--up", choices=("auto", *UP_AXES), default="auto",
                   help="which axis of the scan points up; auto detects y-up and upside-down scans from "
                        "the floor and ceiling planes and rotates them (default auto)")
    p.add_argument("--no-ifc", action="store_true", help="write only the JSON model and report")
    p.set_defaults(func=cmd_convert)




def cmd_convert(args) -> int:
    from .jobs import check_output_dir, output_stems, polled, stop_requested, write_batch_record
    from .reconstruct import convert_file

    check_output_dir(args.out)  # before any work: a bad folder fails in a second, not after hours
    names = output_stems(args.scans)

    def work(path, bar, name):
        with polled():  # SIGTERM: the engine stops at its next progress check
            r = convert_file(path, args.out, method=args.method, seed=args.seed, name=name,
                             units=args.units, up=args.up, write_ifc=not args.no_ifc, progress=bar,
                             should_stop=stop_requested)
        return {"input": r.report["source"]["path"], "json": r.json_path, "ifc": r.ifc_path,
                **r.report["summary"], "method": r.model.provenance.method,
                "seconds": r.report["timings_s"]["total"]}

    results, failures, interrupted = _run_batch(args, args.scans, "converting", work, names=names)
    if results:  # a record of what was written, never a file for a run that wrote nothing
        write_batch_record(args.out, results, failures, interrupted=interrupted)
    lines = [f"{r['input']}: {r['spaces']} spaces, {r['walls']} walls, {r['doors']} doors "
             f"({r['method']}, {r['seconds']:.1f} s) -> {r['ifc'] or r['json']}" for r in results]
    if failures:
        lines.append(f"{len(failures)} of {len(args.scans)} files failed: "
                     + ", ".join(f.file for f in failures))
    _emit(args, {"converted": results, "failed": [f.to_dict() for f in failures],
                 "interrupted": interrupted}, lines)
    return _batch_exit(failures, interrupted)


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
        epilog="Exit codes: 0 all done; 1 some files failed (one line each on stderr); 2 usage; "
        "130 interrupted (Ctrl-C or SIGTERM).",
    )
    parser.add_argument("--version", action="version", version=f"indoor {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log what the engine does")
    parser.add_argument("--debug", action="store_true", help="print the traceback of any error")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="print the traceback of any error")
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
    """Run the ``indoor`` command; returns the exit code.

    0 every file done; 1 some files (or the one file) failed, each with a one-line error;
    2 usage (argparse, or an option's value); 130 interrupted by Ctrl-C or SIGTERM. Any
    exception is caught here: ``--debug`` prints its traceback.
    """
    from .errors import error_kind, error_line
    from .jobs import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_USAGE, terminate_as_interrupt

    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.debug else logging.INFO if args.verbose
                        else logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    try:
        with terminate_as_interrupt():
            return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as e:  # the outer boundary: one line, never a traceback (unless --debug)
        print(f"error: {error_line(e)}", file=sys.stderr)
        if args.debug:
            import traceback

            traceback.print_exc()
        # an option's value (an input error about no file) is a usage error
        usage = isinstance(e, IndoorError) and error_kind(e) == "input" and not getattr(e, "path", None)
        return EXIT_USAGE if usage else EXIT_FAILED


def run() -> None:
    """The console entry point (``indoor``, ``python -m engine``): :func:`main`, then exit.

    After an interrupt the process ends at once (``os._exit``) once its output is flushed:
    a native library stopped between two calls (open3d's thread pool, Embree) can crash at
    interpreter shutdown — seen as a SIGSEGV after the "interrupted" line — and every output
    is already complete or removed by then.
    """
    import os

    from .jobs import EXIT_INTERRUPTED

    code = main()
    if code == EXIT_INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        logging.shutdown()
        os._exit(code)
    raise SystemExit(code)


if __name__ == "__main__":
    run()
