"""Console output shared by the subcommands: the progress bar, text-or-JSON results, the
per-file error boundary of a batch and its exit code.

Subcommand modules import these from here, never from :mod:`engine.cli` itself.
"""
from __future__ import annotations

import json
import sys
import time
from typing import Callable, Optional, Sequence

import numpy as np

from ..errors import InputError
from ..jobs import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, guarded, stop_requested
from ..progress import eta_text

__all__ = ["ConsoleProgress", "UsageError", "emit", "run_batch", "batch_exit", "plain"]


class UsageError(InputError):
    """A bad command-line value that names a file or a key (a parameter file, a ``--set``):
    exit code 2 like any other usage error, on one line."""


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
        self.stream.write(f"\r{self.label[:30]:30s} [{bar}] {100 * fraction:5.1f}% {el:6.1f}s "
                          f"{eta_text(el, fraction):>10s} {message[:30]:30s}")
        if fraction >= 1.0:
            self.stream.write("\n")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self._last < 1.0 and self._last >= 0:
            self.stream.write("\n")
            self.stream.flush()


def emit(args, payload, text_lines: Sequence[str]) -> None:
    """Print ``payload`` as JSON with ``--json``, else ``text_lines`` unless ``--quiet``."""
    if getattr(args, "json", False):
        print(json.dumps(payload, indent=2))
    elif not getattr(args, "quiet", False):
        for line in text_lines:
            print(line)


def plain(o):
    """``json.dumps`` fallback: numpy scalars and arrays as Python numbers and lists."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"{type(o).__name__} is not JSON serializable")


def run_batch(args, items, label: str, work: Callable, names: Optional[Sequence[str]] = None):
    """Run ``work(item, progress)`` (or ``work(item, progress, name)`` with ``names``) for each
    item inside one error boundary each (:func:`engine.jobs.guarded`): any exception becomes a
    one-line error naming the file and its kind, printed at once, and the batch goes on.
    Ctrl-C or SIGTERM stops it; what finished is returned with ``interrupted`` set.

    Returns
    -------
    (results, failures, interrupted) : (list, list[Failure], bool)
    """
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


def batch_exit(failures, interrupted: bool) -> int:
    """The exit code of a batch: 130 interrupted, 1 some failed, else 0."""
    if interrupted:
        print("interrupted: the files finished before it are intact", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_FAILED if failures else EXIT_OK
