"""The ``indoor`` command line.

One module per subcommand (``info``, ``convert``, ``evaluate``, ``changes``, ``synth``,
``segment``, ``params``), each with an ``add_<name>(sub)`` parser builder and a
``cmd_<name>(args)`` that returns the exit code; :mod:`engine.cli.console` holds the
progress bar and output helpers they share. Errors the engine raises on purpose
(:class:`~engine.errors.IndoorError`) become one line on stderr naming the file and the
problem; a batch goes on with the other files and reports which failed.
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import traceback
from typing import Optional, Sequence

from .. import __version__
from ..errors import IndoorError, error_kind, error_line
from ..jobs import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_USAGE, terminate_as_interrupt
from .console import UsageError

__all__ = ["main", "run", "build_parser", "COMMANDS"]

COMMANDS = {
    "info": "point count, bounds, fields, spacing and scans of scan files",
    "convert": "reconstruct building models from scans, write IFC and JSON",
    "evaluate": "completeness, correctness and accuracy of a model against a reference",
    "changes": "compare a model with a newer scan: new points, redundant surfaces",
    "synth": "write a synthetic scan and its ground-truth model",
    "segment": "preprocess scans: align, storeys, planes and the cells",
    "params": "list every reconstruction parameter (value, unit, meaning) or write the TOML parameter file",
}
"""Subcommand → its one-line help, in the order ``--help`` lists them. Each lives in the module
``engine.cli.<name>`` (``add_<name>``, ``cmd_<name>``), imported only when it runs: ``indoor
--help`` imports none of them, ``indoor info`` only its own (the reconstruction, IFC and
evaluation libraries cost seconds to import)."""


def _command_of(argv: Sequence[str]) -> Optional[str]:
    """The subcommand named in ``argv`` (its first word that is not an option), or None."""
    for a in argv:
        if not a.startswith("-"):
            return a if a in COMMANDS else None
    return None


def build_parser(argv: Optional[Sequence[str]] = None) -> argparse.ArgumentParser:
    """The ``indoor`` parser; every subcommand also gets ``--debug``, ``--quiet`` and ``--json``.

    ``argv`` given: only the subcommand it names gets its whole parser (the others are listed
    with their help, enough for ``--help`` and for argparse's "invalid choice"); None: all
    of them."""
    import importlib

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
    wanted = set(COMMANDS) if argv is None else {_command_of(argv)}
    for name, text in COMMANDS.items():
        if name in wanted:
            getattr(importlib.import_module(f"{__name__}.{name}"), f"add_{name}")(sub)
        else:
            orig(name, help=text, add_help=False)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the ``indoor`` command; returns the exit code.

    0 every file done; 1 some files (or the one file) failed, each with a one-line error;
    2 usage (argparse, an option's value, a bad parameter file or key); 130 interrupted by
    Ctrl-C or SIGTERM. Any exception is caught here: ``--debug`` prints its traceback.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
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
            traceback.print_exc()
        # an option's value (an input error about no file) or a parameter file is a usage error
        usage = isinstance(e, UsageError) or (
            isinstance(e, IndoorError) and error_kind(e) == "input" and not getattr(e, "path", None))
        return EXIT_USAGE if usage else EXIT_FAILED


def run() -> None:
    """The console entry point (``indoor``, ``python -m engine``): :func:`main`, then exit.

    After an interrupt the process ends at once (``os._exit``) once its output is flushed:
    a native library stopped between two calls (open3d's thread pool, Embree) can crash at
    interpreter shutdown — seen as a SIGSEGV after the "interrupted" line — and every output
    is already complete or removed by then.
    """
    code = main()
    if code == EXIT_INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        logging.shutdown()
        os._exit(code)
    raise SystemExit(code)
